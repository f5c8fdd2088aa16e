"""The FreeCAD object's worker: one design run in torsal's own Python, outside FreeCAD.

FreeCAD and torsal each load an OpenCascade (FreeCAD's system OCC 7.6, build123d's OCP wheel)
and their own numpy and matplotlib; in one process they clash (measured: the assembly
stage's plot fails on FreeCAD's ``mpl_toolkits``), and a crash in a stage would take the user's
unsaved document with it. So :class:`~torsal.hosts.freecad.feature.FinsFeature` writes a
:class:`FinsJob` and runs ``python -m torsal.hosts.freecad JOB.json`` with the Python of
torsal's environment; FreeCAD only reads the STEP back (``Part.read``).

A job folder holds ``design.toml`` (the design file with the object's properties applied:
what was run, re-runnable with ``torsal design``), ``surface.obj`` when the object's
``Surface`` is linked, and ``out/`` (the outputs of :meth:`torsal.Design.run` and its stage
cache, so a recompute re-runs only the stages whose inputs changed). The job prints progress
as JSON lines on stdout and writes ``result.json`` (:class:`FinsOutcome`).

Exit status as the command line's: 0 done (buildable or not: ``buildable`` says), 2 bad input
(the message on stderr names the key), 1 a bug.
"""
from __future__ import annotations

import json
import sys
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ...core.atomic import atomic_path, write_json
from ...core.errors import TorsalError, raised_in_torsal
from ...core.units import UNIT_TO_MM, scale
from ...geometry.surfaces import grid_faces
from ...pipeline.assembly import unbuildable_message
from ...pipeline.design import Design
from ...pipeline.design_file import DesignFileError, absolute_file_paths, load_design_file
from ..results import read_parts

__all__ = ["FinsJob", "FinsOutcome", "SurfaceGrid", "effective_design", "grid_mesh", "run_job",
           "write_design", "outcome_of"]


@dataclass
class SurfaceGrid:
    """A face sampled on a regular grid of its (u, v) parameters, in millimetres.

    ``points`` has ``nu * nv`` rows ``[x, y, z]``, row-major (``index = i * nv + j``, as
    :func:`~torsal.geometry.surfaces.grid_faces`); ``inside[k]`` is False where the grid
    point lies outside a trimmed face."""

    nu: int
    nv: int
    points: list
    inside: list


@dataclass
class FinsJob:
    """What the FreeCAD object asks for; lengths in millimetres (FreeCAD's unit), angles in
    degrees. ``None`` keeps the design file's value."""

    design: str
    folder: str
    spacing_mm: float | None = None
    depth_mm: float | None = None
    thickness_mm: float | None = None
    #: 0 switches ``constraints.min_torsal_angle`` off
    min_torsal_angle: float | None = None
    sun_start: str | None = None
    sun_end: str | None = None
    sun_hours: list | None = None
    surface: SurfaceGrid | None = None
    #: polylines ``[[x, y, z], ...]`` that replace the design's ``goals.strokes``
    strokes: list | None = None
    stroke_width_mm: float | None = None
    #: family 1's spacing and depth (``fins.spacing = [s0, s1]``); None: ``spacing_mm`` /
    #: ``depth_mm`` for both families (or, with those None too, the design file's values)
    spacing1_mm: float | None = None
    depth1_mm: float | None = None

    @classmethod
    def read(cls, path: str | Path) -> "FinsJob":
        return cls.from_dict(json.loads(Path(path).read_text()))

    @classmethod
    def from_dict(cls, data: dict) -> "FinsJob":
        """The job of :func:`dataclasses.asdict`'s dict (as written, or sent to a live session)."""
        data = dict(data)
        if data.get("surface") is not None:
            data["surface"] = SurfaceGrid(**data["surface"])
        return cls(**data)

    def write(self, path: str | Path) -> Path:
        return write_json(path, asdict(self))


@dataclass
class FinsOutcome:
    """What a job produced (``result.json``): the files, the verdicts, and the parts (names
    and families, :func:`~torsal.hosts.results.read_parts`) in the order of the STEP file's
    solids."""

    design: str
    step: str
    report: str
    buildable: bool
    sun_blocked: float | None
    parts: list
    families: list
    interfering: list
    stages_run: list = field(default_factory=list)
    stages_cached: list = field(default_factory=list)
    problems: str = ""


def grid_mesh(grid: SurfaceGrid, factor: float) -> tuple[np.ndarray, np.ndarray]:
    """Mesh A from a sampled face: vertices (n, 3) scaled by ``factor`` (mm -> model units)
    and triangles (m, 3) of the grid (:func:`~torsal.geometry.surfaces.grid_faces`), without the
    triangles that reach outside a trimmed face and the vertices no triangle uses.

    >>> g = SurfaceGrid(nu=3, nv=2, points=[[i, 0, j] for i in range(3) for j in range(2)],
    ...                 inside=[True] * 5 + [False])
    >>> v, f = grid_mesh(g, 0.001)
    >>> v.shape, f.shape
    ((5, 3), (3, 3))
    """
    pts = np.asarray(grid.points, float).reshape(grid.nu * grid.nv, 3) * factor
    faces = grid_faces(grid.nu, grid.nv)
    faces = faces[np.asarray(grid.inside, bool)[faces].all(axis=1)]
    used = np.unique(faces)
    new = np.full(len(pts), -1)
    new[used] = np.arange(len(used))
    return pts[used], new[faces]


def _write_obj(path: Path, vertices: np.ndarray, faces: np.ndarray) -> None:
    lines = ["# torsal: a FreeCAD face tessellated on its (u, v) grid, model units"]
    lines += [f"v {x:.12g} {y:.12g} {z:.12g}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n")


def _family_value(given, both_mm: float | None, second_mm: float | None, mm: float):
    """``fins.spacing`` or ``fins.depth`` in model units from the job's family-0 (or both)
    and family-1 lengths in mm, over the design file's ``given`` (one number or [f0, f1]);
    None keeps ``given``. One number where the two families agree.

    >>> _family_value([0.6, 1.2], 800.0, None, 0.001)      # one length: both families
    0.8
    >>> _family_value([0.6, 1.2], None, 1800.0, 0.001)     # family 1's only
    [0.6, 1.8]
    >>> _family_value(0.6, 600.0, 600.0, 0.001)
    0.6
    """
    if second_mm is None:
        return None if both_mm is None else both_mm * mm
    if both_mm is not None:
        first = both_mm * mm
    elif isinstance(given, (list, tuple)) and given:
        first = given[0]
    else:
        first = given
    if first is None:       # no family-0 length anywhere: the loader names the missing key
        return None
    second = second_mm * mm
    return first if abs(second - first) <= 1e-12 * max(abs(first), 1.0) else [first, second]


def effective_design(job: FinsJob) -> dict:
    """The design file's data with the job's values applied (model units of the design).

    Raises :class:`~torsal.pipeline.design_file.DesignFileError` when the design file is not
    TOML (its keys are checked when the result is loaded).
    """
    path = Path(job.design)
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise DesignFileError(f"{path}: not valid TOML ({exc})") from None
    # the job's design file lives in another folder: its relative paths made absolute
    absolute_file_paths(data, path.resolve().parent)
    units = data.get("units", "m")
    mm = scale("mm", units) if units in UNIT_TO_MM else 1.0   # (a bad unit: the loader names it)
    fins = data.setdefault("fins", {})
    for key, both, second in (("spacing", job.spacing_mm, job.spacing1_mm),
                              ("depth", job.depth_mm, job.depth1_mm)):
        value = _family_value(fins.get(key), both, second, mm)
        if value is not None:
            fins[key] = value
    if job.thickness_mm is not None:
        data.setdefault("material", {})["thickness_mm"] = job.thickness_mm
    if job.min_torsal_angle is not None:
        constraints = data.setdefault("constraints", {})
        if job.min_torsal_angle > 0:
            constraints["min_torsal_angle"] = job.min_torsal_angle
        else:
            constraints.pop("min_torsal_angle", None)
    sun = data.setdefault("sun", {})
    if job.sun_start or job.sun_end:
        for key in ("epw", "weather", "vectors"):   # a date range replaces the file's sun
            sun.pop(key, None)
        sun["start"], sun["end"] = job.sun_start or sun.get("start"), job.sun_end or sun.get("end")
    if job.sun_hours is not None:
        sun["hours"] = list(job.sun_hours)
    if job.surface is not None:
        vertices, faces = grid_mesh(job.surface, mm)
        obj = Path(job.folder) / "surface.obj"
        _write_obj(obj, vertices, faces)
        data["surface"] = {"mesh": str(obj)}
    if job.strokes is not None:
        width = {"width": job.stroke_width_mm * mm} if job.stroke_width_mm else {}
        data.setdefault("goals", {})["strokes"] = [
            {"points": (np.asarray(s, float) * mm).tolist(), **width} for s in job.strokes]
    # FreeCAD reads the solids from the STEP file and their names from the parts list
    data.setdefault("outputs", {}).update(step=True, bom=True)
    return data


def write_design(job: FinsJob):
    """The job's design file written as ``folder/design.toml`` (:func:`effective_design`) and
    read back: returns its path and the :class:`~torsal.pipeline.design_file.DesignSpec`.

    Raises :class:`~torsal.core.errors.TorsalError` (bad input, naming the key)."""
    import tomli_w

    folder = Path(job.folder)
    folder.mkdir(parents=True, exist_ok=True)
    data = effective_design(job)
    design_path = folder / "design.toml"
    with atomic_path(design_path) as tmp:
        tmp.write_text(f"# written by torsal's FreeCAD object from {job.design}\n"
                       + tomli_w.dumps(data))
    return design_path, load_design_file(design_path)


def outcome_of(result, design_path: Path) -> FinsOutcome:
    """What a finished design run (:class:`~torsal.pipeline.design.DesignResult`, its folder
    the job's ``out``) gives the FreeCAD object."""
    out = Path(result.folder)
    parts = read_parts(out)
    assembly = result.report.get("fabrication", {}).get("assembly", {})
    report = result.files.get("report_html", result.files.get("report_json", "report.json"))
    return FinsOutcome(
        design=str(design_path), step=str(out / result.report["fabrication"]["step"]),
        report=str(out / report),
        buildable=bool(assembly.get("buildable", True)),
        sun_blocked=result.report.get("light", {}).get("blocked_share"),
        parts=[p.name for p in parts], families=[p.group for p in parts],
        interfering=sorted(set(assembly.get("interfering_parts", []))
                           | set(assembly.get("blocked_parts", []))),
        stages_run=[s for s in result.stage_seconds if s not in result.cached],
        stages_cached=list(result.cached), problems=unbuildable_message(assembly))


def run_job(job: FinsJob, *, progress=None) -> FinsOutcome:
    """Write the job's design file, run it (stage cache in ``folder/out``) and describe the
    result; ``progress(stage, event, info)`` as :meth:`torsal.Design.run`'s.

    Raises :class:`~torsal.core.errors.TorsalError` (bad input, naming the key)."""
    design_path, spec = write_design(job)
    result = Design(spec, source=design_path).run(Path(job.folder) / "out", progress=progress,
                                                  accept_unbuildable=True)
    return outcome_of(result, design_path)


def main(argv: list[str] | None = None) -> int:
    """``python -m torsal.hosts.freecad JOB.json``: run the job, write ``result.json``
    beside it; exit status 0, 2 (bad input) or 1 (a bug)."""
    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        print("usage: python -m torsal.hosts.freecad JOB.json | --live", file=sys.stderr)
        return 2
    path = Path(argv[0])

    def progress(stage, event, info):
        if event in ("start", "done", "cached", "progress"):
            print(json.dumps({"stage": stage, "event": event,
                              **{k: v for k, v in info.items() if isinstance(v, (int, float, str))}}),
                  flush=True)

    try:
        outcome = run_job(FinsJob.read(path), progress=progress)
    except (TorsalError, OSError) as exc:
        print("\n".join([str(exc), *getattr(exc, "__notes__", ())]), file=sys.stderr)
        return 2
    except ValueError as exc:
        if not raised_in_torsal(exc):
            raise
        print(str(exc), file=sys.stderr)
        return 2
    write_json(path.with_name("result.json"), asdict(outcome))
    return 0

