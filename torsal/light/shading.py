"""What the fins block, what they let through, where they reflect: ray-cast measurements.

Every measurement here rests on one kernel, :func:`rays_blocked`, which casts rays with
Embree (through ``embreex``, the backend trimesh uses for ``mesh.ray``) against the fins
given as a ``trimesh.Trimesh`` (thin surfaces or closed solids: any triangles block).
Without embreex the kernel falls back to trimesh's pure-Python ray tracer (slow).

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

import weakref
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from torsal.core.atomic import atomic_path
from torsal.geometry.mesh import average_edge_length, vertex_normals

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

try:  # embreex is a declared dependency; the fallback only keeps the module importable
    from embreex import rtcore_scene as _rtcore_scene
    from embreex.mesh_construction import TriangleMesh as _EmbreeTriangles

    HAS_EMBREE = True
except ImportError:  # pragma: no cover - exercised only without embreex
    HAS_EMBREE = False

_MISS = np.inf
_DEFAULT_CHUNK = 1 << 21  # rays per embree call: bounds memory to ~100 MB of temporaries


# --------------------------------------------------------------------------- the kernel
class _RayScene:
    """A static Embree scene of one mesh, centred at its bounding-box centre so that
    float32 coordinates keep their precision; distances stay in model units."""

    def __init__(self, mesh: trimesh.Trimesh):
        v = np.asarray(mesh.vertices, dtype=float)
        f = np.asarray(mesh.faces, dtype=np.int64)
        self.n_faces = len(f)
        if self.n_faces:
            lo, hi = v[f.ravel()].min(axis=0), v[f.ravel()].max(axis=0)
            self.center = 0.5 * (lo + hi)
            self.size = float(np.linalg.norm(hi - lo))
        else:
            self.center, self.size = np.zeros(3), 0.0
        self._fallback = None
        if self.n_faces == 0:
            return
        if HAS_EMBREE:
            self.scene = _rtcore_scene.EmbreeScene()
            _EmbreeTriangles(scene=self.scene, vertices=(v - self.center).astype(np.float32),
                             indices=f.astype(np.int32))
        else:  # pragma: no cover
            self._fallback = trimesh.ray.ray_triangle.RayMeshIntersector(mesh)

    def _prep(self, origins, directions):
        o = (np.asarray(origins, dtype=float) - self.center).astype(np.float32)
        d = np.asarray(directions, dtype=np.float32)
        return np.ascontiguousarray(o), np.ascontiguousarray(d)

    def occluded(self, origins, directions, tfar=None) -> np.ndarray:
        """(m,) bool: does the ray ``origins + t directions``, ``0 <= t <= tfar``, hit?"""
        m = len(origins)
        if self.n_faces == 0 or m == 0:
            return np.zeros(m, bool)
        if self._fallback is not None:  # pragma: no cover
            t, _ = self.first_hit(origins, directions)
            return t <= (np.inf if tfar is None else np.asarray(tfar, float))
        o, d = self._prep(origins, directions)
        dists = None if tfar is None else np.ascontiguousarray(
            np.broadcast_to(np.asarray(tfar, np.float32), (m,)), dtype=np.float32).copy()
        return self.scene.run(o, d, dists=dists, query="OCCLUDED") != -1

    def first_hit(self, origins, directions):
        """Distance (inf on a miss) and triangle index (-1) of the first hit, (m,) each."""
        m = len(origins)
        if self.n_faces == 0 or m == 0:
            return np.full(m, _MISS), np.full(m, -1, np.int64)
        if self._fallback is not None:  # pragma: no cover
            loc, ray, tri = self._fallback.intersects_location(origins, directions,
                                                               multiple_hits=False)
            t = np.full(m, _MISS)
            prim = np.full(m, -1, np.int64)
            t[ray] = np.einsum("ij,ij->i", loc - origins[ray], directions[ray])
            prim[ray] = tri
            return t, prim
        o, d = self._prep(origins, directions)
        out = self.scene.run(o, d, output=1)
        prim = out["primID"].astype(np.int64)
        t = out["tfar"].astype(float)
        hit = prim != -1
        t[~hit] = _MISS
        prim[~hit] = -1
        return t, prim


_SCENES: "weakref.WeakKeyDictionary[trimesh.Trimesh, tuple[int, _RayScene]]" = \
    weakref.WeakKeyDictionary()


def _scene(mesh) -> _RayScene:
    """The (cached) ray scene of ``mesh``; rebuilt when the mesh's data changed."""
    if not isinstance(mesh, trimesh.Trimesh):
        raise TypeError(
            f"obstacles must be a trimesh.Trimesh, got {type(mesh).__name__}; for a "
            "SupportStructure pass support.fin_mesh()")
    key = hash(mesh)
    cached = _SCENES.get(mesh)
    if cached is not None and cached[0] == key:
        return cached[1]
    scene = _RayScene(mesh)
    _SCENES[mesh] = (key, scene)
    return scene


def _points(points, name="points") -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim == 1 and p.shape == (3,):
        p = p[None]
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"{name} must be an (n, 3) array, got shape {p.shape}")
    bad = np.flatnonzero(~np.isfinite(p).all(axis=1))
    if bad.size:
        raise ValueError(f"{name} {bad[:10].tolist()} are NaN or infinite; remove them")
    return p


def _unit(directions, name="directions") -> np.ndarray:
    d = _points(directions, name)
    n = np.linalg.norm(d, axis=1)
    bad = np.flatnonzero(n < 1e-12)
    if bad.size:
        raise ValueError(f"{name} {bad[:10].tolist()} have zero length; a ray needs a direction")
    return d / n[:, None]


def _epsilon(scene: _RayScene, *arrays) -> float:
    size = scene.size
    for a in arrays:
        if len(a):
            size = max(size, float(np.abs(a - scene.center).max()))
    return max(1e-6 * size, 1e-9)


def ray_hits(obstacles: trimesh.Trimesh, origins, directions, *, max_distance=None,
             epsilon: float | None = None) -> np.ndarray:
    """Paired rays: does ray ``i`` from ``origins[i]`` along ``directions[i]`` hit?

    Parameters
    ----------
    obstacles : trimesh.Trimesh
    origins, directions : (m, 3) float
        Directions need not be unit; zero length raises.
    max_distance : float or (m,) float, optional
        Segment length from the origin (default: infinite rays).
    epsilon : float, optional
        Origins are moved this far along their ray first, so that a ray starting on a
        triangle does not hit it (default ``1e-6`` of the model size).

    Returns
    -------
    (m,) bool
    """
    o = _points(origins, "origins")
    d = _unit(directions)
    if len(d) != len(o):
        raise ValueError(f"{len(o)} origins but {len(d)} directions; pass one direction per origin")
    sc = _scene(obstacles)
    eps = _epsilon(sc, o) if epsilon is None else float(epsilon)
    tfar = None if max_distance is None else np.maximum(np.asarray(max_distance, float) - eps, 0.0)
    out = np.empty(len(o), bool)
    for s in range(0, len(o), _DEFAULT_CHUNK):
        sl = slice(s, s + _DEFAULT_CHUNK)
        out[sl] = sc.occluded(o[sl] + eps * d[sl], d[sl],
                              None if tfar is None else np.broadcast_to(tfar, (len(o),))[sl])
    return out


def rays_blocked(obstacles: trimesh.Trimesh, points, directions, *,
                 epsilon: float | None = None, chunk_size: int = _DEFAULT_CHUNK) -> np.ndarray:
    """Which rays from the points towards the light meet an obstacle.

    One Embree occlusion query per ray over all ``n * k`` combinations (chunked to bound
    memory), origins nudged by ``epsilon`` along their ray against self-hits.

    Parameters
    ----------
    obstacles : trimesh.Trimesh
        Fins as thin surfaces or solids; an empty mesh blocks nothing.
    points : (n, 3) float
        Ray origins, model units. NaN raises ``ValueError``.
    directions : (k, 3) float
        Directions towards the light (e.g. sun vectors); normalized here, zero length raises.
    epsilon : float, optional
        Origin offset along the ray, default ``1e-6`` of the model size.
    chunk_size : int
        Rays per Embree call.

    Returns
    -------
    (n, k) bool
        True where the ray from point ``i`` along direction ``j`` hits an obstacle.
    """
    p = _points(points)
    d = _unit(directions)
    n, k = len(p), len(d)
    out = np.zeros((n, k), bool)
    sc = _scene(obstacles)
    if sc.n_faces == 0 or n == 0:
        return out
    eps = _epsilon(sc, p) if epsilon is None else float(epsilon)
    step = max(1, int(chunk_size) // max(k, 1))
    for s in range(0, n, step):
        pc = p[s:s + step]
        o = (pc[:, None, :] + eps * d[None, :, :]).reshape(-1, 3)
        dd = np.broadcast_to(d[None], (len(pc), k, 3)).reshape(-1, 3)
        out[s:s + step] = sc.occluded(o, dd).reshape(len(pc), k)
    return out


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


def _sun_input(sun, weights):
    """(k, 3) unit sun vectors and (k,) weights from SunDirections or an array."""
    if hasattr(sun, "vectors") and hasattr(sun, "above_horizon"):
        keep = np.asarray(sun.above_horizon, bool)
        v = _unit(np.asarray(sun.vectors)[keep], "sun vectors")
        w = np.asarray(sun.weights, float)[keep] if weights is None else np.asarray(weights, float)
    else:
        v = _unit(sun, "sun vectors")
        w = np.ones(len(v)) if weights is None else np.asarray(weights, float).ravel()
    if w.shape != (len(v),):
        raise ValueError(f"weights must have one value per sun direction ({len(v)}), got {w.shape}")
    if np.any(~np.isfinite(w)) or np.any(w < 0):
        raise ValueError("weights must be finite and non-negative")
    return v, w


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


def _frames(n: np.ndarray):
    """Two unit tangents per unit normal, (n, 3) each."""
    helper = np.where(np.abs(n[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    t1 = np.cross(helper, n)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    return t1, np.cross(n, t1)


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


# --------------------------------------------------------------------------- reflection
def reflect(incoming, normals) -> np.ndarray:
    """Specular reflection ``r = i - 2 <i, n> n`` of propagation directions ``i`` (unit)
    at unit normals ``n``; (k, 3) or broadcastable."""
    i = np.asarray(incoming, float)
    n = np.asarray(normals, float)
    return i - 2.0 * np.sum(i * n, axis=-1, keepdims=True) * n


def mirror_normals(incoming, outgoing) -> np.ndarray:
    """Unit normals of the bisector mirror planes that send ``incoming`` light to ``outgoing``
    (paper 4.3, Fig. 13: mirror planes to become torsal planes).

    Parameters
    ----------
    incoming : (k, 3) or (3,) float
        Propagation direction of the arriving light (for sunlight: ``-sun``).
    outgoing : (k, 3) or (3,) float
        Wanted propagation direction after the reflection. Broadcast against ``incoming``.

    Returns
    -------
    (k, 3) float
        ``n = (o - i) / |o - i|`` with unit ``i``, ``o``; it faces the arriving light
        (``<n, -i> >= 0``) and ``reflect(i, n) == o``.

    Examples
    --------
    >>> mirror_normals([0, 1, 0], [0, 0, 1]).round(4)   # horizontal ray sent straight up
    array([[ 0.    , -0.7071,  0.7071]])
    """
    i = _unit(np.atleast_2d(incoming), "incoming")
    o = _unit(np.atleast_2d(outgoing), "outgoing")
    i, o = np.broadcast_arrays(i, o)
    h = o - i
    length = np.linalg.norm(h, axis=1)
    bad = np.flatnonzero(length < 1e-9)
    if bad.size:
        raise ValueError(
            f"incoming and outgoing directions {bad[:10].tolist()} are equal: light passing "
            "straight on needs no mirror (no bisector plane)")
    return h / length[:, None]


@dataclass
class ReflectionResult:
    """Outcome of :func:`reflected_hits`.

    Attributes
    ----------
    share : float
        Weighted share of the sunlight striking fins that lands on the target after one
        specular reflection (NaN if no sunlight strikes a fin).
    per_direction : (k,) float
        The same per sun direction.
    struck_area, landed_area : (k,) float
        Cross-section (m^2, i.e. W per W/m^2 of DNI) of sunlight striking fins and of the
        part landing on the target.
    """

    share: float
    per_direction: np.ndarray
    struck_area: np.ndarray
    landed_area: np.ndarray


def reflected_hits(fins: trimesh.Trimesh, sun, target_region: trimesh.Trimesh, *,
                   resolution: int = 256, weights=None) -> ReflectionResult:
    """Share of sunlight striking the fins that reaches the target after one mirror bounce.

    For each sun direction a regular grid of ``resolution**2`` parallel rays (equal flux
    each) is cast along ``-sun`` over the fins' projected outline; rays meeting the target
    first are not counted. At each fin hit the ray is reflected specularly (both fin sides
    mirror) and counts as landed if it meets the target before any fin.

    Parameters
    ----------
    fins : trimesh.Trimesh
    sun : SunDirections or (k, 3) float
        Sun vectors (site -> sun).
    target_region : trimesh.Trimesh
        e.g. a rectangle on a ceiling.
    resolution : int, default 256
    weights : (k,) float, optional
        Per-direction weights (default ``sun.weights`` or 1).

    Returns
    -------
    ReflectionResult
    """
    s_all, w = _sun_input(sun, weights)
    if not isinstance(target_region, trimesh.Trimesh) or len(target_region.faces) == 0:
        raise ValueError("target_region must be a non-empty trimesh.Trimesh")
    fs, ts = _scene(fins), _scene(target_region)
    k = len(s_all)
    struck, landed = np.zeros(k), np.zeros(k)
    if fs.n_faces == 0:
        return ReflectionResult(float("nan"), np.full(k, np.nan), struck, landed)
    fv = np.asarray(fins.vertices, float)[np.unique(np.asarray(fins.faces).ravel())]
    allv = np.concatenate([fv, np.asarray(target_region.vertices, float)])
    center = fv.mean(axis=0)
    reach = 2.0 * np.linalg.norm(allv - center, axis=1).max() + 1.0
    eps = 1e-6 * reach
    fn = np.asarray(fins.face_normals, float)
    res = int(resolution)
    for j, s in enumerate(s_all):
        t1, t2 = _frames(s[None])
        t1, t2 = t1[0], t2[0]
        u, v = (fv - center) @ t1, (fv - center) @ t2
        du, dv = (u.max() - u.min()) / res, (v.max() - v.min()) / res
        if du <= 0 or dv <= 0:  # fins seen edge-on: no cross-section
            continue
        gu = u.min() + (np.arange(res) + 0.5) * du
        gv = v.min() + (np.arange(res) + 0.5) * dv
        U, V = np.meshgrid(gu, gv, indexing="ij")
        o = center + reach * s + U.reshape(-1, 1) * t1 + V.reshape(-1, 1) * t2
        d = np.broadcast_to(-s, o.shape)
        t_f, prim = fs.first_hit(o, d)
        t_t, _ = ts.first_hit(o, d)
        hit = np.isfinite(t_f) & ~(t_t < t_f)
        if not hit.any():
            continue
        n = fn[prim[hit]]
        r = reflect(-s, n)
        # exact hit on the triangle's plane (float64), then step off it on the lit side
        oh = o[hit]
        p0 = np.asarray(fins.vertices, float)[np.asarray(fins.faces)[prim[hit], 0]]
        t_exact = np.einsum("ij,ij->i", oh - p0, n) / (n @ s)
        h = oh - t_exact[:, None] * s
        side = np.sign(n @ s)[:, None] * n  # unit normal on the side the light came from
        o2 = h + eps * side
        t_f2, _ = fs.first_hit(o2, r)
        t_t2, _ = ts.first_hit(o2, r)
        land = np.isfinite(t_t2) & (t_t2 < t_f2)
        struck[j] = hit.sum() * du * dv
        landed[j] = land.sum() * du * dv
    with np.errstate(invalid="ignore", divide="ignore"):
        per = landed / struck
    total = (w * struck).sum()
    share = float((w * landed).sum() / total) if total > 0 else float("nan")
    return ReflectionResult(share, per, struck, landed)


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
