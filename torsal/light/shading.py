"""What the fins block and what they let through: ray-cast measurements.

Every measurement here rests on the ray kernel of :mod:`torsal.light.rays`
(:func:`rays_blocked`, :func:`ray_hits`: Embree through ``embreex``). Where reflected sunlight
lands is :mod:`torsal.light.reflection`; its names (:func:`reflected_hits`,
:func:`mirror_normals`, :func:`reflect`, :class:`ReflectionResult`) stay importable from here.

Conventions
-----------
- Lengths in model units (metres), angles in degrees.
- The design surface ``A`` is a ``trimesh.Trimesh`` or a ``(vertices, faces)`` pair whose
  normals point to the outside (the sun side); "inside" is ``-normal``. ``A`` itself is
  never an obstacle: only the fins block.
- Sun vectors point from the site towards the sun (see :mod:`torsal.light.sun`); light
  *propagates* along ``-sun``.

Examples
--------
>>> import numpy as np, trimesh
>>> wall = trimesh.Trimesh([[-1, 1, -1], [1, 1, -1], [1, 1, 1], [-1, 1, 1]],
...                        [[0, 1, 2], [0, 2, 3]])
>>> rays_blocked(wall, np.zeros((2, 3)), [[0, 1, 0], [0, -1, 0]])
array([[ True, False],
       [ True, False]])
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from torsal.core.atomic import atomic_path
from torsal.geometry.mesh import average_edge_length, vertex_normals
from torsal.light.rays import (  # noqa: F401  (the kernel, importable from here as before)
    _DEFAULT_CHUNK,
    _MISS,
    _SCENES,
    HAS_EMBREE,
    _epsilon,
    _frames,
    _points,
    _RayScene,
    _scene,
    _sun_input,
    _unit,
    ray_hits,
    rays_blocked,
)
from torsal.light.reflection import (  # noqa: F401  (moved there; importable from here)
    ReflectionResult,
    mirror_normals,
    reflect,
    reflected_hits,
)

__all__ = [
    "rays_blocked",
    "ray_hits",
    "direct_sun_blocked",
    "transparency",
    "see_through",
    "mirror_normals",
    "reflect",
    "reflected_hits",
    "ShadingResult",
    "TransparencyResult",
    "SeeThroughResult",
    "ReflectionResult",
    "compare",
]


# --------------------------------------------------------------------------- sampling
def _as_mesh(surface) -> trimesh.Trimesh:
    if isinstance(surface, trimesh.Trimesh):
        return surface
    try:
        v, f = surface
    except (TypeError, ValueError):
        raise TypeError("surface must be a trimesh.Trimesh or a (vertices, faces) pair") from None
    return trimesh.Trimesh(np.asarray(v, float), np.asarray(f, np.int64), process=False)


def _surface_samples(surface, samples, seed):
    """Points on A and their outward unit normals.

    ``samples``: int (area-uniform random points, face normals), ``"vertices"`` (vertices
    and area-weighted vertex normals), an (n, 3) array of points (normal of the closest
    face) or a ``(points, normals)`` pair.
    """
    mesh = _as_mesh(surface)
    if isinstance(samples, str):
        if samples != "vertices":
            raise ValueError(f"samples must be an int, 'vertices', points or (points, normals); got {samples!r}")
        return np.asarray(mesh.vertices, float), vertex_normals(mesh.vertices, mesh.faces)
    if isinstance(samples, (int, np.integer)):
        if samples < 1:
            raise ValueError(f"samples must be at least 1, got {samples}")
        pts, face = trimesh.sample.sample_surface(mesh, int(samples), seed=seed)
        return np.asarray(pts, float), np.asarray(mesh.face_normals[face], float)
    if isinstance(samples, tuple) and len(samples) == 2:
        pts, nrm = _points(samples[0], "sample points"), _unit(samples[1], "sample normals")
        if len(pts) != len(nrm):
            raise ValueError(f"{len(pts)} sample points but {len(nrm)} normals")
        return pts, nrm
    pts = _points(samples, "sample points")
    _, _, tri = trimesh.proximity.closest_point(mesh, pts)
    return pts, np.asarray(mesh.face_normals[tri], float)


def _default_offset(surface) -> float:
    mesh = _as_mesh(surface)
    return 1e-4 * average_edge_length(mesh.vertices, mesh.faces)



# --------------------------------------------------------------------------- direct sun
@dataclass
class ShadingResult:
    """Outcome of :func:`direct_sun_blocked`.

    Attributes
    ----------
    points, normals : (n, 3) float
        Sample points on A (before the inward offset) and their outward normals.
    sun : (k, 3) float
        Sun vectors used (above the horizon only).
    weights : (k,) float
        Weight of each direction (1, or DNI in W/m^2).
    blocked : (n, k) bool
        The ray from the point towards the sun meets a fin.
    incident : (n, k) bool
        The sun is in front of A at the point (``<sun, normal> > 0``); rays from behind A
        are shaded by the building itself and are left out of every share.
    per_point : (n,) float
        Weighted share of incident sun blocked at each point, NaN where no sun is incident.
    per_direction : (k,) float
        Share of the incident points blocked for each sun direction (NaN if none incident).
    share : float
        Weighted share over all points and directions, in [0, 1].
    """

    points: np.ndarray
    normals: np.ndarray
    sun: np.ndarray
    weights: np.ndarray
    blocked: np.ndarray
    incident: np.ndarray
    per_point: np.ndarray
    per_direction: np.ndarray
    share: float


def direct_sun_blocked(fins: trimesh.Trimesh, surface, sun, samples=2000, *, weights=None,
                       offset: float | None = None, cosine_weighted: bool = False,
                       seed: int | None = 0) -> ShadingResult:
    """Share of direct sun rays that the fins block, per sample point on A and overall.

    Sample points on A are moved ``offset`` to the inside (``-normal``) and a ray is cast
    from each towards every sun direction; a ray counts only where the sun is in front of A
    (``<sun, normal> > 0``). Direction ``j`` weighs ``weights[j]`` (times ``<sun, normal>``
    when ``cosine_weighted``, i.e. blocked share of direct irradiance on A).

    Parameters
    ----------
    fins : trimesh.Trimesh
        e.g. ``SupportStructure.fin_mesh()`` or :func:`torsal.light.baselines.horizontal_louvers`.
    surface : trimesh.Trimesh or (vertices, faces)
        Design surface A, normals outside.
    sun : SunDirections or (k, 3) float
        Sun vectors (site -> sun); below-horizon times of a ``SunDirections`` are dropped.
    samples : int, "vertices", (n, 3) points or (points, normals), default 2000
        Where to measure; an int draws area-uniform points (``seed``).
    weights : (k,) float, optional
        Per-direction weights; default ``sun.weights`` (DNI for :func:`hot_hours`) or 1.
    offset : float, optional
        Inward offset, default ``1e-4`` of A's mean edge length.
    cosine_weighted : bool, default False
    seed : int, optional

    Returns
    -------
    ShadingResult
    """
    s, w = _sun_input(sun, weights)
    pts, nrm = _surface_samples(surface, samples, seed)
    off = _default_offset(surface) if offset is None else float(offset)
    origins = pts - off * nrm
    blocked = rays_blocked(fins, origins, s)
    cos = nrm @ s.T
    incident = cos > 0
    wk = w[None, :] * (cos if cosine_weighted else 1.0) * incident
    with np.errstate(invalid="ignore", divide="ignore"):
        per_point = (wk * blocked).sum(axis=1) / wk.sum(axis=1)
        per_direction = (incident & blocked).sum(axis=0) / incident.sum(axis=0)
    total = wk.sum()
    share = float((wk * blocked).sum() / total) if total > 0 else float("nan")
    return ShadingResult(pts, nrm, s, w, blocked, incident, per_point, per_direction, share)


# --------------------------------------------------------------------------- transparency
def _cap_directions(m: int, half_angle_deg: float) -> np.ndarray:
    """``m`` directions stratified uniformly in solid angle over the cap around +z."""
    i = np.arange(m) + 0.5
    cos_a = np.cos(np.radians(half_angle_deg))
    ct = 1.0 - (1.0 - cos_a) * i / m
    st = np.sqrt(np.maximum(0.0, 1.0 - ct * ct))
    phi = i * np.pi * (3.0 - np.sqrt(5.0))  # golden angle
    return np.c_[st * np.cos(phi), st * np.sin(phi), ct]



@dataclass
class TransparencyResult:
    """Outcome of :func:`transparency`: shares of view rays that pass unobstructed.

    Attributes
    ----------
    along_normal : float
        Share of points whose view straight out along the normal is free.
    cone : float
        Share of free rays over the cone (uniform in solid angle) around the normal.
    view_dirs : float or None
        Share of free rays over the given global view directions (only those in front of A
        at each point), if any were given.
    per_point_normal, per_point_cone : (n,) float
        Per point; ``per_point_view`` likewise (NaN where no given direction is in front).
    points, normals : (n, 3) float
    """

    along_normal: float
    cone: float
    view_dirs: float | None
    per_point_normal: np.ndarray
    per_point_cone: np.ndarray
    per_point_view: np.ndarray | None
    points: np.ndarray
    normals: np.ndarray


def transparency(fins: trimesh.Trimesh, surface, view_dirs=None, *, samples=1000,
                 cone_half_angle: float = 60.0, cone_rays: int = 64,
                 offset: float | None = None, seed: int | None = 0) -> TransparencyResult:
    """How transparent the fins are from inside: the paper's "shallow and transparent".

    From sample points on A (moved ``offset`` inside), view rays go out straight along the
    outward normal and over a cone of ``cone_half_angle`` around it (``cone_rays`` rays,
    stratified uniformly in solid angle, same pattern at every point); optionally also
    along global ``view_dirs`` (only where in front of A). A ray is free if it meets no fin.

    Parameters
    ----------
    fins : trimesh.Trimesh
    surface : trimesh.Trimesh or (vertices, faces)
    view_dirs : (k, 3) float, optional
        Global view directions (pointing outwards, away from the building).
    samples : see :func:`direct_sun_blocked`
    cone_half_angle : float, default 60
        Degrees, in (0, 90].
    cone_rays : int, default 64
    offset : float, optional
    seed : int, optional

    Returns
    -------
    TransparencyResult
    """
    if not 0.0 < cone_half_angle <= 90.0:
        raise ValueError(f"cone_half_angle must be in (0, 90] degrees, got {cone_half_angle}")
    pts, nrm = _surface_samples(surface, samples, seed)
    off = _default_offset(surface) if offset is None else float(offset)
    origins = pts - off * nrm
    n = len(pts)
    free_normal = ~ray_hits(fins, origins, nrm)
    local = _cap_directions(int(cone_rays), cone_half_angle)
    t1, t2 = _frames(nrm)
    dirs = (local[None, :, 0:1] * t1[:, None] + local[None, :, 1:2] * t2[:, None]
            + local[None, :, 2:3] * nrm[:, None])  # (n, m, 3)
    m = len(local)
    hit = ray_hits(fins, np.repeat(origins, m, axis=0), dirs.reshape(-1, 3)).reshape(n, m)
    per_cone = 1.0 - hit.mean(axis=1)
    view_share, per_view = None, None
    if view_dirs is not None:
        v = _unit(view_dirs, "view_dirs")
        blocked = rays_blocked(fins, origins, v)
        front = (nrm @ v.T) > 0
        with np.errstate(invalid="ignore", divide="ignore"):
            per_view = (front & ~blocked).sum(axis=1) / front.sum(axis=1)
        view_share = float((front & ~blocked).sum() / front.sum()) if front.any() else float("nan")
    return TransparencyResult(float(free_normal.mean()), float(per_cone.mean()), view_share,
                              free_normal.astype(float), per_cone, per_view, pts, nrm)


# --------------------------------------------------------------------------- see-through
@dataclass
class SeeThroughResult:
    """Outcome of :func:`see_through`.

    Attributes
    ----------
    share : float
        Share of the target's area visible from the viewpoint past the fins (area-uniform
        samples on the target, segment tests).
    image_share : float
        The same share measured on the fish-eye image, solid-angle weighted (NaN if the
        target is outside the field of view).
    image : (res, res) int
        Pixel classes: 0 outside the fish-eye circle, 1 free, 2 fin, 3 target visible,
        4 target hidden by a fin.
    path : Path or None
        The PNG written, if a path was given.
    """

    share: float
    image_share: float
    image: np.ndarray
    path: Path | None


_CLASS_COLORS = np.array([
    [1.00, 1.00, 1.00],  # outside
    [0.80, 0.90, 1.00],  # free (sky / view)
    [0.35, 0.35, 0.38],  # fin
    [0.10, 0.45, 0.95],  # target visible
    [0.90, 0.25, 0.20],  # target hidden behind a fin
])


def _fisheye_dirs(axis, fov_deg, res):
    a = axis / np.linalg.norm(axis)
    up = np.array([0.0, 0.0, 1.0]) if abs(a[2]) < 0.99 else np.array([0.0, 1.0, 0.0])
    right = np.cross(a, up)
    right /= np.linalg.norm(right)
    top = np.cross(right, a)
    c = (np.arange(res) + 0.5) / res * 2.0 - 1.0
    u, v = np.meshgrid(c, -c)  # row 0 is the top of the image
    r = np.hypot(u, v)
    inside = r <= 1.0
    theta = r * np.radians(fov_deg) / 2.0  # equidistant projection
    phi = np.arctan2(v, u)
    d = (np.cos(theta)[..., None] * a + (np.sin(theta) * np.cos(phi))[..., None] * right
         + (np.sin(theta) * np.sin(phi))[..., None] * top)
    with np.errstate(invalid="ignore", divide="ignore"):
        solid = np.where(theta > 0, np.sin(theta) / np.where(theta > 0, theta, 1.0), 1.0)
    return d, inside, solid


def see_through(fins: trimesh.Trimesh, viewpoint, target: trimesh.Trimesh, fov: float = 180.0,
                *, view_direction=None, resolution: int = 256, samples: int = 4000,
                path=None, title: str | None = None, seed: int | None = 0) -> SeeThroughResult:
    """Fish-eye check that a target is visible through the fins (Fig. 7c's insets).

    Parameters
    ----------
    fins : trimesh.Trimesh
    viewpoint : (3,) float
        Eye point ``O_i`` (inside, behind the fins).
    target : trimesh.Trimesh
        Target region, e.g. a rectangle; its own back faces are not treated as occluders.
    fov : float, default 180
        Full field of view of the equidistant fish-eye, degrees, in (0, 360).
    view_direction : (3,) float, optional
        Image centre; default towards the target's area centroid.
    resolution : int, default 256
        Image size in pixels.
    samples : int, default 4000
        Area-uniform points on the target for ``share``.
    path : str or Path, optional
        Where to write the PNG (atomically); nothing written if None.
    title : str, optional

    Returns
    -------
    SeeThroughResult
    """
    eye = _points(viewpoint, "viewpoint")[0]
    if not 0.0 < fov < 360.0:
        raise ValueError(f"fov must be in (0, 360) degrees, got {fov}")
    if not isinstance(target, trimesh.Trimesh) or len(target.faces) == 0:
        raise ValueError("target must be a non-empty trimesh.Trimesh (e.g. a rectangle)")
    # area share by segment tests to target samples
    tp, _ = trimesh.sample.sample_surface(target, int(samples), seed=seed)
    seg = np.asarray(tp, float) - eye
    dist = np.linalg.norm(seg, axis=1)
    if np.any(dist < 1e-12):
        raise ValueError("the viewpoint lies on the target")
    share = float(1.0 - ray_hits(fins, np.broadcast_to(eye, seg.shape), seg,
                                 max_distance=dist).mean())
    # image
    axis = (np.asarray(target.area_faces @ target.triangles_center / target.area) - eye
            if view_direction is None else _unit(view_direction, "view_direction")[0])
    d, inside, solid = _fisheye_dirs(axis, fov, int(resolution))
    dirs = d[inside]
    o = np.broadcast_to(eye, dirs.shape)
    t_fin, _ = _scene(fins).first_hit(o, dirs)
    t_tgt, _ = _scene(target).first_hit(o, dirs)
    cls = np.zeros(inside.shape, np.int64)
    c = np.ones(len(dirs), np.int64)
    c[np.isfinite(t_fin)] = 2
    tg = np.isfinite(t_tgt)
    c[tg & (t_tgt < t_fin)] = 3
    c[tg & (t_tgt >= t_fin)] = 4
    cls[inside] = c
    w = solid[inside]
    seen, hidden = w[c == 3].sum(), w[c == 4].sum()
    image_share = float(seen / (seen + hidden)) if seen + hidden > 0 else float("nan")
    out = None
    if path is not None:
        out = _write_fisheye(Path(path), cls, fov, share,
                             title or f"view from ({eye[0]:.2f}, {eye[1]:.2f}, {eye[2]:.2f})")
    return SeeThroughResult(share, image_share, cls, out)


def _write_fisheye(path: Path, cls: np.ndarray, fov: float, share: float, title: str) -> Path:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    fig = Figure(figsize=(5, 5.4), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    ax.imshow(_CLASS_COLORS[cls], interpolation="nearest")
    if (cls == 3).any() or (cls == 4).any():  # outline the target region
        ax.contour((cls >= 3).astype(float), levels=[0.5], colors="k", linewidths=0.8)
    ax.set_axis_off()
    ax.set_title(f"{title}\nfish-eye {fov:g} deg, target visible {100 * share:.1f} %", fontsize=9)
    ax.legend(handles=[Patch(color=_CLASS_COLORS[i], label=lab) for i, lab in
                       ((2, "fin"), (3, "target visible"), (4, "target hidden"))],
              loc="lower center", ncol=3, fontsize=7, frameon=False, bbox_to_anchor=(0.5, -0.08))
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    return path



# --------------------------------------------------------------------------- comparison
def compare(designs: dict, surface, sun, *, samples=2000, view_dirs=None,
            cone_half_angle: float = 60.0, seed: int | None = 0) -> dict[str, dict]:
    """Measure several fin sets with the same samples, sun and view rays.

    Parameters
    ----------
    designs : dict of str -> trimesh.Trimesh
        e.g. ``{"torsal": support.fin_mesh(), **torsal.light.baselines.baselines(...)}``.
    surface, sun, samples, seed
        As in :func:`direct_sun_blocked` (one set of sample points for every design).
    view_dirs, cone_half_angle
        As in :func:`transparency`.

    Returns
    -------
    dict of str -> dict
        Per design: ``blocked`` (weighted share of direct sun blocked), ``transparent_normal``,
        ``transparent_cone`` (and ``transparent_view`` if ``view_dirs``), ``fin_area`` (m^2,
        one side) and ``triangles``.
    """
    pts, nrm = _surface_samples(surface, samples, seed)
    out = {}
    for name, fins in designs.items():
        b = direct_sun_blocked(fins, surface, sun, samples=(pts, nrm))
        t = transparency(fins, surface, view_dirs, samples=(pts, nrm),
                         cone_half_angle=cone_half_angle)
        row = {"blocked": b.share, "transparent_normal": t.along_normal,
               "transparent_cone": t.cone, "fin_area": float(fins.area),
               "triangles": int(len(fins.faces))}
        if view_dirs is not None:
            row["transparent_view"] = t.view_dirs
        out[name] = row
    return out
