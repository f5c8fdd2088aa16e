"""Tests of torsal remeshing (Wang et al. 2013, 4.2, Fig. 8): analytic truth on graph surfaces."""
import numpy as np
import pytest
import trimesh

from torsal.geometry.congruence import Congruence
from torsal.geometry.frame_field import torsal_frame_field
from torsal.geometry.remesh import ParametrizationError, extract_quads, parametrize, remesh_torsal
from torsal.geometry.surfaces import canopy, graph_surface

from graph_cases import noisy_saddle, principal_directions, saddle, star  # tests/geometry/graph_cases.py


def distance_to_A(c, points):
    """Unsigned distance of points to mesh A (libigl AABB, independent of torsal)."""
    import igl

    d2, _, _ = igl.point_mesh_squared_distance(np.asarray(points, float), np.asarray(c.vertices, float),
                                               np.asarray(c.faces, np.int64))
    return np.sqrt(d2)


@pytest.fixture(scope="module")
def saddle_case():
    V, F = graph_surface(saddle, nu=31, nv=31)
    c = Congruence.from_normals((V, F))
    return c, remesh_torsal(c, 1.0 / 20)


def test_edges_follow_principal_directions(saddle_case):
    c, s = saddle_case
    a, e = s.vertices_a, s.edges
    mid = 0.5 * (a[e[:, 0]] + a[e[:, 1]])
    d = a[e[:, 1]] - a[e[:, 0]]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    pd = principal_directions(saddle, mid[:, 0], mid[:, 1])
    dev = np.degrees(np.arccos(np.clip(np.abs(np.einsum("eij,ej->ei", pd, d)).max(1), 0, 1)))
    assert np.median(dev) < 3.0
    # and each family follows one principal direction consistently
    fam_dir = np.abs(np.einsum("eij,ej->ei", pd, d)).argmax(1)
    for fam in (0, 1):
        share = np.bincount(fam_dir[s.edge_family == fam], minlength=2).max() / (s.edge_family == fam).sum()
        assert share > 0.95


def test_fins_nearly_planar_after_extraction(saddle_case):
    _, s = saddle_case
    assert len(s.edges) > 700
    assert s.delta_pl < 0.01


def test_combinatorics_of_a_disk(saddle_case):
    _, s = saddle_case
    inner = ~s.metadata["boundary"]
    deg = np.bincount(s.edges.ravel(), minlength=len(s.vertices_a))
    assert np.all(deg[inner] == 4)            # lattice nodes: regular quad-mesh vertices
    assert np.all(deg[~inner] == 1)            # boundary hits: one fin each
    sizes = np.array([len(f) for f in s.faces])
    interior_faces = [f for f in s.faces if inner[f].all()]
    assert all(len(f) == 4 for f in interior_faces) and len(interior_faces) > 300
    assert sizes.min() >= 3
    # each lattice node has two edges of each family; strips of a family do not branch
    for fam in (0, 1):
        dfam = np.bincount(s.edges[s.edge_family == fam].ravel(), minlength=len(deg))
        assert np.all(dfam[inner] == 2)
    # lattice nodes sit at integer (u, v) (up to the global offset of the lattice)
    uv = s.metadata["uv"][inner]
    assert np.allclose((uv - uv[0]) - np.round(uv - uv[0]), 0.0, atol=1e-9)
    # each face of A~ winds like A (normals agree)
    f4 = [f for f in interior_faces][:50]
    a = s.vertices_a
    for f in f4:
        p = a[f]
        n = np.cross(p[1] - p[0], p[2] - p[0]) + np.cross(p[2] - p[0], p[3] - p[0])
        assert n[2] > 0


def test_vertices_on_A_and_lines(saddle_case):
    c, s = saddle_case
    mesh = trimesh.Trimesh(c.vertices, c.faces, process=False)
    cp, dist, tri = trimesh.proximity.closest_point(mesh, s.vertices_a)
    assert distance_to_A(c, s.vertices_a).max() <= 1e-9
    # b~ lies on the congruence's line through a~: e interpolated linearly in A's triangle (eq. 4)
    bary = trimesh.triangles.points_to_barycentric(c.vertices[c.faces[tri]], s.vertices_a)
    e = np.einsum("nk,nkd->nd", bary, c.directions[c.faces[tri]])
    eb = s.vertices_b - s.vertices_a
    assert np.abs(np.cross(eb, e)).max() / np.linalg.norm(e, axis=1).min() <= 1e-9
    assert np.abs(eb - e).max() <= 1e-9  # the same combination: b~ = sum w_k b_k


def test_spacing_sets_fin_distance(saddle_case):
    _, s = saddle_case
    a, e = s.vertices_a, s.edges
    inner = ~s.metadata["boundary"][e].any(1)
    length = np.linalg.norm(a[e[inner, 1]] - a[e[inner, 0]], axis=1)
    assert abs(np.median(length) - 1 / 20) < 0.1 / 20


@pytest.mark.parametrize("spacings", [(1 / 20, 1 / 10), (1 / 10, 1 / 20)])
def test_each_family_its_own_spacing(saddle_case, spacings):
    """fins.spacing = [s0, s1]: the family-0 fins s0 apart, the family-1 fins s1 apart. Along a
    fin of one family the lattice points are where the other family's fins cross it, so an
    inner edge of family 0 is s1 long and one of family 1 s0 (paper 4.2); the sparse family
    has the fewer strips, in the ratio of the spacings."""
    c, even = saddle_case
    s = remesh_torsal(c, spacings)
    a, e = s.vertices_a, s.edges
    inner = ~s.metadata["boundary"][e].any(1)
    length = np.linalg.norm(a[e[:, 1]] - a[e[:, 0]], axis=1)
    for fam, crossing in ((0, spacings[1]), (1, spacings[0])):
        mine = inner & (s.edge_family == fam)
        assert abs(np.median(length[mine]) - crossing) < 0.1 * crossing
    strips = [len(s.strips(f)) for f in (0, 1)]
    same = [len(even.strips(f)) for f in (0, 1)]       # both families at 1/20
    sparse = int(np.argmax(spacings))
    assert strips[1 - sparse] == same[1 - sparse]
    assert abs(strips[sparse] / same[sparse] - 0.5) < 0.1
    assert distance_to_A(c, a).max() <= 1e-9
    assert s.delta_pl < 0.01


def test_a_spacing_per_family_must_be_two_positive_lengths(saddle_case):
    c, _ = saddle_case
    for bad in ((0.05, -0.1), (0.05, 0.1, 0.2), (0.05, float("nan"))):
        with pytest.raises(ValueError, match="two \\(family 0, family 1\\)"):
            remesh_torsal(c, bad)


def test_patch_with_a_hole_remeshes():
    V, F = canopy(nu=29, nv=29)
    centre = np.array([1.0, 0.5])
    bc = V[F].mean(1)
    keep = np.linalg.norm(bc[:, :2] - centre, axis=1) > 1.8
    m = trimesh.Trimesh(V, F[keep], process=False)
    m.remove_unreferenced_vertices()
    c = Congruence.from_normals((m.vertices, m.faces))
    s = remesh_torsal(c, 0.45)
    assert len(s.edges) > 300
    # no node inside the window; nodes on its rim exist (iso-lines stop at the hole)
    r = np.linalg.norm(s.vertices_a[:, :2] - centre, axis=1)
    assert r.min() > 1.5
    bnd = s.metadata["boundary"]
    assert (bnd & (r < 2.3)).sum() >= 8
    assert distance_to_A(c, s.vertices_a).max() <= 1e-9
    assert s.delta_pl < 0.05


def test_field_with_singularity_remeshes():
    V, F = graph_surface(star, nu=31, nv=31)
    c = Congruence.from_normals((V, F))
    fld = torsal_frame_field(c)
    assert len(fld.singularities) == 1
    p = parametrize(fld, 0.05)
    assert p.metadata["rotational_cut_edges"] > 0     # the cut runs from the umbilic to the boundary
    assert len(p.flipped) == 0
    # the transition across the cut is -I plus an integer translation, satisfied by (u, v)
    ce = np.flatnonzero(p.cut)
    f0, f1 = fld.edge_faces[ce, 0], fld.edge_faces[ce, 1]
    for k, e in enumerate(ce[:20]):
        for vtx in fld.edges[e]:
            uv0 = p.uv[f0[k]][fld.faces[f0[k]] == vtx][0]
            uv1 = p.uv[f1[k]][fld.faces[f1[k]] == vtx][0]
            assert np.allclose(uv0, -uv1 + p.transition[e], atol=1e-6)
    s = extract_quads(p, congruence=c)
    assert len(s.edges) > 600
    # away from the umbilic the mesh is a regular quad mesh; near it there is an irregular face
    sizes = np.array([len(f) for f in s.faces])
    assert (sizes == 4).mean() > 0.8 and (sizes > 4).any()
    assert distance_to_A(c, s.vertices_a).max() <= 1e-9


def test_failure_names_the_problem():
    c = Congruence.from_normals(graph_surface(saddle, nu=11, nv=11))
    with pytest.raises(ParametrizationError, match="spacing"):
        remesh_torsal(c, 50.0)
    with pytest.raises(ValueError, match="spacing"):
        remesh_torsal(c, -1.0)


def test_irregular_field_fails_saying_where():
    """A random congruence followed exactly (no smoothing of its ~140 singularities) folds; the
    error names the faces and the nearest singularity. (The default field smoothing of
    remesh_torsal makes even this field parametrizable, see the noisy-field tests below.)"""
    from torsal.geometry.mesh import vertex_normals

    V, F = graph_surface(lambda x, y: 0.3 * (x**2 - 0.5 * y**2), nu=21, nv=21)
    rng = np.random.default_rng(0)
    c = Congruence(V, F, vertex_normals(V, F) + 0.5 * rng.normal(size=V.shape))
    with pytest.raises(ParametrizationError, match=r"folds over in \d+ of 800 faces.*faces \[.*singularity at vertex"):
        remesh_torsal(c, 0.2, field_kwargs={"smoothing": None})


def test_facade_with_window():
    from torsal.geometry.surfaces import facade_patch

    V, F = facade_patch(nu=33, nv=17)
    bc = V[F].mean(1)
    window = (np.abs(bc[:, 0] - 1.0) < 1.5) & (np.abs(bc[:, 2] - 3.0) < 1.0)
    m = trimesh.Trimesh(V, F[~window], process=False)
    m.remove_unreferenced_vertices()
    c = Congruence.from_normals((m.vertices, m.faces))
    s = remesh_torsal(c, 0.4)
    a = s.vertices_a
    # no node in the window: every removed triangle's barycenter is far from all nodes
    from scipy.spatial import cKDTree

    assert cKDTree(a).query(bc[window])[0].min() > 0.05
    assert distance_to_A(c, a).max() <= 1e-9
    assert s.delta_pl < 0.02
    # the window's rim carries boundary nodes on all four sides
    rim = s.metadata["boundary"] & (np.abs(a[:, 0] - 1.0) < 1.7) & (np.abs(a[:, 2] - 3.0) < 1.2)
    assert rim.sum() >= 8


def test_noisy_torsal_field_remeshes_along_the_smooth_directions():
    """The failure mode of example 13: the raw field folds the parametrization; smoothed below
    half the fin spacing (the default) it has no singularity, no fold, and the fins follow the
    saddle's analytic principal directions."""
    c = noisy_saddle()
    with pytest.raises(ParametrizationError, match="folds over"):
        remesh_torsal(c, 0.1, field_kwargs={"smoothing": None})
    s = remesh_torsal(c, 0.1)
    assert s.metadata["field_smoothing"] == pytest.approx(0.05)
    assert s.metadata["singularities"] == [] and s.metadata["flipped_faces"] == 0
    a, e = s.vertices_a, s.edges
    assert len(e) > 150
    mid = 0.5 * (a[e[:, 0]] + a[e[:, 1]])
    d = a[e[:, 1]] - a[e[:, 0]]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    pd = principal_directions(saddle, mid[:, 0], mid[:, 1])
    dev = np.degrees(np.arccos(np.clip(np.abs(np.einsum("eij,ej->ei", pd, d)).max(1), 0, 1)))
    assert np.median(dev) < 2.0 and np.percentile(dev, 90) < 6.0
    assert distance_to_A(c, a).max() <= 1e-9


def test_near_parabolic_face_does_not_fold_its_neighbours():
    """Where the two directions nearly coincide (a parabolic face) the dual frame grows like
    1 / sin(angle); fitted against it, one such face folds dozens around it. Fitted along the
    field directions only that face is affected."""
    import dataclasses

    from torsal.geometry.frame_field import face_bases

    V, F = graph_surface(saddle, nu=21, nv=21)
    ff = torsal_frame_field(Congruence.from_normals((V, F)))
    bad = 333
    _, _, n = face_bases(V, F)
    t0 = ff.directions[bad, 0]
    d = ff.directions.copy()
    th = np.radians(0.5)
    d[bad, 1] = np.cos(th) * t0 + np.sin(th) * np.cross(n[bad], t0)
    p = parametrize(dataclasses.replace(ff, directions=d), 0.1)
    assert set(p.flipped.tolist()) <= {bad}
    assert p.residual < 0.1


def test_a_cut_that_exchanges_the_families_thins_one_lattice():
    """Across a cut whose matching swaps u and v (a quarter-turn singularity) a family-0 fin
    continues as a family-1 fin, so the families cannot each have a lattice of their own
    spacing: both take the smaller spacing and the sparse family keeps every m-th line, when
    the larger spacing is m times the smaller; other ratios are refused, naming the fix."""
    from types import SimpleNamespace

    from torsal.geometry.frame_field import GROUP
    from torsal.geometry.remesh import _thinning

    swap = int(np.flatnonzero(GROUP[:, 0, 0] == 0)[0])
    flip = int(np.flatnonzero((GROUP[:, 0, 0] == -1) & (GROUP[:, 1, 1] == -1))[0])
    V, F = graph_surface(saddle, nu=5, nv=5)
    field = SimpleNamespace(vertices=V, faces=F, singularities=np.array([12]),
                            edge_faces=np.array([[0, 1], [2, 3]]), matching=np.array([flip, swap]))
    assert _thinning(field, np.array([0, 1]), (0.5, 0.5)) is None     # one spacing: any cut
    assert _thinning(field, np.array([0]), (0.5, 1.0)) is None        # a half turn keeps them
    assert _thinning(field, np.array([0, 1]), (0.5, 1.0)) == {"family": 1, "every": 2}
    assert _thinning(field, np.array([0, 1]), (1.5, 0.5)) == {"family": 0, "every": 3}
    with pytest.raises(ParametrizationError, match=r"exchange.*\[0.5, 0.8\].*whole multiple"):
        _thinning(field, np.array([0, 1]), (0.5, 0.8))


def test_a_thinned_lattice_keeps_every_other_line_of_the_sparse_family(saddle_case):
    """The extraction of a thinned lattice (both families at 1/20, family 1 keeping every
    other line): family 1 has half the strips, family 0 all of them, and an inner family-0
    fin runs from one kept family-1 line to the next, 1/10 long (no node where a dropped line
    would have crossed it)."""
    c, even = saddle_case
    p = parametrize(torsal_frame_field(c, smoothing=1 / 40), 1 / 20)
    p.metadata["thin"] = {"family": 1, "every": 2}
    s = extract_quads(p, congruence=c)
    strips = [len(s.strips(f)) for f in (0, 1)]
    assert strips[0] == len(even.strips(0))
    assert abs(strips[1] / len(even.strips(1)) - 0.5) < 0.1
    a, e = s.vertices_a, s.edges
    inner = ~s.metadata["boundary"][e].any(1) & (s.edge_family == 0)
    assert abs(np.median(np.linalg.norm(a[e[inner, 1]] - a[e[inner, 0]], axis=1)) - 0.1) < 0.01
    assert distance_to_A(c, a).max() <= 1e-9
