"""Congruence optimization as a casadi NLP (Wang et al. 2013, 4.1, eq. (9)): the paper's augmented
Lagrangian with projected-Newton steps, IPOPT as the solver of record.

The mesh A is fixed; the variables are the line directions ``e_i`` (3 per vertex), so the
lines are ``a_i + lambda e_i`` and mesh B has vertices ``b_i = a_i + e_i``. A
:class:`CongruenceProblem` collects energies (eq. (9) and section 4.1) and constraints,
each over a vertex, face or edge subset, and :meth:`CongruenceProblem.solve` minimizes::

    f = sum_t w_t f_t(e)    subject to   c_j(e) >= 0,   ||e_i|| = 1

Assembly. Every term is one casadi ``SX`` function of one element
(:mod:`torsal.geometry.optimize.terms`) mapped over its elements with ``Function.map``. Value,
gradient, constraint Jacobian and the exact Hessian of the Lagrangian are assembled from
the mapped per-element derivatives (gradient, Jacobian rows, upper triangle of the local
Hessian) by constant sparse scatter matrices, and handed to IPOPT through ``nlpsol``'s
``grad_f`` / ``jac_g`` / ``hess_lag`` options, or to the augmented Lagrangian
(:mod:`.alm`: PHR multipliers and per-row penalties on the inequality rows, Newton steps with
one sparse Cholesky factorization of the projected Hessian plus ``rho J^T J`` each).
``solve()`` takes the augmented Lagrangian for constrained designs and IPOPT otherwise
(:mod:`.solve`); the result says which produced the answer and how long each part took. This keeps building and every Hessian
evaluation linear in the mesh size (casadi's automatic Hessian of a mapped graph colours
the whole problem and was ~100x slower on a 1k-vertex mesh). MUMPS is the linear solver.

Weights, light directions, target points, strokes and constraint margins are NLP
parameters: calling a term method again with the same element subset only changes
parameters, and the next :meth:`~CongruenceProblem.solve` re-uses the built solver,
warm-started from the last solution (the paper's interactive design loop).

Default weights are the paper's Fig. 12 values (the column alignment of that table is
ambiguous; these are the values the rows agree on most): ``normal 2``, ``fair 1``,
``fair_torsal 10``, ``perpendicular 1`` (rows 7b, 9, 11; 7a/7c use 10), ``parallel 0.1``
(row 9; 7c uses .2, 11 uses .01), ``torsal_plane 20`` (7d; 13 uses 5000),
``torsal_direction 0.1`` (7a, 7d), ``align 200`` (11). Terms the paper has no weight for:
``through_points 1``, ``closeness 1``.
Constraints are measured, not trusted: after every iterate and at the end, torsal angles,
hyperbolicity and angles to a direction are measured on the resulting congruence
(:mod:`.measure`), ``OptimizationResult.max_violation`` is in each constraint's own units
(degrees for angles), and a solve whose measured value misses a bound by more than 0.1
degree is not ``success``. ``min_torsal_angle`` is imposed in a split form (two rows per face,
linear in the torsal form's isotropic part, with a documented lower bound on its strength;
:class:`TorsalAngleForm`, :mod:`.forms`, :meth:`CongruenceProblem.min_torsal_angle`); a lifted
form (the torsal form's coordinates as NLP variables, the bound on variables) converges in
half the iterations but to rougher lines. One-sided inequalities can be made elastic
(``CongruenceProblem(elastic=rho)``, l1-exact slacks).

Package layout (one responsibility per module):

- :mod:`.problem`: :class:`CongruenceProblem`, the builder API: the term builders of
  :mod:`.energies` and :mod:`.constraints` over three parts, its terms (:mod:`.registry`), the
  NLPs built from them (:mod:`.cache`) and the solve state (:mod:`.strategy`);
- :mod:`.strategy`: the solve room's types: options, the solve state, starts and runs, the one
  strategy interface (``SolveStrategy``) and its composition (``Then``);
- :mod:`.solve`: one ``solve()`` call: the route, its composed strategy, the start, the
  measured answer;
- :mod:`.alm`: the augmented Lagrangian; :mod:`.factor`: its sparse Cholesky factorization;
- :mod:`.catalogue`: default weights, one term's data (:class:`~.catalogue.Term`), input checks;
- :mod:`.forms`: the forms of the torsal-angle constraint;
- :mod:`.kernels`: per-element derivative kernels, the gnomonic chart, C compilation;
- :mod:`.nlp`: assembly of the NLP (:class:`~.nlp.Built`);
- :mod:`.ipopt`: IPOPT options and the three-pass strategy; :mod:`.working_set`: pass 2;
- :mod:`.family`: a generated family of constrained designs (reliability checks);
- :mod:`.lbfgs`: the paper's L-BFGS baseline;
- :mod:`.measure`: constraints measured on the geometry;
- :mod:`.history`, :mod:`.result`: per-iteration history, best feasible iterate, the result
  (with how close to converged it is: ``OptimizationResult.convergence``, the stopping rule
  ``Stop``).
"""
from torsal.core.lazy import lazy_exports
__getattr__, __dir__ = lazy_exports(__name__, {
    ".catalogue": ("DEFAULT_WEIGHTS",),
    ".forms": ("TorsalAngleBetween", "TorsalAngleForm"),
    ".measure": ("Measurement",),
    ".nlp": ("tangent_frames",),
    ".problem": ("CongruenceProblem",),
    ".result": ("STOPS", "Convergence", "IterationRecord", "OptimizationError",
                "OptimizationResult", "Stop", "StopReason"),
    ".solve": ("SOLVERS", "Solver"),
})

__all__ = ["CongruenceProblem", "OptimizationResult", "OptimizationError", "DEFAULT_WEIGHTS",
           "IterationRecord", "Measurement", "TorsalAngleForm", "TorsalAngleBetween", "tangent_frames", "Solver",
           "SOLVERS", "Stop", "STOPS", "StopReason", "Convergence"]
