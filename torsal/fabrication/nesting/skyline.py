"""Skyline nesting: each part dropped from above onto the parts below it, true shapes in
columns.

The usable sheet is cut into vertical columns ``res`` wide. A placed part's *top* (the
largest y of its outline grown by the spacing ``sep``, per column) raises the sheet's
*skyline*; a new part, turned and moved to a column boundary, falls until one of its columns
meets the skyline: ``y = max over its columns (skyline - bottom)``, ``bottom`` the smallest y
of its outline in the column. No column of it then comes nearer than ``sep`` to a part below
(conservative: a column's extremes are taken over the whole column). Curved strips (example
9's and 11's canopies, whose outlines fill 55-75 % of their bounding rectangle) fall into the
hollow of the strip below, which the rows (:mod:`.rows`) cannot do.

Choice (deterministic): parts in a fixed order; each goes to the first sheet where it fits,
in the orientation and column that waste the least area under it (between its bottom and the
skyline), then the lowest top. Units: those of the outlines.

>>> from shapely.geometry import Polygon
>>> arc = Polygon([(0, 0), (500, 150), (1000, 0), (1000, 100), (500, 250), (0, 100)])
>>> p = column_profiles([arc], [0.0], res=10.0, sep=5.0)[0]
>>> round(float(p.bottom[0]), 1), round(float(p.bottom[49]), 1)   # the arc rises to the middle
(0.0, 147.0)
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from shapely import affinity
from shapely.geometry import Polygon

__all__ = ["column_profiles", "ColumnProfile", "SkylinePacker", "DEFAULT_RESOLUTION"]

#: column width as a share of the sheet's usable length (2.5 m sheet: about 6 mm columns)
DEFAULT_RESOLUTION = 1.0 / 400.0


@dataclass
class ColumnProfile:
    """One part in one orientation, its bounds' lower left corner at the origin.

    ``rot`` degrees turn the original outline about the origin and ``shift`` then moves it
    here; ``width``, ``height`` its bounds (unit); ``bottom`` (k,) the smallest y of the
    outline per column (``inf`` where it misses the column), ``top`` (k + 2 g,) the largest y
    of the outline grown by ``sep`` per column, from ``g`` columns left of the part to ``g``
    right of it (``-inf`` where it misses).
    """

    name: str
    rot: float
    shift: tuple[float, float]
    width: float
    height: float
    bottom: np.ndarray = field(repr=False)
    top: np.ndarray = field(repr=False)


def _edge_extremes(ring: np.ndarray, edges: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per column ``[edges[j], edges[j+1]]``: the smallest and largest y of the closed ring
    ``(n, 2)`` inside it (a polygon's extremes over a vertical slab lie on its boundary:
    at the segments' ends clipped to the slab). ``(k,)`` each, ``inf`` / ``-inf`` where
    the ring misses the column."""
    p, q = ring[:-1], ring[1:]
    x0, x1 = np.minimum(p[:, 0], q[:, 0]), np.maximum(p[:, 0], q[:, 0])
    a, b = edges[:-1][:, None], edges[1:][:, None]                      # (k, 1)
    lo, hi = np.maximum(a, x0[None]), np.minimum(b, x1[None])           # (k, E)
    hit = lo <= hi
    dx = q[:, 0] - p[:, 0]
    flat = np.abs(dx) < 1e-12
    slope = np.where(flat, 0.0, (q[:, 1] - p[:, 1]) / np.where(flat, 1.0, dx))

    def y_at(x):
        return np.where(flat[None], p[None, :, 1], p[None, :, 1] + slope[None] * (x - p[None, :, 0]))

    ya, yb = y_at(lo), y_at(hi)
    # a vertical segment spans its two ends' y at one x
    ymin = np.where(flat[None], np.minimum(p[:, 1], q[:, 1])[None], np.minimum(ya, yb))
    ymax = np.where(flat[None], np.maximum(p[:, 1], q[:, 1])[None], np.maximum(ya, yb))
    return (np.where(hit, ymin, np.inf).min(axis=1), np.where(hit, ymax, -np.inf).max(axis=1))


def _grown_top(top: np.ndarray, res: float, sep: float, g: int) -> np.ndarray:
    """The top of the outline grown by ``sep`` (a disc), per column, from ``g`` columns left
    to ``g`` right: column ``j`` is reached from column ``j + d`` no higher than
    ``top[j + d] + sqrt(sep^2 - ((|d| - 1) res)^2)`` (the columns' nearest points)."""
    k = len(top)
    out = np.full(k + 2 * g, -np.inf)
    for d in range(-g, g + 1):
        near = max(0, abs(d) - 1) * res
        if near > sep:
            continue
        lift = np.sqrt(sep * sep - near * near)
        # part column c reaches out column c - d + g
        out[g - d: g - d + k] = np.maximum(out[g - d: g - d + k], top + lift)
    return out


def column_profiles(outlines, rotations, *, res: float, sep: float, names=None) -> list[ColumnProfile]:
    """Each outline turned by its rotation (degrees) as a :class:`ColumnProfile` with columns
    ``res`` wide and the spacing ``sep`` (unit).

    Parameters
    ----------
    outlines : sequence of Polygon
    rotations : sequence of float
        Degrees, one per outline.
    res, sep : float
        Column width and the distance two outlines keep (unit).
    names : sequence of str, optional
    """
    g = int(np.ceil(sep / res)) + 1
    out = []
    for i, (poly, rot) in enumerate(zip(outlines, rotations)):
        q = affinity.rotate(Polygon(poly.exterior), float(rot), origin=(0, 0))
        minx, miny, maxx, maxy = q.bounds
        ring = np.asarray(q.exterior.coords) - (minx, miny)
        width, height = maxx - minx, maxy - miny
        k = max(1, int(np.ceil(width / res - 1e-9)))
        edges = np.arange(k + 1) * res
        bottom, top = _edge_extremes(ring, edges)
        out.append(ColumnProfile(None if names is None else names[i], float(rot), (-minx, -miny),
                                 float(width), float(height), bottom, _grown_top(top, res, sep, g)))
    return out


class SkylinePacker:
    """Parts dropped onto sheets of ``length x height`` (usable, unit) in columns ``res``
    wide (see the module docstring). :meth:`add` places one part given its orientations;
    :attr:`placed` holds ``{name: (sheet, ColumnProfile, x, y)}`` in the usable frame."""

    def __init__(self, length: float, height: float, sep: float, res: float):
        self.length, self.height, self.sep, self.res = length, height, sep, res
        self.columns = int(np.ceil(length / res - 1e-9))
        self.g = int(np.ceil(sep / res)) + 1
        self.skylines: list[np.ndarray] = []
        self.placed: dict = {}

    def _best_on(self, sky: np.ndarray, options) -> tuple | None:
        """``(waste, top, column, y, profile)`` of the best drop on one skyline, or None."""
        best = None
        for o in options:
            k = len(o.bottom)
            if k > self.columns or o.height > self.height + 1e-9:
                continue
            present = np.isfinite(o.bottom)
            b = np.where(present, o.bottom, 0.0)
            win = sliding_window_view(sky, k)                                   # (C - k + 1, k)
            d = np.where(present, win - b, -np.inf)
            y = np.maximum(0.0, d.max(axis=1))
            ok = (y + o.height <= self.height + 1e-9) & \
                 (np.arange(len(y)) * self.res + o.width <= self.length + 1e-9)
            if not ok.any():
                continue
            waste = np.where(present, y[:, None] + b - np.maximum(win, 0.0), 0.0).sum(axis=1)
            key = np.where(ok, waste * self.res + 1e-3 * (y + o.height), np.inf)
            x = int(np.argmin(key))
            cand = (float(key[x]), x, float(y[x]), o)
            if best is None or cand[0] < best[0] - 1e-9:
                best = cand
        return best

    def add(self, name: str, options, *, new_sheet: bool = True) -> bool:
        """Place part ``name`` (its :class:`ColumnProfile` orientations) on the first sheet
        it fits, else on a new one (``new_sheet``); False when it is not placed."""
        for si, sky in enumerate(self.skylines):
            best = self._best_on(sky, options)
            if best is not None:
                self._put(si, name, best)
                return True
        if not new_sheet:
            return False
        self.skylines.append(np.zeros(self.columns))
        best = self._best_on(self.skylines[-1], options)
        if best is None:
            self.skylines.pop()
            return False
        self._put(len(self.skylines) - 1, name, best)
        return True

    def _put(self, si: int, name: str, best: tuple) -> None:
        _, x, y, o = best
        sky, g = self.skylines[si], self.g
        lo, hi = max(0, x - g), min(self.columns, x + len(o.bottom) + g)
        sky[lo:hi] = np.maximum(sky[lo:hi], o.top[lo - (x - g): hi - (x - g)] + y)
        self.placed[name] = (si, o, x * self.res, y)
