"""The plate of a part without its slots: its face outlines (top, bottom, sides, end caps), the
polyhedron of those faces (a vertex table and face loops), built as one B-rep directly
(:func:`_plate_direct`) or, where that does not close, its faces sewn (:func:`_plate_sewn`)."""
from __future__ import annotations

import numpy as np

from ..model import Part, _cross, slab_faces
from .brep import _polyhedron_solid
from .errors import InvalidSolidError
from .faces import _coplanar, _face, _fan_volume, _polygon_volumes, _triangles_inside


def _plate_outlines(part: Part, thickness: float):
    """Every face outline of a part's plate (F, 4, 3) and its orientation sign (F,): per panel
    top (``p + t/2 m``), bottom (same diagonal as the top if warped; sign -1: it is oriented
    inwards), the a side and the b side; then the start and end caps."""
    k = len(part.panels)
    top, bot = slab_faces(part.panels, part.miters, thickness)
    sides = np.stack([top, bot, np.stack([top[:, 1], top[:, 0], bot[:, 0], bot[:, 1]], 1),
                      np.stack([top[:, 3], top[:, 2], bot[:, 2], bot[:, 3]], 1)], axis=1)
    caps = np.array([[top[0, 0], top[0, 3], bot[0, 3], bot[0, 0]],
                     [top[-1, 2], top[-1, 1], bot[-1, 1], bot[-1, 2]]])
    return (np.concatenate([sides.reshape(-1, 4, 3), caps]),
            np.r_[np.tile([1.0, -1.0, 1.0, 1.0], k), 1.0, 1.0])


#: BRepBuilderAPI_Sewing's default tolerance: corners closer than this are one point when sewn
_SEW_TOL = 1e-6


def _fans(pts: np.ndarray, planar_tol: float) -> list:
    """Index lists of the planar pieces of polygons with the same number of corners
    (F, n, 3): the whole polygon if its corners are coplanar (:func:`_coplanar`), else
    triangles inside it (:func:`_triangles_inside`, as :func:`_face`)."""
    n = pts.shape[1]
    planar = np.ones(len(pts), bool) if n == 3 else _coplanar(pts, planar_tol)
    tri = _triangles_inside(pts)
    return [[list(range(n))] if ok else t.tolist() for ok, t in zip(planar, tri)]


def _distinct_rows(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(first, inverse)`` of ``np.unique(keys, axis=0, return_index=True,
    return_inverse=True)`` for integer rows ``keys`` (N, 3): the index of the first of each
    distinct row, the rows in lexicographic order, and each row's place among them; the
    same arrays by a stable lexicographic sort (a fifth of its time: ``axis=0`` sorts the
    rows as records).

    >>> [x.tolist() for x in _distinct_rows(np.array([[2, 0, 0], [1, 5, 0], [2, 0, 0]]))]
    [[1, 0], [1, 0, 1]]
    """
    order = np.lexsort(keys.T[::-1])
    rows = keys[order]
    new = np.ones(len(rows), bool)
    new[1:] = (rows[1:] != rows[:-1]).any(axis=1)
    inverse = np.empty(len(rows), np.intp)
    inverse[order] = np.cumsum(new) - 1
    return order[new], inverse


def _plate_direct(part: Part, thickness: float, planar_tol: float):
    """The plate of a part built as a B-rep directly: one vertex per distinct corner, one edge
    per pair of corners that bound a face (shared by its two faces), one planar face per
    outline on the plane through its corners (a fan of triangles where the corners are not
    coplanar, as :func:`_face`), all in one shell: no sewing and no shape healing, which find
    nothing to do on these faces and took two thirds of a part's solid. Returns the OCC solid
    (not yet validated) and the volume of the polyhedron (divergence theorem over its faces).
    ValueError where this construction does not give a closed shell (:func:`_plate` then
    sews the faces)."""
    points, loops, normals, centres, volume = _plate_polyhedron(part, thickness, planar_tol)
    return _polyhedron_solid(points, loops, normals, centres), volume


def _plate_polyhedron(part: Part, thickness: float, planar_tol: float):
    """The faces of a part's plate as :func:`_plate_direct` builds them: ``(points (V, 3),
    loops, normals (F, 3), centres (F, 3), volume)``, each loop the corner ids of one planar
    face (sewn order, oriented as the plate's outlines), its unit Newell normal and the mean of
    its corners (the face's plane), and the volume of the polyhedron (divergence theorem;
    negative where the outlines are turned inwards). ValueError where the faces would not
    make a closed shell of distinct corners."""
    outlines, sign = _plate_outlines(part, thickness)
    # the bottom turned round from its first corner (the fan's diagonal stays that of the top)
    outlines[sign < 0] = outlines[sign < 0][:, [0, 3, 2, 1]]
    # distinct corners: coincident points (collapsed corners of degenerate panels) are one vertex
    flat = outlines.reshape(-1, 3)
    if not np.abs(flat).max() < 1e6:
        raise ValueError("coordinates too large for the vertex table")
    first, ids = _distinct_rows(np.round(flat / 1e-12).astype(np.int64))
    ids = ids.reshape(outlines.shape[:2])
    points = flat[first]
    gaps = np.linalg.norm(points[:, None] - points[None], axis=2)
    np.fill_diagonal(gaps, np.inf)
    if gaps.min() <= _SEW_TOL:       # nearly coincident corners: sewing merges them
        raise ValueError("corners closer than the sewing tolerance")
    # the faces as vertex loops: quads with four distinct corners in one go, the others alone
    clean = (ids != np.roll(ids, -1, axis=1)).all(axis=1)
    loops = [ids[f][piece] for f, pieces in zip(np.flatnonzero(clean),
                                                _fans(outlines[clean], planar_tol))
             for piece in pieces]
    for f in np.flatnonzero(~clean):
        loop = np.array([x for i, x in enumerate(ids[f]) if x != ids[f][i - 1]])
        if len(loop) >= 3:
            loops += [loop[piece] for piece in _fans(points[loop][None], planar_tol)[0]]
    sizes = np.array([len(x) for x in loops])
    normals, centres, volume = [], [], 0.0
    for n in np.unique(sizes):                       # polygons of n corners (3 or 4)
        pts = points[np.array([x for x in loops if len(x) == n])]          # (F, n, 3)
        area = 0.5 * _cross(pts, np.roll(pts, -1, axis=1)).sum(axis=1)   # Newell
        normals.append(area)
        centres.append(pts.mean(axis=1))
        volume += float(_polygon_volumes(pts).sum())        # divergence theorem
    order = np.concatenate([np.flatnonzero(sizes == n) for n in np.unique(sizes)])
    normals, centres = np.concatenate(normals), np.concatenate(centres)
    length = np.linalg.norm(normals, axis=1)
    if not (length > 0).all():
        raise ValueError("a degenerate face")
    return points, [loops[f] for f in order], normals / length[:, None], centres, volume


def _plate(part: Part, thickness: float, planar_tol: float):
    """The plate of a part as a closed OCC solid (not yet validated) and the volume of the
    polyhedron it is built from (divergence theorem over its faces): built directly
    (:func:`_plate_direct`), else its faces sewn."""
    try:
        return _plate_direct(part, thickness, planar_tol)
    except ValueError:
        return _plate_sewn(part, thickness, planar_tol)


def _plate_sewn(part: Part, thickness: float, planar_tol: float):
    """:func:`_plate` by sewing faces made one by one (:func:`_face`)."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Sewing
    from OCP.ShapeFix import ShapeFix_Solid
    from OCP.TopoDS import TopoDS

    outlines, sign = _plate_outlines(part, thickness)
    # outlines without repeated corners (all but degenerate twisted sides) in one go
    clean = (np.linalg.norm(outlines - np.roll(outlines, -1, axis=1), axis=2) > 1e-12).all(axis=1)
    planar = np.zeros(len(outlines), bool)
    planar[clean] = _coplanar(outlines[clean], planar_tol)
    poly_volume = float(sign[clean] @ _polygon_volumes(outlines[clean]))
    sewing = BRepBuilderAPI_Sewing()
    for pts, sgn, ok, flat in zip(outlines, sign, clean, planar):
        for f in _face(pts, planar_tol, planar=bool(flat) if ok else None):
            sewing.Add(f)
        if not ok:
            poly_volume += sgn * _fan_volume(pts)
    sewing.Perform()
    try:
        shell = TopoDS.Shell(sewing.SewedShape())
    except Exception as e:           # a compound of pieces: OCC's Standard_TypeMismatch
        raise InvalidSolidError([part.name], f"the plate's faces do not sew into one shell "
                                f"({type(e).__name__})") from None
    if not BRep_Tool.IsClosed_s(shell):
        raise InvalidSolidError([part.name], "the plate's faces do not sew into a closed shell")
    return ShapeFix_Solid().SolidFromShell(shell), poly_volume
