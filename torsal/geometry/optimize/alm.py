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
semidefinite (:mod:`.projected`), ``J_A`` the rows whose penalty is active or within
``NEAR`` of becoming so (the Gauss-Newton part of the penalty), and a small adaptive ``delta`` (Levenberg-Marquardt:
divided by 10 after a full step, times 10 after a short one). ``K``'s pattern is the
union over all rows, fixed for the NLP and kept across re-solves; MUMPS factors it, analysed
once per pattern (:class:`~torsal.geometry.optimize.factor.SparseCholesky`, :mod:`.mumps`:
multifrontal, faster than qdldl's refactorization on every Fig. 12 row, ``--tables factor``), and its
negative pivots prove an exact Hessian's ``K`` positive definite (:meth:`NewtonSystem.proving`).
A backtracking Armijo line search on ``L_A`` takes the step.

Two things keep the full step where ``L_A``'s model holds. The active set the step itself
predicts: a step that moves rows across the kink of their penalty is replaced by the step
of the active set it predicts, semismooth Newton on the piecewise-quadratic model, up to
:data:`PREDICT` more factorizations (``_predict``), each pass taken only as far as the model
keeps decreasing (:data:`PREDICT_MODEL`: the passes of a set that does not settle end no
worse than they began). And rows near a pole: the torsal-angle
rows of a face whose line turns into the face's plane grow without bound (the metric seen
along the line degenerates; on row 9's answer the line of one face in 100 is within 0.3 deg
of its face's plane). A full step that fails because such a row jumped out of its bounds far
beyond its linear model is not cut by the line search to nothing (1/1000 and less, every
other step before): the row's penalty curvature joins ``K`` for the rest of the solve, and
the step is taken again (``_line_search``, :data:`ERRATIC_JUMP`).

Stopping is on the geometry: a solve has converged when every constraint holds as
measured on the congruence (torsal angles in degrees, ``c_hyp / delta^2``, see
:mod:`.measure`), the inner gradient is below the final tolerance and every row's
complementarity measure is below ``VTOL``. With ``stop="design"`` (the default) it ends
before, at the first iterate that holds every constraint as measured while the objective no
longer moves (the design tolerance, :data:`DESIGN_DECREMENT`): the result says which ended it. Where the
objective has settled but rows are still out of their bounds, their penalties grow at once
(:data:`SETTLED_GAMMA`), not at the next multiplier update.
Limits are counts (Newton steps), never time, so a solve's answer does not depend on the
machine's load. :class:`AlmStrategy` is the solve room's strategy around the method.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable, NamedTuple

import numpy as np
import scipy.sparse as sp

from .cache import NlpKind
from .factor import NotPositiveDefinite, SparseCholesky
from .history import SolveMonitor
from .nlp import Built, NumericFunction, _from_tangent, tangent_frames
from .result import Stop, StopReason
from .strategy import AlmRun, AlmState, Run, SolveContext, Start

#: Newton steps of the augmented Lagrangian when ``solve(max_iter=...)`` is not given
ALM_MAX_STEPS = 500
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
#: complementarity / violation tolerance of the scaled rows (~ radians of line rotation)
VTOL = 1e-4
#: the projected Newton matrix carries the constraints' projected curvature (else only rho J^T J)
CONSTRAINT_CURVATURE = False
#: the relative Newton decrement that ends a solve, per unit of ``solve(tol=...)`` (1e-4 -> 1e-5).
#: With the split rows divided by the form's magnitude (:data:`.forms.SPLIT_SCALE`; k = 0.1),
#: row 9 took 456 Newton steps to 1e-6, the last 300 of them for 0.3 % of its energy
#: (0.01701 -> 0.01695), and 161 to 1e-5; 7c 59 and 64 steps to the same energy
DECREMENT_PER_TOL = 1e-1
#: the Newton decrement is relative to |L_A|, or to this share of the start's objective where
#: that is larger (a design whose energies reach zero): such a solve ends when what is left
#: to gain is below 1e-9 of its start (1e-4 x the final decrement 1e-5). The doubly curved
#: facade at min_torsal_angle 40 (energies 6.3 -> 4e-8) took 13 Newton steps with it and 265
#: with 1e-8, spent on the last 3e-8 of the energy. A warm re-solve keeps the floor of the
#: solve it continues (:attr:`AlmState.floor`): its own start, the last optimum, is near zero
#: there; with that as the scale, the facade re-solved after a 5 degree sun turn took 29 / 55 /
#: 35 Newton steps at min_torsal_angle 40 / 60 / 80 (a cold solve 19 / 27 / 38), with the
#: design's 2 / 8 / 32
FLOOR = 1e-4
#: a warm re-solve: penalties capped at this multiple of a cold start's
WARM_RHO_CAP = 100.0
#: a warm re-solve's first inner tolerance (relative Newton decrement; the final one is 1e-5 at
#: ``solve(tol=1e-4)``). Its first multipliers are the last design's, off where the change moved the
#: optimum, so its first inner minimization ends early and the multiplier update corrects them: row
#: 9 after its bound was raised 2 degrees spent 40 Newton steps (the inner limit) at the last
#: multipliers before the first measured-feasible iterate with 1e-5, and reached quality in 3.9 s
#: against 6.2 (weight / sun changes 0.27 / 3.76 s against 0.29 / 3.79; 7c 0.31 / 0.51 / 0.26
#: against 0.40 / 0.40 / 0.44). 1e-3 (a cold start's) was no faster to quality (row 9: 0.37 / 3.79 /
#: 3.85 s). The doubly curved facade after a 5 degree sun turn (see FLOOR): 2 / 8 / 32 Newton steps
#: at 40 / 60 / 80 degrees, with 1e-5 3 / 4 / 30, with 1e-3 2 / 8 / 49
WARM_EPS = 1e-4
#: first inner tolerance (Newton decrement relative to |L_A|)
EPS_START = 1e-3
#: Newton steps per inner minimization: where it has not reached its tolerance by then, the
#: multipliers are updated anyway (the inner problem's answer at the old multipliers is not
#: worth more steps: its active set changes by hundreds of rows a step). Fig. 12 row 9 in
#: ``torsal design`` (with :data:`PREDICT_MODEL`; 2026-11-29, load 10-15, processor seconds of
#: the congruence stage), Newton steps / s for numpy's eigh, the compiled kernel, eigh of the
#: upper triangle: 40: 130 / 44.8, 135 / 40.8, -; 20: 82 / 30.4 (numpy); 15: 82 / 31.4, 82 /
#: 27.7, 76 / 28.3, energy 0.016936-0.016939 each; 10: 108 / 38.2 (numpy). 7c (26 steps) and the
#: facade at 80 degrees (29) the same at 15 and 40
INNER_MAX = 15
#: multiplier updates per solve: a row stuck at a bound it cannot reach (zero gradient, e.g.
#: hyperbolicity exactly 0 under a margin) takes no Newton step, so only this ends the solve
OUTER_MAX = 60
#: largest turn of one line in one Newton step (gnomonic coordinate, ~ radians)
MAX_TURN = 0.5
_DEBUG = bool(__import__("os").environ.get("TORSAL_ALM_DEBUG"))

#: The design tolerance (``solve(stop=Stop.DESIGN)``, the default): a solve ends at the first
#: Newton iterate that holds every constraint as measured, whose last Newton decrement is at
#: most DESIGN_DECREMENT and whose objective moved by at most DESIGN_DECREASE (either way) over
#: the last DESIGN_WINDOW Newton steps, both relative to the objective itself (not to the
#: decrement's floor: a design whose energies near zero is solved to convergence, where the
#: last 1e-3 of the start's energy still moved its lines by tens of degrees). Past it the
#: objective creeps: Fig. 12 row 9 (2,601 vertices) was first measured-feasible at Newton step
#: 96 of 140, 0.11 % above its converged energy, and spent the last 44 steps (15 of 45 s of
#: processor time) on that 0.11 %, zig-zagging between full and 1/256 steps at decrements 1e-5
#: to 1e-4. Measured against the converged answers (benchmarks/optimize_bench.py --tables stop
#: and the solves alone): row 9 lines at most 2.5 degrees apart (mean 0.14), smallest torsal
#: plane angle 60.013 / 60.012; 7c 27 of 31 Newton steps, 0.017 % *below* the converged energy,
#: lines at most 2.4 degrees apart (mean 0.2), plane angle 39.95 / 40.17 (within the 0.1 degree
#: the bound is measured to). The energy left is not estimated from these numbers: at the same
#: decrement and recent decrease it was -0.02 % (7c), 0.1 % (row 9) and 1.1 % (a 9 x 9 canopy of
#: tests/geometry/test_optimize_stop.py's family), so the report gives the decrement and the
#: recent decrease, not a gap. Downstream (optimize_bench --tables stop, 7c up to the light
#: stage), the design tolerance against convergence moved the figures about as much as the
#: digits past convergence do (tol/10 against tol, an energy 3e-5 apart): blocked share +1.6 % / +5.0 %,
#: transparency -6.4 % / -3.9 %, transparency cone -3.2 % / -6.0 %, support edges +0.4 % / +0.6 %,
#: extracted delta_pl +0.2 % / +11 %, parts -2.1 % / +2.2 %: the remeshed fins follow digits the
#: energy does not see, in no direction; none of them is the better design. Row 9 the same
#: (design / tol/10 against converged): blocked share -0.8 % / -2.3 %, transparency +8.6 % /
#: +3.5 %, transparency cone +7.7 % / +7.6 %, support edges +0.2 % / -2.0 %, parts -1.6 % /
#: -2.9 %; at tol/10 its solve ran into the step limit 1.2 % below the converged energy
DESIGN_DECREMENT = 1e-3
#: see DESIGN_DECREMENT
DESIGN_DECREASE = 1e-3
#: see DESIGN_DECREMENT
DESIGN_WINDOW = 10
#: a warm re-solve's design tolerance before it has taken DESIGN_WINDOW Newton steps: the
#: objective's decrease over the last WARM_WINDOW steps, at that rate over DESIGN_WINDOW steps,
#: within DESIGN_DECREASE. A warm re-solve starts at the last design's optimum: 7a's let-through
#: region moved 0.5 m (issue 43's preview, full size) was at step 4 within 4e-4 of the energy it
#: then crept to by step 13 at 3e-5 a step (full projected steps, decrements 1e-5), where the
#: window of 10 ended it; with this it ends at step 7, energy 0.0225381 against 0.0225343
#: (+0.017 %; benchmarks/session_bench.py). Cold solves as before
WARM_WINDOW = 3

#: the exact Hessian is tried after a full projected step that turned no line by more than this
TURN_EXACT = 0.05
#: the exact Hessian's inertia correction (IPOPT's ``delta_w``, Wachter and Biegler 2006, 3.1): where
#: the exact ``K`` has at most this many negative pivots (MUMPS's inertia) it is factored again
#: with a shift ``delta (mean diagonal) I`` (:meth:`AugmentedLagrangian._exact`): :data:`INERTIA_FIRST`,
#: then :data:`INERTIA_GROW` times the last, up to :data:`INERTIA_MAX`; the next exact step starts
#: from :data:`INERTIA_SHRINK` times the shift that worked. More negative pivots, or retries that
#: failed (not made again until an exact step succeeds): the projected ``K``, as without it
#: (:class:`Inertia`). The doubly curved facade at min_torsal_angle 80 (torsal design's, issue
#: 44): its exact ``K`` had one negative pivot where it was tried, a shift of 1e-8 of the mean
#: diagonal made it positive definite, and the projected steps in between crept (the objective
#: down 3 % a step): 77 -> 42 Newton steps, 305 -> 166 factorizations (benchmarks/optimize_bench.py's
#: docstring). Fig. 12's 7c and 9 had 3-29 negative pivots: unchanged
INERTIA_PIVOTS = 2
#: see INERTIA_PIVOTS
INERTIA_FIRST = 1e-8
#: see INERTIA_PIVOTS
INERTIA_GROW = 10.0
#: see INERTIA_PIVOTS
INERTIA_SHRINK = 1.0 / 3.0
#: see INERTIA_PIVOTS
INERTIA_MAX = 1e-6
#: a step shorter than this raises the Levenberg-Marquardt shift
SHORT_STEP = 0.1
#: how the energies' element Hessians are made positive semidefinite (:func:`.projected.psd_projection`)
PROJECTION = "clamp"
#: re-centre the chart when a line has moved this far from the centre (gnomonic coordinate)
RECENTRE = 0.25
#: Armijo's sufficient decrease
ARMIJO = 1e-4
#: near the answer (a warm re-solve; a cold one once its inner tolerance is the final one):
#: rows within this of a bound (scaled units, ~ radians) carry their penalty curvature
#: ``rho J^T J`` in the Newton matrix while inactive, so a full step does not overshoot
#: across the kink of the penalty where the optimum leaves many rows (7c after a sun change:
#: 46 Newton steps, half cut to alpha <= 1/16 by the line search, against 5 with the band;
#: cold 7c 49 -> 34, row 9 194 -> 173). Not from the start of a cold solve: on the small
#: family that cost more rescues by IPOPT (21 of 80 against 14) and 30 % more processor time
NEAR = 1e-3
#: Newton steps with the band at most: the doubly curved facade at min_torsal_angle 40 (its
#: energies near zero), re-solved after a 5 degree sun turn, took 500 steps with it
#: throughout (10 without it)
NEAR_STEPS = 20
#: passes of the predicted active set per Newton step (:meth:`AugmentedLagrangian._predict`):
#: row 9 from four penalty starts (RHO_START 7, 10, 14, 20) converged by the augmented
#: Lagrangian alone with energies 0.0174-0.0178 and 48-249 Newton steps, against two of four
#: without it (0.0209-0.0239; the other two were handed to IPOPT); the small family: 22 %
#: fewer Newton steps, 10 % more processor time (one factorization per pass)
PREDICT = 3
#: each predicted pass moves only as far as the step's model of ``L_A`` keeps decreasing
#: (``_predict``, ``_Model``). Without it the last pass's step was taken whole, and on Fig. 12
#: row 9 (issue 44) its model value was above the start's (the rows it moved across their bounds
#: added 0.3-6 to the linearized penalty against 0.05-0.3 the energy lost): the line search cut
#: most steps to 1/64-1/4 and the solve's length hung on rounding (74 Newton steps with numpy's
#: eigh, 136-137 with other rounding of the same projection). With it, and :data:`INNER_MAX` 15,
#: 76-82 with each (energy 0.01694 against 0.01724 before, both measured feasible); the facade
#: at 80 degrees 42 -> 29 Newton steps, 7c 26 as before
PREDICT_MODEL = True
#: bisections of the model's slope along a pass (``_Model.minimize``): 2^-20 of the pass
MODEL_BISECTIONS = 20
#: a row that leaves its bounds on a failed full step by more than this beyond its linear
#: model (scaled units) is near a pole (row 9: the torsal-angle rows of faces whose lines turn
#: into the face's plane, where the metric seen along the line degenerates): its penalty
#: curvature joins ``K`` for the rest of the solve (see ``_line_search``)
ERRATIC_JUMP = 1.0
#: the design tolerance's end game: where its conditions on the objective hold (Newton decrement
#: and recent decrease, :data:`DESIGN_DECREMENT`) but rows are still out of their bounds (beyond
#: :data:`VTOL`, scaled), so the iterate is not measured feasible, those rows' penalties grow by
#: this factor at once (per row, as the outer update's; at most once per :data:`DESIGN_WINDOW`
#: Newton steps; 1 turns it off) instead of when the inner minimization ends. Fig. 12 row 9
#: settled at Newton step 70 with 80 rows out (5-6 faces 0.8 degree under the bound); before, the
#: inner minimization ran on, the multiplier update at step 72 put 15 faces up to 5.6 degrees under
#: it, and the design was measured feasible at step 96: 25 Newton steps (8 of 32 s of processor
#: time) for 0.04 % of the energy. With it: feasible and ended at step 74, 20-25 s, energy 0.017241
#: against 0.017225 (+0.09 %); 7c 27 -> 26 steps (0.42719 against 0.42716); downstream in
#: benchmarks/optimize_bench.py's docstring (issue 44, row 9's end game). Not free of risk, as the design
#: tolerance is not: it takes the first settled, feasible iterate, and on a 9 x 9 canopy at 70
#: degrees (tests/geometry/test_optimize_stop.py's miniature) that is now a plateau at step 108
#: (energy 0.1140) which the solve without it left after step 115 (0.0934 at step 282, converged
#: 0.0923); without it, the rule had met such a plateau feasible at step 92 (0.1147) a step before
#: its objective settled, and it stops 5.8 % above the converged energy at 50 degrees. Unchanged:
#: the design family's 20 members at 12 x 12 vertices x 40/60/80 degrees (60 solves), canopies 11-15 at
#: 50-70 degrees (11 at 50 raised too, at step 56: 57 steps either way, energy -0.002 %), rows
#: 7a, 7b, 7d, 11, 13
SETTLED_GAMMA = GAMMA


@dataclass
class NewtonSystem:
    """The fixed pattern of ``K`` (upper triangle) and where each piece's values go.

    Pieces: the projected Lagrangian Hessian's nonzeros, every row's ``J_j^T J_j`` (upper
    triangle of the outer product of its nonzeros), the diagonal.
    """

    n: int
    n_rows: int               # constraint rows
    hess_pos: np.ndarray      # position in K of each Hessian nonzero
    jac_rows: np.ndarray      # (nnz_J,) row of each Jacobian nonzero
    jac_cols: np.ndarray
    pair_a: np.ndarray        # pairs of Jacobian nonzeros of one row (a, b), col_a <= col_b
    pair_b: np.ndarray
    pair_pos: np.ndarray      # their position in K
    diag_pos: np.ndarray      # (n,)
    chol: SparseCholesky
    counts: dict = field(default_factory=lambda: {"factorizations": 0})
    chol_definite: SparseCholesky | None = None     # see proving()
    # values(): the row of each pair, and the last Hessian and Jacobian with what they gave
    pair_row: np.ndarray = field(init=False, repr=False)
    _last_hess: np.ndarray | None = field(default=None, init=False, repr=False)
    _k_hess: np.ndarray | None = field(default=None, init=False, repr=False)
    _last_jac: np.ndarray | None = field(default=None, init=False, repr=False)
    _jac_pairs: tuple = field(default=(), init=False, repr=False)

    def __post_init__(self):
        self.pair_row = self.jac_rows[self.pair_a]

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
        return cls(n, b.n_g, pos[:nh], j_row, j_col, pa, pb, pos[nh:nh + npair], pos[nh + npair:],
                   SparseCholesky(pattern, backend))

    def values(self, hess: np.ndarray, jac: np.ndarray, w_rows: np.ndarray, shift: float) -> np.ndarray:
        """``K``'s values: ``hess + J^T diag(w_rows) J + shift I`` (``jac`` the Jacobian's nonzeros).

        A Newton step assembles ``K`` up to 1 + :data:`PREDICT` times from one ``hess`` and one
        ``jac`` with other row weights: the scattered Hessian and the pairs' Jacobian entries of
        the last arrays passed are kept (by identity: the callers never change them in place),
        the same numbers in the same order."""
        if self._last_hess is not hess:
            self._last_hess, self._k_hess = hess, np.bincount(self.hess_pos, weights=hess, minlength=self.chol.nnz)
        k = self._k_hess.copy()
        if self.pair_a.size:
            if self._last_jac is not jac:
                self._last_jac, self._jac_pairs = jac, (jac[self.pair_a], jac[self.pair_b])
            ja, jb = self._jac_pairs
            w = w_rows[self.pair_row]
            sel = w > 0
            k += np.bincount(self.pair_pos[sel], weights=w[sel] * ja[sel] * jb[sel], minlength=self.chol.nnz)
        k[self.diag_pos] += shift
        return k

    def matrix(self, hess: np.ndarray, jac: np.ndarray, w_rows: np.ndarray, shift: float) -> np.ndarray:
        """``K``'s values: :meth:`values` plus ``shift`` times its mean diagonal (at least 1)."""
        k = self.values(hess, jac, w_rows, 0.0)
        k[self.diag_pos] += shift * max(1.0, float(np.mean(np.abs(k[self.diag_pos]))))
        return k

    def proving(self) -> SparseCholesky:
        """A factorization of ``K``'s pattern that proves ``K`` positive definite (the exact
        Hessian's steps need the proof; the projected ``K`` is positive definite by
        construction): :attr:`chol` itself where its backend reads its pivots, else a qdldl
        one, analysed on first use."""
        if self.chol.definite:
            return self.chol
        if self.chol_definite is None:
            self.chol_definite = SparseCholesky(self.chol.upper(np.ones(self.chol.nnz)), "qdldl")
        return self.chol_definite

    def jt(self, jac: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``J^T v``."""
        return np.bincount(self.jac_cols, weights=jac * v[self.jac_rows], minlength=self.n)

    def jv(self, jac: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``J v``."""
        return np.bincount(self.jac_rows, weights=jac * v[self.jac_cols], minlength=self.n_rows)


class _Point(NamedTuple):
    """One evaluated iterate in the current chart."""

    z: np.ndarray             # chart coordinates
    F: float                  # |V| f
    grad: np.ndarray          # grad F
    g: np.ndarray             # constraint rows (unscaled)
    jac: np.ndarray           # their Jacobian's nonzeros


class _Direction(NamedTuple):
    d: np.ndarray             # the Newton direction (chart coordinates)
    exact: bool               # from the exact Hessian (else the projected one)
    h: np.ndarray             # that Hessian's nonzeros (the predicted steps reuse it)
    shift: float = 0.0        # the relative shift K was factored with (the predicted steps keep it)


class _Search(NamedTuple):
    """How a line search ended: a step (``alpha``, the new ``point``), rows that wrecked the
    full step (``jump``), or neither (no decrease found)."""

    alpha: float = 0.0
    point: _Point | None = None
    jump: np.ndarray | None = None


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


class _Model:
    """The model of ``L_A`` a Newton step minimizes, the rows linearized (see ``_predict``):
    ``m(d) = grad F . d + d.Hd / 2 + sum_j rho_j / 2 dist(t_j + s_j J_j d, [l_j, u_j])^2``
    with ``H`` the Hessian the step was factored with (without its shift: the model is of
    ``L_A``, not of the regularized matrix)."""

    def __init__(self, sys: NewtonSystem, pt: _Point, h: np.ndarray, t, rho, s, lo, hi):
        self.sys, self.pt, self.t, self.rho, self.s, self.lo, self.hi = sys, pt, t, rho, s, lo, hi
        self.H = sys.chol.full(sys.values(h, pt.jac, np.zeros(sys.n_rows), 0.0))

    def minimize(self, a: np.ndarray, b: np.ndarray) -> float:
        """The ``beta`` in [0, 1] that minimizes ``m(a + beta (b - a))`` (the model is convex
        along the segment where ``H`` is positive semidefinite: bisection on its slope)."""
        step = b - a
        Hs = self.H @ step
        q1, q2 = float((self.pt.grad + self.H @ a) @ step), float(step @ Hs)
        ua = self.t + self.s * self.sys.jv(self.pt.jac, a)
        du = self.s * self.sys.jv(self.pt.jac, step)

        def slope(beta: float) -> float:
            u = ua + beta * du
            return q1 + beta * q2 + float(np.sum(self.rho * (u - np.clip(u, self.lo, self.hi)) * du))
        if slope(1.0) <= 0.0 or q2 < 0.0:
            return 1.0
        lo_b, hi_b = 0.0, 1.0
        if slope(0.0) >= 0.0:
            return 0.0
        for _ in range(MODEL_BISECTIONS):
            mid = 0.5 * (lo_b + hi_b)
            lo_b, hi_b = (mid, hi_b) if slope(mid) < 0.0 else (lo_b, mid)
        return 0.5 * (lo_b + hi_b)


@dataclass
class Inertia:
    """IPOPT's inertia correction of the exact Hessian's ``K`` within one solve (see
    :data:`INERTIA_PIVOTS`): the relative shift that last made it positive definite (0: none
    was needed) and whether a refused factorization is retried with a larger shift."""

    last: float = 0.0
    retry: bool = True

    def first(self, rel: float) -> float:
        """The first shift of an exact step: the Levenberg-Marquardt one ``rel``, or
        :data:`INERTIA_SHRINK` of the last that worked."""
        return max(rel, INERTIA_SHRINK * self.last)

    def retry_with(self, shift: float, negative: int | None) -> float | None:
        """The next shift after a factorization at ``shift`` refused with ``negative`` negative
        pivots (None: not counted), or None: no retry."""
        if not self.retry or negative is None or not 0 < negative <= INERTIA_PIVOTS or shift >= INERTIA_MAX:
            return None
        return min(max(INERTIA_FIRST, INERTIA_GROW * shift), INERTIA_MAX)

    def ended(self, ok: bool, retried: bool, shift: float) -> None:
        """An exact step ended (``ok``: with a direction, at relative ``shift``, 0 where the
        Levenberg-Marquardt one sufficed): a failed retry stops the retries until an exact step
        succeeds."""
        if ok or retried:
            self.retry = ok
        if ok:
            self.last = shift


class AugmentedLagrangian:
    """One augmented-Lagrangian solve of a tangent-mode NLP ``b`` (see the module docstring).

    ``p0``: the NLP's parameters (frames are replaced at every iterate); ``monitor`` gets
    every Newton iterate (measured history, best feasible iterate, the user's callback, the
    safety-net time limit); ``feasible(e)`` says whether every constraint holds as measured.
    """

    def __init__(self, b: Built, p0: np.ndarray, monitor: SolveMonitor, feasible: Callable[[np.ndarray], bool],
                 *, max_steps: int, tol: float, stop: Stop = Stop.DESIGN, backend: str | None = None,
                 projection: str | None = None):
        if b.mode != "tangent" or b.n_lift or b.n_slack:
            raise ValueError("the augmented Lagrangian needs the tangent NLP without lifted variables or slacks")
        self.b, self.monitor, self.feasible = b, monitor, feasible
        self.p = np.array(p0, dtype=float)
        # the final inner tolerance: L_A within tol * DECREMENT_PER_TOL (relative) of its minimum
        self.max_steps, self.tol = int(max_steps), float(tol) * DECREMENT_PER_TOL
        self.stop = Stop(stop)
        self.sF = float(max(b.n_vertices, 1))
        if not hasattr(b, "alm_cache"):
            b.alm_cache = {}
        key = ("system", backend)
        if key not in b.alm_cache:
            b.alm_cache[key] = (NewtonSystem.of(b, backend), NumericFunction(b.point), NumericFunction(b.value))
        self.sys, self._pt, self._val = b.alm_cache[key]
        b.hess_lag.mode = projection or PROJECTION
        b.hess_lag.project = True
        b.hess_lag.constraint_curvature = CONSTRAINT_CURVATURE
        self.lo, self.hi = b.lbg, b.ubg
        self.counts = {"factorizations": 0, "shifted": 0, "trials": 0, "exact": 0, "indefinite": 0,
                       "predicted": 0, "erratic": 0, "tightened": 0, "corrected": 0, "backend": self.sys.chol.route}
        # wall seconds by phase: the Lagrangian Hessian's blocks (and their projection), the
        # factorizations with their solves, the line searches (their point evaluations)
        self.seconds = {"hessian": 0.0, "factor": 0.0, "line search": 0.0}
        self.inertia = Inertia()

    # ------------------------------------------------------------------ evaluations
    def _recentre(self, e: np.ndarray) -> np.ndarray:
        """Frames of the chart at the directions ``e`` (``z = 0`` there); returns the frames."""
        frames = tangent_frames(e)
        self.p[:self.b.n_frames] = frames.ravel()
        return frames

    def _point(self, z: np.ndarray) -> _Point:
        """``F``, ``grad F``, ``c``, ``J``'s nonzeros at chart coordinates ``z`` (one evaluation)."""
        f, grad, g, jac = self._pt(z, self.p)
        return _Point(z, float(f[0]) * self.sF, grad * self.sF, g, jac)

    def _hessian(self, mu_unscaled: np.ndarray) -> np.ndarray:
        """The projected Lagrangian Hessian's nonzeros (multipliers ``mu_unscaled``)."""
        return self._hessians(mu_unscaled, exact=False)[1]()

    def _hessians(self, mu_unscaled: np.ndarray, exact: bool, z: np.ndarray | None = None
                  ) -> tuple[np.ndarray | None, Callable[[], np.ndarray]]:
        """``(exact or None, projected)`` Lagrangian Hessians at ``z`` from one evaluation of the
        blocks; the projected one on demand (its eigendecompositions are not needed where the
        exact Hessian is positive definite)."""
        x = np.zeros(self.b.n_var) if z is None else z
        h = self.b.hess_lag
        # the projected matrix leaves the constraints' curvature out (CONSTRAINT_CURVATURE): their
        # element Hessians are evaluated only for the exact one
        rest, mats = h.pieces([x, self.p, np.array([self.sF]), mu_unscaled],
                              constraints=exact or h.constraint_curvature)
        return (h.combine(rest, mats, False) if exact else None), lambda: h.combine(rest, mats, True)

    # ------------------------------------------------------------------ the solve
    def _initial(self, jac: np.ndarray, warm: AlmState | None) -> AlmState:
        """Multipliers, penalties and row scales of a cold start (or the warm ones)."""
        b, sys = self.b, self.sys
        # rows scaled to unit gradients: a penalty curvature RHO_START times the energies'
        # typical curvature per variable (median of the projected Hessian's diagonal)
        h0 = sys.values(self._hessian(np.zeros(b.n_g)), jac, np.zeros(b.n_g), 0.0)[sys.diag_pos]
        r0 = RHO_START * max(float(np.median(h0)), 1e-6)
        if warm is not None and warm.lam.size == b.n_g:
            # the multipliers carry over; penalties that grew for the old problem's hard rows
            # are capped, so the changed problem's first steps are not stiff
            return AlmState(e=warm.e, lam=warm.lam.copy(), rho=np.minimum(warm.rho, WARM_RHO_CAP * r0),
                            scale=warm.scale, delta=warm.delta)
        s = _row_scales(b, jac, sys)
        return AlmState(e=np.zeros((0, 3)), lam=np.zeros(b.n_g), rho=np.full(b.n_g, r0), scale=s, delta=1e-8)

    def _direction(self, z, gl, jac, mu, w, try_exact: bool) -> _Direction | None:
        """The Newton direction ``-K^-1 grad L_A``: with the exact Hessian when asked and it is
        positive definite, or nearly so (:meth:`_exact`), else the projected one (one
        factorization, more only if rounding makes it fail: then with a larger shift)."""
        t0 = time.perf_counter()
        exact_h, projected = self._hessians(mu, exact=try_exact, z=z)
        self.seconds["hessian"] += time.perf_counter() - t0
        if exact_h is not None:
            d, shift = self._exact(exact_h, jac, w, gl)
            if d is not None:
                self.counts["exact"] += 1
                return _Direction(d, True, exact_h, shift)
        t0 = time.perf_counter()
        h = projected()
        self.seconds["hessian"] += time.perf_counter() - t0
        d = self._solve(h, False, jac, w, gl)
        return None if d is None else _Direction(d, False, h, self.rel)

    def _exact(self, h: np.ndarray, jac: np.ndarray, w: np.ndarray, rhs: np.ndarray
               ) -> tuple[np.ndarray | None, float]:
        """The exact Hessian's Newton direction with IPOPT's inertia correction (:class:`Inertia`):
        ``(direction or None, the relative shift it was factored with)``."""
        shift, retried = self.inertia.first(self.rel), False
        d, negative = self._attempt(self.sys.proving(), self.sys.matrix(h, jac, w, shift), rhs, True)
        while d is None and (nxt := self.inertia.retry_with(shift, negative)) is not None:
            shift, retried = nxt, True
            d, negative = self._attempt(self.sys.proving(), self.sys.matrix(h, jac, w, shift), rhs, True)
        self.inertia.ended(d is not None, retried, shift if shift > self.rel else 0.0)
        self.counts["corrected"] += int(d is not None and shift > self.rel)
        return d, shift

    def _attempt(self, chol: SparseCholesky, k: np.ndarray, rhs: np.ndarray, exact: bool
                 ) -> tuple[np.ndarray | None, int | None]:
        """``-k^-1 rhs`` by one factorization: ``(descent direction or None, negative pivots)``
        (the pivots None where the backend does not count them, or the solve gave no descent)."""
        self.counts["factorizations"] += 1
        t0 = time.perf_counter()
        try:
            chol.factor(k)
            d = -chol.solve(rhs)
        except NotPositiveDefinite as exc:
            self.seconds["factor"] += time.perf_counter() - t0
            self.counts["indefinite" if exact else "shifted"] += 1
            if _DEBUG and exact:
                print(f"    exact K: {exc}")
            return None, exc.negative
        self.seconds["factor"] += time.perf_counter() - t0
        # a descent direction, or the factorization was not what it claimed
        if np.all(np.isfinite(d)) and (float(rhs @ d) < 0 or not np.any(rhs)):
            return d, 0
        self.counts["indefinite" if exact else "shifted"] += 1
        return None, None

    def _solve(self, h: np.ndarray, exact: bool, jac: np.ndarray, w: np.ndarray, rhs: np.ndarray,
               shift: float | None = None) -> np.ndarray | None:
        """``-(h + J^T diag(w) J + shift I)^-1 rhs``, a descent direction for ``rhs``; None where
        ``h`` is not positive definite (exact, factored once with ``shift``, default the
        Levenberg-Marquardt one) or rounding defeats every shift (projected)."""
        if exact:
            k = self.sys.matrix(h, jac, w, self.rel if shift is None else shift)
            return self._attempt(self.sys.proving(), k, rhs, True)[0]
        for _ in range(8):
            d, _ = self._attempt(self.sys.chol, self.sys.matrix(h, jac, w, self.rel), rhs, False)
            if d is not None:
                return d
            self.rel = min(max(self.rel * 100.0, 1e-8), 1e4)
        return None

    def _predict(self, pt: _Point, nd: _Direction, gl: np.ndarray, t: np.ndarray, w_rows: np.ndarray,
                 rho, s, lo, hi) -> np.ndarray:
        """The Newton step of the active set it predicts (semismooth Newton on the step's model).

        The Newton step from the current active set overshoots where it moves rows across
        the kink of their penalty (inactive rows it makes active, active ones it frees); the
        line search then cuts it to a fraction (row 9: every other step to 1/1000). The
        model of ``L_A`` with the rows linearized, ``g.d + d.Hd/2 + sum_j rho_j/2 dist(t_j +
        s_j J_j d, [l_j, u_j])^2``, is piecewise quadratic: each pass takes the active set
        the last step predicts (with the bound each row crosses) and minimizes that piece
        (one factorization), at most :data:`PREDICT` passes, until the predicted set repeats.
        With :data:`PREDICT_MODEL`, each pass moves from the last step towards the piece's
        minimizer only as far as the model keeps decreasing (:meth:`_model_step`): the passes
        of a set that does not settle (row 9: a thousand rows change each pass) then never
        end at a step the model itself says is worse than the first.
        ``t``: the rows' shifted values ``s c + lam / rho``; ``w_rows``: the rows' curvature
        weights of the first step. The result is a descent direction of ``L_A`` (else the
        first step).
        """
        sys, d = self.sys, nd.d
        used = w_rows > 0
        model = _Model(sys, pt, nd.h, t, rho, s, lo, hi) if PREDICT_MODEL else None
        # the first step is that of a piece only where its curvature set is the active set
        piece = np.array_equal(used, (t < lo) | (t > hi))
        for _ in range(PREDICT):
            tp = t + s * sys.jv(pt.jac, d)
            pred = (tp < lo) | (tp > hi)
            if piece and np.array_equal(pred, used):
                break
            r = np.where(pred, t - np.where(tp < lo, lo, hi), 0.0)
            self.counts["predicted"] += 1
            nxt = self._solve(nd.h, nd.exact, pt.jac, np.where(pred, rho * s * s, 0.0),
                              pt.grad + sys.jt(pt.jac, s * rho * r), nd.shift)
            if nxt is None:
                break
            if model is not None:
                beta = model.minimize(d, nxt)
                if beta < 1.0:
                    nxt = d + beta * (nxt - d)
            d, used, piece = nxt, pred, True
        return d if float(gl @ d) < 0.0 else nd.d

    def _line_search(self, pt: _Point, d, slope, LA, lam, rho, s, lo, hi, erratic: bool = False) -> _Search:
        """Backtracking Armijo on ``L_A`` along ``d`` from ``pt`` (halving): the step and the
        new point (both None where no step decreases ``L_A``). With ``erratic``: where the
        full step fails because rows left their bounds by more than their linear model says
        (by ``ERRATIC_JUMP``), those rows instead (``jump``, no step taken)."""
        alpha = 1.0
        for _ in range(30):
            self.counts["trials"] += 1
            # the full step as a whole point (most are taken: 7c 26 of 28 trials); the shorter
            # ones the objective and the rows only (half the cost of a point), the accepted one
            # in full. Both kernels give the same values to the last bit
            z = pt.z + alpha * d
            full = self._point(z) if alpha == 1.0 else None
            if full is None:
                f, g = self._val(z, self.p)
                F = float(f[0]) * self.sF
            else:
                F, g = full.F, full.g
            # a trial where a row is not defined (NaN: a line turned onto a degenerate face) fails
            if (np.isfinite(F) and np.all(np.isfinite(g))
                    and F + _phr(s * g, lam, rho, lo, hi).value <= LA + ARMIJO * alpha * slope):
                return _Search(alpha, full if full is not None else self._point(z))
            if erratic and alpha == 1.0 and np.all(np.isfinite(g)):
                lin = s * (pt.g + self.sys.jv(pt.jac, d))
                y = s * g + lam / rho
                out = (y < lo) | (y > hi)
                jump = out & (np.abs(s * g - lin) > ERRATIC_JUMP)
                if jump.any():
                    return _Search(jump=jump)
            alpha *= 0.5
        return _Search()

    def solve(self, e0: np.ndarray, warm: AlmState | None) -> AlmRun:
        """Outer PHR iterations around inner Newton minimizations, from ``e0`` (or ``warm``)."""
        run = self._start(e0, warm)
        self.monitor.start_pass(None)
        while not run.status:
            self._minimize(run)
            if run.status:
                break
            self._update(run)
        lam_g = run.s * run.lam / self.sF           # IPOPT's multipliers: grad f + J^T lam_g = 0
        state = AlmState(e=run.e.copy(), lam=run.lam, rho=run.rho, scale=run.s, delta=self.rel,
                         floor=run.floor)
        return AlmRun(run.e, lam_g, run.steps, run.outer, self.counts["factorizations"], run.status,
                      run.converged, state, dict(self.counts), dict(self.seconds), reason=run.reason,
                      decrement=None if not math.isfinite(run.dec_own) else run.dec_own,
                      recent_decrease=_recent_decrease(run))

    def _start(self, e0: np.ndarray, warm: AlmState | None) -> "_Run":
        """The run's state at ``e0``: the chart, the first point, multipliers and penalties."""
        b = self.b
        e = np.asarray(e0, dtype=float).reshape(-1, 3)
        frames = self._recentre(e)
        pt = self._point(np.zeros(b.n_var))
        st = self._initial(pt.jac, warm)
        self.rel = st.delta
        return _Run(e=e, frames=frames, pt=pt, s=st.scale, lam=st.lam, rho=st.rho,
                    lo=st.scale * self.lo, hi=st.scale * self.hi, warm=warm is not None,
                    # a warm re-solve keeps its design's floor: its own start is the last
                    # optimum, on a zero-residual design near 0 (see FLOOR)
                    floor=max(FLOOR * max(abs(pt.F), 1.0), warm.floor if warm is not None else 0.0),
                    # inner tolerance: the Newton decrement relative to |L_A|, tightened per outer iteration
                    eps=EPS_START if warm is None else max(WARM_EPS, self.tol),
                    v_prev=np.full(b.n_g, np.inf), erratic=np.zeros(b.n_g, bool))

    def _minimize(self, run: "_Run") -> None:
        """One inner minimization of ``L_A(., lam, rho)``: Newton steps until the decrement is
        below the inner tolerance, the step limit, or an ending (``run.status``)."""
        for _ in range(INNER_MAX):
            if run.steps >= self.max_steps or not self._newton_step(run) or run.status:
                return

    def _newton_step(self, run: "_Run") -> bool:
        """One Newton step of the inner minimization; False where the minimization is over."""
        sys, pt, s, lam, rho = self.sys, run.pt, run.s, run.lam, run.rho
        m = _phr(s * pt.g, lam, rho, run.lo, run.hi)
        LA = pt.F + m.value
        gl = pt.grad + sys.jt(pt.jac, s * m.mu)
        # near the answer (a warm start, or the final inner tolerance) the active set has
        # settled: rows at the kink keep their curvature (NEAR), for NEAR_STEPS Newton steps at
        # most (where it takes longer, the answer was not near)
        t = s * pt.g + lam / rho        # the rows' shifted values
        if (run.warm or run.eps <= self.tol) and run.banded < NEAR_STEPS:
            band, run.banded = m.active | _near(t, run.lo, run.hi), run.banded + 1
        else:
            band = m.active
        w = np.where(band | run.erratic, rho * s * s, 0.0)
        tried = run.wait == 0 and run.near
        nd = self._direction(pt.z, gl, pt.jac, s * m.mu, w, tried)
        exact = nd is not None and nd.exact
        run.wait = max(run.wait - 1, 0)
        if tried and not exact:        # indefinite: back off before the next try
            run.wait, run.backoff = run.backoff, min(2 * run.backoff, 32)
        if nd is None:
            run.status, run.reason = "the Newton matrix could not be factored", StopReason.FAILED
            return False
        # relative to |L_A|, or to a floor of the start's objective (zero-residual designs)
        run.dec = -0.5 * float(gl @ nd.d) / max(abs(LA), abs(pt.F), run.floor)
        # the design tolerance's decrement: relative to the objective itself, without the floor
        # (a design whose energies near zero is not "settled" at 1e-3 of its start's energy)
        run.dec_own = -0.5 * float(gl @ nd.d) / max(abs(LA), abs(pt.F), 1e-300)
        if run.dec <= run.eps:
            return False
        d = self._predict(pt, nd, gl, t, w, rho, s, run.lo, run.hi)
        found, turn = self._step(run, nd, d, gl, LA, band)
        run.steps += 1
        if found.point is None:
            self.rel = min(self.rel * 100.0, 1e4)
            if self.rel >= 1e4:
                run.status, run.reason = "the line search found no decrease", StopReason.FAILED
            return True
        alpha, run.pt = found.alpha, found.point
        if alpha * turn < 1e-12:      # rounding: no step left to take
            return False
        if exact and (alpha < 1.0 or turn > MAX_TURN):
            run.wait, run.backoff = run.backoff, min(2 * run.backoff, 32)   # not yet Newton's region
        elif exact:
            run.backoff = 1
        run.near = alpha == 1.0 and turn < TURN_EXACT
        # Levenberg-Marquardt: less shift after a long step, more after a very short one
        # (a short step at a kink of the penalty's active set is not the shift's fault)
        self.rel = (max(self.rel * 0.1, 1e-10) if alpha >= 0.5
                    else min(self.rel * 10.0, 1e-2) if alpha < SHORT_STEP else self.rel)
        if _DEBUG:
            print(f"  step {run.steps:4d} outer {run.outer} LA {LA:.6e} F {run.pt.F:.6e} dec {run.dec:.1e} "
                  f"eps {run.eps:.1e} alpha {alpha:.3g} rel {self.rel:.1e} ex {int(exact)} "
                  f"act {int(m.active.sum())} rho {np.median(rho):.1e}/{rho.max():.1e} err {int(run.erratic.sum())}")
        self._moved(run)
        if (not run.status and self.stop is Stop.DESIGN and SETTLED_GAMMA > 1 and not self.monitor.last_feasible
                and run.steps >= run.tightened + DESIGN_WINDOW and _settled(run)):
            self.counts["tightened"] += run.tighten()
        if not run.status and self.stop is Stop.DESIGN and self._designed(run):
            run.status, run.converged, run.reason = (
                f"stopped at the design tolerance: measured feasible, Newton decrement {run.dec_own:.1e}, "
                f"objective down {_recent_decrease(run):.1e} over {DESIGN_WINDOW} Newton steps"
                f"{'' if _window(run) == DESIGN_WINDOW else f' at the rate of the last {_window(run)}'}", True,
                StopReason.DESIGN)
        return True

    def _designed(self, run: "_Run") -> bool:
        """The design tolerance (:data:`DESIGN_DECREMENT`) holds at the iterate just taken."""
        return self.monitor.last_feasible and _settled(run)

    def _step(self, run: "_Run", nd: _Direction, d: np.ndarray, gl: np.ndarray, LA: float,
              band: np.ndarray) -> tuple[_Search, float]:
        """The line search along ``d`` (capped at :data:`MAX_TURN`), retried where rows near a
        pole wrecked the full step (their curvature then joins ``K``); ``(search, turn)``."""
        s, rho = run.s, run.rho
        for attempt in range(3):
            slope = float(gl @ d)
            turn = float(np.sqrt((d.reshape(-1, 2) ** 2).sum(1)).max(initial=0.0))
            if turn > MAX_TURN:
                d, slope = d * (MAX_TURN / turn), slope * (MAX_TURN / turn)
            t0 = time.perf_counter()
            found = self._line_search(run.pt, d, slope, LA, run.lam, rho, s, run.lo, run.hi, erratic=attempt < 2)
            self.seconds["line search"] += time.perf_counter() - t0
            if found.jump is None:
                return found, turn
            # rows that jumped far past their linear model (a pole of the row): their penalty
            # curvature goes into K, which holds the step back from the pole
            run.erratic |= found.jump
            self.counts["erratic"] += 1
            w = np.where(band | run.erratic, rho * s * s, 0.0)
            d = self._solve(nd.h, nd.exact, run.pt.jac, w, gl, nd.shift)
            if d is None:
                return _Search(), turn
        return found, turn

    def _moved(self, run: "_Run") -> None:
        """After a step: the directions, the chart re-centred where it drifted, the monitor."""
        b = self.b
        run.e = _from_tangent(run.pt.z, run.frames)
        if float(np.abs(run.pt.z).max(initial=0.0)) > RECENTRE:     # keep the chart near its centre
            run.frames = self._recentre(run.e)
            run.pt = self._point(np.zeros(b.n_var))
        g = run.pt.g
        inf = float(np.max(np.maximum(np.maximum(self.lo - g, g - self.hi), 0.0), initial=0.0))
        run.objectives.append(run.pt.F)
        if self.monitor.iterate(run.e, run.pt.F / self.sF, inf):
            timed = self.monitor.timed_out
            run.status = "time limit (safety net) reached" if timed else "stopped by callback"
            run.reason = StopReason.TIME_LIMIT if timed else StopReason.CALLBACK

    def _update(self, run: "_Run") -> None:
        """The outer update: multipliers, the penalties of rows that did not improve, the
        inner tolerance; and whether the solve has ended (``run.status``)."""
        s, pt = run.s, run.pt
        run.outer += 1
        m = _phr(s * pt.g, run.lam, run.rho, run.lo, run.hi)
        run.lam = np.clip(m.mu, -LAM_MAX, LAM_MAX)
        v = s * pt.g - np.clip(s * pt.g + run.lam / run.rho, run.lo, run.hi)
        vmax = float(np.abs(v).max(initial=0.0))
        if run.eps <= self.tol and run.dec <= self.tol and vmax <= VTOL and self.feasible(run.e):
            run.status, run.converged = f"converged: measured feasible, Newton decrement {run.dec:.1e}", True
        elif run.steps >= self.max_steps:
            run.status, run.reason = f"Maximum_Iterations_Exceeded ({run.steps} Newton steps)", StopReason.ITERATION_LIMIT
        elif run.outer >= OUTER_MAX:
            run.status, run.reason = (f"Maximum_Iterations_Exceeded ({run.outer} multiplier updates)",
                                      StopReason.ITERATION_LIMIT)
        grow = (np.abs(v) > TAU * np.abs(run.v_prev)) & (np.abs(v) > VTOL)
        run.rho = np.where(grow & ~run.converged, np.minimum(run.rho * GAMMA, RHO_MAX), run.rho)
        run.v_prev = v
        run.eps = max(self.tol, 0.1 * run.eps)


class AlmStrategy:
    """The strategy ``solver="alm"``: one augmented-Lagrangian solve from the start, warm from
    the last answer's multipliers and penalties where the start resumes it."""

    kind = NlpKind.ALM

    def solve(self, ctx: SolveContext, start: Start) -> Run:
        t0 = time.perf_counter()
        opts, last, b = ctx.options, ctx.state.last, start.b
        warm = last.alm if start.resume and last is not None else None
        a = AugmentedLagrangian(b, start.p, ctx.monitor, ctx.feasible, max_steps=opts.max_iter or ALM_MAX_STEPS,
                                tol=opts.tol, stop=opts.stop)
        r = a.solve(start.e0, warm)
        seconds = time.perf_counter() - t0
        x, frames = b.pack(r.e)
        return Run(x=x, lam_g=r.lam_g, iterations=r.iterations, status=r.status, ok=r.converged, active=True,
                   working=None, frames=frames, build_seconds=0.0, solve_seconds=seconds, b=b, alm=r, solver="alm",
                   # the parts of the augmented Lagrangian's time ("alm factor", ...), within "alm"
                   timings={"alm": seconds, **{f"alm {k}": v for k, v in (r.seconds or {}).items()}})


@dataclass
class _Run:
    """The state of one augmented-Lagrangian solve, between its Newton steps."""

    e: np.ndarray             # (N, 3) directions
    frames: np.ndarray        # the chart's frames
    pt: _Point                # the current point in that chart
    s: np.ndarray             # (n_g,) row scales
    lam: np.ndarray           # (n_g,) multipliers (scaled rows)
    rho: np.ndarray           # (n_g,) penalties
    lo: np.ndarray            # (n_g,) scaled bounds
    hi: np.ndarray
    warm: bool                # a warm re-solve
    floor: float              # the Newton decrement's floor (FLOOR of the start's objective)
    eps: float                # the inner tolerance
    v_prev: np.ndarray        # (n_g,) the last complementarity measures
    erratic: np.ndarray       # (n_g,) bool: rows near a pole (their curvature stays in K)
    banded: int = 0           # Newton steps taken with the band of NEAR rows
    tightened: int = -DESIGN_WINDOW   # the Newton step at which SETTLED_GAMMA last applied
    steps: int = 0            # Newton steps
    outer: int = 0            # multiplier updates
    wait: int = 0             # Newton steps before the exact Hessian is tried again
    backoff: int = 1
    near: bool = False        # the last step was a full short one: try the exact Hessian
    status: str = ""
    converged: bool = False
    dec: float = math.inf     # the last Newton decrement
    dec_own: float = math.inf  # the same relative to the objective alone (the design tolerance)
    reason: StopReason = StopReason.CONVERGED
    objectives: list = field(default_factory=list)   # F after each Newton step (DESIGN_WINDOW)

    def tighten(self) -> int:
        """The penalties of the rows out of their bounds (beyond :data:`VTOL`, scaled) grow by
        :data:`SETTLED_GAMMA` (:data:`RHO_MAX` at most): the objective has settled, the iterate
        is not measured feasible (see SETTLED_GAMMA). Returns how many grew."""
        sg = self.s * self.pt.g
        v = np.abs(sg - np.clip(sg, self.lo, self.hi))
        out = v > VTOL
        if not out.any():       # out only as measured (within VTOL here): nothing to raise
            return 0
        if _DEBUG:
            print(f"  settled at step {self.steps}: {int(out.sum())} rows out, at most {v.max():.2e}: penalties raised")
        self.rho = np.where(out, np.minimum(self.rho * SETTLED_GAMMA, RHO_MAX), self.rho)
        self.tightened = self.steps
        return int(out.sum())


def _window(run: "_Run") -> int:
    """The Newton steps :func:`_recent_decrease` looks back over: :data:`DESIGN_WINDOW`, or
    :data:`WARM_WINDOW` in a warm re-solve that has not taken more than DESIGN_WINDOW."""
    return DESIGN_WINDOW if len(run.objectives) > DESIGN_WINDOW or not run.warm else WARM_WINDOW


def _recent_decrease(run: "_Run") -> float | None:
    """The objective's relative decrease over the last :data:`DESIGN_WINDOW` Newton steps
    (relative to ``|F|``, without the floor of the Newton decrement), None before that many.
    A warm re-solve's before that many: its decrease over the last :data:`WARM_WINDOW` steps
    times ``DESIGN_WINDOW / WARM_WINDOW`` (None before WARM_WINDOW + 1 steps)."""
    f, window = run.objectives, _window(run)
    if len(f) <= window:
        return None
    return (f[-1 - window] - f[-1]) / max(abs(f[-1]), 1e-300) * (DESIGN_WINDOW / window)


def _settled(run: "_Run") -> bool:
    """The design tolerance's conditions on the objective (:data:`DESIGN_DECREMENT`) hold at the
    iterate just taken: its Newton decrement and its recent decrease, either way (an objective
    that rises while the rows are pulled feasible is moving too)."""
    if run.dec_own > DESIGN_DECREMENT:
        return False
    recent = _recent_decrease(run)
    return recent is not None and abs(recent) <= DESIGN_DECREASE


def _near(t: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Rows whose shifted value ``t`` lies within ``NEAR`` of a bound (scaled units)."""
    return (t < lo + NEAR) | (t > hi - NEAR)


def _row_scales(b: Built, jac: np.ndarray, sys: NewtonSystem) -> np.ndarray:
    """One scale per constraint term: the inverse median gradient norm of its rows."""
    norms = np.sqrt(np.bincount(sys.jac_rows, weights=jac * jac, minlength=b.n_g))
    s = np.ones(b.n_g)
    for rows in b.g_slices:
        nz = norms[rows][norms[rows] > 0]
        med = float(np.median(nz)) if nz.size else 1.0
        s[rows] = 1.0 / min(max(med, 1e-6), 1e6)
    return s
