"""IPOPT for the congruence NLP: solver options, the three-pass strategy, iteration reports.

:class:`IpoptPasses` runs one solve of a :class:`~torsal.geometry.optimize.nlp.Built` NLP in
up to three passes (see ``try_unconstrained`` of
:meth:`~torsal.geometry.optimize.CongruenceProblem.solve`): without the inequalities; with a
working set of them (:mod:`~torsal.geometry.optimize.working_set`); with all of them. The
solve room's strategies (:class:`~torsal.geometry.optimize.strategy.SolveStrategy`):
:class:`IpoptSolve` (the passes) and :class:`IpoptWarm` (all constraints, warm from another
strategy's answer: the certification or continuation of the augmented Lagrangian's).
"""
from __future__ import annotations

import time
from typing import NamedTuple

import casadi as ca
import numpy as np
import scipy.sparse as sp
from threadpoolctl import ThreadpoolController

from .alm import ALM_MAX_STEPS
from .cache import NlpKind
from .nlp import Built, _bound_violation
from .projected import PROJECTED_ITERATIONS, ProjectedHessian
from .strategy import Run, SolveContext, SolveState, Start
from .working_set import _WORKING_SET_MAX_SHARE, PassOutcome, _near_bounds, working_set_pass

#: IPOPT iterations of a certification (from the augmented Lagrangian's answer, warm)
CERTIFY_ITERATIONS = 100
#: IPOPT iterations of a solve when ``max_iter`` is not given
IPOPT_MAX_ITER = 200
#: at least this many IPOPT iterations continue an augmented Lagrangian that did not converge
RESCUE_MIN_ITERATIONS = 50


class IpoptRun(NamedTuple):
    """One IPOPT run: its answer and how it ended."""

    x: np.ndarray
    lam_g: np.ndarray | None
    iterations: int
    status: str
    converged: bool
    lam_x: np.ndarray | None = None     # the bound multipliers (casadi's sign: lam_x = z_U - z_L)


class _IterationCallback(ca.Callback):
    """casadi iteration callback: forwards every iterate to ``owner.report_iteration(arg)`` (True stops IPOPT)."""

    def __init__(self, name: str, nx: int, ng: int, np_: int, owner: SolveState):
        ca.Callback.__init__(self)
        self.nx, self.ng, self.np_ = nx, ng, np_
        self.owner = owner
        self.construct(name, {})

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        n = ca.nlpsol_out(i)
        if n == "f":
            return ca.Sparsity.dense(1)
        if n in ("x", "lam_x"):
            return ca.Sparsity.dense(self.nx)
        if n in ("g", "lam_g"):
            return ca.Sparsity.dense(self.ng)
        if n == "lam_p":
            return ca.Sparsity.dense(self.np_)
        return ca.Sparsity(0, 0)

    def eval(self, arg):    # (casadi calls eval_buffer; kept for a casadi without buffers)
        return [ca.DM(1 if self.owner.report_iteration(
            {k: np.asarray(arg[_OUT.index(k)], dtype=float).ravel() for k in ("x", "f", "g")}) else 0)]

    def has_eval_buffer(self):
        return True

    def eval_buffer(self, arg, res):
        """The iterate read from casadi's buffers without copies (a DM per output and its
        conversion to numpy cost about 1 ms per iteration at 4,000 variables)."""
        it = {k: np.frombuffer(arg[_OUT.index(k)], dtype=float) if arg[_OUT.index(k)] is not None
              else np.zeros(0) for k in ("x", "f", "g")}
        np.frombuffer(res[0], dtype=float)[0] = 1.0 if self.owner.report_iteration(it) else 0.0
        return 0


_OUT = ca.nlpsol_out()     # the names of IPOPT's outputs, the callback's inputs



class IpoptPasses:
    """IPOPT solves of one problem's NLPs, reporting every iterate to the call's :class:`SolveMonitor`.

    ``ctx`` supplies the NLP without inequalities (its NLP cache), the current term parameters
    (its registry), the last solution (its solve state, for warm starts) and the options.
    """

    def __init__(self, ctx: SolveContext, frames: np.ndarray, *, limit: int):
        opts = ctx.options
        self.ctx, self.monitor, self.frames = ctx, ctx.monitor, frames
        self.limit, self.tol, self.verbose, self.options = limit, opts.tol, opts.verbose, opts.ipopt_options
        self.active: Built | None = None
        self.build_seconds = 0.0
        self.last: IpoptRun | None = None      # the last run (its bound multipliers for a warm start)

    # ------------------------------------------------------------------ iteration reports
    def report(self, it: dict) -> bool:
        """One IPOPT iterate, ``it`` the arrays ``"x"``, ``"f"`` and ``"g"`` (views into
        casadi's buffers, valid during the call); True stops IPOPT."""
        b = self.active
        x, g = it["x"], it["g"]
        inf = float(np.max(_bound_violation(g, b.lbg, b.ubg))) if g.size else 0.0
        # the objective of eq. (9): without the elastic penalty (0 where every constraint holds)
        f = float(it["f"][0]) - b.penalty(x, self.p)
        stop = self.monitor.iterate(b.unpack(x, self.frames), f, inf)
        if isinstance(b.hess_lag, ProjectedHessian):   # projected first, exact after
            b.hess_lag.project = self.monitor.phase_iteration < PROJECTED_ITERATIONS
        return stop

    # ------------------------------------------------------------------ solvers
    def solver(self, b: Built, warm: bool | str, x0: np.ndarray, p: np.ndarray):
        """The (cached) IPOPT solver of ``b``; the cold and the warm-start variant are built together.

        ``warm``: False (cold), True (warm: a certification, a working-set pass) or a key of
        :data:`RESOLVE_OPTIONS` (the designer's re-solve, see :meth:`IpoptPasses._resolve_variant`).
        ``x0``, ``p``: the start of the first solve, where IPOPT's first Hessian
        regularization is estimated (see :func:`_hessian_shift`).
        """
        max_iter, tol, verbose, options = self.limit, self.tol, self.verbose, self.options
        key = (warm, max_iter, tol, verbose, tuple(sorted((options or {}).items())))
        if key in b.solvers:
            return b.solvers[key][0]
        t0 = time.perf_counter()
        if b.n_g and not warm:
            self.solver(b, True, x0, p)
        # the callback outlives this solve (the solver is cached): it reports to the problem's
        # solve state, which forwards to the passes of the solve in progress
        cb = _IterationCallback(f"cb{len(b.solvers)}", b.n_var, b.n_g, b.n_par, self.ctx.state)
        ip = {"linear_solver": "mumps", "print_level": 5 if verbose else 0, "sb": "yes",
              "max_iter": int(max_iter), "tol": float(tol), "acceptable_tol": 10 * float(tol),
              "acceptable_iter": 10, "mu_strategy": "adaptive", "mumps_pivot_order": 5,
              "constr_viol_tol": 1e-9, "acceptable_constr_viol_tol": 1e-7,
              # energies are means over elements: scale to sums so the KKT tolerance is per vertex
              "obj_scaling_factor": float(max(b.n_vertices, 1)),
              # Hessian regularization: the start is estimated (_hessian_shift); where that
              # fails or later, the regularization needed is O(weight) with per-vertex
              # scaling, so search from 1 in steps of 3 (not 1e-4 in steps of 100): fewer
              # trial factorizations, less over-damped steps
              "first_hessian_perturbation": 1.0, "perturb_inc_fact_first": 3.0}
        if warm:
            ip.update({"warm_start_init_point": "yes", "mu_init": 1e-6, **_push(1e-9)})
        if warm in RESOLVE_OPTIONS:
            ip.update(RESOLVE_OPTIONS[warm])
        ip.update(options or {})
        if "first_hessian_perturbation" not in (options or {}):
            # the estimate is in IPOPT's scaled units: one per objective scaling
            skey = tuple(ip.get(k) for k in _SCALING_OPTIONS)
            if skey not in b.hessian_shifts:
                b.hessian_shifts[skey] = _hessian_shift(b, x0, p, ip)
            if b.hessian_shifts[skey] > 0:
                ip["first_hessian_perturbation"] = b.hessian_shifts[skey]
        # no nlp_grad (casadi's symbolic gradient of the Lagrangian, for multipliers it would
        # recompute): IPOPT returns x, f, g and the multipliers itself, and the element
        # values may then be compiled kernels, which casadi cannot differentiate
        opts = {"ipopt": ip, "print_time": bool(verbose), "grad_f": b.grad_f, "jac_g": b.jac_g,
                "hess_lag": b.hess_lag, "iteration_callback": cb, "error_on_fail": False,
                "calc_lam_p": False, "calc_lam_x": False, "calc_f": False, "calc_g": False,
                "no_nlp_grad": True}
        s = ca.nlpsol("congruence", "ipopt", {"x": b.x, "p": b.p, "f": b.f_expr, "g": b.g_expr}, opts)
        b.solvers[key] = (s, cb)
        self.build_seconds += time.perf_counter() - t0
        return s

    def call(self, s, b: Built, args: dict, cap: int | None) -> IpoptRun:
        """One IPOPT run with at most ``cap`` iterations."""
        self.active, self.p = b, args["p"]
        lbx, ubx = b.variable_bounds(self.ctx.registry.current())
        if b.n_slack:   # slacks just large enough for the start (elastic form, see Built._elastic)
            args = {**args, "x0": b.with_slacks(args["x0"], args["p"]), "lbx": lbx, "ubx": ubx}
        else:           # lifted variables from the directions (a start from another NLP: its directions)
            args = {**args, "x0": b.full(args["x0"], args["p"]), "lbx": lbx, "ubx": ubx}
        self.monitor.start_pass(cap)
        if isinstance(b.hess_lag, ProjectedHessian):
            b.hess_lag.project = True
        # numpy's BLAS threads (the iteration reports' and the projected Hessian's small
        # products) spin between calls: measured on row 7c, 26 s of system time per 28 s solve
        # with two threads, 3 s with one, same wall time on an idle machine; on a busy one
        # the spinning thread takes a core from other work
        with _one_blas_thread():
            r = s(**args)
        stats = s.stats()
        capped = self.monitor.capped
        self.monitor.cap = None
        status = "Maximum_Iterations_Exceeded" if capped else str(stats.get("return_status", "unknown"))
        self.last = IpoptRun(np.asarray(r["x"]).ravel(), np.asarray(r["lam_g"]).ravel(),
                             int(stats.get("iter_count", 0)), status,
                             bool(stats.get("success", False)) and not capped, np.asarray(r["lam_x"]).ravel())
        return self.last


    def solve(self, b: Built, mode: str, warm: bool, lam_g0, x0, p, try_unconstrained: bool, *,
              handover: bool = False, lam_x0: np.ndarray | None = None) -> PassOutcome:
        """IPOPT in up to three passes (see ``try_unconstrained`` of ``CongruenceProblem.solve``).

        1. without the inequality constraints; kept if it meets them;
        2. with only the inequalities that pass 1 violates or nearly meets (the working set),
           from pass 1's answer, growing the set while the answer violates others;
        3. with all of them, from the start.

        ``handover``: where pass 1 converged but misses an inequality, stop there (passes 2
        and 3 are left to the augmented Lagrangian, ``solver="auto"``). ``lam_x0``: the last
        solve's bound multipliers for a warm pass 3 (a lifted form's bounds ``r >= s``,
        ``|t| <= 1``: without them IPOPT starts with the bound multipliers at 0, so its first
        step repairs the dual infeasibility that leaves, 1 to 2 iterations on row 7d).
        """
        limit, ctx = self.limit, self.ctx

        def cold():
            # the cold solver of b, built (with its warm-start variant) when a pass needs it:
            # not when pass 1 answers (row 11: two nlpsol and a Hessian estimate saved)
            return self.solver(b, False, x0, p)

        sw = self.solver(b, True, x0, p) if warm else None
        ineq = b.inequality_rows
        feas_tol = float((self.options or {}).get("constr_viol_tol", 1e-9))
        last = ctx.state.last
        prev_ws = last.working if warm and last is not None else None
        iters, status = 0, ""
        if warm and prev_ws is not None and prev_ws.size == b.n_g:
            # the designer's re-solve after a working-set solve: same set, warm multipliers
            out = working_set_pass(self, sw, cold(), b, x0, p, prev_ws, lam_g0, max(limit // 2, 1), feas_tol)
            if out.converged or self._stopped(out.status):
                return out
            iters, status = out.iterations, out.status
            warm = False     # fall back to all constraints, cold, from the same start
        elif try_unconstrained and ineq.any() and not (warm and last is not None and last.active):
            bf, extra = ctx.nlp.without_inequalities(mode)
            pf = bf.parameters(ctx.registry.current(), self.frames)
            self.build_seconds += extra
            s1 = self.solver(bf, False, x0, pf)
            r1 = self.call(s1, bf, dict(x0=x0, p=pf, lbg=bf.lbg, ubg=bf.ubg), max(limit // 2, 1))
            iters, status = r1.iterations, r1.status
            if self._stopped(status):
                return PassOutcome(r1.x, None, iters, status, False, None, None)
            g1 = np.asarray(b.evaluate(r1.x, p)[2]).ravel()
            viol = _bound_violation(g1, b.lbg, b.ubg) > feas_tol
            if r1.converged and not viol.any():
                return PassOutcome(r1.x, None, iters, status, True, False, None)
            if r1.converged and handover:
                return PassOutcome(r1.x, None, iters, status, False, None, None, handed_over=True)
            # (not with lifted forms: their rows tie the lifted variables to the directions)
            if r1.converged and not b.n_lift and viol[ineq].mean() <= _WORKING_SET_MAX_SHARE:
                g1 = np.asarray(b.evaluate(r1.x, p)[2]).ravel()
                viol = _bound_violation(g1, b.lbg, b.ubg) > feas_tol
                ws = _near_bounds(g1, b) | viol | ~ineq
                s = cold()
                out = working_set_pass(self, s, s, b, r1.x, p, ws, None, (limit - iters) // 2, feas_tol)
                iters += out.iterations
                if out.converged or self._stopped(out.status):
                    return out._replace(iterations=iters)
                status = out.status
            if r1.converged and (b.n_slack or b.n_lift or _violated_count(b, r1.x, p) < _violated_count(b, x0, p)):
                # pass 3 starts where fewer constraints are violated: a flat facade's normals
                # are a line bundle (the apex g = 0 of every torsal-angle cone, where each
                # constraint is stationary), the energies' answer usually is not. In the
                # elastic form every start is feasible, in the lifted form every start meets
                # the inequalities (bounds on the lifted variables; only the equality rows
                # are off): start from the energies' optimum (row 7c, lifted: converged in
                # 358 iterations from there, with the chart re-centred; not in 500 from the start)
                x0 = r1.x
            warm = False
        if not warm:
            x0, p = self._recentre(b, x0, p)
        args = dict(x0=x0, p=p, lbg=b.lbg, ubg=b.ubg)
        s = cold()
        if warm:
            lam_x0 = lam_x0 if lam_x0 is not None and lam_x0.size == b.n_var else np.zeros(b.n_var)
            args.update(x0=b.full(x0, p), lam_g0=lam_g0, lam_x0=lam_x0)
            s = self.solver(b, self._resolve_variant(b, args), x0, p)
        r = self.call(s, b, args, (limit - iters) if iters else None)
        return PassOutcome(r.x, r.lam_g, iters + r.iterations, r.status, r.converged,
                           True if ineq.any() else None, None)

    def _resolve_variant(self, b: Built, args: dict) -> str:
        """``"near"`` where the warm start (all variables and multipliers in ``args``) is within
        :data:`NEAR_KKT` times the tolerance of stationarity, else ``"far"`` (see
        :data:`RESOLVE_OPTIONS`). The residual is IPOPT's dual infeasibility of the objective
        scaled per vertex, ``|V| max |grad f + J^T lam_g + lam_x|`` (without IPOPT's
        gradient-based scaling, which only lowers it): a weight, a stroke or a bound changed
        by a little leaves it near (Fig. 12 row 7d, light weights x1.2: 4e-4), the sun
        turned by 5 degrees far (3.8)."""
        grad, jac = b.derivatives(args["x0"], args["p"])
        r = grad + jac.T @ np.asarray(args["lam_g0"], dtype=float) + args["lam_x0"]
        residual = max(b.n_vertices, 1) * float(np.max(np.abs(r), initial=0.0))
        return "near" if residual <= NEAR_KKT * self.tol else "far"

    def _recentre(self, b: Built, x: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The gnomonic chart re-centred at ``x`` (tangent mode): frames at its directions, ``z = 0``.

        A pass that starts where another ended (pass 3 from pass 1's answer) would otherwise
        start far out in the chart of the solve's start: ``de/dz ~ 1 / (1 + |z|^2)``, so at
        lines turned by 60 to 80 degrees the Newton system is scaled by 1e-1 to 1e-3 there.
        """
        if b.mode != "tangent" or not np.any(np.asarray(x).ravel()[:b.n_dir]):
            return x, p
        e = b.unpack(x, self.frames)
        x, self.frames = b.pack(e)
        p = np.array(p, dtype=float)
        p[:b.n_frames] = self.frames.ravel()
        return x, p

    def warm_pass(self, b: Built, x: np.ndarray, p: np.ndarray, lam_g: np.ndarray, cap: int) -> PassOutcome:
        """All constraints, warm-started at ``x`` with multipliers ``lam_g`` (the certification of
        the augmented Lagrangian's answer, :mod:`.solve`)."""
        sw = self.solver(b, True, x, p)
        r = self.call(sw, b, dict(x0=x, p=p, lbg=b.lbg, ubg=b.ubg, lam_g0=lam_g, lam_x0=np.zeros(b.n_var)), cap)
        return PassOutcome(r.x, r.lam_g, r.iterations, r.status, r.converged, True, None)

    def _stopped(self, status: str) -> bool:
        """The monitor stopped IPOPT (the user's callback or the time limit), not a cap."""
        return status == "User_Requested_Stop" and (self.monitor.stopped_by_user or self.monitor.timed_out)

    def __enter__(self) -> "IpoptPasses":
        """The passes in progress: the cached solvers' callbacks report to them."""
        self.ctx.state.ipopt = self
        return self

    def __exit__(self, *exc) -> None:
        self.ctx.state.ipopt = None

    def bound_multipliers(self, b: Built, lam_g) -> np.ndarray | None:
        """The bound multipliers of the IPOPT run that gave the answer (the last run, on ``b``),
        or None where no multipliers are kept (pass 1's answer: ``lam_g`` None)."""
        last = self.last
        if lam_g is None or last is None or last.lam_x is None or last.lam_x.size != b.n_var:
            return None
        return last.lam_x


class IpoptSolve:
    """The strategy ``solver="ipopt"``: IPOPT in its passes (:meth:`IpoptPasses.solve`).

    ``handover``: where pass 1 (no inequalities) misses one, stop there with the run marked
    ``handed_over``, for the augmented Lagrangian to continue (``"auto"``'s ``ipopt+alm``)."""

    kind = NlpKind.IPOPT

    def __init__(self, *, handover: bool = False):
        self.handover = handover

    def solve(self, ctx: SolveContext, start: Start) -> Run:
        t0 = time.perf_counter()
        b, opts = start.b, ctx.options
        with IpoptPasses(ctx, start.frames, limit=opts.max_iter or IPOPT_MAX_ITER) as passes:
            out = passes.solve(b, ctx.nlp.mode(NlpKind.IPOPT), start.warm, start.lam_g0, start.x0, start.p,
                               opts.try_unconstrained, handover=self.handover, lam_x0=start.lam_x0)
        s = time.perf_counter() - t0 - passes.build_seconds
        return Run(x=out.x, lam_g=out.lam_g, iterations=out.iterations, status=out.status, ok=out.converged,
                   active=out.constraints_active, working=out.working, frames=passes.frames,
                   build_seconds=passes.build_seconds, solve_seconds=s, b=b, solver="ipopt", timings={"ipopt": s},
                   lam_x=passes.bound_multipliers(b, out.lam_g), handed_over=out.handed_over)


def rescues(ctx: SolveContext, previous: Run) -> bool:
    """IPOPT continues an answer that is not converged (``"auto"``), rather than certifying one."""
    return ctx.options.solver == "auto" and not previous.ok


class IpoptWarm:
    """The strategy that continues another's answer (``Start.previous``, the augmented
    Lagrangian's): IPOPT with all constraints, warm from its directions and multipliers.

    A certification (at most :data:`CERTIFY_ITERATIONS`), or where ``"auto"``'s augmented
    Lagrangian did not converge (:func:`rescues`) a continuation with what is left of
    ``max_iter`` (at least :data:`RESCUE_MIN_ITERATIONS`)."""

    kind = NlpKind.IPOPT

    def solve(self, ctx: SolveContext, start: Start) -> Run:
        t0 = time.perf_counter()
        prev, b, first = start.previous, start.b, ctx.monitor.iteration
        cap = (max((ctx.options.max_iter or ALM_MAX_STEPS) - prev.iterations, RESCUE_MIN_ITERATIONS)
               if rescues(ctx, prev) else CERTIFY_ITERATIONS)
        with IpoptPasses(ctx, start.frames, limit=cap) as passes:
            out = passes.warm_pass(b, start.x0, start.p, prev.lam_g, cap)
        s = time.perf_counter() - t0 - passes.build_seconds
        return Run(x=out.x, lam_g=out.lam_g, iterations=out.iterations, status=out.status, ok=out.converged,
                   active=True, working=None, frames=start.frames, build_seconds=passes.build_seconds,
                   solve_seconds=s, b=b, solver="ipopt", timings={"ipopt": s},
                   lam_x=passes.bound_multipliers(b, out.lam_g), first_iteration=first)

def _push(v: float) -> dict:
    """IPOPT's warm-start pushes of the iterate and the bound multipliers off their bounds."""
    return {k: v for k in ("warm_start_bound_push", "warm_start_bound_frac", "warm_start_slack_bound_push",
                           "warm_start_slack_bound_frac", "warm_start_mult_bound_push")}


#: IPOPT's options of the designer's re-solve from the last optimum (pass 3, warm), on top of
#: the warm start's. Both stop at IPOPT's acceptable constraint violation (1e-7, not 1e-9): a
#: start at a KKT point takes its Newton steps, then spent one or two more on the last digits
#: of the lifted rows (row 7d, light weights x1.2: 4 -> 2 iterations), far below what the
#: answer is measured at (0.1 degree; the warm answer is measured on the geometry like any
#: other). "far" (the start is not near stationarity, :meth:`IpoptPasses._resolve_variant`):
#: the iterate and the bound multipliers pushed 1e-4 off their bounds, not 1e-9, so the
#: active set can change without the fraction-to-boundary rule cutting every step (row 7d,
#: the sun turned by 5 degrees: 51 -> 20 iterations, a cold solve of the changed problem 51).
#: "near" orders the KKT matrix by QAMD, not METIS: each solve analyses the matrix afresh and a
#: re-solve near its answer factors it only a few times (row 7d, 2 iterations: analysis 31-39
#: -> 3 ms of processor time, the factorizations no slower, the same iterates).
RESOLVE_OPTIONS = {"near": {"constr_viol_tol": 1e-7, "mumps_pivot_order": 6},
                   "far": {"constr_viol_tol": 1e-7, **_push(1e-4)}}

#: a warm start within this many times ``tol`` of stationarity is "near" (see RESOLVE_OPTIONS)
NEAR_KKT = 100.0


_CONTROLLER: ThreadpoolController | None = None


def _one_blas_thread():
    """A context with numpy's BLAS on one thread. The libraries are scanned once per process
    (``threadpool_limits`` scans every loaded library at each call: 8 ms of a 7a re-solve's
    50 ms of processor time)."""
    global _CONTROLLER
    if _CONTROLLER is None:
        _CONTROLLER = ThreadpoolController()
    return _CONTROLLER.limit(limits=1, user_api="blas")


def _violated_count(b: Built, x: np.ndarray, p: np.ndarray, feas_tol: float = 1e-9) -> int:
    """How many constraint rows of ``b`` the point ``x`` violates."""
    g = np.asarray(b.evaluate(x, p)[2]).ravel()
    return int((_bound_violation(g, b.lbg, b.ubg) > feas_tol).sum())


_SCALING_OPTIONS = ("obj_scaling_factor", "nlp_scaling_method", "nlp_scaling_max_gradient",
                    "nlp_scaling_min_value")


#: ARPACK restarts of the estimate in :func:`_hessian_shift` (20 Lanczos vectors each): an
#: indefinite W at the start converged in about 30 (620 products at 20k variables, row 11)
_EIGSH_RESTARTS = 40


def _hessian_shift(b: Built, x0: np.ndarray, p: np.ndarray, ip: dict) -> float:
    """First Hessian regularization for IPOPT: 1.25 times the most negative eigenvalue (internal).

    IPOPT makes the Lagrangian Hessian ``W`` of the scaled problem positive definite on the
    search space by factoring ``W + delta I`` for ``delta = 0``, then
    ``first_hessian_perturbation``, then growing by ``perturb_inc_fact_first`` until the
    inertia is right; each trial is a full factorization. Far from the optimum the sphere
    makes ``W`` indefinite (``<e, d>^2`` curves down along the circle around ``d``) with a
    most negative eigenvalue of the order of the weights. A few Lanczos steps (scipy
    ``eigsh``, about 1 % of a factorization) estimate it at the start, so the first
    nonzero trial succeeds instead of the third to fifth, and the damping is not
    overshot. The objective Hessian is scaled as IPOPT scales the objective
    (``obj_scaling_factor`` times the gradient-based factor). Returns 0 when ``W`` is
    positive semidefinite at ``x0`` or the estimate fails (IPOPT then searches as usual).
    """
    from scipy.sparse.linalg import eigsh

    if b.n_var == 0 or b.psd:    # nothing to estimate (the Lanczos search would not converge)
        return 0.0
    try:
        x0 = b.full(x0, p)       # with the lifted variables, if any
        scale = float(ip.get("obj_scaling_factor", 1.0))
        if ip.get("nlp_scaling_method", "gradient-based") == "gradient-based":
            g = np.asarray(b.grad_f(x0, p)[1]).ravel()
            gmax = float(np.max(np.abs(g))) if g.size else 0.0
            limit = float(ip.get("nlp_scaling_max_gradient", 100.0))
            if gmax > limit:
                scale *= max(limit / gmax, float(ip.get("nlp_scaling_min_value", 1e-8)))
        h = b.hess_lag(x0, p, scale, np.zeros(b.n_g)).sparse()      # upper triangle
        h = (h + sp.triu(h, 1).T).tocsc()
        if b.n_var <= 200:
            lam = float(np.linalg.eigvalsh(h.toarray())[0])
        else:
            v0 = np.random.default_rng(0).standard_normal(b.n_var)    # same start, same result
            # a bounded number of restarts: on a (nearly) positive semidefinite W the smallest
            # eigenvalue is clustered at 0 and ARPACK would restart up to 20 n times (measured:
            # > 20 min at 20k variables); past the cap IPOPT searches as usual
            lam = float(eigsh(h, k=1, which="SA", tol=5e-2, maxiter=_EIGSH_RESTARTS, v0=v0,
                              return_eigenvectors=False)[0])
    except (RuntimeError, ValueError):   # ArpackError (no convergence), LinAlgError, NaN at x0
        return 0.0
    return 1.25 * -lam if np.isfinite(lam) and lam < 0 else 0.0

