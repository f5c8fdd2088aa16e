"""The B-rep of a closed polyhedron built directly (:func:`_polyhedron_solid`): shared vertices and
edges, one planar face per loop, each edge's curves on its faces' planes stored with it."""
from __future__ import annotations

import numpy as np

from ..model import _cross


def _polyhedron_solid(points: np.ndarray, loops: list, normals, centres, *, pcurves: bool = True):
    """OCC solid of a closed polyhedron: one vertex per point, one edge per pair of points
    that bound a face (built once, shared by its two faces), one face per loop of point ids
    on the plane through its centre with its normal (the loop runs counter-clockwise about
    it), all in one shell. ValueError where the faces do not close.

    With ``pcurves`` each edge's curve on each of its faces' planes is stored with the edge:
    the curve OpenCascade otherwise projects again every time it is asked for (BRepCheck,
    the volume, the point classifier, the mesher: half of their time), computed by the same
    call, so meshes are the same triangle for triangle; the STEP files are written without
    them (the same bytes)."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge
    from OCP.BRepLib import BRepLib
    from OCP.gp import gp_Pnt
    from OCP.TopoDS import TopoDS, TopoDS_Shell, TopoDS_Solid, TopoDS_Vertex, TopoDS_Wire

    builder = BRep_Builder()
    vertices = []
    for x in np.asarray(points, float).tolist():       # as BRepBuilderAPI_MakeVertex makes it
        v = TopoDS_Vertex()
        builder.MakeVertex(v, gp_Pnt(*x), _CONFUSION)
        vertices.append(v)
    edges: dict = {}

    def edge(i: int, j: int):
        """The edge i -> j (shared: built once, from the lower vertex id)."""
        a, b = (i, j) if i < j else (j, i)
        e = edges.get((a, b))
        if e is None:
            e = edges[(a, b)] = BRepBuilderAPI_MakeEdge(vertices[a], vertices[b]).Edge()
        return e if i < j else TopoDS.Edge(e.Reversed())

    shell = TopoDS_Shell()
    builder.MakeShell(shell)
    normals = np.asarray(normals, float)
    ccw = _counter_clockwise(np.asarray(points, float), loops, normals)
    for loop, n, c, fast in zip(loops, normals.tolist(), np.asarray(centres).tolist(), ccw):
        loop = [int(x) for x in loop]
        wire = TopoDS_Wire()
        builder.MakeWire(wire)
        sides = [edge(i, j) for i, j in zip(loop, loop[1:] + loop[:1])]
        for e in sides:
            builder.Add(wire, e)
        wire.Closed(True)
        face = _plane_face(builder, n, c, wire, fast)
        for e in sides if pcurves else ():
            BRepLib.BuildPCurveForEdgeOnPlane_s(e, face)
        builder.Add(shell, face)
    if not BRep_Tool.IsClosed_s(shell):
        raise ValueError("the faces do not close")
    shell.Closed(True)
    solid = TopoDS_Solid()
    builder.MakeSolid(solid)
    builder.Add(solid, shell)
    return solid


#: OpenCascade's Precision::Confusion(): the tolerance BRepLib gives the vertices and faces it makes
_CONFUSION = 1e-7


def _counter_clockwise(points: np.ndarray, loops: list, normals: np.ndarray) -> list[bool]:
    """Whether each loop of point ids runs clearly counter-clockwise about its unit normal
    (its Newell vector, twice its area, along the normal by more than half its length): the
    wire of such a face bounds it, and ``BRepBuilderAPI_MakeFace``'s test (the face's 2D
    classifier at a point far outside, which turns the wire round where that point would be
    inside) finds nothing to do."""
    sizes = np.array([len(x) for x in loops])
    starts = np.r_[0, np.cumsum(sizes)[:-1]]
    a = np.concatenate(loops).astype(int)
    nxt = np.arange(1, len(a) + 1)
    nxt[starts + sizes - 1] = starts                  # each loop's last corner -> its first
    area = np.add.reduceat(_cross(points[a], points[a[nxt]]), starts, axis=0)     # (F, 3)
    return (np.einsum("fi,fi->f", area, normals) > 0.5 * np.linalg.norm(area, axis=1)).tolist()


def _plane_face(builder, n: list, c: list, wire, counter_clockwise: bool):
    """The face of ``wire`` on the plane through ``c`` with unit normal ``n``, as
    ``BRepBuilderAPI_MakeFace(gp_Pln(c, n), wire, True)`` makes it: where the wire runs
    counter-clockwise about ``n`` (its test would keep it as it is) the same face built
    directly, without that test's classifier (half of a plate's B-rep time, for nothing);
    else by that call."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.Geom import Geom_Plane
    from OCP.gp import gp_Dir, gp_Pln, gp_Pnt
    from OCP.TopoDS import TopoDS_Face

    plane = gp_Pln(gp_Pnt(*c), gp_Dir(*n))
    if counter_clockwise:
        face = TopoDS_Face()
        builder.MakeFace(face, Geom_Plane(plane), _CONFUSION)
        builder.Add(face, wire)
        builder.NaturalRestriction(face, False)
        return face
    mk = BRepBuilderAPI_MakeFace(plane, wire, True)
    if not mk.IsDone():
        raise ValueError(f"a face is not made: {mk.Error()}")
    return mk.Face()
