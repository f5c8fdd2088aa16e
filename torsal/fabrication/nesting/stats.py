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
    """Which nester places the parts."""

    #: rows of true shapes, then sparrow empties the emptiest sheets in a time budget
    #: (:func:`~.yield_.nest_for_yield`)
    SPARROW = "sparrow"
    #: rows of true shapes end to end, no search (:func:`~.rows.nest_rows`; a second or two)
    ROWS = "rows"
    #: the fast bottom-left fill (:func:`~torsal.fabrication.layout.nest`), connectors in rows
    #: after the plates
    BOTTOM_LEFT = "bottom-left"


@dataclass
class NestStats:
    """How a nesting went (for the report).

    ``seconds`` wall clock, ``cpu_seconds`` of this process; ``solves`` sparrow calls;
    ``area_bound`` parts' area / sheet area (the sheets a perfect nest would need);
    ``fallback_parts`` parts left where the row layout put them; ``time_limited`` whether the
    time budget ended the search (False: it stopped at the area bound's ceiling or found
    nothing more to try); ``start_sheets`` the sheets of the row layout the search started
    from; ``moves`` parts sparrow moved to another sheet; ``sheets_emptied`` sheets it freed.
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
