"""Mesh loading and validation: bad input gets a clear error naming the problem."""
import numpy as np
import pytest
import scipy.sparse as sp
import trimesh

from torsal.geometry.mesh import (
    MeshError,
    average_edge_length,
    boundary_vertices,
    edge_face_adjacency,
    load_mesh,
    umbrella_laplacian,
    validate_mesh,
    vertex_normals,
)
from torsal.geometry.surfaces import cylinder_patch, grid_faces


def _grid(n=4):
    x, y = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float), indexing="ij")
    return np.c_[x.ravel(), y.ravel(), np.zeros(n * n)], grid_faces(n, n)


@pytest.mark.parametrize("ext", [".obj", ".ply", ".stl", ".off"])
def test_load_all_formats(tmp_path, ext):
    v, f = cylinder_patch(nu=6, nv=4)
    path = tmp_path / f"m{ext}"
    trimesh.Trimesh(v, f, process=False).export(path)
    m = load_mesh(path)
    assert len(m.faces) == len(f)
    assert len(m.vertices) == len(v)
    assert np.isclose(m.area, trimesh.Trimesh(v, f).area)


def test_missing_and_empty_files(tmp_path):
    with pytest.raises(FileNotFoundError, match="not found"):
        load_mesh(tmp_path / "nope.obj")
    empty = tmp_path / "empty.obj"
    empty.write_text("")
    with pytest.raises(MeshError, match="empty"):
        load_mesh(empty)
    no_faces = tmp_path / "points.obj"
    no_faces.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    with pytest.raises(MeshError, match="no triangle faces"):
        load_mesh(no_faces)
    with pytest.raises(MeshError, match="unsupported"):
        load_mesh(tmp_path / "x.dwg") if (tmp_path / "x.dwg").write_text("x") else None


def test_nan_vertex_is_named(tmp_path):
    v, f = _grid()
    v[5, 1] = np.nan
    with pytest.raises(MeshError, match=r"vertices \[5\].*NaN"):
        validate_mesh(v, f)
    path = tmp_path / "nan.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n")
    with pytest.raises(MeshError, match="nan.obj.*NaN"):
        load_mesh(path)


def test_degenerate_faces_are_named():
    v, f = _grid()
    v[5] = (v[4] + v[6]) / 2  # collinear with its row neighbours -> zero-area faces
    v2, f2 = _grid()
    f2 = np.vstack([f2, [1, 1, 2]])
    with pytest.raises(MeshError, match=r"degenerate faces \[%d\] use the same vertex" % (len(f2) - 1)):
        validate_mesh(v2, f2)
    vz, fz = _grid()
    vz[0] = vz[1]  # two vertices at the same place
    with pytest.raises(MeshError, match="zero area"):
        validate_mesh(vz, fz)


def test_non_manifold_edge_is_named():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1]], float)
    f = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    with pytest.raises(MeshError, match=r"non-manifold.*edge \[0, 1\]"):
        validate_mesh(v, f)


def test_inconsistent_orientation_is_named():
    v, f = _grid(3)
    f = f.copy()
    f[0] = f[0, ::-1]
    with pytest.raises(MeshError, match="inconsistent orientation"):
        validate_mesh(v, f)


def test_no_faces():
    with pytest.raises(MeshError, match="no faces"):
        validate_mesh(np.zeros((3, 3)), np.zeros((0, 3), int))


def test_adjacency_boundary_laplacian_normals():
    v, f = _grid(4)
    edges, ef = edge_face_adjacency(f)
    assert len(edges) == 3 * 3 * 2 + 3 * 2 + 3 * 3 - 3 * 0 - 0 or len(edges) == 33
    assert len(edges) == 33  # 24 grid edges + 9 diagonals
    boundary = ef[:, 1] < 0
    assert boundary.sum() == 12
    # each interior edge has two different faces that both contain it
    inner = ~boundary
    for (i, j), (f0, f1) in zip(edges[inner], ef[inner]):
        assert f0 != f1 and {i, j} <= set(f[f0]) and {i, j} <= set(f[f1])
    assert set(boundary_vertices(f)) == set(range(16)) - {5, 6, 9, 10}
    L = umbrella_laplacian(f, 16)
    assert sp.issparse(L)
    # constants and linear functions are in the kernel at interior vertices (regular grid)
    assert np.allclose(L @ np.ones(16), 0)
    interior = [5, 6, 9, 10]
    assert np.allclose((L @ v)[interior], 0)
    n = vertex_normals(v, f)
    assert np.allclose(n, [0, 0, 1])
    assert np.isclose(average_edge_length(v, f), (24 * 1 + 9 * np.sqrt(2)) / 33)


def test_area_weighted_normals():
    # a vertex shared by a big and a small face: area weights favour the big one
    v = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, -1], [0, -1, 0]], float)
    f = np.array([[0, 1, 2], [0, 3, 4]])
    n = vertex_normals(v, f)
    big = np.array([0, 0, 1.0])
    small = np.cross(v[3] - v[0], v[4] - v[0])
    small /= np.linalg.norm(small)
    expected = 50 * big + 0.5 * small
    assert np.allclose(n[0], expected / np.linalg.norm(expected))
