"""What the final cut's cuts cost against the sheets they save (:mod:`.final_cut`, step 2):
where a plate may be cut for yield, the fixings a cut adds, and whether cuts pay at the
user's rates (:class:`~torsal.fabrication.quantities.Rates`).

**Without rates** (no ``[costs]``: no price, none invented) the bill is compared in its own
quantities. A sheet saved is a whole sheet of material (on 3 mm aluminium, 2.5 x 1.25 m:
25 kg, and the cutting of its skeleton); a seam held in its crossing slot adds one contour
and one pierce (metres and pierces the report gives); a plate fixed to the building, cut,
takes one fixing more (each piece is fixed): one small bent bracket and its fasteners
(7a: 0.004 m^2, 33 g, 0.13 % of the sheet saved; 2 M6 bolts and 2 M8 anchors). So a sheet saved pays for its seams
and at most :data:`FIXINGS_PER_SHEET_SAVED` fixing: cuts that add more fixings than that
per sheet they save are not made, and no cut may add a connector (a bracket or splice).
With rates, the rates decide, fixings and all.

Units: those of the fin system (``unit``); prices in the rates' currency.
"""
from __future__ import annotations

from typing import Callable, Mapping

from .pieces import CutCost

__all__ = ["cuts_pay", "fixings_added", "per_fixing", "yield_cut_sites",
           "FIXINGS_PER_SHEET_SAVED"]

#: without rates, the fixings one sheet saved may add (see the module docstring)
FIXINGS_PER_SHEET_SAVED = 1


def cuts_pay(rates, *, sheet, thickness: float, density: float, unit: str, process,
             per_fixing: float = 0.0) -> Callable:
    """``pays(cuts, sheets saved)`` of :func:`~.split.nest_split` from the user's
    :class:`~torsal.fabrication.quantities.Rates` (None: every sheet seams in their slots
    save pays, where the cuts add at most :data:`FIXINGS_PER_SHEET_SAVED` fixing a sheet
    saved; see the module docstring). ``sheet`` ``(w, h)`` and
    ``thickness`` in ``unit``, ``density`` kg/m^3, ``process`` the cutting process the cut rate
    is for, ``per_fixing`` what a fixing costs (its part, anchors and bolts)."""
    if rates is None:
        return lambda cuts, saved: saved > 0 and sum(c.fixings for c in cuts) <= \
            FIXINGS_PER_SHEET_SAVED * saved
    from torsal.core.units import UNIT_TO_MM

    m = UNIT_TO_MM[unit] / 1000.0
    if rates.material_per_sheet is not None:
        per_sheet = float(rates.material_per_sheet)
    else:
        per_sheet = float(rates.material_per_kg) * sheet[0] * sheet[1] * thickness * m ** 3 * density
    cut = float(rates.cut_per_m.get(process, 0.0)) if process is not None else 0.0
    per_cut = rates.per_pierce + rates.per_minute * rates.minutes_per_part

    def pays(cuts: list[CutCost], saved: int) -> bool:
        cost = sum(c.cut * m * cut + per_cut - c.bend * rates.per_bend + c.fixings * per_fixing
                   for c in cuts)
        return saved > 0 and saved * per_sheet > cost

    return pays


def fixings_added(fs, cuts: Mapping[str, tuple]) -> dict[tuple[str, int], int]:
    """``{(plate, node line): fixings}``: how many fixings more the two pieces of a plate of
    ``fs`` cut at that node line of ``cuts`` take than the plate (a plate fixed to the building,
    :mod:`~torsal.fabrication.builder.fixings`: each piece is, one near each end)."""
    from types import SimpleNamespace

    from ..builder.fixings import FixingPlacer

    fixed = {site[0] for site in getattr(fs, "_fixing_sites", {}).values()}
    if fs.fixing_spacing is None or not fixed:
        return {}
    count = FixingPlacer(fs)._count
    out = {}
    for name, js in cuts.items():
        if name not in fixed:
            continue
        p = fs.part(name)
        whole = count(p)
        for j in js:
            out[(name, int(j))] = (count(SimpleNamespace(panels=p.panels[:j]))
                                   + count(SimpleNamespace(panels=p.panels[j:])) - whole)
    return out


def per_fixing(fs, rates, density: float, cutting) -> float:
    """What a fixing of ``fs`` costs at ``rates`` on average: its contour, pierces, fasteners,
    placing it and setting its fasteners (0 without rates or fixings)."""
    if rates is None or not fs.fixings:
        return 0.0
    from ..quantities import part_quantities

    u = fs.unrolled()
    cut = 0.0 if cutting is None else float(rates.cut_per_m.get(cutting.process, 0.0))
    total = 0.0
    for p in fs.fixings:
        q = part_quantities(p, u[p.name], thickness=fs.thickness, unit=fs.unit, density=density,
                            cutting=cutting)
        total += (q.cut_m * cut + q.pierces * rates.per_pierce
                  + rates.per_minute * (rates.minutes_per_part
                                        + q.n_fasteners * rates.minutes_per_fastener)
                  + sum(n * rates.fastener_rate(label) for label, n in q.fasteners.items()))
    return total / len(fs.fixings)


def yield_cut_sites(fs, rates=None) -> tuple[dict, dict]:
    """``(cuts, fixings)``: where the plates of ``fs`` may be cut for yield
    (:func:`~torsal.fabrication.builder.seams.yield_cut_positions`) and the fixings each cut
    adds (:func:`fixings_added`); without ``rates`` only the cuts that add at most
    :data:`FIXINGS_PER_SHEET_SAVED` fixing (whether a sheet saved pays for them,
    :func:`cuts_pay` decides)."""
    from ..builder.seams import yield_cut_positions

    cuts = yield_cut_positions(fs)
    fixings = fixings_added(fs, cuts)
    if rates is None:          # no price: contour, pierces and at most one fixing
        cuts = {n: tuple(j for j in js if fixings.get((n, j), 0) <= FIXINGS_PER_SHEET_SAVED)
                for n, js in cuts.items()}
        cuts = {n: js for n, js in cuts.items() if js}
    return cuts, fixings
