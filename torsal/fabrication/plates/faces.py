"""Polygons as faces: planar OCC faces through corner points (:func:`_face`), the coplanarity
test, the triangles that tile a polygon whose corners are not coplanar, and the signed volume
contributions of polygons as faces of a closed surface (divergence theorem)."""
from __future__ import annotations

import numpy as np

from ..model import _cross


#: build123d's point tolerance: a polygon whose last point is farther than this from its first
#: is closed by repeating the first (as ``Wire.make_polygon(close=True)``)
_CLOSE_TOL = 1e-6


def _dedup(points) -> np.ndarray:
    """Points (n, 3) without consecutive repeats (degenerate twisted sides) and without a last
    point repeating the first."""
    pts = np.asarray(points, float)
    keep = np.r_[True, np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-12]
    pts = pts[keep]
    if len(pts) > 3 and np.linalg.norm(pts[-1] - pts[0]) <= 1e-12:
        pts = pts[:-1]
    return pts


def _polygon_face(pts: np.ndarray):
    """Planar OCC face bounded by the closed polygon ``pts`` (n, 3), built as build123d's
    ``Face(Wire.make_polygon(pts, close=True))`` does (same OCC calls: the wire is fixed,
    the face made on its plane and its orientation fixed). ValueError if OpenCascade finds
    the points not coplanar."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakePolygon
    from OCP.BRepLib import BRepLib_FindSurface
    from OCP.gp import gp_Pnt
    from OCP.ShapeFix import ShapeFix_Face, ShapeFix_Shape
    from OCP.TopoDS import TopoDS

    poly = BRepBuilderAPI_MakePolygon()
    for p in pts:
        poly.Add(gp_Pnt(float(p[0]), float(p[1]), float(p[2])))
    if np.linalg.norm(pts[0] - pts[-1]) > _CLOSE_TOL:
        poly.Add(gp_Pnt(float(pts[0, 0]), float(pts[0, 1]), float(pts[0, 2])))
    wire = poly.Wire()
    if not BRep_Tool.IsClosed_s(wire):
        raise ValueError("Face can only be created with closed wires")
    if not BRepLib_FindSurface(wire, OnlyPlane=True).Found():
        raise ValueError("Cannot build face(s): wires not planar")
    fix = ShapeFix_Shape(wire)
    fix.Perform()
    maker = BRepBuilderAPI_MakeFace(TopoDS.Wire(fix.Shape()), True)
    maker.Build()
    if not maker.IsDone():
        raise ValueError(f"Cannot build face(s): {maker.Error()}")
    face_fix = ShapeFix_Face(maker.Face())
    face_fix.FixOrientation()
    face_fix.Perform()
    return TopoDS.Face(face_fix.Result())


def _face(points, planar_tol: float, planar: bool | None = None) -> list:
    """OCC faces through the points: one planar face, or triangles (:func:`_triangles_inside`)
    if they are not coplanar (to ``min(planar_tol * size, 1e-9)`` in absolute units, below
    OpenCascade's 1e-7). ``planar``: that test, done already (by :func:`_coplanar`) for points without
    repeats."""
    pts = _dedup(points) if planar is None else np.asarray(points, float)
    if len(pts) < 3:
        return []
    if planar is None:
        planar = len(pts) == 3 or bool(_coplanar(pts[None], planar_tol)[0])
    if planar:
        try:
            return [_polygon_face(pts)]
        except ValueError:       # OpenCascade finds it not planar enough: use triangles
            if len(pts) == 3:
                raise
    return [_polygon_face(pts[t]) for t in _triangles_inside(pts[None])[0]]


def _coplanar(pts: np.ndarray, planar_tol: float) -> np.ndarray:
    """Whether each polygon of ``pts`` (F, n, 3) is within ``min(planar_tol * size, 1e-9)`` of
    its best-fit plane (size: its bounding-box diagonal)."""
    c = pts.mean(axis=1, keepdims=True)
    normal = np.linalg.svd(pts - c)[2][:, 2]                                  # (F, 3)
    size = np.linalg.norm(pts.max(axis=1) - pts.min(axis=1), axis=1)
    off = np.abs(np.einsum("fni,fi->fn", pts - c, normal)).max(axis=1)
    return off <= np.minimum(planar_tol * size, 1e-9)


def _triangles_inside(pts: np.ndarray) -> np.ndarray:
    """Corner indices (F, n - 2, 3) of triangles that tile each polygon of ``pts`` (F, n, 3),
    as :func:`_face` and :func:`_plate_direct` build a face whose corners are not coplanar:
    a fan from corner 0, but a quad is split on its diagonal that lies inside it, 1-3 where
    corner 1 or 3 is reflex (seen along its Newell normal): on the diagonal 0-2 outside it the
    two triangles would overlap, one turned against the other, and a solid of such faces is a
    self-overlapping shell that OpenCascade classifies, and so heals and intersects, as inside
    out (example 7c's F0-S001-P00 at 3db0016).

    >>> _triangles_inside(np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.1]]]))[0].tolist()
    [[0, 1, 2], [0, 2, 3]]
    >>> _triangles_inside(np.array([[[0, 0, 0], [2, 0, 0], [2, 2, 0], [1.5, 0.5, 0.1]]]))[0].tolist()
    [[1, 2, 3], [1, 3, 0]]
    """
    pts = np.asarray(pts, float)
    f, n = pts.shape[:2]
    fan = np.array([[0, i, i + 1] for i in range(1, n - 1)]).reshape(-1, 3)
    out = np.broadcast_to(fan, (f, n - 2, 3)).copy()
    if n == 4:
        area = _cross(pts, np.roll(pts, -1, axis=1)).sum(axis=1)             # Newell, (F, 3)
        d = pts[:, 2] - pts[:, 0]
        inside = ((np.einsum("fi,fi->f", _cross(pts[:, 1] - pts[:, 0], d), area) > 0)
                  & (np.einsum("fi,fi->f", _cross(d, pts[:, 3] - pts[:, 0]), area) > 0))
        out[~inside] = [[1, 2, 3], [1, 3, 0]]
    return out


def _polygon_volumes(pts: np.ndarray) -> np.ndarray:
    """Signed volume contributions (F,) of polygons (F, n, 3) as faces of a closed surface
    (divergence theorem: the sum over the faces is the volume it bounds), each tiled as
    :func:`_triangles_inside` tiles it."""
    pts = np.asarray(pts, float)
    t = pts[np.arange(len(pts))[:, None, None], _triangles_inside(pts)]        # (F, n-2, 3, 3)
    return np.einsum("fki,fki->f", t[:, :, 0], _cross(t[:, :, 1], t[:, :, 2])) / 6.0


def _fan_volume(points) -> float:
    """Signed volume contribution (divergence theorem) of a face as :func:`_face` builds it:
    repeated points dropped, triangles as :func:`_triangles_inside`."""
    pts = _dedup(points)
    if len(pts) < 3:
        return 0.0
    return float(_polygon_volumes(pts[None])[0])


def _fan_corners(loops: list) -> tuple:
    """Corner ids ``(first, mid, last)`` (T,) of the fan triangles of a polyhedron's faces
    (``loops`` of point ids), each face's fan from its first corner, faces in order: what the
    divergence theorem and the winding number sum over."""
    n_tri = np.array([len(x) for x in loops]) - 2
    return (np.repeat([x[0] for x in loops], n_tri), np.concatenate([x[1:-1] for x in loops]),
            np.concatenate([x[2:] for x in loops]))
