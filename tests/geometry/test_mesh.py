"""Mesh loading and validation: bad input gets a clear error naming the problem."""
import struct
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
import trimesh

from torsal.core.errors import TorsalError
from torsal.geometry.mesh import (
    MeshError,
    average_edge_length,
    boundary_vertices,
    edge_face_adjacency,
    load_mesh,
    merge_vertices,
    umbrella_laplacian,
    validate_mesh,
    vertex_normals,
)
from torsal.geometry.surfaces import cylinder_patch, grid_faces

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import mesh_cases as mc  # noqa: E402  (tests/mesh_cases.py: independent writers)


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


# ---------------------------------------------------------------- the file's vertices
def test_obj_per_face_normals_keeps_the_8_cube_vertices(tmp_path):
    path = tmp_path / "cube.obj"
    path.write_text(mc.obj_text(mc.CUBE_V, mc.CUBE_QUADS, normals="face", uv=True))
    m = load_mesh(path)
    merge = m.metadata["merge"]
    assert len(m.vertices) == 8 and merge.identity and merge.polygons == 6
    assert np.array_equal(m.vertices, mc.CUBE_V)              # file order, file coordinates
    assert np.array_equal(m.faces, mc.quads_to_tris(mc.CUBE_QUADS))


@pytest.mark.parametrize("fmt", ["obj", "ply", "ply-binary", "off", "stl", "stl-ascii"])
def test_split_files_merge_back_to_the_shared_vertices(tmp_path, fmt):
    """A file that gives every face its own vertices (seams everywhere) reads as the shared mesh."""
    v, f = mc.grid()
    sv, sf = mc.split_per_face(v, f)
    write = {"obj": lambda: mc.obj_text(sv, sf), "ply": lambda: mc.ply_ascii(sv, sf),
             "ply-binary": lambda: mc.ply_binary(sv, sf), "off": lambda: mc.off_text(sv, sf),
             "stl": lambda: mc.stl_binary(v, f), "stl-ascii": lambda: mc.stl_ascii(v, f)}[fmt]()
    path = tmp_path / f"split.{fmt.split('-')[0]}"
    path.write_bytes(write if isinstance(write, bytes) else write.encode())
    m = load_mesh(path)
    merge = m.metadata["merge"]
    assert merge.file_vertices == 3 * len(f) and merge.vertices == len(v)
    assert merge.merged == 3 * len(f) - len(v) and merge.unused == 0
    # merged vertices come in order of their first file vertex; faces keep their order
    order = np.unique(f.ravel(), return_index=True)[1]
    first_seen = f.ravel()[np.sort(order)]
    atol = 1e-6 if fmt == "stl" else 1e-12  # binary STL stores float32
    assert np.allclose(m.vertices, v[first_seen], atol=atol)
    assert np.allclose(m.vertices[m.faces], v[f], atol=atol)
    assert np.array_equal(merge.file_to_merged[sf] if fmt not in ("stl", "stl-ascii") else
                          merge.file_to_merged.reshape(-1, 3), m.faces)


def test_unused_vertices_are_dropped_and_reported(tmp_path):
    v, f = mc.grid()
    path = tmp_path / "unused.obj"
    path.write_text(mc.obj_text(v, f, unused=[[9, 9, 9], [8, 8, 8]]))
    m = load_mesh(path)
    merge = m.metadata["merge"]
    assert (merge.file_vertices, merge.vertices, merge.unused) == (len(v) + 2, len(v), 2)
    assert merge.file_to_merged[-2:].tolist() == [-1, -1]
    assert np.array_equal(m.vertices, v) and "2 in no face" in merge.describe()


def test_merge_tolerance_is_relative_to_the_diagonal():
    v, f = mc.grid()
    diag = np.linalg.norm(np.ptp(v, axis=0))
    sv, sf = mc.split_per_face(v, f)
    rng = np.random.default_rng(0)
    jitter = rng.uniform(-1, 1, sv.shape) * 0.2e-6 * diag / np.sqrt(3)  # well within 1e-6
    mv, mf, merge = merge_vertices(sv + jitter, sf)
    assert merge.vertices == len(v) and np.isclose(merge.tolerance, 1e-6 * diag)
    mv, mf, merge = merge_vertices(sv + jitter, sf, tolerance=None)  # nothing merged
    assert merge.vertices == len(sv)
    mv, mf, merge = merge_vertices(1000 * sv, sf)  # units do not matter
    assert merge.vertices == len(v)


def test_to_merged_rows_per_file_or_merged_vertex():
    v, f = mc.grid()
    sv, sf = mc.split_per_face(v, f)
    _, _, merge = merge_vertices(sv, sf)
    d = np.c_[v[:, :2] * 0.1, np.ones(len(v))]
    per_file = d[f.ravel()]                                   # one row per file vertex
    out, per = merge.to_merged(per_file, what="d.txt")
    order = np.sort(np.unique(f.ravel(), return_index=True)[1])
    assert per == "file vertex" and np.array_equal(out, d[f.ravel()[order]])
    out2, per2 = merge.to_merged(out)
    assert per2 == "merged vertex" and out2 is not None
    bad = per_file.copy()
    bad[5] += 0.5  # a row that disagrees with the other rows of its merged vertex
    with pytest.raises(MeshError, match=r"d.txt: rows \d+ and \d+ belong to file vertices at the same"):
        merge.to_merged(bad, what="d.txt")
    with pytest.raises(MeshError, match=r"7 rows, but the mesh has 20 vertices \(%d in the file" % len(sv)):
        merge.to_merged(np.ones((7, 3)))


# ---------------------------------------------------------------- headers and truncation
@pytest.mark.parametrize("fmt", ["ply", "ply-binary", "off"])
def test_header_counts_must_match_the_content(tmp_path, fmt):
    v, f = mc.CUBE_V, mc.quads_to_tris(mc.CUBE_QUADS)
    write = {"ply": lambda **k: mc.ply_ascii(v, f, **k).encode(),
             "ply-binary": lambda **k: mc.ply_binary(v, f, **k),
             "off": lambda **k: mc.off_text(v, f, **k).encode()}[fmt]
    path = tmp_path / f"m.{fmt.split('-')[0]}"
    path.write_bytes(write(n_face=100_000_000))
    with pytest.raises(MeshError, match=r"declares (100000000 face|8 vertices and 100000000 faces)"):
        load_mesh(path)
    path.write_bytes(write(n_face=5))  # fewer than the file holds
    with pytest.raises(MeshError, match="more data than the header declares|bytes after the records"):
        load_mesh(path)
    path.write_bytes(write(n_vertex=9))
    with pytest.raises(MeshError, match="header"):
        load_mesh(path)


def test_truncated_files_are_rejected_with_the_line(tmp_path):
    v, f = mc.grid()
    text = mc.obj_text(v, f)
    lines = text.splitlines()
    path = tmp_path / "t.obj"
    path.write_text("\n".join(lines[:-1]) + "\n" + lines[-1][:4])  # the last face cut short
    with pytest.raises(MeshError, match=rf"t.obj: line {len(lines)}: .*truncated"):
        load_mesh(path)
    path.write_text(text[: text.index("\nv ", len(text) // 5) + 6])  # cut inside a vertex
    with pytest.raises(MeshError, match=r"line \d+: a vertex needs x y z.*truncated"):
        load_mesh(path)
    stl = mc.stl_ascii(v, f)
    (tmp_path / "t.stl").write_text(stl[: len(stl) // 2])
    with pytest.raises(MeshError, match=r"t.stl: line \d+: .*truncated"):
        load_mesh(tmp_path / "t.stl")
    (tmp_path / "b.stl").write_bytes(mc.stl_binary(v, f)[:-20])
    with pytest.raises(MeshError, match=rf"declares {len(f)} triangles .* truncated"):
        load_mesh(tmp_path / "b.stl")
    (tmp_path / "b.ply").write_bytes(mc.ply_binary(v, f, cut=7))
    with pytest.raises(MeshError, match="truncated"):
        load_mesh(tmp_path / "b.ply")
    off = mc.off_text(v, f)
    (tmp_path / "t.off").write_text(off[: len(off) - 9])
    with pytest.raises(MeshError, match=r"t.off: line \d+:.*truncated"):
        load_mesh(tmp_path / "t.off")


def test_folder_and_garbage_are_named(tmp_path):
    (tmp_path / "dir.obj").mkdir()
    with pytest.raises(TorsalError, match="dir.obj is a folder"):
        load_mesh(tmp_path / "dir.obj")
    (tmp_path / "g.obj").write_bytes(bytes(range(256)) * 4)
    with pytest.raises(MeshError, match=r"g.obj: line 1: .* is not an OBJ statement"):
        load_mesh(tmp_path / "g.obj")


def test_big_endian_binary_ply(tmp_path):
    v, f = mc.grid()
    (tmp_path / "be.ply").write_bytes(mc.ply_binary(v, f, endian=">"))
    m = load_mesh(tmp_path / "be.ply")
    assert np.array_equal(m.vertices, v) and np.array_equal(m.faces, f)


# ---------------------------------------------------------------- same analysis as the merged mesh
def _summary_numbers(s: dict) -> dict:
    """The analysis numbers of a summary (not the file names or the merge report)."""
    return {k: v for k, v in s.items() if k not in ("mesh", "directions", "mesh_file")}


@pytest.mark.parametrize("layout", ["uv-seams", "per-face-normals", "unused-vertices",
                                    "split-ply", "split-stl-ascii", "split-off"])
def test_seams_normals_and_unused_vertices_give_the_merged_analysis(tmp_path, layout):
    from torsal.pipeline.analyze import analyze

    v, f = mc.grid(7, 6)
    sv, sf = mc.split_per_face(v, f)
    text = {"uv-seams": lambda: mc.obj_text(v, f, uv=True),
            "per-face-normals": lambda: mc.obj_text(v, f, normals="face"),
            "unused-vertices": lambda: mc.obj_text(v, f, unused=[[5, 5, 5], [6, 6, 6]]),
            "split-ply": lambda: mc.ply_ascii(sv, sf), "split-stl-ascii": lambda: mc.stl_ascii(v, f),
            "split-off": lambda: mc.off_text(sv, sf)}[layout]()
    ext = {"split-ply": ".ply", "split-stl-ascii": ".stl", "split-off": ".off"}.get(layout, ".obj")
    path = tmp_path / f"m{ext}"
    path.write_text(text)
    (tmp_path / "merged.obj").write_text(mc.obj_text(v, f))
    got = analyze(path).summary
    ref = analyze(tmp_path / "merged.obj").summary
    assert got["vertices"] == len(v) and got["mesh_file"]["file_vertices"] >= len(v)
    a, b = _summary_numbers(got), _summary_numbers(ref)
    rtol = 1e-6 if "stl" in layout else 1e-9  # ASCII STL holds 10 significant digits
    assert a.keys() == b.keys()
    for k in a:
        if isinstance(a[k], dict):
            for kk in a[k]:
                assert np.isclose(a[k][kk], b[k][kk], rtol=rtol, atol=1e-12), (k, kk)
        else:
            assert np.isclose(a[k], b[k], rtol=rtol, atol=1e-12), k


def test_obj_fast_reader_agrees_with_the_line_reader():
    from torsal.geometry.mesh_files import _obj_fast, _obj_lines, _read_obj

    v, f = mc.grid(9, 7)
    for text in (mc.obj_text(v, f), mc.obj_text(v, f, normals="face", uv=True),
                 mc.obj_text(v, f).replace("\n", "\r\n"), mc.obj_text(v, f).replace("\n", "\r"),
                 mc.obj_text(v, f, unused=[[1, 2, 3]])):
        fast, slow = _read_obj(text.encode()), _read_obj(text.encode(), lines=True)
        assert fast.face_lines is None and slow.face_lines is not None  # the fast reader read it
        assert np.array_equal(fast.vertices, slow.vertices) and np.array_equal(fast.faces, slow.faces)
        assert np.array_equal(fast.vertices[:len(v)], v) and np.array_equal(fast.faces, f)
        # the line of every face: 'f' lines counted independently
        f_lines = [k + 1 for k, ln in enumerate(text.replace("\r\n", "\n").replace("\r", "\n")
                                                .split("\n")) if ln.startswith("f ")]
        assert slow.face_lines.tolist() == f_lines
    assert _obj_fast(mc.obj_text(v, f).replace("f 1 ", "f 1.0 ", 1)) is None   # not an index
    # anything unusual goes to the line reader
    assert _obj_fast(mc.obj_text(v, f).replace("f 1 ", "f -1 ", 1)) is None   # a relative index
    assert _obj_fast(mc.obj_text(v, f) + "f 1 2\n") is None                    # a short face
    assert _obj_fast(mc.obj_text(mc.CUBE_V, mc.CUBE_QUADS)) is None                     # polygons
    assert _obj_fast("v 0 0 0\nvx 1 2 3\nf 1 1 1\n") is None


# ---------------------------------------------------------------- files from the wild
def test_ply_magic_and_keywords_in_any_case_and_line_end(tmp_path):
    v, f = mc.grid(4, 3)
    base = mc.ply_ascii(v, f)
    variants = {"upper": base.replace("ply\n", "PLY\n", 1), "crlf": base.replace("\n", "\r\n"),
                "cr": base.replace("\n", "\r"), "upper-crlf": base.replace("ply\n", "PLY\n", 1).replace("\n", "\r\n"),
                "spaces": base.replace("ply\n", "ply  \n", 1).replace("end_header\n", "end_header \n"),
                "bom": "\ufeff" + base, "keywords": base.replace("format ascii", "FORMAT ASCII")
                .replace("element vertex", "ELEMENT VERTEX").replace("end_header", "END_HEADER")}
    for name, text in variants.items():
        p = tmp_path / f"{name}.ply"
        p.write_bytes(text.encode())
        m = load_mesh(p)
        assert np.array_equal(m.vertices, v) and np.array_equal(m.faces, f), name
    # a comment that mentions end_header does not end the header
    p = tmp_path / "c.ply"
    p.write_text(base.replace("comment tests", "comment written before end_header"))
    assert np.array_equal(load_mesh(p).vertices, v)


def test_every_text_reader_keeps_the_line_of_each_face():
    from torsal.geometry.mesh_files import _read_off, _read_ply, _read_stl, _read_obj

    v, f = mc.grid(4, 3)
    q = np.array([[0, 3, 4, 1], [1, 4, 5, 2]])  # two quads: fan-triangulated, one line each

    def lines_of(text, start):
        return [k + 1 for k, ln in enumerate(text.splitlines()) if ln.startswith(start)]

    obj = mc.obj_text(v, q)
    assert _read_obj(obj.encode(), lines=True).face_lines.tolist() == \
        [n for n in lines_of(obj, "f ") for _ in range(2)]
    ply = mc.ply_ascii(v, f)
    assert _read_ply(ply.encode()).face_lines.tolist() == lines_of(ply, "3 ")
    off = mc.off_text(v, f)
    assert _read_off(off.encode()).face_lines.tolist() == lines_of(off, "3 ")
    stl = mc.stl_ascii(v, f)
    assert _read_stl(stl.encode()).face_lines.tolist() == lines_of(stl, "  facet")
    assert _read_stl(mc.stl_binary(v, f)).face_lines is None
    # a face continued over two lines is numbered by its first line
    wrapped = obj.replace("f 1 4 5 2", "f 1 4 \\\n 5 2")
    assert _read_obj(wrapped.encode()).face_lines.tolist() == \
        [n for n in lines_of(wrapped, "f ") for _ in range(2)]


def test_validation_messages_name_the_file_lines(tmp_path):
    v, f = mc.grid(4, 3)
    bad = np.vstack([f, [[0, 1, 1]]])               # a face with a repeated vertex, last line
    text = mc.obj_text(v, bad)
    p = tmp_path / "d.obj"
    p.write_text(text)
    with pytest.raises(MeshError, match=rf"use the same vertex twice; remove them; file line "
                                        rf"{len(text.splitlines())}$") as exc:
        load_mesh(p)
    assert exc.value.faces.tolist() == [len(f)]
    p = tmp_path / "d.stl"
    flipped = f.copy()
    flipped[3] = flipped[3, ::-1]
    p.write_bytes(mc.stl_binary(v, flipped))
    with pytest.raises(MeshError, match=r"inconsistent orientation.*; facets \[.*3.*\] of the file"):
        load_mesh(p)


def test_duplicate_faces_are_dropped_and_both_windings_refused():
    from torsal.geometry.mesh import drop_duplicate_faces

    f = np.array([[0, 1, 2], [2, 3, 0], [1, 2, 0], [0, 2, 3], [3, 0, 2]])
    kept_f, kept = drop_duplicate_faces(f)  # (1, 2, 0) is (0, 1, 2); (0, 2, 3), (3, 0, 2) = (2, 3, 0)
    assert kept.tolist() == [0, 1] and kept_f.tolist() == [[0, 1, 2], [2, 3, 0]]
    with pytest.raises(MeshError, match=r"faces \[0, 2\] are the same triangles twice with "
                                        "opposite windings") as exc:
        drop_duplicate_faces(np.array([[0, 1, 2], [1, 2, 3], [2, 1, 0]]))
    assert exc.value.faces.tolist() == [0, 2]
    same, kept = drop_duplicate_faces(np.array([[0, 1, 2]]))
    assert same.tolist() == [[0, 1, 2]] and kept.tolist() == [0]


def test_binary_ply_lists_of_one_length_read_as_a_block_agree_with_records(tmp_path):
    from torsal.geometry import mesh_files

    v, f = mc.grid(5, 4)
    quads = np.array([[i * 4 + j, (i + 1) * 4 + j, (i + 1) * 4 + j + 1, i * 4 + j + 1]
                      for i in range(4) for j in range(3)])
    data, _ = mc.ply_dialect(v, quads, fmt="binary_little_endian",
                             face_props=[("uchar", "red", np.arange(12)), ("float", "quality",
                                                                           np.linspace(0, 1, 12))])
    block = mesh_files._read_ply(data)
    real = mesh_files._ply_fixed_lists
    try:
        mesh_files._ply_fixed_lists = lambda *a: None   # the record-by-record reader
        records = mesh_files._read_ply(data)
    finally:
        mesh_files._ply_fixed_lists = real
    assert np.array_equal(block.faces, records.faces) and np.array_equal(block.faces, mc.quads_to_tris(quads))
    assert block.polygons == records.polygons == 12


def test_merged_vertex_row_order_is_said_in_words(tmp_path):
    v, f = mc.grid(4, 3)
    p = tmp_path / "g.stl"
    p.write_bytes(mc.stl_binary(v, f))
    merge = load_mesh(p).metadata["merge"]
    assert "first appears in the file (facet by facet, corner by corner)" in merge.vertex_order
    assert "an STL file has no vertex order" in merge.row_convention("merged vertex")
    assert merge.row_convention("file vertex").startswith("row i is vertex record i of the file "
                                                          "(corner i % 3 of facet i // 3)")
    p = tmp_path / "g.obj"
    p.write_text(mc.obj_text(v, f))
    merge = load_mesh(p).metadata["merge"]
    assert merge.vertex_order == "as in the file" and merge.as_dict()["vertex_order"] == "as in the file"


def test_compas_sample_dialect_200_vertices_342_faces(tmp_path):
    """The dialect of COMPAS' sample meshes ('PLY', CRLF, three decimals) at the size of the
    one the issue names (trimesh: 200 vertices, 342 faces): torsal and trimesh agree."""
    v, f = mc.grid(10, 20, bend=0.05)                     # 200 vertices, 2 * 9 * 19 = 342 faces
    data, written = mc.ply_dialect(v * 10, f, magic="PLY", newline="\r\n", digits=3)
    assert data.startswith(b"PLY\r\nformat ascii 1.0\r\n") and b"\r\nend_header\r\n" in data
    p = tmp_path / "tubemesh-like.ply"
    p.write_bytes(data)
    m = load_mesh(p)
    t = trimesh.load(p, process=False, force="mesh")
    assert (len(m.vertices), len(m.faces)) == (len(t.vertices), len(t.faces)) == (200, 342)
    assert np.array_equal(m.vertices, written) and np.array_equal(m.faces, f)
    assert np.allclose(t.vertices, written, atol=1e-5)  # trimesh keeps 'float' as float32
