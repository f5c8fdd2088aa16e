"""The ray kernel every light measurement rests on: Embree ray casting against fins.

:func:`rays_blocked` and :func:`ray_hits` cast rays with Embree (through ``embreex``, the
backend trimesh uses for ``mesh.ray``) against fins given as a ``trimesh.Trimesh`` (thin
surfaces or closed solids: any triangles block). Without embreex the kernel falls back to
trimesh's pure-Python ray tracer (slow). Shared by :mod:`torsal.light.shading` (sun blocked,
view clear) and :mod:`torsal.light.reflection` (where reflected sunlight lands); the names
stay importable from :mod:`torsal.light.shading`.

Lengths in model units; sun vectors point from the site towards the sun.

Examples
--------
>>> import trimesh
>>> floor = trimesh.Trimesh([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], [[0, 1, 2]])
>>> ray_hits(floor, [[0, 0, 1], [5, 5, 1]], [[0, 0, -1], [0, 0, -1]])   # straight down
array([ True, False])
"""
from __future__ import annotations

import os
import weakref
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import trimesh

__all__ = ["rays_blocked", "ray_hits", "face_plane_distances", "HAS_EMBREE"]

try:  # embreex is a declared dependency; the fallback only keeps the module importable
    from embreex import rtcore_scene as _rtcore_scene
    from embreex.mesh_construction import TriangleMesh as _EmbreeTriangles

    HAS_EMBREE = True
except ImportError:  # pragma: no cover - exercised only without embreex
    HAS_EMBREE = False

_MISS = np.inf
_DEFAULT_CHUNK = 1 << 21  # rays per embree call: bounds memory to ~100 MB of temporaries
#: rays per thread at least: a query of fewer is cast in the calling thread. Embree releases
#: the interpreter while it traces, so a large query is split over the cores (each ray's
#: answer is its own: the result does not depend on the split)
_RAYS_PER_THREAD = 1 << 17
#: threads a query is split over at most
_RAY_THREADS = min(os.cpu_count() or 1, 4)
#: |cos| of the angle between a ray and a face's plane normal below which the ray is taken to
#: graze the plane: the double-precision distance is then ill-conditioned and Embree's is kept
_GRAZING = 1e-9


def face_plane_distances(vertices, faces, face_index, origins, directions, *,
                         fallback=None) -> np.ndarray:
    """Ray distances to the planes of given triangles, in double precision.

    Embree works in single precision: a hit distance ``t`` carries a relative error of
    about 6e-8 (0.002 mm at 28 m), and which digits are lost depends on the CPU's code
    path. A position placed from a hit is therefore re-intersected here with the plane of
    the triangle that was hit, ``t = ((p0 - o) . n) / (d . n)`` with ``p0`` a corner and
    ``n`` the unit normal of that triangle, all in float64.

    Parameters
    ----------
    vertices : (V, 3) float
    faces : (F, 3) int
    face_index : (m,) int
        The triangle each ray hit; -1 for a miss.
    origins, directions : (m, 3) float
        The rays ``origins + t directions`` (directions need not be unit; ``t`` is in
        units of their length, as Embree's is).
    fallback : (m,) float, optional
        Distances kept where the ray misses (``face_index`` -1) or grazes the plane
        (``|cos| < 1e-9`` between ray and normal) or the triangle is degenerate; default
        inf.

    Returns
    -------
    (m,) float
        Distances along each ray to its triangle's plane.

    Examples
    --------
    >>> v = np.array([[0, 0, 1.0], [1, 0, 1], [0, 1, 1]])
    >>> face_plane_distances(v, [[0, 1, 2]], [0, -1], [[0.2, 0.2, 0], [0, 0, 0]],
    ...                      [[0, 0, 2.0], [0, 0, 1]])
    array([0.5, inf])
    """
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64)
    k = np.asarray(face_index, np.int64)
    o = np.asarray(origins, float)
    d = np.asarray(directions, float)
    t = np.full(len(k), _MISS) if fallback is None else np.array(fallback, float, copy=True)
    hit = np.flatnonzero(k >= 0)
    if not hit.size:
        return t
    tri = v[f[k[hit]]]                                           # (h, 3, 3)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n_len = np.linalg.norm(n, axis=1)
    dh = d[hit]
    dn = np.einsum("ij,ij->i", dh, n)
    ok = np.abs(dn) > _GRAZING * n_len * np.linalg.norm(dh, axis=1)
    hit, tri, n, dn = hit[ok], tri[ok], n[ok], dn[ok]
    t[hit] = np.einsum("ij,ij->i", tri[:, 0] - o[hit], n) / dn
    return t


# --------------------------------------------------------------------------- the kernel
class _RayScene:
    """A static Embree scene of one mesh, centred at its bounding-box centre so that
    float32 coordinates keep their precision; distances stay in model units."""

    def __init__(self, mesh: trimesh.Trimesh):
        v = np.asarray(mesh.vertices, dtype=float)
        f = np.asarray(mesh.faces, dtype=np.int64)
        self.vertices, self.faces = v, f       # float64: hit distances are refined against them
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
            # the scene commits at its first query: here, before threads query it together
            self.scene.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32),
                           query="OCCLUDED")
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
        """Distance (inf on a miss) and triangle index (-1) of the first hit, (m,) each.

        Embree finds the triangle; the distance is then that triangle's plane intersected
        in double precision (:func:`face_plane_distances`), so a point placed from it is
        exact to float64 whatever the CPU."""
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
        else:
            o, d = self._prep(origins, directions)
            out = self.scene.run(o, d, output=1)
            prim = out["primID"].astype(np.int64)
            t = out["tfar"].astype(float)
            hit = prim != -1
            t[~hit] = _MISS
            prim[~hit] = -1
        return face_plane_distances(self.vertices, self.faces, prim, np.asarray(origins, float),
                                    np.asarray(directions, float), fallback=t), prim


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

    def cast(lo: int, hi: int) -> None:
        pc = p[lo:hi]
        o = (pc[:, None, :] + eps * d[None, :, :]).reshape(-1, 3)
        dd = np.broadcast_to(d[None], (len(pc), k, 3)).reshape(-1, 3)
        out[lo:hi] = sc.occluded(o, dd).reshape(len(pc), k)

    step = max(1, int(chunk_size) // max(k, 1))
    threads = int(min(_RAY_THREADS, n * k // _RAYS_PER_THREAD, n))
    if threads < 2:
        for s in range(0, n, step):
            cast(s, min(s + step, n))
        return out
    # the points in as many parts as threads, each part in chunks (memory)
    step = min(step, -(-n // threads))
    with ThreadPoolExecutor(threads) as pool:
        for f in [pool.submit(cast, s, min(s + step, n)) for s in range(0, n, step)]:
            f.result()
    return out


def _frames(n: np.ndarray):
    """Two unit tangents per unit normal, (n, 3) each."""
    helper = np.where(np.abs(n[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    t1 = np.cross(helper, n)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    return t1, np.cross(n, t1)


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
