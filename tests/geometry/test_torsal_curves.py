"""Torsal curves (Wang et al. 2013, 2.2, Fig. 4): straight in faces, developable strips."""
import numpy as np
import pytest

from torsal.geometry.congruence import Congruence
from torsal.geometry.support import fin_planarity
from torsal.geometry.surfaces import cylinder_patch, graph_surface, surface_of_revolution
from torsal.geometry.torsal_curves import trace_torsal_curve


def _revolution(n=41):
    r = lambda z: 1.0 + 0.35 * z**2  # noqa: E731  (a waisted tower: meridians and parallels differ)
    dr = lambda z: 0.7 * z  # noqa: E731
    v, f = surface_of_revolution(r, z_range=(-0.8, 0.8), angle_deg=90, nu=n, nv=n)
    phi = np.arctan2(v[:, 1], v[:, 0])
    normals = np.c_[np.cos(phi), np.sin(phi), -dr(v[:, 2])]
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    return Congruence(v, f, normals), v, f


def test_cylinder_curves_are_circles_and_rulings():
    v, f = cylinder_patch(1.3, angle_deg=120, height=2.0, nu=15, nv=11)
    c = Congruence(v, f, v * [1, 1, 0] / 1.3)
    around = trace_torsal_curve(c, 60, family=0)
    along = trace_torsal_curve(c, 60, family=1)
    assert around.stop_reasons == ("boundary", "boundary")
    assert np.ptp(around.points_a[:, 2]) < 1e-12
    # ends on the two straight boundary rulings: sweeps the full 120 degrees
    phi = np.degrees(np.arctan2(around.points_a[:, 1], around.points_a[:, 0]))
    assert np.isclose(np.ptp(phi), 120.0)
    assert np.ptp(np.arctan2(along.points_a[:, 1], along.points_a[:, 0])) < 1e-12
    assert np.isclose(np.ptp(along.points_a[:, 2]), 2.0)
    # B polyline = A polyline pushed along the radial lines (interpolated e is radial)
    d = around.points_b - around.points_a
    radial = around.points_a * [1, 1, 0]
    assert np.abs(np.cross(d, radial)).max() < 1e-12
    assert np.all(np.einsum("ij,ij->i", d, radial) > 0)


@pytest.mark.parametrize("family_is_parallel", [True, False])
def test_surface_of_revolution_curves_follow_parallels_and_meridians(family_is_parallel):
    c, v, f = _revolution()
    start = int(np.argmin(np.linalg.norm(c.barycenters() - [1.03, 0.02, 0.3], axis=1)))
    t = c.torsal_directions()[start]
    # which family runs along the parallel (horizontal) here?
    fam_parallel = int(np.argmin(np.abs(t[:, 2])))
    fam = fam_parallel if family_is_parallel else 1 - fam_parallel
    curve = trace_torsal_curve(c, start, family=fam)
    p = curve.points_a
    assert curve.stop_reasons == ("boundary", "boundary")
    if family_is_parallel:
        # stays at (nearly) constant height over the whole 90 degree sweep
        assert np.ptp(p[:, 2]) < 0.01 * curve.length
        phi = np.degrees(np.arctan2(p[:, 1], p[:, 0]))
        assert np.ptp(phi) > 85
    else:
        phi = np.arctan2(p[:, 1], p[:, 0])
        assert np.ptp(phi) * 1.0 < 0.01 * curve.length
        assert np.ptp(p[:, 2]) > 1.5


def test_strip_is_a_discrete_developable_of_planar_quads():
    """Within a face the congruence's developables are planar (property 2), so every quad of
    the traced strip is planar, for a general (non-normal) congruence too."""
    rng = np.random.default_rng(3)
    c0, v, f = _revolution(15)
    e = c0.directions + 0.03 * rng.normal(size=c0.directions.shape)
    c = Congruence(v, f, e)
    assert np.abs(c.normality_residual()).max() > 1e-3 * c.delta, "not a normal congruence"
    start = int(np.argmin(np.linalg.norm(c.barycenters() - [1.1, 0.0, 0.0], axis=1)))
    curve = trace_torsal_curve(c, start, family=0)
    assert len(curve.faces) >= 8
    assert fin_planarity(curve.strip).max() < 1e-9
    # points of the strip lie on lines of the congruence: b - a is the interpolated e
    for fc, bb, pa, pb in zip(np.r_[curve.faces[:1], curve.faces], curve.barycentric,
                              curve.points_a, curve.points_b):
        assert np.allclose(pb - pa, bb @ e[f[fc]], atol=1e-12)


def test_trace_validates_input():
    c, v, f = _revolution(9)
    with pytest.raises(ValueError, match="family must be 0 or 1"):
        trace_torsal_curve(c, 0, family=2)
    with pytest.raises(ValueError, match="does not exist"):
        trace_torsal_curve(c, len(f) + 5)
    with pytest.raises(ValueError, match="not inside face"):
        trace_torsal_curve(c, 0, point=v[f[40, 0]] + [5, 5, 5])


def test_trace_stops_where_the_congruence_becomes_elliptic():
    """Flat A, e = z + 0.5 (x, -y, 0) (hyperbolic, torsal directions along x and y) plus a
    rotation s(x) (-y, x, 0) that makes it elliptic for x > ~0.3: a curve along x stops there."""
    v, f = graph_surface(lambda x, y: 0 * x, nu=21, nv=21)
    x, y = v[:, 0], v[:, 1]
    s = 3.0 * np.maximum(x - 0.1, 0.0)
    e = np.c_[0.5 * x - s * y, -0.5 * y + s * x, np.ones(len(v))]
    c = Congruence(v, f, e)
    assert c.is_hyperbolic()[c.barycenters()[:, 0] < 0].all()
    assert not c.is_hyperbolic()[c.barycenters()[:, 0] > 0.4].any()
    start = int(np.argmin(np.linalg.norm(c.barycenters() - [-0.3, 0.0, 0.0], axis=1)))
    t = c.torsal_directions()[start]
    fam = int(np.argmax(np.abs(t[:, 0])))  # the family along x
    curve = trace_torsal_curve(c, start, family=fam)
    assert curve.stop_reasons[0] == "boundary" or curve.stop_reasons[1] == "boundary"
    assert "not hyperbolic" in curve.stop_reasons
    assert curve.points_a[:, 0].min() < -0.45 and 0.1 < curve.points_a[:, 0].max() < 0.45
