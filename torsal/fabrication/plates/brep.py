"""The B-rep of a closed polyhedron built directly (:func:`_polyhedron_solid`): shared vertices and
edges, one planar face per loop, each edge's curves on its faces' planes stored with it."""
from __future__ import annotations

import numpy as np


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
    from OCP.BRepBuilderAPI import (BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeFace,
                                    BRepBuilderAPI_MakeVertex)
    from OCP.BRepLib import BRepLib
    from OCP.gp import gp_Dir, gp_Pln, gp_Pnt
    from OCP.TopoDS import TopoDS, TopoDS_Shell, TopoDS_Solid, TopoDS_Wire

    builder = BRep_Builder()
    vertices = [BRepBuilderAPI_MakeVertex(gp_Pnt(*map(float, x))).Vertex() for x in points]
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
    for loop, n, c in zip(loops, np.asarray(normals).tolist(), np.asarray(centres).tolist()):
        loop = [int(x) for x in loop]
        wire = TopoDS_Wire()
        builder.MakeWire(wire)
        sides = [edge(i, j) for i, j in zip(loop, loop[1:] + loop[:1])]
        for e in sides:
            builder.Add(wire, e)
        wire.Closed(True)
        mk = BRepBuilderAPI_MakeFace(gp_Pln(gp_Pnt(*c), gp_Dir(*n)), wire, True)
        if not mk.IsDone():
            raise ValueError(f"a face is not made: {mk.Error()}")
        face = mk.Face()
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
