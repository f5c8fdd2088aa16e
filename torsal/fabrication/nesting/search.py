"""The final cut: deterministic nesting for yield, counted in tries, never in seconds.

1. **Starts.** The rows (:func:`~.rows.row_layout`: long parts end to end, slanted ends head
   to tail) and the skyline (:mod:`.skyline`: each part dropped into the hollow of the parts
   below), each in two orders (longest first, largest first); the start with the fewest
   sheets, then the fullest emptiest sheet, is kept. The rows win on straight strips (7a),
   the skyline on curved ones (9, 11). (The final cut's splits, :mod:`.split`, add the rows
   their plan asks for, :func:`~.rows.planned_layout`, and go on from the sheets the search
   found: :class:`_Search`.)
2. **Sheets emptied.** The emptiest sheet is the *victim*; its parts, largest first, are
   first dropped from above onto the fullest sheet that takes them as it is (:class:`_Dropper`:
   a row end, the strip above the rows), else offered to the sheets with the most room (a
   host's parts and the offer packed afresh on one sheet by the skyline, then by the rows);
   where all fit, they move. A victim that is emptied is one sheet fewer; one whose largest
   part finds no host is set aside.
3. **Parts gathered.** One of the three emptiest sheets and a fuller one (fullest first) are
   packed afresh together onto two sheets; where the first comes out fuller than the fuller of
   the two was, they are replaced (the parts gather on the full sheets and the slack on the
   empty ones), and the emptiest sheet is tried again (7d: 38 -> 37 sheets).

It stops at the floor, when nothing is left to try, or after ``tries`` repacks. The floor is
the larger of the area bound's ceiling and the crossing bound (:mod:`.bounds`: the parts longer
than half the sheet cross its middle, so their widths there fill the sheets' heights): no
layout of the search's goes below it, so a start already there is not searched.

Every step is a pure function of the parts and the options: the same design gives the same
sheets on any machine, however busy (``stats.tries`` counts the repacks). ``time_limit`` is
only a safety net: a search it cuts says so (``stats.time_limited``), and that result is the
one thing that can depend on the machine.

Units: those of the outlines (``unit``).

Example
-------
>>> from shapely.geometry import box
>>> parts = {f"p{i}": box(0, 0, 300 + 20 * i, 100) for i in range(6)}
>>> lay = nest_search(parts, sheet=(1000, 500), gap=5, margin=10)
>>> lay.n_sheets, lay.stats.time_limited
(1, False)
"""
from __future__ import annotations

import time
from typing import Callable, NamedTuple

import numpy as np
from shapely import affinity

from ..cutting import Cutting
from ..layout import Layout, placement_of
from .bounds import crossing_bound
from .raster import DEFAULT_CELLS, RasterGrid
from .rows import orientations, planned_layout, prepare, row_layout
from .skyline import DEFAULT_RESOLUTION, SkylinePacker, _edge_extremes, _grown_top, column_profiles
from .stats import Nester, NestStats

__all__ = ["nest_search", "SheetEmptier", "DEFAULT_TRIES"]

#: repacks the search may make (about 20-50 ms each on a 2.5 m sheet)
DEFAULT_TRIES = 600
#: a host is offered parts up to this share of its usable area
_HOST_FILL = 0.95
#: hosts tried for one offer
_HOSTS = 4


class _Frame(NamedTuple):
    """The usable sheet with rows along its longer side: ``length x height`` inside the
    edge; ``turn`` whether that frame is the sheet turned a quarter."""

    w: float
    h: float
    length: float
    height: float
    sep: float
    edge: float
    turn: bool

    @classmethod
    def of(cls, w, h, sep, edge) -> "_Frame":
        turn = h > w
        length, height = (h, w) if turn else (w, h)
        return cls(w, h, length - 2 * edge, height - 2 * edge, sep, edge, turn)

    def on_sheet(self, rot: float, shift, x: float, y: float) -> tuple[float, tuple]:
        """Rotation and offset on the sheet of an outline turned by ``rot``, moved by
        ``shift`` to the origin and placed at ``(x, y)`` of the usable frame."""
        dx, dy = shift[0] + x + self.edge, shift[1] + y + self.edge
        if self.turn:
            return (rot + 90.0) % 360.0, (self.w - dy, dx)
        return rot, (dx, dy)


class _Skyline:
    """The skyline packer over prepared parts: each part's orientations made once."""

    def __init__(self, items, frame: _Frame, rotation_step):
        self.frame, self.rotation_step = frame, rotation_step
        self.res = DEFAULT_RESOLUTION * frame.length
        self.options: dict[str, list] = {}
        self.area: dict[str, float] = {}
        self.length_of: dict[str, float] = {}
        self.add_items(items)

    def add_items(self, items) -> None:
        """Make the orientations of ``items`` (prepared parts)."""
        frame = self.frame
        names, outlines, rots = [], [], []
        for it in items:
            for r in orientations(it.outline, it.base, self.rotation_step, frame.length,
                                  frame.height, across=True):
                names.append(it.name)
                outlines.append(it.outline)
                rots.append(r)
        for p in column_profiles(outlines, rots, res=self.res, sep=frame.sep, names=names):
            if p.width <= frame.length + 1e-9 and p.height <= frame.height + 1e-9:
                self.options.setdefault(p.name, []).append(p)
        for it in items:
            self.area[it.name] = it.outline.area
            if it.name in self.options:
                self.length_of[it.name] = max(o.width for o in self.options[it.name])

    def order(self, names, by: str) -> list:
        key = (lambda n: (-self.length_of[n], -self.area[n], n)) if by == "length" else \
              (lambda n: (-self.area[n], -self.length_of[n], n))
        return sorted(names, key=key)

    def pack(self, names, by: str, *, one_sheet: bool = False) -> dict | None:
        """``{name: (sheet, rot, offset)}`` of ``names`` (None: ``one_sheet`` and they do not
        all fit one sheet)."""
        f = self.frame
        packer = SkylinePacker(f.length, f.height, f.sep, self.res)
        for k, n in enumerate(self.order(names, by)):
            if not packer.add(n, self.options[n], new_sheet=not (one_sheet and k)):
                return None
        return {n: (si, *f.on_sheet(o.rot, o.shift, x, y))
                for n, (si, o, x, y) in packer.placed.items()}


class _Dropper:
    """One part dropped from above onto a sheet as it is (the skyline of the parts already
    there, :mod:`.skyline`), its parts left where they are: a row end or the strip above the
    rows takes it without the sheet being packed afresh."""

    def __init__(self, sky: _Skyline, outlines: dict):
        f = sky.frame
        self.sky, self.frame, self.outlines = sky, f, outlines
        self.packer = SkylinePacker(f.length, f.height, f.sep, sky.res)
        self.edges = np.arange(self.packer.columns + 1) * sky.res
        self.low = {n: min(o.height for o in opts) for n, opts in sky.options.items()}
        self._kept: dict = {}

    def add_items(self, items) -> None:
        """Parts added to the skyline's (:meth:`_Skyline.add_items`, made first)."""
        for it in items:
            opts = self.sky.options.get(it.name)
            if opts:
                self.low[it.name] = min(o.height for o in opts)

    def skyline(self, sheet: dict) -> np.ndarray:
        """The skyline of the parts of ``sheet`` ``{name: (rot, offset)}`` (usable frame)."""
        key = tuple(sorted((n, r, tuple(o)) for n, (r, o) in sheet.items()))
        if key in self._kept:
            return self._kept[key]
        f, pk = self.frame, self.packer
        sky = np.zeros(pk.columns)
        for n, (rot, (dx, dy)) in sheet.items():
            c, s = np.cos(np.radians(rot)), np.sin(np.radians(rot))
            pts = np.asarray(self.outlines[n].exterior.coords) @ np.array([[c, s], [-s, c]]) + (dx, dy)
            if f.turn:                     # the sheet turned a quarter back into the frame
                pts = np.c_[pts[:, 1], f.w - pts[:, 0]]
            _, top = _edge_extremes(pts - f.edge, self.edges)
            sky = np.maximum(sky, _grown_top(top, pk.res, f.sep, pk.g)[pk.g: pk.g + pk.columns])
        if len(self._kept) > 4096:
            self._kept.clear()
        self._kept[key] = sky
        return sky

    def __call__(self, sheet: dict, name: str):
        """``(rot, offset)`` of ``name`` dropped onto ``sheet``, or None where it does not fit."""
        sky = self.skyline(sheet)
        if self.low[name] > self.frame.height - float(sky.min()) + 1e-9:
            return None
        best = self.packer._best_on(sky, self.sky.options[name])
        if best is None:
            return None
        _, x, y, o = best
        return self.frame.on_sheet(o.rot, o.shift, x * self.packer.res, y)


class _HoleFiller:
    """One part put into a hole of a sheet as it is (:mod:`.raster`: any free place its true
    shape fits, also under other parts and between them), the sheet's parts left where they
    are: where the skyline (:class:`_Dropper`) finds no place from above."""

    def __init__(self, frame: _Frame, outlines: dict, options: dict):
        self.frame, self.outlines = frame, outlines
        self.grid = RasterGrid(length=frame.length, height=frame.height, sep=frame.sep,
                               res=frame.length / DEFAULT_CELLS)
        self.options = options
        self.rots = {n: sorted({o.rot for o in opts}) for n, opts in options.items()}
        self._feet: dict = {}
        self._kept: dict = {}

    def add_items(self, items) -> None:
        """Parts added to the skyline's options (made first)."""
        for it in items:
            if it.name in self.options:
                self.rots[it.name] = sorted({o.rot for o in self.options[it.name]})

    def footprints(self, name: str) -> list:
        if name not in self._feet:
            self._feet[name] = [self.grid.footprint(self.outlines[name], r, name)
                                for r in self.rots[name]]
        return self._feet[name]

    def raster(self, sheet: dict):
        """The :class:`~.raster.RasterSheet` of ``sheet`` ``{name: (rot, offset)}``."""
        key = tuple(sorted((n, r, tuple(o)) for n, (r, o) in sheet.items()))
        if key in self._kept:
            return self._kept[key]
        f = self.frame
        rs = self.grid.sheet()
        for n, (rot, (dx, dy)) in sorted(sheet.items()):
            placed = affinity.translate(affinity.rotate(self.outlines[n], rot, origin=(0, 0)), dx, dy)
            if f.turn:                     # the sheet turned a quarter back into the frame
                placed = affinity.affine_transform(placed, (0, 1, -1, 0, 0, f.w))
            rs.add(affinity.translate(placed, -f.edge, -f.edge), n)
        if len(self._kept) > 64:             # a sheet and its FFT: about 0.6 MB
            self._kept.clear()
        self._kept[key] = rs
        return rs

    def __call__(self, sheet: dict, name: str):
        """``(rot, offset)`` of ``name`` put into a hole of ``sheet``, or None."""
        spot = self.grid.spot(self.raster(sheet), self.footprints(name))
        if spot is None:
            return None
        o = spot.footprint
        return self.frame.on_sheet(o.rot, o.shift, spot.x, spot.y)


class _Drops:
    """The skyline's drop, else the hole filler's; each answer remembered by the part and the
    sheet's content (a pure function of the two: asked again, as the split phase asks for the
    same pieces on the same sheets victim after victim, it is not worked out again).
    ``evaluations`` counts the answers worked out."""

    def __init__(self, *drops):
        self.drops = drops
        self.evaluations = 0
        self._known: dict = {}

    def __call__(self, sheet: dict, name: str):
        key = (name, tuple(sorted((n, r, tuple(o)) for n, (r, o) in sheet.items())))
        if key in self._known:
            return self._known[key]
        self.evaluations += 1
        at = None
        for d in self.drops:
            at = d(sheet, name)
            if at is not None:
                break
        if len(self._known) > 200_000:
            self._known.clear()
        self._known[key] = at
        return at


def _sheets(where: dict) -> list[dict]:
    """``[{name: (rot, offset)}]`` per sheet of ``{name: (sheet, rot, offset)}``."""
    sheets: list[dict] = []
    for n, (si, rot, off) in sorted(where.items(), key=lambda kv: (kv[1][0], kv[0])):
        while len(sheets) <= si:
            sheets.append({})
        sheets[si][n] = (rot, off)
    return sheets


class SheetEmptier:
    """Empties the emptiest sheets into the others, in place (step 2 of the module docstring;
    sparrow's search, :func:`~.yield_.nest_for_yield`, is the same loop with another packer).

    ``sheets`` ``[{name: (rot, offset)}]``, ``area`` ``{name: unit^2}``; ``fit(names)`` packs
    ``names`` on one sheet (``{name: (rot, offset)}``, or None); ``may_try()`` says whether
    the budget pays for one more ``fit``; ``floor`` the sheets no packing can go below; a host
    is offered parts up to ``host_fill`` of ``usable`` and ``hosts`` hosts are tried an offer.
    ``tries`` counts the fits, ``moves`` the parts moved, ``emptied`` the sheets freed,
    ``repacked`` the parts some fit placed.
    """

    def __init__(self, sheets, area, *, fit: Callable, may_try: Callable[[], bool],
                 usable: float, floor: int, host_fill: float = _HOST_FILL, hosts: int = _HOSTS,
                 progress=None, drop: Callable | None = None):
        self.sheets, self.area, self.fit, self.may_try = sheets, area, fit, may_try
        self.drop, self.drops = drop, 0
        self.usable, self.floor, self.host_fill, self.hosts = usable, floor, host_fill, hosts
        self.progress = progress
        self.start_sheets = len(sheets)
        self.tries = self.moves = self.emptied = 0
        self.repacked: set = set()

    def filled(self, s: dict) -> float:
        return sum(self.area[n] for n in s)

    def run(self, gather: Callable | None = None) -> None:
        """Empty sheets (the module docstring's step 2); then, with ``gather``, gather the
        parts onto the fuller sheets (:meth:`gather`) and try the emptiest sheet again after
        each change, while the budget lasts."""
        self._empty_all()
        while gather is not None and len(self.sheets) > self.floor and self.may_try() \
                and self.gather(gather):
            victim = min(self.sheets, key=lambda s: (self.filled(s), sorted(s)))
            if self.empty(victim):
                self.sheets.remove(victim)
                self.emptied += 1

    def _empty_all(self) -> None:
        aside: set = set()              # ids of victims whose largest part found no host
        while len(self.sheets) > self.floor and self.may_try():
            victims = [s for s in self.sheets if id(s) not in aside]
            if not victims:
                break
            victim = min(victims, key=lambda s: (self.filled(s), sorted(s)))
            if self.empty(victim):
                self.sheets.remove(victim)
                self.emptied += 1
            else:
                aside.add(id(victim))
            if self.progress is not None:
                self.progress(self.emptied, max(0, len(self.sheets) - self.floor))

    def empty(self, victim: dict) -> bool:
        """Move the victim's parts to other sheets; True if none is left."""
        while victim:
            parts = sorted(victim, key=lambda n: (-self.area[n], n))
            first = parts[0]
            if self.drop is not None and self._drop(victim, first):
                continue
            hosts = sorted((s for s in self.sheets if s is not victim),
                           key=lambda s: (self.filled(s), sorted(s)))
            hosts = [s for s in hosts if self.host_fill * self.usable - self.filled(s)
                     >= self.area[first]][:self.hosts]
            if not self._move(victim, parts, first, hosts):
                return False
        return True

    def gather(self, pack: Callable, victims: int = 3) -> bool:
        """Pack one of the ``victims`` emptiest sheets together with a fuller one (fullest
        first) onto two sheets, ``pack(names)`` (``[{name: (rot, offset)}]``, the first sheet
        filled first); where the first comes out fuller than the fuller of the two was, the
        two are replaced (the parts gather on the full sheets and the empty ones empty out;
        one sheet where they fit one). True when something changed."""
        order = sorted(self.sheets, key=lambda s: (self.filled(s), sorted(s)))
        for victim in order[:victims]:
            for host in sorted((s for s in self.sheets if s is not victim),
                               key=lambda s: (-self.filled(s), sorted(s))):
                if not self.may_try():
                    return False
                self.tries += 1
                new = pack(sorted(host) + sorted(victim))
                if len(new) == 1:
                    host.clear()
                    host.update(new[0])
                    self.sheets.remove(victim)
                    self.emptied += 1
                    return True
                if len(new) == 2 and self.filled(new[0]) > self.filled(host) + 1e-6 * self.usable:
                    host.clear()
                    host.update(new[0])
                    victim.clear()
                    victim.update(new[1])
                    return True
        return False

    def _drop(self, victim: dict, name: str) -> bool:
        """Drop ``name`` onto the fullest other sheet that takes it as it is."""
        for host in sorted((s for s in self.sheets if s is not victim),
                           key=lambda s: (-self.filled(s), sorted(s))):
            if self.usable - self.filled(host) < self.area[name]:
                continue
            self.drops += 1
            at = self.drop(host, name)
            if at is not None:
                host[name] = at
                del victim[name]
                self.repacked.add(name)
                self.moves += 1
                return True
        return False

    def _move(self, victim, parts, first, hosts) -> bool:
        for host in hosts:
            room = self.host_fill * self.usable - self.filled(host)
            offer, a = [], 0.0
            for n in parts:                  # the largest, then what else fits the room
                if a + self.area[n] <= room:
                    offer.append(n)
                    a += self.area[n]
            for attempt in (offer, [first]) if len(offer) > 1 else (offer,):
                if not self.may_try():
                    return False
                self.tries += 1
                fit = self.fit(sorted(host) + attempt)
                if fit is not None:
                    host.clear()
                    host.update(fit)
                    for n in attempt:
                        del victim[n]
                    self.repacked.update(fit)
                    self.moves += len(attempt)
                    return True
        return False


class _Counted:
    """The search's budget: ``tries`` fits, and ``deadline`` (wall clock) as a safety net."""

    def __init__(self, tries: int, deadline: float | None):
        self.tries, self.deadline = tries, deadline
        self.emptier: SheetEmptier | None = None
        self.time_limited = False

    def __call__(self) -> bool:
        if self.emptier.tries >= self.tries:
            return False
        if self.deadline is not None and time.perf_counter() > self.deadline:
            self.time_limited = True
            return False
        return True


def nest_search(outlines, *, sheet: tuple[float, float] = (2500.0, 1250.0), gap: float = 5.0,
                margin: float = 10.0, unit: str = "mm", cutting: Cutting | None = None,
                rotation_step: float | None = None, tries: int = DEFAULT_TRIES,
                time_limit: float | None = None,
                progress: Callable[[int, int], None] | None = None) -> Layout:
    """Nest flat parts for yield, deterministically (see the module docstring).

    Parameters
    ----------
    outlines : sequence of Unrolled, of (name, Polygon), of Polygon, or {name: Polygon}
        Flat parts in ``unit``.
    sheet : (width, height)
        Sheet size, ``unit``.
    gap, margin : float
        Sheet left between the cuts of two parts, and between a cut and the sheet edge.
    cutting : Cutting, optional
        The cutting process (kerf, reliefs); None: cut on the outline.
    rotation_step : float, optional
        Allowed rotations in steps of this many degrees; None: any rotation.
    tries : int
        Repacks the search may make (a count, so the result never depends on the clock).
    time_limit : float, optional
        A safety net in wall-clock seconds; a search it cuts says so (``time_limited``).
    progress : callable, optional
        ``progress(sheets emptied, sheets still above the area bound)`` after each victim.

    Returns
    -------
    Layout
        With :attr:`~.layout.Layout.stats` a :class:`NestStats` (``tries``, ``starts``).
    """
    search = _Search(outlines, sheet=sheet, gap=gap, margin=margin, unit=unit, cutting=cutting,
                     rotation_step=rotation_step, tries=tries, time_limit=time_limit,
                     progress=progress)
    search.run()
    return search.layout()


class _Search:
    """The final cut's search (:func:`nest_search`) as an object: its parts prepared, its
    packers and its sheets kept, so that a later phase (:mod:`.split`: plates split where
    that empties a sheet) goes on from the sheets it found, with parts it adds
    (:meth:`add_items`)."""

    def __init__(self, outlines, *, sheet, gap, margin, unit, cutting, rotation_step, tries,
                 time_limit, progress, sheets: list | None = None, plan: list | None = None):
        """``sheets`` (``[{name: (rot, offset)}]``): start from these sheets, not from the
        rows and the skyline (their parts among ``outlines``; :meth:`run` is not needed);
        ``plan`` (``[[name, ...], ...]``): rows of plates, one more start
        (:func:`~.rows.planned_layout`)."""
        self.t0, self.c0 = time.perf_counter(), time.process_time()
        if tries < 0:
            raise ValueError(f"tries must be >= 0, got {tries}")
        self.gap, self.margin, self.unit, self.cutting = gap, margin, unit, cutting
        self.rotation_step, self.tries, self.time_limit = rotation_step, tries, time_limit
        w, h, items, sep, edge = prepare(outlines, sheet, gap, margin, cutting, unit)
        self.w, self.h, self.sep, self.edge = w, h, sep, edge
        frame = self.frame = _Frame.of(w, h, sep, edge)
        by_name = self.by_name = {it.name: it for it in items}
        area = self.area = {n: it.outline.area for n, it in by_name.items()}
        sky = self.sky = _Skyline(items, frame, rotation_step)
        if sheets is None:
            starts = {f"rows by {by}": row_layout(items, w, h, sep, edge, rotation_step, order=by)
                      for by in ("length", "area")}
            for by in ("length", "area"):
                starts[f"skyline by {by}"] = sky.pack(list(by_name), by)
            if plan is not None:
                starts["rows as planned"] = planned_layout(items, plan, w, h, sep, edge,
                                                           rotation_step)
            fill = {k: _sheets(v) for k, v in starts.items()}
        else:
            fill = {"given": [dict(s) for s in sheets]}
        best = self.best = min(fill, key=lambda k: (len(fill[k]), -min(sum(area[n] for n in s)
                                                                       for s in fill[k]), k))
        self.total = sum(area.values())
        self.start_sheets = {k: len(v) for k, v in fill.items()}
        self.budget = _Counted(tries, None if time_limit is None else self.t0 + time_limit)
        self.by_area = int(np.ceil(self.total / (w * h) - 1e-9))
        outlines = self.outlines = {n: it.outline for n, it in by_name.items()}
        self.crossing = crossing_bound([it.outline for it in items], sheet=(w, h), sep=sep,
                                       edge=edge) if sheets is None else 0
        self.dropper = _Dropper(sky, outlines)
        self.holes = _HoleFiller(frame, outlines, sky.options)
        self.emptier = self.budget.emptier = SheetEmptier(
            fill[best], area, fit=self.repack, may_try=self.budget,
            usable=frame.length * frame.height, floor=max(self.by_area, self.crossing),
            progress=progress, drop=_Drops(self.dropper, self.holes))

    def add_items(self, items) -> None:
        """Parts the search did not start with (prepared :class:`~.items._Item` objects: the
        pieces of a split plate), known from now on to every packer."""
        items = [it for it in items if it.name not in self.by_name]
        for it in items:
            self.by_name[it.name] = it
            self.area[it.name] = it.outline.area
            self.outlines[it.name] = it.outline
        self.sky.add_items(items)
        self.dropper.add_items(items)
        self.holes.add_items(items)

    def repack(self, names):
        """``{name: (rot, offset)}`` of ``names`` packed afresh on one sheet, or None."""
        sky, f = self.sky, self.frame
        for by in ("length", "area"):
            where = sky.pack(names, by, one_sheet=True)
            if where is not None:
                return {n: (rot, off) for n, (_, rot, off) in where.items()}
        where = row_layout([self.by_name[n] for n in names], self.w, self.h, self.sep, self.edge,
                           self.rotation_step)
        if max(si for si, _, _ in where.values()) == 0:
            return {n: (rot, off) for n, (_, rot, off) in where.items()}
        return None

    def pack_two(self, names):
        area = self.area
        outs = [_sheets(self.sky.pack(names, by)) for by in ("length", "area")]
        return min(outs, key=lambda o: (len(o), -sum(area[n] for n in o[0])))

    def run(self) -> None:
        self.emptier.run(gather=self.pack_two)

    def why(self) -> str:
        """Why the search stopped."""
        search = self.emptier
        return ("stopped by the time limit" if self.budget.time_limited else
                "at the area bound" if len(search.sheets) <= self.by_area else
                f"at the crossing bound, {self.crossing} sheets" if len(search.sheets) <= search.floor
                else "all tries made" if search.tries >= self.tries else "nothing more to try")

    def layout(self, *, method: str | None = None) -> Layout:
        """The layout of the sheets as they are now, with its :class:`NestStats`."""
        search, w, h = self.emptier, self.w, self.h
        placements = sorted((placement_of(self.by_name[n], si, rot, dx, dy)
                             for si, s in enumerate(search.sheets)
                             for n, (rot, (dx, dy)) in s.items()),
                            key=lambda p: (p.sheet, p.name))
        lay = Layout((w, h), placements, len(search.sheets), unit=self.unit, gap=self.gap,
                     margin=self.margin, cutting=self.cutting)
        if method is None:
            method = (f"{Nester.SEARCH.value} from {self.best} ({search.emptied} sheets emptied, "
                      f"{self.why()})")
        rotation = "free" if self.rotation_step is None else f"{self.rotation_step:g} deg steps"
        placed = sum(self.area[n] for s in search.sheets for n in s)
        lay.stats = NestStats(method, time.perf_counter() - self.t0, time.process_time() - self.c0,
                              placed / (w * h), time_limit=self.time_limit, fallback_parts=0,
                              rotation=rotation, sheet_fill=lay.sheet_utilization,
                              time_limited=self.budget.time_limited,
                              start_sheets=self.start_sheets[self.best], moves=search.moves,
                              sheets_emptied=search.emptied, tries=search.tries,
                              starts=dict(self.start_sheets), crossing_bound=self.crossing)
        return lay
