"""Raster nesting: a part placed into any hole of a sheet big enough for it, true shapes.

The usable sheet is a grid of square cells ``res`` wide. A sheet's *occupied* cells are those
whose centre lies within ``sep + res / sqrt(2)`` of a part on it; a part's *footprint* the
cells whose centre lies within ``res / sqrt(2)`` of it (both from a round buffer whose chords
lie outside the circle, :func:`_grown`). Every point of a part lies in a cell of its
footprint and every point nearer than ``sep`` to a placed part in an occupied cell, so a part
moved by whole cells to where its footprint meets no occupied cell keeps ``sep`` from every
part (conservative by at most two cells, ``2 res``).

Where the footprint fits is one correlation of the two grids (FFT, :func:`scipy.fft.rfft2`;
the sums are whole numbers, far from the 0.5 they are tested against, so the same cells
come out on any machine): every free position at once, including holes between parts that
no part can fall into from above (the skyline's blind spot, :mod:`.skyline`) and gaps at row
ends. Of those, the part takes the one with the lowest top, then the leftmost.

Units: those of the outlines. Grids are ``(columns along the length, rows across)``.

>>> from shapely.geometry import box
>>> grid = RasterGrid(length=1000.0, height=500.0, sep=5.0, res=10.0)
>>> sheet = grid.sheet()
>>> sheet.add(box(0, 0, 1000, 200))                  # a strip along the bottom
>>> grid.spot(sheet, [grid.footprint(box(0, 0, 400, 250), 0.0)]).y
220.0
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import scipy.fft
from shapely import affinity
from shapely.geometry import Polygon

__all__ = ["RasterGrid", "RasterSheet", "Footprint", "Spot", "DEFAULT_CELLS"]

#: cells along the usable sheet's length (2.5 m sheet: about 5 mm cells)
DEFAULT_CELLS = 500
#: footprint FFTs kept (half a megabyte each on a 2.5 m sheet)
_KEPT_FFTS = 128
#: a round buffer of ``quad_segs`` 2 keeps its chords outside a circle of this share of its radius
_CHORD = float(np.cos(np.pi / 8))


def _grown(poly: Polygon, radius: float) -> Polygon:
    """``poly`` grown by at least ``radius`` everywhere (its buffer's chords outside the disc)."""
    if radius <= 0:
        return poly
    return poly.buffer(radius / _CHORD, quad_segs=2)


def longest_runs(cells: np.ndarray) -> tuple[int, int]:
    """The longest run of set cells along the grid's columns (axis 0) and along its rows."""
    out = []
    for a in (0, 1):
        n = cells.shape[a]
        idx = np.arange(n).reshape((-1, 1) if a == 0 else (1, -1))
        last = np.maximum.accumulate(np.where(cells, -1, idx), axis=a)   # the last unset cell
        out.append(int((idx - last).max(initial=0)))
    return out[0], out[1]


def rasterize(poly: Polygon, x0: float, y0: float, nx: int, ny: int, res: float) -> np.ndarray:
    """``(nx, ny)`` bool: the cells whose centre ``(x0 + (i + 1/2) res, y0 + (j + 1/2) res)``
    lies inside ``poly``'s exterior (even-odd crossings along each row of centres)."""
    ring = np.asarray(poly.exterior.coords)
    p, q = ring[:-1], ring[1:]
    yc = y0 + (np.arange(ny) + 0.5) * res                                 # (ny,)
    lo = np.minimum(p[:, 1], q[:, 1])
    hi = np.maximum(p[:, 1], q[:, 1])
    cross = (lo[None] <= yc[:, None]) & (yc[:, None] < hi[None])          # (ny, E)
    jj, ee = np.nonzero(cross)
    if not len(jj):
        return np.zeros((nx, ny), dtype=bool)
    t = (yc[jj] - p[ee, 1]) / (q[ee, 1] - p[ee, 1])
    x = p[ee, 0] + t * (q[ee, 0] - p[ee, 0])
    # the first centre at or right of each crossing: every centre from there on is crossed once more
    k = np.clip(np.ceil((x - x0) / res - 0.5), 0, nx).astype(int)
    count = np.zeros((ny, nx + 1), dtype=np.int32)
    np.add.at(count, (jj, k), 1)
    return (np.cumsum(count, axis=1)[:, :nx] % 2 == 1).T


class Footprint(NamedTuple):
    """A part in one orientation: ``rot`` degrees about the origin, then ``shift`` moves its
    bounds' lower left corner to the origin; ``cells`` its footprint, cell ``(0, 0)`` at
    ``(-pad, -pad)`` cells; ``width``, ``height`` its bounds (unit)."""

    name: str
    rot: float
    shift: tuple[float, float]
    width: float
    height: float
    cells: np.ndarray
    count: int
    runs: tuple[int, int]


class Spot(NamedTuple):
    """Where a footprint fits on a sheet: ``x``, ``y`` its bounds' lower left corner in the
    usable frame (unit), ``footprint`` which orientation."""

    x: float
    y: float
    footprint: Footprint


@dataclass
class RasterSheet:
    """One sheet's occupied cells (padded by ``pad`` free cells around the usable frame), its
    FFT while it is current, and the parts on it."""

    occupied: np.ndarray
    names: list = field(default_factory=list)
    _fft: np.ndarray | None = field(default=None, repr=False)
    _free: int | None = field(default=None, repr=False)
    _runs: tuple | None = field(default=None, repr=False)
    grid: "RasterGrid" = field(default=None, repr=False)

    @property
    def free(self) -> int:
        """Free cells inside the usable frame."""
        self._count()
        return self._free

    @property
    def runs(self) -> tuple[int, int]:
        """The longest runs of free cells along the frame's length and across it, padding
        included (a footprint reaches into it): a footprint with a longer run fits nowhere."""
        self._count()
        return self._runs

    def _count(self) -> None:
        if self._free is None:
            p = self.grid.pad
            self._free = int((~self.occupied[p:p + self.grid.nx, p:p + self.grid.ny]).sum())
            self._runs = longest_runs(~self.occupied)

    def add(self, placed: Polygon, name: str = "") -> None:
        """Mark ``placed`` (in the usable frame) and the ``sep`` around it occupied."""
        g = self.grid
        big = _grown(placed, g.sep + g.res * np.sqrt(0.5))
        x0, y0, x1, y1 = big.bounds
        i0 = max(0, int(np.floor(x0 / g.res)) + g.pad)
        j0 = max(0, int(np.floor(y0 / g.res)) + g.pad)
        i1 = min(self.occupied.shape[0], int(np.ceil(x1 / g.res)) + g.pad + 1)
        j1 = min(self.occupied.shape[1], int(np.ceil(y1 / g.res)) + g.pad + 1)
        if i1 > i0 and j1 > j0:
            cells = rasterize(big, (i0 - g.pad) * g.res, (j0 - g.pad) * g.res, i1 - i0, j1 - j0, g.res)
            self.occupied[i0:i1, j0:j1] |= cells
        self.names.append(name)
        self._fft = self._free = self._runs = None

    def fft(self) -> np.ndarray:
        if self._fft is None:
            self._fft = scipy.fft.rfft2(self.occupied.astype(np.float32), s=self.grid.shape)
        return self._fft


class RasterGrid:
    """The grid of a ``length x height`` usable frame (unit), cells ``res`` wide, for parts
    kept ``sep`` apart (see the module docstring)."""

    def __init__(self, *, length: float, height: float, sep: float, res: float):
        self.length, self.height, self.sep, self.res = length, height, sep, res
        self.nx, self.ny = int(np.ceil(length / res - 1e-9)), int(np.ceil(height / res - 1e-9))
        # the footprint reaches res / sqrt(2) (and its buffer's chords) beyond the part
        self.pad = int(np.ceil(res * np.sqrt(0.5) / _CHORD / res)) + 1
        full = (self.nx + 2 * self.pad, self.ny + 2 * self.pad)
        self.shape = (scipy.fft.next_fast_len(full[0], real=True),
                      scipy.fft.next_fast_len(full[1], real=True))
        self.full = full
        self._ffts: dict = {}

    def sheet(self) -> RasterSheet:
        return RasterSheet(np.zeros(self.full, dtype=bool), grid=self)

    def footprint(self, outline: Polygon, rot: float, name: str = "") -> Footprint:
        """``outline`` turned by ``rot`` degrees as a :class:`Footprint`."""
        q = affinity.rotate(Polygon(outline.exterior), float(rot), origin=(0, 0))
        minx, miny, maxx, maxy = q.bounds
        q = affinity.translate(q, -minx, -miny)
        w, h = maxx - minx, maxy - miny
        p, r = self.pad, self.res
        nx, ny = int(np.ceil(w / r - 1e-9)) + 2 * p, int(np.ceil(h / r - 1e-9)) + 2 * p
        cells = rasterize(_grown(q, r * np.sqrt(0.5)), -p * r, -p * r, nx, ny, r)
        return Footprint(name, float(rot), (-minx, -miny), float(w), float(h), cells,
                         int(cells.sum()), longest_runs(cells))

    def spot(self, sheet: RasterSheet, footprints) -> Spot | None:
        """The lowest-topped, then leftmost, free position on ``sheet`` of any of
        ``footprints`` (orientations of one part), or None."""
        best = None
        free, (run_x, run_y) = sheet.free, sheet.runs
        for f in footprints:
            if f.count > free or f.runs[0] > run_x or f.runs[1] > run_y or \
                    f.width > self.length + 1e-9 or f.height > self.height + 1e-9:
                continue
            hit = self._hits(sheet, f)
            ni = int(np.floor((self.length - f.width) / self.res + 1e-9)) + 1
            nj = int(np.floor((self.height - f.height) / self.res + 1e-9)) + 1
            ok = hit[:ni, :nj] < 0.5
            if not ok.any():
                continue
            top = np.arange(nj) * self.res + f.height                   # (nj,)
            key = np.where(ok, top[None, :] * (self.nx + 1) + np.arange(ni)[:, None], np.inf)
            i, j = np.unravel_index(int(np.argmin(key)), key.shape)
            cand = (float(key[i, j]), float(i * self.res), float(j * self.res), f)
            if best is None or cand[0] < best[0] - 1e-9:
                best = cand
        return None if best is None else Spot(best[1], best[2], best[3])

    def _hits(self, sheet: RasterSheet, f: Footprint) -> np.ndarray:
        """Occupied cells under ``f`` at every offset: entry ``(i, j)`` places its bounds'
        corner at cell ``(i, j)`` of the usable frame."""
        full = scipy.fft.irfft2(sheet.fft() * self._fft_of(f), s=self.shape)
        fx, fy = f.cells.shape
        # valid offsets start where the footprint's last cell meets the grid's
        return full[fx - 1: self.full[0], fy - 1: self.full[1]]

    def _fft_of(self, f: Footprint) -> np.ndarray:
        """The FFT of ``f``'s cells turned half a turn (a correlation is a convolution with
        it), kept for the last :data:`_KEPT_FFTS` footprints."""
        key = (f.cells.shape, f.cells.tobytes())
        got = self._ffts.pop(key, None)
        if got is None:
            got = scipy.fft.rfft2(f.cells[::-1, ::-1].astype(np.float32), s=self.shape)
        self._ffts[key] = got                  # the most recently used last
        while len(self._ffts) > _KEPT_FFTS:
            del self._ffts[next(iter(self._ffts))]
        return got

    def place(self, sheet: RasterSheet, spot: Spot, outline: Polygon) -> Polygon:
        """Put ``outline`` at ``spot`` on ``sheet``; the placed polygon (usable frame)."""
        f = spot.footprint
        placed = affinity.translate(affinity.rotate(outline, f.rot, origin=(0, 0)),
                                    f.shift[0] + spot.x, f.shift[1] + spot.y)
        sheet.add(placed, f.name)
        return placed


class RasterPacker:
    """Parts put one after another each into the first sheet with a hole for it (the lowest
    top there, :meth:`RasterGrid.spot`), a new sheet where none has: a bottom-left fill of true
    shapes. :attr:`placed` ``{name: (sheet, Spot)}``; :attr:`sheets` the raster sheets."""

    def __init__(self, grid: RasterGrid):
        self.grid = grid
        self.sheets: list[RasterSheet] = []
        self.placed: dict = {}

    def add(self, name: str, outline: Polygon, footprints, *, new_sheet: bool = True) -> bool:
        """Place ``name`` (``footprints`` its orientations); False when it is not placed."""
        for si, sheet in enumerate(self.sheets):
            spot = self.grid.spot(sheet, footprints)
            if spot is not None:
                self.grid.place(sheet, spot, outline)
                self.placed[name] = (si, spot)
                return True
        if not new_sheet:
            return False
        sheet = self.grid.sheet()
        spot = self.grid.spot(sheet, footprints)
        if spot is None:
            return False
        self.sheets.append(sheet)
        self.grid.place(sheet, spot, outline)
        self.placed[name] = (len(self.sheets) - 1, spot)
        return True
