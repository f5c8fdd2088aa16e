"""Strips of a support structure and the parts they are cut into (issues 6, 15).

:func:`_read_strips` reads the fins of a :class:`~torsal.geometry.support.SupportStructure`
into strips (scaled to ``unit``, degenerate panels marked) and :func:`_plate_panels` the
panels of each family's plate around every node; :class:`StripCutter` cuts each strip into
parts: at sharp folds, dropped panels, crossings to be butted, and the ``max_panels``,
``max_part_length`` and ``fit_sheet`` limits of the fin system (rules in
:mod:`torsal.fabrication.parts`). Lengths in the fin system's ``unit``.
"""
from __future__ import annotations

import dataclasses
import warnings
from typing import NamedTuple

import numpy as np

from ..joints import toward_panel
from ..model import (FAMILY_COLORS, MITER_LIMIT, FamilySplit, Part, PartId, _bowtie, _fold_deg,
                     _miter, _oriented_size, _safe_normals, panel_widths)
from ..unroll import flat_outline


class _Strips(NamedTuple):
    """The structure's strips in ``unit``: ``quads`` (k, 4, 3) and ``drops`` (k,) per strip,
    node line ends ``a``, ``b`` (n, 3) and fin ``depth`` (n,) (the deeper family's), and per
    family and node whether a strip passes through it (two kept panels) or ends there (one);
    ``family_depth`` (2, n): how deep each family's fins are at each node (``fins.depth =
    [d0, d1]``; both ``depth`` where the families are alike)."""

    fins: list
    quads: list
    drops: list
    a: np.ndarray
    b: np.ndarray
    depth: np.ndarray
    passes: np.ndarray
    ends: np.ndarray
    family_depth: np.ndarray

    def family_b(self, family: int, node: int) -> np.ndarray:
        """(3,): where the fins of ``family`` end on the node line of ``node``."""
        d = self.depth[node]
        return self.a[node] + (self.b[node] - self.a[node]) * (self.family_depth[family, node] / d)


def _merge_coincident_nodes(structure):
    """The structure with nodes of identical node lines (``a`` and ``b`` equal to 1e-9 of its
    size) merged into one index, e.g. the two families of refined developable strips, which
    duplicate the nodes they share: the plates cross there and need a joint."""
    a, b = np.asarray(structure.vertices_a, float), np.asarray(structure.vertices_b, float)
    if not len(a):
        return structure
    tol = 1e-9 * max(1.0, float(np.abs(np.r_[a, b]).max()))
    key = np.round(np.c_[a, b] / tol).astype(np.int64)
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    canon = first[inv.ravel()]
    if (canon == np.arange(len(a))).all():
        return structure
    return dataclasses.replace(structure, edges=canon[np.asarray(structure.edges)],
                               faces=[[int(canon[v]) for v in f] for f in structure.faces])


def _read_strips(structure, scale: float, drop_mask, extra: dict | None = None) -> _Strips:
    """Strips of a support structure scaled to ``unit``, degenerate panels marked (and the
    panels ``extra`` {strip index: panel indices})"""
    strips = _merge_coincident_nodes(structure).fins()
    a = structure.vertices_a * scale
    b = structure.vertices_b * scale
    depth = np.linalg.norm(b - a, axis=1)
    used = np.unique(structure.edges)
    tiny = depth[used] <= 1e-12 * max(1.0, float(np.abs(a).max()))
    if tiny.any():
        raise ValueError(f"nodes {used[tiny][:10].tolist()} have zero fin depth (a_i == b_i)")
    quads = [fs.quads * scale for fs in strips]
    drops = [drop_mask(q) for q in quads]
    for si, panels in (extra or {}).items():
        drops[si][sorted(panels)] = True
    n = len(a)
    passes = np.zeros((2, n), dtype=bool)
    ends = np.zeros((2, n), dtype=bool)
    for fs, drop in zip(strips, drops):
        v = np.asarray(fs.vertices)
        k = len(drop)
        for j in range(len(v)):
            if fs.closed and j == k:
                continue
            left = j - 1 if j > 0 else (k - 1 if fs.closed else None)
            right = j if j < k else None
            cnt = sum(1 for i in (left, right) if i is not None and not drop[i])
            if cnt == 2:
                passes[fs.family, v[j]] = True
            elif cnt == 1:
                ends[fs.family, v[j]] = True
    ratio = np.asarray(getattr(structure, "family_depth_ratio", (1.0, 1.0)), float)
    return _Strips(strips, quads, drops, a, b, depth, passes, ends, ratio[:, None] * depth)


def _plate_panels(st: _Strips) -> dict:
    """``{(family, node): [(normal, direction into the panel square to the node line,
    (strip, panel))]}``: the kept panels of each family's plate around each node."""
    plate: dict[tuple[int, int], list] = {}
    for si, (fs, q, drop) in enumerate(zip(st.fins, st.quads, st.drops)):
        nq = _safe_normals(q)
        for j, v in enumerate(fs.vertices):
            if fs.closed and j == len(nq):
                continue
            adj = [i for i in (j - 1, j) if 0 <= i < len(nq)]
            if fs.closed and j == 0:
                adj = [len(nq) - 1, 0]
            lst = plate.setdefault((fs.family, int(v)), [])
            line = st.b[v] - st.a[v]
            line = line / np.linalg.norm(line)
            for i in adj:
                if drop[i]:
                    continue
                into = q[i].mean(axis=0) - st.a[v]
                into = into - (into @ line) * line
                ni = np.linalg.norm(into)
                if not ni > 1e-9 * st.depth[v]:
                    continue           # panel centre on the node line: no direction
                # (the side the panel lies on along the node line: not its centre's for a dart)
                lst.append((nq[i], toward_panel(into / ni, q[i], i == j, nq[i]), (si, i)))
    return plate


def folded_back_reach(fold: float, thickness: float) -> float:
    """How far from their common node line two plates ``thickness`` thick, one folded back
    onto the other by ``fold`` degrees (over 90: they lie on the same side of the line, an
    angle ``180 - fold`` apart), overlap (``unit``): a point of one mid-plane ``r`` from the
    line is ``r sin(180 - fold)`` off the other's, inside it while that is under a thickness
    (half of each plate). 0 for folds of 90 degrees or less.

    >>> round(folded_back_reach(170.0, 3.0), 2)
    17.28
    >>> folded_back_reach(60.0, 3.0)
    0.0
    """
    if not fold > 90.0:
        return 0.0
    return float(thickness / np.sin(np.radians(180.0 - fold)))


def _cut_at(ranges: list[tuple[int, int]], cuts) -> list[tuple[int, int]]:
    """Panel ranges ``[lo, hi)`` cut also at the node lines ``cuts`` that lie inside them.

    >>> _cut_at([(0, 4), (4, 7)], {2, 4, 5})
    [(0, 2), (2, 4), (4, 5), (5, 7)]
    """
    if not cuts:
        return ranges
    out = []
    for lo, hi in ranges:
        c = sorted({lo, hi} | {int(j) for j in cuts if lo < j < hi})
        out += list(zip(c[:-1], c[1:]))
    return out


class StripCutter:
    """Cuts the strips of a fin system ``fs`` (its limits: ``min_panel_width``,
    ``max_fold_angle``, ``max_panels``, ``max_part_length``, ``fit_sheet``) into parts; fills its
    ``dropped_panels`` and ``oversize_panels``."""

    def __init__(self, fs):
        self.fs = fs

    def _drop_mask(self, quads: np.ndarray) -> np.ndarray:
        """Panels too narrow, of zero area, self-intersecting (bow-tie: the node lines cross
        inside the fin) or folded back onto the previous panel, to be fabricated."""
        fs = self.fs
        w = panel_widths(quads)
        tol = 1e-9 * max(1.0, float(np.abs(quads).max()))
        n = _safe_normals(quads)
        drop = ((w <= tol) | (w < fs.min_panel_width) | _bowtie(quads)
                | ~np.isfinite(n).all(axis=1))
        # a panel folded back (more than MITER_LIMIT) onto its kept neighbour lies on top of it:
        # it duplicates that fin and cannot be built; drop it
        for j in range(1, len(quads)):
            if drop[j] or drop[j - 1]:
                continue
            fold = _fold_deg(n[j - 1], n[j])
            if fold > MITER_LIMIT:
                drop[j] = True
            elif fold > 90.0 and (min(w[j - 1], w[j]) < folded_back_reach(fold, fs.thickness)
                                  + fs.min_panel_width):
                # folded back less far, but what the narrower panel has outside the other
                # plate is narrower than a panel is kept (7c at full size: an 18.7 mm panel
                # folded back 169.5 deg at the end of F1-S000, 16.5 mm of it inside the next
                # part, 7,773 mm^3): drop that one
                drop[j - 1 if w[j - 1] < w[j] else j] = True
        return drop

    def _miter_ok(self, n1, n2, w1, w2) -> bool:
        """A fold can be mitred: at most MITER_LIMIT, and the bevel ``t/2 tan(fold/2)`` (how far
        the mitre shifts the faces of the plate across the node line) is at most a tenth of
        the narrowest width (:func:`panel_widths`) of both panels; beyond that the faces of a
        narrow, slanted panel twist too much (or cross) for a sound solid."""
        fs = self.fs
        ang = _fold_deg(n1, n2)
        if not ang <= MITER_LIMIT:
            return False
        return 0.5 * fs.thickness * np.tan(np.radians(ang) / 2) <= 0.1 * min(w1, w2)

    def _warn_dropped(self) -> None:
        fs = self.fs
        if fs.dropped_panels:
            d = fs.dropped_panels
            warnings.warn(
                f"{len(d)} degenerate fin panels (narrower than min_panel_width="
                f"{fs.min_panel_width:g} {fs.unit}, self-intersecting or folded back onto their "
                f"neighbour) were dropped (their strips are split there): "
                + "; ".join(f"{s} edge {e} ({w:.3g} {fs.unit} wide)" for s, e, w in d[:8])
                + (" ..." if len(d) > 8 else "") + "; see FinSystem.dropped_panels. Remesh more "
                "finely or move the boundary if these fins are needed", stacklevel=3)

    def _split_ranges(self, quads: np.ndarray, closed: bool,
                      drop: np.ndarray | None = None, extra_cuts=(),
                      avoid=frozenset()) -> list[tuple[int, int]]:
        """Panel ranges [lo, hi) of the parts of one strip (dropped panels left out), cut also
        at the node lines ``extra_cuts`` (crossings joined by butt joints); the cuts for the
        sheet are moved off the node lines ``avoid`` (a mitred seam there could not be
        trimmed) where they can be."""
        fs = self.fs
        k = len(quads)
        drop = np.zeros(k, dtype=bool) if drop is None else np.asarray(drop, dtype=bool)
        cuts = {0, k} | {int(j) % k if closed else int(j) for j in extra_cuts}
        n = _safe_normals(quads)
        with np.errstate(invalid="ignore"):
            ang = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n[:-1], n[1:]), -1, 1)))
        cuts.update((np.flatnonzero(ang > fs.split_angle) + 1).tolist())
        ext = panel_widths(quads)
        cuts.update(j for j in range(1, k) if not self._miter_ok(n[j - 1], n[j], ext[j - 1], ext[j]))
        for i in np.flatnonzero(drop).tolist():
            cuts.update((i, i + 1))
        if closed and k >= 2 and len(cuts) == 2:
            cuts.add(k // 2)
        cuts = sorted(cuts)
        out = []
        for lo, hi in zip(cuts[:-1], cuts[1:]):
            if drop[lo:hi].all():
                continue
            if fs.max_panels and hi - lo > fs.max_panels:
                nchunk = -(-(hi - lo) // fs.max_panels)
                bounds = np.linspace(lo, hi, nchunk + 1).round().astype(int)
                out.extend(zip(bounds[:-1].tolist(), bounds[1:].tolist()))
            else:
                out.append((lo, hi))
        if fs.max_part_length:
            la = np.linalg.norm(quads[:, 1] - quads[:, 0], axis=1)
            lb = np.linalg.norm(quads[:, 2] - quads[:, 3], axis=1)
            seg = np.maximum(la, lb)
            split = []
            for lo, hi in out:
                start, acc = lo, 0.0
                for i in range(lo, hi):
                    if acc + seg[i] > fs.max_part_length and i > start:
                        split.append((start, i))
                        start, acc = i, 0.0
                    acc += seg[i]
                split.append((start, hi))
            out = split
        if fs.fit_sheet is not None:
            fs._oversize = []
            out = [r for lo, hi in out for r in self._fit(quads, lo, hi, avoid)]
        return out

    def _fit(self, quads: np.ndarray, lo: int, hi: int, avoid=frozenset()) -> list[tuple[int, int]]:
        """Cut [lo, hi) into parts whose unrolled outline fits ``fit_sheet`` (any orientation):
        from its start, each part is the longest run that fits, ending at the last node line
        before that which is not in ``avoid`` (where there is one).

        Why the longest run and not halves: halving left 134 of 7a's 172 plates just over half
        a sheet long, and rows of such halves leave a strip of every sheet empty (44 sheets at
        best with the rows nester). Filled to the sheet's length,
        the parts pack to 38 sheets (80 %) and the short rests fill the gaps. A subrun of a run
        that fits also fits, so the longest run is found by bisection."""
        fs = self.fs
        out = []
        start = lo
        while start < hi:
            if self._fits(quads[start:hi]):
                out.append((start, hi))
                break
            if not self._fits(quads[start:start + 1]):
                fs._oversize.append(start)          # a single panel too large: layout reports it
                out.append((start, start + 1))
                start += 1
                continue
            good, bad = start + 1, hi               # [start, good) fits, [start, bad) does not
            while bad - good > 1:
                mid = (good + bad) // 2
                if self._fits(quads[start:mid]):
                    good = mid
                else:
                    bad = mid
            end = next((j for j in range(good, start, -1) if j not in avoid), good)
            out.append((start, end))
            start = end
        return out

    def _fits(self, quads: np.ndarray) -> bool:
        """Whether panels ``quads`` unrolled fit ``fit_sheet`` (remembered across rebuilds:
        :meth:`~torsal.fabrication.parts.FinSystem._cached`)."""
        fs = self.fs
        return fs._cached(self._fits_sheet, np.ascontiguousarray(quads))

    def _fits_sheet(self, quads: np.ndarray) -> bool:
        fs = self.fs
        try:
            outline = flat_outline(quads)
        except ValueError:          # overlaps itself when unrolled: too long anyway
            return False
        w, h = _oriented_size(outline)
        sw, sh = sorted(fs.fit_sheet, reverse=True)
        m = 2.0 * fs.fit_margin
        return max(w, h) <= sw - m and min(w, h) <= sh - m

    def _make_part(self, pid: PartId, quads, lo, hi, nodes, edges, closed,
                   drop: np.ndarray | None = None) -> Part:
        """Part of panels [lo, hi) of a strip, with mitred folds (also across part splits, up
        to a fold of MITER_LIMIT; square ends at sharper folds, next to dropped panels and at
        the strip ends)."""
        fs = self.fs
        q = quads[lo:hi].copy()
        n_all = _safe_normals(quads)
        k = len(quads)
        drop = np.zeros(k, dtype=bool) if drop is None else np.asarray(drop, dtype=bool)
        ext = panel_widths(quads)
        miters = np.empty((hi - lo + 1, 3))
        ends = ["end", "end"]
        for j in range(lo, hi + 1):
            left = j - 1 if j > 0 else (k - 1 if closed else None)
            right = j if j < k else (0 if closed else None)
            end = 0 if j == lo else (1 if j == hi else None)
            if end is not None and left is not None and right is not None:
                other = left if end == 0 else right
                if drop[other]:
                    ends[end] = "dropped"
                elif (_fold_deg(n_all[left], n_all[right]) > fs.split_angle or
                      not self._miter_ok(n_all[left], n_all[right], ext[left], ext[right])):
                    ends[end] = "fold"
                else:
                    ends[end] = "miter"
                if ends[end] != "miter":
                    left, right = (None, right) if end == 0 else (left, None)
            if left is None:
                m = n_all[right]
            elif right is None:
                m = n_all[left]
            else:
                m = _miter(n_all[left], n_all[right])
            miters[j - lo] = m
        return Part(id=pid, panels=q, nodes=np.asarray(nodes[lo:hi + 1]).copy(),
                    edges=np.asarray(edges[lo:hi]).copy(), miters=miters, span=(lo, hi),
                    color=FAMILY_COLORS.get(pid.family, FAMILY_COLORS[-1]), ends=tuple(ends))

    def _strip_parts(self, st: "_Strips", joinery: dict) -> list[list[Part]]:
        """Cut every strip into parts: at sharp folds, dropped panels, length and sheet limits,
        and at crossings where its plate is to be butted against the other family's."""
        fs = self.fs
        strip_no = {0: 0, 1: 0}
        part_of_strip: list[list[Part]] = []
        dropped, oversize = [], []
        present = st.passes | st.ends
        for si, (strip, q, drop) in enumerate(zip(st.fins, st.quads, st.drops)):
            fam = strip.family
            at = {int(v): j for j, v in enumerate(strip.vertices)}
            split_here = {at[x.node] for x in joinery.values()
                          if x.split == fam and x.node in at and 0 < at[x.node] < len(q) + strip.closed}
            # where the joint changed (an end of the other family could not be trimmed against
            # this plate), this plate is split and butted against the other family's instead
            split_here |= {at[v] for v, base in fs._base_at.items()
                           if base != fam and v in at and 0 < at[v] < len(q) + strip.closed}
            ranges = self._split_ranges(q, strip.closed, drop, extra_cuts=split_here,
                                        avoid={j for s_, j in fs._avoid_splits if s_ == si})
            # the final cut's splits for the sheets' yield (nesting.final_cut): node lines
            # where a part of the build without them is cut once more, its other cuts kept
            ranges = _cut_at(ranges, getattr(fs, "_yield_cuts", {}).get(si, ()))
            if fs.family_split == FamilySplit.FAMILY0_CONTINUOUS and fam == 1:
                # family 1 is cut at every node where a family-0 plate is
                cuts = sorted({0, len(q)} | {j for j in range(1, len(q))
                                             if present[0, strip.vertices[j]]} |
                              {x for r in ranges for x in r})
                ranges = [(lo, hi) for lo, hi in zip(cuts[:-1], cuts[1:]) if not drop[lo:hi].all()]
            sn = strip_no[fam]
            strip_no[fam] += 1
            prefix = str(PartId(fam, sn, 0))[:-4]
            dropped += [(prefix, int(strip.edges[i]), float(w))
                        for i, w in zip(np.flatnonzero(drop), panel_widths(q)[drop])
                        if i not in fs._extra.get(si, ())]
            parts = [self._make_part(PartId(fam, sn, i), q, lo, hi, strip.vertices, strip.edges, strip.closed,
                                     drop)
                     for i, (lo, hi) in enumerate(ranges)]
            over = set(fs._oversize) if fs.fit_sheet is not None else set()
            oversize += [p.name for p in parts if p.span[1] - p.span[0] == 1 and p.span[0] in over]
            part_of_strip.append(parts)
        fs.dropped_panels = dropped
        fs.oversize_panels = oversize
        self._warn_dropped()
        if oversize:
            warnings.warn(
                f"{len(oversize)} parts are ONE fin panel each and still larger than the "
                f"{fs.fit_sheet[0]:g} x {fs.fit_sheet[1]:g} {fs.unit} sheet: {oversize[:8]}"
                + (" ..." if len(oversize) > 8 else "") + "; a single panel cannot be split: use a "
                "smaller fin spacing (finer remesh) or a larger sheet; see FinSystem.oversize_panels",
                stacklevel=4)
        return part_of_strip
