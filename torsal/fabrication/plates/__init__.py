"""Plate and slot solids (OpenCascade through OCP): the construction kernel of :mod:`.solids`.

Every part is thickened about its mid-plane by ``thickness``: the plate is a closed
polyhedral shell (top face ``p + t/2 m``, bottom ``p - t/2 m`` with the mitre vectors ``m``
of :class:`~.parts.Part`, side faces along the ``a`` and ``b`` edges, end caps) built as one
B-rep (shared vertices and edges, each face on the plane of its corners; the faces are sewn
only where corners nearly coincide): folds are mitred on the bisector plane, so no boolean
fuse is needed and the plate volume equals ``sum(panel area) * thickness`` up to the twist of
side faces. Egg-crate slots are cut as boxes (a box per panel touching the slot, or one on
the bisector of a flat fold, centred on the node line, ``thickness + clearance`` wide, through
the plate): without a boolean, in the planes of the plate's faces (each face less the boxes'
sections, each box face within the plate's section: :func:`_cut_polyhedron`, then one B-rep
as the plate's), the solid OpenCascade's boolean cut and face unification give, in less than
half their time; the boolean (one per part) cuts the parts where that declines (faces on one
plane, corners on a cutting plane, anything it cannot close into one shell).

Every solid is checked with BRepCheck (build123d's ``is_valid``); an invalid one is repaired
with ``ShapeFix`` and if it stays invalid an :class:`InvalidSolidError` names the part:
nothing is written silently. The slots are checked too (the cut must remove the slot area of
the unrolled part times the thickness, every slot open and the web beyond it kept); where
neither route can cut them (thin, oblique plates of real structures) the sound plate is kept
without them (:class:`SlotCutError`).
The STEP solids are nominal: the cutting process (kerf, reliefs) lives in the DXF only.

Also the meshing of OCC shapes for previews (:func:`_mesh`, :func:`_triangles`).

Units: the ``unit`` of the fin system (mm by default).

The package, lowest first: :mod:`.errors`; :mod:`.faces` (polygons as OCC faces, coplanarity,
the triangles inside a polygon, volumes by the divergence theorem); :mod:`.occ` (box, volume,
BRepCheck, downcast); :mod:`.brep` (a closed polyhedron as one B-rep, with its edge curves);
:mod:`.plate` (the plate's outlines and polyhedron, built directly or sewn); :mod:`.slots` (the
slot boxes, the slot area, the checks of a slotted solid); :mod:`.boolean` (OpenCascade's cut,
the fallback); :mod:`.sections`, :mod:`.polygon_cut`, :mod:`.whole_faces` and :mod:`.direct`
(the slot cut without a boolean); :mod:`.part` (a part's solid: :func:`part_solid`,
:func:`_build_one`); :mod:`.mesh` (preview meshes). Every name is re-exported here.
"""
from __future__ import annotations

from .boolean import SLOT_CUT_FUZZY, _cut, _main_piece, _slotted, _slotted_once  # noqa: F401
from .brep import _polyhedron_solid  # noqa: F401
from .direct import _slotted_direct  # noqa: F401
from .errors import InvalidSolidError, SlotCutError
from .faces import (  # noqa: F401
    _CLOSE_TOL, _coplanar, _dedup, _face, _fan_volume, _polygon_face, _polygon_volumes,
    _triangles_inside)
from .mesh import MESH_TOLERANCE, _face_triangles, _mesh, _triangles  # noqa: F401
from .occ import _box, _downcast, _is_valid, _solids_of, _valid, _volume  # noqa: F401
from .part import _build_one, _labelled, _part_shape, part_solid  # noqa: F401
from .plate import (  # noqa: F401
    _SEW_TOL, _fans, _plate, _plate_direct, _plate_outlines, _plate_polyhedron, _plate_sewn)
from .polygon_cut import _cut_polyhedron  # noqa: F401
from .sections import (  # noqa: F401
    _BITS, _BOX_EDGES, _BOX_FACES, _DIRECT_GAP, _DIRECT_MERGE, _DIRECT_PARALLEL,
    _DIRECT_SAME_PLANE, _box_geometry, _box_planes, _box_sections, _Decline, _Edges, _plane_axes,
    _polyhedron_section, _rings)
from .slots import (  # noqa: F401
    SINGLE_BOX_FOLD, _check_cut, _check_slots, _check_slots_polyhedron, _slot_area,
    _slot_box_frames, _slot_probes, _slot_record_area, slot_boxes)
from .whole_faces import _pieces, _straightened, _whole_faces  # noqa: F401

__all__ = ["InvalidSolidError", "SlotCutError", "part_solid", "slot_boxes", "SINGLE_BOX_FOLD",
           "SLOT_CUT_FUZZY", "MESH_TOLERANCE"]
