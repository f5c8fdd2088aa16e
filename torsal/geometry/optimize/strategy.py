"""The solve room's shared types: one call's options, the state a problem keeps between solves,
where a strategy starts and how it ran, and the one interface every strategy has.

A :class:`SolveStrategy` turns a :class:`Start` into a :class:`Run` within a
:class:`SolveContext` (the problem's terms, its NLP cache, its solve state, the call's options
and monitor): the augmented Lagrangian (:class:`~torsal.geometry.optimize.alm.AlmStrategy`),
IPOPT's passes (:class:`~torsal.geometry.optimize.ipopt.IpoptSolve`), a warm IPOPT pass from
another strategy's answer (:class:`~torsal.geometry.optimize.ipopt.IpoptWarm`) and the L-BFGS
baseline (:class:`~torsal.geometry.optimize.lbfgs.LbfgsStrategy`). The combined routes are
compositions, :class:`Then`: a second strategy continues from the first's answer where the
first's run asks for it (:mod:`.solve` wires them).
"""
from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Callable, NamedTuple, Protocol

import numpy as np

from .cache import NlpCache, NlpKind
from .history import SolveMonitor
from .measure import Measurement
from .nlp import Built
from .registry import TermRegistry
from .result import Stop, StopReason


@dataclass
class AlmState:
    """Where a warm re-solve starts: the answer's directions, multipliers, penalties and row
    scales (the scales stay fixed so that multipliers and penalties keep their meaning)."""

    e: np.ndarray             # (N, 3) unit directions
    lam: np.ndarray           # (n_g,) multipliers of the scaled rows (PHR sign: mu)
    rho: np.ndarray           # (n_g,) penalties of the scaled rows
    scale: np.ndarray         # (n_g,) row scales
    delta: float = 1e-8       # the Levenberg-Marquardt shift (relative)
    floor: float = 0.0        # the Newton decrement's floor of the solve it came from (FLOOR)


class AlmRun(NamedTuple):
    """The answer of the augmented Lagrangian (:class:`~torsal.geometry.optimize.alm.AugmentedLagrangian`)
    and how it ended."""

    e: np.ndarray             # (N, 3) directions
    lam_g: np.ndarray         # multipliers in IPOPT's convention (grad f + J^T lam_g = 0)
    iterations: int           # Newton steps
    outer: int                # outer iterations (multiplier updates)
    factorizations: int
    status: str
    converged: bool
    state: AlmState
    counts: dict              # line-search trials, shifted retries, the backend
    seconds: dict | None = None   # wall seconds by phase: hessian, factor, line search
    reason: StopReason = StopReason.CONVERGED
    decrement: float | None = None        # the last relative Newton decrement
    recent_decrease: float | None = None  # the objective's relative decrease over DESIGN_WINDOW steps


class Solver(str, Enum):
    """The strategies of :meth:`~torsal.geometry.optimize.CongruenceProblem.solve` (a ``str``
    enum: design files give the value, ``constraints.solver = "alm"``)."""

    AUTO = "auto"
    ALM = "alm"
    IPOPT = "ipopt"
    LBFGS = "lbfgs"


#: the ``solver`` options of :meth:`CongruenceProblem.solve` (the first is the default)
SOLVERS = tuple(s.value for s in Solver)


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
    stop: Stop = Stop.DESIGN

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


class SolveState:
    """What a problem keeps between its solves, owned by the solve room: the last answer (the
    next solve's warm start) and the IPOPT solve in progress, to which the iteration
    callbacks of the cached IPOPT solvers report (they outlive one solve)."""

    def __init__(self):
        self.last: Optimum | None = None
        self.ipopt = None           # the IPOPT passes in progress (ipopt.IpoptPasses), or None

    def report_iteration(self, it: dict) -> bool:
        """An IPOPT iterate (``it``: its ``"x"``, ``"f"``, ``"g"``) -> the solve in progress;
        True stops IPOPT."""
        return self.ipopt.report(it) if self.ipopt is not None else False


class Start(NamedTuple):
    """Where a strategy starts."""

    e0: np.ndarray                  # (N, 3) stacked start directions
    lam_g0: np.ndarray | None       # IPOPT's constraint multipliers of the last solve (warm start)
    warm: bool                      # IPOPT starts warm from ``lam_g0``
    before: dict                    # energies at ``e0``
    x0: np.ndarray                  # ``e0`` packed as the NLP's variables
    frames: np.ndarray              # (n, 9) tangent frames of ``Built.pack`` ((0, 9) if unused)
    p: np.ndarray                   # the NLP's parameters at the start
    b: Built                        # the NLP ``x0`` and ``p`` belong to
    resume: bool = False            # starts from the last answer (its multipliers, penalties)
    lam_x0: np.ndarray | None = None  # IPOPT's bound multipliers of the last solve (warm start)
    previous: "Run | None" = None   # the run this one continues (a composition's second strategy)
    build_seconds: float = 0.0      # seconds spent building ``b`` for this start


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
    b: Built                        # the NLP ``x`` belongs to
    alm: AlmRun | None = None       # the augmented Lagrangian's run (state for a warm re-solve)
    solver: str = ""                # who produced the answer ("alm", "ipopt", "alm+ipopt", ...)
    timings: dict | None = None     # seconds per part
    lam_x: np.ndarray | None = None  # IPOPT's bound multipliers of the answer (None: not IPOPT's)
    handed_over: bool = False       # IPOPT's pass 1 missed an inequality and stopped for the next strategy
    first_iteration: int = 0        # the monitor's iteration count before the run: its iterates come after

    @property
    def directions(self) -> np.ndarray:
        """The answer as stacked (N, 3) directions."""
        return self.b.unpack(self.x, self.frames)

    def on(self, b: Built) -> "Run":
        """The same answer as the variables of NLP ``b``."""
        if b is self.b:
            return self
        x, frames = b.pack(self.directions)
        return self._replace(x=x, frames=frames, b=b)


@dataclass
class SolveContext:
    """One solve call's world, handed to every strategy: the problem's terms, NLPs and solve
    state, the call's options and its monitor (history, best feasible iterate, limits)."""

    registry: TermRegistry
    nlp: NlpCache
    state: SolveState
    options: SolveOptions
    monitor: SolveMonitor

    def measure(self, e: np.ndarray) -> dict[str, Measurement]:
        """Every constraint measured at stacked directions ``e``, to the call's tolerances."""
        return self.nlp.measure(e, **self.options.tolerances)

    def feasible(self, e: np.ndarray) -> bool:
        """Every constraint holds as measured at ``e``."""
        return all(m.holds for m in self.measure(e).values())

    @property
    def stopped(self) -> bool:
        """The user's callback or the safety net stopped the solve: no strategy continues."""
        return self.monitor.timed_out or self.monitor.stopped_by_user

    def start_from(self, run: Run, kind: NlpKind) -> Start:
        """A start on ``kind``'s NLP at ``run``'s answer, continuing it (cold multipliers)."""
        b, seconds = self.nlp.get(kind)
        e = run.directions
        x0, frames = b.pack(e)
        return Start(e0=e, lam_g0=None, warm=False, before={}, x0=x0, frames=frames,
                     p=b.parameters(self.registry.current(), frames), b=b, previous=run, build_seconds=seconds)


class SolveStrategy(Protocol):
    """One way to solve the NLP: from ``start`` to a :class:`Run` (not yet measured)."""

    #: the NLP the strategy runs on (:meth:`SolveContext.start_from` packs a start for it)
    kind: NlpKind

    def solve(self, ctx: SolveContext, start: Start) -> Run:
        """Run from ``start``; every iterate goes to ``ctx.monitor``."""
        ...


@dataclass(frozen=True)
class Then:
    """A composed route: ``first``, and where ``when(ctx, run)`` holds for its run (and no
    one stopped the solve), ``second`` continuing from its answer (``Start.previous``);
    ``combine(ctx, first_run, second_run)`` is the route's run."""

    first: SolveStrategy
    second: SolveStrategy
    when: Callable[[SolveContext, Run], bool]
    combine: Callable[[SolveContext, Run, Run], Run]

    @property
    def kind(self) -> NlpKind:
        return self.first.kind

    def solve(self, ctx: SolveContext, start: Start) -> Run:
        run = self.first.solve(ctx, start)
        if ctx.stopped or not self.when(ctx, run):
            return run
        start = ctx.start_from(run, self.second.kind)
        second = self.second.solve(ctx, start)
        return self.combine(ctx, run, second._replace(build_seconds=second.build_seconds + start.build_seconds))
