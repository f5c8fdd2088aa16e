"""Tests of the torsal frame field (Wang et al. 2013, 4.2): analytic truth on graph surfaces."""
import numpy as np
import pytest

from torsal.geometry.congruence import Congruence
from torsal.geometry.frame_field import GROUP, FrameFieldError, torsal_confidence, torsal_frame_field
from torsal.geometry.surfaces import graph_surface

from graph_cases import noisy_saddle, principal_directions, saddle, star  # tests/geometry/graph_cases.py


def test_field_is_the_torsal_directions_combed():
    c = Congruence.from_normals(graph_surface(saddle, nu=21, nv=21))
    ff = torsal_frame_field(c)
    t = c.torsal_directions()
    assert ff.from_torsal.all()
    # each combed direction is one of the torsal lines (up to sign and order)
    for k in range(2):
        al = np.abs(np.einsum("fj,ftj->ft", ff.directions[:, k], t)).max(1)
        assert np.all(al > 1 - 1e-9)
    assert ff.is_seamless and len(ff.singularities) == 0
    assert np.all(ff.matching[ff.edge_faces[:, 1] >= 0] == 0)


def test_dual_frame_is_biorthogonal():
    c = Congruence.from_normals(graph_surface(saddle, nu=11, nv=11))
    ff = torsal_frame_field(c)
    w = ff.dual_frame()
    g = np.einsum("fid,fjd->fij", w, ff.directions)
    assert np.allclose(g, np.eye(2)[None], atol=1e-12)


def test_umbilic_gives_one_half_singularity_at_origin():
    c = Congruence.from_normals(graph_surface(star, nu=31, nv=31))
    ff = torsal_frame_field(c)
    assert len(ff.singularities) == 1
    assert np.allclose(c.vertices[ff.singularities[0]], 0.0)
    # holonomy -I: both line fields turn by pi (index +-1/2)
    assert np.array_equal(GROUP[ff.holonomy[0]], -np.eye(2, dtype=int))


def test_bundle_faces_are_filled_smoothly():
    """Faces declared untrusted (bundle deviation below a threshold) get their directions from
    the smoothness energy; on a smooth saddle these match the true torsal directions."""
    c = Congruence.from_normals(graph_surface(saddle, nu=21, nv=21))
    dev = c.bundle_deviation()
    thr = np.quantile(dev, 0.1)
    ff = torsal_frame_field(c, bundle_tol=thr)
    filled = ~ff.from_torsal
    assert filled.sum() >= 0.09 * len(dev)
    t = c.torsal_directions()[filled]
    al = np.abs(np.einsum("fkj,ftj->fkt", ff.directions[filled], t)).max(2)
    assert np.degrees(np.arccos(np.clip(al, 0, 1))).max() < 5.0
    # filling does not disturb the torsal faces, and the result still combs seamlessly
    tt = c.torsal_directions()[~filled]
    al2 = np.abs(np.einsum("fkj,ftj->fkt", ff.directions[~filled], tt)).max(2)
    assert np.all(al2 > 1 - 1e-9)
    assert ff.is_seamless


def test_sphere_bundle_raises_with_reason():
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=2)
    c = Congruence(s.vertices, s.faces, s.vertices)
    with pytest.raises(FrameFieldError, match="bundle"):
        torsal_frame_field(c)


def test_singularity_agrees_with_libigl_cross_field():
    """Independent check with libigl's cross-field tools (the normal congruence's torsal
    directions are orthogonal, so the frame is a cross field): libigl's singularities sit at or
    next to ours and their quarter-turn indices add up to a half turn (holonomy -I)."""
    igl = pytest.importorskip("igl")
    V, F = graph_surface(star, nu=31, nv=31)
    c = Congruence.from_normals((V, F))
    ff = torsal_frame_field(c)
    t = ff.directions
    mm = igl.cross_field_mismatch(np.ascontiguousarray(V), np.ascontiguousarray(F),
                                  np.ascontiguousarray(t[:, 0]), np.ascontiguousarray(t[:, 1]), False)
    is_s, idx = igl.find_cross_field_singularities(np.ascontiguousarray(V), np.ascontiguousarray(F), mm)
    theirs = np.flatnonzero(is_s)
    assert theirs.size >= 1
    d = np.linalg.norm(V[theirs] - V[ff.singularities[0]], axis=1)
    assert d.max() <= 1.5 * np.linalg.norm(V[1] - V[0]) * np.sqrt(2)
    assert idx[theirs].sum() % 4 == 2


@pytest.mark.parametrize("k1, k2", [(1.0, -1.0), (1.0, 0.0), (0.5, 0.3)])
def test_confidence_is_the_curvature_anisotropy(k1, k2):
    """For a normal congruence the confidence is |kappa_1 - kappa_2| (1/length): what
    defines the principal directions, zero at an umbilic."""
    V, F = graph_surface(lambda x, y: 0.5 * (k1 * x**2 + k2 * y**2), nu=41, nv=41)
    c = Congruence.from_normals((V, F))
    s = torsal_confidence(c)
    near = np.linalg.norm(V[F].mean(1)[:, :2], axis=1) < 0.05
    assert np.allclose(s[near], abs(k1 - k2), rtol=0.02)
    # independent of the length of the lines and of the corner order
    c2 = Congruence(V, F[:, [1, 2, 0]], 3.0 * c.directions)
    assert np.allclose(torsal_confidence(c2), s, rtol=1e-9)


def principal_angle_error(ff, f=saddle):
    """Per face, degrees between each combed direction and the nearest analytic principal
    direction of the graph z = f(x, y)."""
    bc = ff.vertices[ff.faces].mean(1)
    pd = principal_directions(f, bc[:, 0], bc[:, 1])
    al = np.abs(np.einsum("fij,fkj->fik", pd, ff.directions)).max(1)
    return np.degrees(np.arccos(np.clip(al, 0, 1)))


def test_smoothing_removes_spurious_singularities_of_a_noisy_field():
    """1 % noise on the lines scatters the per-face torsal directions by ~15 degrees and gives
    the raw field hundreds of singularities; smoothed below 0.05 (a third of the patch is 0.7)
    the field is singularity-free and within a few degrees of the analytic directions."""
    c = noisy_saddle()
    raw = torsal_frame_field(c)
    assert len(raw.singularities) > 50
    assert np.median(principal_angle_error(raw)) > 8.0
    ff = torsal_frame_field(c, smoothing=0.05)
    assert len(ff.singularities) == 0 and ff.is_seamless
    err = principal_angle_error(ff)
    assert np.median(err) < 2.5 and np.percentile(err, 90) < 6.0
    assert ff.metadata["smoothing"] == 0.05
    assert 0.0 <= ff.metadata["confidence_weight"].min() and ff.metadata["confidence_weight"].max() == 1.0


def test_smoothing_keeps_a_clean_field():
    """On a noise-free saddle the smoothing barely moves the torsal directions."""
    c = Congruence.from_normals(graph_surface(saddle, nu=31, nv=31))
    ff = torsal_frame_field(c, smoothing=0.05)
    assert ff.from_torsal.all() and len(ff.singularities) == 0
    assert np.percentile(principal_angle_error(ff), 99) < 1.0
    with pytest.raises(ValueError, match="smoothing"):
        torsal_frame_field(c, smoothing=-1.0)
