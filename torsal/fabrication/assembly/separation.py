"""Exact cheap proofs that two solids are apart (separating axes, ray parity), so that most
touching plates skip the boolean (see :mod:`torsal.fabrication.assembly`).

Small vectorized kernels over points (m, 3) and triangles (t, 3, 3); units those of the solids.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

# the fin model's vector helper (np.cross bit for bit, cheaper on small arrays): a data-model
# kernel, not the joint builder's code, so the check stays independent of the builder
from ..model import _cross
from .occ import _Face, _face_records, _outward_normals, _plane_normal

CLEAR_TOLERANCE = 1e-7


def _extent(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(x.min(axis=-1), x.max(axis=-1))``, the same numbers (a min or max is exact whatever
    the order), taken along the first axis of a copy laid out so, or coordinate by
    coordinate for three: numpy reduces a short last axis slowly (per output element), which
    was two thirds of the separating-axis tests' time on 7a (projections on an axis (n, a, m))."""
    if x.shape[-1] == 3:
        a, b, c = x[..., 0], x[..., 1], x[..., 2]
        return np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)
    t = np.ascontiguousarray(np.moveaxis(x, -1, 0))
    return t.min(axis=0), t.max(axis=0)


def _dot3(x, y) -> np.ndarray:
    """``(x * y).sum(axis=-1)`` of vectors along a last axis of three (broadcast): the same
    products added in the same order, ``(p0 + p1) + p2``, the numbers numpy's sum gives
    (checked bit for bit on 7a's check and on random arrays), without its reduction over a
    short axis (a dozen times slower)."""
    return x[..., 0] * y[..., 0] + x[..., 1] * y[..., 1] + x[..., 2] * y[..., 2]


def _abs_max(x: np.ndarray) -> np.ndarray:
    """``np.abs(x).max(axis=(1, ...), initial=0.0)``: (k,) the largest magnitude of each
    of the ``k`` blocks of ``x`` (exact), along the first axis of a transposed copy."""
    if not x.size:
        return np.zeros(len(x))
    a = np.abs(x).reshape(len(x), -1)
    return np.maximum(np.ascontiguousarray(a.T).max(axis=0), 0.0)


def _boxes_meet(lo_a, hi_a, lo_b, hi_b) -> np.ndarray:
    """(p, t) whether box ``p`` (``lo_a``, ``hi_a``: (p, 3)) meets box ``t`` (``lo_b``,
    ``hi_b``: (t, 3)), bounds included: the comparisons of ``(lo_b[None] <= hi_a[:, None])
    .all(axis=2) & (hi_b[None] >= lo_a[:, None]).all(axis=2)``, coordinate by coordinate (no
    reduction over a last axis of three, see :func:`_extent`)."""
    out = lo_b[None, :, 0] <= hi_a[:, None, 0]
    for c in (1, 2):
        out &= lo_b[None, :, c] <= hi_a[:, None, c]
    for c in (0, 1, 2):
        out &= hi_b[None, :, c] >= lo_a[:, None, c]
    return out


def hull_clear_of_triangles(points, triangles, *, eps: float = CLEAR_TOLERANCE) -> bool:
    """Whether no triangle reaches into the convex hull of ``points`` by more than ``eps``.

    A separating-axis test: a triangle is apart from the hull when their projections on one
    axis overlap by at most ``eps`` (times the axis length). The axes are the triangle's normal,
    the normal of the points' best plane, and the cross products of the points' difference
    vectors along the hull's edges with the triangle's edges. Any axis that separates proves
    the pair apart, so the answer ``True`` is exact (up to ``eps``); ``False`` means
    *undecided* (the exact boolean decides). For the prism of a planar face swept along ``v``
    the hull's edge directions are the face's edges and ``v`` (give them as ``edges``, see
    :func:`prism_clear`); here every pair of points gives one (small point sets only).

    Parameters
    ----------
    points : (m, 3) array
    triangles : (t, 3, 3) array
        Corners of each triangle.
    eps : float

    >>> import numpy as np
    >>> cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    >>> tri = np.array([[[0.5, 0.5, 1.0], [3, 0.5, 1.0], [0.5, 3, 1.0]]])   # on the top face
    >>> hull_clear_of_triangles(cube, tri), hull_clear_of_triangles(cube, tri - [0, 0, 0.01])
    (True, False)
    """
    p = np.asarray(points, float)
    tri = np.asarray(triangles, float).reshape(-1, 3, 3)
    if not len(tri):
        return True
    i, j = np.triu_indices(len(p), 1)
    return bool(_sat_clear(p[None], (p[j] - p[i])[None], _plane_normal(p)[None], tri,
                           np.ones((1, len(tri)), bool), eps)[0])


def _inside_by_ray(point, triangles) -> bool | None:
    """Whether ``point`` lies inside the closed triangulated surface ``triangles`` (t, 3, 3):
    the parity of the crossings of one ray (Moller-Trumbore); None when that is not certain
    (the point on the surface, the ray grazing an edge or running in a triangle's plane)."""
    inside = _inside_by_rays(np.asarray(point, float)[None], triangles)[0]
    return None if inside < 0 else bool(inside)


def _inside_by_rays(points, triangles) -> np.ndarray:
    """:func:`_inside_by_ray` of many ``points`` (p, 3) against one surface at once: (p,) int,
    1 inside, 0 outside, -1 not certain."""
    d = np.array([0.5773, 0.5871, 0.5675])          # a direction no face of a model shares
    a = triangles[None, :, 0] - points[:, None]      # (p, t, 3)
    e1, e2 = triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    h = _cross(d, e2)
    det = _dot3(e1, h)
    n = _cross(e1, e2)
    nn = np.sqrt(_dot3(n, n))
    good = np.abs(det) > 1e-9 * nn
    tol = 1e-9
    # the ray runs in a triangle's plane
    unsure = (~good & (np.abs(_dot3(n, a)) <= tol * nn)).any(axis=1)
    inv = np.where(good, 1.0 / np.where(good, det, 1.0), 0.0)
    u = -_dot3(a, h) * inv
    q = _cross(-a, e1)
    v = _dot3(q, d) * inv
    w = _dot3(e2, q) * inv                           # distance along the ray
    within = good & (u > -tol) & (v > -tol) & (u + v < 1 + tol)
    edge = (np.abs(u) < tol) | (np.abs(v) < tol) | (np.abs(u + v - 1) < tol)
    # on the surface, or the ray grazes an edge or a corner
    unsure |= (within & ((np.abs(w) < tol) | (edge & (w > -tol)))).any(axis=1)
    return np.where(unsure, -1, (within & (w > 0)).sum(axis=1) % 2)


def _prism_hulls(faces: Sequence[_Face], vectors, eps: float) -> tuple:
    """The hulls of the prisms ``faces`` sweep back along ``vectors`` (p, 3): their corners
    (p, 2m, 3: the face's ``corners``, each vertex once, where known, and their translates;
    a face with fewer corners repeats its first, which leaves the hull as it is),
    edge directions (p, k, 3; zero rows give no axis), face normals (p, 3) and boxes grown by
    ``eps`` (two (p, 3))."""
    nf = len(faces)
    v = np.broadcast_to(np.asarray(vectors, float), (nf, 3))
    corners = [f.points if f.corners is None else f.corners for f in faces]
    m = max(len(c) for c in corners)
    k = max(len(f.edges) for f in faces) + 1
    pts = np.empty((nf, 2 * m, 3))
    edges = np.zeros((nf, k, 3))
    for n, (f, c) in enumerate(zip(faces, corners)):
        fp = np.concatenate([c, c[:1].repeat(m - len(c), axis=0)])
        pts[n, :m], pts[n, m:] = fp, fp - v[n]
        edges[n, :len(f.edges)] = f.edges
        edges[n, len(f.edges)] = v[n]
    normals = np.array([f.normal for f in faces])
    return pts, edges, normals, pts.min(axis=1) - eps, pts.max(axis=1) + eps


def prisms_clear(faces: Sequence[_Face], vectors, other_triangles: np.ndarray,
                 other_box: np.ndarray, *, eps: float = CLEAR_TOLERANCE,
                 triangle_boxes=None) -> np.ndarray:
    """:func:`prism_clear` of many face prisms against one other solid at once: ``vectors``
    (p, 3) or (3,), one per face or shared. Returns (p,) bool (True: proved apart)."""
    tri = other_triangles
    boxes = triangle_boxes if triangle_boxes is not None else (tri.min(axis=1), tri.max(axis=1))
    return prisms_clear_of_each(faces, vectors, [(tri, other_box, boxes)],
                                np.ones((len(faces), 1), bool), eps=eps)[:, 0]


def prisms_clear_of_each(faces: Sequence[_Face], vectors, others: Sequence[tuple],
                         candidates: np.ndarray, *, eps: float = CLEAR_TOLERANCE,
                         groups: np.ndarray | None = None) -> np.ndarray:
    """:func:`prisms_clear` of the prisms of ``faces`` against each of several solids in one
    vectorized pass (one call per solid cost more in numpy's per-call overhead than in
    arithmetic: a part's path meets a dozen others). ``others``: per solid ``(triangles
    (t, 3, 3), box (2, 3), triangle boxes (min, max))``; ``candidates`` (p, o) bool: the
    (prism, solid) pairs to test. Returns (p, o) bool: True where a candidate pair is proved
    apart, each exactly as :func:`prisms_clear` of that solid and the candidate prisms would
    (the same axes and the same tolerance, scaled per solid); False elsewhere. ``groups``
    (p,) int: prisms tested together in :func:`prisms_clear` calls of their own (the pieces of
    one face, :func:`~.sweep.face_pieces`), so scaled per group and solid.

    >>> import numpy as np
    >>> from torsal.fabrication.assembly.occ import _Face
    >>> sq = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    >>> face = _Face(None, sq, np.roll(sq, -1, axis=0) - sq, np.array([0.0, 0.0, 1.0]))
    >>> tri = np.array([[[0, 0, 2.0], [1, 0, 2], [0, 1, 2]]])
    >>> near = (tri, np.array([[0, 0, 2.0], [1, 1, 2]]), (tri.min(axis=1), tri.max(axis=1)))
    >>> prisms_clear_of_each([face], [0, 0, 1], [near], np.ones((1, 1), bool)).tolist()
    [[True]]
    """
    nf, no = len(faces), len(others)
    out = np.zeros((nf, no), bool)
    if not nf or not no or not candidates.any():
        return out
    pts, edges, normals, lo, hi = _prism_hulls(faces, vectors, eps)
    start = np.cumsum([0] + [len(o[0]) for o in others])
    owner = np.repeat(np.arange(no), np.diff(start))
    tri = np.concatenate([o[0] for o in others]).reshape(-1, 3, 3)
    pis, tis = [], []
    for i, (_, _, (tmin, tmax)) in enumerate(others):
        p = np.flatnonzero(candidates[:, i])       # the near pairs of each solid's candidates
        a, b = np.nonzero(_boxes_meet(lo[p], hi[p], tmin, tmax))
        pis.append(p[a])
        tis.append(b + start[i])
    pi, ti = np.concatenate(pis), np.concatenate(tis)
    out[candidates] = True
    if len(pi):
        g = owner[ti] if groups is None else np.asarray(groups)[pi] * no + owner[ti]
        sep = _sat_pairs(pts, edges, normals, tri, pi, ti, g, int(g.max()) + 1, eps)
        bad = np.zeros((nf, no), bool)
        bad[pi[~sep], owner[ti[~sep]]] = True
        out &= ~bad
    # clear of a boundary: apart unless wholly inside (one ray per hull inside the box)
    for i in np.flatnonzero(out.any(axis=0)):
        box = others[i][1]
        ask = np.flatnonzero(out[:, i] & (lo >= box[0]).all(axis=1) & (hi <= box[1]).all(axis=1))
        if len(ask):
            out[ask, i] = _inside_by_rays(pts[ask].mean(axis=1), others[i][0]) == 0
    return out


def _sat_clear(pts, edges, normals, tri, near, eps) -> np.ndarray:
    """(p,) whether no near triangle reaches ``eps`` into the hull of each point set ``pts``
    (p, m, 3) with edge directions ``edges`` (p, k, 3), axis ``normals`` (p, 3); ``near``
    (p, t) selects the triangles (t, 3, 3) each is tested against (only those pairs are)."""
    pi, ti = np.nonzero(near)
    sep = _sat_pairs(pts, edges, normals, tri, pi, ti, np.zeros(len(pi), int), 1, eps)
    clear = np.ones(len(pts), bool)
    clear[pi[~sep]] = False
    return clear


def _sat_pairs(pts, edges, normals, tri, pi, ti, group, n_groups: int, eps) -> np.ndarray:
    """(n,) whether triangle ``tri[ti]`` lies more than ``eps`` outside the hull of point set
    ``pts[pi]`` along one separating axis: the triangle's normal, the set's normal
    ``normals[pi]`` and the cross products of the set's ``edges[pi]`` with the triangle's
    edges. An axis counts if longer than 1e-9 scale^2, ``scale`` the largest centred
    coordinate among the pairs of its ``group`` (one group: one solid's triangles). The two
    normals separate most pairs: the cross products are made for the others only."""
    c = pts.mean(axis=1)                               # (p, 3): centred, smaller round-off
    centred = pts - c[:, None]
    q = centred[pi]                                    # (n, m, 3)
    t = tri[ti] - c[pi][:, None]                       # (n, 3, 3)
    scale = np.ones(n_groups)
    np.maximum.at(scale, group, np.maximum(_abs_max(centred)[pi], _abs_max(t)))
    shortest = 1e-9 * (scale * scale)[group]           # (n,): parallel edges give no axis
    te = t[:, [1, 2, 0]] - t                           # (n, 3, 3) triangle edges
    sep = _separated(np.stack([_cross(te[:, 0], te[:, 1]), normals[pi]], axis=1), q, t,
                     shortest, eps)
    rest = np.flatnonzero(~sep)
    if len(rest):
        cross = _cross(edges[pi[rest]][:, :, None, :], te[rest][:, None, :, :])
        sep[rest] = _separated(cross.reshape(len(rest), -1, 3), q[rest], t[rest],
                               shortest[rest], eps)
    return sep


def _separated(axes, q, t, shortest, eps) -> np.ndarray:
    """(n,) whether one of the ``axes`` (n, a, 3) longer than ``shortest`` (n,) has the
    points ``q`` (n, m, 3) and the triangle ``t`` (n, 3, 3) more than ``eps`` (times its
    length) apart."""
    norm = np.sqrt(_dot3(axes, axes))          # (n, a)
    pp = axes @ q.transpose(0, 2, 1)                   # (n, a, m)
    tp = axes @ t.transpose(0, 2, 1)                   # (n, a, 3)
    (pmin, pmax), (tmin, tmax) = _extent(pp), _extent(tp)
    gap = np.maximum(tmin - pmax, pmin - tmax)
    return ((norm > shortest[:, None]) & (gap >= -eps * norm)).any(axis=1)


def prism_clear(face: _Face, vector, other_triangles: np.ndarray, other_box: np.ndarray,
                *, eps: float = CLEAR_TOLERANCE, triangle_boxes=None) -> bool:
    """Whether the prism that ``face`` sweeps from ``-vector`` to its place provably has no
    volume in common with the solid bounded by ``other_triangles`` (t, 3, 3) whose box is
    ``other_box`` (2, 3) (True: exact, within ``eps``; False: undecided). The prism lies in the
    convex hull of the face's corners and their translates, whose edges run along the face's
    edges and ``vector``: no boundary triangle of the other reaching into that hull
    (:func:`hull_clear_of_triangles`), and the hull not inside the other (one point, ray
    parity), leave them apart. ``triangle_boxes``: the triangles' (min, max) corners, if known."""
    return bool(prisms_clear([face], vector, other_triangles, other_box, eps=eps,
                             triangle_boxes=triangle_boxes)[0])


def solid_cover(shape, faces: list[_Face] | None = None) -> list[tuple[_Face, np.ndarray]]:
    """Prisms that cover a closed planar-faced solid: ``(face, vector)``, each face with
    ``n . w > 0`` swept back along ``vector = L w`` (a point of the solid leaves it along
    ``w`` through such a face within the solid's extent ``L`` along ``w``); ``w`` is the
    outward face normal along which the solid is thinnest (a flat plate: its thickness, one
    prism per face). Empty when a face is not planar (no cover)."""
    faces = _face_records(shape) if faces is None else faces
    normals = _outward_normals(shape, faces)
    if normals is None or not len(faces):
        return []
    verts = np.concatenate([f.points for f in faces])
    proj = verts @ normals.T
    ext = proj.max(axis=0) - proj.min(axis=0)
    k = int(np.argmin(ext))
    w = normals[k] * float(ext[k])
    return [(f, w) for f, n in zip(faces, normals) if n @ normals[k] > 0]


def solid_clear(cover: list[tuple[_Face, np.ndarray]], other_triangles: np.ndarray,
                other_box: np.ndarray, *, eps: float = CLEAR_TOLERANCE,
                triangle_boxes=None) -> bool:
    """Whether the solid covered by the prisms ``cover`` (:func:`solid_cover`) provably has no
    volume in common with the solid bounded by ``other_triangles`` (t, 3, 3), box
    ``other_box`` (True: exact within ``eps``; False: undecided): every prism is clear of it
    (:func:`prism_clear`)."""
    if not cover:
        return False
    return bool(prisms_clear([f for f, _ in cover], np.array([w for _, w in cover]),
                             other_triangles, other_box, eps=eps,
                             triangle_boxes=triangle_boxes).all())


def _triangles_apart(ta: np.ndarray, tb: np.ndarray, eps: float) -> np.ndarray:
    """(n,) whether triangles ``ta[k]`` and ``tb[k]`` (n, 3, 3) are apart by more than ``eps``
    along one of their separating axes: the two normals, the nine cross products of their
    edges and, for coplanar ones, the six normals of their edges in their planes (a complete
    set for two triangles: a pair that none of them separates touches or crosses)."""
    c = 0.5 * (ta.mean(axis=1) + tb.mean(axis=1))                      # centred: less round-off
    a, b = ta - c[:, None], tb - c[:, None]
    ea, eb = a[:, [1, 2, 0]] - a, b[:, [1, 2, 0]] - b                  # (n, 3, 3) edges
    na, nb = _cross(ea[:, 0], ea[:, 1]), _cross(eb[:, 0], eb[:, 1])
    scale = max(float(np.abs(a).max(initial=0.0)), float(np.abs(b).max(initial=0.0)), 1.0)
    shortest = 1e-9 * scale ** 3                                      # parallel edges: no axis
    # the two normals separate most pairs: the other 15 axes for the rest only
    apart = _apart(np.stack([na, nb], axis=1), a, b, shortest, eps)
    rest = np.flatnonzero(~apart)
    if len(rest):
        ea, eb, na, nb = ea[rest], eb[rest], na[rest], nb[rest]
        axes = np.concatenate([_cross(ea[:, :, None], eb[:, None]).reshape(-1, 9, 3),
                               _cross(na[:, None], ea), _cross(nb[:, None], eb)], axis=1)
        apart[rest] = _apart(axes, a[rest], b[rest], shortest, eps)
    return apart


def _apart(axes, a, b, shortest: float, eps: float) -> np.ndarray:
    """(n,) whether one of the ``axes`` (n, k, 3) longer than ``shortest`` has the triangles
    ``a`` and ``b`` (n, 3, 3) more than ``eps`` (times its length) apart."""
    norm = np.sqrt(_dot3(axes, axes))
    pa, pb = axes @ a.transpose(0, 2, 1), axes @ b.transpose(0, 2, 1)  # (n, k, 3)
    (amin, amax), (bmin, bmax) = _extent(pa), _extent(pb)
    gap = np.maximum(bmin - amax, amin - bmax)
    return ((norm > shortest) & (gap > eps * norm)).any(axis=1)


def surfaces_clear(triangles_a: np.ndarray, triangles_b: np.ndarray, box_a: np.ndarray,
                   box_b: np.ndarray, *, eps: float = CLEAR_TOLERANCE,
                   triangle_boxes=None) -> bool:
    """Whether the solids bounded by two closed triangulated surfaces ``triangles_a``,
    ``triangles_b`` (t, 3, 3; exact for planar faces), boxes ``box_a``, ``box_b`` (2, 3),
    provably have no volume in common (True: exact within ``eps``; False: undecided).

    Their boundaries are apart when every triangle of one is more than ``eps`` from every
    triangle of the other whose box meets its own (:func:`_triangles_apart`); two solids with
    boundaries apart have no volume in common unless one lies inside the other (ray parity
    of one corner, looked at only where the boxes nest). Boundaries that touch leave it
    undecided: two solids can share volume with boundaries that only touch (coplanar faces,
    an edge along a face). Unlike :func:`solid_clear` it needs no convex cover, so it proves
    apart what lies in a slot's notch or along a bent connector's legs. ``triangle_boxes``:
    the (min, max) corners of the triangles of ``b``, if known.

    >>> import numpy as np
    >>> cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    >>> quads = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    >>> tri = np.array([cube[[q[0], q[i], q[i + 1]]] for q in quads for i in (1, 2)])
    >>> box = np.array([[0.0, 0, 0], [1, 1, 1]])
    >>> surfaces_clear(tri, tri + [1.001, 0, 0], box, box + [1.001, 0, 0])
    True
    >>> surfaces_clear(tri, tri + [0.999, 0, 0], box, box + [0.999, 0, 0])
    False
    >>> small = 0.25 + 0.5 * tri                                 # inside the cube, apart from its faces
    >>> surfaces_clear(tri, small, box, 0.25 + 0.5 * box), surfaces_clear(tri, small + 2, box, 2.25 + 0.5 * box)
    (False, True)
    """
    ta = np.asarray(triangles_a, float).reshape(-1, 3, 3)
    tb = np.asarray(triangles_b, float).reshape(-1, 3, 3)
    if not len(ta) or not len(tb):
        return False
    bmin, bmax = triangle_boxes if triangle_boxes is not None else (tb.min(axis=1), tb.max(axis=1))
    amin, amax = ta.min(axis=1) - eps, ta.max(axis=1) + eps
    ia, ib = np.nonzero(_boxes_meet(amin, amax, bmin, bmax))
    if len(ia) and not _triangles_apart(ta[ia], tb[ib], eps).all():
        return False
    # boundaries apart: one inside the other is the only way left to share volume
    for t_in, box_in, t_out, box_out in ((ta, box_a, tb, box_b), (tb, box_b, ta, box_a)):
        if (box_in[0] >= box_out[0]).all() and (box_in[1] <= box_out[1]).all():
            if _inside_by_ray(t_in[0, 0], t_out) is not False:
                return False
    return True
