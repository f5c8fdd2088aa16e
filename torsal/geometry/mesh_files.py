"""Reading mesh files as the file has them: OBJ, PLY (ASCII and binary), OFF and STL.

Each reader returns the file's own vertex records, in file order, and its faces as indices
into them (polygons fan-triangulated). Nothing is merged, dropped or repaired here; that is
:func:`torsal.geometry.mesh.merge_vertices`' job, and it reports what it did.

Every reader checks the file against itself: counts a PLY or OFF header declares must match
the records that follow (in both directions), a binary STL's triangle count must match its
size, and a record cut short (a truncated file) is an error naming its line. Errors are
:class:`MeshError` with the file name and,
where there is one, the line number.

Examples
--------
>>> import tempfile, pathlib
>>> p = pathlib.Path(tempfile.mkdtemp()) / "t.obj"
>>> _ = p.write_text("v 0 0 0\\nv 1 0 0\\nv 0 1 0\\nv 1 1 0\\nf 1 2 4 3\\n")
>>> raw = read_mesh_file(p)
>>> raw.vertices.shape, raw.faces.tolist(), raw.polygons
((4, 3), [[0, 1, 3], [0, 3, 2]], 1)
"""
from __future__ import annotations

import re
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from torsal.core.errors import TorsalError
from torsal.core.inputs import read_input

__all__ = ["MeshError", "RawMesh", "read_mesh_file", "SUPPORTED_FORMATS"]

SUPPORTED_FORMATS = (".obj", ".ply", ".off", ".stl")


class MeshError(TorsalError, ValueError):
    """A mesh that torsal cannot work on; the message names the problem and the fix.

    ``faces`` (an int array, or None) are the faces the message is about, as indices into the
    faces that were checked: :func:`~torsal.geometry.mesh.load_mesh` turns them into file lines.
    Defined here, the lowest mesh module, and re-exported by :mod:`torsal.geometry.mesh`.
    """

    def __init__(self, message: str = "", *, faces=None):
        super().__init__(message)
        self.faces = None if faces is None else np.asarray(faces, dtype=np.int64).ravel()


@dataclass(frozen=True)
class RawMesh:
    """A mesh exactly as the file has it.

    Attributes
    ----------
    vertices : (n, 3) float
        Every vertex record of the file, in file order (STL: three per triangle).
    faces : (F, 3) int
        Triangles as indices into ``vertices``; polygons are fan-triangulated.
    polygons : int
        Number of faces with more than three corners that were fan-triangulated.
    format : str
        ``"obj"``, ``"ply"`` (``"ply binary"``), ``"off"``, ``"stl"`` or ``"stl binary"``.
    face_lines : (F,) int or None
        The file line (from 1) each triangle comes from, for messages; None for binary files
        (their face or facet records are counted instead) and for OBJ read by the fast reader
        (``read_mesh_file(path, face_lines=True)`` keeps them).
    """

    vertices: np.ndarray
    faces: np.ndarray
    polygons: int
    format: str
    face_lines: np.ndarray | None = None


def read_mesh_file(path: str | Path, *, face_lines: bool = False) -> RawMesh:
    """Read OBJ, PLY, OFF or STL into a :class:`RawMesh` (the file's vertices and faces).

    ``face_lines=True`` makes the OBJ reader keep the line of every face (slower on big files;
    the other text readers always keep them).

    Raises :class:`~torsal.core.inputs.MissingInputError` (a ``FileNotFoundError``) for a
    missing file, :class:`~torsal.core.inputs.InputFileError` for a folder
    or an unreadable file and :class:`MeshError` for a file whose content is broken
    (the message names the line).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUPPORTED_FORMATS:
        raise MeshError(f"{path}: unsupported mesh format {path.suffix!r}; "
                            f"use one of {', '.join(SUPPORTED_FORMATS)}")
    data = read_input(path, "mesh file")
    if not data.strip():
        raise MeshError(f"{path}: the file is empty; export the surface again")
    reader = {".obj": _read_obj, ".ply": _read_ply, ".off": _read_off, ".stl": _read_stl}[suffix]
    try:
        return reader(data, lines=True) if suffix == ".obj" and face_lines else reader(data)
    except _LineError as exc:
        raise MeshError(f"{path}: {exc}") from None


_BOM = b"\xef\xbb\xbf"


class _LineError(Exception):
    """Internal: a message the public reader prefixes with the file name."""


def _text(data: bytes) -> str:
    """UTF-8 text (undecodable bytes replaced) without a byte-order mark (Windows exporters)."""
    return data.decode("utf-8", errors="replace").removeprefix("\ufeff")


def _text_lines(data: bytes) -> list[str]:
    return _text(data).splitlines()


def _floats(tokens, line_no: int, what: str, last: bool) -> list[float]:
    try:
        return [float(t) for t in tokens]
    except ValueError:
        comma = any("," in t for t in tokens)  # a locale's decimal comma: '1,5'
        raise _LineError(f"line {line_no}: {what} {' '.join(tokens)!r} is not numbers"
                         + (" (decimal commas? mesh files write 1.5, not 1,5: export again "
                            "with a point as the decimal mark)" if comma else "")
                         + _truncated_hint(last)) from None


def _truncated_hint(last: bool) -> str:
    return " (the file ends here: is it truncated?)" if last else ""


def _fan(polys) -> tuple[np.ndarray, int, np.ndarray]:
    """Fan-triangulate polygons (lists of >= 3 indices, or an (F, n) array) -> (T, 3) int64,
    the number of polygons with more than three corners, and the polygon of each triangle (T,)."""
    if isinstance(polys, np.ndarray):  # all polygons have n corners: vectorized
        p = polys.astype(np.int64).reshape(len(polys), -1)
        n = p.shape[1]
        if n == 3:
            return p, 0, np.arange(len(p))
        tris = np.stack([np.stack([p[:, 0], p[:, k], p[:, k + 1]], axis=1)
                         for k in range(1, n - 1)], axis=1).reshape(-1, 3)
        return tris, len(p), np.repeat(np.arange(len(p)), n - 2)
    if all(len(p) == 3 for p in polys):  # the common case, without a Python loop of lists
        return np.asarray(polys, dtype=np.int64).reshape(-1, 3), 0, np.arange(len(polys))
    tris, source, n_poly = [], [], 0
    for j, p in enumerate(polys):
        if len(p) == 3:
            tris.append(p)
            source.append(j)
        else:
            n_poly += 1
            tris.extend([p[0], p[k], p[k + 1]] for k in range(1, len(p) - 1))
            source.extend([j] * (len(p) - 2))
    return np.asarray(tris, dtype=np.int64).reshape(-1, 3), n_poly, np.asarray(source, np.int64)


# ----------------------------------------------------------------------------- OBJ
# statements that carry no triangle geometry; they are read past (free-form curves included):
# groups (g), objects (o), smoothing groups (s), materials (mtllib, usemtl) as Rhino, Blender,
# 3ds Max and SketchUp write them
_OBJ_IGNORED = {"vt", "vn", "vp", "g", "o", "s", "mg", "usemtl", "mtllib", "l", "p", "cstype",
                "deg", "bmat", "step", "curv", "curv2", "surf", "parm", "trim", "hole", "scrv",
                "sp", "end", "con", "bevel", "c_interp", "d_interp", "lod", "maplib", "usemap",
                "shadow_obj", "trace_obj", "ctech", "stech", "call", "csh"}


_OBJ_KEY = re.compile(r"^[ \t]*([^\s#]+)", re.M)
_OBJ_V = re.compile(r"^[ \t]*v[ \t]+(\S+)[ \t]+(\S+)[ \t]+(\S+)", re.M)
# a corner is v, v/vt, v//vn or v/vt/vn with whole numbers; "1.0" is not a corner
_OBJ_C = r"(\d+)(?:/\d*){0,2}"
_OBJ_TRI = re.compile(rf"^[ \t]*f[ \t]+{_OBJ_C}[ \t]+{_OBJ_C}[ \t]+{_OBJ_C}[ \t]*(?:#.*)?$", re.M)
_OBJ_CORNER = re.compile(r"(-?\d+)(?:/(?:-?\d+)?){0,2}")
_OBJ_CONTINUED = re.compile(r"\\[ \t]*$", re.M)  # a backslash ending a line (not in a Windows path)


def _read_obj(data: bytes, *, lines: bool = False) -> RawMesh:
    # one line end for the fast reader (old Mac files end lines with CR alone)
    text = _text(data)
    if "\r" in text:
        text = text.replace("\r\n", "\n").replace("\r", "\n")
    # continuation lines (a backslash at the end) go to the line reader, which keeps line numbers
    fast = None if lines or _OBJ_CONTINUED.search(text) else _obj_fast(text)
    return fast if fast is not None else _obj_lines(text)


def _obj_fast(text: str) -> RawMesh | None:
    """The common OBJ (v records, triangles with positive indices, known statements) read with
    regular expressions; None whenever anything differs, and the line reader decides."""
    keys = _OBJ_KEY.findall(text)
    if not set(keys) <= _OBJ_IGNORED | {"v", "f"}:
        return None
    v_rows, tris = _OBJ_V.findall(text), _OBJ_TRI.findall(text)
    if len(v_rows) != keys.count("v") or len(tris) != keys.count("f"):
        return None  # polygons, short records, negative indices, corners that are not integers ...
    try:
        verts = np.array(v_rows, dtype=float).reshape(-1, 3)
    except ValueError:
        return None
    faces = np.array(tris, dtype=np.int64).reshape(-1, 3) - 1
    if faces.size and (faces.min() < 0 or faces.max() >= len(verts)):
        return None
    return RawMesh(verts, faces, 0, "obj")


def _obj_statements(text: str):
    """(line number, tokens) of every statement; a line ending in a backslash continues on the
    next (Rhino's "wrap long lines"), numbered by its first line. Comments are dropped."""
    lines = text.splitlines()
    k, n = 0, len(lines)
    while k < n:
        line_no = k + 1
        body = lines[k].split("#", 1)[0].rstrip()
        while body.endswith("\\") and k + 1 < n:
            k += 1
            body = body[:-1] + " " + lines[k].split("#", 1)[0].rstrip()
        k += 1
        tokens = body.removesuffix("\\").split()
        if tokens:
            yield line_no, tokens, k == n


def _obj_corner(t: str, line_no: int, n_verts: int) -> int:
    """A face corner -> 0-based vertex index (negative: relative to the vertices so far)."""
    m = _OBJ_CORNER.fullmatch(t)
    if m is None:
        raise _LineError(f"line {line_no}: face corner {t!r} is not a vertex number; OBJ corners "
                         "are whole 1-based numbers, as 'f 1 2 3' or 'f 1/1/1 2/2/2 3/3/3': export "
                         "the mesh again as OBJ or correct the line")
    i = int(m.group(1))
    if i == 0:
        raise _LineError(f"line {line_no}: vertex index 0 (OBJ indices start at 1)")
    return i - 1 if i > 0 else n_verts + i


def _obj_lines(text: str) -> RawMesh:
    """OBJ read statement by statement: every statement checked, errors name the line."""
    verts: list[list[float]] = []
    polys: list[list[int]] = []
    poly_lines: list[int] = []
    for line_no, tokens, last in _obj_statements(text):
        key = tokens[0]
        if key == "v":
            if len(tokens) < 4:
                raise _LineError(f"line {line_no}: a vertex needs x y z, got {' '.join(tokens)!r}"
                                 + _truncated_hint(last))
            verts.append(_floats(tokens[1:4], line_no, "vertex", last))
        elif key == "f":
            if len(tokens) < 4:
                raise _LineError(f"line {line_no}: a face needs at least three corners, got "
                                 f"{' '.join(tokens)!r}" + _truncated_hint(last))
            polys.append([_obj_corner(t, line_no, len(verts)) for t in tokens[1:]])
            poly_lines.append(line_no)
        elif key not in _OBJ_IGNORED:
            raise _LineError(f"line {line_no}: {key[:20]!r} is not an OBJ statement "
                             "(is this a text OBJ file?)")
    faces, n_poly, source = _fan(polys)
    n = len(verts)
    for corners, line_no in zip(polys, poly_lines):
        if min(corners) < 0 or max(corners) >= n:
            raise _LineError(f"line {line_no}: face refers to a vertex that does not exist "
                             f"(the file has {n} vertices)")
    return RawMesh(np.asarray(verts, dtype=float).reshape(-1, 3), faces, n_poly, "obj",
                   np.asarray(poly_lines, np.int64)[source])


# ----------------------------------------------------------------------------- PLY
_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2",
              "int16": "i2", "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4",
              "uint": "u4", "uint32": "u4", "float": "f4", "float32": "f4", "double": "f8",
              "float64": "f8"}
# the face list: "vertex_indices" (Stanford, VTK, MeshLab, Open3D, trimesh), "vertex_index" (others)
_FACE_LISTS = ("vertex_indices", "vertex_index")
# 'ply' on the first line, in any case (COMPAS writes 'PLY'), with any line end
_PLY_MAGIC = re.compile(rb"[ \t]*ply[ \t]*(?:\r\n|\r|\n)", re.I)
_PLY_END = re.compile(rb"(?:^|(?<=\r))[ \t]*end_header[ \t]*(?:\r\n|\r|\n|\Z)", re.I | re.M)


@dataclass
class _PlyElement:
    name: str
    count: int
    line: int
    props: list  # (name, dtype) or (name, count_dtype, item_dtype) for lists


def _ply_header(data: bytes) -> tuple[list[_PlyElement], str, int, int]:
    """Parse the header -> elements, format, byte offset of the data, header line count.

    Keywords, type and element names are read in any case; ``comment`` and ``obj_info`` lines
    (VTK, MeshLab) are skipped."""
    if _PLY_MAGIC.match(data) is None:
        raise _LineError("line 1: not a PLY file (the first line must be 'ply')")
    m = _PLY_END.search(data)
    if m is None:
        raise _LineError("the header has no 'end_header' line (is the file truncated?)")
    header = data[:m.start()].decode("ascii", errors="replace").splitlines()
    fmt, elements = None, []
    for k, line in enumerate(header[1:], start=2):
        t = line.split()
        if not t or t[0].lower() in ("comment", "obj_info"):
            continue
        key, low = t[0].lower(), [x.lower() for x in t]
        if key == "format":
            if len(t) < 2 or low[1] not in ("ascii", "binary_little_endian", "binary_big_endian"):
                raise _LineError(f"line {k}: unknown PLY format {line.strip()!r} (ascii, "
                                 "binary_little_endian or binary_big_endian)")
            fmt = low[1]
        elif key == "element":
            if len(t) != 3 or not t[2].isdigit():
                raise _LineError(f"line {k}: expected 'element NAME COUNT', got {line.strip()!r}")
            elements.append(_PlyElement(low[1], int(t[2]), k, []))
        elif key == "property":
            if not elements:
                raise _LineError(f"line {k}: property before any element")
            if len(t) == 5 and low[1] == "list" and low[2] in _PLY_TYPES and low[3] in _PLY_TYPES:
                elements[-1].props.append((low[4], _PLY_TYPES[low[2]], _PLY_TYPES[low[3]]))
            elif len(t) == 3 and low[1] in _PLY_TYPES:
                elements[-1].props.append((low[2], _PLY_TYPES[low[1]]))
            else:
                raise _LineError(f"line {k}: cannot read property {line.strip()!r} (types: "
                                 "char uchar short ushort int uint float double, or int8 ... "
                                 "float64; lists as 'property list uchar int vertex_indices')")
        else:
            raise _LineError(f"line {k}: unknown header line {line.strip()!r}")
    if fmt is None:
        raise _LineError("the header has no 'format' line")
    return elements, fmt, m.end(), len(header) + 1


def _ply_check_elements(elements: list[_PlyElement]) -> tuple[_PlyElement, _PlyElement | None]:
    by_name = {e.name: e for e in elements}
    vertex = by_name.get("vertex")
    if vertex is None:
        raise _LineError("the header declares no 'element vertex'")
    names = [p[0] for p in vertex.props]
    if not {"x", "y", "z"} <= set(names):
        raise _LineError(f"line {vertex.line}: the vertex element has no x, y, z properties "
                         f"(has {', '.join(names) or 'none'})")
    face = by_name.get("face")
    if face is None and "tristrips" in by_name:
        raise _LineError(f"line {by_name['tristrips'].line}: the file stores triangle strips "
                         "('element tristrips'), not faces; export faces (PLY with 'element "
                         "face'), OBJ or STL")
    if face is not None:
        lists = [p for p in face.props if len(p) == 3 and p[0] in _FACE_LISTS]
        if not lists:
            raise _LineError(f"line {face.line}: the face element has no 'vertex_indices' list")
        if lists[0][2].startswith("f"):
            raise _LineError(f"line {face.line}: the face list '{lists[0][0]}' holds floating-"
                             "point numbers; vertex indices are integers (e.g. 'property list "
                             "uchar int vertex_indices'): export the mesh again")
    return vertex, face


def _read_ply(data: bytes) -> RawMesh:
    data = data.removeprefix(_BOM)
    elements, fmt, offset, n_header = _ply_header(data)
    vertex, face = _ply_check_elements(elements)
    if fmt == "ascii":
        records, lines = _ply_ascii(data[offset:], elements, n_header)
    else:
        records = _ply_binary(data, offset, elements, "<" if fmt.endswith("little_endian") else ">")
        lines = {}
    names = [p[0] for p in vertex.props]
    vv = records["vertex"]
    verts = np.stack([np.asarray(vv[names.index(a)], dtype=float) for a in "xyz"], axis=1)
    kind = "ply" if fmt == "ascii" else "ply binary"
    if face is None:
        return RawMesh(verts, np.zeros((0, 3), np.int64), 0, kind)
    k = next(i for i, p in enumerate(face.props) if len(p) == 3 and p[0] in _FACE_LISTS)
    lists = records["face"][k]
    if not isinstance(lists, np.ndarray):  # polygons of differing sizes
        polys = [np.asarray(p, dtype=np.int64) for p in lists]
        bad = [i for i, p in enumerate(polys) if len(p) < 3]
    else:
        polys, bad = lists, ([0] if lists.shape[1] < 3 and len(lists) else [])
    if bad:
        where = f"line {lines['face'][bad[0]]}: " if "face" in lines else ""
        raise _LineError(f"{where}face {bad[0]} has {len(polys[bad[0]])} corners; faces need at "
                         "least three")
    faces, n_poly, source = _fan(polys)
    if faces.size and (faces.min() < 0 or faces.max() >= len(verts)):
        bad_f = int(source[np.flatnonzero(((faces < 0) | (faces >= len(verts))).any(axis=1))[0]])
        where = f"line {lines['face'][bad_f]}: " if "face" in lines else ""
        raise _LineError(f"{where}face {bad_f} refers to a vertex that does not exist "
                         f"(the header declares {len(verts)} vertices; PLY indices start at 0)")
    face_lines = np.asarray(lines["face"], np.int64)[source] if "face" in lines else None
    return RawMesh(verts, faces, n_poly, kind, face_lines)


def _declared(e: _PlyElement) -> str:
    return f"the header (line {e.line}) declares {e.count} {e.name} records"


def _ply_ascii(body: bytes, elements: list[_PlyElement], n_header: int) -> tuple[dict, dict]:
    """ASCII PLY: one record per line; returns {element: [column per property]} and the
    line of every face record ``{"face": [...]}``."""
    lines = _text_lines(body)
    pos, out, where = 0, {}, {}
    for e in elements:
        cols: list[list] = [[] for _ in e.props]
        rec_lines: list[int] = []
        for r in range(e.count):
            while pos < len(lines) and not lines[pos].strip():
                pos += 1
            if pos >= len(lines):
                raise _LineError(f"{_declared(e)} but the file ends after {r} of them "
                                 f"(line {n_header + len(lines)}): truncated file or wrong header")
            tokens, line_no = lines[pos].split(), n_header + pos + 1
            pos += 1
            rec_lines.append(line_no)
            at = 0
            try:
                for c, p in enumerate(e.props):
                    if len(p) == 3:
                        n = int(tokens[at])
                        if n < 0 or at + 1 + n > len(tokens):
                            raise IndexError
                        cols[c].append([int(x) for x in tokens[at + 1:at + 1 + n]])
                        at += 1 + n
                    else:
                        cols[c].append(float(tokens[at]))
                        at += 1
            except (IndexError, ValueError):
                raise _LineError(f"line {line_no}: {e.name} record {r} is cut short or not numbers "
                                 f"({lines[pos - 1].strip()[:60]!r})"
                                 + (_truncated_hint(True) if pos == len(lines) else
                                    "; do the header's counts match the content?")) from None
            if at != len(tokens):
                raise _LineError(f"line {line_no}: {e.name} record {r} has {len(tokens)} values, "
                                 f"the header's properties take {at}")
        out[e.name] = [np.asarray(c) if len(p) == 2 else _same_length(c)
                       for c, p in zip(cols, e.props)]
        if e.name == "face":
            where["face"] = rec_lines
    rest = [k for k in range(pos, len(lines)) if lines[k].strip()]
    if rest:
        total = ", ".join(f"{e.count} {e.name}" for e in elements)
        raise _LineError(f"line {n_header + rest[0] + 1}: more data than the header declares "
                         f"({total} records); the header's counts are wrong")
    return out, where


def _same_length(lists: list):
    """Lists of one length as an (F, n) int64 array (vectorized later), else the lists."""
    if lists and all(len(x) == len(lists[0]) for x in lists):
        return np.asarray(lists, dtype=np.int64).reshape(len(lists), -1)
    return lists


def _ply_binary(data: bytes, offset: int, elements: list[_PlyElement], endian: str) -> dict:
    """Binary PLY; sizes are checked against the file before anything is allocated."""
    out = {}
    for e in elements:
        remaining = len(data) - offset
        if all(len(p) == 2 for p in e.props):
            dt = np.dtype([(f"p{i}", endian + p[1]) for i, p in enumerate(e.props)])
            need = e.count * dt.itemsize
            if need > remaining:
                raise _LineError(f"{_declared(e)} ({need} bytes) but only {remaining} bytes follow: "
                                 "truncated file or wrong header")
            arr = np.frombuffer(data, dt, count=e.count, offset=offset)
            offset += need
            out[e.name] = [arr[f"p{i}"] for i in range(len(e.props))]
        else:
            out[e.name], offset = _ply_binary_lists(data, offset, e, endian)
    rest = data[offset:]
    if rest.strip():
        total = ", ".join(f"{e.count} {e.name}" for e in elements)
        raise _LineError(f"{len(rest)} bytes after the records the header declares ({total}); "
                         "the header's counts are wrong")
    return out


def _ply_fixed_lists(data: bytes, offset: int, e: _PlyElement, endian: str):
    """Records whose lists all have the length of the first record's (all triangles, all
    quads; per-face colours or quality beside them, as MeshLab writes) as one structured array;
    None when the lengths differ."""
    if e.count == 0:
        return None
    fields, at, n = [], offset, []
    for i, p in enumerate(e.props):  # the first record's list lengths
        if len(p) == 3:
            if at + np.dtype(p[1]).itemsize > len(data):
                return None
            n.append(int(np.frombuffer(data, endian + p[1], count=1, offset=at)[0]))
            if n[-1] < 0:
                return None
            fields += [(f"n{i}", endian + p[1]), (f"p{i}", endian + p[2], (n[-1],))]
            at += np.dtype(p[1]).itemsize + n[-1] * np.dtype(p[2]).itemsize
        else:
            fields.append((f"p{i}", endian + p[1]))
            at += np.dtype(p[1]).itemsize
    dt = np.dtype(fields)
    if dt.itemsize == 0 or offset + e.count * dt.itemsize > len(data):
        return None
    arr = np.frombuffer(data, dt, count=e.count, offset=offset)
    lens = iter(n)
    cols = []
    for i, p in enumerate(e.props):
        if len(p) == 3:
            n_i = next(lens)
            if not np.all(arr[f"n{i}"] == n_i):
                return None
            cols.append(arr[f"p{i}"].astype(np.int64).reshape(e.count, n_i))
        else:
            cols.append(arr[f"p{i}"])
    return cols, offset + e.count * dt.itemsize


def _ply_binary_lists(data: bytes, offset: int, e: _PlyElement, endian: str):
    """Records with list properties: vectorized when every list has one length, else read
    one by one."""
    fixed = _ply_fixed_lists(data, offset, e, endian)
    if fixed is not None:
        return fixed
    cols: list[list] = [[] for _ in e.props]
    for r in range(e.count):
        for c, p in enumerate(e.props):
            try:
                if len(p) == 3:
                    size_c, size_i = np.dtype(p[1]).itemsize, np.dtype(p[2]).itemsize
                    n = int(np.frombuffer(data, endian + p[1], count=1, offset=offset)[0])
                    offset += size_c
                    if n < 0 or offset + n * size_i > len(data):
                        raise ValueError
                    cols[c].append(np.frombuffer(data, endian + p[2], count=n, offset=offset))
                    offset += n * size_i
                else:
                    cols[c].append(np.frombuffer(data, endian + p[1], count=1, offset=offset)[0])
                    offset += np.dtype(p[1]).itemsize
            except ValueError:
                raise _LineError(f"{_declared(e)} but the file ends inside record {r}: "
                                 "truncated file or wrong header") from None
    return cols, offset


# ----------------------------------------------------------------------------- OFF
# OFF, COFF (colours), NOFF (normals), STOFF (texture), in any case; 4OFF and nOFF (other
# dimensions) are named and refused
_OFF_KEY = re.compile(r"^(ST)?C?N?(4|n)?OFF$", re.I)


def _read_off(data: bytes) -> RawMesh:
    lines = _text_lines(data)
    content = [(k + 1, line.split("#", 1)[0].split()) for k, line in enumerate(lines)]
    content = [(n, t) for n, t in content if t]
    if not content:
        raise _LineError("no header: the file holds only comments")
    pos = 0
    n0, t0 = content[0]
    key = _OFF_KEY.match(t0[0])
    if key:
        if key.group(2):
            raise _LineError(f"line {n0}: {t0[0]} is an OFF file of {'4' if key.group(2) == '4' else 'n'}"
                             "-dimensional points; export the surface in 3D (OFF, OBJ or PLY)")
        if len(t0) > 1 and t0[1].upper() == "BINARY":
            raise _LineError(f"line {n0}: binary OFF is not supported; export ASCII OFF, OBJ or PLY")
        counts, count_line = t0[1:], n0
        pos = 1
        if not counts:
            if len(content) < 2:
                raise _LineError(f"line {n0}: the file ends before the counts line (is it truncated?)")
            count_line, counts = content[1]
            pos = 2
    elif t0[0][0].isdigit():
        counts, count_line, pos = t0, n0, 1  # the OFF keyword is optional
    else:
        raise _LineError(f"line {n0}: not an OFF file (the first line must be OFF, got {t0[0][:20]!r})")
    try:
        nv, nf = int(counts[0]), int(counts[1])
        if nv < 0 or nf < 0:
            raise ValueError
    except (ValueError, IndexError):
        raise _LineError(f"line {count_line}: expected 'vertices faces edges' counts, got "
                         f"{' '.join(counts)!r}") from None
    declared = f"the header (line {count_line}) declares {nv} vertices and {nf} faces"
    if len(content) - pos < nv + nf:
        have = len(content) - pos
        raise _LineError(f"{declared} but the file holds {have} records after it "
                         f"({min(have, nv)} vertices, {max(0, have - nv)} faces; last line "
                         f"{content[-1][0]}): truncated file or wrong header")
    last_line = content[-1][0]
    verts = []
    for n, t in content[pos:pos + nv]:
        if len(t) < 3:
            raise _LineError(f"line {n}: a vertex needs x y z, got {' '.join(t)!r}"
                             + _truncated_hint(n == last_line))
        verts.append(_floats(t[:3], n, "vertex", n == last_line))
    polys, poly_lines = [], []
    for n, t in content[pos + nv:pos + nv + nf]:
        try:
            k = int(t[0])
            corners = [int(x) for x in t[1:1 + k]]
        except ValueError:
            raise _LineError(f"line {n}: face {' '.join(t)[:60]!r} is not 'count i j k ...'; do the "
                             f"header's counts (line {count_line}) match the content?") from None
        if k < 3 or len(corners) != k:
            raise _LineError(f"line {n}: a face needs a corner count >= 3 and that many indices, got "
                             f"{' '.join(t)!r}" + _truncated_hint(n == last_line))
        if min(corners) < 0 or max(corners) >= nv:
            raise _LineError(f"line {n}: face refers to a vertex that does not exist "
                             f"(the header declares {nv} vertices; OFF indices start at 0)")
        polys.append(corners)
        poly_lines.append(n)
    if len(content) - pos > nv + nf:
        raise _LineError(f"line {content[pos + nv + nf][0]}: more data than the header declares "
                         f"({declared}); the header's counts are wrong")
    faces, n_poly, source = _fan(polys)
    return RawMesh(np.asarray(verts, dtype=float).reshape(-1, 3), faces, n_poly, "off",
                   np.asarray(poly_lines, np.int64)[source])


# ----------------------------------------------------------------------------- STL
def _read_stl(data: bytes) -> RawMesh:
    if len(data) >= 84:
        (count,) = struct.unpack("<I", data[80:84])
        if len(data) == 84 + 50 * count:
            return _stl_binary(data, count)
    if data.removeprefix(_BOM).lstrip()[:5].lower() == b"solid":
        return _stl_ascii(data)
    if len(data) < 84:
        raise _LineError(f"only {len(data)} bytes: too short for a binary STL (84-byte header) "
                         "and not an ASCII STL (no 'solid'): truncated file?")
    raise _LineError(f"the binary STL header declares {count} triangles ({84 + 50 * count} bytes) "
                     f"but the file has {len(data)} bytes: truncated file or wrong header")


def _stl_binary(data: bytes, count: int) -> RawMesh:
    dt = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    tri = np.frombuffer(data, dt, count=count, offset=84)
    verts = tri["v"].reshape(-1, 3).astype(float)
    return RawMesh(verts, np.arange(len(verts), dtype=np.int64).reshape(-1, 3), 0, "stl binary")


def _stl_ascii(data: bytes) -> RawMesh:
    lines = _text_lines(data)
    verts: list[list[float]] = []
    polys: list[list[int]] = []
    poly_lines: list[int] = []
    loop: list[int] | None = None
    loop_line = facet_line = 0
    in_solid = False
    for k, line in enumerate(lines):
        t, n, last = line.split(), k + 1, k + 1 == len(lines)
        if not t:
            continue
        key = t[0].lower()
        if key == "solid":
            in_solid = True
        elif key == "endsolid":
            if loop is not None:
                raise _LineError(f"line {n}: 'endsolid' inside an unfinished facet")
            in_solid = False
        elif key == "facet":
            facet_line = n
        elif key == "endfacet":
            facet_line = 0
        elif key == "outer":
            loop, loop_line = [], facet_line or n  # a facet is where its 'facet' line is
        elif key == "vertex":
            if loop is None or len(t) != 4:
                raise _LineError(f"line {n}: expected 'vertex x y z' inside 'outer loop', got "
                                 f"{line.strip()!r}" + _truncated_hint(last))
            loop.append(len(verts))
            verts.append(_floats(t[1:], n, "vertex", last))
        elif key == "endloop":
            if loop is None or len(loop) < 3:
                raise _LineError(f"line {n}: a facet needs at least three vertices")
            polys.append(loop)
            poly_lines.append(loop_line)
            loop = None
        else:
            raise _LineError(f"line {n}: {t[0][:20]!r} is not an ASCII STL keyword"
                             + _truncated_hint(last))
    if in_solid or loop is not None:
        raise _LineError(f"line {len(lines)}: the file ends inside a "
                         f"{'facet' if loop is not None else 'solid'} (no 'endsolid'): truncated file")
    faces, n_poly, source = _fan(polys)
    return RawMesh(np.asarray(verts, dtype=float).reshape(-1, 3), faces, n_poly, "stl",
                   np.asarray(poly_lines, np.int64)[source])
