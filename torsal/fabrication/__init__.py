"""Fabrication: fins and strips as parts, joints, solids, unrolled strips, nested sheets, parts list.

Reads a :class:`~torsal.geometry.support.SupportStructure` (model units, metres by default)
and knows nothing of how it was optimized. Fabrication lengths are in ``unit`` (mm).
"""
from .layout import Layout, PartTooLargeError, Placement, bill_of_materials, read_dxf_parts
from .nesting import nest
from .joints import MAX_CROSSING_FOLD, MIN_CROSSING_ANGLE, slot_width
from .model import Joint, JointKind
from .parts import (Crossing, FamilySplit, FinSystem, Part, PartId, Slot, SlotSide, fold_angles,
                    quad_normals)
from .solids import InvalidSolidError, export_step, part_solid, read_step
from .ifc import export_ifc
from .unroll import Unrolled, fold_back, unroll
from .assembly import (AssemblyCheck, AssemblyJoint, AssemblyStep, Interference, check_assembly,
                       face_polygons, joints_of, verify_assembly)

__all__ = [
    "FinSystem", "FamilySplit", "Part", "PartId", "Slot", "SlotSide", "Crossing",
    "fold_angles", "quad_normals", "Unrolled", "unroll", "fold_back", "nest", "Layout",
    "Placement", "PartTooLargeError", "bill_of_materials", "read_dxf_parts",
    "InvalidSolidError", "part_solid", "export_step", "read_step", "export_ifc", "Joint", "JointKind",
    "slot_width", "MIN_CROSSING_ANGLE", "MAX_CROSSING_FOLD",
    "AssemblyCheck", "AssemblyJoint", "AssemblyStep", "Interference", "check_assembly",
    "joints_of", "verify_assembly", "face_polygons",
]
