"""``torsal analyze``: the analysis of one line congruence (eqs. 1-3, 7)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._io import write_json
from ..geometry.congruence import Congruence
from ..geometry.mesh import load_mesh

__all__ = ["AnalysisResult", "analyze", "load_directions"]

def load_directions(path: str | Path, n_vertices: int) -> np.ndarray:
    """Read per-vertex line directions, (n, 3), from ``.npy`` or a text/CSV file (one row
    per vertex, three numbers separated by spaces or commas; ``#`` starts a comment)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"directions file not found: {path}")
    try:
        if path.suffix.lower() == ".npy":
            d = np.load(path)
        else:
            delim = "," if "," in path.read_text() else None
            d = np.loadtxt(path, delimiter=delim, ndmin=2)
    except ValueError as exc:
        raise ValueError(f"{path}: could not read directions ({exc}); expected rows 'x y z'") from None
    d = np.asarray(d, dtype=float)
    if d.ndim != 2 or d.shape != (n_vertices, 3):
        raise ValueError(
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
        Per-vertex line directions (see :func:`load_directions`); default the normal
        congruence of A (area-weighted vertex normals).
    out_dir : path, optional
        Where to write ``analysis.json`` and ``torsal_field.png`` (atomically, replacing
        earlier runs). Nothing is written when omitted.
    plot : bool
        Also draw the PNG.

    Examples
    --------
    >>> res = analyze("examples/facade_patch.obj", out_dir="out")  # doctest: +SKIP
    >>> res.summary["hyperbolic_share"]  # doctest: +SKIP
    1.0
    """
    mesh_path = Path(mesh)
    m = load_mesh(mesh_path)
    if directions is None:
        c = Congruence.from_normals(m)
        kind = "normals"
    else:
        c = Congruence(m.vertices, m.faces, load_directions(directions, len(m.vertices)))
        kind = str(directions)
    summary = {"mesh": str(mesh_path), "directions": kind, **c.summary()}
    files = {}
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        files["json"] = str(write_json(out / "analysis.json", summary))
        if plot:
            from ..report import plot_torsal_field

            files["png"] = str(plot_torsal_field(
                c, out / "torsal_field.png",
                title=f"{mesh_path.name}: {summary['faces']} faces, "
                      f"{100 * summary['hyperbolic_share']:.1f}% hyperbolic"))
    return AnalysisResult(congruence=c, summary=summary, files=files)
