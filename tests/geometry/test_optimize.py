"""CongruenceProblem: NLP assembly, IPOPT solves and the paper's design goals (Wang et al. 2013, 4.1).

Small meshes only; every check is against an analytic truth or an independent numpy measure
(torsal.geometry.congruence), never against the optimizer's own report.
"""
import casadi as ca
import numpy as np
import pytest

from torsal.geometry.congruence import Congruence
from torsal.geometry.optimize import CongruenceProblem, OptimizationError, OptimizationResult
from torsal.geometry.surfaces import facade_patch, sphere_patch

SUN = np.array([0.3, -0.8, -0.5]) / np.linalg.norm([0.3, -0.8, -0.5])


@pytest.fixture(scope="module")
def facade():
    return Congruence.from_normals(facade_patch(nu=13, nv=9))


def _angles_deg(u, v):
    c = np.abs(np.einsum("ij,ij->i", u, v)) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
    return np.degrees(np.arccos(np.clip(c, 0, 1)))


def _noisy(n, max_deg, rng):
    ax = rng.standard_normal(n.shape)
    ax -= np.einsum("ij,ij->i", ax, n)[:, None] * n
    ax /= np.linalg.norm(ax, axis=1, keepdims=True)
    ang = np.radians(rng.uniform(0, max_deg, len(n)))[:, None]
    return np.cos(ang) * n + np.sin(ang) * ax


# ----------------------------------------------------------------------- assembly is exact
def test_the_problems_nlps_share_their_element_kernels(facade, monkeypatch):
    """Pass 1's NLP, the main one and the augmented Lagrangian's make each element function's
    kernels once per problem: the second and third build add none."""
    import torsal.geometry.optimize.nlp as nlp

    made = []
    local = nlp.Local
    monkeypatch.setattr(nlp, "Local", lambda *a, **k: made.append(a[0]) or local(*a, **k))
    v, f = facade_patch(nu=5, nv=4)
    p = (CongruenceProblem(Congruence.from_normals((v, f))).normal().fair().fair_torsal().perpendicular(SUN)
         .hyperbolic().min_torsal_angle(30))
    p.build()
    p.nlp.built["tangent"].derive()
    first = len(made)
    element_terms = {(id(t.element.fn), t.constraint) for t in p.registry.term_list("tangent") if t.matrix is None}
    assert first == len(element_terms) == len(p.nlp.kernels)
    p.nlp.without_inequalities("tangent")
    p.build("alm")
    assert len(made) == first
    p.remove("perpendicular")           # a new structure: the kernels go with the built NLPs
    assert not p.nlp.built and not p.nlp.kernels


@pytest.mark.parametrize("form", ["split", "lift"])
def test_lazy_nlp_values_match_the_eager_and_its_derived_expressions(facade, form):
    """IPOPT's main NLP assembles its values first and its derivatives on first use: the values
    equal an eagerly built NLP's and the derived objective and rows at the same point."""
    from torsal.geometry.optimize.nlp import Built

    v, f = facade_patch(nu=5, nv=4)
    c = Congruence.from_normals((v, f))
    p = (CongruenceProblem(c).normal().fair().fair_torsal().perpendicular(SUN)
         .torsal_direction([1, 4], [1.0, 0, 0.2]).hyperbolic().min_torsal_angle(30, form=form))
    p.build()
    b = p.nlp.built["tangent"]
    assert not b._derived
    x, fr = b.pack(_noisy(c.directions, 20, np.random.default_rng(5)))
    par = b.parameters(p.registry.current(), fr)
    x = b.full(x, par)
    ev, fval, g = b.evaluate(x, par)
    assert not b._derived and g.size == b.n_g > 0
    eager = Built(b.terms, b.n_vertices, b.mode, hessian=b.hessian)
    ev2, f2, g2 = eager.evaluate(x, par)
    np.testing.assert_allclose(np.asarray(ev).ravel(), np.asarray(ev2).ravel(), rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose([fval, *g], [f2, *g2], rtol=1e-12, atol=1e-14)
    f3, g3 = b.value(x, par)            # first use of a derived expression: assembled now
    assert b._derived and b.derive() == 0.0
    np.testing.assert_allclose([fval, *g], [float(f3), *np.asarray(g3).ravel()], rtol=1e-12, atol=1e-14)


@pytest.mark.parametrize("form", ["split", "lift"])
@pytest.mark.parametrize("normalize", ["tangent", "constraint"])
def test_assembled_gradient_and_hessian_match_finite_differences(facade, normalize, form):
    v, f = facade_patch(nu=5, nv=4)
    c = Congruence.from_normals((v, f))
    rng = np.random.default_rng(3)
    p = (CongruenceProblem(c, normalize=normalize).normal().fair().fair_torsal()
         .perpendicular(SUN).torsal_direction([1, 4], [1.0, 0, 0.2]).hyperbolic().min_torsal_angle(30, form=form))
    p.build()
    b = p.nlp.built[normalize]
    e = _noisy(c.directions, 20, rng)
    x0, fr = b.pack(e)
    par = b.parameters(p.registry.current(), fr)
    x0 = b.full(x0, par)              # lift: with the lifted variables (3 per face)
    assert x0.size == b.n_dir + (3 * len(c.faces) if form == "lift" else 0)
    x0 = x0 + 0.05 * rng.standard_normal(x0.size)
    lam_g = rng.standard_normal(b.n_g)
    f0, g0 = (np.asarray(v).ravel() for v in b.grad_f(x0, par))
    H = np.asarray(ca.densify(b.hess_lag(x0, par, 1.3, lam_g)))
    H = np.triu(H) + np.triu(H, 1).T
    _, J = b.jac_g(x0, par)
    J = np.asarray(ca.densify(J))
    h = 1e-6
    lifted = rng.choice(np.arange(b.n_dir, x0.size), 6, replace=False) if form == "lift" else np.zeros(0, int)
    for i in np.concatenate([rng.choice(b.n_dir, 8, replace=False), lifted]):
        dx = np.zeros(x0.size)
        dx[i] = h
        fp, gp = (np.asarray(v).ravel() for v in b.grad_f(x0 + dx, par))
        fm, gm = (np.asarray(v).ravel() for v in b.grad_f(x0 - dx, par))
        assert abs((fp - fm)[0] / (2 * h) - g0[i]) <= 1e-6 * (np.abs(g0).max() + 1e-12)
        gp_, Jp = b.jac_g(x0 + dx, par)
        gm_, Jm = b.jac_g(x0 - dx, par)
        dg = (np.asarray(gp_).ravel() - np.asarray(gm_).ravel()) / (2 * h)
        assert np.allclose(dg, J[:, i], atol=1e-6 * (np.abs(J).max() + 1e-12))
        # Hessian of the Lagrangian column i: d/dx_i (1.3 grad f + J^T lam_g)
        lag = lambda gg, JJ: 1.3 * gg + np.asarray(ca.densify(JJ)).T @ lam_g  # noqa: E731
        col = (lag(gp, Jp) - lag(gm, Jm)) / (2 * h)
        assert np.allclose(col, H[:, i], atol=1e-5 * (np.abs(H).max() + 1e-12))


@pytest.mark.skipif(__import__("shutil").which("gcc") is None and __import__("shutil").which("cc") is None,
                    reason="needs a C compiler")
def test_compiled_kernels_give_the_same_derivatives(tmp_path, monkeypatch):
    monkeypatch.setenv("TORSAL_KERNEL_CACHE", str(tmp_path / "kernels"))
    monkeypatch.chdir(tmp_path)   # code generation must not write into the working directory
    v, f = facade_patch(nu=5, nv=4)
    c = Congruence.from_normals((v, f))
    e = _noisy(c.directions, 20, np.random.default_rng(4))
    out = []
    for jit in (False, True):
        p = CongruenceProblem(c, jit=jit).normal().perpendicular(SUN).hyperbolic()
        p.build()
        b = p.nlp.built["tangent"]
        x0, fr = b.pack(e)
        x0 = x0 + 0.05
        par = b.parameters(p.registry.current(), fr)
        lam = np.linspace(-1, 1, b.n_g)
        out.append([np.asarray(ca.densify(v)).ravel() for v in
                    (*b.grad_f(x0, par), *b.jac_g(x0, par), b.hess_lag(x0, par, 0.7, lam))])
    for a, b_ in zip(*out):
        assert np.allclose(a, b_, rtol=1e-12, atol=1e-14)
    # the kernels really were compiled (not the silent interpreted fallback), nothing else left
    assert len(list((tmp_path / "kernels").glob("tk_*.so"))) >= 6
    assert sorted(x.name for x in tmp_path.iterdir()) == ["kernels"]
    assert not list((tmp_path / "kernels").glob(".tk_*"))
    # a second build of the same terms loads the same kernels, from this process's memo
    from torsal.geometry.optimize.kernels import Local
    from torsal.geometry.optimize.terms import torsal_angle_element

    fn = torsal_angle_element(1.0).fn
    k1, k2 = (Local(fn, 3, True, jit=True) for _ in range(2))
    assert k1.hess is k2.hess and k1.hess.class_name() == "External"


# ----------------------------------------------------------------------- normal congruences
def test_sphere_normal_congruence_has_zero_f_norm():
    v, f = sphere_patch(2.0, nu=9, nv=9, center=(0.5, 0.0, -1.0))
    c = Congruence(v, f, (v - [0.5, 0.0, -1.0]) / 2.0)
    en = CongruenceProblem(c).normal().energies()
    assert en["normal"] < 1e-28
    # and a clearly non-normal congruence (twisted lines) does not
    twist = c.directions + 0.3 * np.cross([0, 0, 1.0], v - v.mean(0))
    assert CongruenceProblem(Congruence(v, f, twist)).normal().energies()["normal"] > 1e-6


def test_noisy_start_returns_to_the_normals():
    """Wang et al. 2013, 5 (robustness): noise up to 50 degrees does not change the result."""
    v, f = sphere_patch(nu=11, nv=11)
    c = Congruence.from_normals((v, f))
    n = c.directions
    e0 = _noisy(n, 50.0, np.random.default_rng(1))
    assert _angles_deg(e0, n).mean() > 20
    # f_norm + f_fair have the parallel lines as a global minimum (both vanish there), so the
    # normals need an anchor: a weak closeness to them, the regularizer of the paper's eq. (8)
    p = CongruenceProblem(c).normal().fair().closeness(initial=n, weight=0.1)
    noisy = p.solve(initial=e0)
    clean = p.solve(initial=n)
    assert noisy.success and clean.success
    ang = _angles_deg(noisy.congruence.directions, n)
    assert ang.mean() < 2.0 and ang.max() < 6.0
    assert _angles_deg(noisy.congruence.directions, clean.congruence.directions).max() < 0.05
    assert noisy.energies_after["normal"] < 1e-3 * noisy.energies_before["normal"]


# ----------------------------------------------------------------------- the design goals
def _shading_problem(c):
    return (CongruenceProblem(c).fair().fair_torsal().closeness(weight=0.01)
            .perpendicular(SUN, weight=10))


def test_shading_with_hyperbolicity_constraint(facade):
    delta2 = facade.delta**2
    free = _shading_problem(facade).solve()
    assert free.success
    hyp_free = free.congruence.hyperbolicity() / delta2
    assert (hyp_free < -1e-6).sum() >= 3, "without the constraint some faces become elliptic"
    res = _shading_problem(facade).hyperbolic(margin=1e-6).solve()
    assert res.success, res.status
    out = res.congruence
    assert np.abs(out.directions @ SUN).mean() < 0.05
    assert np.abs(facade.directions @ SUN).mean() > 0.5
    assert (out.hyperbolicity() >= 0).all() and out.is_hyperbolic().all()
    assert res.max_violation["hyperbolic"] <= res.measured["hyperbolic"].tolerance    # c_hyp >= margin, measured
    assert np.allclose(np.linalg.norm(out.directions, axis=1), 1.0, atol=1e-12)
    assert res.constraints_active is True       # the solve without it broke it: solved with it


def test_inactive_inequalities_are_met_by_the_solve_without_them(facade):
    """Near its normals the facade's congruence is hyperbolic (real principal curvatures), so
    hyperbolic() and a mild angle bound are not active: the first pass (no inequalities) gives
    the answer, a local minimizer of the constrained problem too; the constrained solve lands
    on the same lines."""
    def problem(**kw):
        return (CongruenceProblem(facade, **kw).normal().fair().closeness(weight=0.1)
                .perpendicular(SUN, weight=0.1))

    # with hessian="auto" pass 1 has the Gauss-Newton Hessian: the same IPOPT run as the
    # energies' own solve with it, and the same minimizer as with the exact Hessian
    free = problem(hessian="gauss-newton").solve("ipopt")
    exact = problem(hessian="exact").solve("ipopt")
    assert free.success and exact.success
    assert _angles_deg(free.congruence.directions, exact.congruence.directions).max() < 0.05
    p = problem(hessian="auto").hyperbolic().min_torsal_angle(5)
    seen = []
    res = p.solve("ipopt", callback=seen.append)
    assert res.success and res.constraints_active is False, res.status
    assert res.iterations == free.iterations and len(seen) == res.iterations + 1    # one pass
    assert np.allclose(res.congruence.directions, free.congruence.directions, atol=1e-12)
    assert max(res.max_violation.values()) <= 1e-9
    assert "inactive" in res.summary()
    # positive semidefinite by construction: no regularization estimate for pass 1
    pass1 = p.nlp.built["tangent/without-inequalities"]
    assert pass1.psd and not p.nlp.built["tangent"].psd and set(pass1.hessian_shifts.values()) <= {0.0}
    # the main NLP only checked pass 1's rows: its derivatives were never assembled
    assert not p.nlp.built["tangent"]._derived
    both = problem().hyperbolic().min_torsal_angle(5).solve("ipopt", try_unconstrained=False)
    assert both.success and both.constraints_active is True
    assert _angles_deg(both.congruence.directions, res.congruence.directions).max() < 0.05
    assert free.constraints_active is None


def test_active_constraints_resolve_in_one_pass_within_max_iter(facade):
    p = _shading_problem(facade).hyperbolic(margin=1e-6)
    capped = p.solve("ipopt", max_iter=12)
    assert not capped.success and capped.iterations <= 12
    assert "Maximum_Iterations_Exceeded" in capped.status
    first = p.solve("ipopt", initial=facade.directions)
    assert first.success and first.constraints_active is True
    seen = []
    p.perpendicular(SUN @ np.array([[1.0, 0.05, 0], [-0.05, 1.0, 0], [0, 0, 1.0]]), weight=10)
    again = p.solve("ipopt", callback=seen.append)       # warm start, constraints were active: no first pass
    assert again.success and again.constraints_active is True
    assert len(seen) == again.iterations + 1


def test_working_set_imposes_only_the_constraints_that_matter(facade):
    """A hyperbolicity margin that 4 of 192 faces miss at the unconstrained optimum: pass 2
    imposes it on those and the faces near the bound only; the answer is the fully
    constrained solve's, and the faces left out hold with slack (zero multipliers)."""
    def problem():
        return CongruenceProblem(facade).normal().fair().closeness(weight=0.1).perpendicular(SUN, weight=0.1)

    delta2 = facade.delta**2
    free = problem().solve("ipopt")
    h = np.sort(free.congruence.hyperbolicity() / delta2)
    margin = 0.5 * (h[3] + h[4])
    missed = np.flatnonzero(free.congruence.hyperbolicity() / delta2 < margin)
    assert len(missed) == 4
    p = problem().hyperbolic(margin=margin)
    res = p.solve("ipopt")
    assert res.success and res.constraints_active is True, res.status
    ws = res.working_set["hyperbolic"]
    assert set(missed) <= set(ws) and len(ws) <= 0.1 * len(facade.faces)
    hyp = res.congruence.hyperbolicity() / delta2
    assert hyp.min() >= margin - 1e-9
    out = np.setdiff1d(np.arange(len(facade.faces)), ws)
    assert hyp[out].min() > margin + 1e-6              # left out: met with slack
    assert "working set" in res.summary()
    capped = problem().hyperbolic(margin=margin).solve("ipopt", max_iter=7)
    assert capped.iterations <= 7 and not capped.success
    full = problem().hyperbolic(margin=margin).solve("ipopt", try_unconstrained=False)
    assert full.success and full.working_set is None
    assert abs(res.objective - full.objective) <= 1e-6 * full.objective
    assert _angles_deg(res.congruence.directions, full.congruence.directions).max() < 0.05
    # the designer moves the sun: the re-solve keeps the working set and still agrees
    moved = SUN @ np.array([[1.0, 0.05, 0], [-0.05, 1.0, 0], [0, 0, 1.0]])
    again = p.perpendicular(moved, weight=0.1).solve("ipopt")
    ref = problem().hyperbolic(margin=margin).perpendicular(moved, weight=0.1).solve("ipopt", 
        initial=full.congruence.directions, try_unconstrained=False)
    assert again.success and again.working_set is not None, again.status
    assert (again.congruence.hyperbolicity() / delta2).min() >= margin - 1e-8
    assert _angles_deg(again.congruence.directions, ref.congruence.directions).max() < 0.05


def test_min_torsal_angle_holds_on_every_face(facade):
    free = _shading_problem(facade).solve()
    assert np.nanmin(free.congruence.torsal_plane_angle()) < 35
    res = _shading_problem(facade).hyperbolic().min_torsal_angle(40).solve()
    assert res.success, res.status
    ang = res.congruence.torsal_plane_angle()        # the fins' crossing angle, 4.1
    assert np.isfinite(ang).all()
    assert ang.min() >= 40 - 1e-3


def test_lines_pass_through_target_points(facade):
    target = np.array([0.0, -15.0, 3.0])
    vs = np.arange(40, 50)
    res = CongruenceProblem(facade).normal().fair().through_points(target, vs).solve()
    assert res.success
    e, a = res.congruence.directions[vs], facade.vertices[vs]
    dist = np.linalg.norm(np.cross(target - a, e), axis=1) / np.linalg.norm(e, axis=1)
    before = np.linalg.norm(np.cross(target - a, facade.directions[vs]), axis=1)
    assert before.max() > 0.5 * facade.delta
    assert dist.max() < 1e-3 * facade.delta


def test_torsal_directions_follow_strokes(facade):
    faces = np.arange(20, 40)
    stroke = np.array([1.0, 0.0, 0.3])
    corners = facade.vertices[facade.faces[faces]]
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    t = stroke - (normal @ stroke)[:, None] * normal

    def deviation(cong):
        td = cong.torsal_directions()[faces]
        return np.min([_angles_deg(td[:, k], t) for k in range(2)], axis=0)

    assert deviation(facade).max() > 10
    res = CongruenceProblem(facade).normal().fair().torsal_direction(faces, stroke, weight=10).solve()
    assert res.success
    assert deviation(res.congruence).max() < 2.0


def test_torsal_plane_term_turns_planes_towards_the_normal(facade):
    faces = np.arange(len(facade.faces))
    res = (CongruenceProblem(facade).normal().fair().torsal_plane(faces, normals=SUN)
           .hyperbolic(margin=1e-6).solve())
    assert res.success
    assert res.energies_after["torsal_plane"] < 0.05 * res.energies_before["torsal_plane"]
    planes = res.congruence.torsal_planes()
    ok = np.isfinite(planes).all(axis=(1, 2))
    assert ok.mean() > 0.95
    best = np.min([_angles_deg(planes[ok, k], np.tile(SUN, (ok.sum(), 1))) for k in range(2)], axis=0)
    assert np.median(best) < 10


def test_align_with_makes_torsal_directions_coincide():
    v, f = facade_patch(nu=9, nv=7)
    c1 = Congruence.from_normals((v, f))
    e2 = c1.directions + 0.8 * np.cross([0, 0, 1.0], v - v.mean(0)) / 6   # twisted: other torsal directions
    c2 = Congruence(v + 0.4 * c1.directions, f, e2)

    def deviation(a1, a2):
        t1, t2 = a1.torsal_directions(), a2.torsal_directions()
        return np.minimum(_angles_deg(t1[:, 0], t2[:, 0]), _angles_deg(t1[:, 0], t2[:, 1]))

    before = deviation(c1, c2)
    assert np.mean(~(before < 5)) > 0.3          # many faces differ by > 5 deg (or are elliptic)
    # closeness keeps both away from the degenerate parallel-lines minimum of f_fair
    q = CongruenceProblem(c2).fair().closeness()
    p = CongruenceProblem(c1).fair().closeness().align_with(q, weight=2e4)
    assert "aligned.closeness" in p.terms
    res = p.solve()
    assert res.success, res.status
    a1, a2 = res.congruences
    assert np.array_equal(a2.vertices, c2.vertices)
    dev = deviation(a1, a2)
    assert np.isfinite(dev).all()
    assert np.median(dev) < 1.0 and np.mean(dev < 5) > 0.95
    assert res.energies_after["align"] < 1e-2 * res.energies_before["align"]


# ----------------------------------------------------------------------- custom terms
def test_custom_term_equals_builtin_and_custom_constraint_holds(facade):
    p1 = CongruenceProblem(facade).perpendicular(SUN, weight=3.0)
    d = ca.DM(SUN)
    p2 = CongruenceProblem(facade).add_term("perpendicular", 3.0, lambda e, a: ca.dot(e[0, :].T, d) ** 2,
                                            over="vertices")
    e = _noisy(facade.directions, 30, np.random.default_rng(5))
    assert np.isclose(p1.energies(e)["perpendicular"], p2.energies(e)["perpendicular"], rtol=1e-12)
    # a face constraint: the mean line of every face leans at least 0.2 towards -z
    res = (CongruenceProblem(facade).fair().perpendicular([0, 0, 1.0], weight=10)
           .add_constraint("downward", lambda e, a: -(e[0, 2] + e[1, 2] + e[2, 2]) / 3, over="faces",
                           lower=0.2).solve())
    assert res.success, res.status
    ec = res.congruence.barycenter_directions()
    assert (ec[:, 2] <= -0.2 + 1e-6).all()
    assert res.max_violation["downward"] <= 1e-6


# ----------------------------------------------------------------------- the design loop
def test_resolve_with_new_parameters_reuses_the_solver(facade):
    p = CongruenceProblem(facade).normal().fair().perpendicular(SUN, weight=10).hyperbolic(margin=1e-6)
    first = p.solve()
    assert first.build_seconds > 0 and first.success
    sun2 = np.array([0.5, -0.7, -0.5]) / np.linalg.norm([0.5, -0.7, -0.5])
    built = dict(p.nlp.built)            # the NLPs the first solve built, by kind
    assert built
    p.perpendicular(sun2, weight=10).set_weight("fair", 2.0)
    again = p.solve()
    # nothing is rebuilt: a new sun and a weight are parameters of the NLPs built before (the
    # very objects are kept; a warm pass may add one it did not need the first time)
    assert all(p.nlp.built.get(k) is nlp for k, nlp in built.items())
    assert again.success
    assert np.abs(again.congruence.directions @ sun2).mean() < 0.05
    assert np.abs(again.congruence.directions @ sun2).mean() < np.abs(first.congruence.directions @ sun2).mean()
    # a new subset changes the structure: rebuilt
    kept = dict(p.nlp.built)
    p.perpendicular(sun2, vertices=np.arange(50))
    assert p.solve().build_seconds > 0
    assert not any(p.nlp.built.get(k) is nlp for k, nlp in kept.items())


@pytest.mark.parametrize("nu, nv", [(10, 10), (30, 20)])   # dense and Lanczos estimate
def test_first_hessian_regularization_is_the_analytic_curvature(nu, nv):
    """f = w/|V| sum <e_i, d>^2 on the sphere, in IPOPT's scaling (objective times |V|): the
    tangent-chart Hessian at e_i has eigenvalues 2w(1 - 2c^2) and -2w c^2 (c = <e_i, d>; the
    circle around d curves down), so IPOPT's first regularization is 1.25 * 2w c^2."""
    from torsal.geometry.surfaces import flat_facade

    c = Congruence.from_normals(flat_facade(nu=nu, nv=nv))       # all e_i = (0, -1, 0)
    w = 3.0
    p = CongruenceProblem(c, hessian="exact").perpendicular(SUN, weight=w)     # the exact Hessian's estimate
    r = p.solve()
    assert r.success and np.abs(r.congruence.directions @ SUN).max() < 1e-4
    cos = abs(SUN[1])
    expected = 1.25 * 2 * w * cos**2
    rel = 1e-9 if 2 * nu * nv <= 200 else 5e-2
    shifts = p.nlp.built["tangent"].hessian_shifts
    assert list(shifts.values()) == [pytest.approx(expected, rel=rel)]
    # another objective scaling on the same built problem: its own estimate, in its units
    r2 = p.solve(initial=c.directions, ipopt_options={"obj_scaling_factor": 2.0 * nu * nv})
    assert r2.success and list(p.nlp.built) == ["tangent"]
    assert sorted(shifts.values()) == [pytest.approx(expected, rel=rel), pytest.approx(2 * expected, rel=rel)]


def test_callback_gets_progress_and_can_stop(facade):
    seen = []
    res = CongruenceProblem(facade).normal().fair().perpendicular(SUN).solve(callback=seen.append)
    assert len(seen) >= res.iterations >= 1
    assert {"iteration", "objective", "infeasibility"} <= set(seen[0])
    stop = CongruenceProblem(facade).normal().fair().perpendicular(SUN).solve(callback=lambda s: True)
    assert not stop.success and stop.iterations <= 1


def test_infeasible_constraint_is_reported_and_can_raise(facade):
    p = CongruenceProblem(facade).fair().add_constraint("impossible", lambda e, a: e[0, 2], over="vertices",
                                                        lower=2.0)
    res = p.solve(max_iter=50)
    assert isinstance(res, OptimizationResult) and not res.success
    assert "impossible" in res.status and res.worst_constraint[0] == "impossible"
    assert res.max_violation["impossible"] > 0.5
    with pytest.raises(OptimizationError, match="impossible"):
        p.solve(max_iter=50, raise_on_failure=True)


# ----------------------------------------------------------------------- solvers and modes
@pytest.mark.parametrize("normalize", ["constraint", "renormalize"])
def test_normalization_modes_agree_on_the_shading_goal(facade, normalize):
    res = CongruenceProblem(facade, normalize=normalize).normal().fair().perpendicular(SUN, weight=10).solve()
    assert res.success, res.status
    e = res.congruence.directions
    assert np.allclose(np.linalg.norm(e, axis=1), 1.0, atol=1e-6)
    assert np.abs(e @ SUN).mean() < 0.05


def test_lbfgs_baseline_decreases_the_same_objective(facade):
    p = CongruenceProblem(facade).normal().fair().perpendicular(SUN, weight=10)
    res = p.solve(solver="lbfgs", max_iter=300)
    assert res.solver == "lbfgs"
    assert res.energies_after["total"] < 0.05 * res.energies_before["total"]
    assert np.allclose(np.linalg.norm(res.congruence.directions, axis=1), 1.0)


# ----------------------------------------------------------------------- bad input
def test_bad_input_gets_clear_errors(facade):
    p = CongruenceProblem(facade)
    with pytest.raises(ValueError, match="NaN"):
        p.perpendicular([np.nan, 0, 1])
    with pytest.raises(ValueError, match="shape"):
        p.perpendicular(np.ones((3, 3)))
    with pytest.raises(IndexError, match="out of range"):
        p.parallel([0, 0, 1.0], vertices=[0, 10_000])
    with pytest.raises(ValueError, match="zero"):
        p.perpendicular([0, 0, 0])
    with pytest.raises(ValueError, match="alpha_deg"):
        p.min_torsal_angle(95)
    with pytest.raises(ValueError, match="unknown weight"):
        CongruenceProblem(facade, weights={"nrml": 1.0})
    with pytest.raises(ValueError, match="normalize"):
        CongruenceProblem(facade, normalize="sometimes")
    with pytest.raises(ValueError, match="no terms"):
        CongruenceProblem(facade).solve()
    with pytest.raises(ValueError, match="lower bound"):
        p.add_constraint("x", lambda e, a: e[0, 0], lower=1.0, upper=0.0)
    with pytest.raises(ValueError, match="same faces"):
        CongruenceProblem(facade).align_with(CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5))))


def test_default_weights_are_the_papers(facade):
    p = (CongruenceProblem(facade).normal().fair().fair_torsal().perpendicular(SUN).parallel(SUN, vertices=[0])
         .torsal_direction([0], [1.0, 0, 0]).torsal_plane([1], normals=SUN))
    w = {k: v[1] for k, v in p.terms.items()}
    assert w == {"normal": 2.0, "fair": 1.0, "fair_torsal": 10.0, "perpendicular": 1.0, "parallel": 0.1,
                 "torsal_direction": 0.1, "torsal_plane": 20.0}
    assert CongruenceProblem(facade, weights={"normal": 5.0}).normal().terms["normal"][1] == 5.0
