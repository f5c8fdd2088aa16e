"""A generated corpus of bad and unusual inputs, each run through the command line.

Every case writes its own small files (nothing big is stored) and runs ``torsal.cli.main``
in-process; a few run the installed ``torsal`` as a subprocess to show that no traceback
reaches stderr. A bad input must exit 2 with a message naming the problem (and the line, for a
line of a file), no traceback, and no result of its own; an unusual but valid input must exit 0
with the right answer (counts and hyperbolic faces computed here independently of torsal's
readers, vertices compared with the records the file holds). A failing ``analyze`` or ``design``
runs into a folder holding a real earlier design and analysis, which must stay byte for byte.

Kinds: mesh files (truncated, lying headers, garbage, broken geometry, unusual but valid
layouts in every format, the dialects of VTK, Open3D, MeshLab, COMPAS, Rhino, Blender, slicers
and OFF writers), directions files (magnitudes, rows with positions, row order), design files
(a bad value for every key of the schema, missing and unknown keys, sun, EPW, mesh and size
problems) and command lines.
"""
from __future__ import annotations

import copy
import datetime as dt
import json
import math
import os
import re
import shutil
import struct
import subprocess
import sys
import typing
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Callable

import numpy as np
import pytest
from annotated_types import Ge, Gt, Le, Lt
from pydantic import BaseModel

import mesh_cases as mc
from torsal.cli import main
from torsal.pipeline.design_file import DesignSpec, Region
from torsal.geometry.congruence import Congruence
from torsal.light.sun import write_synthetic_epw


@dataclass
class Case:
    """One input: ``make(tmp) -> argv`` writes its files; the run must exit ``code`` with
    ``message`` (a regex) on stderr (code 2) or pass ``check(tmp, out_dir)`` (code 0)."""

    id: str
    make: Callable[[Path], list[str]]
    code: int = 2
    message: str = ""
    check: Callable[[Path], None] | None = None


CASES: list[Case] = []


def case(id, make, code=2, message="", check=None):
    CASES.append(Case(id, make, code, message, check))


# ============================================================== meshes: reference answers
GRID_V, GRID_F = mc.grid(5, 4)                                  # 20 vertices, 24 faces


def _hyperbolic(v, f) -> int:
    return int(Congruence.from_normals((np.asarray(v, float), np.asarray(f))).summary()["hyperbolic_faces"])


GRID_HYP = _hyperbolic(GRID_V, GRID_F)
GRID_HYP_F32 = _hyperbolic(GRID_V.astype(np.float32).astype(float), GRID_F)
CUBE_F = mc.quads_to_tris(mc.CUBE_QUADS)
CUBE_HYP = _hyperbolic(mc.CUBE_V, CUBE_F)
SPLIT_V, SPLIT_F = mc.split_per_face(GRID_V, GRID_F)           # 72 file vertices


def _analysis_check(vertices, faces, hyperbolic, file_vertices=None, rows=None, order=None):
    def check(out: Path):
        s = json.loads((out / "analysis.json").read_text())
        assert (s["vertices"], s["faces"], s["hyperbolic_faces"]) == (vertices, faces, hyperbolic)
        if file_vertices is not None:
            assert s["mesh_file"]["file_vertices"] == file_vertices
        if rows is not None:
            assert s["directions_rows"] == rows
            assert s["directions_row_order"]  # the order the rows were read in, in words
        if order is not None:
            assert re.search(order, s["directions_row_order"]), s["directions_row_order"]
    return check


def _write(name: str, content) -> Callable[[Path], Path]:
    def w(tmp: Path) -> Path:
        p = tmp / name
        if isinstance(content, bytes):
            p.write_bytes(content)
        else:
            p.write_bytes(content.encode())
        return p
    return w


def mesh_case(id, name, content, code=2, message="", check=None, extra=()):
    w = _write(name, content)
    case(f"mesh-{id}", lambda tmp: ["analyze", str(w(tmp)), "--no-plot", *extra], code, message, check)


# ============================================================== meshes: valid but unusual
grid_ok = _analysis_check(20, 24, GRID_HYP)
split_ok = _analysis_check(20, 24, GRID_HYP, file_vertices=72)
mesh_case("cube-per-face-normals-uv", "cube.obj",
          mc.obj_text(mc.CUBE_V, mc.CUBE_QUADS, normals="face", uv=True), 0,
          check=_analysis_check(8, 12, CUBE_HYP, file_vertices=8))
mesh_case("cube-split-per-face-stl", "cube.stl", mc.stl_binary(mc.CUBE_V, CUBE_F), 0,
          check=_analysis_check(8, 12, CUBE_HYP, file_vertices=36))
for fmt, content in {
    "obj": mc.obj_text(SPLIT_V, SPLIT_F), "ply": mc.ply_ascii(SPLIT_V, SPLIT_F),
    "plyb": mc.ply_binary(SPLIT_V, SPLIT_F), "plybe": mc.ply_binary(SPLIT_V, SPLIT_F, endian=">"),
    "off": mc.off_text(SPLIT_V, SPLIT_F), "stla": mc.stl_ascii(GRID_V, GRID_F),
}.items():
    ext = {"plyb": "ply", "plybe": "ply", "stla": "stl"}.get(fmt, fmt)
    mesh_case(f"split-per-face-{fmt}", f"split.{ext}", content, 0, check=split_ok)
mesh_case("split-per-face-stl-binary", "split.stl", mc.stl_binary(GRID_V, GRID_F), 0,
          check=_analysis_check(20, 24, GRID_HYP_F32, file_vertices=72))
mesh_case("obj-uv-seams-everywhere", "seams.obj", mc.obj_text(GRID_V, GRID_F, uv=True), 0, check=grid_ok)
mesh_case("obj-per-face-normals", "pfn.obj", mc.obj_text(GRID_V, GRID_F, normals="face"), 0, check=grid_ok)
UNUSED = [[9.0, 9.0, 9.0], [-3.0, 2.0, 1.0]]
mesh_case("obj-unused-vertices", "u.obj", mc.obj_text(GRID_V, GRID_F, unused=UNUSED), 0,
          check=_analysis_check(20, 24, GRID_HYP, file_vertices=22))
mesh_case("ply-unused-vertices", "u.ply", mc.ply_ascii(np.vstack([GRID_V, UNUSED]), GRID_F), 0,
          check=_analysis_check(20, 24, GRID_HYP, file_vertices=22))
mesh_case("off-unused-vertices", "u.off", mc.off_text(np.vstack([UNUSED, GRID_V]), GRID_F + 2), 0,
          check=_analysis_check(20, 24, GRID_HYP, file_vertices=22))
for fmt, text in {"obj": mc.obj_text(GRID_V, GRID_F), "ply": mc.ply_ascii(GRID_V, GRID_F),
                  "off": mc.off_text(GRID_V, GRID_F), "stl": mc.stl_ascii(GRID_V, GRID_F)}.items():
    ok = split_ok if fmt == "stl" else grid_ok
    mesh_case(f"crlf-{fmt}", f"crlf.{fmt}", text.replace("\n", "\r\n"), 0, check=ok)
    mesh_case(f"utf8-bom-{fmt}", f"bom.{fmt}", "\ufeff" + text, 0, check=ok)
    mesh_case(f"no-final-newline-{fmt}", f"nonl.{fmt}", text.rstrip("\n"), 0, check=ok)
    mesh_case(f"trailing-blank-lines-{fmt}", f"blank.{fmt}", text + "\n\n  \n", 0, check=ok)
mesh_case("obj-comments-groups-materials", "g.obj",
          "mtllib x.mtl\n# comment\n" + mc.obj_text(GRID_V, GRID_F).replace("o patch", "o patch\ng a b\nusemtl red\ns 1")
          + "l 1 2\n# end\n", 0, check=grid_ok)
_neg = ["v " + " ".join(map(repr, map(float, p))) for p in GRID_V]
_neg += ["f " + " ".join(str(i - len(GRID_V)) for i in face) for face in GRID_F]
mesh_case("obj-negative-indices", "neg.obj", "\n".join(_neg) + "\n", 0, check=grid_ok)
_w = ["v " + " ".join(map(repr, map(float, p))) + " 1.0" for p in GRID_V]
_w += ["f " + " ".join(str(i + 1) for i in face) for face in GRID_F]
mesh_case("obj-homogeneous-w", "w.obj", "\n".join(_w) + "\n", 0, check=grid_ok)
_col = mc.obj_text(GRID_V, GRID_F).splitlines()
_col = [ln + " 0.5 0.25 1.0" if ln.startswith("v ") else ln for ln in _col]
mesh_case("obj-rgb-after-xyz", "rgb.obj", "\n".join(_col) + "\n", 0, check=grid_ok)
_cont = mc.obj_text(GRID_V, GRID_F).replace("f 1 ", "f 1 \\\n ", 1)
mesh_case("obj-line-continuation", "cont.obj", _cont, 0, check=grid_ok)
QUADS = np.array([[i * 4 + j, (i + 1) * 4 + j, (i + 1) * 4 + j + 1, i * 4 + j + 1]
                  for i in range(4) for j in range(3)])
QUAD_T = mc.quads_to_tris(QUADS)
quad_ok = _analysis_check(20, 24, _hyperbolic(GRID_V, QUAD_T))
mesh_case("obj-quads", "q.obj", mc.obj_text(GRID_V, QUADS), 0, check=quad_ok)
mesh_case("ply-quads", "q.ply", mc.ply_ascii(GRID_V, QUADS), 0, check=quad_ok)
mesh_case("ply-binary-quads", "qb.ply", mc.ply_binary(GRID_V, QUADS), 0, check=quad_ok)
mesh_case("off-quads", "q.off", mc.off_text(GRID_V, QUADS), 0, check=quad_ok)
_extra = mc.ply_ascii(GRID_V, GRID_F).replace(
    "property float z\n", "property float z\nproperty float nx\nproperty uchar red\n").replace(
    "comment tests", "obj_info made by hand\ncomment tests")
_lines = _extra.splitlines()
_h = _lines.index("end_header")
_lines = _lines[:_h + 1] + [ln + " 0.0 200" for ln in _lines[_h + 1:_h + 1 + 20]] + _lines[_h + 21:]
mesh_case("ply-extra-vertex-properties", "x.ply", "\n".join(_lines) + "\n", 0, check=grid_ok)
_off = mc.off_text(GRID_V, GRID_F).splitlines()
mesh_case("off-counts-on-keyword-line", "k.off", "\n".join([f"OFF {len(GRID_V)} {len(GRID_F)} 0"] + _off[3:]) + "\n",
          0, check=grid_ok)
mesh_case("off-without-keyword", "nk.off", "\n".join(_off[2:]) + "\n", 0, check=grid_ok)
_coff = [("C" + ln if ln == "OFF" else ln) for ln in _off]
_coff = [ln + " 255 0 0 255" if k > 2 and k < 3 + 20 else ln for k, ln in enumerate(_coff)]
mesh_case("coff-with-colours", "c.off", "\n".join(_coff) + "\n", 0, check=grid_ok)
for scale, shift in ((1e-3, 0.0), (1e3, 0.0), (1.0, 1e5)):
    sv = SPLIT_V * scale + shift
    mesh_case(f"split-scaled-{scale:g}-shift-{shift:g}", "s.obj", mc.obj_text(sv, SPLIT_F), 0,
              check=_analysis_check(20, 24, _hyperbolic(GRID_V * scale + shift, GRID_F), file_vertices=72))
mesh_case("stl-binary-header-says-solid", "solid.stl",
          b"solid but binary".ljust(80) + mc.stl_binary(GRID_V, GRID_F)[80:], 0,
          check=_analysis_check(20, 24, GRID_HYP_F32, file_vertices=72))
mesh_case("upper-case-extension", "UP.OBJ", mc.obj_text(GRID_V, GRID_F), 0, check=grid_ok)
mesh_case("two-pieces-analyze-is-fine", "two.obj",
          mc.obj_text(np.vstack([GRID_V, GRID_V + [10, 0, 0]]), np.vstack([GRID_F, GRID_F + 20])), 0,
          check=_analysis_check(40, 48, 2 * GRID_HYP))

# ============================================================== meshes: what exporters write
# Files in the dialect of each program, written by tests/mesh_cases.py: each must load with the
# file's vertices (compared here, exactly, with the records the file holds, merged where the
# file repeats a position) and give the analysis of the surface at the file's precision.
def _file_check(name, written, faces, *, duplicates=0, trimesh_too=False):
    """The analysis of the surface the file holds, and load_mesh keeping its vertices."""
    from torsal.geometry.mesh import load_mesh

    expected_v = mc.first_occurrences(written)
    surface = _surface_of(written)
    counts = _analysis_check(len(expected_v), len(faces), _hyperbolic(surface, faces))

    def check(out: Path):
        counts(out)
        s = json.loads((out / "analysis.json").read_text())
        assert s["mesh_file"]["duplicate_faces_dropped"] == duplicates
        m = load_mesh(out.parent / name)
        assert np.array_equal(np.asarray(m.vertices), expected_v)   # the file's own numbers
        if trimesh_too:  # a second reader of the same file: trimesh
            import trimesh

            t = trimesh.load(out.parent / name, process=False, force="mesh")
            # trimesh keeps ASCII 'property float' as float32
            assert np.allclose(np.asarray(t.vertices, float), expected_v, rtol=0, atol=1e-6)
            assert len(t.faces) == len(faces)
    return check


def _surface_of(written):
    """The grid's vertices at the precision the file holds them (the grid's order)."""
    rows = mc.first_occurrences(written)
    if len(rows) == len(GRID_V):
        order = np.lexsort(rows.T[::-1])
        grid_order = np.lexsort(GRID_V.T[::-1])
        out = np.empty_like(rows)
        out[grid_order] = rows[order]  # the same lexicographic ranks as the grid's positions
        return out
    return rows


def dialect_case(id, name, data_written, faces, code=0, message="", **kw):
    data, written = data_written
    mesh_case(f"dialect-{id}", name, data, code, message,
              check=_file_check(name, written, faces, **kw) if code == 0 else None)


_COLOURS = [("uchar", "red", np.arange(20) * 12 % 256), ("uchar", "green", np.full(20, 7)),
            ("uchar", "blue", np.full(20, 200))]
_NORMALS = [("float", n, np.linspace(-1, 1, 20)) for n in ("nx", "ny", "nz")]
_FACE_RGBA = [(t, n, np.full(24, 9)) for t, n in (("uchar", "red"), ("uchar", "green"),
                                                  ("uchar", "blue"), ("uchar", "alpha"))]
PLY_DIALECTS = {
    # COMPAS' sample meshes: 'PLY', CRLF, three decimals (trimesh reads them too)
    "compas-upper-case-crlf": dict(magic="PLY", newline="\r\n", digits=3),
    "vtk-binary-float": dict(fmt="binary_little_endian", header=(
        "comment VTK generated PLY File", "obj_info vtkPolyData points and polygons: vtk4.0")),
    "vtk-binary-normals-colours": dict(fmt="binary_little_endian", vertex_props=_NORMALS + _COLOURS,
                                       header=("comment VTK generated PLY File",)),
    "vtk-ascii": dict(header=("comment VTK generated PLY File",
                              "obj_info vtkPolyData points and polygons: vtk4.0")),
    "open3d-binary-double-uint": dict(fmt="binary_little_endian", coord="double",
                                      index_type="uint", vertex_props=_NORMALS + _COLOURS,
                                      header=("comment Created by Open3D",)),
    "open3d-ascii-double": dict(coord="double", index_type="uint", vertex_props=_COLOURS,
                                header=("comment Created by Open3D",)),
    "meshlab-ascii-quality-rgba": dict(
        header=("comment VCGLIB generated",),
        vertex_props=[("float", "quality", np.linspace(0, 1, 20))] + _COLOURS
        + [("uchar", "alpha", np.full(20, 255))], face_props=_FACE_RGBA),
    "meshlab-binary-face-colours": dict(fmt="binary_little_endian", header=("comment VCGLIB generated",),
                                        face_props=_FACE_RGBA),
    "big-endian-ushort-indices": dict(fmt="binary_big_endian", count_type="uint8",
                                      index_type="uint16"),
    "vertex-index-int-counts": dict(list_name="vertex_index", count_type="int"),
    "vertex-index-binary-int-counts": dict(fmt="binary_little_endian", list_name="vertex_index",
                                           count_type="int", index_type="int32", coord="float32"),
    "keywords-upper-case": dict(magic="PLY", newline="\r\n", digits=6),
}
for id, kw in PLY_DIALECTS.items():
    data, written = mc.ply_dialect(GRID_V, GRID_F, **kw)
    if id == "keywords-upper-case":
        head, _, body = data.partition(b"end_header")
        data = head.replace(b"format ascii", b"FORMAT ASCII").replace(b"property float", b"PROPERTY FLOAT") \
            + b"END_HEADER" + body
    dialect_case(f"ply-{id}", f"{id}.ply", (data, written), GRID_F,
                 trimesh_too=id.startswith("compas"))
for fmt in ("ascii", "binary_little_endian"):  # quads with per-face colours (one vectorized block)
    dialect_case(f"ply-meshlab-quads-face-colours-{fmt}", "q.ply",
                 mc.ply_dialect(GRID_V, QUADS, fmt=fmt, face_props=[(t, n, np.full(12, 3))
                                                                    for t, n, _ in _FACE_RGBA]),
                 QUAD_T)
_MIXED = [list(q) for q in QUADS[:6]] + [list(t) for t in QUAD_T[12:]]
dialect_case("ply-binary-mixed-polygons-face-colours", "m.ply",
             mc.ply_dialect(GRID_V, _MIXED, fmt="binary_little_endian",
                            face_props=[("uchar", "red", np.full(len(_MIXED), 1))]),
             mc.quads_to_tris(QUADS[:6]).tolist() + QUAD_T[12:].tolist())
mesh_case("dialect-ply-float-face-indices", "fi.ply",
          mc.ply_dialect(GRID_V, GRID_F, index_type="float")[0], 2,
          r"line 7: the face list 'vertex_indices' holds floating-point numbers; vertex indices "
          "are integers")
mesh_case("dialect-ply-triangle-strips", "ts.ply",
          mc.ply_dialect(GRID_V, GRID_F)[0].replace(b"element face", b"element tristrips"), 2,
          r"line 7: the file stores triangle strips .* export faces")

OBJ_DIALECTS = {
    "blender": dict(app="blender"), "blender-vertex-colours": dict(app="blender", colours=True),
    "blender-two-objects": dict(app="blender", objects=2),
    "rhino-crlf": dict(app="rhino", newline="\r\n"),
    "rhino-relative-indices": dict(app="rhino", objects=3, relative=True),
    "rhino-wrapped-lines": dict(app="rhino", wrap=True, newline="\r\n"),
    "rhino-relative-wrapped": dict(app="rhino", objects=2, relative=True, wrap=True),
}
for id, kw in OBJ_DIALECTS.items():
    dialect_case(f"obj-{id}-triangles", f"{id}.obj", mc.obj_dialect(GRID_V, GRID_F, **kw), GRID_F)
    dialect_case(f"obj-{id}-quads", f"{id}q.obj", mc.obj_dialect(GRID_V, QUADS, **kw), QUAD_T)
_objf = mc.obj_text(GRID_V, GRID_F).splitlines()
_k = next(k for k, ln in enumerate(_objf) if ln.startswith("f "))
for id, corner in (("float", "1.0"), ("exponent", "1e0"), ("float-vt", "1/2.5/1"), ("hex", "0x1")):
    bad = list(_objf)
    bad[_k] = "f " + " ".join([corner] + _objf[_k].split()[2:])
    mesh_case(f"obj-non-integer-corner-{id}", "n.obj", "\n".join(bad) + "\n", 2,
              rf"line {_k + 1}: face corner '{re.escape(corner)}' is not a vertex number; OBJ "
              "corners are whole 1-based numbers")
mesh_case("obj-non-integer-all", "n.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1.0 2.0 3.0\n", 2,
          r"line 4: face corner '1.0' is not a vertex number")
_wrapped = mc.obj_dialect(GRID_V, GRID_F, app="rhino", wrap=True)[0].decode().splitlines()
_w = next(k for k, ln in enumerate(_wrapped) if ln.endswith("\\"))
_wrapped[_w + 1] = _wrapped[_w + 1].replace("/", ".5/", 1)  # a bad corner on a continued line
mesh_case("obj-bad-corner-on-continued-line", "w.obj", "\n".join(_wrapped) + "\n", 2,
          rf"line {_w + 1}: face corner '[\d.]+/[\d/]+' is not a vertex number")

# STL from slicers: every facet twice (dropped, counted), or both sides (refused)
_TWICE = np.repeat(GRID_F, 2, axis=0)
_stl32 = GRID_V.astype(np.float32).astype(float)
dialect_case("stl-every-facet-twice-binary", "twice.stl",
             (mc.stl_binary(GRID_V, _TWICE), _stl32[_TWICE.ravel()]), GRID_F, duplicates=24)
dialect_case("stl-every-facet-twice-ascii", "twice.stl",
             (mc.stl_ascii(GRID_V, np.vstack([GRID_F, GRID_F])),
              np.array([[float(f"{x:.9e}") for x in r] for r in GRID_V])[np.vstack([GRID_F, GRID_F]).ravel()]),
             GRID_F, duplicates=24)
_two_solids = mc.stl_ascii(GRID_V, GRID_F[:12]) + mc.stl_ascii(GRID_V, GRID_F[12:])
dialect_case("stl-two-solids-in-one-file", "two.stl",
             (_two_solids, np.array([[float(f"{x:.9e}") for x in r] for r in GRID_V])[GRID_F.ravel()]),
             GRID_F)
mesh_case("stl-both-sides", "both.stl", mc.stl_ascii(GRID_V, np.vstack([GRID_F, GRID_F[:, ::-1]])), 2,
          r"faces \[0, 1, 2, .* are the same triangles twice with opposite windings: the "
          r"surface lies on itself there \(both sides of it exported, or a fold\); export one side"
          r".*; file lines 2, 9, 16")
mesh_case("stl-binary-both-sides", "both.stl", mc.stl_binary(GRID_V, np.vstack([GRID_F, GRID_F[:, ::-1]])),
          2, r"opposite windings.*; facets \[0, 1, 2, .* of the file, counted from 0")
mesh_case("obj-face-written-twice", "d.obj", mc.obj_text(GRID_V, np.vstack([GRID_F, GRID_F[:3]])), 0,
          check=_file_check("d.obj", GRID_V, GRID_F, duplicates=3))

# OFF with colours, normals, comments, in any case
_offl = mc.off_text(GRID_V, GRID_F).splitlines()    # OFF, comment, counts, vertices, faces
_cols = [f"{_offl[3 + k]} {k * 10 % 256} 20 30 255" for k in range(20)]
_fcols = [f"{ln} 0.5 0.25 1.0 1.0" for ln in _offl[23:]]
OFF_DIALECTS = {
    "coff-vertex-colours-face-colours": ["COFF", "# exported with colours", _offl[2]] + _cols + _fcols,
    "noff-normals": ["NOFF", _offl[2]] + [f"{ln} 0 0 1" for ln in _offl[3:23]] + _offl[23:],
    "cnoff": ["CNOFF", _offl[2]] + [f"{ln} 0 0 1 1 0 0 1" for ln in _offl[3:23]] + _offl[23:],
    "lower-case-comments-everywhere": ["off  # keyword", "# a comment", f"{_offl[2]}  # counts"]
                                      + [f"{ln} # vertex {k}" for k, ln in enumerate(_offl[3:23])]
                                      + ["", "# faces"] + _offl[23:],
    "face-colour-indices": ["OFF", _offl[2]] + _offl[3:23] + [f"{ln} 4" for ln in _offl[23:]],
}
for id, lines in OFF_DIALECTS.items():
    dialect_case(f"off-{id}", f"{id}.off", ("\n".join(lines) + "\n", GRID_V), GRID_F)
mesh_case("off-4d", "4.off", "4OFF\n3 1 0\n0 0 0 0\n1 0 0 0\n0 1 0 0\n3 0 1 2\n", 2,
          r"line 1: 4OFF is an OFF file of 4-dimensional points")

# ============================================================== meshes: truncated
TEXTS = {"obj": mc.obj_text(GRID_V, GRID_F), "ply": mc.ply_ascii(GRID_V, GRID_F),
         "off": mc.off_text(GRID_V, GRID_F), "stl": mc.stl_ascii(GRID_V, GRID_F)}
for fmt, text in TEXTS.items():
    lines = text.splitlines(keepends=True)
    data_lines = [k for k, ln in enumerate(lines)
                  if re.match(r"\s*(v |f |vertex |-?\d)", ln) and len(ln.split()) >= 3][1:]
    for j in np.linspace(0, len(data_lines) - 1, 9).astype(int):
        k = data_lines[j]
        ln = lines[k]
        first = len(ln) - len(ln.lstrip())
        cut = ln.index(" ", first) + 1            # keep only the first token of the line
        mesh_case(f"truncated-{fmt}-line{k + 1}", f"t.{fmt}", "".join(lines[:k]) + ln[:cut], 2,
                  r"truncat" + (rf".*|line {k + 1}" if fmt == "obj" else ""))
for fmt, data in {"ply": mc.ply_binary(GRID_V, GRID_F), "stl": mc.stl_binary(GRID_V, GRID_F)}.items():
    for cut in (1, 7, 13, 50, 333, len(data) // 2, len(data) - 90):
        mesh_case(f"truncated-binary-{fmt}-minus{cut}", f"tb.{fmt}", data[:len(data) - cut], 2, "truncated")

# ============================================================== meshes: headers that lie
NV, NF = len(GRID_V), len(GRID_F)
for element in ("vertex", "face"):
    n_true = NV if element == "vertex" else NF
    for n in (0, n_true - 1, n_true + 1, 100_000_000):
        kw = {"n_vertex" if element == "vertex" else "n_face": n}
        mesh_case(f"ply-header-{element}-{n}", "h.ply", mc.ply_ascii(GRID_V, GRID_F, **kw), 2, "header")
        mesh_case(f"ply-binary-header-{element}-{n}", "hb.ply", mc.ply_binary(GRID_V, GRID_F, **kw), 2,
                  "header|corners")
        mesh_case(f"off-header-{element}-{n}", "h.off", mc.off_text(GRID_V, GRID_F, **kw), 2, "header")
for n in (0, NF - 1, NF + 1, 100_000_000):
    mesh_case(f"stl-binary-count-{n}", "h.stl", mc.stl_binary(GRID_V, GRID_F, count=n), 2,
              f"header declares {n} triangles")

# ============================================================== meshes: not meshes
rng = np.random.default_rng(18)
GARBAGE_MSG = {"obj": "OBJ statement|vertex needs|face", "ply": "not a PLY file",
               "off": "not an OFF file|counts", "stl": "header declares|ASCII STL|too short"}
for seed in range(5):
    blob = rng.integers(0, 256, 1500 + 37 * seed, dtype=np.uint8).tobytes()
    for fmt, msg in GARBAGE_MSG.items():
        mesh_case(f"random-bytes-{seed}-{fmt}", f"r.{fmt}", blob, 2, msg)
for name, text in {"html": "<html><body>not a mesh</body></html>\n", "json": '{"vertices": []}\n',
                   "toml": "[surface]\nmesh = 'x.obj'\n", "words": "hello world\n"}.items():
    for fmt, msg in GARBAGE_MSG.items():
        mesh_case(f"text-{name}-{fmt}", f"w.{fmt}", text, 2,
                  msg + "|no triangle faces|end_header|solid")
for fmt in ("obj", "ply", "off", "stl"):
    mesh_case(f"empty-{fmt}", f"e.{fmt}", "", 2, "empty")
    mesh_case(f"whitespace-{fmt}", f"ws.{fmt}", " \n\t\n", 2, "empty")
mesh_case("obj-only-comments", "c.obj", "# nothing\n# here\n", 2, "no triangle faces")
mesh_case("off-only-comments", "c.off", "# nothing\n", 2, "only comments")
mesh_case("ply-no-end-header", "n.ply", "ply\nformat ascii 1.0\nelement vertex 3\n", 2, "end_header")
mesh_case("ply-no-format", "n.ply", "ply\nelement vertex 0\nend_header\n", 2, "format")
mesh_case("ply-no-xyz", "n.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float a\nend_header\n1\n",
          2, "no x, y, z")
mesh_case("ply-unknown-type", "n.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty float128 x\nend_header\n",
          2, "cannot read property")
mesh_case("off-binary", "b.off", "OFF BINARY\n", 2, "binary OFF is not supported")
mesh_case("stl-ascii-no-endsolid", "n.stl", mc.stl_ascii(GRID_V, GRID_F).replace("endsolid patch\n", ""),
          2, "no 'endsolid'")
for ext in ("dwg", "3ds", "fbx", "gltf", "txt"):
    mesh_case(f"unsupported-{ext}", f"m.{ext}", mc.obj_text(GRID_V, GRID_F), 2, "unsupported mesh format")
case("mesh-is-a-folder", lambda tmp: (tmp / "m.obj").mkdir() or ["analyze", str(tmp / "m.obj")], 2,
     "is a folder")
case("mesh-missing", lambda tmp: ["analyze", str(tmp / "nope.obj")], 2, "not found")
case("mesh-dangling-symlink", lambda tmp: os.symlink(tmp / "gone.obj", tmp / "l.obj") or
     ["analyze", str(tmp / "l.obj")], 2, "not found")

# ============================================================== meshes: broken geometry
TRI_V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.2]], float)
TRI_F = np.array([[0, 1, 2], [1, 3, 2]])
BROKEN = {
    "nan-vertex": (np.vstack([TRI_V[:3], [[np.nan, 1, 0]]]), TRI_F, "NaN"),
    "inf-vertex": (np.vstack([TRI_V[:3], [[np.inf, 1, 0]]]), TRI_F, "infinite"),
    "index-out-of-range": (TRI_V, np.array([[0, 1, 2], [1, 7, 2]]), "does not exist"),
    "repeated-vertex": (TRI_V, np.array([[0, 1, 2], [1, 1, 2]]), "same vertex twice"),
    "zero-area": (np.vstack([TRI_V, [[2, 0, 0]]]), np.array([[0, 1, 4], [0, 1, 2]]), "zero area"),
    "non-manifold": (np.vstack([TRI_V, [[0.5, 0.5, 1], [0.5, 0.5, -1]]]),
                     np.array([[0, 1, 2], [1, 0, 4], [0, 1, 5]]), "non-manifold"),
    "flipped-face": (TRI_V, np.array([[0, 1, 2], [2, 3, 1]]), "inconsistent orientation"),
    "face-twice-both-windings": (TRI_V, np.array([[0, 1, 2], [2, 1, 0]]), "opposite windings"),
    "merge-makes-degenerate": (np.vstack([TRI_V, [[1, 0, 0]]]), np.array([[0, 1, 2], [1, 3, 4]]),
                               "same vertex twice.*after merging"),
}
for kind, (v, f, msg) in BROKEN.items():
    for fmt in ("obj", "ply", "off"):
        if kind == "index-out-of-range" and fmt == "obj":
            content = mc.obj_text(v, f)
        else:
            content = {"obj": mc.obj_text, "ply": mc.ply_ascii, "off": mc.off_text}[fmt](v, f)
        mesh_case(f"{kind}-{fmt}", f"b.{fmt}", content, 2, msg)
for fmt in ("obj", "ply", "off"):
    _twice = np.array([[0, 1, 2], [1, 3, 2], [0, 1, 2]])
    mesh_case(f"face-twice-one-winding-{fmt}", f"t.{fmt}",
              {"obj": mc.obj_text, "ply": mc.ply_ascii, "off": mc.off_text}[fmt](TRI_V, _twice), 0,
              check=_analysis_check(4, 2, _hyperbolic(TRI_V, TRI_F)))
mesh_case("stl-nan", "n.stl", mc.stl_binary(TRI_V, TRI_F)[:84 + 12] + struct.pack("<f", math.nan)
          + mc.stl_binary(TRI_V, TRI_F)[84 + 16:], 2, "NaN")
mesh_case("stl-zero-area", "z.stl", mc.stl_binary(np.vstack([TRI_V, [[2, 0, 0]]]), np.array([[0, 1, 4], [0, 1, 2]])),
          2, "zero area")
mesh_case("obj-index-zero", "z.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 2, "index 0")
mesh_case("obj-face-two-corners", "z.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\nf 1 2 3\n", 2, "at least three")
mesh_case("obj-face-letters", "z.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf a b c\n", 2,
          "line 4: face corner 'a' is not a vertex number")
mesh_case("obj-vertex-letters", "z.obj", "v 0 zero 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", 2, "not numbers")
mesh_case("obj-points-only", "p.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", 2, "no triangle faces")
mesh_case("obj-lines-only", "l.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n", 2, "no triangle faces")
mesh_case("ply-two-corner-face", "t.ply", mc.ply_ascii(TRI_V, [[0, 1, 2], [1, 3]]), 2, "corners")
mesh_case("off-two-corner-face", "t.off", mc.off_text(TRI_V, [[0, 1, 2], [1, 3]]), 2, "corner count")
mesh_case("off-negative-index", "t.off", mc.off_text(TRI_V, [[0, 1, 2], [1, -3, 2]]), 2, "does not exist")

# ============================================================== directions files
SPLIT_OBJ = _write("split.obj", mc.obj_text(SPLIT_V, SPLIT_F))
PLAIN_OBJ = _write("plain.obj", mc.obj_text(GRID_V, GRID_F))
D20 = np.c_[0.1 * GRID_V[:, 0], 0.05 * GRID_V[:, 1] - 0.2, np.ones(20)]   # one per merged vertex
_first = np.sort(np.unique(GRID_F.ravel(), return_index=True)[1])
D20_SPLIT_ORDER = D20[GRID_F.ravel()[_first]]  # merged vertices of the split file: first-seen order
D72 = D20[GRID_F.ravel()]                                                  # one per file vertex


def _dir_hyp(v, f, d):
    return int(Congruence(v, f, d).summary()["hyperbolic_faces"])


_split_mv = GRID_V[GRID_F.ravel()[_first]]
_order = GRID_F.ravel()[_first]
_inv = np.empty(20, int)
_inv[_order] = np.arange(20)
SPLIT_MF = _inv[GRID_F]


def directions_case(id, mesh_writer, rows_writer, code=2, message="", check=None):
    def make(tmp):
        return ["analyze", str(mesh_writer(tmp)), "--directions", str(rows_writer(tmp)), "--no-plot"]
    case(f"directions-{id}", make, code, message, check)


def _txt(name, arr, **kw):
    def w(tmp):
        np.savetxt(tmp / name, arr, **kw)
        return tmp / name
    return w


def _npy(name, arr):
    def w(tmp):
        np.save(tmp / name, arr, allow_pickle=True)
        return tmp / name
    return w


HYP_D = _dir_hyp(_split_mv, SPLIT_MF, D20_SPLIT_ORDER)
directions_case("per-file-vertex", SPLIT_OBJ, _txt("d.txt", D72), 0,
                check=_analysis_check(20, 24, HYP_D, rows="one per file vertex"))
directions_case("per-merged-vertex", SPLIT_OBJ, _txt("d.txt", D20_SPLIT_ORDER), 0,
                check=_analysis_check(20, 24, HYP_D, rows="one per merged vertex"))
directions_case("per-vertex-plain", PLAIN_OBJ, _txt("d.txt", D20), 0,
                check=_analysis_check(20, 24, _dir_hyp(GRID_V, GRID_F, D20), rows="one per vertex"))
SPLIT_STL = _write("split.stl", mc.stl_ascii(GRID_V, GRID_F))
directions_case("stl-per-corner", SPLIT_STL, _txt("d.txt", D72), 0,
                check=_analysis_check(20, 24, HYP_D, rows="one per file vertex"))
directions_case("utf8-bom", PLAIN_OBJ, _write("d.txt", "\ufeff" + "\n".join(" ".join(repr(float(x)) for x in r) for r in D20)),
                0, check=_analysis_check(20, 24, _dir_hyp(GRID_V, GRID_F, D20), rows="one per vertex"))
directions_case("csv", PLAIN_OBJ, _txt("d.csv", D20, delimiter=","), 0,
                check=_analysis_check(20, 24, _dir_hyp(GRID_V, GRID_F, D20), rows="one per vertex"))
directions_case("npy-per-file-vertex", SPLIT_OBJ, _npy("d.npy", D72), 0,
                check=_analysis_check(20, 24, HYP_D, rows="one per file vertex"))
directions_case("comments", PLAIN_OBJ, _txt("d.txt", D20, header="x y z", comments="# "), 0,
                check=_analysis_check(20, 24, _dir_hyp(GRID_V, GRID_F, D20), rows="one per vertex"))
_dis = D72.copy()
_dis[40] += [0.3, 0, 0]
directions_case("per-file-rows-disagree", SPLIT_OBJ, _txt("d.txt", _dis), 2, "belong to file vertices at the same")
for n in (0 + 5, 19, 21, 71, 73):
    directions_case(f"rows-{n}", SPLIT_OBJ, _txt("d.txt", np.ones((n, 3))), 2,
                    rf"{n} rows, but the mesh has 20 vertices \(72 in the file")
for n in (5, 19, 21):
    directions_case(f"plain-rows-{n}", PLAIN_OBJ, _txt("d.txt", np.ones((n, 3))), 2,
                    rf"{n} rows, but the mesh has 20 vertices; give one row per vertex")
for cols in (1, 2, 4):
    directions_case(f"columns-{cols}", PLAIN_OBJ, _txt("d.txt", np.ones((20, cols))), 2, "rows of 3 numbers|x y z")
_nan = D20.copy()
_nan[3, 1] = np.nan
directions_case("nan", PLAIN_OBJ, _txt("d.txt", _nan), 2, r"rows \[3\] \(line 4\) have NaN")
_inf = D20.copy()
_inf[7, 0] = np.inf
directions_case("inf", PLAIN_OBJ, _txt("d.txt", _inf), 2, r"rows \[7\] \(line 8\) have NaN or infinite")
_zero = D20.copy()
_zero[11] = 0
directions_case("zero-row", PLAIN_OBJ, _txt("d.txt", _zero), 2, r"rows \[11\] \(line 12\) have zero length")
directions_case("empty", PLAIN_OBJ, _write("d.txt", ""), 2, "d.txt: no rows; expected one 'dx dy dz' row")
directions_case("garbage-text", PLAIN_OBJ, _write("d.txt", "north east up\n" * 20), 2,
                "line 1: 'north east up' is not numbers; each row is 'dx dy dz'")
directions_case("header-row", PLAIN_OBJ, _write("d.csv", "x,y,z\n" + "0,0,1\n" * 20), 2,
                "line 1: 'x,y,z' is not numbers.*put a header behind '#'")
directions_case("binary-garbage", PLAIN_OBJ, _write("d.txt", bytes(range(256)) * 3), 2, "line 1: .* is not numbers")
directions_case("npy-1d", PLAIN_OBJ, _npy("d.npy", np.ones(20)), 2, "rows of 3 numbers")
directions_case("npy-object", PLAIN_OBJ, _npy("d.npy", np.array([{"a": 1}] * 20, dtype=object)), 2,
                "could not read directions")
directions_case("npy-garbage", PLAIN_OBJ, _write("d.npy", b"\x93NUMPY garbage" * 10), 2, "could not read directions")
directions_case("npy-strings", PLAIN_OBJ, _npy("d.npy", np.array([["a", "b", "c"]] * 20)), 2, "rows of 3 numbers")
# magnitudes: overflow is not zero, underflow is short, both named with their line
_huge = D20.copy()
_huge[5] = [1e300, 0.0, 1e300]
directions_case("huge-row", PLAIN_OBJ, _txt("d.txt", _huge, header="dx dy dz", comments="# "), 2,
                r"rows \[5\] \(line 7\) have values up to 1e\+300: beyond 1e\+30 their squares "
                r"overflow \(they are not zero\)")
_tiny = D20.copy()
_tiny[2] = [1e-300, 0.0, 1e-300]
directions_case("tiny-row", PLAIN_OBJ, _txt("d.txt", _tiny), 2,
                r"rows \[2\] \(line 3\) are zero to working precision \(length 1.41e-300")
directions_case("columns-change", PLAIN_OBJ, _write("d.txt", "0 0 1\n1 1 0 0 0 1\n"), 2,
                r"line 2: 6 numbers, rows have 3, as the rows before it")
# rows with positions: matched to the vertex at x y z, in any order, for any file
D20_HYP = _dir_hyp(GRID_V, GRID_F, D20)
_perm = np.random.default_rng(7).permutation(20)
P20 = np.c_[GRID_V, D20][_perm]
for mesh_id, writer in (("stl", SPLIT_STL), ("obj", PLAIN_OBJ), ("split-obj", SPLIT_OBJ)):
    directions_case(f"positions-{mesh_id}", writer, _txt("d.txt", P20), 0,
                    check=_analysis_check(20, 24, D20_HYP, rows="one per position"))
directions_case("positions-per-corner-stl", SPLIT_STL, _txt("d.csv", np.c_[GRID_V, D20][GRID_F.ravel()],
                                                              delimiter=","), 0,
                check=_analysis_check(20, 24, D20_HYP, rows="one per position"))
_off = P20.copy()
_off[4, :3] += [0.2, 0.0, 0.0]
directions_case("positions-not-on-the-mesh", PLAIN_OBJ, _txt("d.txt", _off), 2,
                r"rows \[4\] \(line 5\) name points that are no vertex of the mesh")
directions_case("positions-a-vertex-missing", PLAIN_OBJ, _txt("d.txt", P20[1:]), 2,
                rf"mesh vertices \[{_perm[0]}\] have no row; give one direction per vertex position")
_two = np.vstack([P20, P20[:1] * [1, 1, 1, 1, 1, -1]])
directions_case("positions-disagree", PLAIN_OBJ, _txt("d.txt", _two), 2,
                rf"rows 0 and 20 belong to one vertex \(mesh vertex {_perm[0]}\) but differ")
# 20 plain rows for an STL: the merged order is torsal's, not the file's (STL has none), so
# they are refused, pointing to the rows with positions (P20 above: the same 20 directions in
# any order, read with the STL as with the OBJ) and to one row per facet corner
directions_case("stl-rows-per-merged-vertex-refused", SPLIT_STL, _txt("d.txt", D20), 2,
                r"d.txt: 20 rows 'dx dy dz', one per vertex, for an STL mesh: an STL file has no "
                r"vertex order of its own .*Give rows 'x y z dx dy dz' .*one 'dx dy dz' row per "
                r"facet corner \(72 rows")
directions_case("stl-binary-rows-per-merged-vertex-refused",
                _write("split-b.stl", mc.stl_binary(GRID_V, GRID_F)), _txt("d.txt", D20), 2,
                r"for an STL mesh: an STL file has no vertex order.*'x y z dx dy dz'")
case("directions-folder", lambda tmp: (tmp / "d").mkdir() or
     ["analyze", str(PLAIN_OBJ(tmp)), "--directions", str(tmp / "d")], 2, r"directions file .*d is a folder")
case("directions-missing", lambda tmp: ["analyze", str(PLAIN_OBJ(tmp)), "--directions", str(tmp / "no.txt")], 2,
     "directions file not found")

# ============================================================== design files
FULL = {
    "name": "corpus [test]", "units": "m",
    "surface": {"generator": "facade_patch", "params": {"nu": 5, "nv": 5}},
    "site": {"latitude": 48.2, "longitude": 16.4, "timezone": "Europe/Vienna", "elevation": 10.0,
             "north_angle": 0.0},
    "sun": {"vectors": [[0.3, -0.8, 0.5]], "hours": [13.0, 17.0], "step": "1h", "months": [6, 7],
            "min_temperature": 26.0, "min_dni": 300.0},
    "goals": {"block": True, "let_through": {"x": [0.0, 1.0]},
              "see_through": [{"target": [0.0, -5.0, 1.0], "region": {"x": [0.0, 1.0]}}],
              "reflect": {"target": [0.0, -5.0, 3.0], "region": {"z": [0.0, 1.0]}},
              "strokes": [{"points": [[0.0, 0.0, 0.0], [1.0, 0.0, 1.0]], "width": 0.5}],
              "boundary_aligned": False,
              "sun_regions": [{"region": {"y": [0.0, 1.0], "vertices": [0, 1], "faces": [0]},
                               "vectors": [[0.0, -1.0, 1.0]]}]},
    "weights": {k: 1.0 for k in ("norm", "fair", "fair_torsal", "perp", "par", "plane", "dir",
                                 "through", "closeness")},
    "constraints": {"hyperbolic": True, "hyperbolic_margin": 0.0, "min_torsal_angle": 10.0,
                    "max_iter": 50, "jit": False},
    "fins": {"spacing": 1.0, "depth": 0.5, "optimize": True, "planarity_tol": 1e-4,
             "developable_levels": 0},
    "material": {"name": "steel", "thickness_mm": 3.0, "density": 7850.0,
                 "sheet_mm": [2500.0, 1250.0], "gap_mm": 5.0, "clearance_mm": 0.5,
                 "family_split": "egg-crate"},
    "outputs": {"step": False, "rhino_3dm": False, "dxf": True, "bom": True, "renders": True,
                "light_samples": 100},
    "substructure": {"offset": 0.3, "weight": 200.0, "depth": 0.15},
    "costs": {"currency": "EUR", "material_per_kg": 6.5, "cut_per_m": {"laser": 1.2},
              "per_pierce": 0.05, "per_bend": 0.8, "fasteners": {"bolt": 0.35, "anchor": 2.5},
              "per_minute": 1.0, "minutes_per_part": 3.0, "minutes_per_fastener": 1.0,
              "minutes_per_hole_drilled": 0.5},
    "annual": {"enabled": False, "points": 100, "ambient_bounces": 1},
    "room": {"depth": 6.0, "height": 3.0, "storey_height": 3.5, "sill": 0.9, "head": 2.7,
             "reflectance": [0.2, 0.5, 0.7], "transmittance": 0.6, "shade_transmittance": 0.05,
             "occupied_hours": [8.0, 18.0], "ambient_bounces": 2, "ambient_divisions": 512},
}
#: keys whose tables are maps of the user's names (not keys of the schema)
MAPS = ("params", "cut_per_m", "fasteners")
DATES = {"start": "2026-06-01", "end": "2026-06-30"}


def toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(v)


def _strip(tp):
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if origin in (typing.Union, getattr(__import__("types"), "UnionType")):
        inner = [a for a in args if a is not type(None)]
        return _strip(inner[0]) if len(inner) == 1 else inner[0]
    return tp


def bad_values(field) -> list:
    """Values that break a field's type or bounds."""
    tp = _strip(field.annotation)
    origin = typing.get_origin(tp)
    out: list = []
    if tp is bool:
        out = ["maybe", 2]
    elif tp is int:
        out = [1.5, "many"]
    elif tp is float:
        out = ["abc", math.nan, math.inf]
    elif tp is str:
        out = [[1, 2]]
    elif origin is typing.Literal or (isinstance(tp, type) and issubclass(tp, Enum)):
        out = ["bogus"]
    elif tp is Path:
        out = [5]
    elif tp is dt.date:
        out = ["2026-13-45"]
    elif origin is tuple:
        out = ["x", [1.0]]
    elif origin in (list, dict):
        out = ["x"]
    elif isinstance(tp, type) and issubclass(tp, BaseModel):
        out = ["x"]
    for m in field.metadata:
        if isinstance(m, Gt):
            out += [m.gt, m.gt - 1]
        elif isinstance(m, Ge):
            out += [m.ge - 1]
        elif isinstance(m, Lt):
            out += [m.lt]
        elif isinstance(m, Le):
            out += [m.le + 1]
    return out


def leaves(model, data, path=()):
    """(path, field) for every key present in ``data`` (a valid design), tables included."""
    for name, field in model.model_fields.items():
        if name not in data:
            continue
        p = path + (name,)
        yield p, field
        sub = _strip(field.annotation)
        origin = typing.get_origin(sub)
        if origin is list and typing.get_args(sub) and isinstance(typing.get_args(sub)[0], type) \
                and issubclass(typing.get_args(sub)[0], BaseModel):
            yield from leaves(typing.get_args(sub)[0], data[name][0], p + (0,))
        elif isinstance(sub, type) and issubclass(sub, BaseModel):
            yield from leaves(sub, data[name], p)


def _set(d, path, value):
    for k in path[:-1]:
        d = d[k]
    d[path[-1]] = value


def _delete(d, path):
    for k in path[:-1]:
        d = d[k]
    del d[path[-1]]


def design_text(data: dict) -> str:
    out = []
    top = {k: v for k, v in data.items() if not isinstance(v, dict)}
    out += [f"{k} = {toml_value(v)}" for k, v in top.items()]
    for k, v in data.items():
        if isinstance(v, dict):
            out.append(f"[{k}]")
            out += [f"{a} = {toml_value(b)}" for a, b in v.items()]
    return "\n".join(out) + "\n"


def design_case(id, data_or_text, message, code=2, extra=(), files=None):
    def make(tmp):
        if files:
            files(tmp)
        p = tmp / "d.toml"
        p.write_text(data_or_text if isinstance(data_or_text, str) else design_text(data_or_text))
        return ["design", str(p), "--out", str(tmp / "out"), *extra]
    case(f"design-{id}", make, code, message)


def _key(path) -> str:
    return ".".join(str(p) for p in path)


for path, field in list(leaves(DesignSpec, FULL)):
    for k, bad in enumerate(bad_values(field)):
        data = copy.deepcopy(FULL)
        _set(data, path, bad)
        design_case(f"bad-{_key(path)}-{k}", data, re.escape(_key(path)) + r"\b.*")
    if field.is_required():
        data = copy.deepcopy(FULL)
        _delete(data, path)
        design_case(f"missing-{_key(path)}", data, re.escape(_key(path)) + ": missing")


def _tables(data, path=()):
    for k, v in data.items():
        if isinstance(v, dict) and k not in MAPS:
            yield path + (k,)
            yield from _tables(v, path + (k,))
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            yield path + (k, 0)
            yield from _tables(v[0], path + (k, 0))


for table in [()] + list(_tables(FULL)):
    data = copy.deepcopy(FULL)
    node = data
    for k in table:
        node = node[k]
    node["colour"] = 1
    design_case(f"unknown-key-in-{_key(table) or 'top'}", data,
                re.escape(_key(table + ("colour",))) + ": unknown key")

_dates = copy.deepcopy(FULL)
del _dates["sun"]["vectors"]
_dates["sun"].update(DATES)
SUN_CASES = {
    "vectors-empty": ({"vectors": []}, "sun.vectors: the list of sun vectors is empty"),
    "vectors-zero": ({"vectors": [[0, 0, 0]]}, r"sun.vectors: sun vectors \[0\] have zero length"),
    "vectors-one-zero": ({"vectors": [[0, -1, 1], [0.0, 0.0, 0.0]]}, r"sun vectors \[1\] have zero length"),
    "vectors-short": ({"vectors": [[0, 1]]}, "sun.vectors.0"),
    "vectors-below-horizon": ({"vectors": [[0, 0, -1]]}, r"sun vectors \[0\] point below the horizon"),
    "vectors-light-direction": ({"vectors": [[0, 0.5, 1], [-0.3, 0.8, -0.5]]},
                                r"sun vectors \[1\] point below the horizon"),
    "step-0h": ({**DATES, "step": "0h"}, "sun.step = '0h' must be at least 1min"),
    "step-negative": ({**DATES, "step": "-1h"}, "sun.step = '-1h' must be at least 1min"),
    "step-seconds": ({**DATES, "step": "1s"}, "sun.step = '1s' must be at least 1min"),
    "step-words": ({**DATES, "step": "hourly"}, "sun.step = 'hourly' is not a time step"),
    "step-empty": ({**DATES, "step": ""}, "sun.step = '' is not a time step"),
    "hours-reversed": ({**DATES, "hours": [17, 13]}, r"sun.hours = \[17.0, 13.0\] must be \[h0, h1\]"),
    "hours-25": ({**DATES, "hours": [13, 25]}, r"sun.hours = \[13.0, 25.0\]"),
    "hours-negative": ({**DATES, "hours": [-1, 5]}, r"sun.hours = \[-1.0, 5.0\]"),
    "start-after-end": ({"start": "2026-07-01", "end": "2026-06-01"}, "start <= end"),
    "only-start": ({"start": "2026-07-01"}, "sun.start and sun.end must both be dates"),
    "months-13": ({**DATES, "months": [13]}, "sun.months must be numbers 1..12"),
    "two-sources": ({**DATES, "vectors": [[0, 0, 1]]}, "give exactly one of"),
    "no-source": ({}, "give exactly one of"),
}
for id, (sun, msg) in SUN_CASES.items():
    data = copy.deepcopy(FULL)
    data["sun"] = sun
    design_case(f"sun-{id}", data, msg)
_sr_below = copy.deepcopy(FULL)
_sr_below["goals"]["sun_regions"][0]["vectors"] = [[0.0, 1.0, -1.0]]
design_case("sun-regions-vectors-below-horizon", _sr_below,
            r"goals.sun_regions.0.vectors: sun vectors \[0\] point below the horizon")
for goal, region, msg in (("let_through", {"x": [100.0, 200.0]}, "goals.let_through = .* contains no vertex"),
                          ("reflect", {"target": [0.0, -5.0, 3.0], "region": {"z": [50.0, 60.0]}},
                           "goals.reflect.region contains no face"),
                          ("see_through", [{"target": [0.0, -5.0, 1.0], "region": {"y": [50.0, 60.0]}}],
                           r"goals.see_through\[0\].region contains no vertex")):
    data = copy.deepcopy(FULL)
    data["goals"] = {goal: region}
    design_case(f"goal-{goal}-matches-nothing", data, "stage 'congruence' failed: " + msg)
_nosite = copy.deepcopy(_dates)
del _nosite["site"]
design_case("dates-without-site", _nosite, r"a \[site\] .* is needed")


def _epw_files(kind):
    def make(tmp):
        p = tmp / "w.epw"
        if kind == "empty":
            p.write_text("")
        elif kind == "garbage":
            p.write_text("hello,world\n1,2,3\n")
        elif kind == "binary":
            p.write_bytes(bytes(range(256)) * 8)
        elif kind == "folder":
            p.mkdir()
        else:
            write_synthetic_epw(p, 48.2, 16.4, tz_hours=1)
            lines = p.read_text().splitlines()
            if kind == "header-only":
                lines = lines[:8]
            elif kind == "truncated":
                lines = lines[:500] + [lines[500][:25]]
            elif kind == "bad-location":
                lines[0] = "LOCATION,Here,-,-,-,0,north,east,1,100"
            elif kind == "latitude-200":
                lines[0] = "LOCATION,Here,-,-,-,0,200,16,1,100"
            elif kind == "sub-hourly":
                lines[7] = "DATA PERIODS,1,4,Data,Sunday, 1/ 1,12/31"
            elif kind == "text-in-temperature":
                f = lines[100].split(",")
                f[6] = "hot"
                lines[100] = ",".join(f)
            p.write_text("\n".join(lines) + "\n")
    return make


EPW_CASES = {"empty": "not an EPW weather file.*empty", "garbage": "not an EPW weather file",
             "binary": "not an EPW weather file", "header-only": "no hourly data rows",
             "truncated": "line 501: .*truncated", "bad-location": "line 1: latitude",
             "latitude-200": "out of range", "text-in-temperature": "line 101: temperature 'hot'",
             "sub-hourly": "line 8: 4 records per hour; torsal reads hourly EPW files",
             "folder": "is a folder"}
for kind, msg in EPW_CASES.items():
    data = copy.deepcopy(FULL)
    data["sun"] = {"epw": "w.epw"}
    design_case(f"epw-{kind}", data, (r"stage 'sun' failed: sun.epw = .*" if kind != "folder" else "")
                + msg, files=_epw_files(kind))
_missing_epw = copy.deepcopy(FULL)
_missing_epw["sun"] = {"epw": "none.epw"}
design_case("epw-missing", _missing_epw, "sun.epw: file not found")


def _mesh_file(name, content):
    def make(tmp):
        if content is None:
            (tmp / name).mkdir()
        else:
            (tmp / name).write_bytes(content if isinstance(content, bytes) else content.encode())
    return make


MESH_DESIGNS = {
    "one-triangle": ("t.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
                     "stage 'surface' failed: surface.mesh = .*1 face.*at least two triangles"),
    "two-pieces": ("p.obj", mc.obj_text(np.vstack([GRID_V, GRID_V + [10, 0, 0]]),
                                        np.vstack([GRID_F, GRID_F + 20])),
                   "surface.mesh = .*in 2 pieces"),
    "truncated": ("c.obj", mc.obj_text(GRID_V, GRID_F)[:-4], "surface.mesh = .*truncated"),
    "lying-header": ("h.ply", mc.ply_ascii(GRID_V, GRID_F, n_face=100_000_000),
                     "surface.mesh = .*declares 100000000 face"),
    "folder": ("m.obj", None, "is a folder"),
    "flipped": ("f.obj", mc.obj_text(TRI_V, np.array([[0, 1, 2], [2, 3, 1]])), "inconsistent orientation"),
}
for id, (name, content, msg) in MESH_DESIGNS.items():
    data = copy.deepcopy(FULL)
    data["surface"] = {"mesh": name}
    design_case(f"mesh-{id}", data, msg, files=_mesh_file(name, content))
_nomesh = copy.deepcopy(FULL)
_nomesh["surface"] = {"mesh": "none.obj"}
design_case("mesh-missing", _nomesh, "surface.mesh: file not found")
for id, params, msg in (("nu-1", {"nu": 1}, "surface.params.nu = 1"),
                        ("nu-fraction", {"nu": 4.5}, "surface.params.nu = 4.5"),
                        ("unknown-param", {"radius": 3}, r"surface.params \['radius'\] do not fit"),
                        ("flat-width-zero", {"width": 0.0}, "stage 'surface' failed")):
    data = copy.deepcopy(FULL)
    data["surface"] = {"generator": "facade_patch", "params": params}
    design_case(f"surface-{id}", data, msg)

SIZE = {"spacing-in-metres-as-mm": (("fins", "spacing"), 0.005, r"fins about [\d,]+ \(limit 20,000\): change fins.spacing"),
        "spacing-tiny": (("fins", "spacing"), 1e-4, "change fins.spacing"),
        "light-samples-absurd": (("outputs", "light_samples"), 10**9, "rays about .* change outputs.light_samples"),
        "step-and-disk": (("fins", "spacing"), 0.01, "disk about .* MB")}
for id, (path, value, msg) in SIZE.items():
    data = copy.deepcopy(FULL)
    _set(data, path, value)
    if id == "step-and-disk":
        data["outputs"]["step"] = True
    design_case(f"size-{id}", data, "stage 'estimate' failed: this design is too big.*" + msg)

TOML_TEXT = {"unclosed-table": "[fins\nspacing = 1\n", "duplicate-key": "name = 'a'\nname = 'b'\n",
             "bad-string": "name = 'unterminated\n", "binary": "\x00\x01\x02garbage",
             "equals-missing": "[fins]\nspacing 1\n", "yaml": "fins:\n  spacing: 1\n"}
for id, text in TOML_TEXT.items():
    design_case(f"toml-{id}", text, "not valid TOML")
design_case("empty-file", "", "missing")
_bom = copy.deepcopy(FULL)
_bom["fins"]["spacing"] = -1.0
design_case("utf8-bom-is-read", "\ufeff" + design_text(_bom), "fins.spacing: Input should be greater than 0")
case("design-is-a-folder", lambda tmp: (tmp / "d.toml").mkdir() or
     ["design", str(tmp / "d.toml"), "--out", str(tmp / "out")], 2, "design file .*d.toml is a folder")
case("design-missing", lambda tmp: ["design", str(tmp / "none.toml"), "--out", str(tmp / "out")], 2,
     "design file not found")

# ============================================================== command lines
def _valid_design(tmp):
    p = tmp / "ok.toml"
    p.write_text(design_text(FULL))
    return p


def _afile(tmp):
    (tmp / "afile").write_text("not a folder")
    return tmp / "afile"


for cmd in ("design", "analyze"):
    def target(tmp, cmd=cmd):
        return ["design", str(_valid_design(tmp))] if cmd == "design" else ["analyze", str(PLAIN_OBJ(tmp))]
    case(f"cli-{cmd}-out-empty", lambda tmp, t=target: t(tmp) + ["--out", ""], 2, "--out: the path is empty")
    case(f"cli-{cmd}-out-blank", lambda tmp, t=target: t(tmp) + ["--out", "  "], 2, "--out: the path is empty")
    case(f"cli-{cmd}-out-is-file", lambda tmp, t=target: t(tmp) + ["--out", str(_afile(tmp))], 2,
         "afile: is a file, not a folder")
    case(f"cli-{cmd}-out-under-file", lambda tmp, t=target: t(tmp) + ["--out", str(_afile(tmp) / "x" / "y")], 2,
         "afile is a file, so there can be no folder under it")
    case(f"cli-{cmd}-out-unwritable", lambda tmp, t=target: t(tmp) + ["--out", "/proc/torsal-corpus"], 2,
         "/proc/torsal-corpus: cannot write there")
case("cli-no-command", lambda tmp: [], 2, "required: COMMAND|the following arguments are required")
case("cli-unknown-command", lambda tmp: ["build"], 2, "invalid choice: 'build'")
case("cli-design-no-out", lambda tmp: ["design", str(_valid_design(tmp))], 2, "--out")
case("cli-analyze-no-mesh", lambda tmp: ["analyze"], 2, "mesh")
case("cli-unknown-flag", lambda tmp: ["analyze", str(PLAIN_OBJ(tmp)), "--fast"], 2, "unrecognized arguments: --fast")
case("cli-normals-and-directions", lambda tmp: ["analyze", str(PLAIN_OBJ(tmp)), "--normals", "--directions", "x"],
     2, "not allowed with argument")


# ============================================================== the run
RESULT_FILES = {"report.json", "report.html", "parts.csv", "fins.step", "fins.3dm", "fins.ifc",
                "congruence.ply",
                "support.obj", "analysis.json", "torsal_field.png", "sheets", ".torsal-staging",
                ".torsal-results.json"}


def test_the_corpus_is_big_and_varied():
    kinds = {c.id.split("-")[0] for c in CASES}
    assert len(CASES) >= 300, len(CASES)
    assert {"mesh", "directions", "design", "cli"} <= kinds
    assert sum(c.code == 0 for c in CASES) >= 40
    assert len({c.id for c in CASES}) == len(CASES)
    assert DesignSpec.model_validate(FULL) and DesignSpec.model_validate(_dates)  # bases are valid


EARLIER_DESIGN = """
name = "an earlier good run"
units = "cm"
[surface]
generator = "facade_patch"
params = { nu = 4, nv = 4 }
[sun]
vectors = [[0.3, -0.8, 0.5]]
[fins]
spacing = 3.0
depth = 0.5
[constraints]
# one sun on a nearly flat patch: without it the optimum is a bundle of parallel lines whose
# torsal planes cross at a few degrees (the joinery check warns), and the plates break
min_torsal_angle = 40
[outputs]
step = false
rhino_3dm = false
renders = false
dxf = true
light_samples = 100
"""


@pytest.fixture(scope="session")
def earlier_results(tmp_path_factory):
    """An output folder holding the results of a successful ``torsal design`` and a successful
    ``torsal analyze`` (real runs, once per test session; the stage cache removed). Every
    failing case runs into a copy of it."""
    import fcntl

    session = tmp_path_factory.getbasetemp()  # under xdist: .../pytest-N/popen-gwK
    base = (session.parent if os.environ.get("PYTEST_XDIST_WORKER") else session) / "earlier-results"
    base.mkdir(exist_ok=True)
    out = base / "out"
    with open(base / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # the first process runs them, the others wait
        if not (base / "done").exists():
            (base / "d.toml").write_text(EARLIER_DESIGN)
            (base / "plain.obj").write_text(mc.obj_text(GRID_V, GRID_F))
            # (its fins are 5 mm deep: nothing can fix them to the building, so the run is
            # accepted as not buildable; what matters here is a complete earlier result)
            assert main(["design", str(base / "d.toml"), "--out", str(out),
                         "--accept-unbuildable"]) == 0
            # what refuses it is the load path alone: no part interferes or is blocked (a
            # slot that would cut its fin in two is butted instead: issue 44)
            assembly = json.loads((out / "report.json").read_text())["fabrication"]["assembly"]
            assert not assembly["interfering"] and not assembly["blocked_parts"], assembly
            assert main(["analyze", str(base / "plain.obj"), "--out", str(out)]) == 0
            shutil.rmtree(out / ".torsal-cache")
            (base / "done").write_text("")
    names = {p.name for p in out.iterdir()}
    assert {"report.json", "parts.csv", "congruence.ply", "sheets", "analysis.json",
            "torsal_field.png", ".torsal-results.json"} <= names, names
    return out


def snapshot(folder: Path) -> dict:
    """Every file under ``folder`` but the stage cache -> its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and ".torsal-cache" not in p.relative_to(folder).parts}


def _out_of(argv: list[str]) -> str | None:
    return argv[argv.index("--out") + 1] if "--out" in argv[:-1] else None


@pytest.mark.parametrize("c", CASES, ids=[c.id for c in CASES])
def test_input(c: Case, tmp_path, capsys, monkeypatch, earlier_results):
    """Each input: exit 0 with the right answer, or exit 2 naming the problem; a failing
    ``analyze`` or ``design`` runs into a folder holding an earlier good design and analysis,
    and must leave every file of it as it was."""
    monkeypatch.chdir(tmp_path)   # an output that lands in the current folder would show here
    argv = c.make(tmp_path)
    out_dir = tmp_path / "out"
    if c.code == 0 and argv[0] == "analyze":
        argv = argv + ["--out", str(out_dir)]
    seeded = c.code != 0 and argv[:1] in (["analyze"], ["design"]) and (
        _out_of(argv) == str(out_dir) or  # command-line cases keep the command line they test
        (argv[0] == "analyze" and "--out" not in argv and not c.id.startswith("cli-")))
    if seeded:
        argv = argv if "--out" in argv else argv + ["--out", str(out_dir)]
        shutil.copytree(earlier_results, out_dir)
        before = snapshot(out_dir)
    code = main(argv)
    captured = capsys.readouterr()
    err = captured.err
    assert "Traceback" not in err and "Traceback" not in captured.out
    assert code == c.code, err
    if c.code == 0:
        c.check(out_dir)
        return
    assert err.strip(), "a failure must say why"
    assert re.search(c.message, err, re.S), f"expected /{c.message}/ in:\n{err}"
    if seeded:  # the earlier results, byte for byte, and nothing of this run
        assert snapshot(out_dir) == before
        assert not (out_dir / ".torsal-staging").exists()
    else:
        left = {p.name for p in out_dir.iterdir()} if out_dir.exists() else set()
        assert not (left & RESULT_FILES), left
    assert not (tmp_path / "report.html").exists() and not (tmp_path / "analysis.json").exists()


def test_failing_reruns_include_failures_inside_the_run():
    """The seeded cases above: every failing analyze and design of the corpus, among them
    failures inside the run (a stage, after the earlier results were staged)."""
    seeded = [c for c in CASES if c.code != 0 and c.id.split("-")[0] in ("mesh", "directions", "design")]
    assert len(seeded) >= 300
    assert sum("stage '" in c.message for c in seeded) >= 10


# a user's evening: one folder, a good design and analysis, then failing reruns of every kind
# (each failing inside the run, after the earlier results were staged), then a good one
RERUNS = ["design-goal-reflect-matches-nothing", "design-epw-truncated", "design-size-spacing-tiny",
          "design-mesh-flipped", "design-mesh-two-pieces", "mesh-stl-both-sides",
          "mesh-obj-non-integer-all", "directions-huge-row", "directions-positions-not-on-the-mesh",
          "mesh-truncated-ply-line27"]


def test_an_earlier_good_result_survives_every_failing_rerun(tmp_path, capsys, earlier_results):
    out = tmp_path / "out"
    shutil.copytree(earlier_results, out)
    before = snapshot(out)
    finished = json.loads((out / ".torsal-results.json").read_text())["runs"]
    assert set(finished) == {"design", "analyze"}
    for id in RERUNS:
        c = next(c for c in CASES if c.id == id)
        work = tmp_path / id
        work.mkdir()
        argv = [a if a != str(work / "out") else str(out) for a in c.make(work)]
        argv = argv if "--out" in argv else argv + ["--out", str(out)]
        assert main(argv) == 2, id
        err = capsys.readouterr().err
        kind = argv[0]
        assert f"the earlier {kind} results (" in err and "are left as they were" in err, (id, err)
        assert f"finished {finished[kind]['finished']}, not this one" in err, (id, err)
        assert snapshot(out) == before, id
    # and a good rerun replaces the analysis, leaving the design's results to the design
    (tmp_path / "plain.obj").write_text(mc.obj_text(GRID_V * 2.0, GRID_F))
    assert main(["analyze", str(tmp_path / "plain.obj"), "--out", str(out), "--no-plot"]) == 0
    after = snapshot(out)
    assert json.loads(after["analysis.json"])["average_edge_length"] == pytest.approx(
        2 * json.loads(before["analysis.json"])["average_edge_length"])
    assert "torsal_field.png" not in after          # not written again: an earlier result no more
    assert {k: v for k, v in after.items() if k not in ("analysis.json", ".torsal-results.json")} == \
        {k: v for k, v in before.items() if k not in ("analysis.json", "torsal_field.png",
                                                      ".torsal-results.json")}


#: the quick set (make test) runs one case of each kind through the real command: a mesh file
#: refused by its reader, a design file refused by its schema, a stage failing inside the run
#: (after the fork server started), a directions file, a command line; every case of the corpus
#: also runs in-process above (test_input: exit 2, the message, no traceback)
SUBPROCESS = ["mesh-truncated-obj-line25", "design-sun-vectors-zero", "design-epw-garbage",
              "directions-nan", "cli-design-out-is-file"]
#: second cases of a kind the quick set runs, in the slow set (make test-slow, CI): each is a
#: process importing torsal (3-4 CPU s; a design's stage failure also starts the fork server:
#: 8-12 s of a fresh clone's make test)
SUBPROCESS_SLOW = ["mesh-ply-header-face-100000000", "design-size-spacing-in-metres-as-mm",
                   "design-mesh-one-triangle", "directions-stl-rows-per-merged-vertex-refused"]


@pytest.mark.parametrize("id", SUBPROCESS + [pytest.param(i, marks=pytest.mark.slow)
                                             for i in SUBPROCESS_SLOW])
def test_no_traceback_reaches_stderr_of_the_real_command(id, tmp_path):
    c = next(c for c in CASES if c.id == id)
    exe = Path(sys.executable).with_name("torsal")
    res = subprocess.run([str(exe), *c.make(tmp_path)], capture_output=True, text=True, timeout=120,
                         cwd=tmp_path)
    assert res.returncode == 2
    assert "Traceback" not in res.stderr and res.stderr.startswith("error: ")
    assert re.search(c.message, res.stderr, re.S)


# ============================================================== mutated files (fuzzing)
def _mutate(data: bytes, rng) -> bytes:
    """Flip, delete, insert or duplicate a few spans of bytes."""
    data = bytearray(data)
    kind = rng.integers(0, 4)
    for _ in range(rng.integers(1, 6)):
        if kind == 0 and data:
            data[rng.integers(0, len(data))] = rng.integers(0, 256)
        elif kind == 1 and len(data) > 2:
            a = rng.integers(0, len(data))
            data[a:a + rng.integers(1, 40)] = b""
        elif kind == 2:
            a = rng.integers(0, len(data) + 1)
            data[a:a] = bytes(rng.choice(list(b"0123456789 -.eE\nvf/#[]=\"'"), rng.integers(1, 10)))
        else:
            a = rng.integers(0, len(data))
            data[a:a] = data[a:a + rng.integers(1, 60)]
    return bytes(data)


def test_mutated_mesh_files_load_or_fail_cleanly(tmp_path):
    """1,200 random mutations of valid files in every format: each loads or raises a
    TorsalError (a MeshError naming the file); never another exception."""
    from torsal.core.errors import TorsalError
    from torsal.geometry.mesh import load_mesh

    v, f = mc.grid(4, 3)
    bases = [("obj", mc.obj_text(v, f, normals="face", uv=True).encode()),
             ("ply", mc.ply_ascii(v, f).encode()), ("ply", mc.ply_binary(v, f)),
             ("off", mc.off_text(v, f).encode()), ("stl", mc.stl_binary(v, f)),
             ("stl", mc.stl_ascii(v, f).encode())]
    rng = np.random.default_rng(2026)
    outcomes = {"loaded": 0, "rejected": 0}
    for k in range(1200):
        ext, data = bases[k % len(bases)]
        path = tmp_path / f"m{k}.{ext}"
        path.write_bytes(_mutate(data, rng))
        try:
            m = load_mesh(path)
            assert np.isfinite(m.vertices).all() and len(m.faces) > 0
            outcomes["loaded"] += 1
        except TorsalError as exc:
            assert str(path) in str(exc)
            outcomes["rejected"] += 1
    assert outcomes["rejected"] > 600 and outcomes["loaded"] > 50, outcomes


def test_mutated_design_files_load_or_fail_cleanly(tmp_path):
    """400 random mutations of a valid design file: each loads or raises a TorsalError."""
    from torsal.core.errors import TorsalError
    from torsal.pipeline.design_file import load_design_file

    base = design_text(FULL).encode()
    rng = np.random.default_rng(18)
    rejected = 0
    for k in range(400):
        path = tmp_path / f"d{k}.toml"
        path.write_bytes(_mutate(base, rng))
        try:
            load_design_file(path)
        except TorsalError:
            rejected += 1
    assert rejected > 200
