"""The one unit table of torsal: lengths per unit name, and DXF's ``$INSUNITS`` codes.

Model geometry is in the design's ``units`` (metres by default); fabrication lengths are in
millimetres unless a writer is told otherwise. Every conversion reads this table.

Examples
--------
>>> scale("m", "mm")
1000.0
>>> UNIT_TO_M["in"]
0.0254
"""
from __future__ import annotations

__all__ = ["UNIT_TO_MM", "UNIT_TO_M", "INSUNITS", "UNITS", "scale"]

#: millimetres per unit
UNIT_TO_MM: dict[str, float] = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4, "ft": 304.8}
#: metres per unit
UNIT_TO_M: dict[str, float] = {k: v / 1000.0 for k, v in UNIT_TO_MM.items()}
#: DXF ``$INSUNITS`` code per unit
INSUNITS: dict[str, int] = {"in": 1, "ft": 2, "mm": 4, "cm": 5, "m": 6}
#: the unit names torsal accepts
UNITS: tuple[str, ...] = tuple(UNIT_TO_MM)


def scale(from_unit: str, to_unit: str) -> float:
    """Factor that turns a length in ``from_unit`` into ``to_unit`` (both names from :data:`UNITS`).

    Raises ``ValueError`` naming the allowed units for an unknown name.
    """
    for u in (from_unit, to_unit):
        if u not in UNIT_TO_MM:
            raise ValueError(f"unknown unit {u!r}; use one of {sorted(UNIT_TO_MM)}")
    return UNIT_TO_MM[from_unit] / UNIT_TO_MM[to_unit]
