"""How few sheets the parts can need: the area bound, and the bound of the parts that must
cross the middle of every sheet they are on.

**The crossing bound.** A part laid along the rows (its minimum rotated rectangle along the
sheet's longer side, as the rows, the skyline and the search lay every part longer than the
sheet is high) and longer than half the usable length crosses the sheet's middle line, the line
across the rows half way along them, wherever it is placed. Where it crosses, it takes its
*chord*: the length of that line inside it (the sum of its pieces where the part is concave
across it: another part may lie in between, nested into the concavity). The parts crossing one
sheet's middle take their pieces of that line and keep ``sep`` to each other, so their chords
and spacings fit the usable height:
the sheets are at least the bins of a bin packing of ``chord + sep`` into ``height + sep``. A
part's chord is the least over the places the middle line can cross it, its slots closed (no
part goes into another's slot). The bin packing's bound is the arc-flow linear programme's
(Valerio de Carvalho 1999), rounded up: for these sizes the optimum or one below it. A part
turned diagonally into one half of the sheet (one 1.3-1.7 m long can be) escapes the bound,
and leaves most of that half empty.

Unrolled fins cut to the longest run that fits the sheet are mostly such parts: on 7a, 118 of
its 314 parts cross the middle, about 400 mm each, three a sheet, and no nesting of those parts
needs fewer than 39 sheets (77 %) however the rest is packed. Only cutting them shorter can.

Units: those of the outlines.

>>> from shapely.geometry import box
>>> strips = [box(0, 0, 2000, 400)] * 7           # three 400 mm strips cross each sheet's middle
>>> crossing_bound(strips, sheet=(2500, 1250), sep=5, edge=10)
3
"""
from __future__ import annotations

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import Polygon

__all__ = ["crossing_bound", "crossing_chords", "bin_packing_bound"]

#: places along a part where its chord is measured
_SAMPLES = 33
#: slots up to this many spacings wide are closed when a chord is measured
_CLOSE = 3.0


def _base_turned(poly: Polygon) -> Polygon:
    """The outline turned so that its minimum rotated rectangle's long side lies along x."""
    rect = np.asarray(poly.minimum_rotated_rectangle.exterior.coords)[:3]
    e1, e2 = rect[1] - rect[0], rect[2] - rect[1]
    d = e1 if np.linalg.norm(e1) >= np.linalg.norm(e2) else e2
    return affinity.rotate(poly, -float(np.degrees(np.arctan2(d[1], d[0]))), origin=(0, 0))


def crossing_chords(outlines, *, sheet, sep: float, edge: float) -> np.ndarray:
    """The chords (see the module docstring) of the parts that cross every sheet's middle,
    ``unit``; ``outlines`` Polygons, ``sheet`` ``(w, h)``, ``sep`` the distance two outlines
    keep, ``edge`` the distance to the sheet's edge."""
    w, h = map(float, sheet)
    length, height = max(w, h) - 2 * edge, min(w, h) - 2 * edge
    half = length / 2.0
    chords = []
    for poly in outlines:
        q = _base_turned(poly)
        x0, y0, x1, y1 = q.bounds
        if x1 - x0 <= half:
            continue
        # slots closed: no other part goes into them
        r = _CLOSE * sep
        c = q.buffer(r, join_style="mitre", mitre_limit=2.0).buffer(-r, join_style="mitre",
                                                                     mitre_limit=2.0)
        if c.is_empty:          # pragma: no cover - a part thinner than the spacing
            c = q
        # the middle line crosses the part at x0 + t, t from (its length - half) to half
        ts = x0 + np.linspace((x1 - x0) - half, half, _SAMPLES)
        lines = shapely.linestrings([[[t, y0 - 1.0], [t, y1 + 1.0]] for t in ts])
        inside = shapely.length(shapely.intersection(c, lines))
        chords.append(float(np.nan_to_num(inside).min()))
    return np.asarray(chords)


def bin_packing_bound(sizes, capacity: float, *, steps: int = 250) -> int:
    """A lower bound on the bins of capacity ``capacity`` that hold items of ``sizes``: the
    arc-flow linear programme over ``capacity / steps`` units (sizes rounded down, the
    capacity up), rounded up; at least the continuous bound.

    >>> bin_packing_bound([0.4] * 7, 1.0)        # two a bin: the continuous bound says 3
    4
    """
    sizes = np.asarray(sizes, float)
    q = capacity / steps
    if (sizes > capacity + 1e-9).any():
        raise ValueError("an item is larger than a bin")
    continuous = int(np.ceil(sizes.sum() / capacity - 1e-9))
    sizes = np.floor(sizes / q + 1e-9).astype(int)
    sizes = sizes[sizes > 0]
    if not len(sizes):
        return continuous
    cap = steps
    from scipy.optimize import linprog
    from scipy.sparse import coo_matrix

    vals, counts = np.unique(sizes, return_counts=True)
    vals, counts = vals[::-1], counts[::-1]                  # largest first
    reach = np.zeros(cap + 1, dtype=bool)
    reach[0] = True
    arcs = []                                                 # (from, to, item kind)
    for t, (s, k) in enumerate(zip(vals, counts)):
        new = reach.copy()
        for m in range(1, int(k) + 1):                        # up to k items of this size
            if m * s > cap:
                break
            new[m * s:] |= reach[:cap + 1 - m * s]
        starts = np.flatnonzero(new[:cap + 1 - s])
        arcs += [(int(u), int(u + s), t) for u in starts]
        reach = new
    nodes = sorted({0, cap} | {u for u, _, _ in arcs} | {v for _, v, _ in arcs})
    arcs += [(u, cap, -1) for u in nodes if u < cap]         # the bin's unused rest
    index = {u: i for i, u in enumerate(nodes)}
    rows, cols, data = [], [], []
    for a, (u, v, t) in enumerate(arcs):
        rows += [index[u], index[v]]
        cols += [a, a]
        data += [-1.0, 1.0]
    n_nodes, n_arcs = len(index), len(arcs)
    # the bins: a flow from 0 back to cap (one variable), counted in the objective
    rows += [index[0], index[cap]]
    cols += [n_arcs, n_arcs]
    data += [1.0, -1.0]
    eq = coo_matrix((data, (rows, cols)), shape=(n_nodes, n_arcs + 1)).tocsr()
    kinds = [(a, t) for a, (_, _, t) in enumerate(arcs) if t >= 0]
    ub = coo_matrix(([-1.0] * len(kinds), ([t for _, t in kinds], [a for a, _ in kinds])),
                    shape=(len(vals), n_arcs + 1)).tocsr()
    cost = np.zeros(n_arcs + 1)
    cost[-1] = 1.0
    res = linprog(cost, A_ub=ub, b_ub=-counts.astype(float), A_eq=eq, b_eq=np.zeros(n_nodes),
                  bounds=(0, None), method="highs")
    if res.status != 0:         # pragma: no cover - the programme is always feasible
        return continuous
    return max(continuous, int(np.ceil(res.fun - 1e-6)))


def crossing_bound(outlines, *, sheet, sep: float, edge: float) -> int:
    """The sheets no nesting of ``outlines`` (Polygons) goes below for the parts that cross
    every sheet's middle (see the module docstring)."""
    w, h = map(float, sheet)
    height = min(w, h) - 2 * edge
    chords = crossing_chords(outlines, sheet=sheet, sep=sep, edge=edge)
    return bin_packing_bound(chords + sep, height + sep)
