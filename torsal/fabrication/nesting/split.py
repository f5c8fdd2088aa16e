"""Plates cut where that empties a sheet: the final cut's splits for yield (issues 40, 42).

The search (:mod:`.search`) cannot go below the crossing bound (:mod:`.bounds`): parts longer
than half the sheet each take a row of it, and on the facades the rows of 1.5-2.1 m plates
leave 0.4-0.9 m of every 2.48 m row that too few short parts fill (7a: 39 sheets, 77 %).
Cut such a plate at a node line, and its pieces fill those row ends. Where a plate may be cut
is given (``cuts``: where the seam stays inside a crossing slot, no connector,
:func:`~torsal.fabrication.builder.seams.yield_cut_positions`); which plates are cut, and
where, is decided here:

A. **Sheets emptied by cuts** (:class:`~.split_phase.SplitPhase`, on the searched sheets). The emptiest
   sheet is the *victim*. Its parts, largest first, are dropped onto the other sheets as they
   are (the search's skyline drop, then its hole filler) or packed afresh with a host's parts
   (the search's repack); a part that finds no place is **cut** at one of its node lines: of
   its two pieces the largest that drops onto another sheet goes there, the other stays on
   the victim and is tried in its turn (dropped, cut again). A piece is the part's flat
   outline between two node lines (a *stand-in*: the fin system builds the real pieces
   afterwards, :mod:`.final_cut`; :mod:`.pieces`), so it lies where the part lay. Where the victim empties,
   its cuts must *pay* (``pays``, the bill of quantities: each cut adds its contour, a pierce
   and a part to place, removes the bend it is on, and may add fixings); a victim that does
   not empty, or whose cuts do not pay, is put back as it was (no cut is kept that saved no
   sheet) and the next emptiest is tried.
B. **Cuts for the rows** (:class:`~.row_plan.RowPlan`). The same, in one dimension, on rows of the
   sheet's length: every plate an effective length (its area over its width: parallelograms
   head to tail), the rows filled best fit decreasing, then rows emptied into the others'
   ends by cuts. The cuts that bring the rows down to a sheet fewer, two, ... (at most
   :data:`ROW_PLANS` of them) are made before the search, which runs afresh on the pieces,
   and then A again.

Of the layouts whose cuts pay, the one with the fewest sheets, then the fewest fixings
added, then the fewest cuts, is kept. Every step counts its tries (drops and repacks), never seconds: the same parts, cuts
and options give the same sheets on every machine.

Units: those of the outlines.
"""
from __future__ import annotations

import copy
import dataclasses
import time
from dataclasses import dataclass, field
from typing import Callable, Mapping, NamedTuple, Sequence

from ..layout import Layout
from .pieces import CutCost, Pieces, cut_outlines, piece_name
from .row_plan import RowPlan
from .search import DEFAULT_TRIES, _Search
from .split_phase import SplitPhase

__all__ = ["CutCost", "SplitNesting", "nest_split", "DEFAULT_SPLIT_TRIES", "piece_name"]

#: drops and repacks the split phase may make (a drop: one part tried on one sheet)
DEFAULT_SPLIT_TRIES = 2000
#: row plans (:class:`~.row_plan.RowPlan`) whose cuts are nested afresh at most
ROW_PLANS = 2


@dataclass
class SplitNesting:
    """The final cut with plates split (:func:`nest_split`).

    ``base`` the search's layout without a split (what :func:`~.search.nest_search` gives);
    ``layout`` the sheets with the pieces (stand-ins named by :func:`piece_name`; ``base``
    itself where nothing was split); ``cuts`` ``{part: (node lines of the part cut)}``;
    ``pieces`` ``{stand-in name: (part, lo, hi)}`` of the pieces laid out; ``costs`` the
    :class:`CutCost` of every cut kept; ``sheets`` the sheets emptied by the cuts, each with
    the cuts it took (``[(cuts, sheets after)]``); ``tries`` the drops and repacks made."""

    base: Layout
    layout: Layout
    cuts: dict = field(default_factory=dict)
    pieces: dict = field(default_factory=dict)
    costs: list = field(default_factory=list)
    sheets: list = field(default_factory=list)
    tries: int = 0
    refused: int = 0
    #: why no plate was cut (empty where some were)
    why: str = ""

    @property
    def sheets_saved(self) -> int:
        return self.base.n_sheets - self.layout.n_sheets

    @property
    def n_cuts(self) -> int:
        return sum(len(c) for c in self.cuts.values())


class _Candidate(NamedTuple):
    """A layout whose cuts may be kept: its ``sheets``, ``cuts`` (how many), ``layout``, the
    parts and pieces laid out (``names``), the :class:`CutCost` of its cuts and the sheets
    they emptied (``steps``, :attr:`~.split_phase.SplitPhase.sheets`)."""

    sheets: int
    cuts: int
    layout: Layout
    names: tuple
    costs: list
    steps: list

    @property
    def rank(self) -> tuple[int, int, int]:
        """The fewest sheets, then the fewest fixings added (each a bracket, its bolts and
        an anchor drilled into the building, where a seam in its slot adds only a contour),
        then the fewest cuts: the smaller the better."""
        return self.sheets, sum(c.fixings for c in self.costs), self.cuts


class _SplitRun:
    """One :func:`nest_split`: the search's sheets ``search`` (run), its layout ``base``, the
    ``pieces`` that may be cut and whether cuts ``pay``; :meth:`phase` (step A) and
    :meth:`row_plans` (step B) give the candidates, :meth:`result` the best."""

    def __init__(self, search: _Search, pieces: Pieces, pays: Callable, options: dict,
                 split_tries: int):
        self.search, self.pieces, self.pays = search, pieces, pays
        self.options, self.split_tries = options, split_tries
        self.base = search.layout()
        self.n0 = self.base.n_sheets
        #: the parts as the search had them (step A adds its pieces to the search's)
        self.names = list(search.by_name)
        self.used = 0
        self.t0, self.c0 = search.t0, search.c0

    def phase(self, s: _Search, before: list) -> _Candidate:
        """Step A on the sheets of ``s`` (run), after the cuts ``before`` (step B's)."""
        ph = SplitPhase(s, self.pieces.bind(s), self.pays, self.split_tries,
                        self.options["progress"], before=before, saved_from=self.n0)
        ph.run()
        self.used += ph.used()
        lay = s.layout()
        laid = tuple(sorted(n for sh in s.emptier.sheets for n in sh))
        return _Candidate(lay.n_sheets, len(before) + len(ph.made), lay, laid, before + ph.made,
                          ph.sheets)

    def row_plans(self, best: _Candidate) -> list[_Candidate]:
        """Step B: the rows' cuts for a sheet fewer than ``best``, two, ... (at most
        :data:`ROW_PLANS` plans; stopped where two plans in a row miss the sheets they aim at,
        or where the cuts cost more than those sheets are worth), each nested afresh, then
        step A; the candidates whose cuts pay."""
        search, pieces, pays, n0 = self.search, self.pieces, self.pays, self.n0
        names = self.names
        plan = RowPlan(pieces, names, search.frame)
        plan.run(0)
        per_sheet = len(plan.rows) / n0
        tried: set = set()
        found, misses = [], 0
        for target in range(best.sheets - 1, search.by_area - 1, -1):
            state = next((st for st in plan.states if st[0] <= per_sheet * target + 1e-9), None)
            if state is None or len(tried) >= ROW_PLANS or misses >= 2:
                break
            key = tuple(sorted(state[1]))
            if not key or key in tried:
                continue
            tried.add(key)
            by_part: dict[str, set] = {}
            for part, j in state[1]:
                by_part.setdefault(part, set()).add(j)
            outs = cut_outlines(pieces, names, by_part)
            if outs is None:
                continue
            before = [pieces.cost(part, j) for part, j in sorted(state[1])]
            if not pays(before, n0 - target):
                break                     # more cuts than the sheets they aim at are worth
            s = _Search(outs, plan=state[2], **self.options)
            s.run()
            cand = self.phase(s, before)
            if cand.sheets < n0 and pays(cand.costs, n0 - cand.sheets):
                found.append(cand)
            # two plans in a row that miss the sheets they aim at: the rows' cuts do not
            # reach them
            misses = misses + 1 if cand.sheets > target else 0
        return found

    def result(self, found: list[_Candidate]) -> SplitNesting:
        """The :class:`SplitNesting` of the best candidate (:attr:`_Candidate.rank`: the
        fewest sheets, then fixings added, then cuts) among those that save a sheet and whose
        cuts pay."""
        base, n0, pays = self.base, self.n0, self.pays
        ok = [c for c in found if c.sheets < n0 and (not c.cuts or pays(c.costs, n0 - c.sheets))]
        seconds = dict(seconds=time.perf_counter() - self.t0,
                       cpu_seconds=time.process_time() - self.c0)
        if not ok:
            res = SplitNesting(base, copy.copy(base), tries=self.used,
                               why=f"no cuts that pay emptied a sheet ({self.used} tries)")
            res.layout.stats = dataclasses.replace(base.stats, **seconds)
            return res
        best = min(ok, key=lambda c: c.rank)
        lay = best.layout
        # (the time of the whole split search, every candidate's)
        lay.stats.seconds, lay.stats.cpu_seconds = seconds["seconds"], seconds["cpu_seconds"]
        if not best.cuts:                 # (A's drops emptied a sheet the search left)
            return SplitNesting(base, lay, tries=self.used,
                                why="the sheets were emptied without a cut")
        lay.stats.method = (f"{base.stats.method}; then {best.cuts} cuts of plates, "
                            f"{n0 - best.sheets} sheets fewer")
        pieces = self.pieces
        made = pieces.cuts_of(best.names)
        costs = [pieces.cost(p, j) for p, js in made.items() for j in js]
        return SplitNesting(base, lay, cuts=made, costs=costs, sheets=best.steps, tries=self.used,
                            pieces={n: pieces.of[n] for n in best.names if n in pieces.of})


def nest_split(outlines, *, cuts: Mapping[str, Sequence[int]],
               pays: Callable[[list, int], bool] | None = None,
               fixings: Mapping[tuple[str, int], int] | None = None,
               sheet: tuple[float, float] = (2500.0, 1250.0), gap: float = 5.0, margin: float = 10.0,
               unit: str = "mm", cutting=None, rotation_step: float | None = None,
               tries: int = DEFAULT_TRIES, split_tries: int = DEFAULT_SPLIT_TRIES,
               time_limit: float | None = None, progress=None) -> SplitNesting:
    """The final cut (:func:`~.search.nest_search`), then plates split where that empties a
    sheet (see the module docstring).

    Parameters
    ----------
    outlines : sequence of Unrolled
        The flat parts (their panels and fold lines say where a node line runs).
    cuts : {part name: node lines}
        Where each part may be cut (node line ``j`` between its panels ``j - 1`` and ``j``).
    pays : callable, optional
        ``pays([CutCost, ...], sheets saved)``: whether those cuts are worth the sheets they
        save; None: every sheet saved is.
    fixings : {(part, node line): int}, optional
        The fixings a cut adds (:attr:`CutCost.fixings`).
    split_tries : int
        Drops and repacks each split phase may make.
    Other parameters are those of :func:`~.search.nest_search`.
    """
    options = dict(sheet=sheet, gap=gap, margin=margin, unit=unit, cutting=cutting,
                   rotation_step=rotation_step, tries=tries, time_limit=time_limit,
                   progress=progress)
    search = _Search(outlines, **options)
    search.run()
    unrolled = {u.name: u for u in outlines if hasattr(u, "panels")}
    pieces = Pieces(dict(search.by_name), unrolled, cuts, fixings)
    run = _SplitRun(search, pieces, pays or (lambda costs, saved: True), options, split_tries)
    base = run.base
    if not pieces.cuts or search.budget.time_limited or base.n_sheets <= search.by_area:
        why = ("no plate may be cut at a crossing slot" if not pieces.cuts else
               "the time limit cut the search" if search.budget.time_limited else
               "the sheets are at the area bound")
        return SplitNesting(base, base, why=why)
    found = [run.phase(search, [])]                      # A: the searched sheets
    found += run.row_plans(min(found, key=lambda c: (c.sheets, c.cuts)))      # B, then A
    return run.result(found)
