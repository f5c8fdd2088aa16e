"""Tests of eq. (8) support optimization and developable refinement (Wang et al. 2013, 4.2, Fig. 10)."""
import numpy as np
import pytest
import trimesh

from torsal.geometry.congruence import Congruence
from torsal.geometry.developable import refine_developable
from torsal.geometry.remesh import remesh_torsal
from torsal.geometry.support import SupportStructure, fin_planarity, optimize_support
from torsal.geometry.surfaces import canopy, graph_surface


def saddle(x, y):
    return 0.3 * (x**2 - 0.5 * y**2) + 0.1 * x**3


def distance_to_A(V, F, points):
    import igl

    d2, _, _ = igl.point_mesh_squared_distance(np.asarray(points, float), np.asarray(V, float),
                                               np.asarray(F, np.int64))
    return np.sqrt(d2)


@pytest.fixture(scope="module")
def saddle_structure():
    V, F = graph_surface(saddle, nu=21, nv=21)
    c = Congruence.from_normals((V, F))
    return V, F, c, remesh_torsal(c, 1.0 / 12)


@pytest.fixture(scope="module")
def umbilic_structure():
    def star(x, y):
        return 0.5 * (x**2 + y**2) + 0.3 * (x**3 - 3 * x * y**2)

    V, F = graph_surface(star, nu=21, nv=21)
    c = Congruence.from_normals((V, F))
    s = remesh_torsal(c, 1.0 / 12)
    assert len(s.metadata["singularities"]) == 1
    return V, F, c, s


@pytest.fixture(scope="module")
def window_structure():
    V, F = canopy(nu=25, nv=25)
    bc = V[F].mean(1)
    keep = np.linalg.norm(bc[:, :2] - [1.0, 0.5], axis=1) > 1.8
    m = trimesh.Trimesh(V, F[keep], process=False)
    m.remove_unreferenced_vertices()
    c = Congruence.from_normals((m.vertices, m.faces))
    return np.asarray(m.vertices), np.asarray(m.faces), c, remesh_torsal(c, 0.6)


def test_fin_planarity_analytic():
    # a twisted quad: diagonals (0,0,0)-(1,1,h) and (1,0,0)-(0,1,0) are at distance h/2 (x=y plane)
    h = 0.1
    q = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, h], [0, 1, 0]]], float)
    d1, d2 = np.sqrt(2 + h * h), np.sqrt(2)
    expected = (h / 2) * np.sqrt(2) / np.sqrt(2 + h * h) / (0.5 * (d1 + d2))
    # distance of the skew lines: |(p1-p0).(d1 x d2)| / |d1 x d2|
    a, b = q[0, 2] - q[0, 0], q[0, 3] - q[0, 1]
    n = np.cross(a, b)
    exact = abs(np.dot(q[0, 1] - q[0, 0], n)) / np.linalg.norm(n) / (0.5 * (d1 + d2))
    assert np.isclose(fin_planarity(q)[0], exact)
    assert exact > 0.01 and np.isclose(exact, expected)


@pytest.mark.parametrize("case, method", [
    ("saddle_structure", "ipopt"), ("window_structure", "ipopt"),
    ("saddle_structure", "projection"), ("window_structure", "projection"),
    ("umbilic_structure", "ipopt"), ("umbilic_structure", "projection"),
])
def test_optimize_reaches_planarity_and_stays_on_A(case, method, request):
    V, F, c, s = request.getfixturevalue(case)
    assert s.delta_pl > 1e-4  # there is something to do
    r = optimize_support(s, (V, F), hard_tol=1e-4, method=method, rounds=2)
    assert r.success, r.status
    assert r.structure.delta_pl <= 1e-4
    assert r.delta_pl_after == r.structure.delta_pl
    assert distance_to_A(V, F, r.structure.vertices_a).max() <= 0.01 * c.delta
    assert r.distance_to_reference <= 0.01
    # combinatorics untouched; the input is not modified
    assert np.array_equal(r.structure.edges, s.edges) and r.structure.faces == s.faces
    assert s.delta_pl == r.delta_pl_before


def test_soft_planarity_reduces_delta_pl(saddle_structure):
    V, F, c, s = saddle_structure
    r = optimize_support(s, (V, F), weights={"plnr": 200.0}, rounds=1)
    assert r.structure.delta_pl < 0.2 * s.delta_pl
    assert r.solve_seconds > 0 and r.iterations > 0


def test_single_quad_exact():
    a = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    b = a + [[0, 0, 1], [0, 0, 1], [0.2, 0, 1], [0, 0, 1]]
    s = SupportStructure(a, b, [[0, 1, 2, 3]], np.array([[0, 1], [1, 2], [2, 3], [0, 3]]), np.array([0, 1, 0, 1]))
    assert s.delta_pl > 0.01
    for method in ("ipopt", "projection"):
        r = optimize_support(s, hard_tol=1e-6, method=method)
        assert r.success and r.structure.delta_pl <= 1e-6


def test_refine_developable_gives_planar_smooth_strips(saddle_structure):
    V, F, c, s = saddle_structure
    r = refine_developable(s, levels=2, reference=(V, F))
    strips0 = s.fins()
    strips1 = r.fins()
    assert len(strips1) == len(strips0)
    # every strip now has 4x the fins, all planar
    n0 = sorted(len(x.edges) for x in strips0)
    n1 = sorted(len(x.edges) for x in strips1)
    assert n1 == [4 * k for k in n0]
    assert r.delta_pl <= 1e-4
    # smoother: the turning angle between consecutive fin edges drops
    def turning(strips):
        out = []
        for st in strips:
            p = st.quads[:, 0]
            p = np.r_[p, st.quads[-1:, 1]]
            d = np.diff(p, axis=0)
            d /= np.linalg.norm(d, axis=1, keepdims=True)
            if len(d) > 1:
                out.append(np.arccos(np.clip((d[1:] * d[:-1]).sum(1), -1, 1)).max())
        return np.max(out)
    assert turning(strips1) < turning(strips0)
    assert distance_to_A(V, F, r.vertices_a).max() <= 0.01 * c.delta


def test_default_reaches_the_planarity_a_sheet_part_needs(saddle_structure):
    # a weak planarity weight (as a user may set to favour proximity) leaves the fins warped;
    # the default goes on with planarity as a hard constraint until delta_pl <= 1e-4
    from torsal.geometry.support import PLANARITY_TOL

    V, F, c, s = saddle_structure
    short = dict(rounds=1, weights={"plnr": 1e-4})
    soft = optimize_support(s, (V, F), planarity_tol=None, **short)
    assert soft.structure.delta_pl > PLANARITY_TOL          # the paper's soft eq. (8) alone
    r = optimize_support(s, (V, F), **short)
    assert r.success, r.status
    assert r.structure.delta_pl <= PLANARITY_TOL == 1e-4
    assert np.abs(r.structure.planarity()).max() == r.delta_pl_after
    assert "hard constraint" in r.status and r.delta_pl_before == s.delta_pl
    assert distance_to_A(V, F, r.structure.vertices_a).max() <= 0.01 * c.delta


def test_default_says_why_when_planarity_is_not_reached(saddle_structure):
    V, F, c, s = saddle_structure
    r = optimize_support(s, (V, F), rounds=1, max_iter=2, planarity_tol=1e-12)
    assert not r.success
    assert r.structure.delta_pl > 1e-12
    assert "not planar enough" in r.status and "1e-12" in r.status


def test_each_family_its_own_depth(tmp_path):
    """family_depth_ratio: family 1's fins reach half-way along the node lines. Their quads,
    strips and fin mesh end there (fin areas: length x depth on a flat grid of vertical node
    lines), the fins stay exactly planar (two coplanar node lines at any depth), and the ratio
    survives eq. (8), the developable refinement and a save / load."""
    x, y = np.meshgrid(np.arange(3) * 0.3, np.arange(3) * 0.2)
    a = np.stack([x, y, 0 * x], axis=-1).reshape(-1, 3)
    idx = np.arange(9).reshape(3, 3)
    e0 = np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()]
    e1 = np.c_[idx[:-1, :].ravel(), idx[1:, :].ravel()]
    faces = [[idx[r, c], idx[r, c + 1], idx[r + 1, c + 1], idx[r + 1, c]]
             for r in range(2) for c in range(2)]
    s = SupportStructure(a, a + [0, 0, 0.4], faces, np.r_[e0, e1], np.r_[[0] * 6, [1] * 6],
                         family_depth_ratio=(1.0, 0.5))
    q = s.fin_quads()
    depth = np.linalg.norm(q[:, 3] - q[:, 0], axis=1)
    assert np.allclose(depth, np.where(s.edge_family == 0, 0.4, 0.2))
    assert s.delta_pl == 0.0
    for st in s.fins():
        assert np.allclose(st.quads[:, 2, 2], 0.4 if st.family == 0 else 0.2)
    # area: 6 family-0 fins 0.3 x 0.4, 6 family-1 fins 0.2 x 0.2
    assert np.isclose(s.fin_mesh().area, 6 * 0.3 * 0.4 + 6 * 0.2 * 0.2)
    assert optimize_support(s, planarity_tol=None).structure.family_depth_ratio == (1.0, 0.5)
    assert refine_developable(s, 1).family_depth_ratio == (1.0, 0.5)
    s.save(tmp_path / "s.npz")
    assert SupportStructure.load(tmp_path / "s.npz").family_depth_ratio == (1.0, 0.5)
    for bad in ((0.0, 1.0), (1.0, 1.5)):
        with pytest.raises(ValueError, match="family_depth_ratio"):
            SupportStructure(a, a + [0, 0, 0.4], faces, np.r_[e0, e1], np.r_[[0] * 6, [1] * 6],
                             family_depth_ratio=bad)
