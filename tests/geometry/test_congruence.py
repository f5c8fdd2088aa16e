"""Congruence quantities against analytic truth (Wang et al. 2013, eqs. (1)-(3), (7))."""
import numpy as np
import pytest
import trimesh

from torsal.geometry.congruence import (
    Congruence,
    face_frame,
    focal_coefficients,
    torsal_coefficients,
)
from torsal.geometry.surfaces import cylinder_patch, graph_surface, sphere_patch


def _angle_deg(u, v):
    """Angle between lines (sign-free), degrees."""
    c = np.abs(np.einsum("ij,ij->i", u, v)) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
    return np.degrees(np.arccos(np.clip(c, 0, 1)))


# ---------------------------------------------------------------- sphere: a line bundle
@pytest.mark.parametrize("R", [0.7, 3.0])
def test_sphere_normals_form_a_bundle(R):
    v, f = sphere_patch(R, theta_max_deg=50, nu=15, nv=15, center=(1.0, -2.0, 0.5))
    e = (v - [1.0, -2.0, 0.5]) / R
    c = Congruence(v, f, e)
    fr = face_frame(v, f, e)
    scale = (np.linalg.norm(fr.a_u, axis=1) * np.linalg.norm(fr.e_v, axis=1)
             * np.linalg.norm(fr.e, axis=1) ** 2)
    assert np.max(np.abs(c.normality_residual()) / scale) < 1e-10
    assert np.allclose(c.focal_parameters(), -R, atol=1e-9 * R, rtol=0)
    # every focal point is the centre
    assert np.allclose(c.focal_points(), [1.0, -2.0, 0.5], atol=1e-9 * R)
    assert c.is_bundle().all()
    assert np.isnan(c.torsal_directions()).all(), "a bundle has no preferred torsal directions"
    assert c.summary()["bundle_faces"] == len(f)


def test_icosphere_bundle_and_from_normals_is_nearly_normal():
    s = trimesh.creation.icosphere(subdivisions=3, radius=2.0)
    exact = Congruence(s.vertices, s.faces, s.vertices / 2.0)
    assert exact.is_bundle().all()
    approx = Congruence.from_normals(s)
    # area-weighted normals of an icosphere are close to radial: focal points within a few
    # percent of the centre (the discrete normals are not exactly radial)
    # (near an umbilic, discrete normals may make a face slightly elliptic: NaN there)
    lam = approx.focal_parameters()
    finite = np.isfinite(lam).all(axis=1)
    assert np.array_equal(finite, approx.is_hyperbolic())
    assert np.median(np.abs(lam[finite] + 2.0)) / 2.0 < 0.05


# ---------------------------------------------------------------- cylinder
@pytest.mark.parametrize("R", [0.5, 2.0])
def test_cylinder_focal_points_on_axis_and_at_infinity(R):
    v, f = cylinder_patch(R, angle_deg=100, height=1.5, nu=19, nv=9)
    e = v * [1, 1, 0] / R
    c = Congruence(v, f, e)
    lam = c.focal_parameters()
    assert np.allclose(lam[:, 0], -R, rtol=1e-12)
    assert np.isposinf(lam[:, 1]).all()
    # focal point 0 lies on the axis (x = y = 0)
    p = c.focal_points()
    assert np.allclose(p[:, 0, :2], 0.0, atol=1e-12)
    assert np.isinf(p[:, 1]).all()
    t = c.torsal_directions()
    axis = np.array([0.0, 0.0, 1.0])
    # direction 0 (focal point on the axis) goes around the axis, direction 1 along it
    assert np.abs(t[:, 0] @ axis).max() < 1e-12
    assert np.allclose(np.abs(t[:, 1] @ axis), 1.0, atol=1e-12)
    assert np.allclose(c.torsal_angle(), 90.0)
    assert np.abs(c.normality_residual()).max() < 1e-12
    assert c.is_hyperbolic().all() and not c.is_bundle().any()
    # torsal planes: plane 0 (around) is orthogonal to the axis; plane 1 contains it
    n = c.torsal_planes()
    assert np.allclose(np.abs(n[:, 0] @ axis), 1.0, atol=1e-12)
    assert np.abs(n[:, 1] @ axis).max() < 1e-12


# ---------------------------------------------------------------- graph surfaces
def _principal(fx, fy, fxx, fxy, fyy, x, y):
    """Principal curvatures (w.r.t. the upward normal, S = -dN) and 3D principal directions."""
    gx, gy = fx(x, y), fy(x, y)
    W = np.sqrt(1 + gx**2 + gy**2)
    I = np.array([[1 + gx**2, gx * gy], [gx * gy, 1 + gy**2]]).transpose(2, 0, 1)
    II = np.array([[fxx(x, y), fxy(x, y)], [fxy(x, y), fyy(x, y)]]).transpose(2, 0, 1) / W[:, None, None]
    S = np.linalg.solve(I, II)
    k, vec = np.linalg.eig(S)
    k, vec = k.real, vec.real
    Xx = np.stack([np.ones_like(x), np.zeros_like(x), gx], 1)
    Xy = np.stack([np.zeros_like(x), np.ones_like(x), gy], 1)
    dirs = vec[:, 0, :, None] * Xx[:, None, :] + vec[:, 1, :, None] * Xy[:, None, :]
    return k, dirs


SURFACES = {
    # name: f, fx, fy, fxx, fxy, fyy
    "hyperbolic paraboloid": (
        lambda x, y: 0.6 * x * y + 0.2 * x**2,
        lambda x, y: 0.6 * y + 0.4 * x, lambda x, y: 0.6 * x,
        lambda x, y: 0.4 + 0 * x, lambda x, y: 0.6 + 0 * x, lambda x, y: 0 * x),
    "elliptic paraboloid": (
        lambda x, y: 0.5 * (1.2 * x**2 + 0.4 * y**2),
        lambda x, y: 1.2 * x, lambda x, y: 0.4 * y,
        lambda x, y: 1.2 + 0 * x, lambda x, y: 0 * x, lambda x, y: 0.4 + 0 * x),
}


def _graph_errors(name, n):
    f, fx, fy, fxx, fxy, fyy = SURFACES[name]
    v, faces = graph_surface(f, nu=n, nv=n)
    normals = np.stack([-fx(v[:, 0], v[:, 1]), -fy(v[:, 0], v[:, 1]), np.ones(len(v))], 1)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    c = Congruence(v, faces, normals)
    bc = c.barycenters()
    k, pdirs = _principal(fx, fy, fxx, fxy, fyy, bc[:, 0], bc[:, 1])
    order = np.argsort(1.0 / k, axis=1)  # focal parameters are 1/kappa, sorted ascending
    k = np.take_along_axis(k, order, 1)
    pdirs = np.take_along_axis(pdirs, order[:, :, None], 1)
    lam = c.focal_parameters() * np.linalg.norm(c.barycenter_directions(), axis=1)[:, None]
    curv_err = np.abs(1.0 / lam - k).max() / np.abs(k).max()
    t = c.torsal_directions()
    dir_err = max(_angle_deg(t[:, 0], pdirs[:, 0]).max(), _angle_deg(t[:, 1], pdirs[:, 1]).max())
    return curv_err, dir_err


@pytest.mark.parametrize("name", list(SURFACES))
def test_graph_surface_focal_distances_and_principal_directions_converge(name):
    errs = [_graph_errors(name, n) for n in (9, 17, 33)]
    curv = np.array([e[0] for e in errs])
    ang = np.array([e[1] for e in errs])
    # converged to within a few percent / degrees on the finest grid ...
    assert curv[-1] < 0.02, curv
    assert ang[-1] < 1.0, ang
    # ... and at least first order: halving h at least ~halves the error
    assert np.all(curv[1:] <= 0.6 * curv[:-1]), curv
    assert np.all(ang[1:] <= 0.6 * ang[:-1]), ang


# ---------------------------------------------------------------- random congruences
def _random_congruence(seed, n=9, noise_deg=40.0):
    rng = np.random.default_rng(seed)
    v, f = graph_surface(lambda x, y: 0.3 * np.sin(2 * x) * np.cos(3 * y), nu=n, nv=n)
    v = v + rng.normal(scale=0.01, size=v.shape)
    e = np.array([0.0, 0.0, 1.0]) + np.tan(np.radians(noise_deg)) * rng.uniform(-1, 1, v.shape) * [1, 1, 0]
    e *= rng.uniform(0.5, 2.0, (len(v), 1))  # directions need not be unit
    return Congruence(v, f, e), v, f, e


@pytest.mark.parametrize("seed", range(4))
def test_random_congruence_eqs_1_2_3_agree(seed):
    c, v, f, e = _random_congruence(seed)
    fr = face_frame(v, f, e)
    g = torsal_coefficients(fr)
    cc = focal_coefficients(fr)
    hyp = c.hyperbolicity()
    disc1 = g[:, 1] ** 2 - g[:, 0] * g[:, 2]
    clear = np.abs(hyp) > 1e-9 * np.abs(hyp).max()
    assert 0 < (hyp > 0).sum() < len(f), "the random set should mix hyperbolic and elliptic faces"
    # eq (2) >= 0  <=>  eq (1) has real solutions  <=>  eq (3) has real roots
    assert np.array_equal((hyp > 0)[clear], (disc1 > 0)[clear])
    t = c.torsal_directions()
    lam = c.focal_parameters()
    assert np.array_equal(np.isfinite(t).all(axis=(1, 2)), c.is_hyperbolic())
    assert np.array_equal(~np.isnan(lam).any(axis=1), c.is_hyperbolic())

    ok = np.flatnonzero(c.is_hyperbolic() & (hyp > 1e-6 * np.abs(hyp).max()))
    # each torsal direction solves eq (1)
    basis = np.stack([fr.a_u, fr.a_v], axis=2)[ok]
    for s in (0, 1):
        uv = np.linalg.lstsq(basis[0], t[ok[0], s], rcond=None)[0]  # smoke: first face
        assert np.isfinite(uv).all()
        uv = np.einsum("fij,fj->fi", np.linalg.pinv(basis), t[ok, s])
        q = g[ok, 0] * uv[:, 0] ** 2 + 2 * g[ok, 1] * uv[:, 0] * uv[:, 1] + g[ok, 2] * uv[:, 1] ** 2
        assert np.abs(q).max() < 1e-9 * np.abs(g[ok]).max() * 1e3
        # each focal parameter solves eq (3)
        L = lam[ok, s]
        r = cc[ok, 0] * L**2 + cc[ok, 1] * L + cc[ok, 2]
        assert np.abs(r).max() < 1e-8 * np.abs(cc[ok]).max() * (1 + np.abs(L).max()) ** 2


@pytest.mark.parametrize("seed", range(3))
def test_torsal_plane_contains_the_neighbouring_line_and_its_focal_point(seed):
    """Pairing: moving from the barycentre along torsal direction t, the next line of the
    congruence stays in torsal plane t (to first order) and meets the barycentre's line at
    focal point t."""
    c, v, f, e = _random_congruence(seed)
    hyp = c.hyperbolicity()
    ok = np.flatnonzero(c.is_hyperbolic() & (hyp > 1e-3 * np.abs(hyp).max())
                        & (c.torsal_angle() > 20) & np.isfinite(c.focal_parameters()).all(1)
                        & (np.abs(c.focal_parameters()).max(1) < 20))
    assert ok.size > 10
    t = c.torsal_directions()[ok]
    n = c.torsal_planes()[ok]
    p = c.focal_points()[ok]
    a_c, e_c = c.barycenters()[ok], c.barycenter_directions()[ok]
    fr = face_frame(v, f[ok], e)
    basis = np.stack([fr.a_u, fr.a_v], axis=2)
    errs = {}
    for eps in (1e-3, 1e-4):
        for s in (0, 1):
            uv = np.einsum("fij,fj->fi", np.linalg.pinv(basis), t[:, s]) * eps
            a2 = a_c + uv[:, :1] * fr.a_u + uv[:, 1:] * fr.a_v
            e2 = e_c + uv[:, :1] * fr.e_u + uv[:, 1:] * fr.e_v
            # off-plane component of the neighbouring line, relative to eps
            off = np.abs(np.einsum("ij,ij->i", a2 - a_c, n[:, s])) + np.abs(np.einsum("ij,ij->i", e2, n[:, s]))
            # closest point of the neighbouring line to the line at the barycentre
            w0 = a_c - a2
            A, B, C = (e_c * e_c).sum(1), (e_c * e2).sum(1), (e2 * e2).sum(1)
            D, E = (e_c * w0).sum(1), (e2 * w0).sum(1)
            sc = (B * E - C * D) / (A * C - B * B)
            meet = a_c + sc[:, None] * e_c
            errs[eps, s] = (np.median(off / eps), np.median(np.linalg.norm(meet - p[:, s], axis=1)))
    for s in (0, 1):
        # off-plane motion is second order: shrinks ~10x when eps shrinks 10x
        assert errs[1e-4, s][0] < 0.2 * errs[1e-3, s][0] + 1e-12
        # the neighbouring lines meet the barycentre's line at the paired focal point
        assert errs[1e-4, s][1] < 0.2 * errs[1e-3, s][1] + 1e-9
        assert errs[1e-4, s][1] < 1e-2


def test_normality_residual_matches_eq_6_projection():
    """Eq (7) and eq (6) (projection along e_c) agree up to the factor |e_c|^2."""
    c, v, f, e = _random_congruence(7)
    fr = face_frame(v, f, e)
    ec = fr.e / np.linalg.norm(fr.e, axis=1, keepdims=True)

    def proj(x):
        return x - np.einsum("ij,ij->i", x, ec)[:, None] * ec

    a_ij, a_ik = proj(fr.a_u), proj(fr.a_v)
    e_ij, e_ik = proj(fr.e_u), proj(fr.e_v)
    eq6 = np.einsum("ij,ij->i", a_ij, e_ik) - np.einsum("ij,ij->i", a_ik, e_ij)
    r = c.normality_residual() / np.linalg.norm(fr.e, axis=1) ** 2
    assert np.allclose(r, eq6, atol=1e-12 * np.abs(eq6).max())


def test_directions_are_validated():
    v, f = cylinder_patch(nu=4, nv=3)
    with pytest.raises(ValueError, match="one row per vertex"):
        Congruence(v, f, v[:-1])
    e = v.copy()
    e[3] = np.nan
    with pytest.raises(ValueError, match=r"vertices \[3\].*NaN"):
        Congruence(v, f, e)
    e = v * [1, 1, 0]
    e[5] = 0.0
    with pytest.raises(ValueError, match=r"vertices \[5\] are zero"):
        Congruence(v, f, e)


def test_from_mesh_pair_round_trip_and_mismatch():
    v, f = cylinder_patch(nu=5, nv=4)
    e = v * [1, 1, 0]
    c = Congruence.from_mesh_pair((v, f), (v + e, f))
    assert np.allclose(c.directions, e)
    assert np.allclose(c.vertices_b, v + e)
    with pytest.raises(ValueError, match="combinatorially equivalent"):
        Congruence.from_mesh_pair((v, f), (v[:-1], f[:-1]))


def test_parallel_lines_are_a_bundle_at_infinity():
    v, f = graph_surface(lambda x, y: 0.2 * x * y, nu=5, nv=5)
    c = Congruence(v, f, np.tile([0.1, 0.2, 1.0], (len(v), 1)))
    assert c.is_bundle().all()
    assert np.isposinf(c.focal_parameters()).all()


def test_with_directions_shares_the_mesh_and_checks_the_directions():
    """Same mesh (not copied, not validated again), new directions checked as in the
    constructor; every derived quantity is that of a congruence built from scratch."""
    from torsal.geometry.surfaces import facade_patch

    c = Congruence.from_normals(facade_patch(nu=6, nv=5))
    d = c.directions + np.random.default_rng(1).normal(scale=0.2, size=c.directions.shape)
    w = c.with_directions(d)
    fresh = Congruence(c.vertices, c.faces, d)
    assert w.vertices is c.vertices and w.faces is c.faces and w.delta == c.delta
    np.testing.assert_array_equal(w.torsal_angle(), fresh.torsal_angle())
    np.testing.assert_array_equal(w.hyperbolicity(), fresh.hyperbolicity())
    d[3] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        c.with_directions(d)
    with pytest.raises(ValueError, match="one row per vertex"):
        c.with_directions(d[:-1])


@pytest.mark.parametrize("alpha", [0.0, 0.2, 7.0, 40.0])
def test_direction_spread_of_a_cone_of_lines_is_its_half_angle(alpha):
    """Lines on a cone of half-angle alpha around z (every azimuth, evenly): their mean is the
    axis, so the widest angle from it is alpha; lengths do not matter."""
    from torsal.geometry.congruence import direction_spread

    phi = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    a = np.radians(alpha)
    d = np.stack([np.sin(a) * np.cos(phi), np.sin(a) * np.sin(phi), np.full(12, np.cos(a))], axis=1)
    d *= np.linspace(0.5, 3.0, 12)[:, None]
    assert direction_spread(d) == pytest.approx(alpha, abs=1e-6)
    # opposite lines cancel: no mean direction
    assert np.isnan(direction_spread(np.array([[0, 0, 1.0], [0, 0, -1.0]])))
