"""OpenCascade kernels of the assembly check: shapes' volumes, boxes, faces and triangles,
exact booleans (non-destructive, confirmed), distances and the prisms faces sweep.

Units: those of the solids (unit^3 for volumes).
"""
from __future__ import annotations

from typing import NamedTuple, Sequence

import numpy as np

from .result import MIN_INTERFERENCE_VOLUME, TOUCHING_TOLERANCE

def _shape(x):
    """TopoDS_Shape of a build123d shape or an OCP shape."""
    return getattr(x, "wrapped", x)


def _mesh(shapes, tolerance: float) -> None:
    """Triangulate the shapes (in place, once, before any fork) for the proximity prefilter,
    each unless it has a triangulation that fine already (as :func:`~..plates._mesh`): the
    solids the solids' workers made for the check (or a STEP file's reading process) come
    meshed so, and meshing them again found it done in 0.7 s of this process's time on 7a
    (the test: 0.01 s)."""
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.BRepTools import BRepTools

    for s in shapes:
        if BRepTools.Triangulation_s(s, 0.1 * tolerance):
            continue
        # serial: worker threads left behind would deadlock the forked processes
        BRepMesh_IncrementalMesh(s, 0.1 * tolerance, False, 0.5, False)


def _signed_volume(shape) -> float:
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(shape, props)
    return float(props.Mass())


def _volume(shape) -> float:
    return abs(_signed_volume(shape))


def _vertices(shape) -> np.ndarray:
    """(k, 3) coordinates of the vertices of a shape (exact extents of a polyhedral solid)."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_VERTEX
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    out = []
    ex = TopExp_Explorer(shape, TopAbs_VERTEX)
    while ex.More():
        out.append(BRep_Tool.Pnt_s(TopoDS.Vertex(ex.Current())).Coord())
        ex.Next()
    return np.asarray(out, float).reshape(-1, 3)


def _bbox(shape) -> np.ndarray:
    """(2, 3) axis-aligned bounding box (min, max) of a shape."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib

    box = Bnd_Box()
    BRepBndLib.Add_s(shape, box, False)
    lo, hi = box.CornerMin(), box.CornerMax()
    return np.array([[lo.X(), lo.Y(), lo.Z()], [hi.X(), hi.Y(), hi.Z()]])


def _faces(shape) -> list:
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    out = []
    ex = TopExp_Explorer(shape, TopAbs_FACE)
    while ex.More():
        out.append(TopoDS.Face(ex.Current()))
        ex.Next()
    return out


def face_polygons(solid) -> list[np.ndarray]:
    """Outer loops of the faces of a polyhedral solid, each (k, 3) in order (for pictures)."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepTools import BRepTools, BRepTools_WireExplorer

    out = []
    for f in _faces(_shape(solid)):
        ex = BRepTools_WireExplorer(BRepTools.OuterWire_s(f))
        pts = []
        while ex.More():
            p = BRep_Tool.Pnt_s(ex.CurrentVertex())
            pts.append((p.X(), p.Y(), p.Z()))
            ex.Next()
        pts = np.asarray(pts, float).reshape(-1, 3)
        if len(pts) >= 3 and np.isfinite(pts).all():     # degenerate loops are left out
            out.append(pts)
    return out


def common_volume(s1, s2, *, upright: bool = False) -> float:
    """Volume of the intersection of two solids (exact OpenCascade boolean), unit^3.

    The boolean runs non-destructively: by default OpenCascade may widen the tolerances of
    its arguments' vertices while it works (to about 1 mm, seen on a slotted plate crossing
    another at an egg-crate), and then got this very common wrong (``a & b`` reported all of
    ``b``, more than ``b``'s own volume, where ``b & a`` gave 0 and no point of ``b`` lies
    inside ``a``),
    and later booleans on the changed solids came out differently in one process than in
    another (a path blocked or clear by the worker count). An overlap above
    :data:`MIN_INTERFERENCE_VOLUME` is confirmed too: measured again in the other order and
    with a fuzzy tolerance, the median of the three is returned, so that one wrong boolean in
    the first order cannot make an interference (a wrong 0 there is not looked at again: that
    would triple the cost of every boolean).

    ``upright``: both solids are known to face outwards (:func:`is_upright`), so OpenCascade
    need not check each argument for an inside-out solid, which it does by classifying a
    point against it: about a third of the boolean of two of 7a's slotted plates.

    Raises RuntimeError when the boolean fails even with a fuzzy tolerance.

    >>> from build123d import Box, Pos
    >>> round(common_volume(Box(2, 2, 2), Pos(1, 0, 0) * Box(2, 2, 2), upright=True), 6)
    4.0
    """
    a, b = _shape(s1), _shape(s2)
    first = _common(a, b, upright=upright)
    if not first > MIN_INTERFERENCE_VOLUME:
        return first
    return float(np.median([first, _common(b, a, upright=upright),
                            _common(a, b, fuzzy=_FUZZY, upright=upright)]))


def is_upright(shape) -> bool:
    """Whether a closed solid faces outwards: its signed volume (:func:`_signed_volume`) is
    positive (an inside-out solid's is negative, and a boolean would take its complement)."""
    return _signed_volume(_shape(shape)) > 0.0


#: unit: fuzzy tolerance of the boolean that confirms an overlap or retries a failed one
_FUZZY = 1e-6


def _common(a, b, *, fuzzy: float = 0.0, upright: bool = False) -> float:
    """Volume of ``a & b`` (TopoDS shapes, left unchanged); a failed exact boolean is tried
    again with the fuzzy tolerance :data:`_FUZZY` (RuntimeError if that fails too)."""
    for f in ((0.0, _FUZZY) if fuzzy == 0.0 else (fuzzy,)):
        op = _boolean_common(a, b, f, upright=upright)
        if op.IsDone():
            return _volume(op.Shape())
    raise RuntimeError("BRepAlgoAPI_Common failed")


def _boolean_common(a, b, fuzzy: float, *, upright: bool = False):
    """The built ``BRepAlgoAPI_Common`` of ``a`` and ``b``: non-destructive (the arguments
    keep their tolerances), with ``fuzzy`` (unit; 0: exact); ``upright``: both face outwards,
    OpenCascade does not check them for inside-out solids."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Common
    try:
        from OCP.TopTools import TopTools_ListOfShape
    except ImportError:           # OCP >= 7.8 has the list type in OCP.collections only
        from OCP.collections import List_TopoDS_Shape as TopTools_ListOfShape

    op = BRepAlgoAPI_Common()
    la, lb = TopTools_ListOfShape(), TopTools_ListOfShape()
    la.Append(a)
    lb.Append(b)
    op.SetArguments(la)
    op.SetTools(lb)
    op.SetNonDestructive(True)
    op.SetCheckInverted(not upright)
    if fuzzy > 0.0:
        op.SetFuzzyValue(fuzzy)
    op.Build()
    return op


def _first_vertex(shape):
    """The first vertex of a shape as :func:`_vertices` lists them (a ``gp_Pnt``; None: it
    has none), without visiting the others."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_VERTEX
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    ex = TopExp_Explorer(shape, TopAbs_VERTEX)
    return BRep_Tool.Pnt_s(TopoDS.Vertex(ex.Current())) if ex.More() else None


#: unit: the classifier's tolerance of :func:`_inside` (a point nearer the boundary is ON)
INSIDE_TOLERANCE = 1e-7


def _inside(shape, solid) -> bool:
    """A vertex of ``shape`` (its first) lies strictly inside ``solid``."""
    from OCP.BRepClass3d import BRepClass3d_SolidClassifier
    from OCP.TopAbs import TopAbs_IN

    p = _first_vertex(shape)
    if p is None:
        return False
    cls = BRepClass3d_SolidClassifier(solid, p, INSIDE_TOLERANCE)
    return cls.State() == TopAbs_IN


def solid_distance(s1, s2) -> float:
    """Exact distance between two solids (0 when they touch, overlap or one holds the other).

    >>> from build123d import Box, Pos
    >>> solid_distance(Box(1, 1, 1), Pos(3, 0, 0) * Box(1, 1, 1)), solid_distance(Box(3, 3, 3), Box(1, 1, 1))
    (2.0, 0.0)
    """
    from OCP.BRepExtrema import BRepExtrema_DistShapeShape

    a, b = _shape(s1), _shape(s2)
    d = BRepExtrema_DistShapeShape(a, b)
    if not d.IsDone():
        raise RuntimeError("BRepExtrema_DistShapeShape failed")
    dist = float(d.Value())
    # the distance of the boundaries: a solid wholly inside the other is at distance 0
    if dist > 0 and (_inside(a, b) or _inside(b, a)):
        return 0.0
    return dist


#: unit: how far a triangle may reach into a convex prism and the prism still count as clear of
#: it (OpenCascade's confusion tolerance, the precision of its booleans themselves)


def _near(s1, s2, tol: float) -> bool:
    """Whether two meshed shapes come within about ``tol`` (BVH on their triangulations, fast;
    exact triangles for planar faces, a conservative test of the gap): a prefilter only."""
    from OCP.BRepExtrema import BRepExtrema_ShapeProximity

    p = BRepExtrema_ShapeProximity(s1, s2, tol)
    p.Perform()
    return not p.IsDone() or p.OverlapSubShapes1().Size() > 0


def _plane_normal(points: np.ndarray) -> np.ndarray:
    """Unit normal of the best-fit plane of (m, 3) points."""
    return np.linalg.svd(points - points.mean(axis=0), full_matrices=False)[2][-1]


class _Face(NamedTuple):
    """A face of a moving solid: its OCC face, vertices (k, 3), edge directions (k, 3), its
    plane's normal and its ``corners`` (:func:`_corners` of ``points``; None: ``points``)."""

    face: object
    points: np.ndarray
    edges: np.ndarray
    normal: np.ndarray
    corners: np.ndarray | None = None


def _corners(points: Sequence[np.ndarray]) -> list[np.ndarray]:
    """Per face, the distinct rows of its ``points`` (k, 3), each where it first occurs: a
    face's vertices are listed once per edge (twice each), its hull's corners once (the
    separating-axis tests project them all, :func:`~.separation._prism_hulls`). All faces of
    a solid in one sort (a face at a time cost more than the rest of its records)."""
    if not len(points):
        return []
    counts = np.array([len(p) for p in points])
    x = np.concatenate(points).reshape(-1, 3)
    face = np.repeat(np.arange(len(points)), counts)
    order = np.lexsort((x[:, 2], x[:, 1], x[:, 0], face))      # stable: first occurrence first
    xs, fs = x[order], face[order]
    new = np.ones(len(x), bool)
    new[1:] = (fs[1:] != fs[:-1]) | (xs[1:] != xs[:-1]).any(axis=1)
    keep = np.zeros(len(x), bool)
    keep[order[new]] = True
    return np.split(x[keep], np.cumsum(np.bincount(face[keep], minlength=len(points)))[:-1])


def _face_records(shape) -> list[_Face]:
    """The :class:`_Face` of every face of ``shape``, in the explorer's order: its vertices as
    :func:`_vertices` of the face lists them (each edge's, in the edge's order: the explorer
    of vertices walks the same edges), its edges' directions (last vertex minus first, as
    ``TopExp.LastVertex`` and ``FirstVertex`` take them: the edge's own FORWARD and REVERSED
    vertex) and its best-fit plane's normal; each edge's vertices read once."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS, TopoDS_Iterator

    out = []
    for f in _faces(shape):
        edges, pts = [], []
        ex = TopExp_Explorer(f, TopAbs_EDGE)
        while ex.More():
            first = last = None
            # the edge's vertices as stored (orientation not composed with the edge's, as
            # TopExp.FirstVertex / LastVertex read them), located as the explorer places them
            it = TopoDS_Iterator(ex.Current(), False, True)
            while it.More():
                v = it.Value()
                xyz = BRep_Tool.Pnt_s(TopoDS.Vertex(v)).Coord()
                pts.append(xyz)
                o = v.Orientation()
                if first is None and o == TopAbs_FORWARD:
                    first = xyz
                elif last is None and o == TopAbs_REVERSED:
                    last = xyz
                it.Next()
            edges.append((last[0] - first[0], last[1] - first[1], last[2] - first[2]))
            ex.Next()
        pts = np.asarray(pts, float).reshape(-1, 3)
        out.append(_Face(f, pts, np.asarray(edges, float).reshape(-1, 3), _plane_normal(pts)))
    return [f._replace(corners=c) for f, c in zip(out, _corners([f.points for f in out]))]


def _outward_normals(shape, faces: list[_Face]) -> np.ndarray | None:
    """(f, 3) outward unit normals of the planar faces of a closed solid (None: a face is not
    planar)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.GeomAbs import GeomAbs_Plane
    from OCP.TopAbs import TopAbs_REVERSED

    out = []
    for f in faces:
        surf = BRepAdaptor_Surface(f.face)
        if surf.GetType() != GeomAbs_Plane:
            return None
        d = surf.Plane().Axis().Direction()
        n = np.array([d.X(), d.Y(), d.Z()])
        out.append(-n if f.face.Orientation() == TopAbs_REVERSED else n)
    # a shell oriented inside out has a negative volume: its faces point in
    return np.asarray(out).reshape(-1, 3) * (1.0 if _signed_volume(shape) >= 0 else -1.0)


def _face_prism(face, v: np.ndarray):
    """The oriented, meshed solid ``face`` sweeps along ``-v`` (None: the face runs along
    ``v`` and sweeps no volume)."""
    from OCP.BRepGProp import BRepGProp
    from OCP.BRepLib import BRepLib
    from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism
    from OCP.GProp import GProp_GProps
    from OCP.TopoDS import TopoDS
    from OCP.gp import gp_Vec

    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, props)
    pr = TopoDS.Solid(BRepPrimAPI_MakePrism(face, gp_Vec(*map(float, -v)), True).Shape())
    # faces along the path sweep no volume (numerically a sliver of either sign: skip it)
    if abs(_signed_volume(pr)) <= 1e-9 * props.Mass() * float(np.linalg.norm(v)):
        return None
    # a face swept against its normal gives an inside-out solid; the boolean would take its
    # complement: orient it
    BRepLib.OrientClosedSolid_s(pr)
    _mesh([pr], 1.0)
    return pr


def _meshed_triangles(shape) -> np.ndarray | None:
    """:func:`_boundary_triangles` of a meshed shape, or None where a face has no
    triangulation (a degenerate face that BRepMesh leaves out: a prism's side swept along its
    own edge has no area)."""
    from OCP.BRep import BRep_Tool
    from OCP.TopLoc import TopLoc_Location

    if any(BRep_Tool.Triangulation_s(f, TopLoc_Location()) is None for f in _faces(shape)):
        return None
    return _boundary_triangles(shape)


def _boundary_triangles(shape) -> np.ndarray:
    """(t, 3, 3) corners of the triangles of a shape's boundary (exact for planar faces),
    meshed first if it is not (:class:`~.checker.AssemblyChecker` keeps them per solid)."""
    return _boundary_triangles_by_face(shape)[0]


def _boundary_triangles_by_face(shape) -> tuple[np.ndarray, np.ndarray | None]:
    """``(triangles (t, 3, 3), counts (f,))``: :func:`_boundary_triangles` of ``shape`` and
    how many of them each of its faces (:func:`_faces`, in that order) has, so that face
    ``n``'s are a slice of the array, the very numbers :func:`_boundary_triangles` of that
    face gives (its triangulation, read alike); ``counts`` None where a face is met twice
    (then the faces' triangles are not in :func:`_faces`' order)."""
    from OCP.BRepTools import BRepTools

    from ..plates import _face_triangles

    deflection = 0.1 * TOUCHING_TOLERANCE           # as _mesh meshes for the check
    if not BRepTools.Triangulation_s(shape, deflection):
        _mesh([shape], TOUCHING_TOLERANCE)   # serially (a check meshes its solids before any fork)
    # forked workers call this: no threads
    per = [v[t].reshape(-1, 3, 3) for v, t in _face_triangles(shape, deflection, threads=False)]
    tri = np.concatenate(per) if per else np.zeros((0, 3, 3))
    counts = np.array([len(t) for t in per], np.int64)
    return tri, (counts if len(per) == len(_faces(shape)) else None)
