"""What the final cut's cuts cost against the sheets they save (:mod:`.final_cut`, step 2):
where a plate may be cut for yield, the fixings a cut adds, and whether cuts pay at the
user's rates (:class:`~torsal.fabrication.quantities.Rates`).

**Without rates** (no ``[costs]``: no price, none invented) the bill is compared in its own
quantities. A sheet saved is a whole sheet of material (on 3 mm aluminium, 2.5 x 1.25 m:
25 kg, and the cutting of its skeleton); a seam held in its crossing slot adds one contour
and one pierce (metres and pierces the report gives); a cut that leaves a piece nothing
holds to the building takes one fixing more (:func:`fixings_added`: a plate's fixings stay,
each on its piece, and a piece none falls on is held by the crossing plate at its seam
where the load path's slot rule says so; a piece hung in slots it slides out of takes its
own): one small bent bracket and its fasteners
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
    ``fs`` cut at that node line of ``cuts`` take than the plate, as the fin system rebuilt
    with the cut places them (:mod:`~torsal.fabrication.builder.fixings`):

    * a plate that carries others (a root of the assembly): its fixings stay, each on the
      piece it falls on (:func:`~torsal.fabrication.builder.fixings.fixing_shares`); a piece
      none falls on takes one only where none of its slot crossings holds it
      (:func:`~torsal.fabrication.builder.fixings.slot_held`, the seam's crossing plate
      among them): 0 or 1;
    * a plate hung in slots it would slide out of (one fixing of its own,
      ``AssemblyPlanner._slot_hung``): one for each piece that still hangs (a piece bolted by
      a connector to a root there hangs no more) less the plate's one;
    * a plate fixed because nothing else held it: one for each piece, less its one."""
    from ..builder.fixings import FixingPlacer, fixing_shares, slot_held
    from ..builder.paths import AssemblyPlanner

    if fs.fixing_spacing is None or fs.structure is None:
        return {}
    fixed = {site[0] for site in getattr(fs, "_fixing_sites", {}).values()}
    placer = FixingPlacer(fs)
    roots = {p.name for p in AssemblyPlanner(fs)._roots()}
    dips, bolted = _hanging(fs, roots)
    out = {}
    for name, js in cuts.items():
        p = fs.part(name)
        for j in map(int, js):
            halves = (p.nodes[:j + 1], p.nodes[j:])
            if name in roots and name in fixed:
                shares = fixing_shares(placer, [p.panels[:j], p.panels[j:]])
                n = sum(1 for c, nodes in zip(shares, halves)
                        if not c and not slot_held(fs, name, nodes))
            elif name in dips:
                n = sum(not bolted.get(name, set()) & {int(v) for v in nodes}
                        for nodes in halves) - int(name in fixed)
            else:
                n = int(name in fixed)
            out[(name, j)] = n
    return out


def _hanging(fs, roots: set) -> tuple[set, dict]:
    """``(dips, bolted)``: the family-1 plates of ``fs`` other than ``roots`` whose way out of
    an egg-crate slot dips (:func:`~torsal.fabrication.builder.paths.dipping_slot_plates`:
    hung in slots, ``AssemblyPlanner._slot_hung``), and ``{plate: nodes}`` where a connector
    bolts a plate to a root (or its end is bent into a tab bolted to one): kept per node, since
    a cut piece hangs unless one of its own nodes is bolted."""
    from ..builder.paths import dipping_slot_plates
    from ..model import JointKind

    dips = set(dipping_slot_plates(fs, exclude=roots))
    bolted: dict = {}
    for j in fs.joints:
        if j.kind != JointKind.EGG_CRATE and (j.connector or j.kind == JointKind.BUTT_TAB) \
                and roots & set(j.parts):
            # (a tab is the bracket the build held the plate with, bent from its end)
            for n in j.parts:
                bolted.setdefault(n, set()).add(int(j.node))
    return dips, bolted


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
