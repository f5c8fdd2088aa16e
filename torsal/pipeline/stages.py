"""The stages of a design run, in order, as plain functions of their declared inputs.

Each function takes a :class:`~torsal.pipeline.stage.StageInputs` and returns a dict; the
keys each one returns are listed in its docstring. :data:`DEFAULT_PIPELINE` strings them
together; insert a stage with ``DEFAULT_PIPELINE.insert(stage, after="fabrication")``.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .design_file import DesignSpec
from ..geometry.congruence import Congruence, direction_spread
from ..geometry.optimize import TorsalAngleBetween
from ..geometry.mesh import area_vector, load_mesh, validate_mesh
from ..geometry.support import per_family
from .annual import annual_applies, annual_key, check_weather_site, run_annual
from .assembly import MAX_CROSSING_FOLD, congruence_gate, run_assembly, support_gate
from ..fabrication.nesting.background import write_sheets
from .fins import fabrication_summary, fin_system
from .measure import devices_key, measure_fins, run_devices, sun_goals
from .outputs import target_patch, write_geometry, write_structure_obj
from .quantities import quantities_report
from .errors import DesignError
from .stage import Pipeline, Stage, StageInputs

__all__ = ["surface_mesh", "sun_directions", "run_surface", "run_estimate", "run_sun", "run_orient",
           "run_congruence", "run_remesh", "run_support", "measure_fins", "run_light", "run_substructure",
           "run_fabrication", "run_pictures", "run_report", "DEFAULT_PIPELINE", "STAGES", "fin_system",
           "run_assembly", "run_devices"]

# constraints met to 1e-4 are met for a building (unit length to 0.01%, c_hyp to rounding of
# the design's scale); IPOPT's "acceptable level" often lands at ~1e-6
CONSTRAINT_TOL = 1e-4


# ------------------------------------------------------------------ surface and sun
def surface_mesh(spec: DesignSpec, *, report: bool = False):
    """Mesh A of a design: vertices (n, 3) in model units and triangles (m, 3); with
    ``report``, also how a mesh file's vertices were merged (a dict, None for a generator)."""
    s = spec.surface
    if s.mesh is not None:
        m = load_mesh(s.mesh)
        v, f = np.asarray(m.vertices, float), np.asarray(m.faces, np.int64)
        return (v, f, m.metadata["merge"].as_dict()) if report else (v, f)
    from ..geometry import surfaces

    try:
        v, f = surfaces.GENERATORS[s.generator](**s.params)
    except TypeError as exc:
        raise ValueError(f"surface.params do not fit generator '{s.generator}': {exc}") from None
    validate_mesh(v, f)
    return (v, f, None) if report else (v, f)


def sun_directions(spec: DesignSpec) -> tuple[np.ndarray, np.ndarray]:
    """Unit sun vectors (k, 3), site -> sun in the model frame, and their weights (k,):
    explicit vectors, the hot hours of a weather file (EPW, TMY3 or TMY2; refused when its
    place is far from ``[site]``, :func:`~torsal.pipeline.annual.check_weather_site`), or a
    pvlib sun path."""
    s, site = spec.sun, spec.site
    from ..light import sun as sunmod

    if s.vectors is not None:
        vec = np.asarray(s.vectors, float)
        length = np.linalg.norm(vec, axis=1, keepdims=True)
        if len(vec) == 0 or not np.all(length > 0):  # the design file rejects these already
            raise DesignError("sun", "sun vectors must be non-empty and of non-zero length",
                              key="sun.vectors", value=s.vectors)
        return vec / length, np.ones(len(vec))
    if s.weather_file is not None:
        north = site.north_angle if site else 0.0
        path = s.weather_file
        try:
            weather = sunmod.read_weather(path)
        except sunmod.WeatherFileError as exc:
            raise DesignError("sun", str(exc).removeprefix(f"{path}: "), key=s.weather_key,
                              value=str(path)) from None
        meta = weather[1]
        check_weather_site(spec, meta["latitude"], meta["longitude"], meta.get("name", ""),
                           stage="sun")
        res = sunmod.hot_hours(path, s.min_temperature, s.min_dni, north_angle=north,
                               months=s.months, hours=tuple(s.hours), weather=weather)
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


def run_surface(inp: StageInputs) -> dict:
    """Mesh A as given, checked for the optimizer (:func:`~torsal.pipeline.checks.check_surface`).
    Returns ``vertices`` (n, 3), ``faces`` (m, 3) and, for a mesh file, ``mesh_file`` (how the
    file's vertices were merged, :meth:`~torsal.geometry.mesh.MeshMerge.as_dict`)."""
    from ..geometry.mesh import MeshError
    from .checks import check_surface

    s = inp.spec.surface
    key, value = ("surface.mesh", str(s.mesh)) if s.mesh is not None else \
        ("surface.params", dict(s.params))
    try:
        v, f, merge = surface_mesh(inp.spec, report=True)
    except MeshError as exc:
        raise DesignError("surface", str(exc), key=key, value=value) from None
    check_surface(v, f, key=key, value=value)
    return {"vertices": v, "faces": f, "mesh_file": merge}


def run_estimate(inp: StageInputs, *, enforce: bool = True) -> dict:
    """The run's size from the design file and mesh A (:func:`~torsal.pipeline.checks.estimate_size`);
    above :data:`~torsal.pipeline.checks.SIZE_LIMITS` it stops the run (``enforce``). Returns
    the ``report`` section."""
    from .checks import check_size, estimate_size

    est = estimate_size(inp.spec, inp["surface"]["vertices"], inp["surface"]["faces"])
    if enforce:
        check_size(est)
    return {"report": est.as_dict()}


def run_sun(inp: StageInputs) -> dict:
    """Returns ``vectors`` (k, 3) site -> sun, ``weights`` (k,)."""
    vec, w = sun_directions(inp.spec)
    return {"vectors": vec, "weights": w}


def run_orient(inp: StageInputs) -> dict:
    """Mesh A oriented so its normals (and so the initial lines) face the sun: the fins
    stand on the sun side. Returns ``vertices``, ``faces`` (flipped if needed) and the
    ``surface`` report section."""
    v, f = inp["surface"]["vertices"], inp["surface"]["faces"]
    sun = inp["sun"]
    flipped = bool(area_vector(v, f) @ (sun["vectors"] * sun["weights"][:, None]).sum(0) < 0)
    if flipped:
        f = f[:, ::-1].copy()
    mesh_file = inp["surface"].get("mesh_file")
    return {"vertices": v, "faces": f, "report": {
        "vertices": int(len(v)), "faces": int(len(f)), "flipped_to_face_the_sun": flipped,
        **({"mesh_file": mesh_file} if mesh_file else {})}}


# ------------------------------------------------------------------ congruence (4.1)
def run_congruence(inp: StageInputs, *, make_problem=None, solve_options: dict | None = None) -> dict:
    """Optimize the congruence (eq. 9; the augmented Lagrangian or IPOPT, ``constraints.solver``).
    Returns ``directions`` (n, 3), ``optimum`` (the warm start of a re-solve), the
    ``report`` section, and with a ``[substructure]`` ``substructure_vertices`` /
    ``substructure_directions`` (n, 3).

    ``make_problem(spec, vertices, faces, sun_vectors, sun_weights)``: the problem to solve,
    default :func:`~torsal.pipeline.problem.congruence_problem`; a live session
    (:class:`torsal.session.Session`) passes one that re-uses its built problem and warm-starts
    it from the last optimum. ``solve_options``: more :meth:`CongruenceProblem.solve
    <torsal.geometry.optimize.CongruenceProblem.solve>` options (e.g. ``stop``, ``tol``; none:
    the optimizer's defaults, the design tolerance): ``benchmarks/optimize_bench.py --tables
    stop`` runs the stage to convergence beside the default."""
    from .problem import congruence_problem

    spec = inp.spec
    v, f = inp["orient"]["vertices"], inp["orient"]["faces"]
    sun = inp["sun"]
    p = (make_problem or congruence_problem)(spec, v, f, sun["vectors"], sun["weights"])
    C = spec.constraints
    r = p.solve(solver=C.solver.value, certify=C.certify, max_iter=C.max_iter, max_seconds=C.max_seconds,
                callback=lambda info: inp.progress("iteration", info),
                constraint_tol=CONSTRAINT_TOL, **(solve_options or {}))
    c = r.congruence
    # a design is usable when every constraint holds as measured on its geometry (angles
    # within 0.1 degree, see OptimizationResult.max_violation), converged or not
    if not (r.success or r.feasible):
        raise ValueError(
            f"the congruence optimization did not converge ({r.status}); worst constraint: "
            f"{max(r.max_violation, key=r.max_violation.get) if r.max_violation else 'none'}. "
            "Relax [constraints] (e.g. min_torsal_angle) or raise constraints.max_iter")
    extra, extra_report = {}, {}
    if len(r.congruences) > 1:
        c2 = r.congruences[1]
        extra = {"substructure_vertices": np.asarray(c2.vertices),
                 "substructure_directions": np.asarray(c2.directions)}
        extra_report = {"substructure_line_spread_deg": _spread(c2)}
    return {
        **extra,
        "directions": np.asarray(c.directions),
        # the optimum with its multipliers and penalties: a warm re-solve after a small change
        # (CongruenceProblem.warm_start_from), kept in the stage cache's entry
        "optimum": p.optimum,
        "report": {
            "vertices": int(len(v)), "faces": int(len(f)),
            "build_s": float(r.build_seconds), "solve_s": float(r.solve_seconds),
            "status": str(r.status), "iterations": int(r.iterations),
            # which solver produced the design, the seconds of each part, and the counts
            # (Newton steps, factorizations) that decide the result instead of time
            "solver": str(r.solver),
            "timings_s": {k: float(x) for k, x in r.timings.items()},
            "counts": {k: (x if isinstance(x, str) else int(x)) for k, x in r.counts.items()},
            # True: the safety net constraints.max_seconds cut the solve (load-dependent)
            "time_limited": bool(r.time_limited),
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
            # both readings of c_ang, measured, and which one constraints.min_torsal_angle bounds
            **_torsal_angles(c, spec.constraints),
            "hyperbolic_share": float(c.is_hyperbolic().mean()),
            # measured on the geometry, not the NLP: each constraint's bound, worst value and
            # the faces (vertices) that miss it by more than its tolerance
            "constraints": _measured_constraints(r),
            "converged": bool(r.success),
            # how close to converged the design is: the stopping rule (the optimizer's
            # default: the design tolerance), why the solve ended, the last Newton decrement
            # and the objective's relative decrease over the last Newton steps
            "convergence": None if r.convergence is None else r.convergence.as_dict(),
            "faces_without_torsal_directions": int((~np.isfinite(c.torsal_angle())).sum()),
            # the widest angle of a line from the lines' mean direction (degrees): near 0 the
            # optimized lines are nearly parallel, the fins close to plain louvers
            "line_spread_deg": _spread(c), **extra_report,
            # faces where the fins of the two families cross too obliquely to be slotted
            "joinery": congruence_gate(c),
        },
    }


def _spread(c: Congruence) -> float | None:
    """:func:`direction_spread` of the lines in degrees, None where it is undefined (JSON)."""
    x = direction_spread(c.directions)
    return x if np.isfinite(x) else None


def _min_deg(angles: np.ndarray) -> float | None:
    """The smallest finite angle (degrees), None where no face has one (JSON)."""
    return float(np.nanmin(angles)) if np.isfinite(angles).any() else None


def _torsal_angles(c: Congruence, constraints) -> dict:
    """Both torsal angles of the optimized congruence (``report.congruence``), degrees.

    ``min_torsal_plane_angle_deg``: the smallest angle at which the two torsal planes (the
    fins of the two families) cross; ``min_torsal_direction_angle_deg``: the smallest angle
    between the torsal directions in the face (c_ang as Wang et al. 2013, 4.1 state it);
    ``min_torsal_angle_deg``: the plane angle again, under the key earlier reports used;
    ``torsal_angle_between``: which of the two ``constraints.min_torsal_angle`` bounds (None
    without the bound)."""
    plane = _min_deg(c.torsal_plane_angle())
    bounded = constraints.min_torsal_angle is not None
    return {"min_torsal_plane_angle_deg": plane,
            "min_torsal_direction_angle_deg": _min_deg(c.torsal_angle()),
            "min_torsal_angle_deg": plane,
            # a spec copied with model_copy(update=...) is not validated: the value may be a str
            "torsal_angle_between": TorsalAngleBetween(constraints.torsal_angle_between).value
            if bounded else None}


def _measured_constraints(r) -> dict:
    """The measured constraint state of a solve, JSON-ready (``report.congruence.constraints``);
    a torsal-angle bound says which angle it measured (``angle``: ``"planes"`` or
    ``"directions"``)."""
    out = {}
    for name, m in r.measured.items():
        worst_value = (float(m.values.min()) if m.kind in ("torsal_angle", "hyperbolicity")
                       else float(m.values.max())) if m.values.size else None
        out[name] = {"bound": m.bound, "unit": m.unit, "measured": worst_value,
                     "max_violation": m.worst, "tolerance": m.tolerance,
                     "elements_missing": [int(i) for i in m.missed[:50]],
                     "n_missing": int(len(m.missed))}
        if m.between is not None:
            out[name]["angle"] = m.between
    return out


def optimized_congruence(inp: StageInputs) -> Congruence:
    """The optimized congruence over the oriented mesh A (needs inputs orient, congruence)."""
    o = inp["orient"]
    return Congruence(o["vertices"], o["faces"], inp["congruence"]["directions"])


# ------------------------------------------------------------------ support structure (4.2, eq. 8)
def _remesh(congruence: Congruence, spacing, depth):
    """Torsal remeshing (4.2) at ``spacing`` (one for both families or ``(s0, s1)``) with
    fins cut to ``depth`` along their lines (one, or ``(d0, d1)``): the node lines as deep as
    the deeper family, each family's fins reaching its own depth
    (``SupportStructure.family_depth_ratio``)."""
    from ..geometry.remesh import remesh_torsal

    s = remesh_torsal(congruence, spacing)
    d = np.array(per_family(depth, "depth"))
    e = s.vertices_b - s.vertices_a
    s.vertices_b = s.vertices_a + d.max() * e / np.linalg.norm(e, axis=1, keepdims=True)
    s.family_depth_ratio = tuple(float(x) for x in d / d.max())
    return s


def run_remesh(inp: StageInputs) -> dict:
    """Torsal remeshing at each family's fin spacing and depth (``fins.spacing``,
    ``fins.depth``). Returns ``structure`` (SupportStructure) and ``delta_pl`` of the
    extracted structure."""
    fins = inp.spec.fins
    s = _remesh(optimized_congruence(inp), fins.spacings, fins.depths)
    return {"structure": s, "delta_pl": s.delta_pl}


def run_support(inp: StageInputs, *, optimize=None) -> dict:
    """Planarize the fins (eq. 8), soft then hard if needed, and refine to developable
    strips (Fig. 10) if asked. Returns ``structure`` and the ``report`` section.

    ``optimize(structure, *, reference, planarity_tol)``: the planarization, default
    :func:`~torsal.geometry.support.optimize_support`; a live session's preview passes one
    that stops early (:mod:`torsal.session.preview`)."""
    spec = inp.spec
    o = inp["orient"]
    reference = (o["vertices"], o["faces"])
    s = inp["remesh"]["structure"]
    t0 = time.perf_counter()
    if spec.fins.optimize:
        from ..geometry.support import optimize_support

        # soft eq. (8), then planarity as a hard constraint if the soft energy was not enough
        r = (optimize or optimize_support)(s, reference=reference, planarity_tol=spec.fins.planarity_tol)
        s, status, ok = r.structure, str(r.status), bool(r.success)
    else:
        status, ok = "not optimized (fins.optimize = false)", True
    solve_s = time.perf_counter() - t0
    if spec.fins.developable_levels:
        from ..geometry.developable import refine_developable

        s = refine_developable(s, spec.fins.developable_levels)
    return {"structure": s, "report": {
        "quads": int(sum(len(p) == 4 for p in s.faces)), "faces": int(len(s.faces)),
        "edges": int(len(s.edges)), "nodes": int(len(s.vertices_a)),
        "families": family_figures(s, spec),
        "delta_pl_extracted": float(inp["remesh"]["delta_pl"]),
        "delta_pl_optimized": float(s.delta_pl), "solve_s": float(solve_s),
        "status": status, "success": ok,
        # crossings where a strip folds too much to slide through a slot
        "joinery": support_gate(s, spec.fins.max_fold_at_crossing
                                if spec.fins.max_fold_at_crossing is not None
                                else MAX_CROSSING_FOLD)}}


def family_figures(structure, spec: DesignSpec) -> dict:
    """Each torsal family's spacing and depth as asked (model units) and its strips, fins and
    fin area as built into the structure (m^2, one side): what a lighter second family saves.

    Returns ``{"spacing": [s0, s1], "depth": [d0, d1], "strips": [n0, n1], "fins": [e0, e1],
    "fin_area_m2": [A0, A1]}``.
    """
    quads = structure.fin_quads()
    area = 0.5 * (np.linalg.norm(np.cross(quads[:, 2] - quads[:, 0], quads[:, 3] - quads[:, 1]),
                                 axis=1)) * spec.metres_per_unit ** 2
    fam = structure.edge_family
    return {"spacing": list(spec.fins.spacings), "depth": list(spec.fins.depths),
            "strips": [len(structure.strips(f)) for f in (0, 1)],
            "fins": [int((fam == f).sum()) for f in (0, 1)],
            "fin_area_m2": [float(area[fam == f].sum()) for f in (0, 1)]}


# ------------------------------------------------------------------ light
def built_structure(structure, left_out):
    """The support structure without the fins (structure edges) ``left_out`` by the
    fabrication (panels too narrow or lying along the plate they end against): the fins that
    are built. ``structure`` itself when nothing is left out."""
    if not len(left_out):
        return structure
    keep = np.ones(len(structure.edges), bool)
    keep[np.asarray(sorted(left_out), np.int64)] = False
    return type(structure)(structure.vertices_a, structure.vertices_b, structure.faces,
                           structure.edges[keep], structure.edge_family[keep],
                           metadata=dict(structure.metadata),
                           family_depth_ratio=structure.family_depth_ratio)


def run_light(inp: StageInputs) -> dict:
    """Sun blocked over the sun hours and view clear, for the fins as built (without the
    panels the fabrication left out; every fin when the pipeline has no fabrication) and, as
    ``devices``, for the standard devices of the same depth and spacing (the devices stage;
    :func:`measure_fins` for both). Returns the ``report`` section and ``map`` (``points``
    (p, 3), ``per_point`` (p,) blocked share) for the figure."""
    spec = inp.spec
    o, sun = inp["orient"], inp["sun"]
    v, f = o["vertices"], o["faces"]
    left_out = inp["fabrication"].get("left_out_edges", []) if "fabrication" in inp else []
    # the fins as built: panels the fabrication left out neither shade nor reflect
    fins = built_structure(inp["support"]["structure"], left_out).fin_mesh()
    n, m_per_unit = spec.outputs.light_samples, spec.metres_per_unit
    report, blocked = measure_fins(fins, (v, f), sun, n, m_per_unit,
                                   view=spec.view.field(m_per_unit),
                                   view_measure=spec.view.measure.value,
                                   goals=sun_goals(spec, v, f))
    devices = inp["devices"]["measured"]
    lr = devices["horizontal louvers"]
    extra = {}
    if spec.goals.reflect is not None:
        # where the fins as built send the sunlight (Fig. 13); map["reflection"]: the picture
        from .reflection import measure_reflection

        extra["reflection"], picture = measure_reflection(
            spec, built_structure(inp["support"]["structure"], left_out), sun, v,
            metres_per_unit=m_per_unit)
        extra["reflected_to_target"] = extra["reflection"]["on_target"]
    return {"report": {
        **extra,
        "sun_directions": int(len(sun["vectors"])),
        "fins_measured": int(len(inp["support"]["structure"].edges) - len(left_out)),
        **report,
        # kept for readers of earlier reports; on a canopy: not applicable, with the reason
        "baseline_louvers": {k: lr[k] for k in ("blocked_share", "transparency",
                                                 "transparency_cone")} if lr["applicable"]
        else {"applicable": False, "reason": lr["reason"]},
        "devices": devices},
        "map": {"points": blocked.points, "per_point": blocked.per_point,
                **({"reflection": picture} if extra else {})}}


# ------------------------------------------------------------------ substructure (Fig. 11)
def run_substructure(inp: StageInputs) -> dict:
    """The aligned substructure's support structure. Returns ``structure`` and the
    ``report`` section."""
    from ..geometry.support import optimize_support

    spec, cong = inp.spec, inp["congruence"]
    f = inp["orient"]["faces"]
    v2 = cong["substructure_vertices"]
    s2 = _remesh(Congruence(v2, f, cong["substructure_directions"]), spec.fins.spacings,
                 spec.substructure.depth)
    extracted = s2.delta_pl
    r2 = optimize_support(s2, reference=(v2, f))
    return {"structure": r2.structure, "report": {
        "edges": int(len(r2.structure.edges)),
        "delta_pl_extracted": float(extracted),
        "delta_pl_optimized": float(r2.structure.delta_pl)}}


# ------------------------------------------------------------------ fabrication
def _ifc_options(spec: DesignSpec) -> dict:
    """:func:`~torsal.fabrication.ifc.export_ifc` options of the design file: its name, site
    and material."""
    options = {"project": spec.name or "torsal fins", "material": spec.material.name,
               "density": spec.material.density}
    if spec.site is not None:
        options.update(latitude=spec.site.latitude, longitude=spec.site.longitude,
                       elevation=spec.site.elevation, north_angle=spec.site.north_angle)
    return options


def run_fabrication(inp: StageInputs) -> dict:
    """Parts, joints and solids; STEP / 3DM / nested DXF sheets / parts list as the design's
    [outputs] ask. Returns the ``report`` section, ``files`` written and the ``layout``."""
    from ..fabrication import joints_of
    from ..fabrication.assembly import TOUCHING_TOLERANCE, fastenings_of
    from ..fabrication.solids import prepare_workers, release_workers

    spec, out = inp.spec, inp.out
    m = spec.material
    structure = inp["support"]["structure"]
    solids = spec.outputs.step or spec.outputs.rhino_3dm or spec.outputs.ifc
    # the solids (most of the stage's work) are built by worker processes while this one
    # unrolls, nests and writes the sheets; STEP and 3DM collect them afterwards. The
    # workers take seconds to start (each imports OpenCascade): they start while this
    # process builds the parts (about one per fin), and check the seams meanwhile
    # the workers mesh the solids too when the 3DM needs them, and make the assembly check's
    # solids (meshed at its tolerance, with the records of its cheap tests)
    if solids:
        prepare_workers(len(structure.edges), mesh=spec.outputs.rhino_3dm,
                        check=TOUCHING_TOLERANCE)
    written = {}
    try:
        fs = fin_system(spec, structure)
        fs, layout = _final_cut(inp, fs)      # plates split for yield (the final cut only)
        if solids:
            fs.start_solids()
    finally:
        release_workers()          # not taken by start_solids (fewer parts, or an error)
    sheets_path = out / "sheets" / "fins.dxf"
    pending = None
    try:
        # the sheets need only the flat parts: a process of their own nests and writes them
        # (the rows nester) while the workers build the solids and this process writes the
        # solids' files as soon as they come; the final cut's layout is nested here
        if layout is None and solids:
            pending = _start_nest(inp, fs, sheets_path if spec.outputs.dxf else None)
        step = _write_solids(inp, fs) if solids else {}
        sheets = None
        if pending is not None:
            layout, sheets = pending.result(), pending.sheets
        else:
            layout = _nest(inp, fs) if layout is None else layout
            if spec.outputs.dxf:
                sheets = write_sheets(layout, sheets_path)
        if sheets is not None:
            written["dxf"] = [str(Path(p).relative_to(out)) for p in sheets.paths]
        if spec.outputs.bom:
            fs.bill_of_materials(out / "parts.csv", density=m.density, layout=layout)
            written["bom"] = "parts.csv"
        written.update(step)                 # in the order of earlier reports' files
    except BaseException:
        if pending is not None:
            pending.cancel()
        fs.cancel_solids()
        raise
    left_out = ([{"strip": s_, "edge": int(e), "node": int(v), "reason": why}
                 for s_, e, v, why in getattr(fs, "coplanar_panels", [])]
                + [{"strip": s_, "edge": int(e), "node": None,
                    "reason": f"narrower than a plate ({w:.1f} mm)"}
                   for s_, e, w in fs.dropped_panels])
    return {"report": {
        "parts": int(len(fs.parts)), "panels": int(fs.n_panels), **fabrication_summary(fs),
        "sheets": int(layout.n_sheets),
        "utilization": float(layout.utilization),
        "nesting": _nesting_report(layout, sheets),
        "cutting": _cutting_report(layout),
        **quantities_report(spec, fs, layout, structure),   # the bill of quantities, the price
        "panels_left_out": len(left_out), "panels_left_out_list": left_out[:50],
        "step": written.get("step"), "dxf": written.get("dxf")},
        "files": written, "layout": layout,
        # for the light stage: the fins that are not built
        "left_out_edges": sorted({d["edge"] for d in left_out}),
        # for the assembly stage: which parts each joint joins, and along which axis; which
        # parts each bolt and anchor holds (read from the holes: the load path)
        "joints": joints_of(fs), "fastenings": fastenings_of(fs)}


def _write_solids(inp: StageInputs, fs) -> dict:
    """Write the STEP, 3DM and IFC files the design asks for; returns ``{kind: file}``.
    The assembly stage checks the solids these files are written from (the solids' workers
    made its solids with them, :func:`~torsal.fabrication.workers.check_solids`); that the
    STEP file gives those solids back is what its tests prove (tests/fabrication/
    test_step_fidelity.py), not read again on every run."""
    spec, out = inp.spec, inp.out
    written = {}
    # the IFC (seconds of ifcopenshell) is written by a process of its own while this one
    # writes the STEP file; written atomically: a failure leaves no fins.ifc
    ifc = fs.start_ifc(out / "fins.ifc", **_ifc_options(spec)) if spec.outputs.ifc else None
    try:
        if spec.outputs.step:
            fs.export_step(out / "fins.step")
            written["step"] = "fins.step"
        if spec.outputs.rhino_3dm:
            fs.export_3dm(out / "fins.3dm")
            written["3dm"] = "fins.3dm"
        if ifc is not None:
            # the run goes on (the assembly check, the pictures) while its process writes it
            inp.defer(ifc)
            written["ifc"] = "fins.ifc"
    except BaseException:
        if ifc is not None:
            ifc.cancel()
        raise
    return written


def _start_nest(inp: StageInputs, fs, dxf):
    """The design's sheets nested, and written to ``dxf`` (a path, or None), in a process of
    its own (:meth:`~torsal.fabrication.FinSystem.start_layout`: the same layout and files
    as :func:`_nest` and :func:`~torsal.fabrication.nesting.background.write_sheets` here);
    None for the final cut's search, which :func:`_nest` keeps by the parts' content."""
    from ..fabrication.nesting import Nester

    options = nest_options(inp.spec, fs.unit)
    if options["nester"] == Nester.SEARCH:
        return None

    def progress(done, left):
        inp.progress("progress", {"phase": "nesting sheets", "done": done, "total": done + left})

    return fs.start_layout(progress=progress, dxf=dxf, **options)


def nest_options(spec: DesignSpec, unit: str) -> dict:
    """:func:`~torsal.fabrication.nesting.nest_parts` options of the design file: its sheet,
    [cutting] process and [nesting] keys; the nester is the rows, or the search for the final
    cut (``nesting.final_cut``), unless ``nesting.nester`` names one."""
    from ..fabrication.cutting import Cutting
    from ..fabrication.nesting import DEFAULT_NESTER, FINAL_CUT_NESTER, Nester

    m, c, n = spec.material, spec.cutting, spec.nesting
    cutting = Cutting.for_process(c.process, kerf_mm=c.kerf_mm, tool_diameter_mm=c.tool_diameter_mm,
                                  relief=c.relief, unit=unit)
    # the final cut nests for yield: the search, also where the design names the rows (its
    # every run's nester; example 9) but not a nester of its own choice for yield
    nester = (FINAL_CUT_NESTER if n.final_cut and n.nester in (None, Nester.ROWS) else
              n.nester or DEFAULT_NESTER)
    return dict(sheet=tuple(m.sheet_mm), gap=m.gap_mm, margin=n.margin_mm, cutting=cutting,
                nester=nester, time_limit=n.time_limit_s, seed=n.seed, tries=n.tries,
                rotation_step=n.rotation_step_deg)


#: the version of the final cut's splits: a memo of an earlier one is not read back
_FINAL_CUT_VERSION = 1


def _final_cut(inp: StageInputs, fs):
    """``(fin system, layout)``: with ``nesting.final_cut`` and the search, the final cut
    (:func:`~torsal.fabrication.nesting.final_cut.final_cut`): the sheets, and the plates
    split where a sheet saved pays (a new fin system, built with those cuts); ``(fs, None)``
    otherwise (:func:`_nest` nests). The split search is kept by the parts' content in the
    design's memo, so a re-run only builds the cut fin system again."""
    from ..fabrication.nesting import Nester
    from ..fabrication.nesting import final_cut as fc
    from . import fins

    spec = inp.spec
    # a fin system an earlier final cut of this process split (kept for its assembly check):
    # every run starts from the one it was split from
    unsplit = getattr(fs, "_unsplit", None)
    if unsplit is not None:
        fs = unsplit
        fins.keep_fin_system(spec, fs)
    options = nest_options(spec, fs.unit)
    if not spec.nesting.final_cut or options["nester"] != Nester.SEARCH:
        return fs, None

    def progress(done, left):
        inp.progress("progress", {"phase": "nesting sheets", "done": done, "total": done + left})

    rates = None if spec.costs is None else spec.costs.rates()
    key = None
    if inp.memo is not None:
        from .memo import content_key

        key = content_key(_FINAL_CUT_VERSION, sorted(fs.unrolled().items()), sorted(
            (k, v.value if hasattr(v, "value") else v) for k, v in options.items()
            if k != "cutting"), options["cutting"], rates, spec.material.density,
            fc.yield_cut_sites(fs, rates))
    new, layout, split = fc.final_cut(fs, options, rates=rates, density=spec.material.density,
                                      progress=progress, memo=inp.memo, key=key)
    if new is not fs:
        # the assembly check takes the solids of this run's fin system: the split one
        new._unsplit = fs
        fins.keep_fin_system(spec, new, structure=fs.structure)
    return new, layout


def _nest(inp: StageInputs, fs):
    """The design's sheets (:func:`nest_options`), nested in this process. The final cut's
    search is kept by the parts' content (:class:`~.memo.Memo`): asked for again, or after
    a change that leaves the flat parts as they were, it is read back, not searched again.
    A layout the time limit cut is not kept."""
    from ..fabrication.nesting import Nester

    options = nest_options(inp.spec, fs.unit)

    def progress(done, left):
        inp.progress("progress", {"phase": "nesting sheets", "done": done, "total": done + left})

    def make():
        return fs.layout(progress=progress, **options)

    if options["nester"] != Nester.SEARCH or inp.memo is None:
        return make()
    from .memo import content_key

    key = content_key(sorted(fs.unrolled().items()), sorted(
        (k, v.value if hasattr(v, "value") else v) for k, v in options.items() if k != "cutting"),
        options["cutting"])
    layout = inp.memo.load("sheets", key)
    if layout is not None:
        layout.stats.method += ", kept from an earlier run of the same parts"
    else:
        layout = make()
        if not layout.stats.time_limited:
            inp.memo.store("sheets", key, layout)
    return layout


def _nesting_report(layout, sheets) -> dict:
    """Sheets used, the area bound, utilization (of the layout, and of the parts' area in the
    DXF files when written: ``sheets``, :class:`~torsal.fabrication.nesting.background.SheetFiles`,
    the area a reader of the files finds, taken from the drawings they are written from) and
    the nester's time."""
    st = layout.stats
    sheet_area = layout.sheet[0] * layout.sheet[1]
    rep = {"nester": st.method, "sheets": int(layout.n_sheets),
           "area_bound_sheets": float(layout.area_bound),
           "utilization": float(layout.utilization), "utilization_dxf": None,
           "seconds": float(st.seconds), "cpu_seconds": float(st.cpu_seconds),
           "time_limit_s": st.time_limit, "seed": st.seed, "solves": int(st.solves),
           "fallback_parts": int(st.fallback_parts), "rotation": st.rotation,
           "time_limited": bool(st.time_limited), "tries": int(st.tries),
           "starts": dict(st.starts), "deterministic": "sparrow" not in st.method
           and not st.time_limited,
           # the final cut's plates split for yield: which, where, what it saved (or why not)
           "split": getattr(st, "split", None)}
    if sheets is not None and layout.n_sheets:
        rep["utilization_dxf"] = float(sheets.area_read_back / (layout.n_sheets * sheet_area))
    return rep


def _cutting_report(layout) -> dict | None:
    """The cutting process the DXF's CUT layer is compensated for, and its reliefs and holes."""
    c = layout.cutting
    if c is None:
        return None
    from ..core.units import UNIT_TO_MM

    f = UNIT_TO_MM[c.unit]
    holes = [d for p in layout.placements for _, d in p.holes]
    return {"process": c.process.value, "kerf_mm": c.kerf * f, "tool_diameter_mm": c.tool_diameter * f,
            "relief": c.relief.value, "reliefs": int(sum(len(p.reliefs) for p in layout.placements)),
            "holes_cut": int(sum(c.hole_path(d)[0] == "cut" for d in holes)),
            "holes_drilled": int(sum(c.hole_path(d)[0] == "drill" for d in holes))}


# ------------------------------------------------------------------ report
def run_pictures(inp: StageInputs) -> dict:
    """The report's PNG renders (``outputs.renders``): the torsal field, the fins, the blocked
    sun, the sheets, the ceiling light (:func:`~torsal.pipeline.report.draw_design_pictures`).
    A concurrent stage: drawn in a process of its own while the assembly is checked. Returns
    ``files`` {kind: file name}, which the report's HTML shows."""
    from .report import draw_design_pictures

    o = inp["orient"]
    images = draw_design_pictures(inp.out, inp.spec, optimized_congruence(inp),
                                  inp["support"]["structure"], inp["light"]["map"],
                                  (o["vertices"], o["faces"]),
                                  inp["fabrication"].get("layout") if "fabrication" in inp
                                  else None)
    return {"files": images}


def run_report(inp: StageInputs) -> dict:
    """Geometry files (congruence PLY, support OBJ), ``report.json`` and, with
    ``outputs.renders``, the figures and ``report.html``; cheap, so always written fresh.
    Returns ``files`` and, as the report's ``design`` section, the design as run."""
    from .report import write_design_report

    spec, out = inp.spec, inp.out
    congruence = optimized_congruence(inp)
    structure = inp["support"]["structure"]
    files = write_geometry(out, congruence, structure)
    if "substructure" in inp:
        write_structure_obj(out / "substructure.obj", inp["substructure"]["structure"])
        files["substructure"] = "substructure.obj"
    from ..core.atomic import write_json

    # the design as run (validated, defaults filled in): a report says what it measured
    design = spec.model_dump(mode="json")
    report = {**inp.report, "design": design}
    write_json(out / "report.json", report)
    files["report_json"] = "report.json"
    if spec.outputs.renders:
        o = inp["orient"]
        files.update(write_design_report(out, spec, report, congruence, structure,
                                         inp["light"]["map"], (o["vertices"], o["faces"]),
                                         inp["fabrication"].get("layout")
                                         if "fabrication" in inp else None,
                                         sun=(inp["sun"]["vectors"], inp["sun"]["weights"]),
                                         images=inp["pictures"]["files"]
                                         if "pictures" in inp else None))
    return {"report": design, "files": files}


def _file_digest(path) -> str | None:
    """The content hash of an input file: an edited mesh or EPW under the same name is new input."""
    import hashlib

    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]
    except OSError:
        return None  # the stage itself reports the file


def _estimate_key(spec):
    return (spec.fins.spacing, spec.sun.model_dump(mode="json"), spec.outputs.model_dump(),
            spec.substructure is not None)


def _surface_key(spec):
    s = spec.surface
    return (s.model_dump(mode="json"), _file_digest(s.mesh) if s.mesh is not None else None)


def _sun_key(spec):
    s = spec.sun
    return (s.model_dump(mode="json"),
            spec.site.model_dump(mode="json") if spec.site else None,
            _file_digest(s.weather_file) if s.weather_file is not None else None)


def _congruence_key(spec):
    return (spec.goals.model_dump(mode="json"), spec.weights.model_dump(),
            spec.constraints.model_dump())


def _remesh_key(spec):
    return (spec.fins.spacing, spec.fins.depth)


def _fins_key(spec):
    return (spec.fins.model_dump(),)


def _light_key(spec):
    return (spec.outputs.light_samples, spec.view.model_dump(mode="json"))


def _substructure_key(spec):
    return (spec.fins.model_dump(), spec.substructure.model_dump())


def _has_substructure(spec):
    return spec.substructure is not None


def _fabrication_key(spec):
    return (spec.material.model_dump(mode="json"), spec.outputs.model_dump(), spec.units,
            spec.cutting.model_dump(mode="json"), spec.nesting.model_dump(mode="json"),
            # the price of the bill of quantities is in the stage's report section
            None if spec.costs is None else spec.costs.model_dump(mode="json"))


def _assembly_key(spec):
    return (spec.outputs.renders,)


def _pictures_key(spec):
    return (spec.name,)


def _renders(spec):
    return bool(spec.outputs.renders)


#: what the devices' process imports while it waits for the surface and the sun
_LIGHT_MODULES = ("torsal.light.devices", "torsal.light.rays", "torsal.light.shading",
                  "torsal.light.view")
#: what the pictures' process imports while it waits for the light (matplotlib: seconds)
_PICTURE_MODULES = ("torsal.pipeline.report", "matplotlib.figure",
                    "matplotlib.backends.backend_agg", "matplotlib.collections",
                    "matplotlib.patches", "matplotlib.colors", "mpl_toolkits.mplot3d.art3d")


#: The stages of a design run, in order. Insert more with ``DEFAULT_PIPELINE.insert``.
DEFAULT_PIPELINE = Pipeline((
    Stage("surface", run_surface, key=_surface_key),
    Stage("estimate", run_estimate, inputs=("surface",), key=_estimate_key, cache=False),
    Stage("sun", run_sun, key=_sun_key),
    Stage("orient", run_orient, inputs=("surface", "sun"), cache=False, section="surface"),
    Stage("congruence", run_congruence, inputs=("orient", "sun"), key=_congruence_key),
    Stage("remesh", run_remesh, inputs=("orient", "congruence"), key=_remesh_key),
    Stage("support", run_support, inputs=("orient", "remesh"), key=_fins_key),
    Stage("substructure", run_substructure, inputs=("orient", "congruence"),
          key=_substructure_key, applies=_has_substructure),
    Stage("fabrication", run_fabrication, inputs=("support",), key=_fabrication_key),
    # the standard devices of the fins' depth and spacing (measured into light.devices): they
    # read only the surface and the sun, so a process of their own measures them from the
    # moment those are known, while the fins are optimized and made
    Stage("devices", run_devices, inputs=("orient", "sun"), key=devices_key, concurrent=True,
          preload=_LIGHT_MODULES, low_priority=True),
    # after the fabrication: it measures the fins that are built
    Stage("light", run_light, inputs=("orient", "sun", "support", "fabrication", "devices"),
          key=_light_key),
    # the report's pictures, drawn in a process of their own while the annual light and
    # the assembly are computed
    Stage("pictures", run_pictures, inputs=("orient", "congruence", "support", "light",
                                            "fabrication"), key=_pictures_key,
          applies=_renders, cache=False, concurrent=True, preload=_PICTURE_MODULES),
    # annual irradiance by Radiance, bare / fins as built / devices ([annual] enabled)
    Stage("annual", run_annual, inputs=("orient", "sun", "support", "fabrication"),
          key=annual_key, applies=annual_applies, section="light.annual"),
    Stage("assembly", run_assembly, inputs=("support", "fabrication"),
          key=_assembly_key, section="fabrication.assembly"),
    Stage("report", run_report, inputs=("sun", "orient", "congruence", "support", "light",
                                        "substructure", "fabrication", "pictures", "assembly"),
          cache=False, section="design"),
))

#: Stage names in order.
STAGES = DEFAULT_PIPELINE.names
