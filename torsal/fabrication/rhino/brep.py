"""A solid part's 3DM Brep: its record (:func:`brep_record`: openNURBS bytes made without
rhino3dm, from the solid's faces), rhino3dm's encoding of it (:func:`encoded_brep`) and the
rhino3dm ``Brep`` (:func:`brep_of`), with the mesh's Brep (:mod:`.mesh_brep`) where the faces
make no record; the volume of a Brep read back (:func:`brep_volume`).

Units: those of the solid.
"""
from __future__ import annotations

import numpy as np

from .faces import _polygon_faces
from .mesh_brep import _mesh_brep
from .records import _record
from .topology import _topology


def brep_record(shape, tolerance: float, *, threads: bool = True) -> bytes | None:
    """The 3DM record (openNURBS ``WriteObject`` bytes of an ``ON_Brep``, as in a version 7 or
    8 .3dm file) of the closed Brep of an OCC solid: one planar face per plane face of the
    solid (the outlines of its mesh's faces at ``tolerance``: plane faces are exact), a curved
    face (a bolt hole's wall) as its mesh's triangles, with the solid's vertices; None where
    the faces do not make one (an outline that touches itself, faces that do not close):
    :func:`brep_of` then joins the mesh. ``threads=False`` in forked processes (see
    :func:`~..plates._mesh`)."""
    faces = _polygon_faces(shape, tolerance, threads)
    return None if faces is None else _brep_bytes(*faces)


def _brep_bytes(points: np.ndarray, faces: list) -> bytes | None:
    """The record (:func:`brep_record`) of a Brep of planar ``faces`` (lists of loops of indices
    into ``points`` (n, 3), :func:`~.faces._polygon_faces`): per face an ``ON_PlaneSurface``
    through the centroid of its outer loop, normal its Newell vector, x along its first side,
    domain the loops' extent; per edge a 3d ``ON_LineCurve`` between its vertices, per trim a
    2d one (the edge's ends in the face's plane), the edge's tolerance the largest distance of
    its ends from the planes of its faces (a vertex's: from those of its faces)
    (:func:`~.topology._topology`, :func:`~.records._record`). None if an edge is not on
    exactly two faces in opposite senses, a side or a face is degenerate, or the faces enclose
    no volume (they face inwards)."""
    topology = _topology(points, faces)
    return None if topology is None else _record(topology)


def encoded_brep(shape, tolerance: float) -> dict | None:
    """rhino3dm's encoding (as ``Brep.Encode()`` gives it, picklable; rhino3dm's
    ``CommonObject.Decode`` reads it) of the 3DM Brep of ``shape`` (:func:`brep_of`); None if
    it is not a valid closed solid (the 3DM takes the mesh)."""
    record = brep_record(shape, tolerance)
    if record is not None:
        return _encoding(record)
    brep = _mesh_brep(shape, tolerance)
    return brep.Encode() if brep is not None and brep.IsSolid and brep.IsValid else None


def brep_of(shape, tolerance: float):
    """A closed rhino3dm ``Brep`` of an OCC solid: one planar face per plane face of the solid
    (:func:`brep_record`, read by rhino3dm); where the solid's faces do not make one, its mesh's
    faces joined by rhino3dm (:func:`~.mesh_brep._mesh_brep`: a face per planar quad or
    triangle)."""
    import rhino3dm

    record = brep_record(shape, tolerance)
    if record is not None:
        brep = rhino3dm.CommonObject.Decode(_encoding(record))
        if brep is not None:
            return brep
    return _mesh_brep(shape, tolerance)


def brep_volume(brep) -> float:
    """The volume of a rhino3dm ``Brep`` of planar faces (cubed units of its points; rhino3dm
    has no mass properties), to check a Brep read back from a .3dm file against its solid: the
    divergence theorem over its faces' loops, each the polygon of its trims' start vertices,
    (1/6) sum (p_i x p_i+1) . c, c the centroid of its face's outer loop."""
    pts = np.array([(v.Location.X, v.Location.Y, v.Location.Z) for v in brep.Vertices])
    total = 0.0
    for face in brep.Faces:
        c = pts[[t.StartVertexIndex for t in face.Loops[0].Trims]].mean(axis=0)
        for loop in face.Loops:
            p = pts[[t.StartVertexIndex for t in loop.Trims]]
            total += np.cross(p - c, np.roll(p, -1, axis=0) - c).sum(axis=0) @ c / 6.0
    return total


def _encoding(record: bytes) -> dict:
    """rhino3dm's encoding (``CommonObject.Decode`` reads it) of a record (:func:`brep_record`)."""
    import base64

    return {"version": 10000, "archive3dm": 70, "opennurbs": _opennurbs_version(),
            "data": base64.b64encode(record).decode()}


def _opennurbs_version() -> int:
    """The openNURBS version of rhino3dm (what its encodings state)."""
    global _OPENNURBS
    if _OPENNURBS is None:
        import rhino3dm

        _OPENNURBS = rhino3dm.Point(rhino3dm.Point3d(0, 0, 0)).Encode()["opennurbs"]
    return _OPENNURBS


_OPENNURBS = None
