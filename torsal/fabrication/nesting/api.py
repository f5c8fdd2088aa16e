"""The sheets of a fin system's unrolled parts, by the nester the design asks for."""
from __future__ import annotations

import time
from typing import Callable, Mapping, Sequence

from ..cutting import Cutting
from ..layout import Layout
from .bottom_left import merge_layouts, nest, shelf_pack
from .rows import nest_rows
from .search import DEFAULT_TRIES, nest_search
from .stats import DEFAULT_SEED, Nester, NestStats
from .yield_ import nest_for_yield

__all__ = ["nest_parts"]


def nest_parts(unrolled: Mapping, *, connectors=frozenset(), sheet: tuple[float, float] = (2500.0, 1250.0),
               gap: float = 5.0, margin: float = 10.0, unit: str = "mm",
               cutting: Cutting | None = None, nester: Nester | str = Nester.BOTTOM_LEFT,
               rotations: Sequence[float] = (0, 90, 180, 270),
               time_limit: float | None = None, seed: int = DEFAULT_SEED,
               rotation_step: float | None = None, tries: int = DEFAULT_TRIES,
               progress: Callable[[int, int], None] | None = None) -> Layout:
    """The sheets of a fin system's unrolled parts ``{name: Unrolled}``: with
    :attr:`Nester.SPARROW` all parts together (rows, then sparrow empties sheets in
    ``time_limit`` seconds; :func:`~.yield_.nest_for_yield`), with :attr:`Nester.SEARCH` the
    final cut's deterministic search (``tries``; :func:`~.search.nest_search`), with
    :attr:`Nester.ROWS` the rows
    alone (:func:`~.rows.nest_rows`), with :attr:`Nester.BOTTOM_LEFT` the plates by
    :func:`~.bottom_left.nest` (``rotations``) and the ``connectors`` (names) in rows on the sheets
    after them (:func:`~.bottom_left.shelf_pack`). :class:`~.cutting.CuttingError` if the
    cutting process cannot cut the slots."""
    t0, c0 = time.perf_counter(), time.process_time()
    if cutting is not None:
        cutting.check_slots(unrolled.values())
    nester = Nester(nester)
    if nester == Nester.SPARROW:
        return nest_for_yield(list(unrolled.values()), sheet=sheet, gap=gap, margin=margin,
                              unit=unit, cutting=cutting, time_limit=time_limit, seed=seed,
                              rotation_step=rotation_step, progress=progress)
    if nester == Nester.SEARCH:
        return nest_search(list(unrolled.values()), sheet=sheet, gap=gap, margin=margin, unit=unit,
                           cutting=cutting, rotation_step=rotation_step, tries=tries,
                           time_limit=time_limit, progress=progress)
    if nester == Nester.ROWS:
        lay = nest_rows(list(unrolled.values()), sheet=sheet, gap=gap, margin=margin, unit=unit,
                        cutting=cutting, rotation_step=rotation_step)
        rotation = "free" if rotation_step is None else f"{rotation_step:g} deg steps"
    else:
        plates = nest([u for n, u in unrolled.items() if n not in connectors], sheet=sheet, gap=gap,
                      margin=margin, rotations=rotations, unit=unit, cutting=cutting)
        lay = plates
        if connectors:
            kit = shelf_pack([u for n, u in unrolled.items() if n in connectors], sheet=sheet, gap=gap,
                             margin=margin, unit=unit, first_sheet=plates.n_sheets, cutting=cutting)
            lay = merge_layouts(plates, kit)
        rotation = f"{len(rotations)} rotations"
    lay.stats = NestStats(nester.value, time.perf_counter() - t0, time.process_time() - c0,
                          lay.area_bound, rotation=rotation, sheet_fill=lay.sheet_utilization,
                          fallback_parts=len(lay.placements))
    return lay
