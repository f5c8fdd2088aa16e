"""Which cuts let the rows fill, in one dimension: step B of :mod:`.split`.

Units: those of the outlines.
"""
from __future__ import annotations

import numpy as np

from .pieces import Pieces, piece_name

__all__ = ["RowPlan"]


class RowPlan:
    """Which cuts let the rows fill, in one dimension (step B of :mod:`.split`): every
    part at least a fifth of the sheet's height wide is a length along a row, its *effective*
    length ``area / width + sep`` (its minimum rotated rectangle's width: parallelograms end to
    end head to tail take that), the rows as long as the usable sheet. The parts are put into
    rows best fit decreasing; then the emptiest row is emptied into the others' ends, a part
    that fits no end cut at one of its node lines so that its larger piece that fits one goes
    there (the other is tried in its turn), as :class:`~.split_phase.SplitPhase` does on the
    sheets. Rows that cannot be emptied are put back as they were. :attr:`states`
    ``[(rows, cuts, names)]``: after each row emptied, how many rows are left, the cuts
    ``[(part, node line)]`` taken so far and the rows' parts and pieces by name."""

    def __init__(self, pieces: Pieces, names, frame):
        self.pieces, self.frame = pieces, frame
        self.cap = frame.length + frame.sep
        self._eff: dict = {}
        items = [n for n in sorted(names) if self.eff(n) is not None]
        rows: list[list] = []
        fills: list[float] = []
        for n in sorted(items, key=lambda n: (-self.eff(n), n)):
            left = [(self.cap - f - self.eff(n), i) for i, f in enumerate(fills)
                    if self.cap - f - self.eff(n) >= -1e-9]
            if left:
                i = min(left)[1]
                rows[i].append(n)
                fills[i] += self.eff(n)
            else:
                rows.append([n])
                fills.append(self.eff(n))
        self.rows = rows
        self.states = [(len(rows), [], self._names(rows))]

    def eff(self, name: str, key: tuple | None = None) -> float | None:
        """The effective length of a part or piece (None: too narrow to take a row)."""
        key = key or self.pieces.whole(name)
        if key not in self._eff:
            poly = self.pieces.polygon(*key)
            e = None
            if poly is not None:
                rect = np.asarray(poly.minimum_rotated_rectangle.exterior.coords)[:3]
                a, b = np.linalg.norm(rect[1] - rect[0]), np.linalg.norm(rect[2] - rect[1])
                w = min(a, b)
                if w >= 0.2 * self.frame.height:
                    e = poly.area / w + self.frame.sep
            self._eff[key] = e
        return self._eff[key]

    def fill(self, row) -> float:
        return sum(self._eff[k] for k in row)

    def run(self, floor_rows: int, budget: int = 20000) -> None:
        """Empty rows down to ``floor_rows`` (see the class docstring), in at most ``budget``
        parts placed."""
        rows = [[self.pieces.whole(n) for n in r] for r in self.rows]
        cuts: list = []
        aside: set = set()
        self._work = 0
        while len(rows) > floor_rows and self._work < budget:
            victims = [r for r in rows if id(r) not in aside]
            if not victims:
                break
            victim = min(victims, key=lambda r: (self.fill(r), sorted(r)))
            snapshot = [(r, list(r)) for r in rows]
            made = self._empty(victim, [r for r in rows if r is not victim])
            if made is not None:
                rows.remove(victim)
                cuts += made
                self.states.append((len(rows), list(cuts), self._names(rows)))
            else:
                for r, content in snapshot:
                    r[:] = content
                aside.add(id(victim))

    def _empty(self, victim: list, others: list) -> list | None:
        """Put the parts of ``victim`` into the ends of ``others``, cutting those that fit no
        end; the cuts ``[(part, node line)]`` made, or None where a part finds no end."""
        made: list = []
        queue = sorted(victim, key=lambda k: (-self._eff[k], k))
        victim.clear()
        while queue:
            self._work += 1
            k = queue.pop(0)
            row = self._best_row(others, self._eff[k])
            if row is not None:
                row.append(k)
                continue
            best = self._best_cut(others, k)
            if best is None:
                return None
            j, go, stay, r = best
            r.append(go)
            made.append((k[0], j))
            queue.append(stay)
            queue.sort(key=lambda k: (-self._eff[k], k))
        return made

    def _best_cut(self, rows: list, k: tuple):
        """``(node line, piece that goes, piece that stays, its row)``: the cut of ``k``
        ``(part, lo, hi)`` whose larger piece fits a row of ``rows``, the longest such piece
        first (then the tightest fit); None where none fits."""
        best = None
        part, lo, hi = k
        for j in self.pieces.positions_of(part, lo, hi):
            for go, stay in (((part, lo, j), (part, j, hi)), ((part, j, hi), (part, lo, j))):
                e, e2 = self.eff(None, go), self.eff(None, stay)
                if e is None or e2 is None:
                    continue
                r = self._best_row(rows, e)
                if r is not None:
                    cand = (-e, self.cap - self.fill(r) - e, j, go, stay, r)
                    if best is None or cand[:3] < best[:3]:
                        best = cand
        return None if best is None else best[2:]

    def _names(self, rows) -> list[list[str]]:
        """The rows' parts and pieces by name, each row's longest first."""
        out = []
        for r in rows:
            keys = sorted((self.pieces.whole(k) if isinstance(k, str) else k for k in r),
                          key=lambda k: (-self._eff[k], k))
            out.append([k[0] if (k[1], k[2]) == (0, len(self.pieces.unrolled[k[0]].panels))
                        else piece_name(*k) for k in keys])
        return out

    def _best_row(self, rows, e: float):
        best, left = None, None
        for r in rows:
            room = self.cap - self.fill(r) - e
            if room >= -1e-9 and (left is None or room < left - 1e-9):
                best, left = r, room
        return best
