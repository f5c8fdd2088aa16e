"""The problem builder: :class:`CongruenceProblem` (Wang et al. 2013, 4.1, eq. (9)).

Energies and constraints are added by chaining methods (:mod:`.energies`, :mod:`.constraints`;
the term catalogue of :mod:`.catalogue` and :mod:`torsal.geometry.optimize.terms`), registered
in a :class:`~.registry.TermRegistry`; :meth:`CongruenceProblem.solve` builds the NLPs it needs
(:class:`~.cache.NlpCache`, :mod:`.nlp`), runs the route's strategy (:mod:`.solve`: the augmented
Lagrangian, IPOPT, the L-BFGS baseline) and measures the constraints on the answer (:mod:`.measure`).
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from ..congruence import Congruence
from .cache import HESSIANS, NlpCache, NlpKind
from .constraints import ConstraintTerms
from .energies import EnergyTerms
from .measure import Measurement
from .registry import NORMALIZE, TermRegistry, check_weights
from .result import STOPS, OptimizationResult, Stop
from .solve import SOLVERS, SolveCall
from .strategy import Optimum, SolveOptions, SolveState

__all__ = ["CongruenceProblem", "HESSIANS"]


class CongruenceProblem(EnergyTerms, ConstraintTerms):
    """An optimization problem over the line directions of a congruence (Wang et al. 2013, 4.1).

    Build it by chaining term and constraint methods (:class:`~.energies.EnergyTerms`,
    :class:`~.constraints.ConstraintTerms`), then call :meth:`solve`. The problem is three
    parts: its terms (:attr:`registry`, a :class:`~.registry.TermRegistry`), the NLPs built
    from them (:attr:`nlp`, an :class:`~.cache.NlpCache`) and what the solve room keeps
    between solves (:attr:`state`, a :class:`~.strategy.SolveState`: the last answer).

    Parameters
    ----------
    congruence : Congruence
        Mesh A and the initial directions (e.g. ``Congruence.from_normals``).
    weights : dict, optional
        Overrides of :data:`DEFAULT_WEIGHTS` by term name, used when a method gets no ``weight``.
    normalize : {"tangent", "constraint", "renormalize"}
        How ``||e_i|| = 1`` is kept. ``"tangent"`` (default, fastest): every ``e_i`` is a unit
        vector by construction, ``e = (f0 + z1 f1 + z2 f2) / sqrt(1 + z1^2 + z2^2)`` with 2
        variables per vertex around a frame re-centred at the start of every solve (a
        gnomonic chart; halves the KKT system compared to ``"constraint"``).
        ``"constraint"``: ``||e_i||^2 = 1`` as IPOPT equality constraints.
        ``"renormalize"``: the paper's way: no unit constraint; a penalty
        ``mean((||e_i||^2 - 1)^2)`` (weight 1) keeps lengths near 1 during a solve, and the
        directions are renormalized afterwards (and after every round of ``lbfgs``).
    hessian : {"projected", "exact", "guarded", "gauss-newton", "auto"}
        Hessian of the energies' part of the Lagrangian. ``"projected"`` (default): in an NLP
        without constraint rows (a problem without constraints, and pass 1 of a solve with
        inequalities, see ``try_unconstrained`` of :meth:`solve`), each energy element's
        Hessian and each vertex's chart curvature with its negative eigenvalues clamped to 0
        (projected Newton, :mod:`~torsal.geometry.optimize.projected`) for the first
        ``PROJECTED_ITERATIONS`` (10) IPOPT iterations, then exact; NLPs with constraint rows
        use the exact Hessian. The projected sum is positive semidefinite, so IPOPT factors
        once per iteration instead of searching for a regularization, and only the elements
        that curve down are flattened (fewer iterations than the exact Hessian on the
        unconstrained Fig. 12 rows and at 100k vertices, ``benchmarks/optimize_bench.py``);
        it switches to exact because projected Newton converges linearly where the
        energies' minimum is not zero. The augmented Lagrangian (``solve(solver="alm")``)
        builds its own NLP with every element projected (:mod:`~torsal.geometry.optimize.alm`).
        ``"gauss-newton"``: ``2 J_r^T J_r`` for
        every energy that is a sum of squares (all built-in ones but ``fair``, which is
        quadratic and exact either way), no chart curvature for them; positive semidefinite,
        so IPOPT's inertia correction only meets the constraints' curvature (the constraints
        keep their exact Hessian). ``"exact"``: the exact Hessian. ``"guarded"``:
        Gauss-Newton for a problem without constraints, checked: if its answer has more
        faces without torsal directions than the start, by more than ``solve.COLLAPSE_SHARE`` (2 %)
        of the faces (``SolveCall._collapse``), the solve is repeated from the same start with the
        exact Hessian, which the problem then keeps; exact for a problem with constraints.
        ``"auto"``: Gauss-Newton for pass 1 of a solve with inequality constraints (the NLP
        without them, see ``try_unconstrained`` of :meth:`solve`), exact for every other NLP.
        Gauss-Newton converges in a few iterations where the exact Hessian is indefinite,
        but its full steps can land on a trivial zero of the energies, close to a line
        bundle (faces without torsal directions); the guard catches that and returns the
        exact Hessian's answer at the cost of a second solve, so it is not the default: it
        pays off where the energies' minimum is not zero (e.g. with ``closeness``).
    elastic : float, default 0
        ``rho > 0``: the elastic (l1-exact penalty) form of the one-sided inequalities (slacks
        ``p_j >= 0``, ``c_j + p_j >= l_j``, ``rho / |V| sum p_j`` in the objective; see
        :meth:`~torsal.geometry.optimize.nlp.Built._elastic`): LICQ holds everywhere, every
        start is feasible, multipliers are bounded by ``rho``. 0 (default): off. An option for
        IPOPT, not the default (it did not converge faster on row 7c); on small patches it
        reaches the same optimum (tests/geometry/test_optimize_forms.py).
    jit : bool, default False
        Compile the per-element kernels to C with the system compiler (casadi codegen; cached
        on disk in ``~/.cache/torsal/kernels`` or ``$TORSAL_KERNEL_CACHE``, so only the first
        build on a machine pays ~1 s per kernel). Evaluations get several times faster:
        use it for large meshes and the interactive loop.

    Notes
    -----
    Every element term sees mesh A in units of ``delta`` (``a / delta``, with unit line
    directions), so the paper's normalizations (``1/delta^2`` in f_norm, ``c_hyp / delta^2``,
    ...) are exact and every kernel is independent of the mesh (compiled once with
    ``jit=True``). For f_fair/t this means ``B = A/delta + e`` in the projection condition
    (its zero set does not depend on the distance of B; see
    :func:`torsal.geometry.optimize.terms.fair_torsal_residual_sx`).

    Examples
    --------
    >>> from torsal.geometry.surfaces import facade_patch
    >>> c = Congruence.from_normals(facade_patch(nu=9, nv=7))
    >>> res = (CongruenceProblem(c).normal().fair().perpendicular([0.3, -0.8, -0.5])
    ...        .hyperbolic().solve())
    >>> res.success, res.max_violation["hyperbolic"] <= 1e-6     # c_hyp / delta^2, measured
    (True, True)
    """


    def __init__(self, congruence: Congruence, weights: dict | None = None,
                 normalize: str = NORMALIZE[0], jit: bool = False, hessian: str = HESSIANS[0],
                 elastic: float = 0.0):
        if not isinstance(congruence, Congruence):
            raise TypeError("CongruenceProblem needs a torsal Congruence (e.g. Congruence.from_normals(mesh))")
        if normalize not in NORMALIZE:
            raise ValueError(f"normalize must be 'tangent', 'constraint' or 'renormalize', got {normalize!r}")
        if hessian not in HESSIANS:
            raise ValueError(f"hessian must be one of {HESSIANS}, got {hessian!r}")
        if not (np.isfinite(elastic) and elastic >= 0):
            raise ValueError(f"elastic must be a finite number >= 0 (0: off), got {elastic}")
        #: the terms and the congruences they act on
        self.registry = TermRegistry(congruence, check_weights(weights))
        #: the NLPs built from the terms, kept until a term's structure changes
        self.nlp = NlpCache(self.registry, normalize=normalize, jit=bool(jit), hessian=hessian,
                            elastic=float(elastic))
        #: the solve room's state between solves (the last answer: the next warm start)
        self.state = SolveState()

    # ------------------------------------------------------------------ what it holds
    @property
    def congruence(self) -> Congruence:
        """Mesh A and the start directions (the first aligned congruence)."""
        return self.registry.congruence

    @property
    def delta(self) -> float:
        """The mean edge length of mesh A: the unit every element term sees A in."""
        return self.registry.delta

    @property
    def weights(self) -> dict:
        """The default weight per term name (:data:`DEFAULT_WEIGHTS` with the overrides)."""
        return self.registry.weights

    @property
    def normalize(self) -> str:
        return self.nlp.normalize

    @property
    def jit(self) -> bool:
        return self.nlp.jit

    @property
    def hessian(self) -> str:
        return self.nlp.hessian

    @property
    def elastic(self) -> float:
        return self.nlp.elastic

    @property
    def n_var(self) -> int:
        return self.registry.n_var

    @property
    def terms(self) -> dict:
        """Registered terms and constraints by name: ``{name: (kind, weight or None, n_elements)}``."""
        return {k: ("constraint" if t.constraint else "energy", None if t.constraint else t.weight,
                    len(np.unique(t.elements)))
                for k, t in self.registry.terms.items()}

    def _add(self, term) -> "CongruenceProblem":
        """Register ``term``; where the NLP's structure changed, the built NLPs and the last
        answer go (parameters and weights alone keep them: the interactive loop's re-solve)."""
        if self.registry.add(term):
            self._structure_changed()
            self.nlp.exact_after_collapse = False
        return self

    def _structure_changed(self) -> None:
        """The NLPs are rebuilt at the next solve, from the congruences' directions."""
        self.nlp.forget()
        self.state.last = None

    def set_weight(self, name: str, weight: float) -> "CongruenceProblem":
        """Change one energy's weight (an NLP parameter: no rebuild)."""
        if name not in self.registry.terms or self.registry.terms[name].constraint:
            raise KeyError(f"no energy named {name!r}; energies: "
                           f"{sorted(k for k, t in self.registry.terms.items() if not t.constraint)}")
        if not (np.isfinite(weight) and weight >= 0):
            raise ValueError(f"weight of {name!r} must be a finite number >= 0, got {weight}")
        self.registry.terms[name].weight = float(weight)
        return self

    def move_vertices(self, vertices) -> "CongruenceProblem":
        """Move mesh A's vertices to ``vertices`` (n, 3), model units, keeping its faces: the
        start directions become the moved mesh's normals. Register every term again afterwards
        (its data are mesh A's points; solving before raises a clear error): a term over the
        same elements keeps the built NLP, whose mesh data are parameters, so a designer's
        moved point re-solves without a rebuild (:class:`torsal.session.Session`). The last
        answer stays the next warm start.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> v, f = facade_patch(nu=7, nv=5)
        >>> p = CongruenceProblem(Congruence.from_normals((v, f))).normal().fair().hyperbolic()
        >>> built = p.build()
        >>> v2 = v.copy(); v2[17] += [0.0, -0.05, 0.0]
        >>> p = p.move_vertices(v2).normal().fair().hyperbolic()
        >>> p.build(), p.solve().success         # the NLP built before, no rebuild
        (0.0, True)
        """
        self.registry.move_vertices(vertices)
        return self

    def remove(self, name: str) -> "CongruenceProblem":
        """Remove a term or constraint (the solver is rebuilt at the next solve)."""
        if name not in self.registry.terms:
            raise KeyError(f"no term named {name!r}; terms: {sorted(self.registry.terms)}")
        del self.registry.terms[name]
        self._structure_changed()
        return self

    # ------------------------------------------------------------------ evaluating
    def build(self, solver: str = NlpKind.IPOPT.value) -> float:
        """Assemble the NLP (done by :meth:`solve` when needed); returns the seconds it took.

        ``solver``: ``"ipopt"`` (the NLP IPOPT solves), ``"alm"`` (the same NLP with every
        element Hessian projected, see :mod:`.alm`) or ``"lbfgs"`` (constraints as
        penalties). The built NLP is kept until a term's element subset changes (parameters
        and weights can change freely).
        """
        return self.nlp.build(solver)

    def energies(self, directions=None) -> dict:
        """Unweighted energies and ``"total"`` (weighted, eq. (9)) at ``directions`` (default current).

        ``directions`` is (n, 3) for this congruence or the stacked (N, 3) of all aligned ones.
        """
        return self.nlp.evaluate(self.registry.check_directions(directions), rows=False)[0]

    def measure(self, directions=None, *, angle_tol_deg: float = 0.1,
                constraint_tol: float = 1e-6) -> dict[str, Measurement]:
        """Every constraint measured on the geometry at ``directions`` (default: current).

        Torsal angles, hyperbolicity and angles to ``d`` come from
        :class:`~torsal.geometry.congruence.Congruence` (not from the NLP); see
        :mod:`torsal.geometry.optimize.measure`.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5))).min_torsal_angle(30)
        >>> m = p.measure()["min_torsal_angle"]
        >>> m.unit, m.bound, bool(m.values.min() > 30)
        ('deg', 30.0, True)
        """
        e = self.registry.check_directions(directions)
        return self.nlp.measure(e, angle_tol_deg=angle_tol_deg, constraint_tol=constraint_tol)

    # ------------------------------------------------------------------ solving
    @property
    def optimum(self) -> Optimum | None:
        """The last solve's answer with its multipliers and penalties, None before a solve.

        Picklable: keep it (the pipeline's stage cache does) and hand it to
        :meth:`warm_start_from` of a problem with the same structure to re-solve from it
        after a change of a weight, a light direction, a stroke or a bound.
        """
        last = self.state.last
        return None if last is None else Optimum(directions=np.array(last.directions), lam_g=last.lam_g,
                                                 alm=last.alm, active=last.active, working=last.working,
                                                 lam_x=last.lam_x)

    def warm_start_from(self, optimum: Optimum) -> "CongruenceProblem":
        """The next :meth:`solve` starts from ``optimum`` (of this problem or one of the same
        structure): its directions, and its multipliers and penalties where they fit.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> c = Congruence.from_normals(facade_patch(nu=7, nv=5))
        >>> p = CongruenceProblem(c).normal().fair().perpendicular([0.3, -0.8, -0.5]).hyperbolic()
        >>> first = p.solve()
        >>> q = CongruenceProblem(c).normal().fair().perpendicular([0.35, -0.8, -0.5]).hyperbolic()
        >>> q.warm_start_from(p.optimum).solve().success
        True
        """
        if not isinstance(optimum, Optimum):
            raise TypeError("warm_start_from needs an Optimum (CongruenceProblem.optimum)")
        e = np.asarray(optimum.directions, dtype=float)
        if e.size != self.n_var or not np.isfinite(e).all():
            raise ValueError(f"the optimum has {e.size // 3} directions; this problem has {self.n_var // 3}")
        self.state.last = Optimum(directions=e.reshape(-1, 3), lam_g=optimum.lam_g, alm=optimum.alm,
                                  active=optimum.active, working=optimum.working, lam_x=optimum.lam_x)
        return self

    def solve(self, solver: str = SOLVERS[0], max_iter: int | None = None, tol: float = 1e-4,
              callback: Callable | None = None, *, warm_start: bool = True, initial=None,
              raise_on_failure: bool = False, verbose: bool = False, constraint_tol: float = 1e-6,
              angle_tol_deg: float = 0.1, penalty: float = 1e3, ipopt_options: dict | None = None,
              try_unconstrained: bool = True, max_seconds: float | None = None,
              keep_best: bool = True, certify: bool = False,
              stop: Stop | str = Stop.DESIGN) -> OptimizationResult:
        """Minimize the energies subject to the constraints.

        Parameters
        ----------
        solver : {"auto", "alm", "ipopt", "lbfgs"}
            ``"auto"`` (default): the fastest route to a measured-feasible optimum: the
            augmented Lagrangian for an NLP with inequality rows that it can solve (tangent
            chart, no lifted form or elastic slacks), IPOPT otherwise, where the augmented
            Lagrangian continues if IPOPT's pass without inequalities misses one (``"ipopt+alm"``);
            if the augmented Lagrangian ends without a measured-feasible answer, IPOPT
            continues from it. A warm re-solve of an augmented Lagrangian's answer continues
            with the augmented Lagrangian (its multipliers and penalties).
            ``"alm"``: the paper's augmented Lagrangian with projected-Newton steps, one
            sparse Cholesky factorization per step (:mod:`~torsal.geometry.optimize.alm`).
            ``"ipopt"``: interior point, exact Hessian, MUMPS, real inequality constraints
            (the solver of record).
            ``"lbfgs"``: the paper's baseline: scipy L-BFGS-B in rounds of 10 iterations with
            renormalization of the ``e_i`` after each round; constraints become penalties
            ``penalty * mean(min(c, 0)^2)``.
        max_iter : int, optional
            Iteration limit: Newton steps of the augmented Lagrangian (default 500), IPOPT
            iterations (default 200), L-BFGS iterations (default 1000). Limits are counts,
            so the answer does not depend on the machine's load.
        tol : float
            IPOPT's KKT tolerance, with the objective scaled by the number of vertices (the
            energies are means, so this makes the criterion per vertex and independent of the
            mesh size). The augmented Lagrangian has converged at a relative Newton decrement
            of ``tol * 1e-1`` with every constraint holding as measured (with ``stop="design"``
            it may end before, see ``stop``). L-BFGS: stop when a round decreases the
            objective by less than ``tol`` times the starting objective.
        stop : {"design", "converged"}
            ``"design"`` (default, :class:`~torsal.geometry.optimize.result.Stop`): the
            augmented Lagrangian also ends at the first iterate that holds every constraint
            as measured while its objective has stopped moving (relative Newton decrement and
            decrease over the last 10 Newton steps both below 1e-3,
            :data:`~torsal.geometry.optimize.alm.DESIGN_DECREMENT`; a warm re-solve before its
            10th step: at the rate of its last 3, :data:`~torsal.geometry.optimize.alm.WARM_WINDOW`): the digits after it do
            not change the fins, the light figures or the measured angles (examples 7c and 9,
            ``benchmarks/optimize_bench.py --tables stop``). ``"converged"``: to ``tol``.
            ``OptimizationResult.convergence`` says which ended the solve and how close to
            converged the answer is. IPOPT and L-BFGS stop at their own tests either way.
        callback : callable, optional
            Called each iteration with ``{"iteration", "objective", "infeasibility",
            "measured_violation"}`` (the last: worst measured violation as a multiple of its
            tolerance, see :class:`IterationRecord`); returning True stops the solve.
        warm_start : bool
            Start from the last solution (with IPOPT's constraint multipliers) when the
            problem structure is unchanged; otherwise from the congruence's directions.
        initial : (n, 3) float, optional
            Explicit start directions (overrides the warm start).
        raise_on_failure : bool
            Raise :class:`OptimizationError` instead of returning an unsuccessful result.
        verbose : bool
            Let IPOPT print its log.
        constraint_tol : float
            Measured violation above which ``hyperbolic`` (in ``c_hyp / delta^2``) and a user's
            own constraint count as not met.
        angle_tol_deg : float
            Measured violation (degrees) above which ``min_torsal_angle`` and ``max_angle_to``
            count as not met (default 0.1).
        penalty : float
            Penalty weight of constraints for ``lbfgs``.
        ipopt_options : dict, optional
            Extra IPOPT options (e.g. ``{"mumps_pivot_order": 7}``).
        max_seconds : float, optional
            A safety net, not a way to shape the result: a wall-time limit; at the limit the
            best feasible iterate is returned and ``OptimizationResult.time_limited`` (and the
            status) say that the answer depends on the machine's load.
        certify : bool
            After the augmented Lagrangian, IPOPT with all constraints from its answer and
            multipliers (warm start): a KKT point to IPOPT's tolerances; ``solver`` of the
            result is then ``"alm+ipopt"`` (kept as the augmented Lagrangian's answer, with a
            status that says so, where IPOPT does not converge).
        keep_best : bool
            When the solver stops early (iteration or time limit, callback) or ends on an
            iterate that misses a constraint as measured, return the lowest-objective iterate
            that was feasible as measured, if any (``from_iteration`` says which).
        try_unconstrained : bool
            IPOPT with inequality constraints: solve in up to three passes.

            1. Without the inequalities (equalities stay). If that answer meets every
               inequality to IPOPT's ``constr_viol_tol`` (1e-9) it is kept: a feasible local
               minimizer of the energy is a local minimizer of the constrained problem. This
               pays off where the constraints are not active but slow IPOPT down, e.g.
               ``hyperbolic`` when the energies favour near-parallel lines (``c_hyp`` is
               degenerate there, see :meth:`hyperbolic`): the bench's row 7a with
               ``hyperbolic()`` needs 14 iterations instead of 200.
            2. If at most 5% of the inequalities are violated: from pass 1's answer, with only
               those and the ones near their bound (the working set) imposed, adding any that
               the answer then violates. The others hold with slack, so their multipliers are
               zero and the answer is a KKT point of the whole problem; IPOPT carries barrier
               terms for a few elements instead of all. (``solver="auto"`` hands passes 2
               and 3 to the augmented Lagrangian: Fig. 13's mirror fins, 78 IPOPT iterations
               in pass 2 against 8 Newton steps.)
            3. Otherwise, or if pass 2 does not converge: all constraints, from the start (or
               from pass 1's answer where that violates fewer of them, e.g. a flat facade).

            ``max_iter`` bounds the iterations of all passes together (pass 1 gets at most
            half, pass 2 half of the rest; in a re-solve, half). A re-solve (warm start) starts at the pass that
            answered last: pass 2 keeps its working set (and multipliers) and grows it as
            needed; pass 3 keeps all constraints. ``OptimizationResult.constraints_active`` and
            ``.working_set`` say which pass gave the result.

        Returns
        -------
        OptimizationResult
            ``success`` needs a converged solver *and* every constraint holding as measured.
        """
        if stop not in STOPS:
            raise ValueError(f"stop must be one of {STOPS}, got {stop!r}")
        opts = SolveOptions(solver=solver, max_iter=max_iter, tol=tol, callback=callback, warm_start=warm_start,
                            initial=initial, raise_on_failure=raise_on_failure, verbose=verbose,
                            constraint_tol=constraint_tol, angle_tol_deg=angle_tol_deg, penalty=penalty,
                            ipopt_options=ipopt_options, try_unconstrained=try_unconstrained,
                            max_seconds=max_seconds, keep_best=keep_best, certify=certify, stop=Stop(stop))
        return SolveCall(self.registry, self.nlp, self.state, opts).run()
