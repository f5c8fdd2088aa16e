"""One call of :meth:`~torsal.geometry.optimize.CongruenceProblem.solve`: route, start, run, measure.

:class:`SolveCall` holds the options of one call (:class:`SolveOptions`) and runs the chosen
strategy, each in its own module:

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
constraints. Whatever runs, the answer is measured on the geometry
(:mod:`.measure`) before it is returned.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace
from enum import Enum
from typing import Callable, NamedTuple

import numpy as np

from ..congruence import Congruence
from .alm import AlmRun, AlmState, AugmentedLagrangian
from .factor import limit_mumps_threads
from .history import SolveMonitor
from .ipopt import IpoptStrategy
from .lbfgs import lbfgs
from .measure import worst_missed
from .nlp import Built, _renormalize
from .result import OptimizationError, OptimizationResult
from .working_set import _working_ids

class Solver(str, Enum):
    """The strategies of :meth:`~torsal.geometry.optimize.CongruenceProblem.solve` (a ``str``
    enum: design files give the value, ``constraints.solver = "alm"``)."""

    AUTO = "auto"
    ALM = "alm"
    IPOPT = "ipopt"
    LBFGS = "lbfgs"


#: the ``solver`` options of :meth:`CongruenceProblem.solve` (the first is the default)
SOLVERS = tuple(s.value for s in Solver)

#: Newton steps of the augmented Lagrangian when ``max_iter`` is not given
ALM_MAX_STEPS = 500

#: IPOPT iterations of a certification (from the augmented Lagrangian's answer, warm)
CERTIFY_ITERATIONS = 100

#: "guarded": a Gauss-Newton answer with more faces without torsal directions than the start,
#: by more than this share of the faces, counts as collapsed (re-solved with the exact Hessian)
COLLAPSE_SHARE = 0.02


@dataclass(frozen=True)
class SolveOptions:
    """The options of one :meth:`CongruenceProblem.solve` call (documented there)."""

    solver: str = SOLVERS[0]
    max_iter: int | None = None
    tol: float = 1e-4
    callback: Callable | None = None
    warm_start: bool = True
    initial: np.ndarray | None = None
    raise_on_failure: bool = False
    verbose: bool = False
    constraint_tol: float = 1e-6
    angle_tol_deg: float = 0.1
    penalty: float = 1e3
    ipopt_options: dict | None = None
    try_unconstrained: bool = True
    max_seconds: float | None = None
    keep_best: bool = True
    certify: bool = False

    @property
    def tolerances(self) -> dict:
        return dict(angle_tol_deg=float(self.angle_tol_deg), constraint_tol=float(self.constraint_tol))


@dataclass(frozen=True)
class Optimum:
    """A solve's answer with what a warm re-solve starts from (picklable; see
    :meth:`~torsal.geometry.optimize.CongruenceProblem.warm_start_from`).

    ``directions`` (N, 3) stacked over the aligned congruences; ``lam_g`` IPOPT's multipliers
    of a converged solve (or None), ``lam_x`` its bound multipliers (a lifted form's bounds;
    or None); ``alm`` the augmented Lagrangian's multipliers,
    penalties and row scales (:class:`~torsal.geometry.optimize.alm.AlmState`, or None);
    ``active`` and ``working`` IPOPT's passes (see ``OptimizationResult``).
    """

    directions: np.ndarray
    lam_g: np.ndarray | None = None
    alm: AlmState | None = None
    active: bool | None = None
    working: np.ndarray | None = None
    lam_x: np.ndarray | None = None


class Start(NamedTuple):
    """Where a solve starts (:meth:`SolveCall._start`)."""

    e0: np.ndarray                  # (N, 3) stacked start directions
    lam_g0: np.ndarray | None       # IPOPT's constraint multipliers of the last solve (warm start)
    warm: bool                      # IPOPT starts warm from ``lam_g0``
    before: dict                    # energies at ``e0``
    x0: np.ndarray                  # ``e0`` packed as the NLP's variables
    frames: np.ndarray              # (n, 9) tangent frames of ``Built.pack`` ((0, 9) if unused)
    p: np.ndarray                   # the NLP's parameters at the start
    resume: bool = False            # starts from the last answer (its multipliers, penalties)
    lam_x0: np.ndarray | None = None  # IPOPT's bound multipliers of the last solve (warm start)


class Run(NamedTuple):
    """How a strategy ran, before its answer is measured."""

    x: np.ndarray                   # the answer as the NLP's variables
    lam_g: np.ndarray | None        # constraint multipliers, IPOPT's convention (None for L-BFGS)
    iterations: int
    status: str
    ok: bool                        # the solver converged
    active: bool | None             # ``OptimizationResult.constraints_active``
    working: np.ndarray | None      # pass 2's working-set mask over ``g``, else None
    frames: np.ndarray              # the frames to unpack ``x`` with
    build_seconds: float            # NLPs built during the run
    solve_seconds: float
    alm: AlmRun | None = None       # the augmented Lagrangian's run (state for a warm re-solve)
    solver: str = ""                # who produced the answer ("alm", "ipopt", "alm+ipopt", ...)
    timings: dict | None = None     # seconds per part
    lam_x: np.ndarray | None = None  # IPOPT's bound multipliers of the answer (None: not IPOPT's)


def route(problem: "CongruenceProblem", solver: str) -> str:
    """The strategy of ``solve(solver=...)`` (see the module docstring)."""
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")
    solver = Solver(solver).value
    if solver in ("ipopt", "lbfgs"):
        return solver
    why = alm_unsupported(problem)
    if solver == "alm" and why:
        raise ValueError(f"solver='alm' cannot solve this problem: {why}; use solver='ipopt'")
    if solver == "auto":
        return "alm" if _has_bounding_rows(problem) and not why else "ipopt"
    return "alm"


def _has_bounding_rows(problem: "CongruenceProblem") -> bool:
    """Inequality rows other than hyperbolicity (a torsal-angle bound, an angle to a line, a
    custom constraint). Hyperbolicity alone (Fig. 12 rows 7a, 7b, 10, 11, 13) is inactive almost
    everywhere, and IPOPT's pass without inequalities answers rows 7a, 7b and 11 as the
    unconstrained problems they are (row 11: the augmented Lagrangian is 10 times slower; 7a:
    it drives the zero-residual energies to 1e-16, where the torsal directions of 16 faces
    nearly merge, against IPOPT's 2 at 1e-10); row 13, where that pass misses hyperbolicity,
    is continued by the augmented Lagrangian (:meth:`SolveCall._continue_with_alm`),
    benchmarks/optimize_bench.py."""
    return any(t.constraint and t.lower < t.upper and t.kind != "hyperbolicity"
               for t in problem._term_list(problem.normalize))


def _hyperbolic_margin(problem: "CongruenceProblem") -> bool:
    """``hyperbolic(margin > 0)``: a face at a line bundle has ``c_hyp = 0`` with zero gradient,
    so the augmented Lagrangian's steps cannot lift it to the margin (measured: 500 Newton
    steps without converging on a 1e-6 and a 2e-3 margin); IPOPT's passes keep those designs."""
    return any(t.kind == "hyperbolicity" and t.bound > 0 for t in problem._terms.values())


def alm_unsupported(problem: "CongruenceProblem") -> str | None:
    """Why the augmented Lagrangian cannot solve ``problem``, or None."""
    if problem.normalize != "tangent":
        return f"normalize={problem.normalize!r} (it works in the tangent chart)"
    if problem.elastic:
        return "elastic slacks"
    if any(t.lift for t in problem._terms.values()):
        return "a lifted min_torsal_angle form (bounds on lifted variables)"
    return None


class SolveCall:
    """One :meth:`CongruenceProblem.solve` call: build, start, run a strategy, measure, package."""

    def __init__(self, problem: "CongruenceProblem", options: SolveOptions):
        self.problem, self.opts = problem, options

    def run(self) -> OptimizationResult:
        problem, opts = self.problem, self.opts
        t_call, c_call = time.perf_counter(), time.process_time()
        limit_mumps_threads()
        solver = route(problem, opts.solver)
        if solver == "ipopt" and self._resumes_alm():
            solver = "alm"     # a re-solve continues with the strategy whose state it keeps
        build_s = problem.build(solver)
        if solver != "alm":
            build_s += problem.build("ipopt")    # the main NLP also evaluates energies and constraints
        b = problem._built[problem._key(solver)]
        start = self._start(solver, b)
        tols = opts.tolerances

        def worst(e):
            m = problem.measure(e, **tols).values()
            return max((x.worst / x.tolerance if x.tolerance > 0 else x.worst for x in m), default=0.0)

        monitor = SolveMonitor(worst, opts.callback, opts.max_seconds, t0=t_call)
        monitor.cpu0 = c_call
        run = self._run(solver, b, start, monitor)
        build_s += run.build_seconds
        if monitor.timed_out:
            run = run._replace(status=f"time limit of {opts.max_seconds:g} s reached (the safety net "
                                      "max_seconds: the answer depends on the machine's load)", ok=False)
        e = b.unpack(run.x, run.frames)
        if problem.normalize == "renormalize" or solver == "lbfgs":
            e = _renormalize(e.ravel()).reshape(-1, 3)
        finite = bool(np.isfinite(e).all())
        collapsed = (self._collapse(start.e0, e) if finite and solver == "ipopt" and problem.hessian == "guarded"
                     and b.hessian == "gauss-newton" else None)
        if collapsed is not None:
            # the Gauss-Newton steps reached a trivial zero of the energies: solve again from
            # the same start with the exact Hessian (kept for this problem's structure)
            problem._exact_after_collapse = True
            problem._built.pop(problem._key(solver), None)
            res = SolveCall(problem, replace(opts, raise_on_failure=False)).run()
            res = replace(res, iterations=res.iterations + run.iterations,
                          build_seconds=res.build_seconds + build_s,
                          solve_seconds=res.solve_seconds + run.solve_seconds,
                          status=f"Gauss-Newton: {collapsed}; exact Hessian: {res.status}")
        else:
            res = self._package(solver, b, e, run, monitor, before=start.before, build_seconds=build_s)
        if opts.raise_on_failure and not res.success:
            raise OptimizationError(f"congruence optimization failed: {res.status}", res)
        return res

    # ------------------------------------------------------------------ start
    def _start(self, solver: str, b: Built) -> Start:
        """Where the solve starts: ``initial``, the last answer (warm start) or the
        congruence's directions (moved off the line-bundle apex, :meth:`_off_the_apex`)."""
        problem, opts = self.problem, self.opts
        e0, lam_g0, lam_x0, warm, resume = problem._directions(), None, None, False, False
        if opts.initial is not None:
            init = np.asarray(opts.initial, dtype=float)
            if init.size != problem.n_var or not np.isfinite(init).all():
                raise ValueError(f"initial must be a finite ({problem.n_var // 3}, 3) array")
            e0 = init.reshape(-1, 3)
        elif opts.warm_start and problem._last is not None:
            e0, resume = problem._last["e"], True
            lam_g0 = problem._last.get("lam_g") if solver == "ipopt" else None
            warm = lam_g0 is not None and lam_g0.size == b.n_g and b.n_g > 0
            lam_x0 = problem._last.get("lam_x") if warm else None
        if not resume and opts.initial is None:
            e0 = self._off_the_apex(e0)
        before = problem._evaluate(e0, rows=False)[0]
        x0, frames = b.pack(e0)
        p = b.parameters(problem._current(), frames)
        return Start(e0=e0, lam_g0=lam_g0, warm=warm, before=before, x0=x0, frames=frames, p=p, resume=resume,
                     lam_x0=lam_x0)

    def _off_the_apex(self, e: np.ndarray) -> np.ndarray:
        """The start moved off the line-bundle apex where a torsal-angle bound needs it.

        A flat facade's normals (or any parallel lines) are a line bundle on every face: the
        apex ``g = 0`` of every torsal-angle cone, where each constraint is stationary, so no
        Newton or interior-point method can find a direction out. When most faces of a
        ``min_torsal_angle`` constraint start weaker than 4 times its strength floor ``s``,
        the start gets a saddle twist ``e_i + 4 s (x_i t1 - y_i t2)`` (``t1``, ``t2`` the
        principal axes of mesh A, ``x, y`` in units of ``delta``): the normal congruence of
        a saddle, torsal directions 90 degrees apart, strength about ``4 s`` per edge.
        """
        problem = self.problem
        terms = [t for t in problem._terms.values() if t.kind == "torsal_angle" and t.block == 0]
        if not terms:
            return e
        s = max(float(t.par[0, 1]) for t in terms)
        c = problem._blocks[0]
        n = len(c.vertices)
        cong = Congruence(c.vertices, c.faces, e[:n])
        faces = np.unique(np.concatenate([t.elements for t in terms]))
        if np.mean(cong.bundle_deviation()[faces] < 4 * s) < 0.5:
            return e
        v = c.vertices - c.vertices.mean(axis=0)
        axes = np.linalg.svd(v, full_matrices=False)[2]
        x, y = (v @ axes[0]) / problem.delta, (v @ axes[1]) / problem.delta
        twisted = e[:n] + 4 * s * (x[:, None] * axes[0] - y[:, None] * axes[1])
        twisted /= np.linalg.norm(twisted, axis=1, keepdims=True)
        return np.concatenate([twisted, e[n:]])

    # ------------------------------------------------------------------ strategies
    def _run(self, solver: str, b: Built, start: Start, monitor: SolveMonitor) -> Run:
        t0 = time.perf_counter()
        if solver == "alm":
            return self._run_alm(b, start, monitor, t0)
        if solver == "lbfgs":
            opts = self.opts
            r = lbfgs(b, start.x0, start.p, monitor, max_iter=opts.max_iter or 1000, tol=opts.tol,
                      penalty=opts.penalty)
            s = time.perf_counter() - t0
            return Run(x=r.x, lam_g=None, iterations=r.iterations, status=r.status, ok=r.converged,
                       active=None, working=None, frames=start.frames, build_seconds=0.0, solve_seconds=s,
                       solver="lbfgs", timings={"lbfgs": s})
        return self._run_ipopt(b, start, monitor, t0)

    def _strategy(self, monitor: SolveMonitor, frames: np.ndarray, limit: int) -> IpoptStrategy:
        opts = self.opts
        return IpoptStrategy(self.problem, monitor, frames, limit=limit, tol=opts.tol, verbose=opts.verbose,
                             options=opts.ipopt_options)

    def _resumes_alm(self) -> bool:
        """``"auto"`` re-solves from an answer of the augmented Lagrangian (its multipliers and
        penalties kept): it continues with the augmented Lagrangian."""
        problem, opts = self.problem, self.opts
        return (opts.solver == "auto" and opts.warm_start and opts.initial is None
                and (problem._last or {}).get("alm") is not None and alm_unsupported(problem) is None)

    def _run_ipopt(self, b: Built, start: Start, monitor: SolveMonitor, t0: float) -> Run:
        """IPOPT in its passes (:meth:`IpoptStrategy.solve`). ``"auto"``: where pass 1 (no
        inequalities) misses one, the augmented Lagrangian continues from its answer instead
        of IPOPT's working-set and all-constraint passes (:meth:`_continue_with_alm`)."""
        problem, opts = self.problem, self.opts
        strategy = self._strategy(monitor, start.frames, opts.max_iter or 200)
        handover = opts.solver == "auto" and alm_unsupported(problem) is None and not _hyperbolic_margin(problem)
        problem._strategy = strategy
        try:
            out = strategy.solve(b, problem._mode("ipopt"), start.warm, start.lam_g0, start.x0, start.p,
                                 opts.try_unconstrained, handover=handover, lam_x0=start.lam_x0)
        finally:
            problem._strategy = None
        s = time.perf_counter() - t0 - strategy.build_seconds
        run = Run(x=out.x, lam_g=out.lam_g, iterations=out.iterations, status=out.status, ok=out.converged,
                  active=out.constraints_active, working=out.working, frames=strategy.frames,
                  build_seconds=strategy.build_seconds, solve_seconds=s, solver="ipopt", timings={"ipopt": s},
                  lam_x=self._bound_multipliers(strategy, b, out.lam_g))
        if out.handed_over and not (monitor.timed_out or monitor.stopped_by_user):
            return self._continue_with_alm(b, start, run, monitor)
        return run

    def _continue_with_alm(self, b: Built, start: Start, pass1: Run, monitor: SolveMonitor) -> Run:
        """The augmented Lagrangian with all constraints from IPOPT's pass-1 answer (the energies'
        optimum, which misses some inequalities).

        IPOPT's working-set pass carries barrier terms on every face near its bound: on Fig.
        12 row 13 (hyperbolicity binds on about 2 % of the faces, 18 % in the working set) it
        took 78 iterations against the augmented Lagrangian's 8 Newton steps
        (benchmarks/optimize_bench.py)."""
        problem = self.problem
        t0 = time.perf_counter()
        build_s = problem.build("alm")
        ba = problem._built[problem._key("alm")]
        e1 = b.unpack(pass1.x, pass1.frames)
        x0, frames = ba.pack(e1)
        start = start._replace(e0=e1, x0=x0, frames=frames, p=ba.parameters(problem._current(), frames),
                               resume=False, warm=False, lam_g0=None)
        run = self._run_alm(ba, start, monitor, time.perf_counter())
        x, frames = b.pack(ba.unpack(run.x, run.frames))
        return run._replace(
            x=x, frames=frames, iterations=pass1.iterations + run.iterations,
            status=f"IPOPT without inequalities: {pass1.status} ({pass1.iterations} iterations), "
                   f"missed some; augmented Lagrangian: {run.status}",
            build_seconds=pass1.build_seconds + build_s + run.build_seconds,
            solve_seconds=pass1.solve_seconds + (time.perf_counter() - t0 - build_s),
            solver="ipopt+" + run.solver, timings={"ipopt pass 1": pass1.solve_seconds, **(run.timings or {})})

    def _run_alm(self, b: Built, start: Start, monitor: SolveMonitor, t0: float) -> Run:
        """The augmented Lagrangian from ``start`` (:mod:`.alm`), warm from the last answer's
        multipliers and penalties when there are some; IPOPT certifies its answer
        (``certify``) or continues from it where it is not measured-feasible (``"auto"``)."""
        problem, opts = self.problem, self.opts
        tols = opts.tolerances

        def feasible(e):
            return all(m.holds for m in problem.measure(e, **tols).values())

        warm = (problem._last or {}).get("alm") if start.resume else None
        a = AugmentedLagrangian(b, start.p, monitor, feasible, max_steps=opts.max_iter or ALM_MAX_STEPS,
                                tol=opts.tol)
        r = a.solve(start.e0, warm)
        t_alm = time.perf_counter() - t0
        x, frames = b.pack(r.e)
        run = Run(x=x, lam_g=r.lam_g, iterations=r.iterations, status=r.status, ok=r.converged, active=True,
                  working=None, frames=frames, build_seconds=0.0, solve_seconds=t_alm, alm=r, solver="alm",
                  # the parts of the augmented Lagrangian's time ("alm factor", ...), within "alm"
                  timings={"alm": t_alm, **{f"alm {k}": v for k, v in (r.seconds or {}).items()}})
        stopped = monitor.timed_out or monitor.stopped_by_user
        # not converged (measured infeasible, or feasible but stopped by its step limit): IPOPT
        # continues from it, warm, so "auto" ends at a KKT point whenever one is in reach
        rescue = opts.solver == "auto" and not r.converged
        if stopped or not (opts.certify or rescue):
            return run
        return self._certify(run, r, monitor, rescue)

    def _certify(self, run: Run, r: AlmRun, monitor: SolveMonitor, rescue: bool) -> Run:
        """IPOPT with all constraints, warm from the augmented Lagrangian's answer and
        multipliers: a KKT point to IPOPT's tolerances (certification), or the continuation
        of an answer that is not measured-feasible (``rescue``)."""
        problem, opts = self.problem, self.opts
        t0 = time.perf_counter()
        n_alm = monitor.iteration          # the iterates after it are IPOPT's
        build_s = problem.build("ipopt")
        b = problem._built[problem.normalize]
        x, frames = b.pack(r.e)
        p = b.parameters(problem._current(), frames)
        cap = CERTIFY_ITERATIONS if not rescue else max((opts.max_iter or ALM_MAX_STEPS) - r.iterations, 50)
        strategy = self._strategy(monitor, frames, cap)
        problem._strategy = strategy
        try:
            out = strategy.warm_pass(b, x, p, r.lam_g, cap)
        finally:
            problem._strategy = None
        t_ip = time.perf_counter() - t0 - strategy.build_seconds
        build_s += strategy.build_seconds
        timings = {**run.timings, "ipopt": t_ip}
        e_ip = b.unpack(out.x, frames)
        tols = opts.tolerances
        ok_ip = out.converged and all(m.holds for m in problem.measure(e_ip, **tols).values())
        if not ok_ip and not rescue:
            # the report says IPOPT did not certify the augmented Lagrangian's answer; where
            # IPOPT's iterates went lower while feasible as measured, that answer was no local
            # minimum (row 9: 0.01777 -> 0.01736 in 100 iterations) and the lowest of them is
            # the better design
            status = run.status + f"; IPOPT did not certify it ({out.status}, {out.iterations} iterations)"
            best = monitor.best                 # IPOPT's when numbered after the ALM's iterates
            f_alm = problem._evaluate(r.e, rows=False)[1] if best is not None and best.iteration > n_alm else None
            if f_alm is not None and best.objective < f_alm - 1e-9 * max(abs(f_alm), 1e-300):
                x, frames = b.pack(best.directions)
                status += (f" but lowered the objective from {f_alm:.6g} to {best.objective:.6g}, "
                           f"feasible as measured: its best feasible iterate (iteration {best.iteration})")
                run = run._replace(x=x, frames=frames, lam_g=None, solver="alm+ipopt")   # IPOPT's design
            return run._replace(status=status, iterations=run.iterations + out.iterations,
                                build_seconds=run.build_seconds + build_s, timings=timings)
        how = "certified by IPOPT" if not rescue else "continued by IPOPT"
        return Run(x=out.x, lam_g=out.lam_g, iterations=run.iterations + out.iterations,
                   status=f"{run.status}; {how}: {out.status} ({out.iterations} iterations)", ok=out.converged,
                   active=True, working=None, frames=frames, build_seconds=run.build_seconds + build_s,
                   solve_seconds=run.solve_seconds + t_ip, alm=r, solver="alm+ipopt", timings=timings,
                   lam_x=self._bound_multipliers(strategy, b, out.lam_g))

    @staticmethod
    def _bound_multipliers(strategy: IpoptStrategy, b: Built, lam_g) -> np.ndarray | None:
        """The bound multipliers of the IPOPT run that gave the answer (its last run, on ``b``),
        or None where no multipliers are kept (pass 1's answer: ``lam_g`` None)."""
        last = strategy.last
        if lam_g is None or last is None or last.lam_x is None or last.lam_x.size != b.n_var:
            return None
        return last.lam_x

    # ------------------------------------------------------------------ the answer
    def _collapse(self, e_start: np.ndarray, e_end: np.ndarray) -> str | None:
        """Why the answer ``e_end`` collapsed compared to ``e_start``, or None (``hessian="guarded"``).

        Collapsed: on some aligned congruence, the faces without torsal directions (elliptic
        faces and bundles, :meth:`Congruence.torsal_angle` NaN) grew by more than
        ``COLLAPSE_SHARE`` of the faces.
        """
        problem = self.problem
        for c0, c1 in zip(problem._congruences(e_start), problem._congruences(e_end)):
            n0, n1 = (int(np.isnan(c.torsal_angle()).sum()) for c in (c0, c1))
            if n1 - n0 > COLLAPSE_SHARE * len(c1.faces):
                return (f"{n1} of {len(c1.faces)} faces without torsal directions (start {n0}), "
                        "collapsed toward a line bundle")
        return None

    def _package(self, solver: str, b: Built, e: np.ndarray, run: Run, monitor: SolveMonitor, *,
                 before: dict, build_seconds: float) -> OptimizationResult:
        """The :class:`OptimizationResult` of the answer ``e`` (stacked (N, 3)), measured.

        Falls back to the monitor's best feasible iterate (``keep_best``), writes the misses
        into the status and keeps the answer (and a converged solve's multipliers, the
        augmented Lagrangian's penalties) for a warm start.
        """
        problem, opts = self.problem, self.opts
        tols = opts.tolerances
        status, ok, lam_g, working = run.status, run.ok, run.lam_g, run.working
        finite = bool(np.isfinite(e).all())
        meas = problem.measure(e, **tols) if finite else {}
        holds = finite and all(m.holds for m in meas.values())
        from_iteration = None
        best = monitor.best
        if opts.keep_best and best is not None and (
                not holds or (not ok and best.objective < problem._evaluate(e, rows=False)[1])):
            # stopped early or ended infeasible: the best iterate that held every constraint
            e, from_iteration, lam_g, working = best.directions, best.iteration, None, None
            meas, holds, finite = problem.measure(e, **tols), True, True
            status += f"; returned the best feasible iterate (iteration {best.iteration})"
        if finite:
            after, fval = problem._evaluate(e, rows=False)[:2]
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
            congs = problem._congruences(e)
            # multipliers only from a converged solve: a warm start (mu_init 1e-6) from an
            # unconverged iterate's multipliers was slower than a cold one
            problem._last = {"e": e, "lam_g": lam_g if ok else None, "active": run.active,
                             "working": working if ok else None,
                             "lam_x": run.lam_x if ok and lam_g is not None else None,
                             "alm": run.alm.state if run.alm is not None and from_iteration is None else None}
        else:
            congs = list(problem._blocks)
        counts = {"iterations": run.iterations}
        if run.alm is not None:
            counts.update(newton_steps=run.alm.iterations, outer_iterations=run.alm.outer,
                          factorizations=run.alm.factorizations, **{k: v for k, v in run.alm.counts.items()
                                                                    if k != "factorizations"})
        timings = {"build": build_seconds, **(run.timings or {}),
                   "total": time.perf_counter() - monitor.t0}
        return OptimizationResult(congruence=congs[0], success=ok, status=status, iterations=run.iterations,
                                  build_seconds=build_seconds, solve_seconds=run.solve_seconds,
                                  energies_before=before, energies_after=after,
                                  max_violation={k: m.worst for k, m in meas.items()}, worst_constraint=worst_c,
                                  congruences=tuple(congs), solver=run.solver or solver, objective=float(fval),
                                  constraints_active=run.active,
                                  working_set=None if working is None else _working_ids(b, working),
                                  violated={k: m.missed for k, m in meas.items()}, measured=meas,
                                  history=monitor.history, from_iteration=from_iteration,
                                  timings=timings, counts=counts, time_limited=monitor.timed_out)
