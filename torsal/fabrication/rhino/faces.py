"""The faces of an OCC solid as polygons: its meshed faces (:func:`~..plates._face_triangles`)
welded, each plane face as its boundary loops (the outer loop first, then its holes), a curved
face (a bolt hole's wall) as its triangles, a face each: the input of
:func:`~.topology._topology`.

Units: those of the solid.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..plates import _face_triangles
from .topology import _cross

#: a face of a solid is a plane face in :func:`~.brep.brep_record` if the corners of its
#: triangles lie within this fraction of the mesh's deflection of one plane (OpenCascade's
#: plane faces: 1e-11 mm and less on example 7a; a curved face's mesh: about the deflection)
PLANAR = 1e-4


class PolygonFaces(NamedTuple):
    """A solid's faces as polygons (:func:`_polygon_faces`)."""
    points: np.ndarray     #: (n, 3) the welded points
    faces: list            #: per face its loops (lists of indices into ``points``), outer first


class Welded(NamedTuple):
    """Meshed faces with their vertices merged (:func:`_weld`)."""
    points: np.ndarray     #: (n, 3) the merged vertices
    triangles: list        #: per face its triangles (m, 3) as indices into ``points``


class FaceEdges(NamedTuple):
    """One face's triangles and their directed edges (:func:`_face_edges`)."""
    kept: list             #: the triangles kept, each as a face ``[[a, b, c]]``
    directed: dict         #: their directed edges ``(a, b)`` in order (a dict as ordered set)


def _weld(faces: list) -> Welded:
    """The points (n, 3) and triangles of meshed faces ``[(vertices (k, 3), triangles (m, 3)),
    ...]``: their vertices merged where they agree to 1e-9 of the largest coordinate (at least
    1), and each face's triangles (m, 3) as indices into them (a face without triangles as an
    empty array: ``triangles`` runs along ``faces``)."""
    pts = np.concatenate([v for v, _ in faces]) if faces else np.zeros((0, 3))
    scale = max(1.0, float(np.abs(pts).max(initial=0.0)))
    _, first, ids = np.unique(np.round(pts / (1e-9 * scale)).astype(np.int64), axis=0,
                              return_index=True, return_inverse=True)
    ids = ids.ravel()
    offsets = np.cumsum([0] + [len(v) for v, _ in faces])
    welded = [ids[o:o + len(v)][t] for o, (v, t) in zip(offsets, faces)]
    return Welded(pts[first], welded)


def _membrane(tris: np.ndarray) -> set:
    """The vertex sets (sorted tuples) of triangles ``tris`` (n, 3) that occur twice with
    opposite orientations."""
    key = np.sort(tris, axis=1)
    # the orientation: the parity of the vertices' inversions (a cyclic turn keeps it)
    a, b, c = np.asarray(tris).T
    parity = ((a > b).astype(int) + (a > c) + (b > c)) % 2
    seen: dict = {}
    out = set()
    for k, par in zip(map(tuple, key.tolist()), parity.tolist()):
        if k in seen and seen[k] != par:
            out.add(k)
        seen.setdefault(k, par)
    return out


def _polygon_faces(shape, tolerance: float, threads: bool = True) -> PolygonFaces | None:
    """The points (n, 3) and faces of an OCC solid: its meshed faces (:func:`~..plates._face_triangles`)
    welded as :func:`~.mesh_brep._rhino_mesh` welds them (:func:`_weld`), without membranes
    (:func:`_membrane`), each face as its loops of point indices (the outer loop first,
    counter-clockwise seen from outside, then its holes), taken from the boundary of its
    triangles; a face whose triangles' corners are not within :data:`PLANAR` x ``tolerance``
    of one plane (a curved hole wall) as its triangles, a face each. None where a plane face's
    boundary passes a point twice or a hole lies in none of its outer loops."""
    faces = _face_triangles(shape, tolerance, threads=threads)
    if not faces:
        return None
    points, welded = _weld(faces)
    welded = [w for w in welded if len(w)]
    if not welded:
        return None
    membrane = _membrane(np.concatenate(welded))
    planar = _planar(points, welded, tolerance)
    out = []
    for g, flat in zip(welded, planar.tolist()):
        kept, directed = _face_edges(g, membrane)
        if not flat:                      # a curved face: its triangles
            out.extend(kept)
            continue
        loops = _boundary_loops(directed)
        if loops is None:
            return None
        if len(loops) == 1:
            out.append(loops)
        elif loops:
            split = _outer_and_holes(points, loops)
            if split is None:
                return None
            out.extend(split)
    return PolygonFaces(points, out) if out else None


def _planar(points: np.ndarray, welded: list, tolerance: float) -> np.ndarray:
    """Which faces (bool, one per element of ``welded``: triangles (m, 3) into ``points``
    (n, 3)) are plane faces: area vector not zero and every corner of their triangles within
    :data:`PLANAR` x ``tolerance`` (length) of the plane of their area vector through their
    first triangle's first corner."""
    n_tri = np.array([len(t) for t in welded])
    at = np.cumsum(n_tri) - n_tri
    corners = points[np.concatenate(welded)]                       # (m, 3, 3)
    area = np.add.reduceat(_cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), at)
    norm = np.linalg.norm(area, axis=1)
    z = area / np.where(norm > 0, norm, 1.0)[:, None]
    face_of = np.repeat(np.arange(len(welded)), n_tri)
    dev = np.abs(np.einsum("mkj,mj->mk", corners - corners[at][face_of, :1], z[face_of])).max(axis=1)
    return (norm > 0) & (np.maximum.reduceat(dev, at) <= PLANAR * tolerance)


def _face_edges(tris: np.ndarray, membrane: set) -> FaceEdges:
    """One face's triangles ``tris`` (m, 3) as faces and edges: ``kept`` its triangles
    that are neither degenerate (a repeated index) nor in ``membrane`` (:func:`_membrane`),
    each as a face ``[[a, b, c]]``; ``directed`` the directed edges ``(a, b)`` of the kept
    triangles, in order (a dict used as an ordered set)."""
    directed = {}
    kept = []
    for a, b, c in tris.tolist():
        if a == b or b == c or a == c or (membrane and tuple(sorted((a, b, c))) in membrane):
            continue
        kept.append([[a, b, c]])
        directed[(a, b)] = directed[(b, c)] = directed[(c, a)] = None
    return FaceEdges(kept, directed)


def _boundary_loops(directed: dict) -> list | None:
    """The closed loops (lists of point indices) of the boundary of a face of directed edges
    ``directed`` (:func:`_face_edges`): the edges whose reverse is not among them, chained end
    to start. None if the boundary passes a point twice or a chain does not close."""
    nxt = {}
    for a, b in directed:
        if (b, a) not in directed:        # on the boundary of the face
            if a in nxt:
                return None               # the boundary passes a point twice
            nxt[a] = b
    loops = []
    while nxt:
        start = next(iter(nxt))
        loop, b = [start], nxt.pop(start)
        while b != start:
            loop.append(b)
            b = nxt.pop(b, None)
            if b is None:
                return None
        loops.append(loop)
    return loops


def _outer_and_holes(points: np.ndarray, loops: list) -> list | None:
    """Faces ``[[outer, hole, ...], ...]`` of the boundary loops of one plane face: outer loops
    turn about the face's normal (the Newell vector of the largest loop), holes against it,
    each hole in the outer loop that holds its first point; None if one lies in none."""
    newell = [_newell(points[lp]) for lp in loops]
    normal = max(newell, key=lambda n: float(n @ n))
    outer = [i for i, n in enumerate(newell) if n @ normal > 0]
    faces = {i: [loops[i]] for i in outer}
    z = normal / np.linalg.norm(normal)
    x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    frame = np.stack([x / np.linalg.norm(x), np.cross(z, x / np.linalg.norm(x))], axis=1)
    for i, n in enumerate(newell):
        if i in faces:
            continue
        p = points[loops[i][0]] @ frame
        holder = [j for j in outer if _inside(p, points[loops[j]] @ frame)]
        if len(holder) != 1:
            return None
        faces[holder[0]].append(loops[i])
    return list(faces.values())


def _newell(p: np.ndarray) -> np.ndarray:
    """Newell vector (twice the vector area) of a closed polygon (k, 3)."""
    q = p - p.mean(axis=0)
    return np.cross(q, np.roll(q, -1, axis=0)).sum(axis=0)


def _inside(p: np.ndarray, poly: np.ndarray) -> bool:
    """Whether 2d point ``p`` lies inside polygon ``poly`` (k, 2) (crossing number)."""
    x, y = poly[:, 0], poly[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cross = (y > p[1]) != (y1 > p[1])
    with np.errstate(divide="ignore", invalid="ignore"):
        xs = x + (p[1] - y) * (x1 - x) / (y1 - y)
    return bool(np.count_nonzero(cross & (p[0] < xs)) % 2)
