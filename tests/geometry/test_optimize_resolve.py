"""Warm re-solves for interactive design (issue 25: a re-solve from the previous optimum in
<= T/5): what a re-solve starts from and what it must not cost.

Judged by IPOPT's iteration counts and the answer's measured geometry, not by time.
"""
import pickle

import casadi as ca
import numpy as np
import pytest

from torsal.geometry.congruence import Congruence
from torsal.geometry.optimize import CongruenceProblem
from torsal.geometry.optimize.nlp import NumericFunction
from torsal.geometry.surfaces import facade_patch

SUN = np.array([0.3, -0.8, -0.5]) / np.linalg.norm([0.3, -0.8, -0.5])


def _lifted(c, sun=SUN):
    return (CongruenceProblem(c).normal().fair().perpendicular(sun, weight=10).closeness(weight=0.1)
            .hyperbolic().min_torsal_angle(50, form="lift"))


@pytest.fixture(scope="module")
def solved():
    c = Congruence.from_normals(facade_patch(nu=9, nv=9))
    p = _lifted(c)
    first = p.solve()
    assert first.success and first.solver == "ipopt"
    return c, p, first


def test_the_optimum_keeps_the_bound_multipliers_of_a_lifted_form(solved):
    """A lifted min_torsal_angle imposes its bound on variables (r >= s, |t| <= 1): the optimum
    keeps IPOPT's bound multipliers, nonzero exactly on variables at a bound, and they survive
    pickling (the pipeline's stage cache keeps the optimum)."""
    c, p, first = solved
    opt = pickle.loads(pickle.dumps(p.optimum))
    b = p.nlp.built["tangent"]
    assert opt.lam_x is not None and opt.lam_x.size == b.n_var
    x, fr = b.pack(first.congruence.directions)
    xf = b.full(x, b.parameters(p.registry.current(), fr))
    lbx, ubx = b.variable_bounds(p.registry.current())
    bounded = np.isfinite(lbx) | np.isfinite(ubx)
    assert np.abs(opt.lam_x[bounded]).max() > 0
    gap = np.minimum(xf - lbx, ubx - xf)[bounded]
    # complementary (an interior point: lam * gap ~ IPOPT's final barrier parameter)
    assert np.all(np.abs(opt.lam_x[bounded]) * gap < 1e-6 * np.abs(opt.lam_x).max())
    assert not np.any(opt.lam_x[~bounded])          # the directions have no bounds


def test_an_unchanged_lifted_design_resolves_in_no_iteration(solved):
    """Re-solving the unchanged problem from its optimum with all its multipliers starts at a KKT
    point: no iteration. Without the bound multipliers (as before they were kept) IPOPT starts
    dual-infeasible and takes at least one."""
    c, p, first = solved
    opt = p.optimum
    q = _lifted(c).warm_start_from(opt)
    again = q.solve()
    assert again.success and again.iterations == 0
    np.testing.assert_allclose(again.congruence.directions, first.congruence.directions, atol=1e-9)
    without = _lifted(c).warm_start_from(type(opt)(directions=opt.directions, lam_g=opt.lam_g, active=opt.active))
    r = without.solve()
    assert r.success and r.iterations >= 1


def test_a_changed_lifted_design_resolves_to_the_cold_answer(solved):
    """After the sun turns by 3 degrees, the warm re-solve (directions, constraint and bound
    multipliers) takes fewer iterations than a cold solve of the changed problem and ends at
    the same optimum, measured feasible."""
    c, p, first = solved
    turned = np.array([[np.cos(0.05), -np.sin(0.05), 0], [np.sin(0.05), np.cos(0.05), 0], [0, 0, 1]]) @ SUN
    q = _lifted(c).warm_start_from(p.optimum)
    q.perpendicular(turned, weight=10)
    warm, cold = q.solve(), _lifted(c, turned).solve()
    assert warm.success and cold.success
    assert warm.iterations < cold.iterations
    assert warm.objective == pytest.approx(cold.objective, rel=0.01)
    assert np.nan_to_num(warm.congruence.torsal_plane_angle()).min() >= 50 - 0.1


def test_numeric_function_matches_a_casadi_call():
    """NumericFunction (casadi's buffers) gives a casadi call's values, for repeated calls with
    new arguments, and refuses an argument of the wrong size."""
    x, p = ca.MX.sym("x", 4), ca.MX.sym("p", 2)
    fn = ca.Function("f", [x, p], [ca.sin(x) * p[0], ca.sum1(x * x) + p[1]])
    num = NumericFunction(fn)
    rng = np.random.default_rng(0)
    for _ in range(3):
        a, b = rng.standard_normal(4), rng.standard_normal(2)
        got, want = num(a, b), fn(a, b)
        for g, w in zip(got, want):
            np.testing.assert_allclose(g, np.asarray(w).ravel(), rtol=1e-15)
    with pytest.raises(ValueError, match="argument 1 has 3 entries"):
        num(a, np.zeros(3))


@pytest.mark.skipif(__import__("shutil").which("gcc") is None and __import__("shutil").which("cc") is None,
                    reason="needs a C compiler")
def test_ipopt_solves_with_compiled_values(tmp_path, monkeypatch):
    """The element values are compiled kernels too (IPOPT's solver is built without casadi's
    symbolic nlp_grad, which cannot differentiate them): the same values, the same iterates."""
    monkeypatch.setenv("TORSAL_KERNEL_CACHE", str(tmp_path / "kernels"))
    c = Congruence.from_normals(facade_patch(nu=5, nv=4))
    out = []
    for jit in (False, True):
        p = CongruenceProblem(c, jit=jit).normal().perpendicular(SUN).min_torsal_angle(50, form="lift")
        r = p.solve(solver="ipopt")
        b = p.nlp.built["tangent"]
        x, fr = b.pack(r.congruence.directions)
        ev, f, g = b.evaluate(x, b.parameters(p.registry.current(), fr))
        out.append((r, ev, f, g))
    (r0, *v0), (r1, *v1) = out
    assert r0.success and r1.success and r0.iterations == r1.iterations
    np.testing.assert_allclose(r1.congruence.directions, r0.congruence.directions, atol=1e-10)
    for a, b_ in zip(v0, v1):
        np.testing.assert_allclose(a, b_, rtol=1e-9, atol=1e-13)


def test_a_resolve_starts_near_or_far_from_stationarity(solved):
    """A small change (a weight x1.01) leaves the optimum near stationarity: IPOPT's warm start
    as it is ("near"). The sun turned by 15 degrees does not: the iterate and the bound
    multipliers are pushed off their bounds ("far"), and the answer is the cold one."""
    c, p, first = solved
    q = _lifted(c).warm_start_from(p.optimum)
    q.set_weight("perpendicular", 10.1)
    near = q.solve()
    kinds = {k[0] for k in q.nlp.built["tangent"].solvers}
    assert near.success and "near" in kinds and "far" not in kinds
    turned = np.array([[np.cos(0.26), -np.sin(0.26), 0], [np.sin(0.26), np.cos(0.26), 0], [0, 0, 1]]) @ SUN
    q.perpendicular(turned, weight=10.1)
    far, cold = q.solve(), _lifted(c, turned).set_weight("perpendicular", 10.1).solve()
    assert "far" in {k[0] for k in q.nlp.built["tangent"].solvers}
    assert far.success and cold.success
    assert far.objective == pytest.approx(cold.objective, rel=0.01)


def test_moved_vertices_are_parameters_of_the_built_nlp():
    """Mesh A's points are NLP parameters: after ``move_vertices`` and the terms registered
    again, the built NLP is kept (no rebuild) and evaluates the moved mesh's energies and rows
    exactly as a problem made on it; a solve before the terms are registered again is refused."""
    v, f = facade_patch(nu=9, nv=7)
    terms = lambda p: p.normal().fair().perpendicular(SUN, weight=10).hyperbolic().min_torsal_angle(30)
    p = terms(CongruenceProblem(Congruence.from_normals((v, f))))
    p.solve()
    built = dict(p.nlp.built)
    moved = v.copy()
    moved[31] += [0.02, -0.1, 0.05]
    with pytest.raises(ValueError, match="register them again"):
        p.move_vertices(moved).solve()
    terms(p)
    # the built NLPs are kept (the solve's strategy's; IPOPT's is built where it is needed)
    assert built and all(p.nlp.built.get(k) is b for k, b in built.items())
    assert p.build("alm") == 0.0
    fresh = terms(CongruenceProblem(Congruence.from_normals((moved, f))))
    e = p.optimum.directions
    got, want = p.energies(e), fresh.energies(e)
    assert got.keys() == want.keys()
    for k in want:
        assert got[k] == pytest.approx(want[k], rel=1e-12, abs=1e-15), k
    np.testing.assert_allclose(p.measure(e)["hyperbolic"].values, fresh.measure(e)["hyperbolic"].values,
                               rtol=1e-12, atol=1e-15)
    r = p.solve()
    assert r.success and r.min_torsal_angle_deg >= 30 - 0.1
