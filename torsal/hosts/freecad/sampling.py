"""FreeCAD geometry as torsal's input, sampled inside FreeCAD (FreeCAD's ``Part`` API only).

- :func:`linked_face`: the face a ``Surface`` link names (a face, or a shape of one face).
- :func:`face_grid`: the face on a regular grid of its (u, v) parameters, about ``edge`` apart
  in space; torsal triangulates the grid (:func:`~torsal.hosts.freecad.job.grid_mesh`). A
  parameter grid follows the surface's own lines, which a design surface (a B-spline facade)
  is drawn along; a CAD tessellation's slivers would be poor faces for the congruence.
- :func:`wire_polylines`: the wires of ``Strokes`` links as polylines (Fig. 7b).

Lengths are FreeCAD's millimetres. FreeCAD is imported by FreeCAD's own Python only: these
functions take FreeCAD objects.
"""
from __future__ import annotations

import math

from ...core.errors import TorsalError
from .job import SurfaceGrid

__all__ = ["MAX_GRID", "MIN_GRID", "SamplingError", "linked_face", "face_grid", "wire_polylines"]

#: grid points per parameter direction: at least 3 (torsal's generators' minimum), at most 150
#: (22,500 vertices: more than a design needs, and the optimizer's size limit stops it anyway)
MIN_GRID, MAX_GRID = 3, 150
#: samples along a parameter line when measuring its length
_LENGTH_SAMPLES = 33


class SamplingError(TorsalError, ValueError):
    """A linked shape that cannot be a surface or a stroke; the message says what to link."""


def linked_face(link):
    """The face of a ``PropertyLinkSub`` value ``(object, ["Face2"])`` or ``(object, [])``
    (the object's shape must then have exactly one face)."""
    obj, subs = link
    shape = obj.Shape
    subs = [s for s in (subs or []) if s]
    if subs:
        if len(subs) > 1 or not subs[0].startswith("Face"):
            raise SamplingError(f"Surface links {obj.Label} {subs}: link one face (e.g. Face1)")
        return shape.getElement(subs[0])
    faces = shape.Faces
    if len(faces) != 1:
        raise SamplingError(f"Surface links {obj.Label}, a shape of {len(faces)} faces: link "
                            "one of its faces (select the face, or set Surface to "
                            f"({obj.Name}, ['Face1']))")
    return faces[0]


def _line_length(face, fixed: float, lo: float, hi: float, along_u: bool) -> float:
    ts = [lo + (hi - lo) * k / (_LENGTH_SAMPLES - 1) for k in range(_LENGTH_SAMPLES)]
    pts = [face.valueAt(t, fixed) if along_u else face.valueAt(fixed, t) for t in ts]
    return sum((b - a).Length for a, b in zip(pts, pts[1:]))


def _count(length: float, edge: float) -> int:
    return max(MIN_GRID, min(MAX_GRID, int(math.ceil(length / edge)) + 1))


def face_grid(face, edge: float) -> SurfaceGrid:
    """Sample ``face`` on a ``nu x nv`` grid of its parameter range, with ``nu`` and ``nv``
    chosen so neighbouring points are about ``edge`` (mm) apart along the longest parameter
    line (between :data:`MIN_GRID` and :data:`MAX_GRID` points). Points outside a trimmed face
    are marked (``inside``)."""
    if not edge > 0:
        raise SamplingError(f"the tessellation edge length must be > 0 mm, got {edge}")
    u0, u1, v0, v1 = face.ParameterRange
    lu = max(_line_length(face, v0 + (v1 - v0) * s, u0, u1, True) for s in (0.0, 0.5, 1.0))
    lv = max(_line_length(face, u0 + (u1 - u0) * s, v0, v1, False) for s in (0.0, 0.5, 1.0))
    if lu == 0 or lv == 0:
        raise SamplingError("the linked face has no area (a degenerate parameter range)")
    nu, nv = _count(lu, edge), _count(lv, edge)
    points, inside = [], []
    for i in range(nu):
        u = u0 + (u1 - u0) * i / (nu - 1)
        for j in range(nv):
            v = v0 + (v1 - v0) * j / (nv - 1)
            p = face.valueAt(u, v)
            points.append([p.x, p.y, p.z])
            inside.append(bool(face.isPartOfDomain(u, v)))
    return SurfaceGrid(nu=nu, nv=nv, points=points, inside=inside)


def wire_polylines(objects, step: float) -> list[list[list[float]]]:
    """Every wire (or loose edge) of the linked objects as a polyline of points about
    ``step`` (mm) apart, ends included."""
    out = []
    for obj in objects:
        shape = obj.Shape
        pieces = list(shape.Wires) or list(shape.Edges)
        if not pieces:
            raise SamplingError(f"Strokes links {obj.Label}, which has no wire or edge: link "
                                "sketches, Draft wires or B-spline curves")
        for piece in pieces:
            n = max(2, int(math.ceil(piece.Length / step)) + 1)
            out.append([[p.x, p.y, p.z] for p in piece.discretize(Number=n)])
    return out
