"""The pipeline: the only room that ties the stages together.

- :func:`analyze`: the analysis of one congruence (``torsal analyze``).
- :class:`Design`: a design file run end to end (``torsal design``): congruence
  optimization (4.1), torsal remeshing (4.2), support optimization (eq. 8), optional
  developable refinement (Fig. 10), light measurement and fabrication. Each stage's result
  is cached under ``OUT/.torsal-cache`` by a hash of its inputs, so a changed material re-runs
  only fabrication. Outputs are written atomically; a failing stage raises
  :class:`DesignError` naming the stage and leaves earlier outputs intact.
"""
from __future__ import annotations

import hashlib
import io
import json
import pickle
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from . import __version__
from ._io import atomic_path, write_json
from .design_file import DesignFileError, DesignSpec, Region, load_design_file
from .geometry.congruence import Congruence
from .geometry.mesh import area_vector, edge_face_adjacency, load_mesh, validate_mesh
from torsal.core.errors import TorsalError
from torsal.core.inputs import check_input, read_input

__all__ = ["AnalysisResult", "analyze", "load_directions", "read_directions", "DirectionsError", "Design", "DesignError",
           "DesignFileError", "STAGES"]

#: Pipeline stages in order.
STAGES = ("surface", "sun", "congruence", "remesh", "support", "light", "substructure",
          "fabrication")
_CACHE_VERSION = "1"    # bump when a stage's cached value changes shape
JIT_MIN_VERTICES = 500  # default for constraints.jit (tests run smaller designs interpreted)


# ====================================================================== analyze
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
    if out_dir is not None:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        files["json"] = str(write_json(out / "analysis.json", summary))
        if plot:
            from .report import plot_torsal_field

            files["png"] = str(plot_torsal_field(
                c, out / "torsal_field.png",
                title=f"{mesh_path.name}: {summary['faces']} faces, "
                      f"{100 * summary['hyperbolic_share']:.1f}% hyperbolic"))
    return AnalysisResult(congruence=c, summary=summary, files=files)


# ====================================================================== design
class DesignError(TorsalError, RuntimeError):
    """A pipeline stage failed; ``stage`` names it and the message says why."""

    def __init__(self, stage: str, message: str):
        super().__init__(f"stage '{stage}' failed: {message}")
        self.stage = stage


Progress = Callable[[str, str, dict], None]


def _quiet(stage: str, event: str, info: dict) -> None:
    pass


def _hash(*parts) -> str:
    h = hashlib.sha256()
    for p in parts:
        if isinstance(p, np.ndarray):
            h.update(np.ascontiguousarray(p).tobytes())
            h.update(str(p.shape).encode())
        else:
            h.update(json.dumps(p, sort_keys=True, default=str).encode())
        h.update(b"|")
    return h.hexdigest()[:16]


def _box_mask(region: Region, points: np.ndarray) -> np.ndarray | None:
    """Points inside the region's axis ranges; None when the region gives no range."""
    inside, boxed = np.ones(len(points), bool), False
    for k, name in enumerate("xyz"):
        r = getattr(region, name)
        if r is not None:
            boxed = True
            inside &= (points[:, k] >= r[0]) & (points[:, k] <= r[1])
    return inside if boxed else None


def _indices(idx, n: int, what: str) -> np.ndarray:
    idx = np.asarray(idx, np.int64)
    if idx.size and (idx.min() < 0 or idx.max() >= n):
        raise ValueError(f"region.{what} has indices outside 0..{n - 1}")
    return idx


def select_vertices(region: Region | None, vertices: np.ndarray) -> np.ndarray:
    """Indices of the vertices inside a :class:`Region` (all when ``region`` is None)."""
    n = len(vertices)
    if region is None:
        return np.arange(n)
    mask = _box_mask(region, vertices)
    idx = np.flatnonzero(mask) if mask is not None else np.zeros(0, np.int64)
    if region.vertices is not None:
        idx = np.union1d(idx, _indices(region.vertices, n, "vertices"))
    return idx


def select_faces(region: Region | None, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Indices of the faces whose barycenter is inside a :class:`Region`, listed in
    ``region.faces``, or with all corners in ``region.vertices``."""
    nf = len(faces)
    if region is None:
        return np.arange(nf)
    mask = _box_mask(region, vertices[faces].mean(axis=1))
    idx = np.flatnonzero(mask) if mask is not None else np.zeros(0, np.int64)
    if region.faces is not None:
        idx = np.union1d(idx, _indices(region.faces, nf, "faces"))
    if region.vertices is not None:
        vin = np.zeros(len(vertices), bool)
        vin[_indices(region.vertices, len(vertices), "vertices")] = True
        idx = np.union1d(idx, np.flatnonzero(vin[faces].all(axis=1)))
    return idx


def dominant_light_direction(d: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The one design light direction for f_perp from many weighted directions, (3,) unit.

    The eigenvector of ``M = sum_k w_k d_k d_k^T`` with the largest eigenvalue: the direction
    that carries most of ``sum_k w_k <e, d_k>^2``, signed like the weighted mean. The paper
    uses one light direction per goal (4.3); making the lines orthogonal to the whole span of
    a sun path instead would force them parallel to M's weakest eigenvector, a parallel
    bundle without torsal directions.
    """
    d = np.asarray(d, float)
    w = np.asarray(w, float)
    M = (d * w[:, None]).T @ d
    q = np.linalg.eigh(M)[1][:, -1]
    return q if q @ (d * w[:, None]).sum(0) >= 0 else -q


@dataclass
class DesignResult:
    """What a design run produced: the report (as in report.json) and the files written."""

    report: dict
    files: dict = field(default_factory=dict)
    stage_seconds: dict = field(default_factory=dict)
    cached: list = field(default_factory=list)


class Design:
    """A design file and the pipeline that builds it.

    Examples
    --------
    >>> d = Design.from_toml("examples/7a_facade_block.toml")  # doctest: +SKIP
    >>> result = d.run("out/7a")                                # doctest: +SKIP
    >>> result.report["support"]["delta_pl_optimized"] <= 1e-4  # doctest: +SKIP
    True
    """

    def __init__(self, spec: DesignSpec, *, source: str | Path | None = None):
        self.spec = spec
        self.source = Path(source) if source else None

    @classmethod
    def from_toml(cls, path: str | Path) -> "Design":
        """Read and validate a design file (see :mod:`torsal.design_file`)."""
        return cls(load_design_file(path), source=path)

    # ------------------------------------------------------------------ stages
    def _surface(self):
        s = self.spec.surface
        if s.mesh is not None:
            m = load_mesh(s.mesh)
            return np.asarray(m.vertices, float), np.asarray(m.faces, np.int64)
        from .geometry import surfaces

        try:
            v, f = surfaces.GENERATORS[s.generator](**s.params)
        except TypeError as exc:
            raise ValueError(f"surface.params do not fit generator '{s.generator}': {exc}") from None
        validate_mesh(v, f)
        return v, f

    def _sun(self):
        s, site = self.spec.sun, self.spec.site
        from .light import sun as sunmod

        if s.vectors is not None:
            vec = np.asarray(s.vectors, float)
            vec /= np.linalg.norm(vec, axis=1, keepdims=True)
            return vec, np.ones(len(vec))
        if s.epw is not None:
            north = site.north_angle if site else 0.0
            res = sunmod.hot_hours(s.epw, s.min_temperature, s.min_dni, north_angle=north,
                                   months=s.months, hours=tuple(s.hours))
        else:
            res = sunmod.sun_path(site.latitude, site.longitude, str(s.start), str(s.end),
                                  timezone=site.timezone, hours=tuple(s.hours), freq=s.step,
                                  months=s.months, elevation=site.elevation,
                                  north_angle=site.north_angle)
        keep = np.asarray(res.above_horizon, bool)
        vec = np.asarray(res.vectors)[keep]
        w = np.asarray(res.weights)[keep] if res.weights is not None else np.ones(keep.sum())
        if len(vec) == 0:
            raise ValueError("no sun above the horizon in the given dates and hours; widen sun.hours "
                             "or the date range")
        return vec, w

    def _congruence_problem(self, v, f, sun, w_sun):
        from .geometry.optimize import CongruenceProblem

        spec, W = self.spec, self.spec.weights
        c0 = Congruence.from_normals((v, f))
        weights = {k: val for k, val in W.model_dump().items() if val is not None}
        rename = {"norm": "normal", "perp": "perpendicular", "par": "parallel",
                  "plane": "torsal_plane", "dir": "torsal_direction", "through": "through_points"}
        weights = {rename.get(k, k): val for k, val in weights.items()}
        C = spec.constraints
        # compiled kernels pay back their one-off compile time (about a second each, cached
        # per machine) on paper-sized surfaces; small studies start faster interpreted
        jit = C.jit if C.jit is not None else len(v) >= JIT_MIN_VERTICES
        p = CongruenceProblem(c0, jit=jit)
        wget = weights.get
        if wget("normal", 2.0) > 0:
            p.normal(weight=wget("normal", 2.0))
        if wget("fair", 1.0) > 0:
            p.fair(weight=wget("fair", 1.0))
        if wget("fair_torsal"):
            p.fair_torsal(weight=wget("fair_torsal"))
        g = spec.goals
        light = -sun  # light travels from the sun
        through = select_vertices(g.let_through, v) if g.let_through is not None else np.zeros(0, int)
        blocked_v = np.setdiff1d(np.arange(len(v)), through)
        d_main = dominant_light_direction(light, w_sun)
        if g.block and blocked_v.size and not g.sun_regions:
            p.perpendicular(d_main, vertices=blocked_v, weight=wget("perpendicular", 10.0))
        if through.size:
            p.parallel(d_main, vertices=through, weight=wget("parallel", 0.2))
        for k, st in enumerate(g.see_through):
            idx = select_vertices(st.region, v)
            if idx.size == 0:
                raise ValueError(f"goals.see_through[{k}].region contains no vertex")
            p.through_points(np.tile(st.target, (idx.size, 1)), vertices=idx,
                             weight=wget("through_points"), name=f"through_points_{k}")
        faces_dir, seg_dir = self._stroke_faces(v, f)
        if faces_dir.size:
            p.torsal_direction(faces_dir, seg_dir, weight=wget("torsal_direction", 0.1))
        for k, sr in enumerate(g.sun_regions):
            fi = select_faces(sr.region, v, f)
            if fi.size == 0:
                raise ValueError(f"goals.sun_regions[{k}].region contains no face")
            d = np.asarray(sr.vectors, float)
            d = -(d / np.linalg.norm(d, axis=1, keepdims=True)).mean(0)
            p.torsal_plane(fi, normals=d / np.linalg.norm(d), weight=wget("torsal_plane", 20.0),
                           name=f"torsal_plane_{k}")
        if g.reflect is not None:
            from .light.shading import mirror_normals

            fi = select_faces(g.reflect.region, v, f)
            bc = v[f[fi]].mean(axis=1)
            out = np.asarray(g.reflect.target, float) - bc
            n = mirror_normals(np.tile(d_main, (len(fi), 1)), out / np.linalg.norm(out, axis=1, keepdims=True))
            p.torsal_plane(fi, normals=n, weight=wget("torsal_plane", 5000.0), name="reflect")
        if wget("closeness"):
            p.closeness(weight=wget("closeness"))
        if C.hyperbolic:
            p.hyperbolic(margin=C.hyperbolic_margin)
        if C.min_torsal_angle is not None:
            p.min_torsal_angle(C.min_torsal_angle)
        if spec.substructure is not None:
            # Fig. 11: a second congruence behind A, optimized together with the first so that
            # their torsal directions coincide (f_extra)
            sub = spec.substructure
            v2 = v - sub.offset * c0.directions
            q = CongruenceProblem(Congruence.from_normals((v2, f)), jit=jit)
            q.normal(weight=wget("normal", 2.0)).fair(weight=wget("fair", 1.0))
            if C.hyperbolic:
                q.hyperbolic(margin=C.hyperbolic_margin)
            p.align_with(q, weight=sub.weight, label="substructure")
        return p

    def _stroke_faces(self, v, f):
        """Faces and stroke directions for f_dir: designer strokes and, for
        ``boundary_aligned``, the boundary edges (Fig. 7a/7b)."""
        g = self.spec.goals
        bc = v[f].mean(axis=1)
        faces, dirs = [], []
        from .geometry.mesh import average_edge_length

        delta = average_edge_length(v, f)
        for k, st in enumerate(g.strokes):
            pts = np.asarray(st.points, float)
            width = st.width or 1.5 * delta
            seg_a, seg_b = pts[:-1], pts[1:]
            d = seg_b - seg_a
            L2 = (d * d).sum(1)
            t = np.clip(((bc[:, None, :] - seg_a[None]) * d[None]).sum(2) / L2[None], 0, 1)
            closest = seg_a[None] + t[..., None] * d[None]
            dist = np.linalg.norm(bc[:, None, :] - closest, axis=2)
            j = dist.argmin(axis=1)
            near = np.flatnonzero(dist[np.arange(len(bc)), j] <= width)
            if near.size == 0:
                raise ValueError(f"goals.strokes[{k}] passes no face of the surface (within {width:.3g})")
            faces.append(near)
            dirs.append(d[j[near]])
        if g.boundary_aligned:
            # the face on each boundary edge follows the edge
            edges, edge_faces = edge_face_adjacency(f)
            on_boundary = edge_faces[:, 1] < 0
            fe_dirs = np.zeros((len(f), 3))
            fe_dirs[edge_faces[on_boundary, 0]] = (v[edges[on_boundary, 1]]
                                                   - v[edges[on_boundary, 0]])
            idx = np.unique(edge_faces[on_boundary, 0])
            faces.append(idx)
            dirs.append(fe_dirs[idx])
        if not faces:
            return np.zeros(0, np.int64), np.zeros((0, 3))
        fi = np.concatenate(faces)
        di = np.concatenate(dirs)
        fi, first = np.unique(fi, return_index=True)
        return fi, di[first]

    # ------------------------------------------------------------------ run
    def run(self, out_dir: str | Path, *, progress: Progress | None = None,
            use_cache: bool = True) -> DesignResult:
        """Run every stage and write all outputs into ``out_dir``.

        Parameters
        ----------
        out_dir : path
        progress : callable(stage, event, info), optional
            Told ``("congruence", "start", {})``, ``("congruence", "iteration", {...})``,
            ``(stage, "done", {"seconds": ..})`` or ``(stage, "cached", {})``.
        use_cache : bool
            Reuse stage results whose inputs did not change.

        Raises
        ------
        DesignError
            Naming the stage that failed.
        """
        from .report import write_design_report

        progress = progress or _quiet
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        cache_dir = out / ".torsal-cache"
        cache_dir.mkdir(exist_ok=True)
        spec = self.spec
        res = DesignResult(report={"name": spec.name, "units": spec.units})

        def stage(name: str, key_parts: tuple, fn: Callable[[], dict]) -> dict:
            # the package version is part of the key: results of an older torsal are recomputed
            key = _hash(_CACHE_VERSION, __version__, name, *key_parts)
            path = cache_dir / f"{name}-{key}.pkl"
            if use_cache and path.exists():
                try:
                    with open(path, "rb") as fh:
                        value = pickle.load(fh)
                    progress(name, "cached", {})
                    res.cached.append(name)
                    return value | {"_key": key}
                except Exception:  # a stale or broken cache file is just recomputed
                    path.unlink(missing_ok=True)
            progress(name, "start", {})
            t0 = time.perf_counter()
            try:
                value = fn()
            except DesignError:
                raise
            except Exception as exc:
                raise DesignError(name, f"{type(exc).__name__}: {exc}") from exc
            res.stage_seconds[name] = time.perf_counter() - t0
            with atomic_path(path) as tmp:
                with open(tmp, "wb") as fh:
                    pickle.dump(value, fh)
            for old in cache_dir.glob(f"{name}-*.pkl"):
                if old != path:
                    old.unlink(missing_ok=True)
            progress(name, "done", {"seconds": res.stage_seconds[name]})
            return value | {"_key": key}

        surf = stage("surface", (spec.surface.model_dump(mode="json"),),
                     lambda: dict(zip(("vertices", "faces"), self._surface())))
        v, f = surf["vertices"], surf["faces"]
        sun = stage("sun", (spec.sun.model_dump(mode="json"),
                            spec.site.model_dump(mode="json") if spec.site else None),
                    lambda: dict(zip(("vectors", "weights"), self._sun())))
        # fins stand on the sun side of A: orient A's normals (and so the initial lines) there
        flipped = bool(area_vector(v, f) @ (sun["vectors"] * sun["weights"][:, None]).sum(0) < 0)
        if flipped:
            f = f[:, ::-1].copy()
        res.report["surface"] = {"vertices": int(len(v)), "faces": int(len(f)),
                                 "flipped_to_face_the_sun": flipped}

        def run_congruence():
            p = self._congruence_problem(v, f, sun["vectors"], sun["weights"])

            def cb(info):
                progress("congruence", "iteration", info)

            # constraints met to 1e-4 are met for a building (unit length to 0.01%, c_hyp to
            # rounding of the design's scale); IPOPT's "acceptable level" often lands at ~1e-6
            r = p.solve(max_iter=spec.constraints.max_iter, callback=cb, constraint_tol=1e-4)
            c = r.congruence
            feasible = c is not None and all(x <= 1e-4 for x in r.max_violation.values())
            if not r.success and not (feasible and "Maximum_Iterations" in r.status):
                raise ValueError(
                    f"the congruence optimization did not converge ({r.status}); worst constraint: "
                    f"{max(r.max_violation, key=r.max_violation.get) if r.max_violation else 'none'}. "
                    "Relax [constraints] (e.g. min_torsal_angle) or raise constraints.max_iter")
            extra = {}
            if len(r.congruences) > 1:
                c2 = r.congruences[1]
                extra = {"substructure_vertices": np.asarray(c2.vertices),
                         "substructure_directions": np.asarray(c2.directions)}
            return {
                **extra,
                "directions": np.asarray(c.directions),
                "report": {
                    "vertices": int(len(v)), "faces": int(len(f)),
                    "build_s": float(r.build_seconds), "solve_s": float(r.solve_seconds),
                    "status": str(r.status), "iterations": int(r.iterations),
                    "energies": {k: float(x) for k, x in r.energies_after.items()},
                    "energies_before": {k: float(x) for k, x in r.energies_before.items()},
                    "max_violation": {k: float(x) for k, x in r.max_violation.items()},
                    # False: the solve without the inequality constraints already met them
                    "constraints_active": r.constraints_active,
                    # elements IPOPT imposed the inequalities on (None: all of them, or none
                    # needed); the others held with slack
                    "working_set": None if r.working_set is None
                    else {k: int(len(x)) for k, x in r.working_set.items()},
                    "min_hyperbolicity": float(np.nanmin(c.hyperbolicity())),
                    "min_torsal_angle_deg": float(np.nanmin(c.torsal_angle()))
                    if np.isfinite(c.torsal_angle()).any() else None,
                    "hyperbolic_share": float(c.is_hyperbolic().mean()),
                },
            }

        cong = stage("congruence", (surf["_key"], sun["_key"], spec.goals.model_dump(mode="json"),
                                    spec.weights.model_dump(), spec.constraints.model_dump()),
                     run_congruence)
        congruence = Congruence(v, f, cong["directions"])
        res.report["congruence"] = cong["report"]

        def run_remesh():
            from .geometry.remesh import remesh_torsal

            s = remesh_torsal(congruence, spec.fins.spacing)
            e = s.vertices_b - s.vertices_a
            s.vertices_b = s.vertices_a + spec.fins.depth * e / np.linalg.norm(e, axis=1, keepdims=True)
            return {"structure": s, "delta_pl": s.delta_pl}

        rem = stage("remesh", (cong["_key"], spec.fins.spacing, spec.fins.depth), run_remesh)

        def run_support():
            s = rem["structure"]
            t0 = time.perf_counter()
            if spec.fins.optimize:
                from .geometry.support import optimize_support

                r = optimize_support(s, reference=(v, f))
                if r.structure.delta_pl > spec.fins.planarity_tol:
                    # the soft energy was not enough: make planarity a hard constraint
                    r = optimize_support(r.structure, reference=(v, f), hard_tol=spec.fins.planarity_tol)
                s, status, ok = r.structure, str(r.status), bool(r.success)
            else:
                status, ok = "not optimized (fins.optimize = false)", True
            solve_s = time.perf_counter() - t0
            if spec.fins.developable_levels:
                from .geometry.developable import refine_developable

                s = refine_developable(s, spec.fins.developable_levels)
            return {"structure": s, "report": {
                "quads": int(sum(len(p) == 4 for p in s.faces)), "faces": int(len(s.faces)),
                "edges": int(len(s.edges)), "nodes": int(len(s.vertices_a)),
                "delta_pl_extracted": float(rem["delta_pl"]),
                "delta_pl_optimized": float(s.delta_pl), "solve_s": float(solve_s),
                "status": status, "success": ok}}

        sup = stage("support", (rem["_key"], spec.fins.model_dump()), run_support)
        structure = sup["structure"]
        res.report["support"] = sup["report"]

        def run_light():
            from .light import direct_sun_blocked, horizontal_louvers, transparency

            fins = structure.fin_mesh()
            n = spec.outputs.light_samples
            blocked = direct_sun_blocked(fins, (v, f), sun["vectors"], samples=n,
                                         weights=sun["weights"])
            clear = transparency(fins, (v, f), samples=n // 2)
            louvers = horizontal_louvers(v, f, spec.fins.depth, spec.fins.spacing)
            lb = direct_sun_blocked(louvers, (v, f), sun["vectors"], samples=n, weights=sun["weights"])
            lt = transparency(louvers, (v, f), samples=n // 2)
            extra = {}
            if spec.goals.reflect is not None:
                from .light import reflected_hits

                extra["reflected_to_target"] = float(reflected_hits(
                    fins, sun["vectors"], _target_patch(spec.goals.reflect.target, v),
                    weights=sun["weights"], resolution=128).share)
            return {"report": {
                **extra,
                "sun_directions": int(len(sun["vectors"])),
                "blocked_share": float(blocked.share),
                "transparency": float(clear.along_normal),
                "transparency_cone": float(clear.cone),
                "baseline_louvers": {"blocked_share": float(lb.share),
                                     "transparency": float(lt.along_normal),
                                     "transparency_cone": float(lt.cone)}},
                "map": {"points": blocked.points, "per_point": blocked.per_point}}

        light = stage("light", (sup["_key"], sun["_key"], spec.outputs.light_samples), run_light)
        res.report["light"] = light["report"]

        substructure = None
        if "substructure_directions" in cong:
            def run_substructure():
                from .geometry.remesh import remesh_torsal
                from .geometry.support import optimize_support

                v2 = cong["substructure_vertices"]
                c2 = Congruence(v2, f, cong["substructure_directions"])
                s2 = remesh_torsal(c2, spec.fins.spacing)
                e = s2.vertices_b - s2.vertices_a
                s2.vertices_b = s2.vertices_a + spec.substructure.depth * e / np.linalg.norm(
                    e, axis=1, keepdims=True)
                extracted = s2.delta_pl
                r2 = optimize_support(s2, reference=(v2, f))
                return {"structure": r2.structure, "report": {
                    "edges": int(len(r2.structure.edges)),
                    "delta_pl_extracted": float(extracted),
                    "delta_pl_optimized": float(r2.structure.delta_pl)}}

            sub = stage("substructure", (cong["_key"], spec.fins.model_dump(),
                                         spec.substructure.model_dump()), run_substructure)
            substructure = sub["structure"]
            res.report["substructure"] = sub["report"]

        files: dict = {}

        def run_fabrication():
            from .fabrication import FinSystem

            m = spec.material
            fs = FinSystem(structure, m.thickness_mm, family_split=m.family_split.value,
                           clearance=m.clearance_mm, fit_sheet=tuple(m.sheet_mm),
                           model_unit=spec.units, unit="mm")
            written = {}
            if spec.outputs.step:
                fs.export_step(out / "fins.step")
                written["step"] = "fins.step"
            if spec.outputs.rhino_3dm:
                fs.export_3dm(out / "fins.3dm")
                written["3dm"] = "fins.3dm"
            layout = fs.layout(sheet=tuple(m.sheet_mm), gap=m.gap_mm)
            if spec.outputs.dxf:
                paths = layout.export_dxf(out / "sheets" / "fins.dxf")
                written["dxf"] = [str(Path(p).relative_to(out)) for p in paths]
            if spec.outputs.bom:
                fs.bill_of_materials(out / "parts.csv", density=m.density, layout=layout)
                written["bom"] = "parts.csv"
            return {"report": {
                "parts": int(len(fs.parts)), "panels": int(fs.n_panels),
                "sheets": int(layout.n_sheets),
                "utilization": float(layout.utilization),
                "step": written.get("step"), "dxf": written.get("dxf"),
                "files": written}, "layout": layout}

        fab_key = (sup["_key"], spec.material.model_dump(mode="json"), spec.outputs.model_dump(),
                   spec.units)
        fab = stage("fabrication", fab_key, run_fabrication)
        missing = [p for p in _flat(fab["report"]["files"]) if not (out / p).exists()]
        if missing:  # outputs deleted since the cached run: make them again
            (cache_dir / f"fabrication-{fab['_key']}.pkl").unlink(missing_ok=True)
            fab = stage("fabrication", fab_key, run_fabrication)
        res.report["fabrication"] = {k: x for k, x in fab["report"].items() if k != "files"}
        files.update(fab["report"]["files"])

        # geometry outputs and the report are cheap: always written fresh
        files.update(_write_geometry(out, congruence, structure))
        if substructure is not None:
            _write_structure_obj(out / "substructure.obj", substructure)
            files["substructure"] = "substructure.obj"
        write_json(out / "report.json", res.report)
        files["report_json"] = "report.json"
        if spec.outputs.renders:
            files.update(write_design_report(out, self.spec, res.report, congruence, structure,
                                             light["map"], (v, f), fab.get("layout")))
        res.files = files
        return res


def _target_patch(target, vertices, size: float | None = None):
    """A horizontal square around a reflection target (a patch of ceiling), as a trimesh;
    its side is a third of the surface's extent unless given."""
    import trimesh

    t = np.asarray(target, float)
    h = 0.5 * (size or np.ptp(vertices, axis=0).max() / 3.0)
    corners = t + np.array([[-h, -h, 0], [h, -h, 0], [h, h, 0], [-h, h, 0]])
    return trimesh.Trimesh(corners, [[0, 1, 2], [0, 2, 3]], process=False)


def _flat(x):
    if isinstance(x, (list, tuple)):
        for y in x:
            yield from _flat(y)
    elif isinstance(x, dict):
        for y in x.values():
            yield from _flat(y)
    elif x:
        yield x


def _write_geometry(out: Path, congruence: Congruence, structure) -> dict:
    """The optimized congruence as PLY (vertex directions as properties ex, ey, ez) and the
    support structure as OBJ (groups A, B and fins)."""
    v, f, e = congruence.vertices, congruence.faces, congruence.directions
    lines = ["ply", "format ascii 1.0", "comment torsal line congruence: lines a_i + t e_i",
             f"element vertex {len(v)}", "property double x", "property double y", "property double z",
             "property double ex", "property double ey", "property double ez",
             f"element face {len(f)}", "property list uchar int vertex_indices", "end_header"]
    lines += [" ".join(f"{x:.12g}" for x in row) for row in np.c_[v, e]]
    lines += [f"3 {a} {b} {c}" for a, b, c in f]
    with atomic_path(out / "congruence.ply") as tmp:
        tmp.write_text("\n".join(lines) + "\n")
    _write_structure_obj(out / "support.obj", structure)
    return {"congruence": "congruence.ply", "support": "support.obj"}


def _write_structure_obj(path: Path, s) -> None:
    """A support structure as OBJ: groups A (nodes on the surface), B, and the fins of
    each family (one quad per edge)."""
    n = len(s.vertices_a)
    obj = ["# torsal support structure: A~ (nodes on the surface), B~, one fin quad per edge"]
    obj += [f"v {x:.12g} {y:.12g} {z:.12g}" for x, y, z in s.vertices_a]
    obj += [f"v {x:.12g} {y:.12g} {z:.12g}" for x, y, z in s.vertices_b]
    obj.append("g A")
    obj += ["f " + " ".join(str(i + 1) for i in poly) for poly in s.faces]
    obj.append("g B")
    obj += ["f " + " ".join(str(i + 1 + n) for i in poly) for poly in s.faces]
    for fam in (0, 1):
        obj.append(f"g fins_family_{fam}")
        for i, j in s.edges[s.edge_family == fam]:
            obj.append(f"f {i + 1} {j + 1} {j + 1 + n} {i + 1 + n}")
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(obj) + "\n")
