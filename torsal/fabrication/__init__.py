"""Fabrication: fins and strips as parts, joints, solids, unrolled strips, nested sheets, parts list.

Reads a :class:`~torsal.geometry.support.SupportStructure` (model units, metres by default)
and knows nothing of how it was optimized. Fabrication lengths are in ``unit`` (mm).
"""
from torsal.core.lazy import lazy_exports
from .unroll import Unrolled, fold_back, unroll
__getattr__, __dir__ = lazy_exports(__name__, {
    ".layout": ("Layout", "PartTooLargeError", "Placement", "bill_of_materials", "read_dxf_parts"),
    ".nesting": ("nest",),
    ".joints": ("MAX_CROSSING_FOLD", "MIN_CROSSING_ANGLE", "slot_width"),
    ".model": ("Joint", "JointKind"),
    ".parts": ("Crossing", "FamilySplit", "FinSystem", "Part", "PartId", "Slot", "SlotSide",
               "fold_angles", "quad_normals"),
    ".solids": ("InvalidSolidError", "export_step", "part_solid", "read_step"),
    ".ifc": ("export_ifc",),
    ".assembly": ("AssemblyCheck", "AssemblyJoint", "AssemblyStep", "Interference",
                  "check_assembly", "face_polygons", "joints_of", "verify_assembly"),
})

__all__ = [
    "FinSystem", "FamilySplit", "Part", "PartId", "Slot", "SlotSide", "Crossing",
    "fold_angles", "quad_normals", "Unrolled", "unroll", "fold_back", "nest", "Layout",
    "Placement", "PartTooLargeError", "bill_of_materials", "read_dxf_parts",
    "InvalidSolidError", "part_solid", "export_step", "read_step", "export_ifc", "Joint", "JointKind",
    "slot_width", "MIN_CROSSING_ANGLE", "MAX_CROSSING_FOLD",
    "AssemblyCheck", "AssemblyJoint", "AssemblyStep", "Interference", "check_assembly",
    "joints_of", "verify_assembly", "face_polygons",
]
