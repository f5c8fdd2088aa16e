"""A generated corpus of bad and unusual inputs, each run through the command line.

Every case writes its own small files (nothing big is stored) and runs ``torsal.pipeline.cli.main``
in-process; a few run the installed ``torsal`` as a subprocess to show that no traceback
reaches stderr. A bad input must exit 2 with a message naming the problem, no traceback, and
leave no result file; an unusual but valid input must exit 0 with the right answer (counts and
hyperbolic faces computed here independently of torsal's readers).

Kinds: mesh files (truncated, lying headers, garbage, broken geometry, unusual but valid
layouts in every format), directions files, design files (a bad value for every key of the
schema, missing and unknown keys, sun, EPW, mesh and size problems) and command lines.
"""
from __future__ import annotations

import copy
import datetime as dt
import json
import math
import os
import re
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
from torsal.pipeline.cli import main
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


def _analysis_check(vertices, faces, hyperbolic, file_vertices=None, rows=None):
    def check(out: Path):
        s = json.loads((out / "analysis.json").read_text())
        assert (s["vertices"], s["faces"], s["hyperbolic_faces"]) == (vertices, faces, hyperbolic)
        if file_vertices is not None:
            assert s["mesh_file"]["file_vertices"] == file_vertices
        if rows is not None:
            assert s["directions_rows"] == rows
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
    "duplicate-face": (TRI_V, np.array([[0, 1, 2], [0, 1, 2]]), "orientation|non-manifold"),
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
mesh_case("stl-nan", "n.stl", mc.stl_binary(TRI_V, TRI_F)[:84 + 12] + struct.pack("<f", math.nan)
          + mc.stl_binary(TRI_V, TRI_F)[84 + 16:], 2, "NaN")
mesh_case("stl-zero-area", "z.stl", mc.stl_binary(np.vstack([TRI_V, [[2, 0, 0]]]), np.array([[0, 1, 4], [0, 1, 2]])),
          2, "zero area")
mesh_case("obj-index-zero", "z.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 2, "index 0")
mesh_case("obj-face-two-corners", "z.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\nf 1 2 3\n", 2, "at least three")
mesh_case("obj-face-letters", "z.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf a b c\n", 2, "not a vertex index")
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
directions_case("nan", PLAIN_OBJ, _txt("d.txt", _nan), 2, r"rows \[3\] have NaN")
_inf = D20.copy()
_inf[7, 0] = np.inf
directions_case("inf", PLAIN_OBJ, _txt("d.txt", _inf), 2, r"rows \[7\] have NaN or infinite")
_zero = D20.copy()
_zero[11] = 0
directions_case("zero-row", PLAIN_OBJ, _txt("d.txt", _zero), 2, r"rows \[11\] have zero length")
directions_case("empty", PLAIN_OBJ, _write("d.txt", ""), 2, "could not read directions|rows of 3")
directions_case("garbage-text", PLAIN_OBJ, _write("d.txt", "north east up\n" * 20), 2, "could not read directions")
directions_case("header-row", PLAIN_OBJ, _write("d.csv", "x,y,z\n" + "0,0,1\n" * 20), 2, "could not read directions")
directions_case("binary-garbage", PLAIN_OBJ, _write("d.txt", bytes(range(256)) * 3), 2, "could not read directions")
directions_case("npy-1d", PLAIN_OBJ, _npy("d.npy", np.ones(20)), 2, "rows of 3 numbers")
directions_case("npy-object", PLAIN_OBJ, _npy("d.npy", np.array([{"a": 1}] * 20, dtype=object)), 2,
                "could not read directions")
directions_case("npy-garbage", PLAIN_OBJ, _write("d.npy", b"\x93NUMPY garbage" * 10), 2, "could not read directions")
directions_case("npy-strings", PLAIN_OBJ, _npy("d.npy", np.array([["a", "b", "c"]] * 20)), 2, "rows of 3 numbers")
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
}
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
        if isinstance(v, dict) and k != "params":
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
RESULT_FILES = {"report.json", "report.html", "parts.csv", "fins.step", "fins.3dm", "congruence.ply",
                "support.obj", "analysis.json", "torsal_field.png", "sheets", ".torsal-staging",
                ".torsal-results.json"}


def test_the_corpus_is_big_and_varied():
    kinds = {c.id.split("-")[0] for c in CASES}
    assert len(CASES) >= 300, len(CASES)
    assert {"mesh", "directions", "design", "cli"} <= kinds
    assert sum(c.code == 0 for c in CASES) >= 40
    assert len({c.id for c in CASES}) == len(CASES)
    assert DesignSpec.model_validate(FULL) and DesignSpec.model_validate(_dates)  # bases are valid


@pytest.mark.parametrize("c", CASES, ids=[c.id for c in CASES])
def test_input(c: Case, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)   # an output that lands in the current folder would show here
    argv = c.make(tmp_path)
    out_dir = tmp_path / "out"
    if c.code == 0 and argv[0] == "analyze":
        argv = argv + ["--out", str(out_dir)]
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
    left = {p.name for p in out_dir.iterdir()} if out_dir.exists() else set()
    assert not (left & RESULT_FILES), left
    assert not (tmp_path / "report.html").exists() and not (tmp_path / "analysis.json").exists()


SUBPROCESS = ["mesh-truncated-obj-line25", "mesh-ply-header-face-100000000", "design-sun-vectors-zero",
              "design-epw-garbage", "directions-nan", "design-size-spacing-in-metres-as-mm",
              "cli-design-out-is-file", "design-mesh-one-triangle"]


@pytest.mark.parametrize("id", SUBPROCESS)
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
