"""Where reflected sunlight lands: mirror fins (paper 4.3, Fig. 13), traced and bounded.

To send a ray of light to a prescribed place, "a bisector plane of the original ray and the
reflected ray has to be used as a mirror surface" (Wang et al. 2013, 4.3): :func:`mirror_normals`.
A planar fin reflects a parallel beam into a parallel beam, so a fin sends each sun direction
to one spot the size of the fin, and the spots of the design hours spread as the sun moves.
:func:`best_mirror_normals` chooses, per point, the one mirror plane that lands the most of
the design's sun directions in a target region; :func:`reflected_hits` traces what the fins
as built do with the sunlight; :func:`ideal_mirror_bound` says how much any planar mirror
could land at the points the sun strikes.

Definitions (used in report.json ``light.reflection``)
------------------------------------------------------
- *Struck light*: the direct sunlight whose first obstacle is a fin (either family, either
  side), over the design's sun directions with their weights. Each direction is sampled by
  parallel rays on a jittered grid perpendicular to it; a ray stands for its cross-section
  area (m^2, i.e. W per W/m^2 of direct normal irradiance).
- *On target*: struck light that meets the lit side of the target after specular
  reflections (every fin side a perfect mirror, at most ``max_bounces`` reflections).
- *Elsewhere*: struck light that leaves the fins and misses the target's lit side (into
  the room, back to the sky, onto the ceiling beside the target, onto its unlit side).
- *Trapped*: still between fins after ``max_bounces`` reflections (counted separately).

Shares are ``sum_k w_k area_k(outcome) / sum_k w_k area_k(struck)`` over sun directions k.
The design surface is not an obstacle (glazing) and the room is not modelled: light that
leaves the fins travels on until it meets the target or nothing.

Conventions: lengths in model units; sun vectors point from the site towards the sun, light
propagates along ``-sun``; the target's face normals point to its lit side.

Examples
--------
>>> import numpy as np, trimesh
>>> mirror = trimesh.Trimesh([[-.5, 0, -.5], [.5, 0, -.5], [.5, 1, .5], [-.5, 1, .5]],
...                          [[0, 1, 2], [0, 2, 3]])        # tilted 45 degrees
>>> ceiling = CeilingTarget((0.0, 0.5, 3.0), (2.0, 2.0))    # lit from below
>>> r = reflected_hits(mirror, [[0, -1, 0]], ceiling.mesh(), lit_side=TargetSide.FRONT)
>>> round(r.share, 3)        # the sun on the horizon, sent straight up onto the ceiling
1.0
"""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import NamedTuple

import numpy as np
import trimesh

from torsal.light.rays import _frames, _scene, _sun_input, _unit

__all__ = [
    "reflect",
    "mirror_normals",
    "incidence_plane_normals",
    "TargetSide",
    "CeilingTarget",
    "ReflectionRays",
    "ReflectionResult",
    "reflected_hits",
    "MirrorAim",
    "best_mirror_normals",
    "ReflectionBound",
    "ideal_mirror_bound",
]

#: default number of specular reflections followed before a ray counts as trapped
MAX_BOUNCES = 8
#: at most this many sun directions take part in the search of a mirror plane (the rest are
#: represented by their nearest, :func:`_representatives`); every direction is evaluated
MAX_SEARCH_DIRECTIONS = 24


# --------------------------------------------------------------------------- mirrors
def reflect(incoming, normals) -> np.ndarray:
    """Specular reflection ``r = i - 2 <i, n> n`` of propagation directions ``i`` (unit)
    at unit normals ``n``; (k, 3) or broadcastable.

    >>> reflect([0.0, 1.0, 0.0], [0.0, -np.sqrt(0.5), np.sqrt(0.5)]).round(12) + 0.0
    array([0., 0., 1.])
    """
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


def incidence_plane_normals(incoming, normals) -> np.ndarray:
    """Unit normals of the planes of incidence: the plane through the arriving light
    direction and its reflection at a mirror of normal ``normals``, perpendicular to the
    mirror (it contains the mirror normal).

    A fin in this plane is edge-on to the light that arrives along ``incoming`` and to the
    light the mirror sends on: the other family of a reflecting support structure "kept out
    of the way of the light". NaN rows where the light meets the mirror head-on (every plane
    through the normal is a plane of incidence).

    >>> np.abs(incidence_plane_normals([0, 1, -1], [0, 0, 1])).round(4)   # the plane x = 0
    array([[1., 0., 0.]])
    """
    i = _unit(np.atleast_2d(incoming), "incoming")
    n = _unit(np.atleast_2d(normals), "normals")
    i, n = np.broadcast_arrays(i, n)
    c = np.cross(i, n)
    length = np.linalg.norm(c, axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(length > 1e-9, c / length, np.nan)


# --------------------------------------------------------------------------- target
class TargetSide(str, Enum):
    """Which side of the target counts when reflected light meets it."""

    FRONT = "front"  # only light arriving on the side the target's face normals point to
    BOTH = "both"    # light arriving on either side


@dataclass(frozen=True)
class CeilingTarget:
    """A horizontal rectangle on a ceiling, lit from below: the region reflected sunlight
    should land on.

    Parameters
    ----------
    centre : (3,) float
        Centre of the rectangle; its z is the ceiling's height (model units).
    size : (2,) float
        Width along the model's x axis and depth along its y axis (model units, > 0).

    >>> t = CeilingTarget((0.0, 6.0, 5.5), (4.0, 2.0))
    >>> t.mesh().face_normals[0], t.contains([[1.9, 6.9], [2.1, 6.0]])
    (array([ 0.,  0., -1.]), array([ True, False]))
    """

    centre: tuple[float, float, float]
    size: tuple[float, float]

    def __post_init__(self):
        c = np.asarray(self.centre, float)
        s = np.asarray(self.size, float)
        if c.shape != (3,) or not np.isfinite(c).all():
            raise ValueError(f"the target centre must be three finite numbers, got {self.centre!r}")
        if s.shape != (2,) or not np.isfinite(s).all() or (s <= 0).any():
            raise ValueError(f"the target size must be two positive lengths [w, h], got {self.size!r}")
        object.__setattr__(self, "centre", tuple(float(x) for x in c))
        object.__setattr__(self, "size", tuple(float(x) for x in s))

    @property
    def height(self) -> float:
        """z of the ceiling plane."""
        return self.centre[2]

    def mesh(self) -> trimesh.Trimesh:
        """The rectangle as two triangles whose normals point down (the lit side)."""
        cx, cy, cz = self.centre
        w, h = self.size[0] / 2, self.size[1] / 2
        corners = np.array([[cx - w, cy - h, cz], [cx + w, cy - h, cz], [cx + w, cy + h, cz],
                            [cx - w, cy + h, cz]])
        return trimesh.Trimesh(corners, [[0, 2, 1], [0, 3, 2]], process=False)

    def offsets(self, xy) -> np.ndarray:
        """(n,) Chebyshev offset of ceiling points (n, 2) from the centre in units of the
        half sizes: <= 1 inside the rectangle."""
        xy = np.atleast_2d(np.asarray(xy, float))
        half = np.asarray(self.size) / 2
        return np.max(np.abs(xy - np.asarray(self.centre[:2])) / half, axis=1)

    def contains(self, xy) -> np.ndarray:
        """(n,) bool: ceiling points (n, 2) inside the rectangle (edges included)."""
        return self.offsets(xy) <= 1.0


# --------------------------------------------------------------------------- tracing
@dataclass
class ReflectionRays:
    """The traced rays of one sun direction (for pictures and bounds).

    Attributes
    ----------
    area : float
        Cross-section each ray stands for (model units^2).
    first_hit : (m, 3) float
        Where each struck ray first meets a fin.
    first_group : (m,) int
        The group (``face_groups``) of that fin, 0 without groups.
    outcome : (m,) int8
        0 on target, 1 elsewhere, 2 trapped.
    bounces : (m,) int
        Reflections the ray made.
    touched : (m, G) bool
        The ray met a fin of group g at some reflection.
    ceiling_xy : (m, 2) float
        Where the light ends on the ceiling plane (target hits, and light crossing the plane
        upwards after leaving the fins); NaN where it never reaches it from below.
    """

    area: float
    first_hit: np.ndarray
    first_group: np.ndarray
    outcome: np.ndarray
    bounces: np.ndarray
    touched: np.ndarray
    ceiling_xy: np.ndarray


@dataclass
class ReflectionResult:
    """Outcome of :func:`reflected_hits` (definitions in the module docstring).

    Attributes
    ----------
    share : float
        Weighted share of the struck light that lands on the target (NaN if no sunlight
        strikes a fin).
    per_direction : (k,) float
        The same per sun direction (NaN where nothing is struck).
    struck_area, landed_area : (k,) float
        Cross-section (m^2, i.e. W per W/m^2 of DNI) of sunlight striking fins and of the
        part landing on the target.
    elsewhere_area, trapped_area : (k,) float
        The parts reflected away and still bouncing after ``max_bounces``.
    elsewhere_share : float
        Weighted share of the struck light reflected elsewhere.
    sun : (k, 3) float
        Sun vectors (site -> sun) used.
    weights : (k,) float
    max_bounces : int
    landed_by_bounces : (k, max_bounces) float
        Landed cross-section by the number of reflections (column 0: one reflection).
    group_struck, group_touched, group_touched_landed : (k, G) float
        Cross-section first striking group g, meeting group g at any reflection, and of the
        latter the part landing (G = 1 without ``face_groups``).
    rays : list of ReflectionRays
        Per direction.
    """

    share: float
    per_direction: np.ndarray
    struck_area: np.ndarray
    landed_area: np.ndarray
    elsewhere_area: np.ndarray = field(default_factory=lambda: np.zeros(0))
    trapped_area: np.ndarray = field(default_factory=lambda: np.zeros(0))
    elsewhere_share: float = float("nan")
    sun: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    weights: np.ndarray = field(default_factory=lambda: np.zeros(0))
    max_bounces: int = MAX_BOUNCES
    landed_by_bounces: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    group_struck: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    group_touched: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    group_touched_landed: np.ndarray = field(default_factory=lambda: np.zeros((0, 1)))
    rays: list = field(default_factory=list)


def _jittered_grid(res: int, rng) -> tuple[np.ndarray, np.ndarray]:
    """(res*res,) u, v in [0, 1): one uniformly jittered sample per cell of a res x res
    grid (no aliasing against regularly spaced fins)."""
    i, j = np.meshgrid(np.arange(res), np.arange(res), indexing="ij")
    u = (i.ravel() + rng.random(res * res)) / res
    v = (j.ravel() + rng.random(res * res)) / res
    return u, v


class _Scene(NamedTuple):
    fins: object          # _RayScene of the fins
    target: object        # _RayScene of the target
    normals: np.ndarray   # (F, 3) fin face normals
    groups: np.ndarray    # (F,) group of each fin face
    n_groups: int
    target_normals: np.ndarray  # (T, 3)
    front_only: bool
    eps: float
    ceiling: float | None


def _hit_points(sc: _Scene, o, d, prim, t):
    """Hit points (``t`` from ``first_hit`` is already the float64 distance to the hit
    triangle's plane), the triangles' unit normals and ``d . n``."""
    n = sc.normals[prim]
    return o + t[:, None] * d, n, np.einsum("ij,ij->i", d, n)


def _trace_direction(sc: _Scene, s: np.ndarray, origins: np.ndarray, area: float,
                     max_bounces: int) -> ReflectionRays:
    """Follow the parallel rays ``origins + t (-s)`` through their reflections."""
    d = np.broadcast_to(-s, origins.shape).copy()
    t_f, prim = sc.fins.first_hit(origins, d)
    t_t, _ = sc.target.first_hit(origins, d)
    struck = np.isfinite(t_f) & ~(t_t < t_f)
    o, d, prim, t_f = origins[struck], d[struck], prim[struck], t_f[struck]
    m = len(o)
    outcome = np.full(m, 2, np.int8)
    bounces = np.zeros(m, np.int64)
    touched = np.zeros((m, sc.n_groups), bool)
    ceiling_xy = np.full((m, 2), np.nan)
    first_hit = np.zeros((m, 3))
    first_group = sc.groups[prim] if m else np.zeros(0, np.int64)
    alive = np.arange(m)
    for b in range(max_bounces):
        if not alive.size:
            break
        h, n, dn = _hit_points(sc, o[alive], d[alive], prim[alive], t_f[alive])
        if b == 0:
            first_hit[alive] = h
        touched[alive, sc.groups[prim[alive]]] = True
        bounces[alive] += 1
        r = d[alive] - 2.0 * dn[:, None] * n
        o2 = h - np.sign(dn)[:, None] * n * sc.eps   # step off the fin on the lit side
        tf2, p2 = sc.fins.first_hit(o2, r)
        tt2, q2 = sc.target.first_hit(o2, r)
        on_target = np.isfinite(tt2) & (tt2 < tf2)
        lit = on_target.copy()
        if sc.front_only and on_target.any():
            lit[on_target] = np.einsum("ij,ij->i", r[on_target],
                                       sc.target_normals[q2[on_target]]) < 0
        leaves = ~np.isfinite(tf2) & ~on_target
        outcome[alive[lit]] = 0
        outcome[alive[(on_target & ~lit) | leaves]] = 1
        if lit.any():
            ceiling_xy[alive[lit]] = (o2[lit] + tt2[lit, None] * r[lit])[:, :2]
        if sc.ceiling is not None and leaves.any():
            up = leaves & (r[:, 2] > 1e-12) & (o2[:, 2] < sc.ceiling)
            t_c = (sc.ceiling - o2[up, 2]) / r[up, 2]
            ceiling_xy[alive[up]] = (o2[up] + t_c[:, None] * r[up])[:, :2]
        cont = ~on_target & ~leaves
        nxt = alive[cont]
        o[nxt], d[nxt], prim[nxt], t_f[nxt] = o2[cont], r[cont], p2[cont], tf2[cont]
        alive = nxt
    return ReflectionRays(area, first_hit, np.asarray(first_group, np.int64), outcome, bounces,
                          touched, ceiling_xy)


def reflected_hits(fins: trimesh.Trimesh, sun, target_region: trimesh.Trimesh, *,
                   resolution: int = 256, weights=None, max_bounces: int = MAX_BOUNCES,
                   lit_side: TargetSide = TargetSide.BOTH, face_groups=None,
                   ceiling: float | None = None, seed: int | None = 0) -> ReflectionResult:
    """Where the sunlight striking the fins goes after specular reflections.

    For each sun direction ``resolution**2`` parallel rays (equal flux each, one per cell of
    a jittered grid over the fins' outline seen from the sun) are cast along ``-sun``; rays
    that meet the target before any fin are not counted. At each fin hit the ray is
    reflected specularly (both fin sides mirror) and followed until it meets the target,
    leaves the fins, or has made ``max_bounces`` reflections.

    Parameters
    ----------
    fins : trimesh.Trimesh
        e.g. ``SupportStructure.fin_mesh()``.
    sun : SunDirections or (k, 3) float
        Sun vectors (site -> sun).
    target_region : trimesh.Trimesh
        e.g. :meth:`CeilingTarget.mesh`; its face normals point to its lit side.
    resolution : int, default 256
        Rays per direction = ``resolution**2``.
    weights : (k,) float, optional
        Per-direction weights (default ``sun.weights`` or 1).
    max_bounces : int, default 8
    lit_side : TargetSide, default BOTH
        ``FRONT``: light meeting the target from behind its face normals counts as elsewhere.
    face_groups : (F,) int, optional
        A group per fin triangle (e.g. the fin family ``np.repeat(structure.edge_family, 2)``)
        for the per-group cross-sections.
    ceiling : float, optional
        z of the ceiling plane: where light leaving the fins upwards crosses it is recorded
        (``rays[j].ceiling_xy``) for pictures.
    seed : int, optional
        Seed of the jitter.

    Returns
    -------
    ReflectionResult

    Examples
    --------
    >>> floor = trimesh.Trimesh([[0, -1, 0], [1, -1, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])
    >>> wall = trimesh.Trimesh([[0, -1, 0], [0, 1, 0], [0, 1, 1], [0, -1, 1]], [[0, 1, 2], [0, 2, 3]])
    >>> r = reflected_hits(trimesh.util.concatenate([floor, wall]), [[1, 1, 1]],
    ...                    CeilingTarget((9.0, -9.0, 9.0), (9.0, 9.0)).mesh(), resolution=64)
    >>> bool(r.landed_by_bounces[0, 1] == r.landed_area[0] > 0)   # up after floor and wall
    True
    """
    s_all, w = _sun_input(sun, weights)
    if not isinstance(target_region, trimesh.Trimesh) or len(target_region.faces) == 0:
        raise ValueError("target_region must be a non-empty trimesh.Trimesh")
    if int(max_bounces) < 1:
        raise ValueError(f"max_bounces must be at least 1, got {max_bounces}")
    lit_side = TargetSide(lit_side)
    max_bounces, res = int(max_bounces), int(resolution)
    k = len(s_all)
    nf = len(fins.faces)
    if face_groups is None:
        groups = np.zeros(nf, np.int64)
    else:
        groups = np.asarray(face_groups, np.int64).ravel()
        if groups.shape != (nf,) or (groups < 0).any():
            raise ValueError(f"face_groups must be {nf} non-negative integers, one per fin triangle")
    n_groups = int(groups.max()) + 1 if nf else 1
    zeros = np.zeros(k)
    empty = ReflectionResult(float("nan"), np.full(k, np.nan), zeros.copy(), zeros.copy(),
                             zeros.copy(), zeros.copy(), float("nan"), s_all, w, max_bounces,
                             np.zeros((k, max_bounces)), np.zeros((k, n_groups)),
                             np.zeros((k, n_groups)), np.zeros((k, n_groups)), [])
    fs, ts = _scene(fins), _scene(target_region)
    if fs.n_faces == 0:
        return empty
    verts = np.asarray(fins.vertices, float)
    faces = np.asarray(fins.faces, np.int64)
    fv = verts[np.unique(faces.ravel())]
    center = fv.mean(axis=0)
    allv = np.concatenate([fv, np.asarray(target_region.vertices, float)])
    reach = 2.0 * np.linalg.norm(allv - center, axis=1).max() + 1.0
    sc = _Scene(fs, ts, np.asarray(fins.face_normals, float), groups, n_groups,
                np.asarray(target_region.face_normals, float), lit_side is TargetSide.FRONT,
                1e-6 * reach, None if ceiling is None else float(ceiling))
    rng = np.random.default_rng(seed)
    out = empty
    for j, s in enumerate(s_all):
        t1, t2 = (x[0] for x in _frames(s[None]))
        u, v = (fv - center) @ t1, (fv - center) @ t2
        du, dv = u.max() - u.min(), v.max() - v.min()
        if du <= 0 or dv <= 0:  # fins seen edge-on: no cross-section
            out.rays.append(_trace_direction(sc, s, np.zeros((0, 3)), 0.0, max_bounces))
            continue
        gu, gv = _jittered_grid(res, rng)
        origins = (center + reach * s + (u.min() + gu * du)[:, None] * t1
                   + (v.min() + gv * dv)[:, None] * t2)
        rays = _trace_direction(sc, s, origins, du * dv / res ** 2, max_bounces)
        out.rays.append(rays)
        a = rays.area
        out.struck_area[j] = a * len(rays.outcome)
        out.landed_area[j] = a * (rays.outcome == 0).sum()
        out.elsewhere_area[j] = a * (rays.outcome == 1).sum()
        out.trapped_area[j] = a * (rays.outcome == 2).sum()
        landed = rays.outcome == 0
        out.landed_by_bounces[j] = a * np.bincount(rays.bounces[landed] - 1,
                                                    minlength=max_bounces)[:max_bounces]
        out.group_struck[j] = a * np.bincount(rays.first_group, minlength=n_groups)
        out.group_touched[j] = a * rays.touched.sum(axis=0)
        out.group_touched_landed[j] = a * rays.touched[landed].sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        out.per_direction = out.landed_area / out.struck_area
    total = (w * out.struck_area).sum()
    if total > 0:
        out.share = float((w * out.landed_area).sum() / total)
        out.elsewhere_share = float((w * out.elsewhere_area).sum() / total)
    return out


# --------------------------------------------------------------------------- design and bound
class MirrorAim(NamedTuple):
    """Outcome of :func:`best_mirror_normals`.

    normals : (n, 3) float
        Unit mirror normals, facing the arriving light.
    lands : (n, k) bool
        Sun direction k reflected at point i by that mirror lands in the target.
    share : (n,) float
        Weighted share of the sun directions landing, per point.
    reachable : (n,) bool
        The point lies below the ceiling plane (only from there can light reach the
        ceiling's underside); unreachable points get the mirror towards the target centre.
    """

    normals: np.ndarray
    lands: np.ndarray
    share: np.ndarray
    reachable: np.ndarray


def _landing(points, normals, light, target: CeilingTarget):
    """Chebyshev offsets (..., k) of where light ``light`` (k, 3) (propagation directions)
    reflected at ``points`` (..., 3) by mirrors ``normals`` (..., 3) meets the ceiling plane;
    inf where it does not go up to it."""
    z = target.height
    out = []
    for i in light:
        r = i - 2.0 * (normals @ i)[..., None] * normals
        up = (r[..., 2] > 1e-9) & (points[..., 2] < z)
        t = np.where(up, (z - points[..., 2]) / np.where(up, r[..., 2], 1.0), 0.0)
        xy = points[..., :2] + t[..., None] * r[..., :2]
        half = np.asarray(target.size) / 2
        off = np.max(np.abs(xy - np.asarray(target.centre[:2])) / half, axis=-1)
        out.append(np.where(up, off, np.inf))
    return np.stack(out, axis=-1)


def _representatives(light: np.ndarray, w: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
    """At most ``m`` of the directions (farthest-point sampling from the heaviest) with the
    weights of the directions nearest to each."""
    if len(light) <= m:
        return light, w
    pick = [int(np.argmax(w))]
    dist = 1.0 - light @ light[pick[0]]
    for _ in range(m - 1):
        pick.append(int(np.argmax(dist)))
        dist = np.minimum(dist, 1.0 - light @ light[pick[-1]])
    nearest = np.argmax(light @ light[pick].T, axis=1)
    return light[pick], np.bincount(nearest, weights=w, minlength=len(pick))


def best_mirror_normals(points, sun, target: CeilingTarget, *, weights=None, design_light=None,
                        grid: int = 15, levels: int = 5, chunk: int = 256) -> MirrorAim:
    """Per point, the mirror plane that lands the most of the design's sunlight in the target.

    One plane serves every sun direction (a fin cannot turn with the sun): its reflections
    of the k directions land at k spots that spread as the sun moves. Among the planes the
    search chooses the one with the largest weighted share of directions landing inside the
    target and, among equals, the one whose worst spot lies deepest inside (smallest
    Chebyshev offset): the spread centred in the target. The planes are charted by the aim
    point ``a`` on the ceiling plane of the mirror that sends ``design_light`` to ``a``; a
    ``grid x grid`` search over twice the target's extent, refined ``levels`` times by a
    factor 4 around the best.

    Parameters
    ----------
    points : (n, 3) float
        Mirror positions (e.g. face barycenters of mesh A).
    sun : SunDirections or (k, 3) float
        Sun vectors (site -> sun).
    target : CeilingTarget
    weights : (k,) float, optional
    design_light : (3,) float, optional
        The propagation direction the chart uses; default the weighted mean of ``-sun``.

    Returns
    -------
    MirrorAim

    Examples
    --------
    >>> t = CeilingTarget((0.0, 6.0, 6.0), (4.0, 4.0))
    >>> sun = [[0.3, -0.7, 0.65], [0.0, -0.75, 0.66], [-0.3, -0.7, 0.65]]
    >>> aim = best_mirror_normals([[0.0, 0.0, 2.0]], sun, t)
    >>> bool(aim.lands.all()), bool(aim.reachable[0])
    (True, True)
    """
    p = np.asarray(points, float).reshape(-1, 3)
    s, w = _sun_input(sun, weights)
    light = -s
    if design_light is None:
        mean = (light * w[:, None]).sum(0) if w.sum() > 0 else light.mean(0)
        d = _unit(mean[None], "the mean light direction")[0]
    else:
        d = _unit(np.atleast_2d(design_light), "design_light")[0]
    ls, lw = _representatives(light, w, MAX_SEARCH_DIRECTIONS)

    wsum = max(lw.sum(), 1e-300)
    n_out = np.zeros((len(p), 3))
    centre = np.asarray(target.centre, float)
    g = np.linspace(-1.0, 1.0, int(grid))
    for s0 in range(0, len(p), chunk):
        pc = p[s0:s0 + chunk]
        best = np.tile(centre[:2], (len(pc), 1))
        span = np.asarray(target.size, float)
        for _ in range(int(levels)):
            gx, gy = np.meshgrid(g * span[0], g * span[1], indexing="ij")
            a_xy = best[:, None, :] + np.c_[gx.ravel(), gy.ravel()][None]
            aims = np.concatenate([a_xy, np.full(a_xy.shape[:2] + (1,), centre[2])], axis=2)
            o = aims - pc[:, None, :]
            o /= np.maximum(np.linalg.norm(o, axis=2, keepdims=True), 1e-300)
            n = o - d
            n /= np.maximum(np.linalg.norm(n, axis=2, keepdims=True), 1e-300)
            off = _landing(pc[:, None, :], n, ls, target)            # (c, A, k')
            share = ((off <= 1.0) * lw).sum(axis=2) / wsum
            worst = off.max(axis=2)
            top = share >= share.max(axis=1, keepdims=True) - 1e-12
            pick = np.argmin(np.where(top, worst, np.inf), axis=1)
            rows = np.arange(len(pc))
            best = a_xy[rows, pick]
            n_out[s0:s0 + chunk] = n[rows, pick]
            span = span / 4.0
    reachable = p[:, 2] < centre[2]
    if not reachable.all():
        n_out[~reachable] = mirror_normals(d, _unit(centre - p[~reachable], "target direction"))
    lands = _landing(p, n_out, light, target) <= 1.0
    share = (lands * w).sum(axis=1) / max(w.sum(), 1e-300)
    return MirrorAim(n_out, lands, share, reachable)


class ReflectionBound(NamedTuple):
    """Outcome of :func:`ideal_mirror_bound`.

    share : float
        Weighted share of the struck light that ideal mirrors at the struck points land.
    per_direction : (k,) float
        The same per sun direction (NaN where nothing is struck).
    points : int
        Struck points evaluated.
    """

    share: float
    per_direction: np.ndarray
    points: int


def ideal_mirror_bound(result: ReflectionResult, target: CeilingTarget, *,
                       max_points: int = 1500, seed: int | None = 0) -> ReflectionBound:
    """What planar mirrors could land at best, where the sun strikes these fins.

    Every point where a traced ray first meets a fin is given the best mirror plane for all
    the design's sun directions at once (:func:`best_mirror_normals`), as if it were an
    infinitely small mirror with nothing in the way before or after it. The share of the
    struck light those mirrors land bounds what any planar fins at these places can do
    with these sun directions and this target: what is missing is the spread of the
    sunlight over the design hours, which no single plane can gather into the target
    (and points above the ceiling, which cannot light its underside).

    Parameters
    ----------
    result : ReflectionResult
        From :func:`reflected_hits`.
    target : CeilingTarget
    max_points : int
        Struck points evaluated per sun direction (a uniform subsample; every ray stands
        for the same area).

    Returns
    -------
    ReflectionBound

    Examples
    --------
    >>> t = CeilingTarget((0.0, 5.0, 6.5), (4.0, 4.0))
    >>> shelf = trimesh.Trimesh([[-1, -0.5, 2], [1, -0.5, 2], [1, 0, 2], [-1, 0, 2]],
    ...                         [[0, 1, 2], [0, 2, 3]])       # a flat light shelf
    >>> sun = [[0.3, -0.7, 0.65], [0.0, -0.75, 0.66], [-0.3, -0.7, 0.65]]
    >>> r = reflected_hits(shelf, sun, t.mesh(), resolution=32, lit_side=TargetSide.FRONT)
    >>> round(r.share, 2), round(ideal_mirror_bound(r, t).share, 2)   # flat; tilted best
    (0.64, 1.0)
    """
    rng = np.random.default_rng(seed)
    pts, owner = [], []
    for j, rays in enumerate(result.rays):
        m = len(rays.first_hit)
        idx = np.arange(m) if m <= max_points else np.sort(rng.choice(m, max_points, replace=False))
        pts.append(rays.first_hit[idx])
        owner.append(np.full(len(idx), j))
    k = len(result.sun)
    if not pts or not sum(len(x) for x in pts):
        return ReflectionBound(float("nan"), np.full(k, np.nan), 0)
    pts, owner = np.concatenate(pts), np.concatenate(owner)
    aim = best_mirror_normals(pts, result.sun, target, weights=result.weights)
    per = np.full(k, np.nan)
    for j in range(k):
        mine = owner == j
        if mine.any():
            per[j] = aim.lands[mine, j].mean()
    ok = np.isfinite(per)
    wa = result.weights * result.struck_area
    share = float((wa[ok] * per[ok]).sum() / wa[ok].sum()) if wa[ok].sum() > 0 else float("nan")
    return ReflectionBound(share, per, int(len(pts)))
