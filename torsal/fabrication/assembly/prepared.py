"""Solids with the records of the assembly check's cheap tests made once, where they were read.

:class:`~.checker.AssemblyChecker` makes, per solid, what its exact tests without booleans
need: the face records (vertices, edge directions, plane normal), the cover of prisms
(:func:`~.separation.solid_cover`), the boundary triangles and the vertices. Its forked
workers each made their own, for every solid their pairs touch: on example 7a, 5.7 s of
processor time for 314 solids, most of them made twice. The solids' workers make them once
instead, with the solids (:func:`torsal.fabrication.workers.check_record`; or the process
that re-reads a ``fins.step``, :func:`torsal.fabrication.exports.start_read_step`), and send
them with the solids as numpy arrays: a :class:`PreparedSolid`, which the check takes like
any solid (``.wrapped`` is the OCC solid) and whose records it uses as its own. Records are
made from the solids as sent, in the worker or in this process alike, so the check gets the
same numbers wherever they were made.

Units: those of the solids.

>>> from build123d import Box
>>> p = prepare_solid(Box(1, 2, 3).wrapped)
>>> len(p.records.face_points), len(p.records.cover_faces)   # one face swept 1 along x
(6, 1)
>>> [abs(float(x)) for x in p.records.cover_vector]
[1.0, 0.0, 0.0]
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .occ import _Face, _boundary_triangles_by_face, _corners, _face_records, _faces, _vertices
from .separation import solid_cover

__all__ = ["SolidRecords", "PreparedSolid", "solid_records", "prepare_solid", "face_records_of"]


class SolidRecords(NamedTuple):
    """What the cheap tests need of one closed solid, as plain arrays (they pickle).

    ``face_points`` (k_f, 3) and ``face_edges`` (e_f, 3) per face, ``face_normals`` (f, 3) the
    faces' best-fit plane normals, all in the OCC explorer's face order; ``cover_faces`` the
    faces of the cover and ``cover_vector`` (3,) their sweep (:func:`~.separation.solid_cover`;
    empty when the solid has no cover); ``triangles`` (t, 3, 3) the boundary triangles;
    ``vertices`` (v, 3); ``face_triangle_counts`` (f,) how many of the triangles each face
    has, in order (None: not known; see :func:`~.occ._boundary_triangles_by_face`)."""

    face_points: tuple
    face_edges: tuple
    face_normals: np.ndarray
    cover_faces: tuple
    cover_vector: np.ndarray
    triangles: np.ndarray
    vertices: np.ndarray
    face_triangle_counts: np.ndarray | None = None


class PreparedSolid(NamedTuple):
    """An OCC solid (``wrapped``, as build123d names it) with its :class:`SolidRecords`."""

    wrapped: object
    records: SolidRecords


def solid_records(shape) -> SolidRecords:
    """The :class:`SolidRecords` of an OCC solid (meshed first if it is not, as the check
    meshes it). Its vertices are its faces' in the faces' order: :func:`~.occ._vertices` of
    the solid walks the same faces and edges in the same order (the same array, without a
    second walk)."""
    faces = _face_records(shape)
    cover = solid_cover(shape, faces)
    index = {id(f): n for n, f in enumerate(faces)}
    triangles, counts = _boundary_triangles_by_face(shape)
    return SolidRecords(
        face_points=tuple(f.points for f in faces), face_edges=tuple(f.edges for f in faces),
        face_normals=np.array([f.normal for f in faces], float).reshape(-1, 3),
        cover_faces=tuple(index[id(f)] for f, _ in cover),
        cover_vector=np.asarray(cover[0][1], float) if cover else np.zeros(3),
        triangles=triangles,
        vertices=(np.concatenate([f.points for f in faces]) if faces else _vertices(shape)),
        face_triangle_counts=counts)


def prepare_solid(shape) -> PreparedSolid:
    """``shape`` with its :func:`solid_records`."""
    return PreparedSolid(shape, solid_records(shape))


def face_records_of(shape, records: SolidRecords) -> list[_Face]:
    """The face records of ``shape`` (as :func:`~.occ._face_records` makes them) from
    ``records`` made of the same solid: its OCC faces in the explorer's order, the arrays
    from the records. ValueError if the face counts differ (not the same solid)."""
    occ = _faces(shape)
    if len(occ) != len(records.face_points):
        raise ValueError(f"the solid has {len(occ)} faces, its records {len(records.face_points)}")
    return [_Face(f, p, e, n, c) for f, p, e, n, c in
            zip(occ, records.face_points, records.face_edges, records.face_normals,
                _corners(records.face_points))]
