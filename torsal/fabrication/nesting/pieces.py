"""The stand-in pieces of the plates the final cut may split (:mod:`.split`): a piece is a
plate's flat outline between two of its node lines, in the plate's own frame (it lies where it
lay in the plate), prepared as the search takes it; :class:`CutCost`, what one cut adds to the
bill of quantities. The fin system builds the real pieces afterwards (:mod:`.final_cut`).

Units: those of the outlines.

>>> piece_name("F1-S003-P00", 0, 2)
'F1-S003-P00[0:2]'
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Mapping, NamedTuple

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon
from shapely.ops import unary_union

from ..unroll import FLAT_FOLD
from .items import _Item

if TYPE_CHECKING:
    from .search import _Search

__all__ = ["CutCost", "Pieces", "piece_name", "cut_outlines"]


class CutCost(NamedTuple):
    """What one cut adds to the bill of quantities: ``cut`` contour (unit: the two new edges
    less the slot they run through), one pierce and one part to place, ``bend`` 1 where the
    node line was a bend of the plate (its two pieces are flat there: one bend less), and
    ``fixings`` the fixings its pieces take more than the plate (a plate fixed to the
    building: each piece is)."""

    part: str
    position: int
    cut: float
    bend: int
    fixings: int = 0


def piece_name(part: str, lo: int, hi: int) -> str:
    """The stand-in name of the panels ``[lo, hi)`` of ``part``."""
    return f"{part}[{lo}:{hi}]"


def _perimeter(poly) -> float:
    return float(poly.exterior.length + sum(r.length for r in poly.interiors))


class Pieces:
    """The stand-in pieces of the parts that may be split: their flat outlines (the part's
    outline between two of its node lines, in the part's own frame: a piece lies where it lay
    in the part), prepared as the search takes them, made once each. ``parents`` the whole
    parts as prepared (``{name: _Item}``), ``cuts`` where each may be cut; :meth:`bind` names
    the search that new pieces are registered with."""

    def __init__(self, parents: Mapping, unrolled: Mapping, cuts: Mapping, fixings=None):
        self.parents, self.unrolled = parents, unrolled
        self.fixings = fixings or {}
        self.cuts = {n: tuple(sorted({int(j) for j in c})) for n, c in cuts.items()
                     if n in parents and n in unrolled and len(c)}
        #: stand-in name -> (part, lo, hi)
        self.of: dict[str, tuple[str, int, int]] = {}
        self.search: _Search | None = None
        self._polys: dict = {}
        self._items: dict = {}

    def bind(self, search: _Search) -> "Pieces":
        self.search = search
        return self

    def whole(self, name: str) -> tuple[str, int, int]:
        """``(part, lo, hi)`` of a part or piece."""
        if name in self.of:
            return self.of[name]
        return name, 0, len(self.unrolled[name].panels) if name in self.unrolled else 0

    def positions_of(self, part: str, lo: int, hi: int) -> list[int]:
        """The node lines of ``part`` inside ``[lo, hi)`` it may be cut at."""
        return [j for j in self.cuts.get(part, ()) if lo < j < hi]

    def polygon(self, part: str, lo: int, hi: int) -> Polygon | None:
        """The flat outline of panels ``[lo, hi)`` of ``part`` (in the part's frame), or None
        where it does not come apart there into one polygon."""
        key = (part, lo, hi)
        if key not in self._polys:
            u, parent = self.unrolled[part], self.parents[part]
            if (lo, hi) == (0, len(u.panels)):
                poly = parent.outline
            else:
                span = unary_union([Polygon(q) for q in u.panels[lo:hi]]).buffer(0)
                poly = parent.outline.intersection(span)
                if poly.geom_type != "Polygon" or poly.is_empty or not poly.is_valid:
                    poly = None
                else:
                    poly = shapely.set_precision(poly, 0.0)
            self._polys[key] = poly
        return self._polys[key]

    def item(self, part: str, lo: int, hi: int) -> _Item | None:
        """The prepared stand-in of panels ``[lo, hi)`` of ``part`` (the part's own item for
        the whole part), or None."""
        u = self.unrolled[part]
        if (lo, hi) == (0, len(u.panels)):
            return self.parents[part]
        key = (part, lo, hi)
        if key not in self._items:
            self._items[key] = self._item(part, lo, hi)
            if self._items[key] is not None:
                self.of[self._items[key].name] = key
        return self._items[key]

    def get(self, part: str, lo: int, hi: int) -> str | None:
        """The name of the stand-in of panels ``[lo, hi)`` of ``part``, registered with the
        bound search; None where the outline does not come apart there."""
        it = self.item(part, lo, hi)
        if it is None:
            return None
        if it.name not in self.search.by_name:
            self.search.add_items([it])
        return it.name

    def _item(self, part: str, lo: int, hi: int) -> _Item | None:
        u, parent = self.unrolled[part], self.parents[part]
        poly = self.polygon(part, lo, hi)
        if poly is None:
            return None
        span = unary_union([Polygon(q) for q in u.panels[lo:hi]]).buffer(1e-6)
        folds = []
        for i in range(lo, hi - 1):
            if abs(float(u.fold_angles[i])) <= FLAT_FOLD:
                continue
            folds.append((LineString(u.fold_lines[i]).intersection(poly), float(u.fold_angles[i])))
        holes = [h for h in parent.holes if span.contains(shapely.Point(h[0]))]
        reliefs = parent.reliefs
        if len(reliefs):
            reliefs = reliefs[shapely.contains_xy(span, reliefs[:, 0], reliefs[:, 1])]
        # (a stand-in: its label is the real piece's, made when the fin system is rebuilt)
        rp = poly.representative_point()
        it = _Item(piece_name(part, lo, hi), poly, folds, (rp.x, rp.y), 0.0, parent.label_angle,
                   n_panels=hi - lo, holes=holes, reliefs=reliefs)
        rect = np.asarray(poly.minimum_rotated_rectangle.exterior.coords)[:3]
        e1, e2 = rect[1] - rect[0], rect[2] - rect[1]
        d = e1 if np.linalg.norm(e1) >= np.linalg.norm(e2) else e2
        it.base = -float(np.degrees(np.arctan2(d[1], d[0])))
        r = poly.exterior.distance(rp)
        it.label_height = float(np.clip(0.8 * r, 1.0, 20.0)) if r > 0 else 1.0
        return it

    def cost(self, part: str, j: int) -> CutCost:
        """The :class:`CutCost` of cutting ``part`` at its node line ``j``."""
        k = len(self.unrolled[part].panels)
        a, b, whole = self.polygon(part, 0, j), self.polygon(part, j, k), self.polygon(part, 0, k)
        extra = (_perimeter(a) + _perimeter(b) - _perimeter(whole)) if a is not None and \
            b is not None else 0.0
        bend = int(abs(float(self.unrolled[part].fold_angles[j - 1])) > FLAT_FOLD)
        return CutCost(part, int(j), float(extra), bend, int(self.fixings.get((part, int(j)), 0)))

    def cuts_of(self, names) -> dict[str, tuple[int, ...]]:
        """``{part: node lines cut}`` of the parts and pieces ``names`` laid out."""
        out: dict[str, set] = {}
        for n in names:
            if n in self.of:
                part, lo, hi = self.of[n]
                k = len(self.unrolled[part].panels)
                out.setdefault(part, set()).update(j for j in (lo, hi) if 0 < j < k)
        return {p: tuple(sorted(js)) for p, js in sorted(out.items())}


def _ranges(k: int, cuts) -> list[tuple[int, int]]:
    c = sorted({0, k} | {int(j) for j in cuts if 0 < j < k})
    return list(zip(c[:-1], c[1:]))


def cut_outlines(pieces: Pieces, names, cuts: Mapping) -> list | None:
    """The parts ``names`` (prepared items) with those of ``cuts`` ``{part: node lines}``
    replaced by their pieces' stand-ins; None where a piece does not come apart."""
    out = []
    for n in names:
        if n not in cuts:
            out.append(pieces.parents[n])
            continue
        for lo, hi in _ranges(len(pieces.unrolled[n].panels), cuts[n]):
            it = pieces.item(n, lo, hi)
            if it is None:
                return None
            out.append(it)
    return out
