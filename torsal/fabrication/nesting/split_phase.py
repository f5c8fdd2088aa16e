"""Sheets emptied by cuts: step A of :mod:`.split`, on the sheets of a search that has run.

Units: those of the outlines.
"""
from __future__ import annotations

from typing import Callable

from .pieces import CutCost, Pieces
from .search import _Search

__all__ = ["SplitPhase"]


class SplitPhase:
    """Step A of :mod:`.split` on the sheets of ``search`` (one that has run): victims emptied
    by drops, repacks and cuts of ``pieces`` in at most ``tries`` drops and repacks, each
    sheet emptied by cuts kept only where ``pays`` (those cuts, ``before`` and all made so
    far, against the sheets saved from ``saved_from``); :attr:`made` the cuts kept and
    :attr:`sheets` ``[(cuts, sheets after)]`` the sheets they emptied."""

    def __init__(self, search: _Search, pieces: Pieces, pays: Callable, tries: int, progress, *,
                 before: list, saved_from: int):
        self.search, self.pieces, self.pays, self.tries = search, pieces, pays, tries
        self.before, self.saved_from = list(before), saved_from
        self.progress = progress
        self.em = search.emptier
        self.made: list[CutCost] = []         # the cuts of the sheets emptied so far
        self.trying: list[CutCost] = []       # the cuts of the victim being tried
        self.sheets: list = []
        self.refused = 0
        self.start = (self.em.tries, self.em.drop.evaluations)

    def used(self) -> int:
        """Repacks and drops worked out (a drop answered before is not counted)."""
        return (self.em.tries - self.start[0]) + (self.em.drop.evaluations - self.start[1])

    def may_try(self) -> bool:
        return self.used() < self.tries

    def run(self) -> None:
        em = self.em
        floor = self.search.by_area
        saved_may_try, saved_floor = em.may_try, em.floor
        em.may_try = self.may_try
        aside: set = set()
        try:
            while len(em.sheets) > floor and self.may_try():
                victims = [s for s in em.sheets if id(s) not in aside]
                if not victims:
                    break
                victim = min(victims, key=lambda s: (em.filled(s), sorted(s)))
                snapshot = [(s, dict(s)) for s in em.sheets]
                self.trying = []
                ok = self._empty(victim)
                if ok and (not self.trying or self._pays(len(em.sheets) - 1)):
                    em.sheets.remove(victim)
                    em.emptied += 1
                    if self.trying:
                        self.made += self.trying
                        self.sheets.append((tuple(self.trying), len(em.sheets)))
                else:
                    for s, content in snapshot:       # put back as it was: no cut for nothing
                        s.clear()
                        s.update(content)
                    aside.add(id(victim))
                if self.progress is not None:
                    self.progress(em.emptied, max(0, len(em.sheets) - floor))
        finally:
            em.may_try, em.floor = saved_may_try, saved_floor

    def _pays(self, sheets: int) -> bool:
        """Whether every cut made so far (``before``, the cuts the phase started with, and
        those of the sheets emptied) and the victim's pays for the sheets then saved."""
        if self.pays(self.before + self.made + self.trying, self.saved_from - sheets):
            return True
        self.refused += 1
        return False

    def _empty(self, victim: dict) -> bool:
        em, area = self.em, self.em.area
        while victim:
            if not self.may_try():
                return False
            parts = sorted(victim, key=lambda n: (-area[n], n))
            first = parts[0]
            if em._drop(victim, first):
                continue
            hosts = sorted((s for s in em.sheets if s is not victim),
                           key=lambda s: (em.filled(s), sorted(s)))
            hosts = [s for s in hosts if em.host_fill * em.usable - em.filled(s)
                     >= area[first]][:em.hosts]
            if em._move(victim, parts, first, hosts):
                continue
            if not self._split(victim, first):
                return False
        return True

    def _split(self, victim: dict, name: str) -> bool:
        """Cut ``name`` (on ``victim``) where one of its pieces drops onto another sheet: that
        piece goes there, the other stays on the victim."""
        pc = self.pieces
        part, lo, hi = pc.whole(name)
        options = []
        for j in pc.positions_of(part, lo, hi):
            a, b = pc.get(part, lo, j), pc.get(part, j, hi)
            if a is None or b is None:
                continue
            options += [(a, b, j), (b, a, j)]
        area = self.em.area
        # the largest piece first: as much of the part as possible off the victim
        options.sort(key=lambda o: (-area[o[0]], o[0]))
        at = victim[name]
        for go, stay, j in options:
            if not self.may_try():
                return False
            del victim[name]
            victim[go] = victim[stay] = at         # a piece lies where it lay in the part
            if self.em._drop(victim, go):
                self.trying.append(pc.cost(part, j))
                return True
            del victim[go], victim[stay]
            victim[name] = at
        return False
