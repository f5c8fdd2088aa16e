"""The paper's baseline: L-BFGS on the penalized energy with re-normalization (Wang et al. 2013, 4.1)."""
from __future__ import annotations

import math
import time
from typing import NamedTuple

import numpy as np

from .cache import NlpKind
from .history import SolveMonitor
from .nlp import Built, _renormalize
from .strategy import Run, SolveContext, Start

#: L-BFGS iterations when ``solve(max_iter=...)`` is not given
LBFGS_MAX_ITER = 1000


class LbfgsRun(NamedTuple):
    """The answer of :func:`lbfgs` and how it ended."""

    x: np.ndarray
    status: str
    converged: bool
    iterations: int


def lbfgs(b: Built, x0: np.ndarray, p: np.ndarray, monitor: SolveMonitor, *, max_iter: int, tol: float,
          penalty: float) -> LbfgsRun:
    """scipy L-BFGS-B in rounds of 10 iterations, directions re-normalized after each round.

    ``b`` is the ``"penalty"`` NLP (constraints as energies ``mean(min(c, 0)^2)``, weighted
    ``penalty``); every iterate is reported to ``monitor`` (measured history, best feasible
    iterate, time limit, the user's callback). Stops when a round decreases the objective by
    less than ``tol`` times the starting objective.
    """
    from scipy.optimize import minimize

    pen = np.array(p)
    for t, off in zip(b.terms, b.p_offsets):
        if t.name.startswith("penalty:"):
            pen[off] = penalty
    fg = b.grad_f
    x = _renormalize(np.asarray(x0, float))
    f_prev, f_start = math.inf, None
    status, ok = "maximum iterations", False
    count = {"it": 0}

    def fun(z):
        f, g = fg(z, pen)
        return float(f), np.asarray(g).ravel()

    def cb(z):
        count["it"] += 1
        if monitor.iterate(_renormalize(z).reshape(-1, 3), fun(z)[0]):
            raise StopIteration

    while count["it"] < max_iter:
        try:
            r = minimize(fun, x, jac=True, method="L-BFGS-B", callback=cb,
                         options={"maxiter": min(10, max_iter - count["it"]), "gtol": 1e-12, "ftol": 1e-15})
            x = _renormalize(r.x)
        except StopIteration:
            status = "time limit" if monitor.timed_out else "stopped by callback"
            break
        f = fun(x)[0]
        if not np.isfinite(f):
            status = "objective is NaN"
            break
        f_start = f if f_start is None else f_start
        if abs(f_prev - f) <= tol * max(abs(f_start), 1e-300) or r.nit == 0:
            status, ok = "converged (relative decrease per round below tol)", True
            break
        f_prev = f
    return LbfgsRun(x, status, ok, count["it"])


class LbfgsStrategy:
    """The strategy ``solver="lbfgs"``: :func:`lbfgs` on the penalty NLP."""

    kind = NlpKind.LBFGS

    def solve(self, ctx: SolveContext, start: Start) -> Run:
        t0 = time.perf_counter()
        opts = ctx.options
        r = lbfgs(start.b, start.x0, start.p, ctx.monitor, max_iter=opts.max_iter or LBFGS_MAX_ITER, tol=opts.tol,
                  penalty=opts.penalty)
        s = time.perf_counter() - t0
        return Run(x=r.x, lam_g=None, iterations=r.iterations, status=r.status, ok=r.converged, active=None,
                   working=None, frames=start.frames, build_seconds=0.0, solve_seconds=s, b=start.b,
                   solver="lbfgs", timings={"lbfgs": s})
