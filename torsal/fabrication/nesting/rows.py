"""Row nesting: long parts end to end in rows along the sheet, true shapes, exact spacing.

Unrolled fins are strips (7a: 172 plates, most 350-430 mm wide and 0.4-2.5 m long, on 2.5 x
1.25 m sheets), so a sheet holds a few rows of them; what decides the yield is which parts share a
row and how close their slanted ends come. Each part is turned so that its minimum rotated
rectangle lies along the rows (the rows run along the sheet's longer side), and may be
turned half a turn more so that its end meets its neighbour's.

Contact: a row's parts stand on the row's bottom line. Their shapes are cut into :data:`SLABS`
horizontal slabs; per slab the row keeps its *frontier*, the largest x of its parts grown by
the spacing ``sep`` (a round buffer, a little larger than ``sep``), and a part's *left* is the
smallest x of its true shape in the slab. A new part goes to ``x = max over slabs (frontier -
left)``: no slab of it comes nearer than ``sep`` to a part of the row (conservative: within a
slab the extremes are taken over the whole slab). Rows are stacked ``sep`` apart by their
heights.

Assignment (best fit decreasing): the parts longest first; each goes to the row, of any
sheet, that it leaves with the least length to spare; where no row has room, to a new row on
the sheet with the least height to spare, else to a new sheet. Small parts (connectors) are
packed after the plates into the free rectangles of the sheets (the row ends and the strip
above the rows), each turned to fit, in shelves; those left over go on new sheets the same
way.

Units: those of the outlines.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import Polygon

from ..cutting import Cutting
from ..layout import Layout, PartTooLargeError, placement_of, spacing
from .items import _as_items, _turned_shapes, check_fits

__all__ = ["nest_rows", "row_layout", "planned_layout", "prepare", "SLABS"]

#: parts smaller than this share of the usable sheet go in shelves (connectors), not rows
SMALL = 0.02
#: horizontal slabs of a row's band (the contact model's resolution)
SLABS = 128


@dataclass
class Shape:
    """One part in one orientation, its bounds' lower left corner at the origin.

    ``rot`` degrees turn the original outline about the origin and ``shift`` then moves it
    here; ``left`` (SLABS,) the smallest x of the shape per slab, ``right`` the largest x of
    the shape grown by the spacing (``inf`` / ``-inf`` where the slab misses it).
    """

    name: str
    rot: float
    shift: tuple[float, float]
    length: float
    height: float
    polygon: Polygon
    left: np.ndarray = field(repr=False, default=None)
    right: np.ndarray = field(repr=False, default=None)


@dataclass
class Row:
    """A row of parts on a sheet: its height (the tallest part), the x its parts reach in every
    slab (grown by the spacing), and ``[(Shape, x)]``."""

    height: float
    frontier: np.ndarray
    parts: list = field(default_factory=list)


@dataclass
class RowSheet:
    """A sheet of rows, and small parts in its free rectangles ``[(Shape, x, y)]``."""

    rows: list = field(default_factory=list)
    loose: list = field(default_factory=list)

    def height_used(self, sep: float) -> float:
        return sum(r.height for r in self.rows) + sep * max(0, len(self.rows) - 1)


def orientations(outline: Polygon, base: float, rotation_step: float | None,
                 length: float, height: float, *, across: bool = False) -> list[float]:
    """The rotations (degrees) a part may take on a ``length x height`` sheet frame: ``base``
    (its minimum rotated rectangle along x) and half a turn more (``across``: and a quarter
    turn, for small parts packed in shelves); with ``rotation_step``, the allowed angle whose
    bounding box is lowest among those that fit, and half a turn more where allowed."""
    if rotation_step is None:
        turns = (0.0, 90.0, 180.0) if across else (0.0, 180.0)
        return [(base + t) % 360.0 for t in turns]
    allowed = np.arange(0.0, 360.0, rotation_step)
    boxes = []
    for a in allowed:
        x0, y0, x1, y1 = affinity.rotate(outline, float(a), origin=(0, 0)).bounds
        if x1 - x0 <= length + 1e-9 and y1 - y0 <= height + 1e-9:
            boxes.append((y1 - y0, float(a)))
    if not boxes:
        return []
    boxes.sort()
    out = [boxes[0][1]]
    if across:
        out += [a for _, a in boxes[1:2]]
    flip = (out[0] + 180.0) % 360.0
    if any(abs(a - flip) < 1e-9 for _, a in boxes):
        out.append(flip)
    return out


def shapes_of(names, outlines, rots, sep: float, band: float) -> list[Shape]:
    """Every ``(name, outline, rotation)`` as a :class:`Shape` with its slab profiles over a
    band ``band`` high (vectorized over the parts with shapely)."""
    out = []
    for n, p, r in zip(names, outlines, rots):
        q = affinity.rotate(p, r, origin=(0, 0))
        minx, miny, maxx, maxy = q.bounds
        out.append(Shape(n, float(r), (-minx, -miny), maxx - minx, maxy - miny,
                         affinity.translate(q, -minx, -miny)))
    if not out:
        return out
    true = np.array([s.polygon for s in out], dtype=object)
    # a 16-segment quarter circle lies inside the true one by 0.12 %: grow a little more
    grown = shapely.buffer(true, sep * 1.002, quad_segs=16)
    edges = np.linspace(0.0, band, SLABS + 1)
    left = np.full((len(out), SLABS), np.inf)
    right = np.full((len(out), SLABS), -np.inf)
    big = 1e3 * (band + max(s.length for s in out) + sep)
    for k in range(SLABS):
        lo, hi = edges[k], edges[k + 1]
        b = shapely.bounds(shapely.clip_by_rect(true, -big, lo, big, hi))
        ok = ~np.isnan(b[:, 0])
        left[ok, k] = b[ok, 0]
        # grown shapes reach sep below the row's bottom: the bottom slab takes that in
        g = shapely.bounds(shapely.clip_by_rect(grown, -big, lo if k else -big, big,
                                                hi if k < SLABS - 1 else big))
        ok = ~np.isnan(g[:, 2])
        right[ok, k] = g[ok, 2]
    for i, s in enumerate(out):
        s.left, s.right = left[i], right[i]
    return out


class RowPacker:
    """Best fit decreasing of the plates into rows on sheets (see the module docstring).

    ``length``, ``height``: the usable sheet (inside the margins, rows along ``length``);
    ``sep``: the distance two outlines keep.
    """

    def __init__(self, length: float, height: float, sep: float):
        self.length, self.height, self.sep = length, height, sep
        self.sheets: list[RowSheet] = []

    def _new_row(self, sheet: RowSheet, s: Shape) -> None:
        r = Row(s.height, np.full(SLABS, -np.inf))
        self._put(r, s, 0.0)
        sheet.rows.append(r)

    @staticmethod
    def _put(r: Row, s: Shape, x: float) -> None:
        r.parts.append((s, x))
        r.frontier = np.maximum(r.frontier, s.right + x)
        r.height = max(r.height, s.height)

    def add(self, options: list[Shape]) -> None:
        """Place one part, given in its allowed orientations (vectorized over all rows)."""
        rows = [(sh, r) for sh in self.sheets for r in sh.rows]
        if rows:
            frontier = np.stack([r.frontier for _, r in rows])                  # (rows, SLABS)
            height = np.array([r.height for _, r in rows])
            spare_h = np.array([self.height - sh.height_used(self.sep) for sh, _ in rows])
            best = None                    # (key, row index, shape, x)
            for s in options:
                d = frontier - s.left[None, :]
                d[~np.isfinite(d)] = -np.inf
                x = np.maximum(0.0, d.max(axis=1))
                spare = self.length - (x + s.length)
                ok = (spare >= -1e-9) & (s.height <= height + spare_h + 1e-9)
                if not ok.any():
                    continue
                # a taller part raises the row: count the band it takes as length
                key = np.where(ok, spare + np.maximum(0.0, s.height - height) * self.length / self.height,
                               np.inf)
                i = int(np.argmin(key))
                if best is None or key[i] < best[0]:
                    best = (float(key[i]), i, s, float(x[i]))
            if best is not None:
                _, i, s, x = best
                self._put(rows[i][1], s, x)
                return
        s = min(options, key=lambda o: o.height)
        fits = [sh for sh in self.sheets
                if sh.height_used(self.sep) + self.sep + s.height <= self.height + 1e-9]
        if fits:
            self._new_row(min(fits, key=lambda sh: self.height - sh.height_used(self.sep)), s)
        else:
            sh = RowSheet()
            self.sheets.append(sh)
            self._new_row(sh, s)

    def free_rectangles(self, sheet: RowSheet) -> list[tuple[float, float, float, float]]:
        """``(x0, y0, x1, y1)`` left free on ``sheet``: each row's end and the strip above the
        rows (each ``sep`` from the parts)."""
        rects, y = [], 0.0
        for r in sheet.rows:
            x0 = float(np.max(r.frontier[np.isfinite(r.frontier)], initial=0.0))
            if self.length - x0 > 0:
                rects.append((x0, y, self.length, y + r.height))
            y += r.height + self.sep
        if self.height - y > 0:
            rects.append((0.0, y, self.length, self.height))
        return rects

    def place(self) -> list[tuple[int, Shape, float, float]]:
        """``[(sheet, shape, x, y)]`` of the rows' parts, in the usable frame."""
        out = []
        for si, sh in enumerate(self.sheets):
            y = 0.0
            for r in sh.rows:
                out += [(si, s, x, y) for s, x in r.parts]
                y += r.height + self.sep
            out += [(si, s, x, y) for s, x, y in sh.loose]
        return out


def shelf_fill(rects: list, shapes: list[list[Shape]], sep: float) -> tuple[list, list]:
    """Small parts in shelves inside free rectangles: ``rects`` ``(x0, y0, x1, y1)`` (each
    already ``sep`` from the parts around), ``shapes`` each part's orientations (its bounding
    box is what is packed). Returns ``([(rect index, Shape, x, y)], [parts not placed])``,
    parts tallest first, each in the first rectangle with room."""
    placed, left = [], []
    # per rectangle: the shelves' (y, height, x reached) and the next shelf's y
    state = [{"shelves": [], "top": r[1]} for r in rects]
    order = sorted(range(len(shapes)), key=lambda i: -min(s.height for s in shapes[i]))
    for i in order:
        done = False
        for ri, (x0, y0, x1, y1) in enumerate(rects):
            st = state[ri]
            for s in sorted(shapes[i], key=lambda o: o.height):
                for sh in st["shelves"]:
                    if s.height <= sh[1] + 1e-9 and sh[2] + s.length <= x1 + 1e-9:
                        placed.append((ri, s, sh[2], sh[0]))
                        sh[2] += s.length + sep
                        done = True
                        break
                if done:
                    break
                if st["top"] + s.height <= y1 + 1e-9 and x0 + s.length <= x1 + 1e-9:
                    st["shelves"].append([st["top"], s.height, x0 + s.length + sep])
                    placed.append((ri, s, x0, st["top"]))
                    st["top"] += s.height + sep
                    done = True
                    break
            if done:
                break
        if not done:
            left.append(i)
    return placed, left


#: the orders the plates may be offered to the rows in: longest first (best fit decreasing),
#: largest first, widest first (the row's height)
_ORDERS = {
    "length": lambda by: lambda n: (-max(s.length for s in by[n]), -max(s.polygon.area for s in by[n]), n),
    "area": lambda by: lambda n: (-max(s.polygon.area for s in by[n]), -max(s.length for s in by[n]), n),
    "height": lambda by: lambda n: (-min(s.height for s in by[n]), -max(s.length for s in by[n]), n),
}


def row_layout(items, w: float, h: float, sep: float, edge: float,
               rotation_step: float | None = None, *, order: str = "length") -> dict:
    """``{name: (sheet, rotation deg, (dx, dy))}``: each original outline turned about the
    origin, then moved, on sheets ``w x h`` (rows along the longer side; see the module
    docstring). ``items``: prepared parts (``nesting.items._as_items``) that fit the sheet;
    ``order``: the plates longest (``"length"``), largest (``"area"``) or widest
    (``"height"``) first."""
    frame = _RowFrame.of(items, w, h, sep, edge, rotation_step)
    packer = RowPacker(frame.length, frame.height, sep)
    large = sorted((n for n in frame.by if n not in frame.small), key=_ORDERS[order](frame.by))
    for n in large:
        packer.add(frame.by[n])
    return frame.finish(packer)


def planned_layout(items, plan, w: float, h: float, sep: float, edge: float,
                   rotation_step: float | None = None) -> dict:
    """:func:`row_layout`'s ``{name: (sheet, rotation deg, (dx, dy))}`` with the rows given:
    ``plan`` ``[[name, ...], ...]``, the plates of each row in the order they go end to end
    (each in the orientation that ends nearest the row's start; a plate that does not fit its
    row's length is left to the rows' best fit afterwards). The rows go onto the sheets
    tallest first, each onto the first sheet with the height for it; the plates of no row
    and the small parts as :func:`row_layout` places them."""
    frame = _RowFrame.of(items, w, h, sep, edge, rotation_step)
    by, length = frame.by, frame.length
    packer = RowPacker(length, frame.height, sep)
    rows, left, planned = [], [], set()
    for names in plan:
        row = None
        for n in names:
            if n not in by or n in frame.small or n in planned:
                continue
            planned.add(n)
            if row is None:
                s = min(by[n], key=lambda o: (o.height, o.rot))
                row = Row(s.height, np.full(SLABS, -np.inf))
                RowPacker._put(row, s, 0.0)
                continue
            best = None
            for s in by[n]:
                d = row.frontier - s.left
                d[~np.isfinite(d)] = -np.inf
                x = max(0.0, float(d.max()))
                if x + s.length <= length + 1e-9 and (best is None or
                                                       (x + s.length, s.height) < best[0]):
                    best = ((x + s.length, s.height), s, x)
            if best is None:
                left.append(n)
            else:
                RowPacker._put(row, best[1], best[2])
        if row is not None:
            rows.append(row)
    for row in sorted(rows, key=lambda r: -r.height):      # (stable: the plan's order)
        fits = [sh for sh in packer.sheets
                if sh.height_used(sep) + sep + row.height <= frame.height + 1e-9]
        if not fits:
            packer.sheets.append(RowSheet())
            fits = packer.sheets[-1:]
        fits[0].rows.append(row)
    rest = [n for n in by if n not in frame.small and n not in planned] + left
    for n in sorted(rest, key=_ORDERS["length"](by)):
        packer.add(by[n])
    return frame.finish(packer)


@dataclass
class _RowFrame:
    """The usable sheet of the rows (along its longer side: ``turn`` whether that is the
    sheet turned a quarter), the parts' allowed shapes ``by`` name and the ``small`` ones."""

    w: float
    h: float
    edge: float
    sep: float
    turn: bool
    length: float
    height: float
    by: dict
    small: set

    @classmethod
    def of(cls, items, w, h, sep, edge, rotation_step) -> "_RowFrame":
        turn = h > w                              # rows run along the longer side
        length, height = (h, w) if turn else (w, h)
        length, height = length - 2 * edge, height - 2 * edge
        usable = length * height
        small = {it.name for it in items if it.outline.area < SMALL * usable}
        names, outlines, rots = [], [], []
        for it in items:
            for r in orientations(it.outline, it.base, rotation_step, length, height,
                                  across=it.name in small):
                names.append(it.name)
                outlines.append(it.outline)
                rots.append(r)
        by: dict[str, list[Shape]] = {}
        for s in shapes_of(names, outlines, rots, sep, height):
            if s.length <= length + 1e-9 and s.height <= height + 1e-9:
                by.setdefault(s.name, []).append(s)
        for it in items:
            if it.name not in by:
                raise PartTooLargeError(
                    f"part {it.name} fits the {w:g} x {h:g} sheet with margin {edge:g} at none of the "
                    f"rotations in steps of {rotation_step:g} deg: allow finer steps "
                    "([nesting] rotation_step_deg) or any rotation")
        return cls(w, h, edge, sep, turn, length, height, by, small)

    def finish(self, packer: "RowPacker") -> dict:
        """The small parts into the free rectangles of the rows' sheets, then new sheets of
        shelves; ``{name: (sheet, rotation deg, (dx, dy))}`` of every part."""
        by, sep, length, height = self.by, self.sep, self.length, self.height
        rects = [(si, r) for si, sh in enumerate(packer.sheets) for r in packer.free_rectangles(sh)]
        todo = sorted((n for n in by if n in self.small), key=lambda n: n)
        fresh = False                             # whether rects is one empty sheet
        while todo:
            if not rects:
                packer.sheets.append(RowSheet())
                rects, fresh = [(len(packer.sheets) - 1, (0.0, 0.0, length, height))], True
            placed, left = shelf_fill([r for _, r in rects], [by[n] for n in todo], sep)
            for ri, s, x, y in placed:
                packer.sheets[rects[ri][0]].loose.append((s, x, y))
            if fresh and not placed:              # pragma: no cover - each part fits an empty sheet
                raise RuntimeError("a small part fits no empty sheet")
            todo, rects = [todo[i] for i in left], []
        out = {}
        for si, s, x, y in packer.place():
            dx, dy = s.shift[0] + x + self.edge, s.shift[1] + y + self.edge
            rot = s.rot
            if self.turn:                         # the frame turned a quarter: back onto the sheet
                rot, (dx, dy) = (rot + 90.0) % 360.0, (self.w - dy, dx)
            out[s.name] = (si, rot, (dx, dy))
        return out


def prepare(outlines, sheet, gap: float, margin: float, cutting: Cutting | None, unit: str):
    """``(w, h, items, sep, edge)``: the sheet, the parts prepared for nesting, the distance
    between outlines and to the sheet edge; ValueError for a bad sheet, gap or margin,
    :class:`PartTooLargeError` for a part that fits the sheet in no rotation."""
    w, h = map(float, sheet)
    if w <= 0 or h <= 0:
        raise ValueError(f"sheet must have positive size, got {sheet}")
    if gap < 0 or margin < 0:
        raise ValueError("gap and margin must be >= 0")
    items = _as_items(outlines, cutting)
    sep, edge = spacing(gap, margin, cutting)
    check_fits(items, [_turned_shapes(it, (0, 90, 180, 270)) for it in items], w, h, edge,
               (0, 90, 180, 270), unit)
    return w, h, items, sep, edge


def nest_rows(outlines, *, sheet: tuple[float, float] = (2500.0, 1250.0), gap: float = 5.0,
              margin: float = 10.0, unit: str = "mm", cutting: Cutting | None = None,
              rotation_step: float | None = None) -> Layout:
    """Nest flat parts in rows of true shapes end to end (see the module docstring): no
    search, about a second for a thousand parts.

    Parameters are those of :func:`~.yield_.nest_for_yield`; ``rotation_step`` None turns
    each part to its minimum rotated rectangle (any angle) and half a turn more.

    >>> from shapely.geometry import Polygon
    >>> trapezoid = Polygon([(0, 0), (1250, 0), (1150, 400), (100, 400)])
    >>> lay = nest_rows([trapezoid] * 6, sheet=(2500, 1250), gap=5, margin=10)
    >>> lay.n_sheets                          # two per row: one of them upside down
    1
    """
    w, h, items, sep, edge = prepare(outlines, sheet, gap, margin, cutting, unit)
    where = row_layout(items, w, h, sep, edge, rotation_step)
    by_name = {it.name: it for it in items}
    placements = sorted((placement_of(by_name[n], si, rot, dx, dy)
                         for n, (si, rot, (dx, dy)) in where.items()),
                        key=lambda p: (p.sheet, p.name))
    n = 1 + max((p.sheet for p in placements), default=-1)
    return Layout((w, h), placements, n, unit=unit, gap=gap, margin=margin, cutting=cutting)
