"""The faces of the direct slot cut made whole (:func:`_whole_faces`): the cut regions as 3D
corner loops, corners merged into one vertex table, vertices on straight edges dropped, and the
result checked to be one closed, oriented shell of distinct corners whose adjacent faces are not
on one plane, as OpenCascade's boolean cut and face unification leave it."""
from __future__ import annotations

import numpy as np

from ..model import _cross
from .faces import _fan_corners
from .sections import _DIRECT_GAP, _DIRECT_MERGE, _DIRECT_SAME_PLANE, _Decline, _Edges


def _pieces(regions: list, owners: list, planes: dict):
    """The polygons of shapely ``regions`` (in their planes' frames) as 3D corner loops:
    ``(corners (M, 3), sizes, owner of each loop)``, each loop counter-clockwise about its
    plane's normal, without the closing repeat. :class:`_Decline` where a region has a hole."""
    import shapely

    parts, which = shapely.get_parts(np.array(regions, object), return_index=True)
    keep = (shapely.get_type_id(parts) == 3) & (shapely.area(parts) > 0)
    parts, which = parts[keep], which[keep]
    if (shapely.get_num_interior_rings(parts) > 0).any():
        raise _Decline("a face with a hole")
    xy, ring = shapely.get_coordinates(shapely.get_exterior_ring(parts), return_index=True)
    sizes = np.bincount(ring, minlength=len(parts))
    starts = np.r_[0, np.cumsum(sizes)[:-1]]
    # the shoelace sum of each ring (closed by its repeated first point): clockwise ones turn
    step = xy[:-1, 0] * xy[1:, 1] - xy[1:, 0] * xy[:-1, 1]
    area = np.add.reduceat(np.r_[step, 0.0] * (np.r_[ring[1:] == ring[:-1], False]), starts)
    last = np.ones(len(xy), bool)
    last[starts + sizes - 1] = False              # drop each ring's closing repeat
    order = np.arange(len(xy))
    for k in np.flatnonzero(area < 0):
        order[starts[k]:starts[k] + sizes[k] - 1] = order[starts[k]:starts[k] + sizes[k] - 1][::-1]
    xy, ring = xy[order][last], ring[last]
    owner = np.asarray(owners)[which]
    origin, axes = (np.array([planes[o][i] for o in owner]) for i in (1, 2))
    xyz = origin[ring] + np.einsum("mk,mki->mi", xy, axes[ring])
    return xyz, sizes - 1, owner


def _whole_faces(points: np.ndarray, loops: list, normals: np.ndarray, centres: np.ndarray,
                 regions: list, owners: list, planes: dict):
    """The polyhedron of :func:`_cut_polyhedron`: the faces of ``loops`` not in ``owners``
    as they are, the others replaced by the polygons of their ``regions``, then the box faces'
    (:func:`_pieces`). Corners within :data:`_DIRECT_MERGE` are one vertex, a vertex of fewer
    than three faces is dropped (it lies on a straight edge: :func:`_straightened`), and the
    result is checked to be one closed, oriented shell of distinct corners whose adjacent faces
    are not on one plane. Returns ``(points, loops, normals, centres, volume)``, the volume by
    the divergence theorem."""
    xyz, sizes, owner = (_pieces(regions, owners, planes) if regions
                         else (np.zeros((0, 3)), np.zeros(0, int), np.zeros(0, int)))
    ids, extra = _corner_ids(points, xyz)
    new = np.split(ids, np.cumsum(sizes)[:-1]) if len(sizes) else []
    loops, normals, centres = _face_loops(loops, normals, centres, new, owner, planes)
    pts = np.concatenate([points, extra])
    loops = _straight_edges(loops, pts)
    e = _Edges(loops)
    _check_closed(e, len(loops), len(pts), normals)
    pts, loops = _compacted(pts, loops, e)
    return pts, loops, normals, centres, _polyhedron_volume(pts, loops)


def _corner_ids(points: np.ndarray, xyz: np.ndarray):
    """The vertex ids (M,) of the new faces' corners ``xyz`` (M, 3): a corner of the polyhedron
    (``points`` (V, 3)) within :data:`_DIRECT_MERGE`, else a new vertex (ids from V on, copies
    of one corner within :data:`_DIRECT_MERGE` one vertex), and the new vertices (N, 3)."""
    extra = np.zeros((0, 3))
    ids = np.zeros(0, int)
    if len(xyz):                    # the new faces' corners: a corner of the plate, or new
        diff = xyz[:, None] - points[None]
        d2 = np.einsum("mvi,mvi->mv", diff, diff)
        ids = np.argmin(d2, axis=1)
        fresh = np.flatnonzero(d2[np.arange(len(xyz)), ids] > _DIRECT_MERGE ** 2)
        if len(fresh):
            diff = xyz[fresh][:, None] - xyz[fresh][None]
            same = np.einsum("mni,mni->mn", diff, diff) <= _DIRECT_MERGE ** 2
            first = np.argmax(same, axis=1)           # the first copy of each new corner
            kept, which = np.unique(first, return_inverse=True)
            ids[fresh] = len(points) + which.ravel()
            extra = xyz[fresh][kept]
    return ids, extra


def _face_loops(loops: list, normals: np.ndarray, centres: np.ndarray, new: list,
                owner: np.ndarray, planes: dict):
    """The faces of the result in order: each face of ``loops`` not in ``planes`` as it is, or
    in its place the ``new`` loops it owns (``owner``), then the box planes' loops; returns
    ``(loops, normals (F, 3), centres (F, 3))``."""
    out, out_n, out_c = [], [], []
    pieces = iter(zip(new, owner.tolist()))
    piece = next(pieces, None)
    for f in range(len(loops) + max(planes, default=0) + 1):
        if f < len(loops) and f not in planes:
            out.append(list(map(int, loops[f])))
            out_n.append(normals[f])
            out_c.append(centres[f])
        while piece is not None and piece[1] == f:
            out.append(piece[0].tolist())
            out_n.append(planes[f][0])
            out_c.append(planes[f][1])
            piece = next(pieces, None)
    return out, np.array(out_n), np.array(out_c)


def _straight_edges(loops: list, pts: np.ndarray) -> list:
    """The ``loops`` without their vertices of fewer than three faces, which lie on a straight
    edge (:func:`_straightened`); :class:`_Decline` where two corners of a face are one vertex."""
    if any(len(set(x)) != len(x) for x in loops):
        raise _Decline("two corners of a face are one vertex")
    # a vertex of fewer than three faces lies on a straight edge: not a vertex (one where two
    # boxes' notches meet on a face, one between two faces' collinear edges)
    count = np.bincount(np.concatenate(loops), minlength=len(pts))
    if (count < 3).any():
        loops = [_straightened(loop, count >= 3, pts) for loop in loops]
    return loops


def _check_closed(e: _Edges, n_faces: int, n_points: int, normals: np.ndarray) -> None:
    """:class:`_Decline` unless every edge of the faces (``e``) is used once in each sense,
    between faces not on one plane (their unit ``normals``), and the faces are one shell."""
    key = e.a * n_points + e.b
    order = np.argsort(key)
    if (np.diff(key[order]) == 0).any():
        raise _Decline("an edge used twice in one sense")
    at = np.searchsorted(key[order], e.b * n_points + e.a)
    at = np.minimum(at, len(key) - 1)
    if not (key[order][at] == e.b * n_points + e.a).all():
        raise _Decline("the faces do not close")
    other = e.face[order][at]
    if (np.linalg.norm(_cross(normals[e.face], normals[other]), axis=1) < _DIRECT_SAME_PLANE).any():
        raise _Decline("adjacent faces (nearly) on one plane")
    # one shell: every face reached from the first across its edges
    label = np.arange(n_faces)
    while True:
        low = np.minimum(label[e.face], label[other])
        nxt = label.copy()
        np.minimum.at(nxt, e.face, low)
        nxt = nxt[nxt]                              # jump along the chains of labels
        if (nxt == label).all():
            break
        label = nxt
    if (label != 0).any():
        raise _Decline("the result is in pieces")


def _compacted(pts: np.ndarray, loops: list, e: _Edges):
    """``(points, loops)`` with only the vertices the faces use (``e``: their edges), renumbered;
    :class:`_Decline` where two of them are within :data:`_DIRECT_GAP`."""
    used = np.unique(e.a)
    diff = pts[used][:, None] - pts[used][None]
    gaps = np.einsum("mni,mni->mn", diff, diff)
    np.fill_diagonal(gaps, np.inf)
    if gaps.min() <= _DIRECT_GAP ** 2:
        raise _Decline("corners of the result too near each other")
    new_id = np.full(len(pts), -1)
    new_id[used] = np.arange(len(used))
    return pts[used], [new_id[loop] for loop in loops]


def _polyhedron_volume(pts: np.ndarray, loops: list) -> float:
    """The volume of a closed polyhedron (divergence theorem: a fan from each face's first
    corner, about the mean of the points)."""
    ref = pts.mean(axis=0)
    first, mid, last = _fan_corners(loops)
    q0, q1, q2 = pts[first] - ref, pts[mid] - ref, pts[last] - ref
    return float(np.einsum("ki,ki->", q0, _cross(q1, q2))) / 6.0


def _straightened(loop: list, keep: np.ndarray, pts: np.ndarray) -> list:
    """The corners of a face's ``loop`` that ``keep`` keeps; :class:`_Decline` unless every
    corner dropped lies on the straight edge between the corners kept before and after it
    (within :data:`_DIRECT_MERGE`), and three corners are left."""
    kept = [i for i, x in enumerate(loop) if keep[x]]
    if len(kept) < 3:
        raise _Decline("a face of fewer than three corners")
    if len(kept) == len(loop):
        return loop
    for k, i in enumerate(kept):                   # the corners between kept i and the next
        j = kept[(k + 1) % len(kept)]
        between = [loop[m % len(loop)] for m in range(i + 1, j if j > i else j + len(loop))]
        if between:
            a, b = pts[loop[i]], pts[loop[j]]
            d = (b - a) / np.linalg.norm(b - a)
            off = pts[between] - a
            along = off @ d
            if (np.linalg.norm(off - along[:, None] * d, axis=1) > _DIRECT_MERGE).any() or \
                    (along <= 0).any() or (along >= np.linalg.norm(b - a)).any():
                raise _Decline("a corner of fewer than three faces off its face's edge")
    return [loop[i] for i in kept]
