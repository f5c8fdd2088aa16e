"""Meshes of OCC shapes for previews (3DM, glTF, STL, IFC, the assembly check): BRepMesh as
build123d's ``tessellate`` runs it, per face or in one array."""
from __future__ import annotations

import numpy as np


def _face_triangles(shape, tolerance: float, angular_tolerance: float = 0.1, *,
                    threads: bool = True) -> list:
    """``[(vertices (k, 3), triangles (m, 3) into them)]`` per face of an OCC shape, meshed as
    build123d's ``Shape.tessellate`` does (BRepMesh to ``tolerance``, faces in explorer
    order, reversed faces' triangles turned round, so every triangle faces out).
    ``threads=False`` in forked processes (see :func:`_mesh`)."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    _mesh(shape, tolerance, angular_tolerance, threads=threads)
    faces, exp = {}, TopExp_Explorer(shape, TopAbs_FACE)
    while exp.More():                        # each face once, in the order first met
        faces[hash(exp.Current())] = exp.Current()
        exp.Next()
    out = []
    for f in faces.values():
        face = TopoDS.Face(f)
        loc = TopLoc_Location()
        poly = BRep_Tool.Triangulation_s(face, loc)
        pts = [poly.Node(j) for j in range(1, poly.NbNodes() + 1)]
        if not loc.IsIdentity():
            trsf = loc.Transformation()
            pts = [p.Transformed(trsf) for p in pts]
        v = np.array([p.Coord() for p in pts], float).reshape(-1, 3)
        # one triangle at a time: poly.Triangles() copies the whole array on every call
        t = np.array([poly.Triangle(i).Get() for i in range(1, poly.NbTriangles() + 1)],
                     dtype=np.int64).reshape(-1, 3) - 1
        out.append((v, t[:, [0, 2, 1]] if face.Orientation() == TopAbs_REVERSED else t))
    return out


def _triangles(shape, tolerance: float, angular_tolerance: float = 0.1, *, threads: bool = True):
    """Vertices (n, 3) and triangles (m, 3) of an OCC shape: its faces' triangles
    (:func:`_face_triangles`) in one array, vertices not shared between faces."""
    faces = _face_triangles(shape, tolerance, angular_tolerance, threads=threads)
    if not faces:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    offsets = np.cumsum([0] + [len(v) for v, _ in faces[:-1]])
    return (np.concatenate([v for v, _ in faces]),
            np.concatenate([t + o for (_, t), o in zip(faces, offsets)]))


#: preview meshes (3DM, glTF, STL): deflection as a fraction of the plate thickness
MESH_TOLERANCE = 0.05


def _mesh(shape, tolerance: float, angular_tolerance: float = 0.1, *, threads: bool = True) -> None:
    """Mesh an OCC shape (BRepMesh, deflection relative to the edge size; ``threads``: one per
    face in parallel, the same triangles) unless it has a triangulation that fine.

    A forked process must pass ``threads=False``: OpenCascade's thread pool, once started
    in the parent (e.g. by the 3DM export), has no threads in the child, and a parallel mesh
    there waits for them for ever (7c's assembly check hung so, 2026-11-26)."""
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.BRepTools import BRepTools

    if not BRepTools.Triangulation_s(shape, tolerance):
        BRepMesh_IncrementalMesh(shape, tolerance, True, angular_tolerance, threads)
