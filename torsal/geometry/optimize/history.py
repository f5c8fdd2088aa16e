"""Per-solve bookkeeping: iteration counts and caps, the measured history, the best feasible iterate."""
from __future__ import annotations

import math
import time
from typing import Callable, NamedTuple

import numpy as np

from .measure import ROUNDING
from .result import IterationRecord


class BestIterate(NamedTuple):
    """The lowest-objective iterate that was feasible as measured."""

    objective: float
    directions: np.ndarray     # (N, 3) stacked directions of all aligned congruences
    iteration: int


class SolveMonitor:
    """State of one :meth:`~torsal.geometry.optimize.CongruenceProblem.solve` call.

    Every solver iteration (IPOPT's callback, L-BFGS's) goes through :meth:`iterate`, which
    measures the constraints on the iterate (``measure(e) -> (worst / tolerance)``), records
    an :class:`IterationRecord`, keeps the best feasible iterate, enforces the iteration cap
    of the current pass and the wall-time limit, and forwards to the user's callback.
    """

    def __init__(self, measure: Callable[[np.ndarray], float], callback: Callable | None = None,
                 max_seconds: float | None = None, t0: float | None = None):
        self.measure = measure
        self.callback = callback
        self.max_seconds = max_seconds
        self.t0 = time.perf_counter() if t0 is None else t0     # the solve() call's start
        self.cpu0 = time.process_time()
        self.iteration = 0
        self.phase_iteration = 0
        self.cap: int | None = None
        self.history: list[IterationRecord] = []
        self.best: BestIterate | None = None
        self.timed_out = False
        self.stopped_by_user = False
        self.last_feasible = False      # the last iterate held every constraint as measured

    def start_pass(self, cap: int | None) -> None:
        """A new solver run with at most ``cap`` iterations (None: the solver's own limit)."""
        self.phase_iteration, self.cap = 0, cap

    @property
    def capped(self) -> bool:
        return self.cap is not None and self.phase_iteration - 1 >= self.cap

    def iterate(self, e: np.ndarray, objective: float, infeasibility: float = math.nan) -> bool:
        """Record one iterate (directions ``e``); True asks the solver to stop."""
        self.iteration += 1
        self.phase_iteration += 1
        if self.capped:
            self.last_feasible = False
            return True
        worst = self.measure(e) if np.isfinite(e).all() else math.inf
        seconds = time.perf_counter() - self.t0
        feasible = bool(worst <= 1.0 + ROUNDING)   # as Measurement.holds
        self.last_feasible = feasible
        self.history.append(IterationRecord(self.iteration, seconds, float(objective), float(worst), feasible,
                                            time.process_time() - self.cpu0))
        if feasible and np.isfinite(objective) and (self.best is None or objective < self.best.objective):
            self.best = BestIterate(float(objective), np.array(e, dtype=float), self.iteration)
        if self.max_seconds is not None and seconds > self.max_seconds:
            self.timed_out = True
            return True
        if self.callback is not None and self.callback({"iteration": self.iteration, "objective": float(objective),
                                                        "infeasibility": infeasibility,
                                                        "measured_violation": float(worst)}):
            self.stopped_by_user = True
            return True
        return False
