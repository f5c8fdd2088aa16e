"""Solid parts (OpenCascade) and their export: STEP, STL/glTF, 3DM (issue 6).

The public face of three modules, each with one job:

* :mod:`.plates`: the plate and slot solid of each part, built and checked with OCP (how:
  see there); :class:`InvalidSolidError` names any part that is not sound;
* :mod:`.workers`: the worker processes that build them (a :class:`WorkerPool` object that
  owns its processes, prepared ahead in a context variable) and the build
  (:func:`start_solids`, :func:`build_solids`, :func:`solid_shapes`);
* :mod:`.exports`: the files: STEP (nominal solids), Rhino 3DM (a closed Brep per part),
  glTF/STL previews, and :func:`read_step`.

build123d (2 s to import) is used only for the labelled ``Solid`` objects of
:func:`build_solids` / ``FinSystem.solids()``. Units: the ``unit`` of the fin system (mm by
default).
"""
from __future__ import annotations

from .exports import export_3dm, export_mesh, export_step, read_step, write_step, _tessellate  # noqa: F401
from .plates import (  # noqa: F401
    MESH_TOLERANCE, SINGLE_BOX_FOLD, InvalidSolidError, SlotCutError, _box, _build_one, _coplanar,
    _cut, _downcast, _face, _is_valid, _labelled, _mesh, _part_shape, _plate, _plate_direct,
    _plate_outlines, _plate_sewn, _slot_area, _slot_record_area, _slotted, _solids_of,
    _triangles, _valid, _volume, part_solid, slot_boxes)
from .workers import (  # noqa: F401
    PendingSolids, WorkerPool, _collect, _from_bytes, _parts_key, _to_bytes, _workers_for,
    build_solids, cancel_breps, default_workers, prepare_workers, release_workers, solid_shapes,
    start_solids)

__all__ = ["InvalidSolidError", "SlotCutError", "part_solid", "build_solids", "start_solids",
           "solid_shapes", "write_step", "prepare_workers", "release_workers",
           "PendingSolids", "default_workers", "WorkerPool",
           "export_step", "export_mesh", "export_3dm", "read_step"]
