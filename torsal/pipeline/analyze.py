"""``torsal analyze``: the analysis of one line congruence (eqs. 1-3, 7)."""
from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.atomic import write_json
from ..core.errors import TorsalError
from ..core.inputs import check_input, read_input
from ..core.outputs import output_folder
from ..geometry.congruence import Congruence
from ..geometry.mesh import load_mesh
from .staging import Staging

__all__ = ["AnalysisResult", "analyze", "load_directions", "read_directions", "DirectionsError"]

class DirectionsError(TorsalError, ValueError):
    """A directions file that cannot be used; the message names the file and the rows."""


def read_directions(path: str | Path) -> np.ndarray:
    """Read line directions, (k, 3), from ``.npy`` or a text/CSV file (one row per vertex, three
    numbers separated by spaces or commas; ``#`` starts a comment). Rows are not yet matched to
    a mesh: see :meth:`torsal.geometry.mesh.MeshMerge.to_merged`."""
    path = check_input(path, "directions file")
    try:
        if path.suffix.lower() == ".npy":
            d = np.load(path, allow_pickle=False)
        else:
            text = read_input(path, "directions file", text=True)
            delim = "," if "," in text else None
            d = np.loadtxt(io.StringIO(text), delimiter=delim, ndmin=2)
    except (ValueError, EOFError, OSError) as exc:
        raise DirectionsError(f"{path}: could not read directions ({exc}); expected rows 'x y z'"
                              ) from None
    d = np.asarray(d)
    if d.ndim != 2 or d.shape[1] != 3 or not np.issubdtype(d.dtype, np.number):
        raise DirectionsError(f"{path}: expected rows of 3 numbers 'x y z', got an array of shape "
                              f"{d.shape}")
    d = d.astype(float)
    bad = np.flatnonzero(~np.isfinite(d).all(axis=1))
    if bad.size:
        raise DirectionsError(f"{path}: rows {bad[:10].tolist()} have NaN or infinite values")
    zero = np.flatnonzero(np.linalg.norm(d, axis=1) == 0)
    if zero.size:
        raise DirectionsError(f"{path}: rows {zero[:10].tolist()} have zero length; every vertex "
                              "needs a line direction")
    return d


def load_directions(path: str | Path, n_vertices: int) -> np.ndarray:
    """Read per-vertex line directions, (n, 3), from ``.npy`` or a text/CSV file (one row
    per vertex, three numbers separated by spaces or commas; ``#`` starts a comment)."""
    d = read_directions(path)
    if d.shape != (n_vertices, 3):
        raise DirectionsError(
            f"{path}: expected {n_vertices} rows of 3 numbers (one direction per mesh vertex), "
            f"got an array of shape {d.shape}"
        )
    return d


@dataclass
class AnalysisResult:
    """What ``torsal analyze`` produced: the congruence, its summary and the files written."""

    congruence: Congruence
    summary: dict
    files: dict


def analyze(mesh: str | Path, *, directions: str | Path | None = None,
            out_dir: str | Path | None = None, plot: bool = True) -> AnalysisResult:
    """Analyze the line congruence of a mesh: torsal directions, focal points, hyperbolicity,
    normality (Wang et al. 2013, eqs. (1)-(3), (7)).

    Parameters
    ----------
    mesh : path
        OBJ/PLY/STL/OFF triangle mesh A in model units.
    directions : path, optional
        Per-vertex line directions (see :func:`read_directions`), one row per vertex of the
        file or per vertex after merging (see :func:`~torsal.geometry.mesh.load_mesh`; the
        summary's ``directions_rows`` says which); default the normal congruence of A
        (area-weighted vertex normals).
    out_dir : path, optional
        Where to write ``analysis.json`` and ``torsal_field.png`` (together, replacing
        earlier runs; a failed analysis leaves neither, see
        :class:`~torsal.pipeline.staging.Staging`). Nothing is written when omitted.
    plot : bool
        Also draw the PNG.

    Examples
    --------
    >>> res = analyze("examples/facade_patch.obj", out_dir="out")  # doctest: +SKIP
    >>> res.summary["hyperbolic_share"]  # doctest: +SKIP
    1.0
    """
    if out_dir is None:
        return _analyze(Path(mesh), directions, None, plot)
    out = output_folder(out_dir, option="output folder")
    staging = Staging(out, kind="analyze")
    try:
        with staging:
            res = _analyze(Path(mesh), directions, staging.folder, plot)
            staging.keep_only([Path(p).name for p in res.files.values()])
    except Exception as exc:
        exc.add_note(staging.failure_note())
        raise
    res.files = {k: str(out / Path(p).name) for k, p in res.files.items()}
    return res


def _analyze(mesh_path: Path, directions, out: Path | None, plot: bool) -> AnalysisResult:
    """The analysis, writing into ``out`` (the staging folder) when given."""
    m = load_mesh(mesh_path)
    merge = m.metadata["merge"]
    if directions is None:
        c = Congruence.from_normals(m)
        kind = "normals"
    else:
        d, per = merge.to_merged(read_directions(directions), what=f"directions file {directions}")
        c = Congruence(m.vertices, m.faces, d)
        kind = str(directions)
    summary = {"mesh": str(mesh_path), "directions": kind, **c.summary(),
               "mesh_file": merge.as_dict()}
    if directions is not None:
        # which vertices the rows were read as: the file's (mapped onto merged ones) or the mesh's
        summary["directions_rows"] = f"one per {per}"
    files = {}
    if out is not None:
        files["json"] = str(write_json(out / "analysis.json", summary))
        if plot:
            from .report import plot_torsal_field

            files["png"] = str(plot_torsal_field(
                c, out / "torsal_field.png",
                title=f"{mesh_path.name}: {summary['faces']} faces, "
                      f"{100 * summary['hyperbolic_share']:.1f}% hyperbolic"))
    return AnalysisResult(congruence=c, summary=summary, files=files)
