"""Unrolling: edge lengths preserved, fold-back reproduces the 3D part, slots as notches."""
from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import LineString, Point

from fab_structures import cylinder_structure, developable_strip, sphere_structure
from torsal.fabrication import FinSystem, SlotSide, fold_back, unroll

EDGES = np.array([[0, 1], [1, 2], [2, 3], [3, 0]])


def _edge_lengths(q):
    return np.linalg.norm(q[..., EDGES[:, 0], :] - q[..., EDGES[:, 1], :], axis=-1)


def _refold(u):
    """Independent rebuild of 3D from the flat panels and the fold angles: start from the
    first panel placed by the recorded frame, rotate everything after fold i about it."""
    from scipy.spatial.transform import Rotation

    o, e1, e2, _ = u.frame
    x = o + u.panels[..., :1] * e1 + u.panels[..., 1:2] * e2
    for i, ang in enumerate(u.fold_angles):
        p, q = x[i, 1].copy(), x[i, 2].copy()
        axis = (q - p) / np.linalg.norm(q - p)
        rot = Rotation.from_rotvec(ang * axis)
        x[i + 1:] = rot.apply((x[i + 1:] - p).reshape(-1, 3)).reshape(x[i + 1:].shape) + p
    return x


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_developable_strip_unrolls_isometrically_and_folds_back(seed):
    quads, folds = developable_strip(k=7, seed=seed, max_fold_deg=50.0)
    quads = quads * 1000.0
    u = unroll(quads)
    assert u.planar
    rel = np.abs(_edge_lengths(u.panels) - _edge_lengths(quads)) / _edge_lengths(quads)
    assert rel.max() < 1e-9
    # diagonals too: every panel is congruent to its 3D quad
    for d in ((0, 2), (1, 3)):
        l3 = np.linalg.norm(quads[:, d[0]] - quads[:, d[1]], axis=1)
        l2 = np.linalg.norm(u.panels[:, d[0]] - u.panels[:, d[1]], axis=1)
        assert np.abs(l2 - l3).max() / l3.min() < 1e-9
    # recorded fold angles are the ones the strip was built with
    np.testing.assert_allclose(u.fold_angles, folds, atol=1e-12)
    size = np.linalg.norm(np.ptp(quads.reshape(-1, 3), axis=0))
    for rebuilt in (_refold(u), fold_back(u)):
        assert np.abs(rebuilt - quads).max() < 1e-6 * size
    # flat panels do not overlap: union area == sum of areas
    assert u.outline.area == pytest.approx(sum(abs(_shoelace(p)) for p in u.panels), rel=1e-9)


def _shoelace(p):
    x, y = p[:, 0], p[:, 1]
    return 0.5 * (x @ np.roll(y, -1) - y @ np.roll(x, -1))


def test_unrolled_panels_are_not_mirrored():
    quads, _ = developable_strip(k=4, seed=5)
    u = unroll(quads * 1000)
    # the top side (+normal) is up: flat panels keep the orientation of a_i a_j b_j b_i
    assert all(_shoelace(p) > 0 for p in u.panels)


@pytest.mark.parametrize("make", [sphere_structure, cylinder_structure])
def test_fin_system_parts_unroll_and_fold_back(make):
    fs = FinSystem(make(), thickness=3.0, clearance=0.5)
    for p in fs.parts:
        u = unroll(p)
        assert u.name == p.name
        rel = np.abs(_edge_lengths(u.panels) - _edge_lengths(p.panels)) / _edge_lengths(p.panels)
        assert rel.max() < 1e-9, p.name
        assert u.max_edge_error < 1e-9
        assert np.abs(_refold(u) - p.panels).max() < 1e-6 * p.size, p.name
        np.testing.assert_allclose(u.fold_angles, p.fold_angles, atol=1e-12)


def test_cylinder_rows_have_real_folds():
    fs = FinSystem(cylinder_structure(), thickness=3.0)
    row = fs.parts[0]
    assert row.family == 0
    # rows of the tilted cylinder are cone strips: equal, non-trivial folds
    ang = np.degrees(row.fold_angles)
    assert np.all(np.abs(ang) > 3.0)
    np.testing.assert_allclose(ang, ang[0], atol=1e-9)
    assert unroll(row).fold_count == len(row.panels) - 1


def test_slots_are_notches_of_measured_depth_and_width():
    t, c = 3.0, 0.5
    fs = FinSystem(sphere_structure(), thickness=t, clearance=c)
    n_checked = 0
    for p in fs.parts:
        u = unroll(p)
        for s in p.slots:
            pos = s.position
            a2, b2 = (u.panels[0, 0], u.panels[0, 3]) if pos == 0 else (u.panels[pos - 1, 1], u.panels[pos - 1, 2])
            fin = np.linalg.norm(b2 - a2)
            line = LineString([a2, b2])
            inside = line.intersection(u.outline)
            # the node line is in the part only beyond the slot bottom
            assert inside.length == pytest.approx(fin - s.depth, rel=1e-9)
            start, other = (b2, a2) if s.side == SlotSide.B else (a2, b2)
            ax = (other - start) / fin
            perp = np.array([-ax[1], ax[0]])
            mid = start + 0.5 * s.depth * ax
            cross = LineString([mid - 10 * t * perp, mid + 10 * t * perp])
            cut = cross.difference(u.outline)
            # the removed piece around the node line has width thickness + clearance
            piece = min(getattr(cut, "geoms", [cut]), key=lambda g: g.distance(Point(mid)))
            assert piece.distance(Point(mid)) < 1e-9
            assert piece.length == pytest.approx(t + c, rel=1e-9)
            n_checked += 1
    assert n_checked == 2 * len(fs.crossings) > 0


def test_nonplanar_strip_reports_worst_edge_error():
    quads, _ = developable_strip(k=4, seed=1)
    quads = quads * 1000
    bent = quads.copy()
    bent[1, 2] += np.array([0.0, 0.8, 0.0])          # lift one corner of panel 1 ...
    bent[2, 3] = bent[1, 2]                          # ... shared with panel 2
    u = unroll(bent)
    assert not u.planar
    rel = np.abs(_edge_lengths(u.panels) - _edge_lengths(bent)) / _edge_lengths(bent)
    assert u.max_edge_error == pytest.approx(rel.max(), rel=1e-12)
    assert 1e-7 < u.max_edge_error < 1e-2
    # the same strip, planar, is exact
    assert unroll(quads).max_edge_error < 1e-12


def test_unroll_rejects_bad_input():
    with pytest.raises(ValueError):
        unroll(np.zeros((3, 3, 3)))


def _twisted_square(h):
    """A skew square: corners (+-1, +-1) lifted alternately by +-h."""
    return np.array([[1.0, 1.0, h], [-1.0, 1.0, -h], [-1.0, -1.0, h], [1.0, -1.0, -h]])


@pytest.mark.parametrize("h", [1e-4, 1e-2, 0.1])
def test_twisted_square_unrolls_to_the_least_squares_square(h):
    """Edges L = 2 sqrt(1 + h^2), diagonals D = 2 sqrt(2): by symmetry the best flat quad is a
    square of side s minimizing 4 ((s - L) / L)^2 + 2 ((s sqrt2 - D) / D)^2, i.e.
    s = (8 / L + 4 sqrt2 / D) / (8 / L^2 + 8 / D^2)."""
    from torsal.fabrication.unroll import _flat_quads, _plane_frame

    quad = _twisted_square(h)
    L, D = 2.0 * np.sqrt(1.0 + h * h), 2.0 * np.sqrt(2.0)
    s = (8.0 / L + 4.0 * np.sqrt(2.0) / D) / (8.0 / L**2 + 8.0 / D**2)
    flat, planar = _flat_quads(quad[None], 1e-9)
    assert not planar[0]
    np.testing.assert_allclose(_edge_lengths(flat[0]), s, rtol=1e-12)
    diag = np.linalg.norm(flat[0, [0, 1]] - flat[0, [2, 3]], axis=1)
    np.testing.assert_allclose(diag, s * np.sqrt(2.0), rtol=1e-12)
    # placed where it best fits the panel's projection on its plane (a square of side 2
    # about the origin, in the panel's frame)
    o, e1, e2, n = _plane_frame(quad)
    np.testing.assert_allclose(np.abs(n), [0, 0, 1], atol=1e-15)
    proj = (quad - o) @ np.array([e1, e2]).T
    np.testing.assert_allclose(np.abs(proj), 1.0, rtol=1e-15)
    np.testing.assert_allclose(flat[0], proj * s / 2.0, atol=1e-12)


def test_nonplanar_panels_match_an_independent_least_squares_fit():
    """Random bent quads: the vectorized fit reaches the optimum scipy's least_squares finds
    (same cost; same edge and diagonal lengths, so congruent flat quads)."""
    from scipy.optimize import least_squares

    from torsal.fabrication.unroll import _PAIRS, _flat_quads

    rng = np.random.default_rng(7)
    quads = np.array([[0, 0, 0], [300, 0, 0], [310, 150, 0], [-5, 140, 0]], float)
    quads = quads + rng.normal(scale=20.0, size=(40, 4, 3)) * [1.0, 1.0, 0.0]
    quads[:, :, 2] += rng.normal(scale=3.0, size=(40, 4))           # ~1 % of the size
    flat, planar = _flat_quads(quads, 1e-9)
    assert not planar.any()

    def lengths(p):
        return np.linalg.norm(p[..., _PAIRS[:, 0], :] - p[..., _PAIRS[:, 1], :], axis=-1)

    target = lengths(quads)
    for q, f, t in zip(quads, flat, target):
        sol = least_squares(lambda z: (lengths(z.reshape(4, 2)) - t) / t, f.ravel() + 0.5,
                            xtol=1e-15, ftol=1e-15, gtol=1e-15)
        ours = 0.5 * np.sum(((lengths(f) - t) / t) ** 2)
        assert ours <= sol.cost * (1 + 1e-9) + 1e-28
        np.testing.assert_allclose(lengths(f), lengths(sol.x.reshape(4, 2)), rtol=1e-9)


def test_flat_quads_remembered_are_the_bits_of_any_batch():
    """Each bent quad's flat version is its own (the Gauss-Newton treats the quads apart): the
    same bits developed alone, in a batch, in another batch's order or looked up again."""
    import importlib

    mod = importlib.import_module("torsal.fabrication.unroll")   # the module, not the function
    rng = np.random.default_rng(11)
    quads = np.array([[0, 0, 0], [300, 0, 0], [310, 150, 0], [-5, 140, 0]], float)
    quads = quads + rng.normal(scale=20.0, size=(25, 4, 3)) * [1.0, 1.0, 0.0]
    quads[:, :, 2] += rng.normal(scale=3.0, size=(25, 4))
    quads[3] = [[0, 0, 0], [200, 0, 0], [200, 100, 0], [0, 100, 0]]     # a planar one
    mod._FLAT_MEMO.clear()
    batch, planar = mod._develop_quads(quads, 1e-9)
    assert planar.sum() == 1 and planar[3]
    alone = [mod._develop_quads(q[None], 1e-9) for q in quads]
    assert all(np.array_equal(f[0], b) and p[0] == q for (f, p), b, q in zip(alone, batch, planar))
    order = rng.permutation(len(quads))
    for _ in range(2):              # developed (in another order), then looked up
        flat, pl = mod._flat_quads(quads[order], 1e-9)
        assert np.array_equal(flat, batch[order]) and np.array_equal(pl, planar[order])
    assert len(mod._FLAT_MEMO) == len(quads)
    part, pl = mod._flat_quads(quads[5:9], 1e-9)                   # all looked up
    assert np.array_equal(part, batch[5:9]) and np.array_equal(pl, planar[5:9])


def test_flat_outline_is_the_unrolled_outline():
    """``flat_outline`` is ``unroll(...).outline`` (the same vertices), with and without the
    slots, and raises where unroll does (slots cutting the part apart)."""
    from torsal.fabrication.unroll import flat_outline

    fs = FinSystem(sphere_structure(), thickness=3.0, clearance=0.5)
    slotted = [p for p in fs.parts if p.slots]
    assert slotted
    for p in fs.parts:
        for slots in ([], list(p.slots)):
            a, b = flat_outline(p.panels, slots=slots), unroll(p.panels, slots=slots).outline
            assert a.wkb == b.wkb
    import dataclasses

    p, s = next((p, s) for p in slotted for s in p.slots if 0 < s.position < len(p.panels))
    through = dataclasses.replace(s, depth=1e6)          # across the whole node line
    for fn in (lambda: unroll(p.panels, slots=[through]),
               lambda: flat_outline(p.panels, slots=[through])):
        with pytest.raises(ValueError, match="slots cut the part into 2 pieces"):
            fn()
