"""One call of :meth:`~torsal.geometry.optimize.CongruenceProblem.solve`: route, start, run, measure.

:class:`SolveCall` holds the options of one call (:class:`SolveOptions`), picks the route
(:func:`route`), composes its strategy (:func:`strategy_of`; every strategy is a
:class:`~torsal.geometry.optimize.strategy.SolveStrategy`, each in its own module):

- :mod:`.alm`: the augmented Lagrangian with projected-Newton steps (``solver="alm"``);
- :mod:`.ipopt` (with pass 2 in :mod:`.working_set`): IPOPT, the solver of record
  (``solver="ipopt"``), also the certifier of the augmented Lagrangian's answer
  (``certify=True``);
- :mod:`.lbfgs`: the paper's L-BFGS baseline (``solver="lbfgs"``).

``solver="auto"`` (the default) takes the augmented Lagrangian where the NLP has inequality
rows other than hyperbolicity (torsal-angle bounds, angles to lines, custom rows) and it can
solve it (tangent chart, no lifted variables or slacks), IPOPT otherwise (no such rows:
IPOPT's pass without inequalities answers most such designs at the paper's T). Where that
pass misses an inequality, the augmented Lagrangian continues from its answer (``solver`` of
the result ``"ipopt+alm"``) instead of IPOPT's working-set and all-constraint passes; if the
augmented Lagrangian ends without a measured-feasible answer, IPOPT continues from it with all
constraints. Those combined routes are compositions (:class:`~.strategy.Then`). Whatever runs,
the answer is measured on the geometry (:mod:`.measure`) before it is returned.
"""
from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from ..congruence import Congruence
from .alm import ALM_MAX_STEPS, AlmStrategy
from .cache import Hessian, NlpCache
from .factor import limit_mumps_threads
from .history import SolveMonitor
from .ipopt import CERTIFY_ITERATIONS, IpoptSolve, IpoptWarm, rescues
from .lbfgs import LbfgsStrategy
from .measure import worst_missed
from .nlp import _renormalize
from .registry import Normalize, TermRegistry
from .result import Convergence, OptimizationError, OptimizationResult, Stop, StopReason
from .strategy import (SOLVERS, Optimum, Run, SolveContext, SolveOptions, Solver, SolveState, SolveStrategy,
                       Start, Then)
from .working_set import _working_ids

__all__ = ["SolveCall", "SolveOptions", "Optimum", "Solver", "SOLVERS", "route", "alm_unsupported",
           "strategy_of", "off_the_apex", "ALM_MAX_STEPS", "CERTIFY_ITERATIONS", "COLLAPSE_SHARE"]

#: "guarded": a Gauss-Newton answer with more faces without torsal directions than the start,
#: by more than this share of the faces, counts as collapsed (re-solved with the exact Hessian)
COLLAPSE_SHARE = 0.02


def route(registry: TermRegistry, nlp: NlpCache, solver: str) -> Solver:
    """The first strategy of ``solve(solver=...)``: ALM, IPOPT or LBFGS (see the module docstring)."""
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")
    solver = Solver(solver)
    if solver in (Solver.IPOPT, Solver.LBFGS):
        return solver
    why = alm_unsupported(registry, nlp)
    if solver is Solver.ALM and why:
        raise ValueError(f"solver='alm' cannot solve this problem: {why}; use solver='ipopt'")
    if solver is Solver.AUTO:
        # hyperbolicity alone (Fig. 12 rows 7a, 7b, 10, 11, 13) is inactive almost everywhere,
        # and IPOPT's pass without inequalities answers rows 7a, 7b and 11 as the unconstrained
        # problems they are (row 11: the augmented Lagrangian is 10 times slower; 7a: it drives
        # the zero-residual energies to 1e-16, where the torsal directions of 16 faces nearly
        # merge, against IPOPT's 2 at 1e-10); row 13, where that pass misses hyperbolicity, is
        # continued by the augmented Lagrangian (benchmarks/optimize_bench.py)
        return Solver.ALM if registry.has_bounding_rows(nlp.normalize) and not why else Solver.IPOPT
    return Solver.ALM


def alm_unsupported(registry: TermRegistry, nlp: NlpCache) -> str | None:
    """Why the augmented Lagrangian cannot solve the problem, or None."""
    if nlp.normalize != Normalize.TANGENT:
        return f"normalize={nlp.normalize!r} (it works in the tangent chart)"
    if nlp.elastic:
        return "elastic slacks"
    if any(t.lift for t in registry.terms.values()):
        return "a lifted min_torsal_angle form (bounds on lifted variables)"
    return None


def _hyperbolic_margin(registry: TermRegistry) -> bool:
    """``hyperbolic(margin > 0)``: a face at a line bundle has ``c_hyp = 0`` with zero gradient,
    so the augmented Lagrangian's steps cannot lift it to the margin (measured: 500 Newton
    steps without converging on a 1e-6 and a 2e-3 margin); IPOPT's passes keep those designs."""
    return any(t.kind == "hyperbolicity" and t.bound > 0 for t in registry.terms.values())


# ---------------------------------------------------------------------- the compositions
def _alm_then_ipopt(ctx: SolveContext, run: Run) -> bool:
    """IPOPT certifies the augmented Lagrangian's answer (``certify``) or continues it where it
    did not converge (``"auto"``: so that "auto" ends at a KKT point whenever one is in reach)."""
    return ctx.options.certify or rescues(ctx, run)


def _certified(ctx: SolveContext, alm: Run, ip: Run) -> Run:
    """The augmented Lagrangian's run followed by IPOPT's warm one (:class:`IpoptWarm`)."""
    rescue = rescues(ctx, alm)
    timings = {**alm.timings, "ipopt": ip.solve_seconds}
    build_s = alm.build_seconds + ip.build_seconds
    ok_ip = ip.ok and ctx.feasible(ip.directions)
    if not ok_ip and not rescue:
        # the report says IPOPT did not certify the augmented Lagrangian's answer; where
        # IPOPT's iterates went lower while feasible as measured, that answer was no local
        # minimum (row 9: 0.01777 -> 0.01736 in 100 iterations) and the lowest of them is
        # the better design
        status = alm.status + f"; IPOPT did not certify it ({ip.status}, {ip.iterations} iterations)"
        best = ctx.monitor.best             # IPOPT's when numbered after the ALM's iterates
        f_alm = ctx.nlp.objective(alm.alm.e) if best is not None and best.iteration > ip.first_iteration else None
        if f_alm is not None and best.objective < f_alm - 1e-9 * max(abs(f_alm), 1e-300):
            x, frames = alm.b.pack(best.directions)
            status += (f" but lowered the objective from {f_alm:.6g} to {best.objective:.6g}, "
                       f"feasible as measured: its best feasible iterate (iteration {best.iteration})")
            alm = alm._replace(x=x, frames=frames, lam_g=None, solver="alm+ipopt")   # IPOPT's design
        return alm._replace(status=status, iterations=alm.iterations + ip.iterations, build_seconds=build_s,
                            timings=timings)
    how = "certified by IPOPT" if not rescue else "continued by IPOPT"
    return ip._replace(iterations=alm.iterations + ip.iterations,
                       status=f"{alm.status}; {how}: {ip.status} ({ip.iterations} iterations)",
                       build_seconds=build_s, solve_seconds=alm.solve_seconds + ip.solve_seconds, alm=alm.alm,
                       solver="alm+ipopt", timings=timings)


def _handed_over(ctx: SolveContext, run: Run) -> bool:
    """IPOPT's pass 1 converged but missed an inequality and stopped for the augmented Lagrangian."""
    return run.handed_over


def _after_pass1(ctx: SolveContext, pass1: Run, alm: Run) -> Run:
    """IPOPT's pass 1 followed by the augmented Lagrangian from its answer (the energies'
    optimum, which misses some inequalities), as the answer on IPOPT's NLP.

    IPOPT's working-set pass carries barrier terms on every face near its bound: on Fig. 12
    row 13 (hyperbolicity binds on about 2 % of the faces, 18 % in the working set) it took
    78 iterations against the augmented Lagrangian's 8 Newton steps (benchmarks/optimize_bench.py)."""
    return alm.on(pass1.b)._replace(
        iterations=pass1.iterations + alm.iterations,
        status=f"IPOPT without inequalities: {pass1.status} ({pass1.iterations} iterations), "
               f"missed some; augmented Lagrangian: {alm.status}",
        build_seconds=pass1.build_seconds + alm.build_seconds,
        solve_seconds=pass1.solve_seconds + alm.solve_seconds,
        solver="ipopt+" + alm.solver, timings={"ipopt pass 1": pass1.solve_seconds, **(alm.timings or {})})


def strategy_of(first: Solver, registry: TermRegistry, nlp: NlpCache, options: SolveOptions) -> SolveStrategy:
    """The strategy of a route: ``first`` alone, or composed with the one that continues it."""
    alm = Then(AlmStrategy(), IpoptWarm(), when=_alm_then_ipopt, combine=_certified)
    if first is Solver.ALM:
        return alm
    if first is Solver.LBFGS:
        return LbfgsStrategy()
    handover = (options.solver == Solver.AUTO and alm_unsupported(registry, nlp) is None
                and not _hyperbolic_margin(registry))
    if not handover:
        return IpoptSolve()
    return Then(IpoptSolve(handover=True), alm, when=_handed_over, combine=_after_pass1)


# ---------------------------------------------------------------------- the start
def off_the_apex(registry: TermRegistry, e: np.ndarray) -> np.ndarray:
    """The start ``e`` (N, 3) moved off the line-bundle apex where a torsal-angle bound needs it.

    A flat facade's normals (or any parallel lines) are a line bundle on every face: the
    apex ``g = 0`` of every torsal-angle cone, where each constraint is stationary, so no
    Newton or interior-point method can find a direction out. When most faces of a
    ``min_torsal_angle`` constraint start weaker than 4 times its strength floor ``s``,
    the start gets a saddle twist ``e_i + 4 s (x_i t1 - y_i t2)`` (``t1``, ``t2`` the
    principal axes of mesh A, ``x, y`` in units of ``delta``): the normal congruence of
    a saddle, torsal directions 90 degrees apart, strength about ``4 s`` per edge.
    """
    terms = [t for t in registry.terms.values() if t.kind == "torsal_angle" and t.block == 0]
    if not terms:
        return e
    s = max(float(t.par[0, 1]) for t in terms)
    c = registry.blocks[0]
    n = len(c.vertices)
    cong = Congruence(c.vertices, c.faces, e[:n])
    faces = np.unique(np.concatenate([t.elements for t in terms]))
    if np.mean(cong.bundle_deviation()[faces] < 4 * s) < 0.5:
        return e
    v = c.vertices - c.vertices.mean(axis=0)
    axes = np.linalg.svd(v, full_matrices=False)[2]
    x, y = (v @ axes[0]) / registry.delta, (v @ axes[1]) / registry.delta
    twisted = e[:n] + 4 * s * (x[:, None] * axes[0] - y[:, None] * axes[1])
    twisted /= np.linalg.norm(twisted, axis=1, keepdims=True)
    return np.concatenate([twisted, e[n:]])


class SolveCall:
    """One :meth:`CongruenceProblem.solve` call: build, start, run a strategy, measure, package.

    Parameters
    ----------
    registry, nlp, state
        The problem's terms, NLP cache and solve state (the call reads and updates the state).
    options : SolveOptions
    """

    def __init__(self, registry: TermRegistry, nlp: NlpCache, state: SolveState, options: SolveOptions):
        self.registry, self.nlp, self.state, self.opts = registry, nlp, state, options

    def run(self) -> OptimizationResult:
        reg, nlp, opts = self.registry, self.nlp, self.opts
        t_call, c_call = time.perf_counter(), time.process_time()
        limit_mumps_threads()
        first = route(reg, nlp, opts.solver)
        if first is Solver.IPOPT and self._resumes_alm():
            first = Solver.ALM     # a re-solve continues with the strategy whose state it keeps
        strategy = strategy_of(first, reg, nlp, opts)
        # energies and constraints are evaluated with this NLP where IPOPT's is not built
        # (NlpCache.main: the same values); a certifying IPOPT pass builds its own on demand
        b, build_s = nlp.get(strategy.kind)
        tols = opts.tolerances

        def worst(e):
            m = nlp.measure(e, **tols).values()
            return max((x.worst / x.tolerance if x.tolerance > 0 else x.worst for x in m), default=0.0)

        monitor = SolveMonitor(worst, opts.callback, opts.max_seconds, t0=t_call)
        monitor.cpu0 = c_call
        ctx = SolveContext(reg, nlp, self.state, opts, monitor)
        start = self._start(first, b)
        run = strategy.solve(ctx, start)
        build_s += run.build_seconds
        if monitor.timed_out:
            run = run._replace(status=f"time limit of {opts.max_seconds:g} s reached (the safety net "
                                      "max_seconds: the answer depends on the machine's load)", ok=False)
        e = run.directions
        if nlp.normalize == Normalize.RENORMALIZE or first is Solver.LBFGS:
            e = _renormalize(e.ravel()).reshape(-1, 3)
        finite = bool(np.isfinite(e).all())
        collapsed = (self._collapse(start.e0, e) if finite and first is Solver.IPOPT
                     and nlp.hessian == Hessian.GUARDED and b.hessian == "gauss-newton" else None)
        if collapsed is not None:
            # the Gauss-Newton steps reached a trivial zero of the energies: solve again from
            # the same start with the exact Hessian (kept for this problem's structure)
            nlp.keep_exact(strategy.kind)
            res = SolveCall(reg, nlp, self.state, replace(opts, raise_on_failure=False)).run()
            res = replace(res, iterations=res.iterations + run.iterations,
                          build_seconds=res.build_seconds + build_s,
                          solve_seconds=res.solve_seconds + run.solve_seconds,
                          status=f"Gauss-Newton: {collapsed}; exact Hessian: {res.status}")
        else:
            res = self._package(first, e, run, monitor, before=start.before, build_seconds=build_s)
        if opts.raise_on_failure and not res.success:
            raise OptimizationError(f"congruence optimization failed: {res.status}", res)
        return res

    # ------------------------------------------------------------------ start
    def _resumes_alm(self) -> bool:
        """``"auto"`` re-solves from an answer of the augmented Lagrangian (its multipliers and
        penalties kept): it continues with the augmented Lagrangian."""
        opts, last = self.opts, self.state.last
        return (opts.solver == Solver.AUTO and opts.warm_start and opts.initial is None
                and last is not None and last.alm is not None and alm_unsupported(self.registry, self.nlp) is None)

    def _start(self, first: Solver, b) -> Start:
        """Where the solve starts: ``initial``, the last answer (warm start) or the
        congruence's directions (moved off the line-bundle apex, :func:`off_the_apex`)."""
        reg, opts, last = self.registry, self.opts, self.state.last
        e0, lam_g0, lam_x0, warm, resume = reg.directions(), None, None, False, False
        if opts.initial is not None:
            init = np.asarray(opts.initial, dtype=float)
            if init.size != reg.n_var or not np.isfinite(init).all():
                raise ValueError(f"initial must be a finite ({reg.n_var // 3}, 3) array")
            e0 = init.reshape(-1, 3)
        elif opts.warm_start and last is not None:
            e0, resume = last.directions, True
            lam_g0 = last.lam_g if first is Solver.IPOPT else None
            warm = lam_g0 is not None and lam_g0.size == b.n_g and b.n_g > 0
            lam_x0 = last.lam_x if warm else None
        if not resume and opts.initial is None:
            e0 = off_the_apex(reg, e0)
        before = self.nlp.evaluate(e0, rows=False)[0]
        x0, frames = b.pack(e0)
        p = b.parameters(reg.current(), frames)
        return Start(e0=e0, lam_g0=lam_g0, warm=warm, before=before, x0=x0, frames=frames, p=p, b=b,
                     resume=resume, lam_x0=lam_x0)

    # ------------------------------------------------------------------ the answer
    def _collapse(self, e_start: np.ndarray, e_end: np.ndarray) -> str | None:
        """Why the answer ``e_end`` collapsed compared to ``e_start``, or None (``hessian="guarded"``).

        Collapsed: on some aligned congruence, the faces without torsal directions (elliptic
        faces and bundles, :meth:`Congruence.torsal_angle` NaN) grew by more than
        ``COLLAPSE_SHARE`` of the faces.
        """
        reg = self.registry
        for c0, c1 in zip(reg.congruences(e_start), reg.congruences(e_end)):
            n0, n1 = (int(np.isnan(c.torsal_angle()).sum()) for c in (c0, c1))
            if n1 - n0 > COLLAPSE_SHARE * len(c1.faces):
                return (f"{n1} of {len(c1.faces)} faces without torsal directions (start {n0}), "
                        "collapsed toward a line bundle")
        return None

    def _package(self, first: Solver, e: np.ndarray, run: Run, monitor: SolveMonitor, *,
                 before: dict, build_seconds: float) -> OptimizationResult:
        """The :class:`OptimizationResult` of the answer ``e`` (stacked (N, 3)), measured.

        Falls back to the monitor's best feasible iterate (``keep_best``), writes the misses
        into the status and keeps the answer (and a converged solve's multipliers, the
        augmented Lagrangian's penalties) for a warm start.
        """
        reg, nlp, opts = self.registry, self.nlp, self.opts
        tols = opts.tolerances
        status, ok, lam_g, working = run.status, run.ok, run.lam_g, run.working
        finite = bool(np.isfinite(e).all())
        meas = nlp.measure(e, **tols) if finite else {}
        holds = finite and all(m.holds for m in meas.values())
        from_iteration = None
        best = monitor.best
        if opts.keep_best and best is not None and (not holds or (not ok and best.objective < nlp.objective(e))):
            # stopped early or ended infeasible: the best iterate that held every constraint
            e, from_iteration, lam_g, working = best.directions, best.iteration, None, None
            meas, holds, finite = nlp.measure(e, **tols), True, True
            status += f"; returned the best feasible iterate (iteration {best.iteration})"
        if finite:
            after, fval = nlp.evaluate(e, rows=False)[:2]
        else:
            after, fval = {}, math.nan
            status += "; the solution contains NaN"
        worst_c = worst_missed(meas)
        if not finite:
            worst_c = ("NaN", -1, math.inf)
        elif worst_c is not None:
            m = meas[worst_c[0]]
            status += (f"; constraint {worst_c[0]!r} missed by {worst_c[2]:.3g} {m.unit} (measured) "
                       f"on {len(m.missed)} elements, worst {worst_c[1]}")
        ok = bool(ok and holds and finite)
        if finite:
            congs = reg.congruences(e)
            # multipliers only from a converged solve: a warm start (mu_init 1e-6) from an
            # unconverged iterate's multipliers was slower than a cold one
            self.state.last = Optimum(directions=e, lam_g=lam_g if ok else None, active=run.active,
                                      working=working if ok else None,
                                      lam_x=run.lam_x if ok and lam_g is not None else None,
                                      alm=run.alm.state if run.alm is not None and from_iteration is None else None)
        else:
            congs = list(reg.blocks)
        counts = {"iterations": run.iterations}
        if run.alm is not None:
            counts.update(newton_steps=run.alm.iterations, outer_iterations=run.alm.outer,
                          factorizations=run.alm.factorizations, **{k: v for k, v in run.alm.counts.items()
                                                                    if k != "factorizations"})
        timings = {"build": build_seconds, **(run.timings or {}), "total": time.perf_counter() - monitor.t0}
        return OptimizationResult(congruence=congs[0], success=ok, status=status, iterations=run.iterations,
                                  build_seconds=build_seconds, solve_seconds=run.solve_seconds,
                                  energies_before=before, energies_after=after,
                                  max_violation={k: m.worst for k, m in meas.items()}, worst_constraint=worst_c,
                                  congruences=tuple(congs), solver=run.solver or first.value, objective=float(fval),
                                  constraints_active=run.active,
                                  working_set=None if working is None else _working_ids(run.b, working),
                                  violated={k: m.missed for k, m in meas.items()}, measured=meas,
                                  history=monitor.history, from_iteration=from_iteration,
                                  timings=timings, counts=counts, time_limited=monitor.timed_out,
                                  convergence=_convergence(opts.stop, run, monitor, from_iteration))


def _convergence(stop: Stop, run: Run, monitor: SolveMonitor, from_iteration: int | None) -> Convergence:
    """How the solve of ``run`` ended and how close to converged its answer is (the Newton
    decrement and recent decrease where the augmented Lagrangian answered last, and its answer
    is the result: not an earlier best iterate)."""
    alm = run.alm if run.alm is not None and run.solver.endswith("alm") and from_iteration is None else None
    if monitor.timed_out:
        reason = StopReason.TIME_LIMIT
    elif monitor.stopped_by_user:
        reason = StopReason.CALLBACK
    elif alm is not None:
        reason = alm.reason
    elif run.ok:
        reason = StopReason.CONVERGED
    elif "Maximum_Iterations" in run.status:
        reason = StopReason.ITERATION_LIMIT
    else:
        reason = StopReason.FAILED
    return Convergence(stop=Stop(stop), reason=reason, newton_decrement=None if alm is None else alm.decrement,
                       recent_decrease=None if alm is None else alm.recent_decrease)
