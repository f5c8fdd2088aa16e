"""The one light measurement every fin set of a design or a study gets, and the standard
devices it is compared with (the ``devices`` stage).

:func:`measure_fins` measures torsal's fins and every standard device alike: the same seeded
sample points on A, the same sun directions and weights, the same view rays and occupant eye
points. :func:`run_devices` makes the standard devices of the design's fin depth and spacing
on the oriented surface (:func:`torsal.light.devices.standard_devices`: a device that cannot
be made there is reported not applicable with its reason, never measured as 0 %).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .design_file import DesignSpec
from .stage import StageInputs

__all__ = ["measure_fins", "run_devices", "design_devices", "devices_key", "view_clear_key", "VIEW_KEYS",
           "light_summary", "devices_summary", "SunGoals", "sun_goals", "goal_suns",
           "sample_faces", "SAMPLE_SEED"]

#: the report key of each view measure (``view.measure`` in the design file)
VIEW_KEYS = {"occupant": "view_out", "normal": "transparency"}


def view_clear_key(spec: DesignSpec) -> str:
    """The ``light`` report key of the design's chosen view measure."""
    return VIEW_KEYS[spec.view.measure.value]


def _finite(x) -> float | None:
    import math

    return float(x) if x is not None and math.isfinite(x) else None


@dataclass(frozen=True)
class SunGoals:
    """Where a design asks the sun for something else than being blocked.

    Attributes
    ----------
    let_through : (r,) int or None
        Faces of A where the sun should come through (``goals.let_through``, Fig. 9).
    regions : list of ((r,) int, (k, 3) float)
        Faces of A with their own sun directions to block (``goals.sun_regions``, Fig. 7d),
        site -> sun, unit.
    """

    let_through: np.ndarray | None = None
    regions: tuple = ()

    def __bool__(self) -> bool:
        return self.let_through is not None or bool(self.regions)


def sun_goals(spec: DesignSpec, vertices, faces) -> SunGoals:
    """The design's :class:`SunGoals` on mesh A (``goals.let_through``, ``goals.sun_regions``)."""
    from .regions import select_faces

    g = spec.goals
    let_through = None if g.let_through is None else select_faces(g.let_through, vertices, faces)
    regions = tuple((select_faces(r.region, vertices, faces),
                     np.asarray(r.vectors, float) / np.linalg.norm(r.vectors, axis=1, keepdims=True))
                    for r in g.sun_regions)
    return SunGoals(let_through, regions)


def goal_suns(goals: SunGoals, vertices, faces, sun: dict) -> tuple[np.ndarray, np.ndarray]:
    """One set of sun directions and weights standing for what the goals ask everywhere: the
    design's sun weighted by the share of A's area outside the sun regions, and each region's
    directions by its area share (each region's directions share the design sun's total
    weight equally). What a device that cannot differ per region is oriented for."""
    vec, w = np.asarray(sun["vectors"], float), np.asarray(sun["weights"], float)
    if not goals.regions:
        return vec, w
    v, f = np.asarray(vertices, float), np.asarray(faces, np.int64)
    area = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    total, rest = area.sum(), np.ones(len(f), bool)
    vecs, weights = [], []
    for faces_r, vec_r in goals.regions:
        rest[faces_r] = False
        vecs.append(vec_r)
        weights.append(np.full(len(vec_r), area[faces_r].sum() / total * w.sum() / len(vec_r)))
    vecs.append(vec)
    weights.append(w * area[rest].sum() / total)
    return np.concatenate(vecs), np.concatenate(weights)


#: the seed of the sun's sample points on A (:func:`torsal.light.direct_sun_blocked`'s
#: ``seed``): every fin set of a design is measured at the same points
SAMPLE_SEED = 0


def sample_faces(surface, points: np.ndarray, samples) -> np.ndarray:
    """The face of mesh A each sample point of :func:`measure_fins` lies on, (n,) int.

    ``samples`` points drawn area-uniformly with :data:`SAMPLE_SEED`, as
    :func:`~torsal.light.direct_sun_blocked` draws them: the faces they were drawn on, taken
    from the same draw (a millisecond; a closest-point query of 2000 points on 7a's 2048
    faces took 0.07 s of a session's preview). Points drawn otherwise (``samples`` not an
    int, or not the same points) are given the face nearest them.

    >>> v = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    >>> f = np.array([[0, 1, 2], [0, 2, 3]])
    >>> sample_faces((v, f), np.array([[0.9, 0.1, 0], [0.1, 0.9, 0]]), samples=None).tolist()
    [0, 1]
    """
    import trimesh

    v, f = surface
    mesh = trimesh.Trimesh(np.asarray(v, float), np.asarray(f, np.int64), process=False)
    if isinstance(samples, (int, np.integer)):
        drawn, face = trimesh.sample.sample_surface(mesh, int(samples), seed=SAMPLE_SEED)
        if np.array_equal(drawn, points):
            return np.asarray(face, np.int64)
    return np.asarray(trimesh.proximity.closest_point(mesh, points)[2], np.int64)


def _goal(blocked, fins, surface, goals: SunGoals, samples) -> dict:
    """The sun as the goals ask (``goal_share``): the weighted share of incident sun rays
    that do what is asked. Blocked, except over the let-through faces, where it should pass;
    a point in a sun region is asked to block that region's directions instead of the design
    sun's (each region's directions carry the design sun's total weight, shared equally).
    ``samples``: :func:`measure_fins`'s (which face a point is on, :func:`sample_faces`)."""
    from ..light import direct_sun_blocked

    w = blocked.weights[None, :] * blocked.incident
    if not goals or float(w.sum()) <= 0:
        return {"goal_share": _finite(blocked.share)}
    tri = sample_faces(surface, blocked.points, samples)
    inside = (np.isin(tri, goals.let_through) if goals.let_through is not None
              else np.zeros(len(tri), bool))[:, None]
    good = np.where(inside, ~blocked.blocked, blocked.blocked)
    out = {}
    if goals.let_through is not None:
        w_in, w_out = float((w * inside).sum()), float((w * ~inside).sum())
        out["let_through"] = {
            "points_inside": int(inside.sum()),
            "passed_inside": float((w * inside * ~blocked.blocked).sum() / w_in) if w_in else None,
            "blocked_outside": float((w * ~inside * blocked.blocked).sum() / w_out) if w_out else None}
    num, den = (w * good), w.copy()
    extra_num = extra_den = 0.0                      # the regions' own suns
    taken = np.zeros(len(tri), bool)
    regions = []
    for faces_r, vec_r in goals.regions:
        pts = np.isin(tri, faces_r) & ~taken & ~inside[:, 0]
        taken |= pts
        num[pts], den[pts] = 0.0, 0.0
        row = {"points_inside": int(pts.sum()), "blocked_inside": None}
        if pts.any():
            r = direct_sun_blocked(fins, surface, vec_r, samples=(blocked.points[pts],
                                   blocked.normals[pts]), weights=np.full(len(vec_r),
                                   blocked.weights.sum() / len(vec_r)))
            wr = r.weights[None, :] * r.incident
            num_r, den_r = float((wr * r.blocked).sum()), float(wr.sum())
            extra_num, extra_den = extra_num + num_r, extra_den + den_r
            row["blocked_inside"] = num_r / den_r if den_r else None
        regions.append(row)
    if regions:
        out["sun_regions"] = regions
    total = float(den.sum()) + extra_den
    out["goal_share"] = _finite((float(num.sum()) + extra_num) / total) if total > 0 else None
    return out


def measure_fins(fins, surface, sun: dict, samples: int, metres_per_unit: float, *,
                 view=None, view_measure: str = "occupant",
                 goals: SunGoals | None = None) -> tuple[dict, object]:
    """Sun blocked and view clear of a fin set over mesh A.

    Parameters
    ----------
    fins : trimesh.Trimesh
        Thin-surface fins.
    surface : (vertices (n, 3), faces (m, 3))
        Mesh A, normals towards the sun.
    sun : dict
        The sun stage's result: ``vectors`` (k, 3), ``weights`` (k,).
    samples : int
        Points for the sun rays; half as many for the view rays along the normal.
    metres_per_unit : float
    view : torsal.light.view.ViewField, optional
        Occupant eye points and sight lines, model units (default: the defaults in metres).
    view_measure : {"occupant", "normal"}
        Which measure is ``view_clear``.
    goals : SunGoals, optional
        Where the design asks for something else than blocking the design sun
        (:func:`sun_goals`).

    Returns
    -------
    report : dict
        ``blocked_share`` (weighted share of direct sun rays blocked), ``transparency``
        (share of points with a free view along the normal), ``transparency_cone`` (free
        share over a 60 degree cone), ``view_out`` (occupant view out, see
        :mod:`torsal.light.view`) with ``view_out_detail``, ``view_measure`` and
        ``view_clear`` (the chosen one), ``goal_share`` (the weighted share of sun rays that
        do what the goals ask, see :func:`_goal`; ``blocked_share`` without such goals) with
        ``let_through`` (``passed_inside``, ``blocked_outside``) and ``sun_regions``
        (``blocked_inside`` per region) where the design has them, ``fin_area_m2`` (one side).
    blocked : ShadingResult
        Per point, for the figure.
    """
    from ..light import direct_sun_blocked, transparency
    from ..light.view import ViewField, view_out

    if view is None:
        view = ViewField().in_units(metres_per_unit)
    blocked = direct_sun_blocked(fins, surface, sun["vectors"], samples=samples,
                                 weights=sun["weights"], seed=SAMPLE_SEED)
    clear = transparency(fins, surface, samples=samples // 2)
    out = view_out(fins, surface, view)
    # None, never NaN, where a share has nothing to count (no sun strikes A's outside)
    report = {"blocked_share": _finite(blocked.share), "transparency": _finite(clear.along_normal),
              "transparency_cone": _finite(clear.cone), "view_out": out.share,
              "view_out_detail": {k: x for k, x in out.summary().items() if k != "share"},
              "view_measure": view_measure,
              "fin_area_m2": float(fins.area) * metres_per_unit ** 2}
    report["view_clear"] = report[VIEW_KEYS[view_measure]]
    report.update(_goal(blocked, fins, surface, goals or SunGoals(), samples))
    return report, blocked


def design_devices(spec: DesignSpec, vertices, faces, sun: dict, *,
                   goals: SunGoals | None = None) -> dict:
    """The standard devices of the design's fin depth and spacing on mesh A
    (:func:`torsal.light.devices.standard_devices`; with a depth or spacing per family, a
    device's first family takes family 0's and an egg-crate's crossing family family 1's),
    the optimized ones oriented for what the
    goals ask everywhere (a region's own sun over its share of A, :func:`goal_suns`).

    Parameters
    ----------
    spec : DesignSpec
    vertices : (n, 3) float
    faces : (m, 3) int
        Mesh A, oriented (normals towards the sun).
    sun : dict
        The sun stage's result: ``vectors`` (k, 3), ``weights`` (k,).
    goals : SunGoals, optional
        Default :func:`sun_goals` of the design.

    Returns
    -------
    dict of str -> torsal.light.devices.Device
        In :data:`torsal.light.devices.DEVICE_NAMES` order.
    """
    from ..light.devices import standard_devices

    goals = sun_goals(spec, vertices, faces) if goals is None else goals
    vec, w = goal_suns(goals, vertices, faces, sun)
    return standard_devices(vertices, faces, spec.fins.depths, spec.fins.spacings, sun=vec,
                            weights=w)


def run_devices(inp: StageInputs) -> dict:
    """The standard devices of the design's fin depth and spacing, measured.

    Returns ``measured``: {device name: ``applicable``, ``reason``, ``plane_normals``,
    ``stand_out_deg`` (and ``orientation`` for the optimized ones) and, when applicable,
    every figure of :func:`measure_fins`}; in :data:`torsal.light.devices.DEVICE_NAMES` order.
    """
    spec = inp.spec
    o, sun = inp["orient"], inp["sun"]
    v, f = o["vertices"], o["faces"]
    goals = sun_goals(spec, v, f)
    devices = design_devices(spec, v, f, sun, goals=goals)
    view = spec.view.field(spec.metres_per_unit)
    measured = {}
    for name, d in devices.items():
        row = d.as_dict()
        if d.applicable:
            row.update(measure_fins(d.fins, (v, f), sun, spec.outputs.light_samples,
                                    spec.metres_per_unit, view=view,
                                    view_measure=spec.view.measure.value,
                                    goals=goals)[0])
        measured[name] = row
    return {"measured": measured}


def devices_key(spec: DesignSpec) -> tuple:
    """What the devices depend on besides the surface and the sun."""
    g = spec.goals
    return (spec.fins.depth, spec.fins.spacing, spec.outputs.light_samples, spec.units,
            spec.view.model_dump(mode="json"),
            None if g.let_through is None else g.let_through.model_dump(mode="json"),
            [r.model_dump(mode="json") for r in g.sun_regions])


def _view_name(m: dict) -> str:
    return "view out" if m.get("view_measure", "occupant") == "occupant" else "view along the normal"


def _pct(x) -> str:
    return "-" if x is None else f"{100 * x:.1f}%"


def light_summary(light: dict) -> str:
    """The fins' measured light in a few words (the report's ``light`` section), e.g.
    ``sun blocked 93.1%, view out 70.2%``."""
    text = (f"sun blocked {_pct(light['blocked_share'])}, {_view_name(light)} "
            f"{_pct(light.get('view_clear', light.get('transparency')))}")
    lt = light.get("let_through")
    if lt:
        text += (f"; sun as asked {_pct(light['goal_share'])} (let through "
                 f"{_pct(lt['passed_inside'])} over goals.let_through, blocked "
                 f"{_pct(lt['blocked_outside'])} elsewhere)")
    elif light.get("sun_regions"):
        text += (f"; sun as asked {_pct(light['goal_share'])} (each of goals.sun_regions "
                 f"blocking its own sun: "
                 + ", ".join(_pct(r["blocked_inside"]) for r in light["sun_regions"]) + ")")
    return text


def devices_summary(light: dict) -> str:
    """One line on the standard devices of ``light["devices"]``: each made one's sun blocked
    and view, and the ones that cannot be made on the surface, with the first reason.

    >>> devices_summary({"devices": {"egg-crate": {"applicable": False, "reason": "a canopy"},
    ...     "optimized parallel fins": {"applicable": True, "blocked_share": 0.5,
    ...                                 "view_clear": 0.75, "view_measure": "occupant"}}})
    'standard devices, same depth and spacing (sun blocked / view out): optimized parallel fins 50.0% / 75.0%; not applicable: egg-crate (a canopy)'
    """
    devices = light.get("devices") or {}
    made = [(n, d) for n, d in devices.items() if d["applicable"]]
    text = "standard devices, same depth and spacing"
    if made:
        text += (f" (sun blocked / {_view_name(made[0][1])}): "
                 + ", ".join(f"{n} {_pct(d['blocked_share'])} / {_pct(d['view_clear'])}"
                             for n, d in made))
    missing = [(n, d["reason"]) for n, d in devices.items() if not d["applicable"]]
    if missing:
        text += ("; " if made else ": ") + "not applicable: " + ", ".join(n for n, _ in missing)
        text += f" ({missing[0][1]})"
    return text
