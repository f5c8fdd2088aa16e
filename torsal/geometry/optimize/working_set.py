"""The working set of inequality constraints: pass 2 of the IPOPT strategy (:mod:`.ipopt`)."""
from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from .nlp import _bound_violation

if TYPE_CHECKING:
    from .nlp import Built

# few elements need barrier terms; otherwise (e.g. a 60 degree torsal angle on a shading
# canopy, where half of them are violated) the working set would grow round after round
_WORKING_SET_MAX_SHARE = 0.05


def _near_bounds(g: np.ndarray, b: "Built", share: float = 0.1) -> np.ndarray:
    """Inequalities within ``share`` of their constraint's median slack of a bound, or violated."""
    slack = np.minimum(g - b.lbg, b.ubg - g)
    out = np.zeros(g.size, dtype=bool)
    for rows in b.g_slices:
        sl = slack[rows]
        fin = np.isfinite(sl)
        scale = float(np.median(np.abs(sl[fin]))) if fin.any() else 0.0
        out[rows] = ~fin | (sl <= share * scale)
    return out


def _working_ids(b: "Built", mask: np.ndarray) -> dict:
    """Element ids of the imposed inequality constraints, by constraint name (each once: the
    split torsal-angle form has two rows per face)."""
    return {t.name: np.unique(t.elements[mask[rows]]) for t, rows in zip(b.cons, b.g_slices)
            if t.lower < t.upper}


class PassOutcome(NamedTuple):
    """The answer of the pass that ended a solve.

    ``constraints_active``: False when pass 1 (no inequalities) met them all, True when
    inequalities were imposed, None without inequalities. ``working``: the working-set mask
    over ``g`` when pass 2 answered, else None. ``handed_over``: pass 1 missed an inequality
    and the solve asked to stop there (``IpoptPasses.solve(handover=True)``): ``x`` is pass
    1's answer, for the augmented Lagrangian to continue from.
    """

    x: np.ndarray
    lam_g: np.ndarray | None
    iterations: int
    status: str
    converged: bool
    constraints_active: bool | None
    working: np.ndarray | None
    handed_over: bool = False


def working_set_pass(strategy, s_warm, s_cold, b: "Built", x, p, ws: np.ndarray, lam_g, budget: int,
                     feas_tol: float) -> "PassOutcome":
    """Pass 2: IPOPT with the inequalities outside ``ws`` unbounded, adding those the answer
    violates (and their near-active companions) until it violates none.

    An inequality left out and met with slack has a zero multiplier, so the answer is a
    KKT point of the whole problem; IPOPT meanwhile carries barrier terms (and their
    indefinite curvature) only for the few elements that matter.
    """
    iters, status, ok = 0, "", False
    ws = ws.copy()
    while budget - iters > 0:
        args = dict(x0=x, p=p, lbg=np.where(ws, b.lbg, -np.inf), ubg=np.where(ws, b.ubg, np.inf))
        if lam_g is not None:
            args.update(lam_g0=np.where(ws, lam_g, 0.0), lam_x0=np.zeros(b.n_var))
        r = strategy.call(s_warm if lam_g is not None else s_cold, b, args, budget - iters)
        x, lam_g, status, ok = r.x, r.lam_g, r.status, r.converged
        iters += r.iterations
        if not ok:
            break
        g = np.asarray(b.evaluate(x, p)[2]).ravel()
        new = (_bound_violation(g, b.lbg, b.ubg) > feas_tol) & ~ws
        if not new.any():
            break
        ws |= _near_bounds(g, b) | new
        lam_g, ok = None, False          # cold: the new elements have no multipliers yet
    return PassOutcome(x, lam_g, iters, status, ok, True, ws)
