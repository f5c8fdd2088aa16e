"""The fast bottom-left nester (:func:`nest`), the shelves for small parts
(:func:`shelf_pack`) and two layouts one after the other (:func:`merge_layouts`).

:func:`nest` places flat outlines (shapely) on rectangular sheets with a bottom-left fill:
every part, turned so that its minimum rotated rectangle is axis-aligned, largest first, is
tried on each open sheet in every allowed rotation at the candidate corners of the parts
already there, then slid down and left as far as it stays free; the placement with the lowest
top edge wins; a new sheet is opened when nothing fits. Overlap checks keep ``gap`` between
parts and ``margin`` to the sheet edge (:func:`~torsal.fabrication.layout.spacing`).

Units: sheet sizes, gaps and all coordinates in the outlines' unit (mm by default).

Example
-------
>>> from shapely.geometry import box
>>> nest([box(0, 0, 1000, 400)] * 8, sheet=(2500, 1250), gap=5).n_sheets  # 7 a sheet (one turned)
2
"""
from __future__ import annotations

from typing import Sequence

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import Polygon
from shapely.prepared import prep

from ..cutting import Cutting
from ..layout import Layout, PartTooLargeError, placement_of, spacing
from .items import _as_items, _turned_shapes, check_fits

__all__ = ["nest", "shelf_pack", "merge_layouts"]


class _Sheet:
    def __init__(self, w, h, margin, gap):
        self.w, self.h, self.margin, self.gap = w, h, margin, gap
        self.polys: list[Polygon] = []
        self.grown: list = []
        self.bounds = np.zeros((0, 4))

    def free_at(self, poly: Polygon, bounds, x: float, y: float) -> bool:
        """Whether ``poly`` (with ``bounds``) translated by ``(x, y)`` lies inside the margins
        and ``gap`` clear of every part on the sheet. The bounding box is tested first (the
        bounds of a translated polygon are its bounds translated, exactly: rounding is
        monotonic); the polygon is moved only when it meets another part's."""
        minx, miny, maxx, maxy = bounds[0] + x, bounds[1] + y, bounds[2] + x, bounds[3] + y
        m = self.margin
        if minx < m - 1e-9 or miny < m - 1e-9 or maxx > self.w - m + 1e-9 or maxy > self.h - m + 1e-9:
            return False
        if not len(self.bounds):
            return True
        g = self.gap
        b = self.bounds
        hit = np.flatnonzero((b[:, 0] - g < maxx) & (b[:, 2] + g > minx) &
                             (b[:, 1] - g < maxy) & (b[:, 3] + g > miny))
        if not hit.size:
            return True
        # the coordinates plus (x, y), as affinity.translate gives them (up to the sign of a
        # zero) at a quarter of its cost: this test runs ~10^6 times for 1,000 panels
        off = np.array([x, y], dtype=float)
        p = shapely.transform(poly, lambda c: c + off)
        for i in hit:
            if self.grown[i].intersects(p):
                return False
        return True

    def add(self, poly: Polygon):
        self.polys.append(poly)
        grown = poly.buffer(self.gap * (1 - 1e-6), join_style="mitre", mitre_limit=2.0) if self.gap > 0 else poly
        self.grown.append(prep(grown))
        self.bounds = np.vstack([self.bounds, poly.bounds])


def _slide(sheet: _Sheet, poly: Polygon, x: float, y: float, dx: int, dy: int, reach: float):
    """Largest shift along (dx, dy) up to ``reach`` that keeps the part free (bisection)."""
    bounds = poly.bounds

    def ok(s):
        return sheet.free_at(poly, bounds, x + dx * s, y + dy * s)

    lo, hi = 0.0, reach
    if hi <= 0:
        return 0.0
    if ok(hi):
        return hi
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        if ok(mid):
            lo = mid
        else:
            hi = mid
        if hi - lo < 0.05:
            break
    return lo


def _place_on(sheet: _Sheet, shapes) -> tuple | None:
    """Best (score, rotation index, x, y) of a part on a sheet, or None."""
    best = None
    m, g = sheet.margin, sheet.gap
    xs = np.unique(np.r_[m, sheet.bounds[:, 2] + g]) if len(sheet.bounds) else np.array([m])
    ys = np.unique(np.r_[m, sheet.bounds[:, 3] + g]) if len(sheet.bounds) else np.array([m])
    for r, (poly, (w, h)) in enumerate(shapes):
        cand = [(y, x) for y in ys for x in xs if x + w <= sheet.w - m + 1e-9 and y + h <= sheet.h - m + 1e-9]
        cand.sort()
        for y, x in cand:
            if best is not None and y + h >= best[0][0]:
                break                       # cannot beat the best top edge any more
            if not sheet.free_at(poly, poly.bounds, x, y):
                continue
            # slide down and left while free (bottom-left compaction)
            for _ in range(3):
                sy = _slide(sheet, poly, x, y, 0, -1, y - m)
                y -= sy
                sx = _slide(sheet, poly, x, y, -1, 0, x - m)
                x -= sx
                if sy < 0.05 and sx < 0.05:
                    break
            score = (y + h, x)
            if best is None or score < best[0]:
                best = (score, r, x, y)
            break
    return best



def nest(outlines, *, sheet: tuple[float, float] = (2500.0, 1250.0), gap: float = 5.0,
         margin: float = 10.0, rotations: Sequence[float] = (0, 90, 180, 270),
         unit: str = "mm", open_sheets: int = 3, cutting: Cutting | None = None) -> Layout:
    """Nest flat parts on rectangular sheets (bottom-left fill over rotated candidates): the
    fast nester; :func:`~.nesting.nest_for_yield` uses fewer sheets in a time budget.

    Parameters
    ----------
    outlines : sequence of Unrolled, of (name, Polygon), of Polygon, or {name: Polygon}
        Flat parts in ``unit``; :class:`~.unroll.Unrolled` parts also carry their fold
        lines and label position onto the sheet.
    sheet : (width, height)
        Sheet size in ``unit`` (default 2500 x 1250 mm).
    gap : float
        Web of sheet left between the cuts of two parts, ``unit`` (the outlines are ``gap + 2
        kerf`` apart, see :func:`spacing`).
    margin : float
        Web left between the cuts and the sheet edge, ``unit``.
    rotations : sequence of float
        Allowed rotations in degrees, applied after turning each part so that its minimum
        rotated rectangle is axis-aligned (long side along x).
    open_sheets : int
        How many of the most recent sheets are still tried for a part (older sheets are
        closed); bounds the time for large jobs.
    cutting : Cutting, optional
        The cutting process (kerf, reliefs) the sheets are drawn for; None: cut on the outline.

    Raises
    ------
    PartTooLargeError
        If a part fits the sheet in no allowed rotation.
    """
    w, h = map(float, sheet)
    if w <= 0 or h <= 0:
        raise ValueError(f"sheet must have positive size, got {sheet}")
    if gap < 0 or margin < 0:
        raise ValueError("gap and margin must be >= 0")
    if not len(rotations):
        raise ValueError("at least one rotation is needed")
    items = _as_items(outlines, cutting)
    prepared = [_turned_shapes(it, rotations) for it in items]
    sep, edge = spacing(gap, margin, cutting)
    check_fits(items, prepared, w, h, edge, rotations, unit)
    order = sorted(range(len(items)), key=lambda i: -items[i].outline.area)
    sheets: list[_Sheet] = []
    placements = []
    for i in order:
        it, shapes = items[i], prepared[i]
        where = None
        for si in range(max(0, len(sheets) - open_sheets), len(sheets)):
            best = _place_on(sheets[si], shapes)
            if best is not None:
                where = (si, best)
                break
        if where is None:
            sheets.append(_Sheet(w, h, edge, sep))
            best = _place_on(sheets[-1], shapes)
            if best is None:  # pragma: no cover - guarded by the size check above
                raise PartTooLargeError(f"part {it.name} does not fit an empty sheet")
            where = (len(sheets) - 1, best)
        si, (_, r, x, y) = where
        rot = float(rotations[r]) + it.base
        placed = affinity.translate(shapes[r][0], x, y)
        sheets[si].add(placed)
        # transform of the original outline: rotate about origin, then shift
        p0 = affinity.rotate(it.outline, rot, origin=(0, 0))
        placements.append(placement_of(it, si, rot, x - p0.bounds[0], y - p0.bounds[1], placed))
    placements.sort(key=lambda p: (p.sheet, p.name))
    return Layout((w, h), placements, len(sheets), unit=unit, gap=gap, margin=margin, cutting=cutting)


def shelf_pack(outlines, *, sheet: tuple[float, float] = (2500.0, 1250.0), gap: float = 5.0,
               margin: float = 10.0, unit: str = "mm", first_sheet: int = 0,
               cutting: Cutting | None = None) -> Layout:
    """Pack many small flat parts (connectors) in rows: each turned so that its minimum
    rotated rectangle is axis-aligned (long side along x), tallest first, left to right
    with ``gap`` between them, a new row above the tallest of the last one, a new sheet when
    the rows are full. Linear in the number of parts, where :func:`nest` is about quadratic;
    sheets are numbered from ``first_sheet``.

    Raises :class:`PartTooLargeError` if a part does not fit an empty sheet.
    """
    w, h = map(float, sheet)
    items = _as_items(outlines, cutting)
    layout_gap, layout_margin = gap, margin
    gap, margin = spacing(gap, margin, cutting)
    shapes = []
    for it in items:
        p = affinity.rotate(it.outline, it.base, origin=(0, 0))
        minx, miny, maxx, maxy = p.bounds
        if maxx - minx > w - 2 * margin + 1e-9 or maxy - miny > h - 2 * margin + 1e-9:
            raise PartTooLargeError(f"part {it.name} ({maxx - minx:.0f} x {maxy - miny:.0f} {unit}) "
                                    f"does not fit a {w:.0f} x {h:.0f} {unit} sheet")
        shapes.append((it, p, (minx, miny, maxx, maxy)))
    shapes.sort(key=lambda x: -(x[2][3] - x[2][1]))
    m0 = margin + 1e-6 * max(w, h)          # strictly inside the margin
    placements, sheet_no, x, y, row_h = [], first_sheet, m0, m0, 0.0
    for it, p, (minx, miny, maxx, maxy) in shapes:
        pw, ph = maxx - minx, maxy - miny
        if x + pw > w - margin + 1e-9:                  # new row
            x, y, row_h = m0, y + row_h + gap, 0.0
        if y + ph > h - margin + 1e-9:                  # new sheet
            sheet_no, x, y, row_h = sheet_no + 1, m0, m0, 0.0
        placements.append(placement_of(it, sheet_no, it.base, x - minx, y - miny))
        x += pw + gap
        row_h = max(row_h, ph)
    n = (sheet_no - first_sheet + 1) if placements else 0
    return Layout((w, h), placements, n, unit=unit, gap=layout_gap, margin=layout_margin,
                  cutting=cutting)


def merge_layouts(first: Layout, second: Layout) -> Layout:
    """One layout of the sheets of ``first`` followed by those of ``second`` (whose sheet
    numbers start at ``first.n_sheets``)."""
    places = sorted(first.placements + second.placements, key=lambda p: (p.sheet, p.name))
    return Layout(first.sheet, places, first.n_sheets + second.n_sheets, unit=first.unit,
                  gap=first.gap, margin=first.margin, cutting=first.cutting, stats=first.stats)


# ---------------------------------------------------------------------------- reading back
