"""The augmented Lagrangian's exact Newton steps with IPOPT's inertia correction, and a warm
re-solve's design tolerance (issues 43 and 44: the facade at 80 degrees crept on projected
steps where its exact Newton matrix was one small negative pivot from positive definite; the
let-through region's preview waited ten Newton steps for a window it had settled in)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from torsal.geometry.congruence import Congruence
from torsal.geometry.optimize import CongruenceProblem, alm, mumps
from torsal.geometry.optimize.factor import NotPositiveDefinite, SparseCholesky
from torsal.geometry.optimize.nlp import tangent_frames
from torsal.geometry.surfaces import facade_patch

SUN = np.array([0.3, -0.8, -0.5]) / np.linalg.norm([0.3, -0.8, -0.5])

needs_mumps = pytest.mark.skipif(not mumps.available(), reason="MUMPS cannot be called directly here")


@needs_mumps
def test_a_refused_factorization_counts_its_negative_pivots():
    """MUMPS's inertia travels with the refusal: a diagonal matrix with two negative entries."""
    import scipy.sparse as sp

    a = sp.csc_matrix(sp.diags([4.0, -1.0, 3.0, -2.0, 5.0]))
    f = SparseCholesky(a, "mumps")
    with pytest.raises(NotPositiveDefinite) as err:
        f.factor(a.data)
    assert err.value.negative == 2
    assert NotPositiveDefinite("no count").negative is None


def _solver():
    """An augmented Lagrangian on a small constrained facade (the rows' Jacobian set to zero)
    and the positions of its Hessian's diagonal among the Hessian's nonzeros."""
    c = Congruence.from_normals(facade_patch(nu=5, nv=5))
    p = CongruenceProblem(c).normal().fair().perpendicular(SUN).hyperbolic().min_torsal_angle(40)
    p.build("alm")
    b = p.nlp.built["tangent/alm"]
    par = b.parameters(p.registry.current(), tangent_frames(c.directions))
    a = alm.AugmentedLagrangian(b, par, None, lambda e: True, max_steps=10, tol=1e-4, backend="mumps")
    a.rel = 1e-10
    hs = b.hess_lag.sparsity
    col = np.repeat(np.arange(b.n_var), np.diff(np.asarray(hs.colind())))
    diag = np.flatnonzero(np.asarray(hs.row()) == col)
    assert diag.size == b.n_var       # every diagonal entry is in the pattern
    return a, b, diag


def _diagonal(b, diag, values):
    h = np.zeros(b.hess_lag.sparsity.nnz())
    h[diag] = values
    return h


@needs_mumps
def test_an_exact_matrix_one_small_pivot_from_definite_is_shifted_as_ipopt_does():
    """A diagonal exact Hessian with one entry -1e-9 (mean diagonal 1): refused at the
    Levenberg-Marquardt shift 1e-10, accepted at INERTIA_FIRST = 1e-8 (two factorizations), the
    direction that of ``diag + 1e-8 I``; the next exact step starts at a third of that shift
    and needs one factorization."""
    a, b, diag = _solver()
    d = np.ones(b.n_var)
    d[3] = -1e-9
    h, zero_j, zero_w = _diagonal(b, diag, d), np.zeros(a.sys.jac_rows.size), np.zeros(b.n_g)
    rhs = np.linspace(1.0, 2.0, b.n_var)
    scale = max(1.0, np.mean(np.abs(d)))      # K's mean diagonal, at least 1 (NewtonSystem.matrix)
    step, shift = a._exact(h, zero_j, zero_w, rhs)
    assert shift == alm.INERTIA_FIRST and a.counts["factorizations"] == 2 and a.counts["indefinite"] == 1
    np.testing.assert_allclose(step, -rhs / (d + alm.INERTIA_FIRST * scale), rtol=1e-9)
    assert a.inertia.last == alm.INERTIA_FIRST
    step, shift = a._exact(h, zero_j, zero_w, rhs)
    assert shift == pytest.approx(alm.INERTIA_FIRST * alm.INERTIA_SHRINK, rel=1e-15)
    assert a.counts["factorizations"] == 3
    np.testing.assert_allclose(step, -rhs / (d + shift * scale), rtol=1e-9)


@needs_mumps
def test_an_exact_matrix_far_from_definite_falls_back_at_once():
    """One entry -1 (one negative pivot no small shift removes): the retries up to INERTIA_MAX
    fail, and the next exact attempt is not retried; three negative pivots (more than
    INERTIA_PIVOTS): one factorization, no retry."""
    a, b, diag = _solver()
    zero_j, zero_w, rhs = np.zeros(a.sys.jac_rows.size), np.zeros(b.n_g), np.ones(b.n_var)
    d = np.ones(b.n_var)
    d[3] = -1.0
    h = _diagonal(b, diag, d)
    step, shift = a._exact(h, zero_j, zero_w, rhs)
    assert step is None and shift == alm.INERTIA_MAX and not a.inertia.retry
    tries = a.counts["factorizations"]
    assert tries == 1 + round(np.log10(alm.INERTIA_MAX / alm.INERTIA_FIRST) / np.log10(alm.INERTIA_GROW)) + 1
    assert a._exact(h, zero_j, zero_w, rhs)[0] is None and a.counts["factorizations"] == tries + 1
    b2 = _solver()
    a2 = b2[0]
    d[[5, 7]] = -1.0
    assert a2._exact(_diagonal(b2[1], b2[2], d), zero_j, zero_w, rhs)[0] is None
    assert a2.counts["factorizations"] == 1 and a2.inertia.retry


def test_a_warm_resolve_reads_the_design_tolerance_at_the_rate_of_its_last_steps():
    """_recent_decrease: a cold solve's over DESIGN_WINDOW Newton steps (None before); a warm
    re-solve's before that many at the rate of its last WARM_WINDOW steps, scaled to
    DESIGN_WINDOW."""
    f = [10.0, 9.0, 8.5, 8.4, 8.39]
    warm = SimpleNamespace(objectives=f, warm=True)
    w = alm.WARM_WINDOW
    assert alm._recent_decrease(warm) == pytest.approx(
        (f[-1 - w] - f[-1]) / f[-1] * alm.DESIGN_WINDOW / w, rel=1e-15)
    assert alm._recent_decrease(SimpleNamespace(objectives=f, warm=False)) is None
    assert alm._recent_decrease(SimpleNamespace(objectives=f[:w], warm=True)) is None
    long = list(np.linspace(2.0, 1.0, alm.DESIGN_WINDOW + 3))
    for warm_ in (True, False):
        r = SimpleNamespace(objectives=long, warm=warm_)
        assert alm._recent_decrease(r) == pytest.approx((long[-1 - alm.DESIGN_WINDOW] - 1.0) / 1.0, rel=1e-15)


def test_the_correction_takes_a_facade_at_80_degrees_in_fewer_newton_steps(monkeypatch):
    """A miniature of issue 44's facade at min_torsal_angle 80 (energies that reach zero, the
    bound active): exact steps whose matrix needed the shift, and fewer Newton steps than
    without the correction (21 against 30), to the same energy and the bound as measured."""
    c = Congruence.from_normals(facade_patch(nu=9, nv=9))

    def solve():
        return (CongruenceProblem(c).normal(weight=2).fair().perpendicular(SUN, weight=10).hyperbolic()
                .min_torsal_angle(80).solve())

    with_it = solve()
    monkeypatch.setattr(alm, "INERTIA_PIVOTS", 0)
    without = solve()
    assert with_it.success and without.success
    assert with_it.counts["corrected"] > 0 and without.counts["corrected"] == 0
    assert with_it.counts["newton_steps"] < without.counts["newton_steps"]
    # the energies here are 3e-6 of the start's: converged answers of this design spread by 2 %
    # (2.864e-6 .. 2.956e-6 at tol 1e-4 .. 1e-6, every one measured feasible)
    assert with_it.objective == pytest.approx(without.objective, rel=3e-2)
    assert with_it.min_torsal_angle_deg >= 80 - 0.1


def test_a_warm_resolve_ends_at_the_design_tolerance_before_the_window():
    """The shading miniature of test_optimize_stop (energies well above zero) re-solved after
    fair_torsal's weight 10 -> 12: the warm re-solve ends by the design tolerance before
    DESIGN_WINDOW Newton steps (4 against 9 to convergence), measured
    feasible, its energy that of the same warm re-solve to convergence to 1e-3; the rule
    read back from its history."""
    from torsal.geometry.optimize.result import StopReason
    from torsal.geometry.surfaces import canopy

    c = Congruence.from_normals(canopy(nu=11, nv=11))

    def warm():
        p = (CongruenceProblem(c).fair().fair_torsal(weight=10).perpendicular([0, 0, -1.0])
             .parallel([0.3, 0.2, -1.0], vertices=np.arange(5), weight=0.1).hyperbolic().min_torsal_angle(60))
        p.solve()
        p.set_weight("fair_torsal", 12)
        return p

    d, full = warm().solve(), warm().solve(stop="converged")
    assert d.convergence.reason is StopReason.DESIGN and d.success and d.feasible, d.status
    assert d.iterations <= alm.DESIGN_WINDOW and d.iterations < full.iterations
    assert d.objective == pytest.approx(full.objective, rel=1e-3)
    assert d.min_torsal_angle_deg >= 60 - 0.1
    h, w = d.history, alm.WARM_WINDOW
    rate = (h[-1 - w].objective - h[-1].objective) / h[-1].objective * alm.DESIGN_WINDOW / w
    assert abs(rate) <= alm.DESIGN_DECREASE and d.convergence.recent_decrease == pytest.approx(rate, rel=1e-9)
    assert f"at the rate of the last {w}" in d.status
