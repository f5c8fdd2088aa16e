"""The Rhino 3DM form of a solid part: a closed rhino3dm ``Brep`` of its OCC solid
(:func:`brep_of`), made by :func:`~.exports.export_3dm` or, in parallel, by the solids' worker
processes (:func:`encoded_brep`, sent back encoded).

Units: those of the solid.
"""
from __future__ import annotations

import numpy as np

from .plates import _face_triangles

__all__ = ["brep_of", "encoded_brep"]


def encoded_brep(shape, tolerance: float) -> dict | None:
    """rhino3dm's encoding (``Brep.Encode()``, picklable) of the 3DM Brep of ``shape``
    (:func:`brep_of`); None if it is not a valid closed solid (the 3DM takes the mesh)."""
    brep = brep_of(shape, tolerance)
    return brep.Encode() if brep is not None and brep.IsSolid and brep.IsValid else None


def brep_of(shape, tolerance: float):
    """A closed rhino3dm ``Brep`` of an OCC solid: one Brep face per plane face of the solid
    with four corners (a planar quad, exact), the others (faces with slot notches, curved
    hole walls) as the planar triangles of their mesh (curved faces within ``tolerance``),
    joined along shared edges (rhino3dm's ``Brep.CreateFromMesh`` on the welded faces).

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
    """The rhino3dm ``Mesh`` of an OCC solid's faces (:func:`brep_of`), welded: planar quads
    as quads (with ``quads``), the rest as triangles. Pairs of coincident triangles of
    opposite orientation (a membrane of zero thickness inside the solid, which a fuzzy slot
    cut can leave: :data:`~.plates.SLOT_CUT_FUZZY`) are dropped: they enclose no volume and
    make the mesh non-manifold."""
    import rhino3dm

    faces = _face_triangles(shape, tolerance)
    pts = np.concatenate([v for v, _ in faces]) if faces else np.zeros((0, 3))
    scale = max(1.0, float(np.abs(pts).max(initial=0.0)))
    _, first, ids = np.unique(np.round(pts / (1e-9 * scale)).astype(np.int64), axis=0,
                              return_index=True, return_inverse=True)
    ids = ids.ravel()
    offsets = np.cumsum([0] + [len(v) for v, _ in faces])
    welded = [ids[o:o + len(v)][t] for o, (v, t) in zip(offsets, faces)]
    membrane = _membrane(np.concatenate(welded) if welded else np.zeros((0, 3), int))
    mesh = rhino3dm.Mesh()
    for x in pts[first]:             # double precision (Add keeps single precision)
        mesh.Vertices.AddPoint3d(float(x[0]), float(x[1]), float(x[2]))
    for (v, t), g in zip(faces, welded):
        keep = [tuple(sorted(map(int, tri))) not in membrane for tri in g]
        quad = _quad(g) if quads and len(v) == 4 and len(t) == 2 and all(keep) else None
        if quad is not None:
            mesh.Faces.AddFace(*map(int, quad))
        else:
            for (a, b, c), k in zip(g, keep):
                if k:
                    mesh.Faces.AddFace(int(a), int(b), int(c))
    return mesh


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
    """The Brep with its unset edge tolerances set to 0 (see :func:`brep_of`), if that makes it
    valid; else the Brep as it was."""
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
