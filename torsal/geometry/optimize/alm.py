"""The augmented Lagrangian with projected-Newton inner steps (Wang et al. 2013, 4.1, eq. (9)).

The paper solves eq. (9) with its hyperbolicity and angle constraints by an augmented
Lagrangian. This is that method for the same casadi NLP (:class:`~torsal.geometry.optimize.nlp.Built`
in tangent mode, every constraint row an inequality or equality ``l <= c(x) <= u``):

Outer iterations (Powell-Hestenes-Rockafellar, the safeguarded form of Birgin and
Martinez, *Practical Augmented Lagrangian Methods for Constrained Optimization*, 2014,
Algorithm 4.1, with one penalty per row as in Conn, Gould and Toint's LANCELOT)::

    L_A(x) = F(x) + sum_j rho_j / 2 dist(c_j(x) + lam_j / rho_j, [l_j, u_j])^2 - lam_j^2 / (2 rho_j)

with ``F = |V| f`` (the energies are means: this makes them sums, as IPOPT's objective
scaling does) and each constraint term's rows scaled by one factor, the inverse median of
their gradient norms at the start. After each inner minimization ``lam <- mu =
rho (t - P(t))``, ``t = c + lam / rho`` (safeguarded to ``|lam| <= LAM_MAX``); a row's
penalty grows by ``GAMMA`` only when its complementarity measure ``V_j = c_j - P(c_j +
lam_j / rho_j)`` did not fall below ``TAU`` times its last value (and is not already within
the tolerance): rows that converge keep their penalty, so the penalties of the few hard
rows grow without making every other row stiff. The inner tolerance tightens by ``0.1``
per outer iteration down to the final one.

Inner iterations: Newton steps on ``L_A`` in the gnomonic chart, re-centred at every
iterate (a retraction on the unit spheres: each step starts at ``z = 0``). The Newton
matrix is one symmetric positive definite matrix::

    K = sum_e P(H_e) + sum_j P(mu_j H_cj) + P(chart) + rho J_A^T J_A + delta I

with every energy element's and constraint element's Hessian projected to positive
semidefinite (:mod:`.projected`), ``J_A`` the rows whose penalty is active (the
Gauss-Newton part of the penalty), and a small adaptive ``delta`` (Levenberg-Marquardt:
divided by 10 after a full step, times 10 after a short one). ``K``'s pattern is the
union over all rows, fixed for the NLP, so its ordering and symbolic factorization are
computed once (:class:`~torsal.geometry.optimize.factor.SparseCholesky`), also across
re-solves. A backtracking Armijo line search on ``L_A`` takes the step.

Stopping is on the geometry: a solve has converged when every constraint holds as
measured on the congruence (torsal angles in degrees, ``c_hyp / delta^2``, see
:mod:`.measure`), the inner gradient is below the final tolerance and every row's
complementarity measure is below ``VTOL``. Limits are counts (Newton steps), never time,
so a solve's answer does not depend on the machine's load.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, NamedTuple

import casadi as ca
import numpy as np
import scipy.sparse as sp

from .factor import NotPositiveDefinite, SparseCholesky
from .history import SolveMonitor
from .nlp import Built, _from_tangent, tangent_frames

#: penalty growth factor of a row whose complementarity did not decrease enough
GAMMA = 10.0
#: a row's complementarity must fall below this share of its last value to keep its penalty
TAU = 0.5
#: safeguard of the multiplier estimates (scaled units)
LAM_MAX = 1e8
#: largest penalty (scaled units)
RHO_MAX = 1e10
#: first penalty, relative to the energies' curvature per variable
RHO_START = 10.0
#: complementarity / violation tolerance of the scaled rows
VTOL = 1e-6
#: first inner tolerance (gradient of L_A, inf-norm, scaled units)
EPS_START = 1e-1
#: Newton steps per inner minimization
INNER_MAX = 40
#: largest turn of one line in one Newton step (gnomonic coordinate, ~ radians)
MAX_TURN = 0.5
_DEBUG = bool(__import__("os").environ.get("TORSAL_ALM_DEBUG"))

#: Armijo's sufficient decrease
ARMIJO = 1e-4


@dataclass
class AlmState:
    """Where a warm re-solve starts: the answer's directions, multipliers, penalties and row
    scales (the scales stay fixed so that multipliers and penalties keep their meaning)."""

    e: np.ndarray             # (N, 3) unit directions
    lam: np.ndarray           # (n_g,) multipliers of the scaled rows (PHR sign: mu)
    rho: np.ndarray           # (n_g,) penalties of the scaled rows
    scale: np.ndarray         # (n_g,) row scales
    delta: float = 1e-8       # the Levenberg-Marquardt shift (relative)


class AlmRun(NamedTuple):
    """The answer of :func:`alm` and how it ended."""

    e: np.ndarray             # (N, 3) directions
    lam_g: np.ndarray         # multipliers in IPOPT's convention (grad f + J^T lam_g = 0)
    iterations: int           # Newton steps
    outer: int                # outer iterations (multiplier updates)
    factorizations: int
    status: str
    converged: bool
    state: AlmState
    counts: dict              # line-search trials, shifted retries, the backend


class _Numeric:
    """A casadi Function evaluated into preallocated numpy arrays (no DM conversions)."""

    def __init__(self, fn: ca.Function):
        self.fn = fn
        self.buf, self.call = fn.buffer()
        self.out = [np.zeros(fn.nnz_out(i)) for i in range(fn.n_out())]
        for i, r in enumerate(self.out):
            self.buf.set_res(i, memoryview(r))

    def __call__(self, *args) -> list[np.ndarray]:
        keep = [np.ascontiguousarray(a, dtype=float) for a in args]
        for i, a in enumerate(keep):
            self.buf.set_arg(i, memoryview(a))
        self.call()
        return [r.copy() for r in self.out]


@dataclass
class NewtonSystem:
    """The fixed pattern of ``K`` (upper triangle) and where each piece's values go.

    Pieces: the projected Lagrangian Hessian's nonzeros, every row's ``J_j^T J_j`` (upper
    triangle of the outer product of its nonzeros), the diagonal.
    """

    n: int
    hess_pos: np.ndarray      # position in K of each Hessian nonzero
    jac_rows: np.ndarray      # (nnz_J,) row of each Jacobian nonzero
    jac_cols: np.ndarray
    pair_a: np.ndarray        # pairs of Jacobian nonzeros of one row (a, b), col_a <= col_b
    pair_b: np.ndarray
    pair_pos: np.ndarray      # their position in K
    diag_pos: np.ndarray      # (n,)
    chol: SparseCholesky
    counts: dict = field(default_factory=lambda: {"factorizations": 0})

    @classmethod
    def of(cls, b: Built, backend: str | None = None) -> "NewtonSystem":
        n = b.n_var
        hs = b.hess_lag.sparsity
        h_col = np.repeat(np.arange(n), np.diff(np.asarray(hs.colind())))
        h_row = np.asarray(hs.row(), dtype=np.int64)
        js = b.jac_g.sparsity_out(1)
        j_col = np.repeat(np.arange(js.size2()), np.diff(np.asarray(js.colind())))
        j_row = np.asarray(js.row(), dtype=np.int64)
        # pairs of nonzeros in the same row: sort the nonzeros by row
        order = np.lexsort((j_col, j_row))
        rows_sorted = j_row[order]
        starts = np.searchsorted(rows_sorted, np.arange(b.n_g + 1))
        pa, pb = [], []
        counts = np.diff(starts)
        for k in np.unique(counts):
            if k == 0:
                continue
            rs = np.flatnonzero(counts == k)
            iu, ju = np.triu_indices(k)
            base = starts[rs][:, None]
            pa.append(order[(base + iu).ravel()])
            pb.append(order[(base + ju).ravel()])
        pa = np.concatenate(pa) if pa else np.zeros(0, np.int64)
        pb = np.concatenate(pb) if pb else np.zeros(0, np.int64)
        ca_, cb_ = j_col[pa], j_col[pb]
        p_row, p_col = np.minimum(ca_, cb_), np.maximum(ca_, cb_)
        d = np.arange(n)
        keys = np.concatenate([h_col * n + h_row, p_col * n + p_row, d * n + d])
        ukey, pos = np.unique(keys, return_inverse=True)
        pos = pos.ravel()
        col, row = ukey // n, ukey % n
        pattern = sp.csc_matrix((np.ones(ukey.size), row, np.searchsorted(col, np.arange(n + 1))), shape=(n, n))
        nh, npair = h_row.size, pa.size
        return cls(n, pos[:nh], j_row, j_col, pa, pb, pos[nh:nh + npair], pos[nh + npair:],
                   SparseCholesky(pattern, backend))

    def values(self, hess: np.ndarray, jac: np.ndarray, w_rows: np.ndarray, shift: float) -> np.ndarray:
        """``K``'s values: ``hess + J^T diag(w_rows) J + shift I`` (``jac`` the Jacobian's nonzeros)."""
        k = np.bincount(self.hess_pos, weights=hess, minlength=self.chol.nnz)
        if self.pair_a.size:
            w = w_rows[self.jac_rows[self.pair_a]]
            sel = w > 0
            k += np.bincount(self.pair_pos[sel], weights=w[sel] * jac[self.pair_a[sel]] * jac[self.pair_b[sel]],
                             minlength=self.chol.nnz)
        k[self.diag_pos] += shift
        return k

    def jt(self, jac: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``J^T v``."""
        return np.bincount(self.jac_cols, weights=jac * v[self.jac_rows], minlength=self.n)


class _Merit(NamedTuple):
    value: float              # L_A
    mu: np.ndarray            # (n_g,) multiplier estimates rho (t - P(t))
    active: np.ndarray        # (n_g,) bool: t outside [l, u]


def _phr(c: np.ndarray, lam: np.ndarray, rho: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> _Merit:
    """The PHR terms of scaled rows ``c`` with bounds ``[lo, hi]`` (see the module docstring)."""
    t = c + lam / rho
    pt = np.clip(t, lo, hi)
    r = t - pt
    return _Merit(float(np.sum(0.5 * rho * r * r - 0.5 * lam * lam / rho)), rho * r, r != 0.0)


class AugmentedLagrangian:
    """One augmented-Lagrangian solve of a tangent-mode NLP ``b`` (see the module docstring).

    ``p0``: the NLP's parameters (frames are replaced at every iterate); ``monitor`` gets
    every Newton iterate (measured history, best feasible iterate, the user's callback, the
    safety-net time limit); ``feasible(e)`` says whether every constraint holds as measured.
    """

    def __init__(self, b: Built, p0: np.ndarray, monitor: SolveMonitor, feasible: Callable[[np.ndarray], bool],
                 *, max_steps: int, tol: float, backend: str | None = None, projection: str = "clamp"):
        if b.mode != "tangent" or b.n_lift or b.n_slack:
            raise ValueError("the augmented Lagrangian needs the tangent NLP without lifted variables or slacks")
        self.b, self.monitor, self.feasible = b, monitor, feasible
        self.p = np.array(p0, dtype=float)
        self.max_steps, self.tol = int(max_steps), float(tol)
        self.sF = float(max(b.n_vertices, 1))
        if not hasattr(b, "alm_cache"):
            b.alm_cache = {}
        key = ("system", backend)
        if key not in b.alm_cache:
            b.alm_cache[key] = (NewtonSystem.of(b, backend), _Numeric(b.grad_f), _Numeric(b.jac_g),
                                _Numeric(b._evaluate))
        self.sys, self._grad, self._jac, self._eval = b.alm_cache[key]
        b.hess_lag.mode = projection
        b.hess_lag.project = True
        self.lo, self.hi = b.lbg, b.ubg
        self.counts = {"factorizations": 0, "shifted": 0, "trials": 0, "backend": self.sys.chol.backend}

    # ------------------------------------------------------------------ evaluations
    def _point(self, e: np.ndarray):
        """Re-centre the chart at ``e``: the frames, and F, grad F, c, J at ``z = 0``."""
        frames = tangent_frames(e)
        self.p[:self.b.n_frames] = frames.ravel()
        x = np.zeros(self.b.n_var)
        f, grad = self._grad(x, self.p)
        g, jac = self._jac(x, self.p)
        return frames, float(f[0]) * self.sF, grad * self.sF, g, jac

    def _values(self, z: np.ndarray) -> tuple[float, np.ndarray]:
        """``(F, c)`` at chart coordinates ``z`` (frames of the current iterate)."""
        _, f, g = self._eval(z, self.p)
        return float(f[0]) * self.sF, g

    def _hessian(self, mu_unscaled: np.ndarray) -> np.ndarray:
        x = np.zeros(self.b.n_var)
        return self.b.hess_lag.nonzeros([x, self.p, np.array([self.sF]), mu_unscaled])

    # ------------------------------------------------------------------ the solve
    def solve(self, e0: np.ndarray, warm: AlmState | None) -> AlmRun:
        b, sys = self.b, self.sys
        e = np.asarray(e0, dtype=float).reshape(-1, 3)
        frames, F, grad, g, jac = self._point(e)
        if warm is not None and warm.lam.size == b.n_g:
            s, lam, rho, rel = warm.scale, warm.lam.copy(), warm.rho.copy(), warm.delta
        else:
            s = _row_scales(b, jac, sys)
            lam = np.zeros(b.n_g)
            # rows scaled to unit gradients: a penalty curvature RHO_START times the energies'
            # typical curvature per variable (median of the projected Hessian's diagonal)
            h0 = sys.values(self._hessian(np.zeros(b.n_g)), jac, np.zeros(b.n_g), 0.0)[sys.diag_pos]
            r0 = RHO_START * max(float(np.median(h0)), 1e-6)
            rho, rel = np.full(b.n_g, r0), 1e-8
        lo, hi = s * self.lo, s * self.hi
        eps = EPS_START if warm is None else max(self.tol, 1e-3)
        v_prev = np.full(b.n_g, np.inf)
        steps = outer = 0
        status, converged = "", False
        self.monitor.start_pass(None)
        while True:
            # ---------------- inner minimization of L_A(., lam, rho) to eps
            inner = 0
            while True:
                m = _phr(s * g, lam, rho, lo, hi)
                LA = F + m.value
                gl = grad + sys.jt(jac, s * m.mu)
                gnorm = float(np.abs(gl).max(initial=0.0))
                if gnorm <= eps or inner >= INNER_MAX or steps >= self.max_steps:
                    break
                hess = self._hessian(s * m.mu)
                w = np.where(m.active, rho * s * s, 0.0)
                base = sys.values(hess, jac, w, 0.0)
                scale = max(1.0, float(np.mean(base[sys.diag_pos])))
                d = None
                for _ in range(8):       # one factorization, unless rounding needs a shift
                    k = base.copy()
                    k[sys.diag_pos] += rel * scale
                    try:
                        sys.chol.factor(k)
                        self.counts["factorizations"] += 1
                        d = -sys.chol.solve(gl)
                        break
                    except NotPositiveDefinite:
                        self.counts["shifted"] += 1
                        rel = max(rel * 100.0, 1e-8)
                if d is None or not np.all(np.isfinite(d)):
                    status = "the Newton matrix could not be factored"
                    break
                turn = float(np.sqrt((d.reshape(-1, 2) ** 2).sum(1)).max(initial=0.0))
                if turn > MAX_TURN:
                    d *= MAX_TURN / turn
                slope = float(gl @ d)
                if slope >= 0:        # not a descent direction (rounding): shift more
                    rel = max(rel * 100.0, 1e-8)
                    inner += 1
                    steps += 1
                    continue
                alpha, accepted = 1.0, False
                for _ in range(30):
                    self.counts["trials"] += 1
                    Ft, gt = self._values(alpha * d)
                    mt = _phr(s * gt, lam, rho, lo, hi)
                    if np.isfinite(Ft) and Ft + mt.value <= LA + ARMIJO * alpha * slope:
                        accepted = True
                        break
                    alpha *= 0.5
                steps += 1
                inner += 1
                if not accepted:
                    rel = min(rel * 100.0, 1e4)
                    if rel >= 1e4:
                        status = "the line search found no decrease"
                        break
                    continue
                if _DEBUG:
                    print(f"  step {steps:4d} outer {outer} LA {LA:.6e} F {F:.6e} |g| {gnorm:.2e} eps {eps:.1e} "
                          f"alpha {alpha:.3g} rel {rel:.1e} act {int(m.active.sum())} rho {np.median(rho):.1e}/{rho.max():.1e}")
                rel = max(rel * 0.1, 1e-10) if alpha == 1.0 else (min(rel * 10.0, 1e4) if alpha < 0.25 else rel)
                e = _from_tangent(alpha * d, frames)
                frames, F, grad, g, jac = self._point(e)
                inf = float(np.max(np.maximum(np.maximum(self.lo - g, g - self.hi), 0.0), initial=0.0))
                if self.monitor.iterate(e, F / self.sF, inf):
                    status = ("time limit (safety net) reached" if self.monitor.timed_out
                              else "stopped by callback")
                    break
                if abs(LA - (F + _phr(s * g, lam, rho, lo, hi).value)) <= 1e-15 * max(1.0, abs(LA)):
                    break
            if status:
                break
            # ---------------- outer update
            outer += 1
            m = _phr(s * g, lam, rho, lo, hi)
            lam = np.clip(m.mu, -LAM_MAX, LAM_MAX)
            sg = s * g
            v = sg - np.clip(sg + lam / rho, lo, hi)
            vmax = float(np.abs(v).max(initial=0.0))
            gl = grad + sys.jt(jac, s * lam)
            gnorm = float(np.abs(gl).max(initial=0.0))
            if eps <= self.tol and gnorm <= self.tol and vmax <= VTOL and self.feasible(e):
                status, converged = f"converged: measured feasible, KKT residual {gnorm:.1e}", True
                break
            if steps >= self.max_steps:
                status = f"Maximum_Iterations_Exceeded ({steps} Newton steps)"
                break
            grow = (np.abs(v) > TAU * np.abs(v_prev)) & (np.abs(v) > VTOL)
            rho = np.where(grow, np.minimum(rho * GAMMA, RHO_MAX), rho)
            v_prev = v
            eps = max(self.tol, 0.1 * eps)
        lam_g = s * lam / self.sF           # IPOPT's multipliers: grad f + J^T lam_g = 0
        state = AlmState(e=e.copy(), lam=lam, rho=rho, scale=s, delta=rel)
        return AlmRun(e, lam_g, steps, outer, self.counts["factorizations"], status, converged, state,
                      dict(self.counts))


def _row_scales(b: Built, jac: np.ndarray, sys: NewtonSystem) -> np.ndarray:
    """One scale per constraint term: the inverse median gradient norm of its rows."""
    norms = np.sqrt(np.bincount(sys.jac_rows, weights=jac * jac, minlength=b.n_g))
    s = np.ones(b.n_g)
    for rows in b.g_slices:
        nz = norms[rows][norms[rows] > 0]
        med = float(np.median(nz)) if nz.size else 1.0
        s[rows] = 1.0 / min(max(med, 1e-6), 1e6)
    return s
