"""The topology of a Brep of planar faces, as numpy arrays: its loops and trims (one per side
of a loop), the faces' planes (frames and domains), its edges (each side shared by two trims
in opposite senses) and vertices, with the tolerances openNURBS records; checked to close
(:func:`_topology`). :mod:`.records` writes it as openNURBS bytes.

Shapes: ``n`` points, ``f`` faces, ``l`` loops, ``t`` trims, ``e`` edges, ``v`` vertices.
Units: lengths those of the points; the trims' (u, v) are lengths in their face's plane.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Loops(NamedTuple):
    """The faces' loops, face by face, each face's outer loop first."""
    face: np.ndarray       #: (l,) the loop's face
    outer: np.ndarray      #: (l,) bool: an outer loop (else a hole)
    first: np.ndarray      #: (l,) the loop's first trim
    size: np.ndarray       #: (l,) its number of trims (of sides)
    per_face: list         #: (f,) the number of loops of each face


class Trims(NamedTuple):
    """The loops' sides, loop by loop, each from a point to the next point of its loop."""
    start: np.ndarray      #: (t,) the trim's first point (index into the points)
    end: np.ndarray        #: (t,) its last point
    next: np.ndarray       #: (t,) the next trim in its loop
    loop: np.ndarray       #: (t,) the trim's loop
    face: np.ndarray       #: (t,) the trim's face


class Planes(NamedTuple):
    """The faces' planes: origin the centroid of the outer loop's points, z its Newell vector
    (unit), x along its first side; the trims' ends in those frames and the faces' domains."""
    centre: np.ndarray     #: (f, 3) the plane's origin
    x: np.ndarray          #: (f, 3) unit vectors
    y: np.ndarray          #: (f, 3)
    z: np.ndarray          #: (f, 3) the outward normal
    u0: np.ndarray         #: (t,) each trim's start in its face's frame: x
    v0: np.ndarray         #: (t,) y
    d0: np.ndarray         #: (t,) its distance from the plane (signed)
    u1: np.ndarray         #: (t,) each trim's end: x
    v1: np.ndarray         #: (t,) y
    s0: np.ndarray         #: (f,) the face's domain in x: the extent of all its loops
    s1: np.ndarray         #: (f,)
    w0: np.ndarray         #: (f,) its domain in y
    w1: np.ndarray         #: (f,)


class Edges(NamedTuple):
    """The edges: each pair of points joined by a trim, from the lower index to the higher."""
    lo: np.ndarray         #: (e,) the lower point
    hi: np.ndarray         #: (e,) the higher point
    length: np.ndarray     #: (e,) length
    trims: np.ndarray      #: (e, 2) its two trims, in order
    of_trim: np.ndarray    #: (t,) each trim's edge
    forward: np.ndarray    #: (t,) bool: the trim runs from lo to hi
    tolerance: np.ndarray  #: (e,) the larger distance of its ends from its faces' planes


class Vertices(NamedTuple):
    """The vertices: the points at the ends of edges, in the points' order."""
    point: np.ndarray      #: (v,) the vertex's point (index into the points)
    lo: np.ndarray         #: (e,) each edge's vertex at its lower point
    hi: np.ndarray         #: (e,) at its higher point
    of_trim: np.ndarray    #: (t,) each trim's first vertex
    tolerance: np.ndarray  #: (v,) the largest distance from the planes of its faces


class Topology(NamedTuple):
    """A closed Brep of planar faces (:func:`_topology`)."""
    points: np.ndarray     #: (n, 3) float
    loops: Loops
    trims: Trims
    planes: Planes
    edges: Edges
    vertices: Vertices


def _topology(points: np.ndarray, faces: list) -> Topology | None:
    """The topology of a Brep of planar ``faces`` (lists of loops of indices into ``points``
    (n, 3), :func:`~.faces._polygon_faces`). None if a loop has fewer than three points, an
    edge is not on exactly two faces in opposite senses, a side or a face is degenerate, or
    the faces enclose no volume (they face inwards)."""
    pts = np.asarray(points, float)
    found = _loops_and_trims(faces)
    if found is None:
        return None
    loops, trims = found.loops, found.trims
    planes = _planes(pts, loops, trims, len(faces))
    if planes is None:
        return None
    edges = _edges(pts, trims, planes)
    if edges is None or not _volume(pts, trims, planes) > 0:
        return None
    return Topology(pts, loops, trims, planes, edges, _vertices(edges, trims, planes))


class _LoopsTrims(NamedTuple):
    """The loops and the trims of faces (:func:`_loops_and_trims`)."""
    loops: Loops
    trims: Trims


def _loops_and_trims(faces: list) -> _LoopsTrims | None:
    """The loops and trims of ``faces`` (lists of loops of point indices); None if there is
    no loop or one has fewer than three points."""
    loops = [lp for face in faces for lp in face]
    n_loop = np.array([len(lp) for lp in loops])
    if len(loops) == 0 or n_loop.min() < 3:
        return None
    per_face = [len(f) for f in faces]
    loop_face = np.repeat(np.arange(len(faces)), per_face)
    outer = np.concatenate([[True] + [False] * (len(f) - 1) for f in faces])
    start = np.concatenate(loops)                          # each trim's first point
    n_t = len(start)
    first = np.cumsum(n_loop) - n_loop                     # each loop's first trim
    t_loop = np.repeat(np.arange(len(loops)), n_loop)
    nxt = np.arange(1, n_t + 1)
    nxt[first + n_loop - 1] = first                        # the next trim in the loop
    return _LoopsTrims(Loops(loop_face, outer, first, n_loop, per_face),
                       Trims(start, start[nxt], nxt, t_loop, loop_face[t_loop]))


def _planes(pts: np.ndarray, loops: Loops, trims: Trims, n_faces: int) -> Planes | None:
    """The faces' planes (:class:`Planes`) from their outer loops, the trims' ends in them and
    the faces' domains; None if a face's Newell vector or first side (across the normal) is
    zero or not finite."""
    start, end, t_face = trims.start, trims.end, trims.face
    on_outer = loops.outer[trims.loop]
    face_first = loops.first[loops.outer]                  # each face's first trim
    count = np.bincount(t_face[on_outer], minlength=n_faces)
    at = np.cumsum(count) - count                          # (in the outer loops' trims)
    centre = np.add.reduceat(pts[start[on_outer]], at) / count[:, None]
    q0 = pts[start] - centre[t_face]
    q1 = pts[end] - centre[t_face]
    newell = np.add.reduceat(_cross(q0, q1)[on_outer], at)
    norm = np.linalg.norm(newell, axis=1)
    side = pts[end[face_first]] - pts[start[face_first]]
    if not np.all(norm > 0) or not np.all(np.isfinite(norm)):
        return None
    z = newell / norm[:, None]
    x = side - np.einsum("ij,ij->i", side, z)[:, None] * z
    xn = np.linalg.norm(x, axis=1)
    if not np.all(xn > 0):
        return None
    x /= xn[:, None]
    y = _cross(z, x)
    # the trims' ends in their face's frame: u, v and the distance from the plane
    u0, v0, d0 = (np.einsum("ij,ij->i", q0, w[t_face]) for w in (x, y, z))
    u1, v1 = u0[trims.next], v0[trims.next]
    # the faces' domains (the extent of all their loops)
    s0, s1 = np.minimum.reduceat(u0, face_first), np.maximum.reduceat(u0, face_first)
    w0, w1 = np.minimum.reduceat(v0, face_first), np.maximum.reduceat(v0, face_first)
    return Planes(centre, x, y, z, u0, v0, d0, u1, v1, s0, s1, w0, w1)


def _edges(pts: np.ndarray, trims: Trims, planes: Planes) -> Edges | None:
    """The edges of the trims (:class:`Edges`); None if a trim's ends are one point, an edge
    is not on exactly two trims in opposite senses, or one is not longer than 1e-9 of the
    largest coordinate (at least 1)."""
    start, end = trims.start, trims.end
    lo, hi = np.minimum(start, end), np.maximum(start, end)
    if np.any(lo == hi):
        return None
    key = lo * len(pts) + hi
    _, e_first, t_edge, e_count = np.unique(key, return_index=True, return_inverse=True,
                                            return_counts=True)
    t_edge = t_edge.ravel()
    forward = start < end
    if np.any(e_count != 2) or np.any(np.bincount(t_edge, weights=forward) != 1):
        return None
    n_e = len(e_first)
    e_lo, e_hi = lo[e_first], hi[e_first]
    length = np.linalg.norm(pts[e_hi] - pts[e_lo], axis=1)
    if not np.all(length > 1e-9 * max(1.0, float(np.abs(pts).max()))):
        return None
    e_trims = np.argsort(t_edge, kind="stable").reshape(n_e, 2)
    # tolerances: the distance of the ends from the faces' planes
    dev = np.abs(planes.d0)
    t_tol = np.maximum(dev, dev[trims.next])
    e_tol = np.maximum(t_tol[e_trims[:, 0]], t_tol[e_trims[:, 1]])
    return Edges(e_lo, e_hi, length, e_trims, t_edge, forward, e_tol)


def _volume(pts: np.ndarray, trims: Trims, planes: Planes) -> float:
    """The volume the faces enclose (the divergence theorem over the fans of their trims about
    their planes' origins): > 0 when they face out."""
    return np.einsum("ij,ij->", pts[trims.start], _cross(pts[trims.end], planes.centre[trims.face])) / 6.0


def _vertices(edges: Edges, trims: Trims, planes: Planes) -> Vertices:
    """The vertices of the edges (:class:`Vertices`), each one's tolerance the largest distance
    of its point from the planes of the faces of the trims that start at it."""
    n_e = len(edges.lo)
    used, vi = np.unique(np.concatenate([edges.lo, edges.hi]), return_inverse=True)
    vi = vi.ravel()
    v_tol = np.zeros(len(used))
    t_v0 = np.searchsorted(used, trims.start)              # each trim's first vertex
    np.maximum.at(v_tol, t_v0, np.abs(planes.d0))
    return Vertices(used, vi[:n_e], vi[n_e:], t_v0, v_tol)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross products of (n, 3) arrays (np.cross costs more on small arrays)."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=1)
