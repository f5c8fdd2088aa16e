"""Parts from free strips of quads (``FinSystem.from_strips``, e.g. the developables of
``refine_developable``): cut like the structure's strips, without slots or joints to other
plates; splits at sharp folds are butted (the later part trimmed back), never mitred.
Lengths in the fin system's ``unit``.
"""
from __future__ import annotations

from typing import Iterable

import numpy as np

from ..model import Part, PartId, panel_widths
from .ends import EndJoiner
from .strips import StripCutter


class FreeStrips:
    """Cuts free strips into the parts of a fin system ``fs`` under construction and butts the
    splits at sharp folds; fills its ``parts``, ``dropped_panels`` and ``untrimmed_joints``."""

    def __init__(self, fs):
        self.fs = fs
        self.cut, self.ends = StripCutter(fs), EndJoiner(fs)

    def cut_strips(self, strips: Iterable, family: int) -> dict[int, np.ndarray]:
        """The parts of every strip (``(k, 4, 3)`` quads or ``FinStrip``, in ``model_unit``) of
        ``family``, split where a panel is dropped, at sharp folds and by the part limits.
        Returns ``{strip index: its quads in unit}``; ValueError if a strip is not (k, 4, 3)
        quads or there is none."""
        fs = self.fs
        quads_of: dict[int, np.ndarray] = {}
        for s, st in enumerate(strips):
            q = np.asarray(getattr(st, "quads", st), dtype=float) * fs.scale
            fam = int(family)
            if q.ndim != 3 or q.shape[1:] != (4, 3) or len(q) == 0:
                raise ValueError(f"strip {s}: expected (k, 4, 3) quads, got {q.shape}")
            nodes = np.full(len(q) + 1, -1)
            edges = np.full(len(q), -1)
            drop = self.cut._drop_mask(q)
            quads_of[s] = q
            prefix = str(PartId(fam, s, 0))[:-4]
            fs.dropped_panels += [(prefix, int(i), float(w))
                                  for i, w in zip(np.flatnonzero(drop), panel_widths(q)[drop])]
            for index, (lo, hi) in enumerate(self.cut._split_ranges(q, closed=False, drop=drop)):
                fs.parts.append(self.cut._make_part(PartId(fam, s, index), q, lo, hi, nodes,
                                                    edges, closed=False, drop=drop))
        if not fs.parts:
            raise ValueError("no strips given: nothing to fabricate")
        return quads_of

    def butt_folds(self, quads_of: dict[int, np.ndarray]) -> None:
        """Splits at sharp folds: the later part's start butt-trimmed against the previous
        part's square end (:meth:`~.butts.ButtTrimmer._fold_butt`), ``thickness/2`` off it."""
        fs = self.fs
        # splits at sharp folds: butt joints (the later part trimmed back), never mitred
        gap, h = 0.5 * fs.thickness, 0.5 * fs.thickness
        by_strip: dict[int, list[Part]] = {}
        for p in fs.parts:
            by_strip.setdefault(p.id.strip, []).append(p)
        for sidx, parts in by_strip.items():
            q = quads_of[sidx]
            for p in parts:
                if p.ends[0] == "fold":
                    trimmed = list(p.trimmed)
                    prev = self.ends._previous(parts, p, q)
                    trimmed[0] = self.ends.butts._fold_butt(p, prev, q, -1, gap, h)
                    p.trimmed = tuple(trimmed)
