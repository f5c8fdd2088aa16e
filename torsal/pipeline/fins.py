"""The design's fin system: one place that turns a design file's material and joinery keys
into :class:`~torsal.fabrication.FinSystem` options (used by the fabrication and assembly
stages)."""
from __future__ import annotations

from ..design_file import DesignSpec

__all__ = ["fin_system"]


def fin_system(spec: DesignSpec, structure):
    """The design's :class:`~torsal.fabrication.FinSystem` (material, sheet and joinery limits
    of the design file; parts in mm)."""
    from ..fabrication import FinSystem

    m = spec.material
    options = {}
    # unset: the joinery's own limit (torsal.fabrication.joints.MAX_CROSSING_FOLD)
    if spec.fins.max_fold_at_crossing is not None:
        options["max_crossing_fold"] = spec.fins.max_fold_at_crossing
    return FinSystem(structure, m.thickness_mm, family_split=m.family_split.value,
                     clearance=m.clearance_mm, fit_sheet=tuple(m.sheet_mm),
                     model_unit=spec.units, unit="mm", **options)
