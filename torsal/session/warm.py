"""What a live session keeps warm between edits: stage results in memory
(:class:`WarmCache`) and the built congruence problem with its last optimum
(:class:`WarmProblem`)."""
from __future__ import annotations

import threading
from collections import OrderedDict

import numpy as np

from ..geometry.optimize import CongruenceProblem
from ..pipeline.cache import MISSING, StageCache
from ..pipeline.design_file import DesignSpec
from ..pipeline.problem import congruence_problem

__all__ = ["WarmCache", "WarmProblem"]


class WarmCache(StageCache):
    """A :class:`~torsal.pipeline.cache.StageCache` with the last results of each stage kept
    in memory too: a session reads an unchanged stage's result without unpickling it, and
    an edit undone finds its results again. Thread-safe (the preview and the background
    build share it).

    Parameters
    ----------
    folder : path
        The stage cache on disk (``OUT/.torsal-cache``, as ``torsal design`` keeps it).
    keep : int
        Results kept in memory per stage (the most recent).

    Examples
    --------
    >>> import tempfile
    >>> c = WarmCache(tempfile.mkdtemp())
    >>> c.store("remesh", "k1", {"delta_pl": 0.1})
    >>> c.load("remesh", "k1")["delta_pl"], c.load("remesh", "k2") is MISSING
    (0.1, True)
    """

    def __init__(self, folder, *, keep: int = 4):
        super().__init__(folder, enabled=True, prune=True)
        self.keep = int(keep)
        self._memory: dict[str, OrderedDict] = {}
        self._lock = threading.Lock()

    def _remember(self, name: str, key: str, value) -> None:
        entries = self._memory.setdefault(name, OrderedDict())
        entries[key] = value
        entries.move_to_end(key)
        while len(entries) > self.keep:
            entries.popitem(last=False)

    def load(self, name: str, key: str):
        with self._lock:
            entries = self._memory.get(name, {})
            if key in entries:
                return entries[key]
        value = super().load(name, key)
        if value is not MISSING:
            with self._lock:
                self._remember(name, key, value)
        return value

    def has(self, name: str, key: str) -> bool:
        with self._lock:
            if key in self._memory.get(name, {}):
                return True
        return super().has(name, key)

    def store(self, name: str, key: str, value) -> None:
        with self._lock:
            self._remember(name, key, value)
        super().store(name, key, value)


def _structure(p: CongruenceProblem) -> dict:
    return {name: kind for name, (kind, _, _) in p.terms.items()}


class WarmProblem:
    """The congruence problem a session keeps built (its compiled kernels and NLPs) and
    the last good optimum (directions, multipliers, penalties) it re-solves from.

    :meth:`make` is the congruence stage's ``make_problem``
    (:func:`~torsal.pipeline.stages.run_congruence`): the design's terms are registered on the
    kept problem again when mesh A and the terms' names are unchanged (a weight, a light
    direction or a bound is then a parameter of the built NLP: no rebuild), else a new
    problem is made; either way the solve starts from the last good optimum when its size
    fits. :meth:`commit` keeps the problem and its optimum after a good solve; after a
    rejected edit nothing is committed, so the next solve starts from the last good design.

    Examples
    --------
    >>> warm = WarmProblem()
    >>> warm.optimum is None
    True
    """

    def __init__(self):
        self.problem: CongruenceProblem | None = None
        self.optimum = None
        self._mesh: tuple[np.ndarray, np.ndarray] | None = None
        self._pending: tuple | None = None
        self.reused = 0          # solves on the kept problem (no rebuild of its NLP)

    def _fits(self, v: np.ndarray, f: np.ndarray, spec: DesignSpec, fresh: CongruenceProblem) -> bool:
        p = self.problem
        return (p is not None and spec.substructure is None and p.jit == fresh.jit
                and self._mesh is not None and self._mesh[0].shape == v.shape
                and np.array_equal(self._mesh[0], v) and np.array_equal(self._mesh[1], f)
                and _structure(p) == _structure(fresh))

    def make(self, spec: DesignSpec, v: np.ndarray, f: np.ndarray, sun: np.ndarray,
             w_sun: np.ndarray) -> CongruenceProblem:
        """The problem of ``spec`` on mesh A (``v`` (n, 3), ``f`` (m, 3)) with sun
        directions (k, 3) and weights (k,), warm: see the class notes."""
        fresh = congruence_problem(spec, v, f, sun, w_sun)
        if self._fits(v, f, spec, fresh):
            chosen = congruence_problem(spec, v, f, sun, w_sun, into=self.problem)
            self.reused += 1
        else:
            chosen = fresh
        if self.optimum is not None and np.size(self.optimum.directions) == chosen.n_var:
            chosen.warm_start_from(self.optimum)
        self._pending = (chosen, (np.array(v), np.array(f)))
        return chosen

    def commit(self, optimum) -> None:
        """A solve succeeded: keep its problem (if :meth:`make` made one) and ``optimum``."""
        if self._pending is not None:
            self.problem, self._mesh = self._pending
        self._pending = None
        if optimum is not None:
            self.optimum = optimum

    def rollback(self) -> None:
        """An edit was rejected: the next solve starts from the last committed optimum."""
        self._pending = None
