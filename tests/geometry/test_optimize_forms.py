"""The formulations of the torsal-angle constraint reach the same optimum (issue 16).

``min_torsal_angle`` in split form (two rows per face, linear in the isotropic part ``p``; the
default), in the previous cone form (``sqrt(p^2 + s^2)``), the split form with elastic
slacks (an l1-exact penalty), the lifted form (variables ``(r, t, phi)`` per face, the bound as
variable bounds) are different NLPs with the same feasible set up to the strength floor, and
the augmented Lagrangian (``solver="alm"``, split form) is a different method for the split
NLP. On a small doubly curved patch where the bound is active they must give the same
directions and energy, and every face's torsal angle, measured with numpy from eq. (1), must
hold the bound.
"""
import numpy as np
import pytest

from torsal.geometry.congruence import Congruence
from torsal.geometry.optimize import CongruenceProblem
from torsal.geometry.optimize.forms import SPLIT_SCALE, torsal_angle_split_element
from torsal.geometry.surfaces import facade_patch

SUN = np.array([0.3, -0.8, -0.5]) / np.linalg.norm([0.3, -0.8, -0.5])
ALPHA = 85.0
FLOOR = 1e-5     # strength floor (rad per edge), small: both forms then say |p| <= cos(alpha) rho


def _torsal_angle_numpy(c: Congruence) -> np.ndarray:
    """Acute angle (deg) at which the torsal planes of each face cross, from eq. (1) directly:
    the null directions (u, v) of g0 u^2 + 2 g1 u v + g2 v^2 at the barycenter, mapped to
    u a_u + v a_v, spanning a plane with the line e_c each; the angle between those two planes
    is the angle between the normals e_c x d. 0 where the face has none."""
    a, e = c.vertices[c.faces], c.directions[c.faces]
    a_u, a_v = a[:, 1] - a[:, 0], a[:, 2] - a[:, 0]
    e_u, e_v, ec = e[:, 1] - e[:, 0], e[:, 2] - e[:, 0], e.mean(axis=1)
    det = lambda x, y, z: np.einsum("ij,ij->i", x, np.cross(y, z))
    g0, g2 = det(e_u, a_u, ec), det(e_v, a_v, ec)
    g1 = 0.5 * (det(e_u, a_v, ec) + det(e_v, a_u, ec))
    out = np.zeros(len(g0))
    for k in range(len(g0)):
        roots = np.roots([g0[k], 2 * g1[k], g2[k]]) if abs(g0[k]) > 1e-14 else np.array([0.0])
        if abs(g0[k]) <= 1e-14:          # u = 0 is one null direction, the other from 2 g1 u + g2 v = 0
            dirs = [a_v[k], 2 * g1[k] * a_v[k] - g2[k] * a_u[k]] if abs(g1[k]) > 1e-14 else []
        elif np.iscomplexobj(roots) and np.any(np.abs(roots.imag) > 1e-12):
            dirs = []
        else:
            dirs = [r.real * a_u[k] + a_v[k] for r in roots]   # u/v = r
        if len(dirs) == 2:
            n1, n2 = (np.cross(ec[k], d) / np.linalg.norm(np.cross(ec[k], d)) for d in dirs)
            out[k] = np.degrees(np.arccos(min(abs(n1 @ n2), 1.0)))
    return out


#: the module's tests share its solves (11 s of setup): on one xdist worker
#: (make test's --dist loadgroup) it is made once; tests split over the two workers
#: would make it twice
pytestmark = pytest.mark.xdist_group("optimize-forms")


@pytest.fixture(scope="module")
def solved():
    c = Congruence.from_normals(facade_patch(nu=9, nv=7))
    out = {}

    def problem(elastic=0.0):
        # closeness picks one of the many directions perpendicular to the sun
        return CongruenceProblem(c, elastic=elastic).normal().fair().perpendicular(SUN).closeness(weight=0.1)

    for label, form, elastic, solver in (("cone", "cone", 0.0, "ipopt"), ("split", "split", 0.0, "ipopt"),
                                         ("elastic", "split", 1e4, "ipopt"), ("lift", "lift", 0.0, "ipopt"),
                                         ("alm", "split", 0.0, "alm")):
        p = problem(elastic).min_torsal_angle(ALPHA, form=form, min_strength=FLOOR)
        out[label] = p.solve(solver=solver, max_iter=400)
    return out, problem().solve()


def test_the_bound_is_active(solved):
    out, free = solved
    assert _torsal_angle_numpy(free.congruence).min() < ALPHA - 20     # without it, faces close up
    assert out["split"].objective > free.objective * (1 + 5e-4)


@pytest.mark.parametrize("label", ["cone", "split", "elastic", "lift", "alm"])
def test_every_form_holds_the_bound_as_measured_independently(solved, label):
    r = solved[0][label]
    # the cone form's 1/s curvature at p = 0 keeps IPOPT from converging in 400 iterations
    # at this floor (measured); the split form converges in about 20
    assert r.feasible and (r.success or label == "cone"), r.status
    ang = _torsal_angle_numpy(r.congruence)
    assert ang.min() >= ALPHA - 0.1
    np.testing.assert_allclose(ang, np.nan_to_num(r.congruence.torsal_plane_angle()), atol=1e-6)


@pytest.mark.parametrize("label", ["cone", "elastic", "lift", "alm"])
def test_the_forms_reach_the_same_optimum(solved, label):
    out, _ = solved
    ref, r = out["split"], out[label]
    # the bound raises the objective by ~9e-4 (relative) over the free optimum; the cone form
    # ends 2e-3 above the split form's (its 1/s curvature at p = 0 stalls IPOPT, see above)
    assert r.objective == pytest.approx(ref.objective, rel=3e-3 if label == "cone" else 3e-4)
    dev = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", r.congruence.directions,
                                                 ref.congruence.directions), -1, 1)))
    assert dev.max() < (1.5 if label == "cone" else 0.5)


def test_split_rows_say_abs_p_below_cos_alpha_rho():
    """Both rows of a face are >= 0 iff the torsal angle is >= alpha (well above the floor)."""
    a = np.array([0, 0, 0, 1, 0, 0, 0, 1, 0.0])
    fn = torsal_angle_split_element().fn
    for t in np.linspace(0.02, 0.2, 7):
        for k in np.linspace(-0.2, 0.2, 9):          # e(x, y) = normal of z = (t x^2 + k y^2) / 2 ...
            e = np.array([[0, 0, 1.0], [-t, 0, 1.0], [0, -k, 1.0]])
            e /= np.linalg.norm(e, axis=1, keepdims=True)
            c = Congruence(a.reshape(3, 3), np.array([[0, 1, 2]]), e)
            ang = np.nan_to_num(c.torsal_plane_angle())[0]
            rows = [float(fn(e.ravel(), a, [np.cos(np.radians(40)), 1e-6, s])) for s in (1, -1)]
            if abs(ang - 40) > 0.5:
                assert (min(rows) >= 0) == (ang >= 40), (t, k, ang, rows)


def test_split_rows_stay_bounded_where_a_line_turns_into_its_face():
    """A face whose lines tilt into the face's plane: the torsal form's invariants grow without
    bound (the face seen along the line degenerates), the split rows, divided by the form's
    magnitude, stay within (1 + cos(alpha)) (1 + s / k) and still say what the torsal angle
    measured with numpy says (feasible iff the planes cross at alpha or more)."""
    import casadi as ca

    from torsal.geometry.optimize import terms as T

    x, data, _ = T.face_symbols(3, n_par=0)
    frame = T._frame(T._split(x, 3), T._split(data, 3))
    inv = ca.Function("inv", [x, data], list(T.torsal_form_invariants_sx(*frame)))
    fn = torsal_angle_split_element().fn
    a = np.array([0, 0, 0, 1, 0, 0, 0, 1, 0.0])
    alpha = 40.0
    ca40 = np.cos(np.radians(alpha))
    mags, seen = {}, set()
    for tilt in (60.0, 20.0, 5.0, 1.0, 0.2):          # the lines' angle with the face's plane
        for spread in (0.05, 0.2):
            for twist in (-1.0, 0.3, 1.0):
                c0 = np.array([np.cos(np.radians(tilt)), 0.0, np.sin(np.radians(tilt))])
                e = np.array([c0, c0 + [0, spread, spread * twist],
                              c0 + [0, -spread * twist, spread]])
                e /= np.linalg.norm(e, axis=1, keepdims=True)
                p, rho2 = (float(v) for v in inv(e.ravel(), a))
                mags[tilt, spread, twist] = np.hypot(p, np.sqrt(max(rho2, 0.0)))
                rows = [float(fn(e.ravel(), a, [ca40, 1e-6, s])) for s in (1, -1)]
                bound = (1 + ca40) * (1 + 1e-6 / SPLIT_SCALE)
                assert max(abs(r) for r in rows) <= bound, (tilt, rows)
                face = Congruence(a.reshape(3, 3), np.array([[0, 1, 2]]), e)
                ang = np.nan_to_num(face.torsal_plane_angle())[0]
                if abs(ang - alpha) > 0.5:
                    assert (min(rows) >= 0) == (ang >= alpha), (tilt, spread, twist, ang, rows)
                    seen.add(bool(ang >= alpha))
    # the pole the division takes out: the same lines, tilted from 60 to 0.2 degrees
    assert mags[0.2, 0.2, -1.0] > 30 * mags[60.0, 0.2, -1.0], mags
    assert seen == {True, False}                        # both sides of the bound were met


def test_hyperbolic_rows_implied_by_the_angle_bound_are_left_out_and_still_measured():
    c = Congruence.from_normals(facade_patch(nu=9, nv=7))
    faces = np.arange(0, len(c.faces), 2)          # the angle bound on every other face
    p = (CongruenceProblem(c).normal().fair().perpendicular(SUN, weight=10)
         .hyperbolic().min_torsal_angle(40, faces=faces))
    p.build()
    rows = {t.name: t for t in p.nlp.built["tangent"].cons}
    assert set(rows["hyperbolic"].elements) == set(range(len(c.faces))) - set(faces)
    r = p.solve(max_iter=300)
    assert r.success, r.status
    h = r.congruence.hyperbolicity()                  # eq. (2), on every face
    assert set(r.measured["hyperbolic"].elements) == set(range(len(c.faces)))
    assert h.min() >= -1e-9 * p.delta**2
    assert np.nan_to_num(r.congruence.torsal_plane_angle())[faces].min() >= 40 - 0.1
    # a positive margin is not implied: every face gets its row again
    p.hyperbolic(margin=1e-4)
    p.build()
    assert len(p.nlp.built["tangent"].cons[0].elements) == len(c.faces)


def test_lifted_coordinates_are_the_invariants():
    """(u, v, w) of forms.torsal_form_coordinates_sx: u = p and v^2 + w^2 = rho^2 of
    terms.torsal_form_invariants_sx, and |u| / sqrt(v^2 + w^2) is the cosine of the measured
    angle between the torsal planes."""
    from torsal.geometry.optimize.forms import torsal_form_coordinates_element

    fn = torsal_form_coordinates_element().fn
    rng = np.random.default_rng(3)
    a = np.array([0, 0, 0, 1.1, 0.1, 0, 0.3, 0.9, 0.05])
    for _ in range(20):
        e = np.array([[0, 0, 1.0], [0, 0, 1.0], [0, 0, 1.0]]) + 0.2 * rng.standard_normal((3, 3))
        e /= np.linalg.norm(e, axis=1, keepdims=True)
        u, v, w = (float(fn(e.ravel(), a, [0.5, 1e-3, *k])) for k in np.eye(3))
        c = Congruence(a.reshape(3, 3), np.array([[0, 1, 2]]), e)
        ang = c.torsal_plane_angle()[0]
        if np.hypot(v, w) > abs(u) * (1 + 1e-9):
            assert np.degrees(np.arccos(abs(u) / np.hypot(v, w))) == pytest.approx(ang, abs=1e-6)
        else:
            assert np.isnan(ang) or ang == pytest.approx(0.0, abs=1e-3)


def test_energies_of_a_lifted_design_need_no_lifted_variables():
    """The energies and the objective (the report's before/after) are evaluated without
    fitting the lifted variables (they enter only the lifted rows): the same numbers as with
    them, and as the split form's NLP gives at the same directions."""
    c = Congruence.from_normals(facade_patch(nu=6, nv=5))
    e = c.directions + 0.02 * np.random.default_rng(4).standard_normal(c.directions.shape)
    e /= np.linalg.norm(e, axis=1, keepdims=True)

    def make(form):
        return CongruenceProblem(c).normal().fair().perpendicular(SUN).hyperbolic().min_torsal_angle(40, form=form)

    lifted = make("lift")
    with_rows, without = lifted.nlp.evaluate(e), lifted.nlp.evaluate(e, rows=False)
    assert with_rows[0] == without[0] and with_rows[1] == without[1]
    assert make("split").nlp.evaluate(e)[0] == pytest.approx(without[0], rel=1e-12)
    assert lifted.nlp.built["tangent"].n_lift > 0


@pytest.mark.parametrize("form", ["lift"])
def test_lbfgs_baseline_penalizes_every_form_as_its_split_rows(form):
    """The paper's L-BFGS has only the directions as variables: a lifted bound is
    penalized as the split rows over the same faces, so it walks exactly as with split
    (before the fix, the lifted term's 3 rows per face were fed as parameters of 2: an error)."""
    c = Congruence.from_normals(facade_patch(nu=7, nv=6))

    def solve(f):
        p = CongruenceProblem(c).normal().fair().perpendicular(SUN).min_torsal_angle(40, form=f)
        return p.solve(solver="lbfgs", max_iter=30)

    ref, r = solve("split"), solve(form)
    assert r.iterations == ref.iterations and r.objective == ref.objective
    np.testing.assert_array_equal(r.congruence.directions, ref.congruence.directions)
