"""The nesters' names, defaults and the record of how a nesting went."""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

#: seconds the yield nester may take by default: this many per sheet the parts' area needs...
SECONDS_PER_SHEET = 4.0
#: ... and at most this many
DEFAULT_TIME_LIMIT = 120.0
#: sparrow's seed by default
DEFAULT_SEED = 0


class Nester(str, Enum):
    """Which nester places the parts.

    Every run nests with :attr:`ROWS` (deterministic, a second or two); the final cut, asked
    for with ``[nesting] final_cut`` or ``torsal design --final-cut``, with :attr:`SEARCH`
    (deterministic too: counted tries, never the clock). :attr:`SPARROW` stops on the clock,
    so its sheets change with the machine's load.
    """

    #: the final cut: the best of several deterministic starts (rows, skyline), then sheets
    #: emptied by repacking them into others, in counted tries (:func:`~.search.nest_search`)
    SEARCH = "search"
    #: rows of true shapes, then sparrow empties the emptiest sheets in a time budget
    #: (:func:`~.yield_.nest_for_yield`)
    SPARROW = "sparrow"
    #: rows of true shapes end to end, no search (:func:`~.rows.nest_rows`; a second or two)
    ROWS = "rows"
    #: the fast bottom-left fill (:func:`~.bottom_left.nest`), connectors in rows
    #: after the plates
    BOTTOM_LEFT = "bottom-left"


#: the nester of every run: deterministic and fast
DEFAULT_NESTER = Nester.ROWS
#: the nester of the final cut (``[nesting] final_cut``, ``torsal design --final-cut``)
FINAL_CUT_NESTER = Nester.SEARCH


@dataclass
class NestStats:
    """How a nesting went (for the report).

    ``seconds`` wall clock, ``cpu_seconds`` of this process; ``solves`` sparrow calls;
    ``area_bound`` parts' area / sheet area (the sheets a perfect nest would need);
    ``fallback_parts`` parts left where the row layout put them; ``time_limited`` whether the
    time budget ended the search (False: it stopped at the area bound's ceiling or found
    nothing more to try); ``start_sheets`` the sheets of the row layout the search started
    from; ``moves`` parts sparrow (or the search) moved to another sheet; ``sheets_emptied``
    sheets it freed.
    """

    method: str
    seconds: float
    cpu_seconds: float
    area_bound: float
    solves: int = 0
    seed: int | None = None
    time_limit: float | None = None
    fallback_parts: int = 0
    rotation: str = "free"
    sheet_fill: list = field(default_factory=list)
    solve_seconds: float = 0.0
    time_limited: bool = False
    start_sheets: int | None = None
    moves: int = 0
    sheets_emptied: int = 0
    #: tries the search made (a count: the same parts and options give the same layout)
    tries: int = 0
    #: the search's starts as ``{name: sheets}`` (:attr:`Nester.SEARCH`)
    starts: dict = field(default_factory=dict)
    #: the sheets the parts crossing every sheet's middle need at least
    #: (:func:`~.bounds.crossing_bound`; :attr:`Nester.SEARCH`, else None)
    crossing_bound: int | None = None
    #: the final cut's plates split for yield (:meth:`~.final_cut.YieldSplit.as_report`), or
    #: None where none was tried
    split: dict | None = None
