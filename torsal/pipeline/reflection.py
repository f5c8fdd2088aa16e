"""The reflection goal of a design (paper 4.3, Fig. 13): its target on the ceiling, the mirror
planes it asks of the congruence, and what the fins as built do with the sunlight.

The congruence gets two torsal planes prescribed per face of ``goals.reflect.region``
(:func:`reflect_planes`): the *mirror plane*, the one plane that lands the most of the
design's sun directions in the target (:func:`torsal.light.best_mirror_normals`), and, for
the other family, the *plane of incidence* of the design light at that mirror
(:func:`torsal.light.incidence_plane_normals`): it contains the arriving light and the light
the mirror sends on, so those fins stand edge-on to both and keep out of the way of the
light. The two planes meet in the line ``-(i + o)`` (arriving light ``i``, reflected ``o``):
the congruence's line there.

:func:`measure_reflection` traces the sunlight over the fins as built
(:func:`torsal.light.reflected_hits`) and writes report.json ``light.reflection``; the
definitions of struck light, on target and elsewhere are those of :mod:`torsal.light.reflection`.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .design_file import DesignSpec
from .regions import dominant_light_direction, select_faces
from ..light.reflection import (CeilingTarget, TargetSide, best_mirror_normals,
                                ideal_mirror_bound, incidence_plane_normals, reflected_hits)

__all__ = ["GOAL_ON_TARGET", "reflection_target", "ReflectPlanes", "reflect_planes",
           "measure_reflection"]

#: the share of the struck light on the target a reflecting design aims for (issue 26)
GOAL_ON_TARGET = 0.8
#: rays per sun direction of the reflection measurement: RESOLUTION**2
RESOLUTION = 256

DEFINITION = (
    "struck light: direct sunlight at the design's sun directions (with their weights) whose "
    "first obstacle is a fin of either family, sampled by parallel rays of equal flux; on "
    "target: struck light that meets the target's underside after specular reflections "
    "(every fin side a perfect mirror, at most {bounces}); elsewhere: struck light that "
    "leaves the fins and misses the target; trapped: still between fins after {bounces} "
    "reflections. reflecting_fins counts the struck light that meets a fin of the mirror "
    "family at some reflection; other_family_only the struck light that meets only the other "
    "family. bound.ideal_mirrors: the share that a best-oriented planar mirror at every struck "
    "point (one plane for all the sun directions, nothing in its way) would land.")


def reflection_target(spec: DesignSpec, vertices: np.ndarray) -> CeilingTarget:
    """The design's target region: ``goals.reflect.target`` as centre, ``goals.reflect.size``
    (default: a square a third of the surface's extent).

    >>> spec = DesignSpec.model_validate({"name": "t", "surface": {"generator": "canopy"},
    ...     "sun": {"vectors": [[0, -1, 1]]}, "goals": {"reflect": {"target": [0, 6, 5]}},
    ...     "fins": {"spacing": 1, "depth": 0.5}})
    >>> reflection_target(spec, np.array([[0, 0, 0], [12, 3, 0.0]]))
    CeilingTarget(centre=(0.0, 6.0, 5.0), size=(4.0, 4.0))
    """
    r = spec.goals.reflect
    if r.size is not None:
        size = tuple(r.size)
    else:
        side = float(np.ptp(np.asarray(vertices, float), axis=0).max()) / 3.0
        size = (side, side)
    return CeilingTarget(tuple(r.target), size)


class ReflectPlanes(NamedTuple):
    """The torsal planes the reflection goal prescribes (:func:`reflect_planes`).

    faces : (m,) int
        Faces of A that get them (in ``goals.reflect.region``, below the ceiling).
    mirror : (m, 3) float
        Unit normals of the mirror planes.
    incidence : (m, 3) float
        Unit normals of the planes of incidence (the other family).
    light : (3,) float
        The design light direction (propagation) the planes are made for.
    on_target : (m,) float
        Weighted share of the sun directions the mirror at the face's barycenter lands.
    """

    faces: np.ndarray
    mirror: np.ndarray
    incidence: np.ndarray
    light: np.ndarray
    on_target: np.ndarray


def reflect_planes(spec: DesignSpec, v: np.ndarray, f: np.ndarray, sun: np.ndarray,
                   w_sun: np.ndarray) -> ReflectPlanes:
    """The mirror planes and planes of incidence for the faces of ``goals.reflect.region``.

    Parameters
    ----------
    spec : DesignSpec
        With ``goals.reflect``.
    v, f : (n, 3) float, (m, 3) int
        Mesh A.
    sun : (k, 3) float
        Sun vectors (site -> sun); ``w_sun`` (k,) their weights.

    Raises
    ------
    ValueError
        The region has no face, or no face lies below the target's ceiling (light cannot
        reach a ceiling's underside from above it).
    """
    g = spec.goals.reflect
    fi = select_faces(g.region, v, f)
    if fi.size == 0:
        raise ValueError("goals.reflect.region contains no face of the surface; check its "
                         "ranges against the mesh")
    target = reflection_target(spec, v)
    bc = v[f[fi]].mean(axis=1)
    below = bc[:, 2] < target.height
    if not below.any():
        raise ValueError(
            f"goals.reflect.target lies at z = {target.height:g}, below every face of the "
            "reflecting region: reflected light reaches a ceiling's underside only from "
            "below; raise the target or give a region under it")
    fi, bc = fi[below], bc[below]
    light = dominant_light_direction(-sun, w_sun)
    aim = best_mirror_normals(bc, sun, target, weights=w_sun, design_light=light)
    inc = incidence_plane_normals(light, aim.normals)
    return ReflectPlanes(fi, aim.normals, inc, light, aim.share)


# ------------------------------------------------------------------ measurement
def _share(num: float, den: float):
    """num / den, or None (JSON null, never NaN) when nothing was counted."""
    return float(num / den) if den > 0 else None


def _fin_planes(structure):
    """Centres and unit normals (from the diagonals) of the fins, (E, 3) each."""
    q = structure.fin_quads()
    n = np.cross(q[:, 2] - q[:, 0], q[:, 3] - q[:, 1])
    return q.mean(axis=1), n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)


def _mirror_family(structure, sun: dict, target: CeilingTarget, light: np.ndarray):
    """The family whose fins lie closest to the best mirror planes at their centres, and
    the angles (deg) between the fins and those planes per family."""
    centres, normals = _fin_planes(structure)
    fam = np.asarray(structure.edge_family)
    aim = best_mirror_normals(centres, sun["vectors"], target, weights=sun["weights"],
                              design_light=light)
    ang = np.degrees(np.arccos(np.clip(np.abs((normals * aim.normals).sum(1)), 0.0, 1.0)))
    per = {}
    for k in (0, 1):
        a = ang[(fam == k) & aim.reachable]
        if a.size:
            per[k] = {"median": float(np.median(a)), "p90": float(np.percentile(a, 90)),
                      "fins": int(a.size)}
    mirror = min(per, key=lambda k: per[k]["median"]) if per else 0
    return mirror, per


def _direction_row(j, rays, s, w, mirror, area_scale):
    a = rays.area
    struck = a * len(rays.outcome)
    landed = rays.outcome == 0
    touch_m = rays.touched[:, mirror] if rays.touched.shape[1] > mirror else np.zeros(len(landed), bool)
    other = rays.touched.any(axis=1) & ~touch_m
    el = float(np.degrees(np.arcsin(np.clip(s[2], -1, 1))))
    return {
        "vector": [float(x) for x in s], "elevation_deg": el,
        "azimuth_deg": float(np.degrees(np.arctan2(s[0], s[1])) % 360.0),
        "weight": float(w), "struck_m2": float(struck * area_scale),
        "on_target": _share(landed.sum(), len(landed)),
        "elsewhere": _share((rays.outcome == 1).sum(), len(landed)),
        "trapped": _share((rays.outcome == 2).sum(), len(landed)),
        "reflecting_fins_share": _share(touch_m.sum(), len(landed)),
        "reflecting_fins_on_target": _share((landed & touch_m).sum(), touch_m.sum()),
        "other_family_only": _share(other.sum(), len(landed)),
    }


def measure_reflection(spec: DesignSpec, structure, sun: dict, vertices: np.ndarray, *,
                       metres_per_unit: float = 1.0, resolution: int = RESOLUTION):
    """Trace the sunlight over the fins of ``structure`` and report where it lands.

    Parameters
    ----------
    spec : DesignSpec
        With ``goals.reflect``.
    structure : SupportStructure
        The fins as built.
    sun : dict
        ``vectors`` (k, 3) site -> sun, ``weights`` (k,).
    vertices : (n, 3) float
        Mesh A's vertices (for the default target size and the picture's plan).
    metres_per_unit : float
        For the areas in m^2.

    Returns
    -------
    report : dict
        report.json ``light.reflection`` (definitions in ``definition``; shares are None,
        never NaN, where nothing is struck).
    picture : dict
        What :func:`torsal.pipeline.report.plot_ceiling_light` draws.
    """
    target = reflection_target(spec, vertices)
    s, w = np.asarray(sun["vectors"], float), np.asarray(sun["weights"], float)
    light = dominant_light_direction(-s, w)
    mirror, plane_err = _mirror_family(structure, sun, target, light)
    r = reflected_hits(structure.fin_mesh(), s, target.mesh(), weights=w, resolution=resolution,
                       lit_side=TargetSide.FRONT, face_groups=np.repeat(structure.edge_family, 2),
                       ceiling=target.height, seed=0)
    bound = ideal_mirror_bound(r, target)
    area2 = metres_per_unit ** 2
    rows = [_direction_row(j, rays, s[j], w[j], mirror, area2) for j, rays in enumerate(r.rays)]
    for row, b in zip(rows, bound.per_direction):
        row["bound_ideal_mirrors"] = float(b) if np.isfinite(b) else None

    def weighted(key_num, key_den="struck_m2"):
        num = sum(row["weight"] * row[key_den] * (row[key_num] or 0.0) for row in rows)
        return _share(num, sum(row["weight"] * row[key_den] for row in rows))

    refl = sum(row["weight"] * row["struck_m2"] * (row["reflecting_fins_share"] or 0.0) for row in rows)
    refl_on = sum(row["weight"] * row["struck_m2"] * (row["reflecting_fins_share"] or 0.0)
                  * (row["reflecting_fins_on_target"] or 0.0) for row in rows)
    on_target = weighted("on_target")
    report = {
        "definition": DEFINITION.format(bounces=r.max_bounces),
        "target": {"centre": list(target.centre), "size": list(target.size), "lit_from": "below"},
        "on_target": on_target,
        "elsewhere": weighted("elsewhere"),
        "trapped": weighted("trapped"),
        "struck_m2": float(sum(row["struck_m2"] for row in rows)),
        "goal": {"on_target_at_least": GOAL_ON_TARGET,
                 "met": bool(on_target is not None and on_target >= GOAL_ON_TARGET)},
        "reflecting_family": int(mirror),
        "fin_plane_error_deg": {str(k): v for k, v in plane_err.items()},
        "reflecting_fins": {"share_of_struck": weighted("reflecting_fins_share"),
                            "on_target": _share(refl_on, refl)},
        "other_family_only": weighted("other_family_only"),
        "bound": {"ideal_mirrors": bound.share if np.isfinite(bound.share) else None,
                  "points": bound.points},
        "rays_per_direction": int(resolution) ** 2, "max_bounces": int(r.max_bounces),
        "per_sun_direction": rows,
    }
    picture = {
        "target": {"centre": target.centre, "size": target.size},
        "plan": np.asarray(vertices, float)[:, :2],
        "directions": [{"vector": s[j], "weight": float(w[j]), "area": rays.area,
                        "xy": rays.ceiling_xy[np.isfinite(rays.ceiling_xy).all(axis=1)],
                        "on_target": rows[j]["on_target"]}
                       for j, rays in enumerate(r.rays)],
        "on_target": on_target,
    }
    return report, picture
