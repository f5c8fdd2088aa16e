"""What a solve returns: :class:`OptimizationResult`, its per-iteration history and errors."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from typing import NamedTuple

from torsal.core.errors import TorsalError

from ..congruence import Congruence


class IterationRecord(NamedTuple):
    """One solver iteration, as recorded in ``OptimizationResult.history``.

    Attributes
    ----------
    iteration : int
        Running count over all passes of the solve (IPOPT's iteration 0 of each pass counts).
    seconds : float
        Wall time since :meth:`~torsal.geometry.optimize.CongruenceProblem.solve` was called
        (building the NLP included).
    objective : float
        Weighted objective of eq. (9) at the iterate.
    violation : float
        Measured worst violation at the iterate, as a multiple of its tolerance (a value <= 1
        means every constraint holds as measured; 0 without constraints).
    feasible : bool
        ``violation <= 1``.
    cpu_seconds : float
        Processor time of this process since the solve was called (``time.process_time``):
        comparable between solvers on a busy machine, where wall time is not.
    """

    iteration: int
    seconds: float
    objective: float
    violation: float
    feasible: bool
    cpu_seconds: float = math.nan


class Stop(str, Enum):
    """Where :meth:`~torsal.geometry.optimize.CongruenceProblem.solve` may stop (``stop=``; a
    ``str`` enum: design files give the value, ``constraints.stop = "converged"``).

    ``DESIGN`` (the default): at the first iterate that holds every constraint as measured
    while the augmented Lagrangian's objective has stopped moving (its Newton decrement and
    its decrease over the last steps below the design tolerance, see
    :data:`torsal.geometry.optimize.alm.DESIGN_DECREMENT`): the digits after it change
    nothing the fins, the light figures or the measured angles show. ``CONVERGED``: to the
    solver's own convergence (``tol``), for comparisons with the paper's table and for
    certification.
    """

    DESIGN = "design"
    CONVERGED = "converged"


#: the ``stop`` options of :meth:`CongruenceProblem.solve` (the first is the default)
STOPS = tuple(s.value for s in Stop)


class StopReason(str, Enum):
    """Why a solve ended (:attr:`Convergence.reason`)."""

    DESIGN = "design tolerance"          # measured feasible, the objective no longer moves (Stop.DESIGN)
    CONVERGED = "converged"              # the solver's own convergence test
    ITERATION_LIMIT = "iteration limit"
    TIME_LIMIT = "time limit"            # the safety net max_seconds: the answer depends on the load
    CALLBACK = "stopped by callback"
    FAILED = "failed"                    # the solver gave up (no decrease, no factorization, ...)


class Convergence(NamedTuple):
    """How close to converged a solve's answer is (``OptimizationResult.convergence``).

    Attributes
    ----------
    stop : Stop
        The rule the solve was asked to stop at.
    reason : StopReason
        Why it ended.
    newton_decrement : float or None
        The augmented Lagrangian's last Newton decrement relative to its objective (the
        decrease of ``L_A`` a full Newton step predicts: what is left at the current
        multipliers); None where it did not run last.
    recent_decrease : float or None
        The objective's relative decrease over the last :data:`~torsal.geometry.optimize.alm.DESIGN_WINDOW`
        Newton steps (an estimate of the energy still to gain, per that many steps; a warm
        re-solve that took fewer: at the rate of its last :data:`~torsal.geometry.optimize.alm.WARM_WINDOW`);
        None where fewer steps ran or the augmented Lagrangian did not run last.
    """

    stop: Stop
    reason: StopReason
    newton_decrement: float | None = None
    recent_decrease: float | None = None

    def as_dict(self) -> dict:
        """JSON-ready (``report.json``'s ``congruence.convergence``)."""
        return {"stop": self.stop.value, "reason": self.reason.value, "newton_decrement": self.newton_decrement,
                "recent_decrease": self.recent_decrease}


class OptimizationError(TorsalError, RuntimeError):
    """A solve failed and ``raise_on_failure=True`` was given; ``.result`` holds the details."""

    def __init__(self, message: str, result: "OptimizationResult"):
        super().__init__(message)
        self.result = result


@dataclass
class OptimizationResult:
    """Outcome of :meth:`CongruenceProblem.solve`.

    Attributes
    ----------
    congruence : Congruence
        The optimized congruence (same mesh A, new directions).
    success : bool
        Solver converged (or a feasible iterate was kept, see ``from_iteration``), no NaN, and
        every constraint holds as *measured* on the result: angles within ``angle_tol_deg``
        (0.1 degree) of their bound, other constraints within ``constraint_tol``.
    status : str
        The solver's own words (IPOPT return status, scipy message) plus our diagnosis.
    iterations : int
    build_seconds : float
        Time spent building the NLP and solver in this call (0 when the built solver was re-used).
    solve_seconds : float
    energies_before, energies_after : dict[str, float]
        Unweighted, normalized value of every energy (as printed in the paper), plus
        ``"total"``: the weighted objective of eq. (9).
    max_violation : dict[str, float]
        Largest *measured* violation of each constraint, in the constraint's own units (see
        :mod:`torsal.geometry.optimize.measure`): degrees for ``min_torsal_angle`` (how far the
        smallest torsal angle is below the bound; a face without torsal directions counts as
        0 degrees) and ``max_angle_to``, ``c_hyp / delta^2`` for ``hyperbolic``, the function
        value for a user's own constraint; ``unit_length`` is ``max | ||e_i||^2 - 1 |``.
        0 where the constraint holds.
    worst_constraint : tuple or None
        ``(name, element index, violation)`` of the worst measured violation beyond its
        tolerance, None if all hold.
    congruences : tuple of Congruence
        All optimized congruences: this problem's first, then those joined by ``align_with``.
    solver : str
        Who produced the answer: ``"alm"``, ``"ipopt"``, ``"alm+ipopt"`` (the augmented
        Lagrangian's answer certified or continued by IPOPT), ``"ipopt+alm"`` (IPOPT's pass
        without inequalities continued by the augmented Lagrangian) or ``"lbfgs"``.
    objective : float
    constraints_active : bool or None
        IPOPT with inequality constraints: False when the solve without them already met
        them (see ``try_unconstrained`` of :meth:`CongruenceProblem.solve`), True when the
        constrained problem was solved; None otherwise.
    working_set : dict[str, ndarray] or None
        When IPOPT imposed only some inequality constraints (the working set, see
        ``try_unconstrained`` of :meth:`CongruenceProblem.solve`): the element ids (faces,
        vertices, ...) it imposed, by constraint name; all others hold with slack. None when
        every inequality was imposed or none was needed.
    violated : dict[str, ndarray]
        Per constraint, the element ids (faces, vertices) that miss the bound by more than
        the tolerance, measured; empty arrays where it holds.
    measured : dict[str, Measurement]
        The full measurement per constraint (values per element, bound, unit, tolerance).
    history : list of IterationRecord
        One record per solver iteration (all passes): wall time since the solve started,
        objective (eq. (9)) and measured worst violation; see :class:`IterationRecord`.
    from_iteration : int or None
        When the solver stopped early or ended infeasible and an earlier iterate was
        feasible (measured) with lower energy, the result is that iterate and this is its
        iteration number; None when the result is the solver's last iterate.
    timings : dict[str, float]
        Wall seconds per part: ``"build"`` (NLPs), ``"alm"``, ``"ipopt"``, ``"lbfgs"`` (each
        solver that ran), ``"total"`` (the whole call, measuring included).
    counts : dict
        ``"iterations"``; for the augmented Lagrangian also ``"newton_steps"``,
        ``"outer_iterations"``, ``"factorizations"`` (all sparse Cholesky factorizations),
        ``"exact"`` (steps with the exact Hessian), ``"corrected"`` (those of them whose
        Newton matrix needed the inertia correction's shift, :data:`~torsal.geometry.optimize.alm.INERTIA_PIVOTS`),
        ``"indefinite"`` (factorizations of it that were not positive definite), ``"shifted"`` (projected matrices refactored with a larger
        shift), ``"trials"`` (line-search evaluations) and ``"backend"`` (the factorization:
        ``"mumps"`` called directly, ``"mumps/casadi"`` through casadi's interface, see
        :mod:`~torsal.geometry.optimize.factor`).
    time_limited : bool
        The safety net ``max_seconds`` cut the solve: the answer depends on the machine's
        load (the status says so too).
    convergence : Convergence or None
        The stopping rule asked for, why the solve ended and how close to converged its
        answer is (the last Newton decrement, the recent decrease of the objective).
    """

    congruence: Congruence
    success: bool
    status: str
    iterations: int
    build_seconds: float
    solve_seconds: float
    energies_before: dict
    energies_after: dict
    max_violation: dict
    worst_constraint: tuple | None = None
    congruences: tuple = ()
    solver: str = "ipopt"
    objective: float = float("nan")
    constraints_active: bool | None = None
    working_set: dict | None = None
    violated: dict = field(default_factory=dict)
    measured: dict = field(default_factory=dict)
    history: list = field(default_factory=list)
    from_iteration: int | None = None
    timings: dict = field(default_factory=dict)
    counts: dict = field(default_factory=dict)
    time_limited: bool = False
    convergence: Convergence | None = None

    @property
    def feasible(self) -> bool:
        """Every constraint holds as measured on the result (whether or not the solver converged)."""
        return bool(self.max_violation is not None and all(m.holds for m in self.measured.values())
                    and "NaN" not in (self.worst_constraint or ("",))[0])

    @property
    def min_torsal_angle_deg(self) -> float | None:
        """Measured smallest torsal angle over the faces of every ``min_torsal_angle``
        constraint (degrees), None without one."""
        vals = [m.values.min() for m in self.measured.values() if m.kind == "torsal_angle" and m.values.size]
        return float(min(vals)) if vals else None

    def time_to(self, energy: float, *, cpu: bool = False) -> float | None:
        """Wall time (s; processor time with ``cpu``) until the first measured-feasible
        iterate with objective <= ``energy``."""
        for r in self.history:
            if r.feasible and r.objective <= energy:
                return r.cpu_seconds if cpu else r.seconds
        return None

    def summary(self) -> str:
        """One line per fact, for logs and the CLI."""
        lines = [f"{self.solver}: {'ok' if self.success else 'FAILED'} ({self.status}), "
                 f"{self.iterations} iterations, build {self.build_seconds:.2f} s, "
                 f"solve {self.solve_seconds:.2f} s"]
        if self.constraints_active is False:
            lines.append("  inequality constraints inactive: met by the solve without them")
        if self.working_set is not None:
            n = sum(len(v) for v in self.working_set.values())
            lines.append(f"  inequality constraints imposed on {n} elements (the working set); "
                         "the others hold with slack")
        for k in self.energies_after:
            lines.append(f"  {k:>18}: {self.energies_before.get(k, float('nan')):.4g} -> "
                         f"{self.energies_after[k]:.4g}")
        if self.from_iteration is not None:
            lines.append(f"  result: the best feasible iterate, iteration {self.from_iteration}")
        for k, v in self.max_violation.items():
            m = self.measured.get(k)
            unit = f" {m.unit}" if m is not None and m.unit != "value" else ""
            missed = f", {len(self.violated[k])} elements miss it" if len(self.violated.get(k, ())) else ""
            lines.append(f"  violation {k:>8}: {v:.3g}{unit} (measured){missed}")
        return "\n".join(lines)

