"""Nesting: flat parts on as few sheets as possible, the same sheets on every machine.

* :mod:`.rows`: rows of true shapes end to end (:func:`nest_rows`), a second or two: every
  run's nester.
* :mod:`.skyline`: each part dropped into the hollow of the parts below it.
* :mod:`.search`: :func:`nest_search`, the final cut: the rows and the skyline, then sheets
  emptied in counted tries (deterministic).
* :mod:`.raster`: a part put into any hole of a sheet its true shape fits (cells, one FFT
  correlation): the search's hole filler.
* :mod:`.split`: :func:`~.split.nest_split`, the search, then plates cut at crossing slots
  where that empties a sheet that pays (stand-ins of the pieces, :mod:`.pieces`; sheets
  emptied by cuts, :mod:`.split_phase`; cuts planned for the rows, :mod:`.row_plan`).
* :mod:`.final_cut`: :func:`~.final_cut.final_cut`, a fin system's final cut: those cuts
  built (a new fin system, each cut a seam in its slot) and its pieces in their stand-ins'
  places (:mod:`.mapped`), kept where the bill of quantities says so (:mod:`.cut_costs`).
* :mod:`.sparrow`: one sheet packed by sparrow (``spyrrow``), true shapes, any rotation.
* :mod:`.yield_`: :func:`nest_for_yield`, the rows, then sparrow empties the emptiest sheets
  in the time budget.
* :mod:`.api`: :func:`nest_parts`, a fin system's parts by the nester a design asks for.
* :mod:`.stats`: :class:`Nester`, :class:`NestStats` and the defaults.
* :mod:`.bounds`: :func:`crossing_bound`, the sheets the parts longer than half the sheet
  need at least (they cross its middle): the search's floor.

* :mod:`.bottom_left`: :func:`nest`, the fast bottom-left fill, and the shelves for small parts.
* :mod:`.items`: the parts as every nester takes them.
"""
from torsal.core.lazy import lazy_exports
__getattr__, __dir__ = lazy_exports(__name__, {
    ".api": ("nest_parts",),
    ".bottom_left": ("merge_layouts", "nest", "shelf_pack"),
    ".bounds": ("crossing_bound",),
    ".rows": ("nest_rows",),
    ".search": ("DEFAULT_TRIES", "nest_search"),
    ".stats": ("DEFAULT_NESTER", "DEFAULT_SEED", "DEFAULT_TIME_LIMIT", "FINAL_CUT_NESTER",
               "SECONDS_PER_SHEET", "Nester", "NestStats"),
    ".yield_": ("nest_for_yield",),
})

__all__ = ["nest", "shelf_pack", "merge_layouts", "nest_for_yield", "nest_parts", "nest_rows", "nest_search", "Nester", "NestStats", "crossing_bound",
           "DEFAULT_TIME_LIMIT", "SECONDS_PER_SHEET", "DEFAULT_SEED", "DEFAULT_TRIES",
           "DEFAULT_NESTER", "FINAL_CUT_NESTER"]
