"""The older way to a 3DM Brep, where the solid's faces make no record
(:func:`~.brep.brep_record` is None): rhino3dm's ``Brep.CreateFromMesh`` of the solid's welded
mesh (:func:`_mesh_brep`), a face per planar quad or triangle, its edges' tolerance set so
that it is valid (:func:`_with_edge_tolerances`).

Units: those of the solid.
"""
from __future__ import annotations

import numpy as np

from ..plates import _face_triangles
from .faces import _membrane, _weld


def _mesh_brep(shape, tolerance: float):
    """A closed rhino3dm ``Brep`` of an OCC solid's mesh: one Brep face per plane face of the
    solid with four corners (a planar quad, exact), the others as the planar triangles of
    their mesh, joined along shared edges (rhino3dm's ``Brep.CreateFromMesh`` on the welded
    faces). What the 3DM takes where :func:`~.brep.brep_record` makes no Brep.

    rhino3dm leaves the edges' tolerance unset (openNURBS's ON_UNSET_VALUE), which makes
    ``IsValid`` false although each edge lies exactly on both of its faces (they are built
    from the same vertices): the tolerance is set to 0 in the Brep's openNURBS record (the only
    doubles with that value, one per edge) when that makes the Brep valid."""
    import rhino3dm

    brep = rhino3dm.Brep.CreateFromMesh(_rhino_mesh(shape, tolerance), True)
    if brep is None or brep.IsValid:
        return brep
    return _with_edge_tolerances(brep)


def _rhino_mesh(shape, tolerance: float, *, quads: bool = True):
    """The rhino3dm ``Mesh`` of an OCC solid's faces (:func:`~.brep.brep_of`), welded
    (:func:`~.faces._weld`): planar quads as quads (with ``quads``), the rest as triangles.
    Pairs of coincident triangles of opposite orientation (a membrane of zero thickness inside
    the solid, which a fuzzy slot cut can leave: :data:`~..plates.SLOT_CUT_FUZZY`) are
    dropped: they enclose no volume and make the mesh non-manifold."""
    import rhino3dm

    faces = _face_triangles(shape, tolerance)
    welded = _weld(faces)
    tris = welded.triangles
    membrane = _membrane(np.concatenate(tris) if tris else np.zeros((0, 3), int))
    mesh = rhino3dm.Mesh()
    for x in welded.points:          # double precision (Add keeps single precision)
        mesh.Vertices.AddPoint3d(float(x[0]), float(x[1]), float(x[2]))
    for (v, t), g in zip(faces, tris):
        keep = [tuple(sorted(map(int, tri))) not in membrane for tri in g]
        quad = _quad(g) if quads and len(v) == 4 and len(t) == 2 and all(keep) else None
        if quad is not None:
            mesh.Faces.AddFace(*map(int, quad))
        else:
            for (a, b, c), k in zip(g, keep):
                if k:
                    mesh.Faces.AddFace(int(a), int(b), int(c))
    return mesh


def _quad(tris: np.ndarray):
    """The quad (4,) of two triangles (2, 3) that share an edge (in opposite directions), in
    their order, or None."""
    a, b = [list(map(int, t)) for t in tris]
    for i in range(3):
        u, v, w = a[i], a[(i + 1) % 3], a[(i + 2) % 3]
        for j in range(3):
            if b[j] == v and b[(j + 1) % 3] == u:
                x = b[(j + 2) % 3]
                return (u, x, v, w)
    return None


def _with_edge_tolerances(brep):
    """The Brep with its unset edge tolerances set to 0 (see :func:`_mesh_brep`), if that makes
    it valid; else the Brep as it was."""
    import base64
    import struct

    import rhino3dm

    unset = struct.pack("<d", -1.23432101234321e+308)       # openNURBS's ON_UNSET_VALUE
    enc = brep.Encode()
    data = base64.b64decode(enc["data"])
    if data.count(unset) != len(brep.Edges):
        return brep
    enc = dict(enc, data=base64.b64encode(data.replace(unset, struct.pack("<d", 0.0))).decode())
    fixed = rhino3dm.CommonObject.Decode(enc)
    return fixed if fixed is not None and fixed.IsValid and fixed.IsSolid else brep
