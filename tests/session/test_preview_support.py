"""The preview's support structure (:func:`torsal.session.preview.preview_support`) on a 4 x 4
grid of fins with one node's fin edge pushed sideways: nearly planar fins are the design
run's eq. (8) bit for bit; fins soft planarity does not make planar are projected; fins far
beyond its reach are projected from the extracted fins without the soft rounds."""
import numpy as np

from torsal.geometry.support import SupportStructure, optimize_support
from torsal.session.preview import PREVIEW_SOFT_REACH, preview_support

TOL = 1e-4


def _grid(push: float, n: int = 4) -> SupportStructure:
    """Fins 1 deep on the edges of an n x n unit grid; node 5's b pushed ``push`` along x."""
    a = np.array([[x, y, 0.0] for y in range(n) for x in range(n)])
    b = a + [0.0, 0.0, 1.0]
    b[5] += [push, 0.0, 0.0]
    edges, family = [], []
    for y in range(n):
        for x in range(n):
            k = y * n + x
            if x + 1 < n:
                edges.append([k, k + 1])
                family.append(0)
            if y + 1 < n:
                edges.append([k, k + n])
                family.append(1)
    faces = [[y * n + x, y * n + x + 1, (y + 1) * n + x + 1, (y + 1) * n + x]
             for y in range(n - 1) for x in range(n - 1)]
    return SupportStructure(a, b, faces, np.array(edges), np.array(family))


def test_nearly_planar_fins_are_the_design_runs_support():
    s = _grid(1e-3)
    assert TOL < s.delta_pl < PREVIEW_SOFT_REACH * TOL
    r, final = preview_support(s, reference=None, planarity_tol=TOL)
    design = optimize_support(s, None, planarity_tol=TOL)
    assert final and design.success and r.structure.delta_pl <= TOL
    np.testing.assert_array_equal(r.structure.vertices_a, design.structure.vertices_a)
    np.testing.assert_array_equal(r.structure.vertices_b, design.structure.vertices_b)


def test_fins_soft_planarity_leaves_unplanar_are_projected_after_it():
    s = _grid(1e-2)        # delta_pl 3.5e-3: eq. (8)'s soft optimum keeps 4.2e-4
    assert s.delta_pl <= PREVIEW_SOFT_REACH * TOL
    soft = optimize_support(s, None, planarity_tol=None)
    assert soft.delta_pl_after > TOL
    r, final = preview_support(s, reference=None, planarity_tol=TOL)
    assert not final and r.structure.delta_pl <= TOL
    assert r.status.startswith("preview: soft planarity left delta_pl")
    assert r.delta_pl_before == s.delta_pl


def test_fins_beyond_soft_planaritys_reach_are_projected_from_the_extracted_ones():
    s = _grid(0.3)         # delta_pl 0.10: eq. (8)'s soft optimum keeps 0.0126
    assert s.delta_pl > PREVIEW_SOFT_REACH * TOL
    r, final = preview_support(s, reference=None, planarity_tol=TOL)
    projected = optimize_support(s, None, hard_tol=TOL, method="projection")
    assert not final and r.structure.delta_pl <= TOL
    assert r.status.startswith("preview: the extracted fins' delta_pl 0.103 is over 100 times")
    np.testing.assert_array_equal(r.structure.vertices_b, projected.structure.vertices_b)
    assert r.iterations == projected.iterations       # no IPOPT iteration before it
