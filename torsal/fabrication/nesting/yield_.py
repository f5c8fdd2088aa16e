"""Nesting for yield: rows of true shapes, then sparrow empties the emptiest sheets in a time
budget.

Why not one sparrow strip cut into sheets: sparrow (through ``spyrrow`` 0.9) packs one strip
of fixed height, with no bins and no fixed obstacles. Unrolled fins are strips up to a sheet
long (7a: 134 of its 172 plates are longer than half the sheet), so every cut at a sheet
length crosses parts; measured on 7a, a 30 s strip at 80 % density gave windows of one sheet
length 28 % full. Sparrow filling one sheet at a time from a chosen set (the nester before
this one) packed its first sheets 80-87 % full but spent its budget on them and left the
awkward parts to a fallback (47 sheets in 120 s at load 9, 42 in 300 s). So:

1. **Rows** (:func:`~.rows.row_layout`): every part turned along its minimum rotated
   rectangle (half a turn more where its end meets its neighbour's), end to end in rows with
   the exact spacing of the true shapes, best fit decreasing; connectors in the row ends and
   the strip above the rows. About a second; a valid layout (7a: 44 sheets, 69 %).
2. **Empty sheets with sparrow** while the time lasts: the sheet with the least part area is
   the *victim*; its parts, largest first, are offered to the sheets with the most room (a
   host's parts plus the offer, packed afresh by sparrow on one sheet of true shapes, any
   rotation); where sparrow fits them all on the host and shapely agrees (inside the
   margins, ``gap`` between cuts), they move. A victim that is emptied is one sheet fewer; one
   whose largest part finds no host is set aside (the parts that moved stay moved: every
   sheet is valid at every step). It stops at the area bound's ceiling, when no victim is
   left to try, or when the budget cannot pay for another solve (``stats.time_limited``).
3. The fast bottom-left layout (:func:`~.bottom_left.nest`) is made too for up to
   :data:`FAST_COMPARE_PARTS` parts and kept if it needs fewer sheets (``stats.method`` says
   which layout was kept).

What caps the yield of unrolled fins is their length against the sheet's: a part longer than
half the sheet shares a row only with a part whose end interlocks with its own. On 7a, 134 of
the 172 plates are longer than half the sheet (strips too long for a sheet are halved) and at
most 7 pairs of them fit one row end to end (an upper bound by bipartite matching), so laid
along the sheet they need at least 127 rows, 42.3 sheets of three rows (72 %); sparrow gets
below that only by tilting parts (7a: 40 sheets, 76 %, 120 s at load 11-13). Split at the
sheet's length instead (``FinSystem(max_part_length=2400)``, 423 parts), the same strips take
39 sheets in rows alone (77.9 %) and 38 with sparrow (80.0 %, 120 s at load 12).

Time: ``time_limit`` seconds (wall clock) for the whole nesting; each sparrow solve is given
2 s of exploration and 1 of compression and is planned with the ratio of wall seconds to
given seconds measured so far (a loaded machine stretches them).

Determinism: every sparrow solve gets ``seed`` and one thread and the victims and hosts are
taken in a fixed order, so a run repeats exactly where each solve converges within its
seconds; under load a solve explores less and the sheets may differ. The report names the
seed and the seconds.

Units: those of the outlines (``unit``).

Example
-------
>>> from shapely.geometry import box
>>> parts = {f"p{i}": box(0, 0, 300 + 20 * i, 100) for i in range(6)}
>>> lay = nest_for_yield(parts, sheet=(1000, 500), gap=5, margin=10, time_limit=5, compare_fast=False)
>>> lay.n_sheets
1
"""
from __future__ import annotations

import time
from typing import Callable

import numpy as np

from ..cutting import Cutting
from ..layout import Layout, placement_of
from .bottom_left import merge_layouts, nest, shelf_pack
from .rows import SMALL, prepare, row_layout
from .search import SheetEmptier
from .sparrow import SheetSolver
from .stats import DEFAULT_SEED, DEFAULT_TIME_LIMIT, SECONDS_PER_SHEET, Nester, NestStats

__all__ = ["nest_for_yield", "FAST_COMPARE_PARTS"]

#: the fast bottom-left layout is made too, and kept if it needs fewer sheets, up to this many
#: parts (beyond, it takes tens of seconds to minutes)
FAST_COMPARE_PARTS = 1500
#: sparrow's seconds of exploration and compression per solve
_EXPLORE, _COMPRESS = 2, 1
#: a host is offered parts up to this share of its usable area
_HOST_FILL = 0.92
#: hosts tried for one offer
_HOSTS = 3


def nest_for_yield(outlines, *, sheet: tuple[float, float] = (2500.0, 1250.0), gap: float = 5.0,
                   margin: float = 10.0, unit: str = "mm", cutting: Cutting | None = None,
                   time_limit: float | None = None, seed: int = DEFAULT_SEED,
                   rotation_step: float | None = None, compare_fast: bool = True,
                   progress: Callable[[int, int], None] | None = None) -> Layout:
    """Nest flat parts on as few sheets as the time allows (see the module docstring).

    Parameters
    ----------
    outlines : sequence of Unrolled, of (name, Polygon), of Polygon, or {name: Polygon}
        Flat parts in ``unit``.
    sheet : (width, height)
        Sheet size, ``unit``.
    gap, margin : float
        Sheet left between the cuts of two parts, and between a cut and the sheet edge
        (``unit``; see :func:`~.layout.spacing`).
    cutting : Cutting, optional
        The cutting process (kerf, reliefs); None: cut on the outline.
    time_limit : float, optional
        Seconds (wall clock) for the whole nesting, at least 1; default
        :data:`SECONDS_PER_SHEET` per sheet the parts' area needs, at most
        :data:`DEFAULT_TIME_LIMIT`.
    seed : int
        Sparrow's seed.
    rotation_step : float, optional
        Allowed rotations in steps of this many degrees; None: any rotation.
    compare_fast : bool
        Make the fast bottom-left layout too and keep it where it needs fewer sheets (step 3).
    progress : callable, optional
        ``progress(sheets emptied, sheets still above the area bound)`` after each victim.

    Returns
    -------
    Layout
        With :attr:`~.layout.Layout.stats` a :class:`NestStats`.

    Raises
    ------
    PartTooLargeError
        If a part fits the sheet in no rotation.
    """
    t0, c0 = time.perf_counter(), time.process_time()
    if time_limit is not None and not time_limit >= 1:
        raise ValueError(f"time_limit must be at least 1 s, got {time_limit}")
    if rotation_step is not None and not 0 < rotation_step <= 360:
        raise ValueError(f"rotation_step must be in (0, 360] degrees, got {rotation_step}")
    w, h, items, sep, edge = prepare(outlines, sheet, gap, margin, cutting, unit)
    by_name = {it.name: it for it in items}
    area = {n: it.outline.area for n, it in by_name.items()}
    total = sum(area.values())
    usable = (w - 2 * edge) * (h - 2 * edge)
    if time_limit is None:
        time_limit = min(DEFAULT_TIME_LIMIT, SECONDS_PER_SHEET * max(1.0, np.ceil(total / usable)))
    # the fast bottom-left layout first: its seconds are part of the budget
    fast = None
    if compare_fast and len(items) <= FAST_COMPARE_PARTS:
        small = {n for n, a in area.items() if a < SMALL * usable}
        large = nest([it for it in items if it.name not in small], sheet=sheet, gap=gap,
                     margin=margin, unit=unit, cutting=cutting)
        fast = merge_layouts(large, shelf_pack(
            [it for it in items if it.name in small], sheet=sheet, gap=gap, margin=margin,
            unit=unit, cutting=cutting, first_sheet=large.n_sheets))
    where = row_layout(items, w, h, sep, edge, rotation_step)
    sheets: list[dict] = []
    for n, (si, rot, off) in sorted(where.items(), key=lambda kv: kv[1][0]):
        while len(sheets) <= si:
            sheets.append({})
        sheets[si][n] = (rot, off)
    solver = SheetSolver({n: it.outline for n, it in by_name.items()}, w, h, sep, edge, seed,
                         rotation_step)
    budget = _Budget(solver, t0 + time_limit)
    search = SheetEmptier(sheets, area, fit=lambda names: solver.fit(names, _EXPLORE, _COMPRESS),
                          may_try=budget, usable=usable, floor=int(np.ceil(total / (w * h) - 1e-9)),
                          host_fill=_HOST_FILL, hosts=_HOSTS, progress=progress)
    search.run()
    placements = sorted((placement_of(by_name[n], si, rot, dx, dy)
                         for si, s in enumerate(search.sheets) for n, (rot, (dx, dy)) in s.items()),
                        key=lambda p: (p.sheet, p.name))
    lay = Layout((w, h), placements, len(search.sheets), unit=unit, gap=gap, margin=margin,
                 cutting=cutting)
    why = ("stopped by the time budget" if budget.time_limited else
           "at the area bound" if len(search.sheets) <= search.floor else "nothing more to try")
    stats = NestStats(f"{Nester.SPARROW.value} on rows ({search.emptied} sheets emptied, {why})",
                      0.0, 0.0, total / (w * h), solver.calls, seed, float(time_limit),
                      len(items) - len(search.repacked),
                      "free" if rotation_step is None else f"{rotation_step:g} deg steps",
                      lay.sheet_utilization, solver.seconds, budget.time_limited,
                      search.start_sheets, search.moves, search.emptied)
    if fast is not None and fast.n_sheets < lay.n_sheets:
        stats.method = f"{Nester.BOTTOM_LEFT.value} (fewer sheets than {stats.method})"
        stats.sheet_fill, stats.fallback_parts = fast.sheet_utilization, len(items)
        lay = fast
    stats.seconds, stats.cpu_seconds = time.perf_counter() - t0, time.process_time() - c0
    lay.stats = stats
    return lay


class _Budget:
    """Sparrow's wall-clock budget: one more solve while the time left pays for it at the
    ratio of wall to given seconds measured so far (a loaded machine stretches them)."""

    def __init__(self, solver: SheetSolver, deadline: float):
        self.solver, self.deadline = solver, deadline
        self.time_limited = False

    def __call__(self) -> bool:
        sv = self.solver
        ratio = max(1.0, sv.seconds / sv.asked) if sv.calls else 1.0
        if self.deadline - time.perf_counter() < (_EXPLORE + _COMPRESS) * ratio:
            self.time_limited = True
            return False
        return True
