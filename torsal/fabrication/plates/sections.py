"""The geometry of the direct slot cut (:mod:`.polygon_cut`): its tolerances and
:class:`_Decline`, the slot boxes' corners and faces, plane frames, the sections of boxes and of
a closed polyhedron by planes (shapely polygons in the planes' frames), and the box faces
grouped by plane."""
from __future__ import annotations

import math

import numpy as np

from ..model import _cross


#: model units (``unit``): the direct slot cut (:func:`_cut_polyhedron`) declines, leaving the
#: part to OpenCascade's boolean (whose tolerance is 1e-7), where a corner lies this near a
#: plane it is cut by, or two corners of the result lie this near each other
_DIRECT_GAP = 1e-6

#: model units: the copies of one corner computed in the planes of its faces are one vertex
#: within this distance
_DIRECT_MERGE = 1e-8

#: radians: faces of two boxes this near one plane make the direct cut decline unless they are
#: on one plane to 1e-12 (the bottoms of a slot's two boxes: one face)
_DIRECT_PARALLEL = 1e-6

#: radians: adjacent faces of the result this near parallel make the direct cut decline:
#: OpenCascade's face unification merges faces parallel to 1e-12 (and 1e-7 apart), and the
#: faces in between are left to it (the two triangles of a warped panel are 2e-9 apart on
#: example 7a, and stay two faces either way)
_DIRECT_SAME_PLANE = 1e-10


class _Decline(ValueError):
    """The direct slot cut does not apply to a part (a degenerate or unexpected configuration):
    the boolean cuts it."""


def _plane_axes(n: np.ndarray) -> np.ndarray:
    """Unit axes (..., 2, 3) ``e1, e2`` of planes with the unit normals ``n`` (..., 3),
    ``e1 x e2 = n``: ``e1`` is ``n`` crossed with the coordinate axis it is least along."""
    n = np.asarray(n, float)
    if n.shape == (3,):
        return _plane_axes_one(n)
    least = np.argmin(np.abs(n), axis=-1)
    e1 = _cross(n, np.eye(3)[least])
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    return np.stack([e1, _cross(n, e1)], axis=-2)


def _plane_axes_one(n: np.ndarray) -> np.ndarray:
    """:func:`_plane_axes` of one normal (3,), bit for bit: the same products, sums and
    quotients on Python floats (a tenth of the array route's time; once per box face of every
    slotted part)."""
    x = n.tolist()
    least = int(np.argmin(np.abs(n)))
    b = [1.0 if k == least else 0.0 for k in range(3)]
    e1 = [x[1] * b[2] - x[2] * b[1], x[2] * b[0] - x[0] * b[2], x[0] * b[1] - x[1] * b[0]]
    length = math.sqrt(0.0 + e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2])
    e1 = [v / length for v in e1]
    e2 = [x[1] * e1[2] - x[2] * e1[1], x[2] * e1[0] - x[0] * e1[2], x[0] * e1[1] - x[1] * e1[0]]
    return np.array([e1, e2])


_BITS = (np.arange(8)[:, None] >> np.arange(3)) & 1               # corner i: bit k along axis k
_BOX_EDGES = np.array([(i, i | 1 << k) for k in range(3) for i in range(8) if not i >> k & 1])
# each face (axis k, side) as a cycle of corner ids
_BOX_FACES = np.array([[int(np.flatnonzero((_BITS[:, k] == side) & (_BITS[:, p] == bp)
                                           & (_BITS[:, q] == bq))[0])
                        for bp, bq in ((0, 0), (1, 0), (1, 1), (0, 1))]
                       for k, p, q in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) for side in (0, 1)])


def _box_geometry(frames: list):
    """Corners (B, 8, 3) and unit axes (B, 3, 3) of the boxes that :func:`_box` makes of
    ``frames`` (OpenCascade's axes: z along ``z_dir``, x the part of ``x_dir`` square to it,
    y = z x x; corner i at ``origin + bit0 length x + bit1 width y + bit2 height z``)."""
    origin, x_dir, z_dir = (np.array([f[i] for f in frames], float) for i in range(3))
    size = np.array([f[3:6] for f in frames], float)
    z = z_dir / np.linalg.norm(z_dir, axis=1, keepdims=True)
    x = x_dir - np.einsum("bi,bi->b", x_dir, z)[:, None] * z
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    axes = np.stack([x, _cross(z, x), z], axis=1)
    return origin[:, None] + np.einsum("ck,bk,bki->bci", _BITS, size, axes), axes


def _rings(xy: np.ndarray, sizes) -> np.ndarray:
    """Shapely polygons of consecutive rings of ``xy`` (N, 2) with ``sizes`` corners each."""
    import shapely

    sizes = np.asarray(sizes)
    return shapely.polygons(shapely.linearrings(xy, indices=np.repeat(np.arange(len(sizes)), sizes)))


def _box_sections(corners: np.ndarray, normals: np.ndarray, offsets: np.ndarray,
                  origins: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """The sections of boxes (corners (P, 8, 3)) by planes ``x.n = d`` (``normals`` (P, 3),
    ``offsets`` (P,)), pair by pair, as shapely polygons (P,) in the planes' frames
    (``origins`` (P, 3), ``axes`` (P, 2, 3)); None where a plane misses its box."""
    s = np.einsum("pci,pi->pc", corners, normals) - offsets[:, None]
    if (np.abs(s) <= _DIRECT_GAP).any():
        raise _Decline("a box corner on a plane it is cut by")
    i, j = _BOX_EDGES.T
    si, sj = s[:, i], s[:, j]
    hit = si * sj < 0                                                      # (P, 12)
    t = np.where(hit, si / np.where(hit, si - sj, 1.0), 0.0)
    p = corners[:, i] + t[..., None] * (corners[:, j] - corners[:, i])
    xy = np.einsum("pei,pki->pek", p - origins[:, None], axes)              # (P, 12, 2)
    count = hit.sum(axis=1)
    centre = (xy * hit[..., None]).sum(axis=1) / np.maximum(count, 1)[:, None]
    angle = np.where(hit, np.arctan2(xy[..., 1] - centre[:, None, 1], xy[..., 0] - centre[:, None, 0]),
                     np.inf)
    xy = np.take_along_axis(xy, np.argsort(angle, axis=1)[..., None], axis=1)
    out = np.full(len(s), None, object)
    ok = count > 0
    if ok.any():
        out[ok] = _rings(xy[ok][np.arange(12)[None] < count[ok][:, None]], count[ok])
    return out


class _Edges:
    """The edges of a closed polyhedron's faces (``loops`` of point ids): per directed edge
    its corners ``a -> b``, its face and the id of the undirected edge."""

    def __init__(self, loops: list):
        self.sizes = np.array([len(x) for x in loops])
        self.starts = np.r_[0, np.cumsum(self.sizes)[:-1]]
        self.face = np.repeat(np.arange(len(loops)), self.sizes)
        self.a = np.concatenate(loops)
        nxt = np.arange(1, len(self.a) + 1)
        nxt[self.starts + self.sizes - 1] = self.starts          # each loop's last corner -> first
        self.b = self.a[nxt]
        lo, hi = np.minimum(self.a, self.b), np.maximum(self.a, self.b)
        _, self.uid = np.unique(lo * (hi.max() + 1) + hi, return_inverse=True)


def _polyhedron_section(points: np.ndarray, edges: _Edges, normals: np.ndarray, n, s,
                        origin, axes) -> list:
    """The section of a closed polyhedron (``points``, the ``edges`` of its outward faces, their
    unit ``normals``) by a plane of normal ``n`` (``s``: the signed distances of the points
    from it) as shapely polygons in the plane's frame (``origin``, ``axes`` (2, 3)): the
    segments the faces cut from the plane, chained by the edges they cross."""
    hit = np.flatnonzero(s[edges.a] * s[edges.b] < 0)          # in face order
    if not len(hit):
        return []
    lo, hi = np.minimum(edges.a[hit], edges.b[hit]), np.maximum(edges.a[hit], edges.b[hit])
    t = s[lo] / (s[lo] - s[hi])          # from the lower id: one point per undirected edge
    xyz = points[lo] + t[:, None] * (points[hi] - points[lo])
    uid, face = edges.uid[hit], edges.face[hit]
    counts = np.bincount(face)
    if (counts % 2).any():
        raise _Decline("a face crosses a plane an odd number of times")
    if (counts > 2).any():           # a face that is not convex: pair the points along the line
        order = []
        for f in np.flatnonzero(counts):
            idx = np.flatnonzero(face == f)
            if len(idx) > 2:
                idx = idx[np.argsort(xyz[idx] @ np.cross(n, normals[f]))]
            order += idx.tolist()
        pairs = np.array(order).reshape(-1, 2)
    else:
        pairs = np.arange(len(hit)).reshape(-1, 2)
    links: dict = {}
    point: dict = {}
    for i, j in pairs.tolist():
        a, b = int(uid[i]), int(uid[j])
        links.setdefault(a, []).append(b)
        links.setdefault(b, []).append(a)
        point[a], point[b] = i, j
    if any(len(v) != 2 for v in links.values()):
        raise _Decline("the section of the plate does not chain into loops")
    xy = (xyz - origin) @ axes.T
    rings, seen = [], set()
    for start in links:
        if start in seen:
            continue
        ring, prev, cur = [], None, start
        while cur not in seen:
            seen.add(cur)
            ring.append(point[cur])
            a, b = links[cur]
            prev, cur = cur, (b if a == prev else a)
        rings.append(ring)
    polys = list(_rings(xy[np.concatenate(rings)], [len(r) for r in rings]))
    for i, a in enumerate(polys):
        if not a.is_valid or any(a.intersects(b) for b in polys[i + 1:]):
            raise _Decline("the section of the plate is not a set of disjoint polygons")
    return polys


def _box_planes(normals: np.ndarray, corners: np.ndarray) -> list:
    """The faces of boxes (unit ``normals`` (B, 3, 3) of their axes, ``corners`` (B, 8, 3)) by
    plane: ``(outward normal, offset, [(box, face)])``; faces of several boxes that meet on
    one plane to 1e-12 (the bottoms of a slot's two boxes) share one. :class:`_Decline` where
    faces of two boxes that meet are nearly on one plane, or on one plane facing each other."""
    n = np.concatenate([[(2 * side - 1) * a[k] for k in range(3) for side in (0, 1)] for a in normals])
    face = corners[np.arange(len(n)) // 6][np.arange(len(n))[:, None], _BOX_FACES[np.arange(len(n)) % 6]]
    d = np.einsum("fi,fi->f", n, face[:, 0])
    sin = np.linalg.norm(_cross(n[:, None], n[None]), axis=2)
    cos = n @ n.T
    apart = np.abs(d[:, None] - np.where(cos > 0, 1.0, -1.0) * d[None]) >= _DIRECT_GAP
    lo, hi = face.min(axis=1) - _DIRECT_GAP, face.max(axis=1) + _DIRECT_GAP
    meet = ((lo[:, None] <= hi[None]) & (hi[:, None] >= lo[None])).all(axis=2)    # bounding boxes
    near = (sin < _DIRECT_PARALLEL) & ~apart & meet
    np.fill_diagonal(near, False)
    groups, member = [], {}
    for i in range(len(n)):
        j = next((j for j in np.flatnonzero(near[i]) if j < i), None)
        if j is None:
            member[i] = len(groups)
            groups.append((n[i], d[i], [divmod(i, 6)]))
            continue
        if not (cos[i, j] > 0 and sin[i, j] <= 1e-12):
            raise _Decline("box faces nearly on one plane")
        member[i] = member[j]
        groups[member[j]][2].append(divmod(i, 6))
    return groups
