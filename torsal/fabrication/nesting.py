"""Nesting for yield: true shapes, free rotation, sheet by sheet, in a time budget.

:func:`nest_for_yield` fills one sheet at a time with sparrow (Gardeyn & Wauters' strip-packing
heuristic, through the ``spyrrow`` wheel), which places true shapes at any rotation with
collision detection on the exact outlines. Sparrow minimises the length of one strip of fixed
height; a workshop needs whole sheets, and cutting a dense strip into sheet lengths loses the
parts that cross every cut (measured on example 7a: a 30 s strip at 80 % density gave windows
of one sheet length only 28 % full on average, the parts are strips up to a sheet long). So
each sheet is a strip problem of its own:

1. **Choose** the parts for the sheet from those left: the large ones by a row model (parts
   are long strips: rows of them across the sheet, each row no taller than its first part,
   filled along the sheet by each part's area over its width), up to ``target`` of the sheet's
   area, then small ones (brackets) up to the same target, at most their share per sheet.
2. **Pack** them into a strip of the sheet's height with sparrow.
3. **Keep** them if the strip is no longer than the sheet; else keep the parts inside the
   sheet (valid as placed) when they are most of the set, or try once more without the
   crossing part that reaches furthest. The parts not kept go back to the pool. The target
   rises after a sheet that fitted and drops after one that did not.
4. Every kept part is checked with shapely (inside the margins, ``gap`` from every other
   part's cut): a part that is not goes back to the pool.
5. The fast nester's layout (:func:`~.layout.nest` and :func:`~.layout.shelf_pack`) is made
   too (up to 1,500 parts) and kept if it needs fewer sheets: the result is never worse than
   the fast nester's (the stats' ``method`` says which one it is).

Spacing: sparrow gets each outline grown by half the distance two outlines must keep
(``gap + 2 kerf``, :func:`~.layout.spacing`) with a mitre join (narrow slots close), simplified
conservatively (grown ``s`` more, then simplified by ``s``), oriented counter-clockwise, and
centred on its centroid (sparrow mis-places clockwise rings and items far from their
reference point).

Time: ``time_limit`` seconds in all (wall clock), split over the expected solves (sparrow
takes whole seconds: at least 2 s of exploration and 1 of compression per sheet). When the
budget is spent the parts left are nested by the fast nesters (:func:`~.layout.nest` for the
large ones, :func:`~.layout.shelf_pack` for the small ones) and counted in
:attr:`NestStats.fallback_parts`.

Determinism: every sparrow solve gets ``seed`` and one thread, the sheets are filled in a
fixed order, so a run repeats exactly where each solve converges within its seconds (small
sheets, an unloaded machine); under load a solve explores less in the same seconds and the
sheets may differ. The report names the seed and the seconds.

Units: those of the outlines (``unit``).

Example
-------
>>> from shapely.geometry import box
>>> parts = {f"p{i}": box(0, 0, 300 + 20 * i, 100) for i in range(6)}
>>> lay = nest_for_yield(parts, sheet=(1000, 500), gap=5, margin=10, time_limit=5, compare_fast=False)
>>> lay.n_sheets, lay.stats.method
(1, 'sparrow')
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from enum import Enum
from typing import Callable, Mapping, Sequence

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient

from .cutting import Cutting
from .layout import (Layout, _as_items, _turned_shapes, check_fits, merge_layouts, nest,
                     placement_of, shelf_pack, spacing)

__all__ = ["nest_for_yield", "nest_parts", "Nester", "NestStats", "DEFAULT_TIME_LIMIT",
           "SECONDS_PER_SHEET", "DEFAULT_SEED"]

#: seconds the nester may take by default: this many per sheet the parts' area needs...
SECONDS_PER_SHEET = 4.0
#: ... and at most this many
DEFAULT_TIME_LIMIT = 120.0
#: sparrow's seed by default
DEFAULT_SEED = 0
#: parts smaller than this share of the usable sheet are fillers (brackets), not row parts
_SMALL = 0.02
#: the fast nester's layout is made too, and kept if it needs fewer sheets, up to this many parts
_SAFETY_PARTS = 1500
#: first target fill of a sheet (share of its usable area), and its bounds
_TARGET, _TARGET_MIN, _TARGET_MAX = 0.86, 0.6, 0.95


class Nester(str, Enum):
    """Which nester places the parts."""

    #: sparrow sheet by sheet, true shapes, free rotation, in a time budget (:func:`nest_for_yield`)
    SPARROW = "sparrow"
    #: the fast bottom-left fill (:func:`~.layout.nest`), connectors in rows after the plates
    BOTTOM_LEFT = "bottom-left"


@dataclass
class NestStats:
    """How a nesting went (for the report).

    ``seconds`` wall clock, ``cpu_seconds`` of this process; ``solves`` sparrow calls;
    ``area_bound`` parts' area / sheet area (the sheets a perfect nest would need);
    ``fallback_parts`` parts nested by the bottom-left nester after the budget ran out.
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


def _grown(outline: Polygon, half: float) -> Polygon:
    """The outline grown by ``half`` (mitre join: slots narrower than ``2 half`` close),
    simplified without shrinking below that, without holes, counter-clockwise."""
    s = max(0.05 * half, 1e-3 * np.sqrt(outline.area), 1e-9)
    g = outline.buffer(half + s, join_style="mitre", mitre_limit=2.0).simplify(s)
    if g.geom_type != "Polygon":
        g = g.convex_hull
    return orient(Polygon(g.exterior), 1.0)


def _min_width(p: Polygon) -> float:
    """The minimum width of a polygon (rotating calipers over its convex hull)."""
    h = np.asarray(p.convex_hull.exterior.coords)[:-1]
    e = np.roll(h, -1, axis=0) - h
    length = np.linalg.norm(e, axis=1)
    ok = length > 0
    n = np.stack([-e[ok, 1], e[ok, 0]], axis=1) / length[ok, None]      # edge normals (k, 2)
    d = n @ h.T                                                          # (k, corners)
    return float((d.max(axis=1) - d.min(axis=1)).min())


class _Sparrow:
    """One sparrow strip solve per call, on the grown, centred shapes."""

    def __init__(self, shapes: dict, height: float, seed: int, rotation_step: float | None):
        import spyrrow

        self.spyrrow = spyrrow
        self.shapes, self.height, self.seed = shapes, height, seed
        if rotation_step is None:
            self.orientations = None
        else:
            self.orientations = [float(a) for a in np.arange(0.0, 360.0, rotation_step)]
        self.calls = 0
        self.seconds = 0.0             # wall seconds the solves took
        self.asked = 0.0               # and the seconds they were given

    def solve(self, names: list, explore: int, compress: int) -> tuple[float, dict]:
        """Strip length and ``{name: (rotation deg, (tx, ty))}`` of the centred shapes."""
        sp = self.spyrrow
        items = [sp.Item(n, list(self.shapes[n].exterior.coords)[:-1], demand=1,
                         allowed_orientations=self.orientations) for n in names]
        cfg = sp.StripPackingConfig(early_termination=True, total_computation_time=None,
                                    exploration_time=int(explore), compression_time=int(compress),
                                    num_workers=1, seed=int(self.seed))
        t0 = time.perf_counter()
        sol = sp.StripPackingInstance("sheet", strip_height=float(self.height), items=items).solve(cfg)
        self.seconds += time.perf_counter() - t0
        self.asked += explore + compress
        self.calls += 1
        return float(sol.width), {p.id: (float(p.rotation), tuple(map(float, p.translation)))
                                  for p in sol.placed_items}


def nest_for_yield(outlines, *, sheet: tuple[float, float] = (2500.0, 1250.0), gap: float = 5.0,
                   margin: float = 10.0, unit: str = "mm", cutting: Cutting | None = None,
                   time_limit: float | None = None, seed: int = DEFAULT_SEED,
                   rotation_step: float | None = None, compare_fast: bool = True,
                   progress: Callable[[int, int], None] | None = None) -> Layout:
    """Nest flat parts on as few sheets as the time allows (see the module docstring).

    Parameters
    ----------
    outlines : sequence of Unrolled, of (name, Polygon), of Polygon, or {name: Polygon}
        Flat parts in ``unit``.
    sheet : (width, height)
        Sheet size, ``unit``.
    gap, margin : float
        Sheet left between the cuts of two parts, and between a cut and the sheet edge
        (``unit``; see :func:`~.layout.spacing`).
    cutting : Cutting, optional
        The cutting process (kerf, reliefs); None: cut on the outline.
    time_limit : float, optional
        Seconds (wall clock) for the whole nesting, at least 1; default
        :data:`SECONDS_PER_SHEET` per sheet the parts' area needs, at most
        :data:`DEFAULT_TIME_LIMIT`.
    seed : int
        Sparrow's seed.
    rotation_step : float, optional
        Allowed rotations in steps of this many degrees; None: any rotation.
    compare_fast : bool
        Make the fast nester's layout too and keep it where it needs no more sheets (step 5).
    progress : callable, optional
        ``progress(sheets done, parts left)`` after each sheet.

    Returns
    -------
    Layout
        With :attr:`~.layout.Layout.stats` a :class:`NestStats`.

    Raises
    ------
    PartTooLargeError
        If a part fits the sheet in no rotation.
    """
    t0, c0 = time.perf_counter(), time.process_time()
    w, h = map(float, sheet)
    if w <= 0 or h <= 0:
        raise ValueError(f"sheet must have positive size, got {sheet}")
    if gap < 0 or margin < 0:
        raise ValueError("gap and margin must be >= 0")
    if time_limit is not None and not time_limit >= 1:
        raise ValueError(f"time_limit must be at least 1 s, got {time_limit}")
    if rotation_step is not None and not 0 < rotation_step <= 360:
        raise ValueError(f"rotation_step must be in (0, 360] degrees, got {rotation_step}")
    items = _as_items(outlines, cutting)
    sep, edge = spacing(gap, margin, cutting)
    check_fits(items, [_turned_shapes(it, (0, 90, 180, 270)) for it in items], w, h, edge,
               (0, 90, 180, 270), unit)
    by_name = {it.name: it for it in items}
    usable = (w - 2 * edge) * (h - 2 * edge)
    # centred true shapes (what is placed) and grown ones (what sparrow packs)
    centre = {it.name: np.asarray(it.outline.centroid.coords[0]) for it in items}
    true = {n: affinity.translate(it.outline, *(-centre[n])) for n, it in by_name.items()}
    shapes = {n: _grown(p, 0.5 * sep) for n, p in true.items()}
    area = {n: p.area for n, p in true.items()}
    solver = _Sparrow(shapes, h - 2 * edge + sep, seed, rotation_step)
    chooser = _Chooser(true, area, (w - 2 * edge, h - 2 * edge), sep)
    total = sum(area.values())
    if time_limit is None:
        time_limit = min(DEFAULT_TIME_LIMIT, SECONDS_PER_SHEET * max(1.0, np.ceil(total / usable)))
    placed: list = []                  # (name, sheet, rotation, (dx, dy)) of the original outline
    fill: list[float] = []
    target = _TARGET
    pool = chooser.order(list(by_name))
    # never worse than the fast nester: its layout is made first (up to _SAFETY_PARTS parts:
    # beyond, it takes minutes) and kept where sparrow needs as many sheets or more (a loaded
    # machine gives sparrow too little of each second); sparrow does not start where it is
    # at the area bound's ceiling already, and stops as soon as it can no longer beat it
    fast = None
    if compare_fast and len(items) <= _SAFETY_PARTS:
        large = nest([it for it in items if it.name not in chooser.small], sheet=sheet, gap=gap,
                     margin=margin, unit=unit, cutting=cutting)
        fast = merge_layouts(large, shelf_pack(
            [it for it in items if it.name in chooser.small], sheet=sheet, gap=gap, margin=margin,
            unit=unit, cutting=cutting, first_sheet=large.n_sheets))
    beaten = (lambda sheets_so_far, left_area: fast is not None and
              sheets_so_far + np.ceil(left_area / usable - 1e-9) >= fast.n_sheets)
    at_bound = beaten(0, total)
    fill_area = 0.0
    if at_bound:
        pool = []                      # the fast layout is as good as any can be
    while pool:
        left = time_limit - (time.perf_counter() - t0)
        left_area = sum(area[n] for n in pool)
        if beaten(len(fill), left_area):
            break
        # after two sheets, sparrow's own fill so far projects its sheets: stop where that
        # cannot beat the fast layout (a starved solver packs loosely; go on where it packs well)
        if fast is not None and len(fill) >= 2 and fill_area > 0 and \
                len(fill) + np.ceil(left_area / (fill_area / len(fill))) >= fast.n_sheets:
            break
        n_left = max(1.0, sum(area[n] for n in pool) / (target * usable))
        # a solve takes longer than the seconds it is given (setting up; a loaded machine):
        # plan with the ratio measured so far
        ratio = max(1.0, solver.seconds / solver.asked) if solver.calls else 1.0
        per = left / (1.2 * n_left * ratio)
        # sparrow needs about 2 s of exploration and 1 of compression to pack a sheet well
        # (measured on 7a: 1 + 0 s left sheets half empty)
        explore, compress = (int(0.6 * per), int(0.4 * per)) if per >= 5 else (2, 1)
        if left < (explore + compress) * ratio:
            break
        sheet_no = len(fill)
        names = chooser.choose(pool, target, n_left)
        kept, best = None, {}
        for attempt in range(2):
            _, where = solver.solve(names, explore, compress)
            inside = _inside(where, true, w, h, edge, sep)
            if len(inside) == len(names):
                kept = inside
                target = min(_TARGET_MAX, target + 0.01)
                break
            target = max(_TARGET_MIN, target - 0.03)
            if sum(area[n] for n in inside) > sum(area[n] for n in best):
                best = inside
            if attempt == 1 or sum(area[n] for n in inside) >= 0.9 * sum(area[n] for n in names) \
                    or len(names) == 1 or \
                    time_limit - (time.perf_counter() - t0) < (explore + compress) * ratio:
                break
            # once more without the part that reaches furthest out of the sheet
            out = [n for n in names if n not in inside]
            far = max(out, key=lambda n: (_reach(where[n], true[n]), area[n], n))
            names = [n for n in names if n != far]
        kept = kept if kept is not None else best
        if not kept:
            break                      # sparrow placed nothing inside: the fallback takes over
        for n, (rot, (tx, ty)) in kept.items():
            c = centre[n]
            cr = np.array([[np.cos(np.radians(rot)), -np.sin(np.radians(rot))],
                           [np.sin(np.radians(rot)), np.cos(np.radians(rot))]]) @ c
            # placed = rotate(outline - c) + t + shift = rotate(outline) - R c + t + shift
            shift = edge - 0.5 * sep
            placed.append((n, sheet_no, rot, (tx + shift - cr[0], ty + shift - cr[1])))
        fill.append(sum(area[n] for n in kept) / (w * h))
        fill_area += sum(area[n] for n in kept)
        pool = [n for n in pool if n not in kept]
        if progress is not None:
            progress(len(fill), len(pool))
    placements = [placement_of(by_name[n], s, rot, dx, dy) for n, s, rot, (dx, dy) in placed]
    fallback = 0
    pool_left = bool(pool) and fast is not None     # the fast layout is kept: no fallback needed
    if pool and not pool_left:                           # the budget is spent: the fast nesters take the rest
        large = nest([by_name[n] for n in pool if n not in chooser.small],
                     sheet=sheet, gap=gap, margin=margin, unit=unit, cutting=cutting)
        rest = merge_layouts(large, shelf_pack(
            [by_name[n] for n in pool if n in chooser.small], sheet=sheet, gap=gap,
            margin=margin, unit=unit, cutting=cutting, first_sheet=large.n_sheets))
        for p in rest.placements:
            p.sheet += len(fill)
            placements.append(p)
        fill += [0.0] * rest.n_sheets          # measured below
        fallback = len(rest.placements)
    # sheets numbered 0.. in order of use (none left empty)
    renumber = {s: i for i, s in enumerate(sorted({p.sheet for p in placements}))}
    for p in placements:
        p.sheet = renumber[p.sheet]
    fill = [0.0] * len(renumber)
    for p in placements:
        fill[p.sheet] += area[p.name] / (w * h)
    placements.sort(key=lambda p: (p.sheet, p.name))
    stats = NestStats("sparrow", time.perf_counter() - t0, time.process_time() - c0,
                      total / (w * h), solver.calls, seed, float(time_limit), fallback,
                      "free" if rotation_step is None else f"{rotation_step:g} deg steps", fill,
                      solver.seconds)
    if fast is not None and (at_bound or pool_left or fast.n_sheets <= len(fill)):
        why = ("at the area bound" if at_bound else
               "sparrow could not use fewer sheets in the time" if pool_left else
               f"sparrow: {len(fill)} sheets")
        stats.method = f"{Nester.BOTTOM_LEFT.value} ({why})"
        stats.sheet_fill = fast.sheet_utilization
        fast.stats = stats
        return fast
    return Layout((w, h), placements, len(fill), unit=unit, gap=gap, margin=margin,
                  cutting=cutting, stats=stats)


def _reach(where: tuple, shape: Polygon) -> float:
    """How far along the strip a placed (centred) shape reaches."""
    rot, (tx, _) = where
    return affinity.rotate(shape, rot, origin=(0, 0)).bounds[2] + tx


def _inside(where: dict, true: dict, w: float, h: float, edge: float, sep: float) -> dict:
    """The placements (of the centred true shapes, in sparrow's strip) that lie inside the
    sheet's margins and keep ``sep`` from each other, checked with shapely."""
    shift = edge - 0.5 * sep
    polys = {}
    for n, (rot, (tx, ty)) in where.items():
        polys[n] = affinity.translate(affinity.rotate(true[n], rot, origin=(0, 0)), tx + shift, ty + shift)
    tol = 1e-6 * max(w, h)
    ok = {n: p for n, p in polys.items()
          if p.bounds[0] >= edge - tol and p.bounds[1] >= edge - tol
          and p.bounds[2] <= w - edge + tol and p.bounds[3] <= h - edge + tol}
    names = sorted(ok, key=lambda n: (-ok[n].area, n))
    tree = shapely.STRtree([ok[n] for n in names])
    bad: set = set()
    for i, n in enumerate(names):
        if n in bad:
            continue
        for j in tree.query(ok[n], predicate="dwithin", distance=sep - 1e-6 * sep):
            m = names[j]
            if j > i and m not in bad and ok[n].distance(ok[m]) < sep - 1e-6 * max(sep, 1.0):
                bad.add(m)             # the smaller part goes back to the pool
    return {n: where[n] for n in names if n not in bad}


class _Chooser:
    """Which parts to offer sparrow for one sheet (the row model of the module docstring)."""

    def __init__(self, true: dict, area: dict, usable: tuple[float, float], sep: float):
        self.area, self.sep = area, sep
        self.length_u, self.height_u = usable
        self.usable = usable[0] * usable[1]
        self.small = {n for n, a in area.items() if a < _SMALL * self.usable}
        #: a part's row height (its minimum width) and length along the row (area / width),
        #: both with the spacing
        self.height = {n: _min_width(p) + sep for n, p in true.items()}
        self.length = {n: area[n] / (self.height[n] - sep) + sep for n in true}

    def order(self, names: list) -> list:
        """Large parts first, by the area of their row footprint; small ones after."""
        return sorted(names, key=lambda n: (n in self.small, -self.height[n] * self.length[n], n))

    def choose(self, pool: list, target: float, sheets_left: float) -> list:
        """Parts for the next sheet: large ones in rows up to ``target`` of the sheet's area,
        then small ones up to the same target, at most 1.5 times their share per sheet."""
        cap = target * self.usable
        rows: list[list[float]] = []          # [height, filled length]
        used_h, sel, a = 0.0, [], 0.0
        for n in pool:
            if n in self.small or (sel and a + self.area[n] > cap):
                continue
            hn, ln = self.height[n], self.length[n]
            for r in rows:
                if hn <= r[0] + 1e-9 and r[1] + ln <= self.length_u + self.sep:
                    r[1] += ln
                    break
            else:
                if sel and used_h + hn > self.height_u + self.sep:
                    continue
                rows.append([hn, ln])
                used_h += hn
            sel.append(n)
            a += self.area[n]
        small = [n for n in pool if n in self.small]
        share = 1.5 * sum(self.area[n] for n in small) / max(1.0, sheets_left)
        s_used = 0.0
        for n in small:
            if sel and (a + self.area[n] > cap or s_used + self.area[n] > share):
                break
            sel.append(n)
            a += self.area[n]
            s_used += self.area[n]
        return sel or pool[:1]


def nest_parts(unrolled: Mapping, *, connectors=frozenset(), sheet: tuple[float, float] = (2500.0, 1250.0),
               gap: float = 5.0, margin: float = 10.0, unit: str = "mm",
               cutting: Cutting | None = None, nester: Nester | str = Nester.BOTTOM_LEFT,
               rotations: Sequence[float] = (0, 90, 180, 270),
               time_limit: float | None = None, seed: int = DEFAULT_SEED,
               rotation_step: float | None = None,
               progress: Callable[[int, int], None] | None = None) -> Layout:
    """The sheets of a fin system's unrolled parts ``{name: Unrolled}``: with
    :attr:`Nester.SPARROW` all parts together (the connectors fill the gaps between the
    plates; :func:`nest_for_yield`), with :attr:`Nester.BOTTOM_LEFT` the plates by
    :func:`~.layout.nest` (``rotations``) and the ``connectors`` (names) in rows on the sheets
    after them (:func:`~.layout.shelf_pack`). :class:`~.cutting.CuttingError` if the
    cutting process cannot cut the slots."""
    t0, c0 = time.perf_counter(), time.process_time()
    if cutting is not None:
        cutting.check_slots(unrolled.values())
    if Nester(nester) == Nester.SPARROW:
        return nest_for_yield(list(unrolled.values()), sheet=sheet, gap=gap, margin=margin,
                              unit=unit, cutting=cutting, time_limit=time_limit, seed=seed,
                              rotation_step=rotation_step, progress=progress)
    plates = nest([u for n, u in unrolled.items() if n not in connectors], sheet=sheet, gap=gap,
                  margin=margin, rotations=rotations, unit=unit, cutting=cutting)
    lay = plates
    if connectors:
        kit = shelf_pack([u for n, u in unrolled.items() if n in connectors], sheet=sheet, gap=gap,
                         margin=margin, unit=unit, first_sheet=plates.n_sheets, cutting=cutting)
        lay = merge_layouts(plates, kit)
    lay.stats = NestStats(Nester.BOTTOM_LEFT.value, time.perf_counter() - t0,
                          time.process_time() - c0, lay.area_bound,
                          rotation=f"{len(rotations)} rotations", sheet_fill=lay.sheet_utilization)
    return lay
