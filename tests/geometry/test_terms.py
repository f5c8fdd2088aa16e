"""Per-element casadi terms against independent numpy evaluations of the paper's formulas.

Wang et al. 2013, section 4.1 and eq. (9). Each casadi element function is evaluated on random
data and compared (1e-10 relative) with a numpy implementation written from the paper (or
with the numpy kernels of torsal.geometry.congruence); its casadi gradient is compared with
central finite differences.
"""
import casadi as ca
import numpy as np
import pytest

from torsal.geometry.optimize import terms as T
from torsal.geometry.congruence import face_frame, focal_coefficients, normality_residual, torsal_coefficients

RNG = np.random.default_rng(20131)
N = 40  # random samples per term


def _det(x, y, z):
    return np.einsum("...i,...i->...", x, np.cross(y, z))


def _eval(el: T.ElementTerm, x, data, par):
    """Evaluate an element function row by row through casadi's map (as the assembler does)."""
    m = len(x)
    out = el.fn.map(m)(x.T, data.T if data.size else ca.DM(0, m), par.T if par.size else ca.DM(0, m))
    return np.asarray(out).ravel()


def _random_faces(m=N):
    a = RNG.normal(size=(m, 3, 3))
    e = RNG.normal(size=(m, 3, 3)) * 0.3 + [0, 0, 1]
    return a, e


def _fd_check(el: T.ElementTerm, x, data, par, h=1e-6, rtol=1e-6):
    """Casadi gradient vs central differences of the casadi value, for a few samples."""
    xs = ca.SX.sym("x", el.fn.size1_in(0))
    g = ca.Function("g", [xs], [ca.gradient(el.fn(xs, data, par), xs)])
    grad = np.asarray(g(x)).ravel()
    fd = np.empty_like(x)
    for i in range(len(x)):
        xp, xm = x.copy(), x.copy()
        xp[i] += h
        xm[i] -= h
        fd[i] = (float(el.fn(xp, data, par)) - float(el.fn(xm, data, par))) / (2 * h)
    scale = np.abs(grad).max() + 1e-12
    assert np.max(np.abs(grad - fd)) <= rtol * scale + 1e-9, (grad, fd)


def _close(got, want, rtol=1e-10):
    scale = np.maximum(np.abs(want), 1e-300)
    assert np.all(np.abs(got - want) <= rtol * np.maximum(scale, np.abs(want).max() * 1e-6)), (got, want)


# ------------------------------------------------------------------------- f_norm (eq. 7)
def test_normality_matches_congruence_kernel_and_paper_formula():
    a, e = _random_faces()
    got = _eval(T.normality_element(), e.reshape(N, 9), a.reshape(N, 9), np.zeros((N, 0)))
    # independent 1: torsal.geometry.congruence kernel (face frame at the barycenter)
    verts = a.reshape(-1, 3)
    faces = np.arange(3 * N).reshape(N, 3)
    r = normality_residual(face_frame(verts, faces, e.reshape(-1, 3)))
    _close(got, r**2)
    # independent 2: the paper's printed formula with e_c = b_c - a_c
    ec = e.mean(axis=1)
    aij, aik = a[:, 1] - a[:, 0], a[:, 2] - a[:, 0]
    eij, eik = e[:, 1] - e[:, 0], e[:, 2] - e[:, 0]
    paper = (np.einsum("ij,ij->i", np.cross(aij, ec), np.cross(eik, ec))
             - np.einsum("ij,ij->i", np.cross(aik, ec), np.cross(eij, ec)))
    _close(got, paper**2)
    _fd_check(T.normality_element(), e[0].ravel(), a[0].ravel(), [])


def test_normality_vanishes_for_a_bundle_and_orthogonal_torsal_planes():
    # lines through a common centre: every face is a normal congruence piece (a sphere's normals)
    a = RNG.normal(size=(N, 3, 3))
    e = a - [0.3, -0.2, 5.0]
    got = _eval(T.normality_element(), e.reshape(N, 9), a.reshape(N, 9), np.zeros((N, 0)))
    assert np.max(np.abs(got)) < 1e-20 * np.max(np.abs(e)) ** 8


# ------------------------------------------------------------------------- f_fair (pairs)
def test_laplacian_pairs_sum_to_the_umbrella_energy():
    import scipy.sparse as sp

    from torsal.geometry.mesh import umbrella_laplacian
    from torsal.geometry.surfaces import facade_patch

    v, f = facade_patch(nu=6, nv=5)
    n = len(v)
    e = RNG.normal(size=(n, 3))
    L = umbrella_laplacian(f, n)
    want = np.sum((L @ e) ** 2)
    Q = (L.T @ L).tocoo()
    off = Q.row < Q.col
    i, j, q = Q.row[off], Q.col[off], Q.data[off]
    cnt = np.bincount(np.concatenate([i, j]), minlength=n)
    alpha = np.asarray(Q.diagonal()) / cnt
    data = np.stack([2 * q, alpha[i], alpha[j]], 1)
    got = _eval(T.laplacian_pair_element(), np.concatenate([e[i], e[j]], 1), data, np.zeros((len(i), 0)))
    assert abs(got.sum() - want) <= 1e-10 * want
    assert sp.issparse(L)


# ------------------------------------------------------------------------- vertex terms
def test_perpendicular_parallel_through_closeness_max_angle():
    e = RNG.normal(size=(N, 3))
    d = RNG.normal(size=(N, 3))
    a = RNG.normal(size=(N, 3))
    o = RNG.normal(size=(N, 3)) * 5
    z = np.zeros((N, 0))
    _close(_eval(T.perpendicular_element(), e, z, d), np.einsum("ij,ij->i", e, d) ** 2)
    _close(_eval(T.parallel_element(), e, z, d), np.sum(np.cross(e, d) ** 2, axis=1))
    _close(_eval(T.through_point_element(), e, a, o), np.sum(np.cross(o - a, e) ** 2, axis=1))
    _close(_eval(T.closeness_element(), e, z, d), np.sum((e - d) ** 2, axis=1))
    cos_t = RNG.uniform(-1, 1, size=(N, 1))
    got = _eval(T.max_angle_element(), e, z, np.concatenate([d, cos_t], 1))
    _close(got, np.einsum("ij,ij->i", e, d) - cos_t[:, 0])
    _close(_eval(T.unit_length_element(), e, z, z), np.sum(e**2, 1) - 1)
    for el, data, par in [(T.perpendicular_element(), [], d[0]), (T.parallel_element(), [], d[0]),
                          (T.through_point_element(), a[0], o[0]), (T.closeness_element(), [], d[0])]:
        _fd_check(el, e[0], data, par)


def test_through_point_is_squared_distance_for_unit_directions():
    e = RNG.normal(size=(N, 3))
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    a, o = RNG.normal(size=(N, 3)), RNG.normal(size=(N, 3))
    # distance of o from the line a + t e, by projection
    t = np.einsum("ij,ij->i", o - a, e)
    dist = np.linalg.norm(a + t[:, None] * e - o, axis=1)
    _close(_eval(T.through_point_element(), e, a, o), dist**2, rtol=1e-9)


# ------------------------------------------------------------------------- f_dir, f_plane
def _stroke(m=N):
    w1 = RNG.dirichlet([1, 1, 1], size=m)
    w2 = 2.0 / 3.0 - w1  # c = (w1 + w2) / 2 is the barycenter
    return w1, w2


def test_torsal_direction_is_line_coplanarity_and_eq1_in_stroke_direction():
    a, e = _random_faces()
    w1, w2 = _stroke()
    delta = 0.7
    got = _eval(T.torsal_direction_element(delta), e.reshape(N, 9), a.reshape(N, 9), np.c_[w1, w2])
    ap1, ap2 = np.einsum("mk,mki->mi", w1, a), np.einsum("mk,mki->mi", w2, a)
    ep1, ep2 = np.einsum("mk,mki->mi", w1, e), np.einsum("mk,mki->mi", w2, e)
    want = (_det(ap2 - ap1, ep1, ep2) / delta) ** 2
    _close(got, want)
    # the same through eq. (1): gamma0 u^2 + 2 gamma1 uv + gamma2 v^2 at c, (u, v) the stroke
    verts, faces = a.reshape(-1, 3), np.arange(3 * N).reshape(N, 3)
    g = torsal_coefficients(face_frame(verts, faces, e.reshape(-1, 3)))
    u, v = (w2 - w1)[:, 1], (w2 - w1)[:, 2]
    q = g[:, 0] * u * u + 2 * g[:, 1] * u * v + g[:, 2] * v * v
    # [a_p2-a_p1, e_p1, e_p2] = [da, e_c - de/2, e_c + de/2] = [da, e_c, de] = -gamma(u, v)
    _close(got, (q / delta) ** 2, rtol=1e-8)
    _fd_check(T.torsal_direction_element(delta), e[0].ravel(), a[0].ravel(), np.r_[w1[0], w2[0]])


def test_torsal_plane_adds_normal_component():
    a, e = _random_faces()
    w1, w2 = _stroke()
    n = RNG.normal(size=(N, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    got = _eval(T.torsal_plane_element(1.3), e.reshape(N, 9), a.reshape(N, 9), np.c_[w1, w2, n])
    fdir = _eval(T.torsal_direction_element(1.3), e.reshape(N, 9), a.reshape(N, 9), np.c_[w1, w2])
    _close(got, fdir + np.einsum("ij,ij->i", e.mean(1), n) ** 2)


# ------------------------------------------------------------------------- c_hyp, c_ang
def test_hyperbolicity_is_discriminant_of_eq3():
    a, e = _random_faces()
    delta, margin = 0.8, 0.05
    got = _eval(T.hyperbolicity_element(delta), e.reshape(N, 9), a.reshape(N, 9), np.full((N, 1), margin))
    c = focal_coefficients(face_frame(a.reshape(-1, 3), np.arange(3 * N).reshape(N, 3), e.reshape(-1, 3)))
    disc = c[:, 1] ** 2 - 4 * c[:, 0] * c[:, 2]
    _close(got, disc / delta**2 - margin)
    # the paper's printed form of c_hyp
    ec = e.mean(1)
    aij, aik, eij, eik = a[:, 1] - a[:, 0], a[:, 2] - a[:, 0], e[:, 1] - e[:, 0], e[:, 2] - e[:, 0]
    paper = (_det(aij, eik, ec) + _det(eij, aik, ec)) ** 2 - 4 * _det(eij, eik, ec) * _det(aij, aik, ec)
    _close(got, paper / delta**2 - margin)
    _fd_check(T.hyperbolicity_element(delta), e[0].ravel(), a[0].ravel(), [margin])


def _torsal_angle_numpy(a, e):
    """Acute angle (deg) at which the two torsal planes cross at the barycenter (each spanned by
    the line e_c and a torsal direction), NaN if elliptic."""
    fr = face_frame(a.reshape(-1, 3), np.arange(3 * len(a)).reshape(len(a), 3), e.reshape(-1, 3))
    g = torsal_coefficients(fr)
    disc = g[:, 1] ** 2 - g[:, 0] * g[:, 2]
    out = np.full(len(a), np.nan)
    for m in np.flatnonzero(disc > 0):
        # roots of g0 u^2 + 2 g1 u v + g2 v^2 as (u, v) directions, by numpy's polynomial solver
        if abs(g[m, 0]) > 1e-14:
            r = np.roots([g[m, 0], 2 * g[m, 1], g[m, 2]])  # u/v
            uv = [np.array([ri.real, 1.0]) for ri in r]
        else:
            r = np.roots([g[m, 2], 2 * g[m, 1]])  # v/u for the nonzero root, plus u-axis... (v = 0)
            uv = [np.array([1.0, 0.0]), np.array([1.0, r[0].real])]
        t = [x[0] * fr.a_u[m] + x[1] * fr.a_v[m] for x in uv]
        n = [np.cross(fr.e[m], x) for x in t]
        c = abs(n[0] @ n[1]) / (np.linalg.norm(n[0]) * np.linalg.norm(n[1]))
        out[m] = np.degrees(np.arccos(min(c, 1.0)))
    return out


@pytest.mark.parametrize("alpha", [20.0, 40.0, 60.0])
def test_torsal_angle_constraint_sign_matches_the_actual_angle(alpha):
    a, e = _random_faces(200)
    delta = 1.1
    c2 = np.cos(np.radians(alpha)) ** 2
    got = _eval(T.torsal_angle_element(delta), e.reshape(200, 9), a.reshape(200, 9), np.tile([c2, 1 - c2], (200, 1)))
    ang = _torsal_angle_numpy(a, e)
    hyper = np.isfinite(ang)
    assert hyper.sum() > 20 and (~hyper).sum() > 20, "the random sample must contain both kinds"
    # elliptic faces are infeasible; hyperbolic ones feasible iff the angle is at least alpha
    assert np.all(got[~hyper] < 0)
    clear = hyper & (np.abs(ang - alpha) > 1e-6)
    assert np.array_equal(got[clear] >= 0, ang[clear] >= alpha)
    _fd_check(T.torsal_angle_element(delta), e[0].ravel(), a[0].ravel(), [c2, 1 - c2])


def test_torsal_angle_closed_form_tan2():
    """tan^2(theta) = 4 (g1^2 - g0 g2) det M / T^2 against the numerically computed angle
    between the torsal planes, with M the metric of the face edges projected along the line."""
    a, e = _random_faces(100)
    fr = face_frame(a.reshape(-1, 3), np.arange(300).reshape(100, 3), e.reshape(-1, 3))
    g = torsal_coefficients(fr)
    n = fr.e / np.linalg.norm(fr.e, axis=1, keepdims=True)
    pu = fr.a_u - np.einsum("ij,ij->i", fr.a_u, n)[:, None] * n
    pv = fr.a_v - np.einsum("ij,ij->i", fr.a_v, n)[:, None] * n
    E = np.einsum("ij,ij->i", pu, pu)
    F = np.einsum("ij,ij->i", pu, pv)
    G = np.einsum("ij,ij->i", pv, pv)
    Tq = g[:, 0] * G - 2 * g[:, 1] * F + g[:, 2] * E
    D = g[:, 1] ** 2 - g[:, 0] * g[:, 2]
    ang = _torsal_angle_numpy(a, e)
    ok = np.isfinite(ang) & (ang > 1) & (ang < 89)
    tan2 = 4 * D[ok] * (E * G - F * F)[ok] / Tq[ok] ** 2
    assert np.allclose(np.degrees(np.arctan(np.sqrt(tan2))), ang[ok], atol=1e-6)


# ------------------------------------------------------------------------- f_fair/t
def _barycentric_2d(p, tri):
    """Barycentric coordinates of 2D point p in triangle tri (3, 2) by a linear solve."""
    m = np.array([[tri[0, 0], tri[1, 0], tri[2, 0]], [tri[0, 1], tri[1, 1], tri[2, 1]], [1.0, 1.0, 1.0]])
    return np.linalg.solve(m, np.array([p[0], p[1], 1.0]))


def test_fair_torsal_residual_is_scaled_barycentric_jump():
    delta = 0.9
    for _ in range(20):
        a = RNG.normal(size=(4, 3))
        e = RNG.normal(size=(4, 3)) * 0.3 + [0, 0, 1]
        res = T.fair_torsal_residual_sx(list(map(ca.DM, e)), list(map(ca.DM, a)), delta)
        got = np.asarray(ca.DM(res)).ravel()
        m = 0.5 * (e[0] + e[1])
        mu = m / np.linalg.norm(m)
        # orthonormal basis of the plane orthogonal to m; project A and B = A + e
        b1 = np.cross(mu, [1.0, 0, 0]) if abs(mu[0]) < 0.9 else np.cross(mu, [0, 1.0, 0])
        b1 /= np.linalg.norm(b1)
        b2 = np.cross(mu, b1)
        proj = lambda p: np.array([p @ b1, p @ b2])  # noqa: E731
        b = a + e
        lam = _barycentric_2d(proj(a[3]), np.array([proj(x) for x in a[:3]]))
        mu_b = _barycentric_2d(proj(b[3]), np.array([proj(x) for x in b[:3]]))
        # the residual is (lambda - mu) times the two (scaled) projected areas
        da = _det(a[1] - a[0], a[2] - a[0], m)
        db = _det(b[1] - b[0], b[2] - b[0], m)
        want = (lam - mu_b) * da * db / delta**4
        assert np.allclose(got, want, rtol=1e-9, atol=1e-12 * np.abs(want).max())
    el = T.fair_torsal_element(delta)
    _fd_check(el, (RNG.normal(size=(4, 3)) * 0.3 + [0, 0, 1]).ravel(), RNG.normal(size=12), [])


def test_fair_torsal_vanishes_for_parallel_lines_and_bundles():
    a = RNG.normal(size=(N, 4, 3))
    z = np.zeros((N, 0))
    par = np.tile([0.2, -0.1, 1.0], (N, 4))
    assert np.max(np.abs(_eval(T.fair_torsal_element(1.0), par, a.reshape(N, 12), z))) < 1e-24
    bundle = (a - [1.0, 2.0, -4.0]) * 0.3
    assert np.max(np.abs(_eval(T.fair_torsal_element(1.0), bundle.reshape(N, 12), a.reshape(N, 12), z))) < 1e-20


# ------------------------------------------------------------------------- f_extra
def test_alignment_is_cross_product_of_torsal_forms():
    a, e = _random_faces()
    a2, e2 = _random_faces()
    delta = 0.6
    got = _eval(T.torsal_alignment_element(delta), np.c_[e.reshape(N, 9), e2.reshape(N, 9)],
                np.c_[a.reshape(N, 9), a2.reshape(N, 9)], np.zeros((N, 0)))
    faces = np.arange(3 * N).reshape(N, 3)
    g1 = torsal_coefficients(face_frame(a.reshape(-1, 3), faces, e.reshape(-1, 3))) * [1, 2, 1]
    g2 = torsal_coefficients(face_frame(a2.reshape(-1, 3), faces, e2.reshape(-1, 3))) * [1, 2, 1]
    want = (np.linalg.norm(np.cross(g1, g2), axis=1) / delta**2) ** 2
    _close(got, want)
    # the same congruence is aligned with itself
    same = _eval(T.torsal_alignment_element(delta), np.c_[e.reshape(N, 9), e.reshape(N, 9)],
                 np.c_[a.reshape(N, 9), a.reshape(N, 9)], np.zeros((N, 0)))
    assert np.max(np.abs(same)) <= 1e-20 * np.max(want)


def test_custom_element_rejects_non_scalar():
    with pytest.raises(ValueError, match="scalar"):
        T.custom_element("bad", lambda e, a: e[0, :], k=3)


@pytest.mark.parametrize("alpha", [20.0, 40.0, 60.0, 80.0])
def test_torsal_angle_cone_sign_matches_the_actual_angle(alpha):
    """The regular c_ang form: feasible iff the measured angle is >= alpha and the form is
    stronger than the floor; parallel lines (a bundle) are infeasible."""
    a, e = _random_faces(200)
    delta = 1.1
    ca_ = np.cos(np.radians(alpha))
    got = _eval(T.torsal_angle_cone_element(delta), e.reshape(200, 9), a.reshape(200, 9),
                np.tile([ca_, 1e-9], (200, 1)))
    ang = _torsal_angle_numpy(a, e)
    hyper = np.isfinite(ang)
    assert np.all(got[~hyper] < 0)
    clear = hyper & (np.abs(ang - alpha) > 1e-4)
    assert np.array_equal(got[clear] >= 0, ang[clear] >= alpha)
    parallel = _eval(T.torsal_angle_cone_element(delta), np.tile([0, 0, 1.0], (1, 3)), a[:1].reshape(1, 9),
                     np.array([[ca_, 1e-3]]))
    assert parallel[0] == pytest.approx((ca_ - 1.0) * 1e-3)
    _fd_check(T.torsal_angle_cone_element(delta), e[0].ravel(), a[0].ravel(), [ca_, 1e-3])
