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
from ..geometry.congruence import ZERO_DIRECTION_RTOL, Congruence
from ..geometry.mesh import MAX_COORDINATE, MeshError, load_mesh, rows_per_vertex
from .staging import Staging

__all__ = ["AnalysisResult", "analyze", "load_directions", "read_directions", "DirectionsError",
           "DirectionRows", "read_direction_rows", "directions_for_mesh"]


class DirectionsError(TorsalError, ValueError):
    """A directions file that cannot be used; the message names the file and the rows."""




@dataclass(frozen=True)
class DirectionRows:
    """The rows of a directions file, as the file has them.

    Attributes
    ----------
    directions : (k, 3) float
        Line directions e_i (model units: mesh B has vertices a_i + e_i).
    points : (k, 3) float or None
        For rows ``x y z dx dy dz``: the vertex each row belongs to, by position.
    lines : (k,) int or None
        The file line of each row (from 1); None for ``.npy``.
    """

    directions: np.ndarray
    points: np.ndarray | None = None
    lines: np.ndarray | None = None

    def where(self, rows) -> str:
        """``rows [3, 7] (lines 5, 9)`` for messages."""
        rows = np.asarray(rows, dtype=np.int64).ravel()
        text = f"rows {_shown(rows)}"
        if self.lines is not None:
            text += f" ({'line' if rows.size == 1 else 'lines'} {_shown(self.lines[rows])[1:-1]})"
        return text


def _shown(idx) -> str:
    idx = np.asarray(idx).ravel()
    more = f" and {idx.size - 10} more" if idx.size > 10 else ""
    return "[" + ", ".join(str(int(i)) for i in idx[:10]) + more + "]"


def _parse_rows(text: str, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Text rows of 3 or 6 numbers (spaces or commas; ``#`` comments) -> (k, c) array, lines."""
    rows, lines = [], []
    for k, line in enumerate(text.splitlines(), start=1):
        body = line.split("#", 1)[0].replace(",", " ").split()
        if not body:
            continue
        try:
            values = [float(t) for t in body]
        except ValueError:
            raise DirectionsError(
                f"{path}: line {k}: {line.strip()[:40]!r} is not numbers; each row is 'dx dy dz' "
                "(one line direction per vertex) or 'x y z dx dy dz' (a vertex position and its "
                "direction); put a header behind '#'") from None
        if len(values) not in (3, 6) or (rows and len(values) != len(rows[0])):
            expect = f"{len(rows[0])}, as the rows before it" if rows else "3 or 6"
            raise DirectionsError(
                f"{path}: line {k}: {len(values)} numbers, rows have {expect} ('dx dy dz' or "
                "'x y z dx dy dz')")
        rows.append(values)
        lines.append(k)
    if not rows:
        raise DirectionsError(f"{path}: no rows; expected one 'dx dy dz' row per vertex")
    return np.asarray(rows, dtype=float), np.asarray(lines, dtype=np.int64)


def read_direction_rows(path: str | Path) -> DirectionRows:
    """Read a directions file: ``.npy`` or text/CSV with one row per vertex, ``dx dy dz`` (in
    vertex order, see :meth:`~torsal.geometry.mesh.MeshMerge.row_convention`) or
    ``x y z dx dy dz`` (matched to the vertex at ``x y z``, in any order).

    Each direction must be finite, not zero (longer than 1e-12 of the longest row, or of one
    model unit) and below
    ``MAX_COORDINATE`` (1e30: larger values overflow when squared, which is not a zero length).
    Messages name the rows and their file lines.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "d.txt"
    >>> _ = p.write_text("# dx dy dz\\n0 0 1\\n0 1e300 1\\n")
    >>> read_direction_rows(p)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    torsal.pipeline.analyze.DirectionsError: ...d.txt: rows [1] (line 3) have values up to 1e+300: ...
    """
    path = check_input(path, "directions file")
    lines = None
    if path.suffix.lower() == ".npy":
        try:
            d = np.load(path, allow_pickle=False)
        except (ValueError, EOFError, OSError) as exc:
            raise DirectionsError(f"{path}: could not read directions ({exc}); expected a .npy "
                                  "array of rows 'dx dy dz'") from None
        d = np.asarray(d)
        if d.ndim != 2 or d.shape[1] not in (3, 6) or not np.issubdtype(d.dtype, np.number):
            raise DirectionsError(f"{path}: expected rows of 3 numbers 'x y z' (or 6: 'x y z dx "
                                  f"dy dz'), got an array of shape {d.shape} ({d.dtype})")
        d = d.astype(float)
        if len(d) == 0:
            raise DirectionsError(f"{path}: no rows; expected one 'dx dy dz' row per vertex")
    else:
        d, lines = _parse_rows(read_input(path, "directions file", text=True), path)
    rows = DirectionRows(d[:, -3:], d[:, :3] if d.shape[1] == 6 else None, lines)
    _check_rows(rows, path)
    return rows


def _check_rows(rows: DirectionRows, path: Path) -> None:
    d = rows.directions
    bad = np.flatnonzero(~np.isfinite(d).all(axis=1))
    if bad.size:
        raise DirectionsError(f"{path}: {rows.where(bad)} have NaN or infinite values; every "
                              "vertex needs a finite line direction")
    big = np.abs(d).max(axis=1)
    huge = np.flatnonzero(big > MAX_COORDINATE)
    if huge.size:
        raise DirectionsError(
            f"{path}: {rows.where(huge)} have values up to {big[huge].max():.3g}: beyond "
            f"{MAX_COORDINATE:g} their squares overflow (they are not zero); a direction's length "
            "is in model units (mesh B = A + e), so give rows of ordinary size, e.g. unit vectors")
    # the length without squaring the components (1e-300 is short, not zero)
    with np.errstate(invalid="ignore", divide="ignore"):
        length = big * np.linalg.norm(d / np.where(big > 0, big, 1.0)[:, None], axis=1)
    # the rule Congruence applies: shorter than 1e-12 of the longest row (or of one unit)
    zero = np.flatnonzero(length <= ZERO_DIRECTION_RTOL * max(1.0, length.max()))
    if zero.size:
        what = ("have zero length" if not length[zero].any() else
                f"are zero to working precision (length {length[zero].max():.3g}, the longest "
                f"row {length.max():.3g})")
        raise DirectionsError(f"{path}: {rows.where(zero)} {what}; every vertex needs a line "
                              "direction")
    if rows.points is not None:
        p_bad = np.flatnonzero(~np.isfinite(rows.points).all(axis=1)
                               | (np.abs(rows.points) > MAX_COORDINATE).any(axis=1))
        if p_bad.size:
            raise DirectionsError(f"{path}: {rows.where(p_bad)}: the positions 'x y z' are not "
                                  "finite numbers of ordinary size")


def read_directions(path: str | Path) -> np.ndarray:
    """Read line directions, (k, 3), from ``.npy`` or a text/CSV file (one row per vertex,
    three numbers separated by spaces or commas, or six: ``x y z dx dy dz``; ``#`` starts a
    comment). Rows are not yet matched to a mesh: see :func:`directions_for_mesh`."""
    return read_direction_rows(path).directions


def directions_for_mesh(rows: DirectionRows, mesh, *, what: str = "directions") -> tuple[np.ndarray, str]:
    """Directions per mesh vertex, (n, 3), from a file's rows, and which rows were taken as.

    Rows with positions (``x y z dx dy dz``) are matched to the mesh vertex at that position
    (nearer to it than a quarter of the distance to its nearest other vertex; every vertex
    needs a row, rows of one vertex must agree): the answer does not depend on the order of
    the file's vertices, so an STL file and an OBJ of the same surface give the same result.
    Rows without are read per vertex of the file or per merged vertex
    (:meth:`~torsal.geometry.mesh.MeshMerge.to_merged`), except one row per merged vertex of
    an STL file: STL has no vertex order, so that raises :class:`DirectionsError` pointing to
    the ``x y z dx dy dz`` rows (one row per facet corner is the file's own order and is read).

    Parameters
    ----------
    rows : DirectionRows
    mesh : trimesh.Trimesh
        From :func:`~torsal.geometry.mesh.load_mesh` (its ``metadata["merge"]``).

    Returns
    -------
    directions : (n, 3) float
    per : str
        ``"vertex"``, ``"file vertex"``, ``"merged vertex"`` or ``"position"``; its meaning in
        words: ``mesh.metadata["merge"].row_convention(per)``.
    """
    merge = mesh.metadata["merge"]
    if rows.points is None:
        _refuse_unordered(rows, merge, what)
        return merge.to_merged(rows.directions, what=what)
    from scipy.spatial import cKDTree

    v = np.asarray(mesh.vertices, dtype=float)
    tree = cKDTree(v)
    spacing = tree.query(v, k=2)[0][:, 1] if len(v) > 1 else np.array([np.inf])
    dist, idx = tree.query(rows.points)
    far = np.flatnonzero(~(dist <= 0.25 * spacing[idx]))
    if far.size:
        j = far[0]
        raise DirectionsError(
            f"{what}: {rows.where(far)} name points that are no vertex of the mesh (row {j} at "
            f"{rows.points[j].tolist()}: the nearest vertex, {int(idx[j])}, is {dist[j]:.3g} away); "
            "give each vertex's position as the mesh file has it")
    try:
        d = rows_per_vertex(rows.directions, idx, len(v), what=what, same="one vertex",
                            fix="give one direction per vertex position")
    except MeshError as exc:
        raise DirectionsError(str(exc)) from None
    return d, "position"


def _refuse_unordered(rows: DirectionRows, merge, what: str) -> None:
    """Rows ``dx dy dz``, one per merged vertex, for a file with no vertex order (STL): the
    merged order is torsal's, not the user's, so such rows would land on vertices silently
    chosen. One row per facet corner (the file's own order) or rows with positions are
    matched; this refuses the rest."""
    k = len(rows.directions)
    if not (merge.format.startswith("stl") and not merge.identity and k == merge.vertices):
        return
    raise DirectionsError(
        f"{what}: {k} rows 'dx dy dz', one per vertex, for an STL mesh: an STL file has no "
        f"vertex order of its own (its {merge.vertices} vertices are {merge.file_vertices} facet "
        "corners merged by position), so the rows cannot be matched to vertices by their order. "
        "Give rows 'x y z dx dy dz' (each vertex's position and its direction, in any order), or "
        f"one 'dx dy dz' row per facet corner ({merge.file_vertices} rows: corner i % 3 of "
        "facet i // 3)")


def load_directions(path: str | Path, n_vertices: int) -> np.ndarray:
    """Read per-vertex line directions, (n, 3), from ``.npy`` or a text/CSV file (one row
    per vertex, three numbers separated by spaces or commas; ``#`` starts a comment), in the
    order of the mesh's vertices. Rows with positions need the mesh: :func:`directions_for_mesh`."""
    rows = read_direction_rows(path)
    if rows.points is not None:
        raise DirectionsError(f"{path}: rows 'x y z dx dy dz' are matched to a mesh's vertices by "
                              "position; use directions_for_mesh(rows, mesh)")
    d = rows.directions
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
        Per-vertex line directions (see :func:`read_direction_rows`), one row per vertex of the
        file, per vertex after merging (see :func:`~torsal.geometry.mesh.load_mesh`) or with
        its position ``x y z dx dy dz`` (:func:`directions_for_mesh`); the summary's
        ``directions_rows`` says which and ``directions_row_order`` what row ``i`` is; default
        the normal congruence of A (area-weighted vertex normals).
    out_dir : path, optional
        Where to write ``analysis.json`` and ``torsal_field.png`` (together, replacing the
        earlier analysis only when this one succeeds; a failed analysis leaves the folder as
        it was, see :class:`~torsal.pipeline.staging.Staging`). Nothing is written when omitted.
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
        d, per = directions_for_mesh(read_direction_rows(directions), m,
                                     what=f"directions file {directions}")
        c = Congruence(m.vertices, m.faces, d)
        kind = str(directions)
    summary = {"mesh": str(mesh_path), "directions": kind, **c.summary(),
               "mesh_file": merge.as_dict()}
    if directions is not None:
        # which vertices the rows were read as (the file's, the merged mesh's, by position), and
        # the order that implies, in words: a row order is never left implicit
        summary["directions_rows"] = f"one per {per}"
        summary["directions_row_order"] = merge.row_convention(per)
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
