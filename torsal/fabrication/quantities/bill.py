"""The bill of quantities of a fin system: what a workshop prices without opening CAD (issue 42).

Per part and per design, from the unrolled parts (:mod:`torsal.fabrication.unroll`), their
holes (:mod:`torsal.fabrication.builder.fasteners`), the nested sheets
(:class:`~torsal.fabrication.layout.Layout`) and the cutting process
(:class:`~torsal.fabrication.cutting.Cutting`):

* **net material**: the part's own area (the unrolled outline, slots and inner cut-outs
  removed, less its holes ``pi d^2 / 4``) in m^2, and that times the thickness and the
  density in kg;
* **gross material**: the sheets' share: the area of every sheet of the layout is allocated
  to the parts on it in proportion to their outline areas, so the parts' gross areas add up
  to the sheets used (the offcuts are charged to the parts that made them);
* **cut length**: the nominal contours cut (the outline's outer ring, open slots included,
  its inner rings, and the circumference ``pi d`` of every hole the process cuts; the
  toolpath runs ``kerf / 2`` off them and is not counted), in m;
* **pierces**: one per closed contour cut: the outer ring, every inner ring (a closed
  cut-out), every hole the process cuts; holes no wider than the tool are drilled
  (:meth:`Cutting.hole_path <torsal.fabrication.cutting.Cutting.hole_path>`), counted
  apart;
* **bends**: the folds of the part sharper than :data:`~torsal.fabrication.unroll.FLAT_FOLD`
  and their length on the flat part (a slot on a fold shortens it), in m;
* **fasteners**: by label (``"M6 bolt"``, ``"M8 anchor"``: size and
  :class:`FastenerKind`), counted on the connectors and fixings whose holes they go
  through (a bolt shared by two connectors on the two faces of a plate counted once, as
  :func:`~torsal.fabrication.builder.fasteners.fastener_counts` counts them);
* **assembly steps**: parts placed, fasteners set, holes drilled.

Units: lengths in m, areas in m^2, masses in kg, whatever the fin system's ``unit``.

Example
-------
>>> q = bill_of_quantities(fs, layout=layout, density=2700.0)          # doctest: +SKIP
>>> q.cut_m, q.pierces, q.bends, q.net_kg, q.gross_kg                   # doctest: +SKIP
>>> q.part("F0-S000-P00").cut_m                                        # doctest: +SKIP
"""
from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from enum import Enum
from typing import Mapping

import numpy as np
from shapely.geometry import LineString

from torsal.core.units import UNIT_TO_MM

from ..cutting import Cutting, Process
from ..model import CONNECTOR_FAMILY, FIXING_FAMILY, Part
from ..unroll import FLAT_FOLD, Unrolled

__all__ = ["FastenerKind", "split_fastener", "PartQuantities", "AssemblySteps", "Quantities",
           "part_quantities", "bill_of_quantities", "sheet_shares"]


class FastenerKind(str, Enum):
    """What a fastener fixes: a ``bolt`` through a connector and a fin, an ``anchor`` into
    the building."""

    BOLT = "bolt"
    ANCHOR = "anchor"


def split_fastener(label: str) -> tuple[str, FastenerKind]:
    """``(size, kind)`` of a fastener label as the holes name them
    (:attr:`~torsal.fabrication.model.Hole.fastener`, e.g. ``"M6 bolt"``).

    >>> split_fastener("M8 anchor")
    ('M8', <FastenerKind.ANCHOR: 'anchor'>)
    """
    size, _, kind = label.strip().rpartition(" ")
    try:
        return size, FastenerKind(kind)
    except ValueError:
        raise ValueError(f"fastener {label!r} is not '<size> <kind>' with kind one of "
                         f"{[k.value for k in FastenerKind]}") from None


@dataclass(frozen=True, kw_only=True)
class PartQuantities:
    """The quantities of one part.

    Attributes
    ----------
    name : str
        Part name, as in parts.csv and the STEP labels.
    net_m2, net_kg : float
        The part's own area (outline less holes), m^2, and its mass, kg.
    gross_m2, gross_kg : float or None
        The part's share of the sheets (m^2, kg); None without a layout.
    cut_m : float
        Length of the contours cut (outer ring, inner rings, holes cut), m.
    pierces : int
        Closed contours cut: 1 + inner rings + holes cut.
    holes_cut, holes_drilled : int
        Holes cut with the outline, holes drilled (no wider than the tool).
    bends : int
        Folds of the part (bends made on a press brake).
    bend_m : float
        Total length of the bend lines on the flat part, m.
    fasteners : dict of str to int
        Fasteners set through this part's own holes, by label (``"M6 bolt"``); only
        connectors and fixings have any (a fin plate's matching holes take their bolts).
    """

    name: str
    net_m2: float
    net_kg: float
    gross_m2: float | None
    gross_kg: float | None
    cut_m: float
    pierces: int
    holes_cut: int
    holes_drilled: int
    bends: int
    bend_m: float
    fasteners: Mapping[str, int] = field(default_factory=dict)

    @property
    def n_fasteners(self) -> int:
        """Fasteners set through the part's own holes."""
        return int(sum(self.fasteners.values()))


@dataclass(frozen=True)
class AssemblySteps:
    """The counted steps of building a design: ``parts_placed`` (every part, once),
    ``fasteners_set`` (bolts and anchors) and ``holes_drilled`` (holes no wider than the
    tool, drilled rather than cut)."""

    parts_placed: int
    fasteners_set: int
    holes_drilled: int


def _sum(values) -> float:
    return float(sum(values))


@dataclass(frozen=True, kw_only=True)
class Quantities:
    """The bill of quantities of a design: its parts' quantities and their totals.

    Attributes
    ----------
    parts : tuple of PartQuantities
        In the fin system's part order.
    process : Process or None
        The cutting process the holes were counted for (None: every hole cut).
    sheets : int or None
        Sheets used (None without a layout).
    sheet_m2 : float or None
        Area of one sheet, m^2.
    thickness_mm, density : float
        Sheet thickness (mm) and density (kg/m^3) of the masses.
    """

    parts: tuple[PartQuantities, ...]
    process: Process | None
    sheets: int | None
    sheet_m2: float | None
    thickness_mm: float
    density: float

    def part(self, name: str) -> PartQuantities:
        """The quantities of the part called ``name``."""
        for p in self.parts:
            if p.name == name:
                return p
        raise KeyError(f"no part {name!r}")

    net_m2 = property(lambda self: _sum(p.net_m2 for p in self.parts), doc="m^2")
    net_kg = property(lambda self: _sum(p.net_kg for p in self.parts), doc="kg")
    cut_m = property(lambda self: _sum(p.cut_m for p in self.parts), doc="m")
    bend_m = property(lambda self: _sum(p.bend_m for p in self.parts), doc="m")
    pierces = property(lambda self: int(sum(p.pierces for p in self.parts)))
    holes_cut = property(lambda self: int(sum(p.holes_cut for p in self.parts)))
    holes_drilled = property(lambda self: int(sum(p.holes_drilled for p in self.parts)))
    bends = property(lambda self: int(sum(p.bends for p in self.parts)))

    @property
    def gross_m2(self) -> float | None:
        """The sheets used, m^2 (the parts' gross areas add up to it); None without a layout."""
        return None if self.sheets is None else self.sheets * self.sheet_m2

    @property
    def gross_kg(self) -> float | None:
        """The sheets used, kg; None without a layout."""
        m2 = self.gross_m2
        return None if m2 is None else m2 * self.thickness_mm / 1000.0 * self.density

    @property
    def fasteners(self) -> dict[str, int]:
        """Fasteners by label (``"M6 bolt"``), sorted."""
        total: Counter = Counter()
        for p in self.parts:
            total.update(p.fasteners)
        return dict(sorted(total.items()))

    @property
    def assembly(self) -> AssemblySteps:
        return AssemblySteps(len(self.parts), int(sum(self.fasteners.values())), self.holes_drilled)

    def as_report(self) -> dict:
        """The design's totals for report.json (plain numbers; fasteners by kind, then size:
        ``{"bolt": {"M6": 120}}``)."""
        by_kind: dict[str, dict[str, int]] = {}
        for label, n in self.fasteners.items():
            size, kind = split_fastener(label)
            by_kind.setdefault(kind.value, {})[size] = n
        a = self.assembly
        return {"process": None if self.process is None else self.process.value,
                "parts": len(self.parts), "net_m2": self.net_m2, "net_kg": self.net_kg,
                "sheets": self.sheets, "gross_m2": self.gross_m2, "gross_kg": self.gross_kg,
                "cut_m": self.cut_m, "pierces": self.pierces, "holes_cut": self.holes_cut,
                "holes_drilled": self.holes_drilled, "bends": self.bends, "bend_m": self.bend_m,
                "fasteners": by_kind,
                "assembly": {"parts_placed": a.parts_placed, "fasteners_set": a.fasteners_set,
                             "holes_drilled": a.holes_drilled}}


def _bend_length(u: Unrolled) -> float:
    """Length of the bend lines of an unrolled part on its outline (``unit``)."""
    return float(sum(LineString(line).intersection(u.outline).length
                     for line, ang in zip(u.fold_lines, u.fold_angles) if abs(ang) > FLAT_FOLD))


def part_quantities(part: Part, unrolled: Unrolled, *, thickness: float, unit: str,
                    density: float, cutting: Cutting | None = None,
                    gross: float | None = None) -> PartQuantities:
    """The quantities of one part.

    Parameters
    ----------
    part : Part
        The part (its holes and family: a connector's or fixing's own holes take fasteners).
    unrolled : Unrolled
        The part laid flat (:func:`~torsal.fabrication.unroll.unroll`), ``unit``.
    thickness : float
        Sheet thickness, ``unit``.
    unit : str
        Length unit of the part, one of :data:`~torsal.core.units.UNITS`.
    density : float
        kg/m^3, > 0.
    cutting : Cutting, optional
        The process: holes it cannot cut are drilled (None: every hole is cut, as the DXF
        draws them without a process).
    gross : float, optional
        The part's share of the sheets, ``unit``^2 (:func:`sheet_shares`).
    """
    to_m = UNIT_TO_MM[unit] / 1000.0
    if cutting is not None:
        cutting = cutting.in_unit(unit)
    how = [("cut", d) if cutting is None else (cutting.hole_path(d)[0], d)
           for d in (float(h.diameter) for h in part.holes)]
    cut_d = [d for kind, d in how if kind == "cut"]
    outline = unrolled.outline
    net = outline.area - sum(0.25 * np.pi * float(h.diameter) ** 2 for h in part.holes)
    contours = outline.exterior.length + sum(r.length for r in outline.interiors)
    own = part.family in (CONNECTOR_FAMILY, FIXING_FAMILY)
    # (a fin plate's own holes: those of a tab bent from it, bolted to the plate it lies on)
    fasteners = Counter(h.fastener for h in part.holes
                        if (own or getattr(h, "own", False)) and not h.shared)
    kg_per_m2 = thickness * to_m * density
    return PartQuantities(
        name=part.name, net_m2=net * to_m ** 2, net_kg=net * to_m ** 2 * kg_per_m2,
        gross_m2=None if gross is None else gross * to_m ** 2,
        gross_kg=None if gross is None else gross * to_m ** 2 * kg_per_m2,
        cut_m=(contours + np.pi * sum(cut_d)) * to_m,
        pierces=1 + len(outline.interiors) + len(cut_d), holes_cut=len(cut_d),
        holes_drilled=len(how) - len(cut_d), bends=unrolled.fold_count,
        bend_m=_bend_length(unrolled) * to_m, fasteners=dict(sorted(fasteners.items())))


def sheet_shares(layout, *, unit: str) -> dict[str, float]:
    """``{part name: its share of the sheets}`` (``unit``^2): each sheet's area allocated to
    the parts on it in proportion to their outline areas (the shares of a sheet add up to
    it)."""
    f = (UNIT_TO_MM[layout.unit] / UNIT_TO_MM[unit]) ** 2
    sheet = layout.sheet[0] * layout.sheet[1] * f
    on: Counter = Counter()
    for p in layout.placements:
        on[p.sheet] += p.polygon.area
    return {p.name: sheet * p.polygon.area / on[p.sheet] for p in layout.placements}


def bill_of_quantities(fin_system, *, density: float, layout=None,
                       cutting: Cutting | None = None) -> Quantities:
    """The bill of quantities of a fin system (see the module docstring).

    Parameters
    ----------
    fin_system : FinSystem
        Its parts, unrolled (:meth:`~torsal.fabrication.parts.FinSystem.unrolled`),
        thickness and ``unit``.
    density : float
        kg/m^3 of the sheet material, > 0.
    layout : Layout, optional
        The nested sheets: gross material, and its cutting process (``layout.cutting``).
        Every part must be on it.
    cutting : Cutting, optional
        The cutting process, where there is no layout (a layout's own process is used
        otherwise; giving both is an error).

    Raises
    ------
    ValueError
        A density that is not > 0, a layout without some part, or two cutting processes.
    """
    if not (np.isfinite(density) and density > 0):
        raise ValueError(f"density must be > 0 kg/m^3, got {density}")
    if layout is not None and cutting is not None:
        raise ValueError("give the cutting process once: the layout has its own (layout.cutting)")
    if layout is not None:
        cutting = layout.cutting
    unit, t = fin_system.unit, fin_system.thickness
    shares = sheet_shares(layout, unit=unit) if layout is not None else {}
    missing = [p.name for p in fin_system.parts if layout is not None and p.name not in shares]
    if missing:
        raise ValueError(f"{len(missing)} parts are not on the layout's sheets "
                         f"({', '.join(missing[:5])}{' ...' if len(missing) > 5 else ''})")
    unrolled = fin_system.unrolled()
    parts = tuple(part_quantities(p, unrolled[p.name], thickness=t, unit=unit, density=density,
                                  cutting=cutting, gross=shares.get(p.name))
                  for p in fin_system.parts)
    sheet_m2 = None
    if layout is not None:
        sheet_m2 = layout.sheet[0] * layout.sheet[1] * (UNIT_TO_MM[layout.unit] / 1000.0) ** 2
    return Quantities(parts=parts, process=None if cutting is None else cutting.process,
                      sheets=None if layout is None else int(layout.n_sheets), sheet_m2=sheet_m2,
                      thickness_mm=t * UNIT_TO_MM[unit], density=float(density))
