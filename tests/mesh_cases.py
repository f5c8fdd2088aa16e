"""Small mesh files written by hand for the loader tests: each format, with and without seams,
per-face normals, unused vertices, broken headers and truncations.

Writers here are independent of torsal's readers (plain string and struct formatting), so a
test that reads back what they wrote checks the reader against the format, not against itself.
"""
from __future__ import annotations

import struct

import numpy as np

# a unit cube as 6 quads, outward winding (the file an exporter writes)
CUBE_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                   [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
CUBE_QUADS = np.array([[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4],
                       [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]])


def quads_to_tris(q: np.ndarray) -> np.ndarray:
    """Fan triangulation (0, 1, 2), (0, 2, 3) of each quad: what every reader here does."""
    q = np.asarray(q)
    return np.stack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]], axis=1).reshape(-1, 3)


def grid(nu: int = 5, nv: int = 4, *, bend: float = 0.3):
    """A gently doubly curved grid patch (hyperbolic normal congruence), (n,3), (F,3)."""
    x, y = np.meshgrid(np.linspace(0, 2, nu), np.linspace(0, 1.5, nv), indexing="ij")
    z = bend * (x - 1) ** 2 - bend * (y - 0.75) ** 2 + 0.05 * x * y
    v = np.c_[x.ravel(), y.ravel(), z.ravel()]
    f = []
    for i in range(nu - 1):
        for j in range(nv - 1):
            a, b, c, d = i * nv + j, (i + 1) * nv + j, (i + 1) * nv + j + 1, i * nv + j + 1
            f += [[a, b, c], [a, c, d]]
    return v, np.array(f)


def _unit(n: np.ndarray) -> np.ndarray:
    length = np.linalg.norm(n)
    return n / length if length > 0 else n  # a degenerate facet gets a zero normal


def _num(x: float) -> str:
    return repr(float(x))


def obj_text(v, f, *, normals: str | None = None, uv: bool = False, unused=()) -> str:
    """OBJ with ``v`` records as given; ``normals="face"`` writes one ``vn`` per face and
    ``f a//n`` corners; ``uv`` adds a ``vt`` per corner (every face its own texture island);
    ``unused`` are extra vertices appended that no face uses."""
    v, f = np.asarray(v, float), np.asarray(f)
    lines = ["# written by tests/mesh_cases.py", "o patch"]
    lines += [f"v {_num(a)} {_num(b)} {_num(c)}" for a, b, c in v]
    lines += [f"v {_num(a)} {_num(b)} {_num(c)}" for a, b, c in np.asarray(unused, float).reshape(-1, 3)]
    if normals == "face":
        fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        fn /= np.linalg.norm(fn, axis=1, keepdims=True)
        lines += [f"vn {_num(a)} {_num(b)} {_num(c)}" for a, b, c in fn]
    if uv:
        lines += [f"vt {k / (3 * len(f)):.6f} {(k % 7) / 7:.6f}" for k in range(f.size)]
    for k, face in enumerate(f):
        corners = []
        for c, i in enumerate(face):
            t = f"{k * f.shape[1] + c + 1}" if uv else ""
            n = f"{k + 1}" if normals == "face" else ""
            corners.append(f"{i + 1}/{t}/{n}" if (uv or n) else f"{i + 1}")
        lines.append("f " + " ".join(corners))
    return "\n".join(lines) + "\n"


def split_per_face(v, f):
    """Every face its own vertices (what a per-face-normal or per-face-UV export does):
    (3F, 3) vertices, faces 0..3F-1."""
    v, f = np.asarray(v, float), np.asarray(f)
    return v[f].reshape(-1, 3), np.arange(f.size).reshape(f.shape)


def _polys(f) -> list[list[int]]:
    return [[int(i) for i in p] for p in f]  # polygons may differ in length


def ply_ascii(v, f, *, n_vertex=None, n_face=None, extra_lines=()) -> str:
    v, f = np.asarray(v, float), _polys(f)
    head = ["ply", "format ascii 1.0", "comment tests/mesh_cases.py",
            f"element vertex {len(v) if n_vertex is None else n_vertex}",
            "property float x", "property float y", "property float z",
            f"element face {len(f) if n_face is None else n_face}",
            "property list uchar int vertex_indices", "end_header"]
    body = [f"{_num(a)} {_num(b)} {_num(c)}" for a, b, c in v]
    body += [f"{len(p)} " + " ".join(str(int(i)) for i in p) for p in f]
    return "\n".join(head + body + list(extra_lines)) + "\n"


def ply_binary(v, f, *, n_vertex=None, n_face=None, endian="<", cut: int = 0) -> bytes:
    v, f = np.asarray(v, float), _polys(f)
    fmt = "binary_little_endian" if endian == "<" else "binary_big_endian"
    head = ("ply\nformat " + fmt + " 1.0\n"
            f"element vertex {len(v) if n_vertex is None else n_vertex}\n"
            "property double x\nproperty double y\nproperty double z\n"
            f"element face {len(f) if n_face is None else n_face}\n"
            "property list uchar int vertex_indices\nend_header\n").encode()
    body = b"".join(struct.pack(endian + "3d", *row) for row in v)
    body += b"".join(struct.pack(endian + "B", len(p)) + struct.pack(endian + f"{len(p)}i", *p)
                     for p in f)
    data = head + body
    return data[:len(data) - cut] if cut else data


def off_text(v, f, *, n_vertex=None, n_face=None) -> str:
    v, f = np.asarray(v, float), _polys(f)
    lines = ["OFF", "# tests/mesh_cases.py",
             f"{len(v) if n_vertex is None else n_vertex} {len(f) if n_face is None else n_face} 0"]
    lines += [f"{_num(a)} {_num(b)} {_num(c)}" for a, b, c in v]
    lines += [f"{len(p)} " + " ".join(str(int(i)) for i in p) for p in f]
    return "\n".join(lines) + "\n"


def stl_ascii(v, f) -> str:
    v, f = np.asarray(v, float), np.asarray(f)
    lines = ["solid patch"]
    for tri in f:
        p = v[tri]
        n = _unit(np.cross(p[1] - p[0], p[2] - p[0]))
        lines += [f"  facet normal {n[0]:e} {n[1]:e} {n[2]:e}", "    outer loop"]
        lines += [f"      vertex {a:.9e} {b:.9e} {c:.9e}" for a, b, c in p]
        lines += ["    endloop", "  endfacet"]
    lines.append("endsolid patch")
    return "\n".join(lines) + "\n"


def stl_binary(v, f, *, count=None) -> bytes:
    v, f = np.asarray(v, float), np.asarray(f)
    out = [b"binary STL from tests/mesh_cases.py".ljust(80, b" "),
           struct.pack("<I", len(f) if count is None else count)]
    for tri in f:
        p = v[tri]
        n = _unit(np.cross(p[1] - p[0], p[2] - p[0]))
        out.append(struct.pack("<12fH", *n, *p.ravel(), 0))
    return b"".join(out)


WRITERS = {
    ".obj": lambda v, f: obj_text(v, f).encode(),
    ".ply": lambda v, f: ply_ascii(v, f).encode(),
    ".off": lambda v, f: off_text(v, f).encode(),
    ".stl": lambda v, f: stl_binary(v, f),
}


# ---------------------------------------------------------------- exporters' dialects
# Small files as other programs write them (header lines, property types, extra properties,
# line ends, number formats), written here by hand. Each writer returns the bytes and the
# vertex records as the file holds them (rounded to the file's precision), in file order.
_PLY_STRUCT = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h",
               "ushort": "H", "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I",
               "float": "f", "float32": "f", "double": "d", "float64": "d"}


def ply_dialect(v, f, *, fmt: str = "ascii", magic: str = "ply", newline: str = "\n",
                coord: str = "float", header=(), vertex_props=(), face_props=(),
                count_type: str = "uchar", index_type: str = "int",
                list_name: str = "vertex_indices", digits: int | None = None):
    """PLY the way an exporter writes it.

    ``header``: comment / obj_info lines; ``vertex_props`` / ``face_props``: extra properties
    after x y z / after the index list, as (type, name, values) with one value per record;
    ``digits``: ASCII coordinates with that many decimals (COMPAS: 3), else repr.
    Returns (bytes, the vertex records as written (n, 3))."""
    v, f = np.asarray(v, float), _polys(f)
    if fmt != "ascii":
        written = v.astype(np.float32).astype(float) if coord in ("float", "float32") else v.copy()
    elif digits is not None:
        written = np.array([[float(f"{x:.{digits}f}") for x in row] for row in v])
    else:
        written = v.copy()
    head = [magic, f"format {fmt} 1.0", *header, f"element vertex {len(v)}",
            *(f"property {coord} {a}" for a in "xyz"),
            *(f"property {t} {n}" for t, n, _ in vertex_props),
            f"element face {len(f)}", f"property list {count_type} {index_type} {list_name}",
            *(f"property {t} {n}" for t, n, _ in face_props), "end_header"]
    data = newline.join(head).encode() + newline.encode()
    if fmt == "ascii":
        def num(t, x):
            if _PLY_STRUCT[t] in "fd":
                return f"{x:.{digits}f}" if digits is not None else repr(float(x))
            return str(int(x))
        rows = [" ".join([num(coord, x) for x in written[k]]
                         + [num(t, vals[k]) for t, _, vals in vertex_props]) for k in range(len(v))]
        rows += [" ".join([str(len(p))] + [str(i) for i in p]
                          + [num(t, vals[k]) for t, _, vals in face_props])
                 for k, p in enumerate(f)]
        return data + (newline.join(rows) + newline).encode(), written
    end = "<" if fmt == "binary_little_endian" else ">"
    body = []
    for k in range(len(v)):
        body.append(struct.pack(end + 3 * _PLY_STRUCT[coord], *v[k]))
        body += [struct.pack(end + _PLY_STRUCT[t], vals[k]) for t, _, vals in vertex_props]
    for k, p in enumerate(f):
        body.append(struct.pack(end + _PLY_STRUCT[count_type], len(p))
                    + struct.pack(end + len(p) * _PLY_STRUCT[index_type], *p))
        body += [struct.pack(end + _PLY_STRUCT[t], vals[k]) for t, _, vals in face_props]
    return data + b"".join(body), written


def obj_dialect(v, f, *, app: str = "blender", objects: int = 1, relative: bool = False,
                wrap: bool = False, newline: str = "\n", colours: bool = False):
    """OBJ the way Rhino or Blender writes it: comment header, mtllib, objects / groups,
    usemtl, smoothing groups, vt and vn with every corner ``v/vt/vn``; ``objects`` splits the
    faces into that many objects, each with its own vertex records (the seams duplicated);
    ``relative`` writes negative indices (Rhino's option), ``wrap`` continues each face line
    with a backslash (Rhino's "wrap long lines"), ``colours`` writes ``v x y z r g b``.
    Returns (bytes, the vertex records as written (n, 3))."""
    v, f = np.asarray(v, float), _polys(f)
    lines = (["# Rhino", "", "mtllib model.mtl"] if app == "rhino"
             else ["# Blender 4.1.1", "# www.blender.org", "mtllib untitled.mtl"])
    written, n_v, n_vt = [], 0, 0
    chunks = np.array_split(np.arange(len(f)), objects)
    for o, chunk in enumerate(chunks):
        used = sorted({i for k in chunk for i in f[k]})
        local = {i: j for j, i in enumerate(used)}
        name = f"object_{o + 1}" if app == "rhino" else f"Plane.{o:03d}"
        lines += [f"o {name}"] + ([f"g {name}", "usemtl diffuse_0"] if app == "rhino" else [])
        for i in used:
            xyz = [float(f"{x:.6f}") for x in v[i]]
            written.append(xyz)
            col = " 0.8000 0.2000 0.1000" if colours else ""
            lines.append("v " + " ".join(f"{x:.6f}" for x in xyz) + col)
        lines += [f"vn 0.0000 0.0000 1.0000"]
        lines += [f"vt {k / max(1, len(used)):.6f} 0.500000" for k in range(len(used))]
        if app == "blender":
            lines += ["s 0", "usemtl Material"]
        for k in chunk:
            corners = []
            for i in f[k]:
                vi = local[i] - len(used) if relative else n_v + local[i] + 1
                ti = local[i] - len(used) if relative else n_vt + local[i] + 1
                ni = -1 if relative else o + 1
                corners.append(f"{vi}/{ti}/{ni}")
            if wrap and len(corners) > 2:
                lines += ["f " + " ".join(corners[:2]) + " \\", "  " + " ".join(corners[2:])]
            else:
                lines.append("f " + " ".join(corners))
        n_v += len(used)
        n_vt += len(used)
    return (newline.join(lines) + newline).encode(), np.array(written)


def first_occurrences(records) -> np.ndarray:
    """Vertex records without exact repeats, in order of first appearance: what merging
    a file whose seams repeat positions exactly gives."""
    records = np.asarray(records, float)
    return records[np.sort(np.unique(records, axis=0, return_index=True)[1])]
