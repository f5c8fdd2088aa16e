"""Every example design runs end to end in a small version and writes all its outputs."""
import json
import re
from pathlib import Path

import numpy as np
import pytest

from torsal.design import Design
from torsal.geometry.congruence import Congruence

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.toml"))
REPORT_KEYS = {
    "congruence": {"vertices", "faces", "build_s", "solve_s", "status", "energies",
                   "min_hyperbolicity", "min_torsal_angle_deg", "constraints_active",
                   "working_set", "line_spread_deg"},
    "support": {"quads", "edges", "delta_pl_extracted", "delta_pl_optimized", "solve_s"},
    "light": {"blocked_share", "transparency", "baseline_louvers"},
    "fabrication": {"parts", "panels", "sheets", "utilization", "step", "dxf", "assembly"},
}
ASSEMBLY_KEYS = {"pairs_checked", "interfering_pairs", "worst_overlap_mm3", "buildable", "joints",
                 "connectors"}
#: examples whose test-size parts the assembly check still finds interfering or blocked: the
#: report says so truthfully (checked in the test) and the gap stays visible. Empty since
#: 2026-11-28: 11's F1-S008-P01 was blocked only on the solids read back from fins.step (the
#: exact boolean of one face's path prism with F0-S000-P03 gave all of F0-S000-P03, 92,804
#: mm^3, in both orders and the fuzzy one 0; on the fin system's own solids its path was
#: clear); at commit 420a42a 11 at test size builds (exit 0, the same check from fins.step)
NOT_YET_BUILDABLE: set[str] = set()


def recount_interference(step_file) -> list[float]:
    """Common volumes (mm^3) above 1 mm^3 of every pair of solids in a STEP file, worst first,
    counted independently of torsal.fabrication.assembly: every pair whose vertex boxes
    overlap, intersected with BRepAlgoAPI_Common."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Common
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    from torsal.fabrication import read_step

    solids = read_step(step_file)

    def box(shape):
        from OCP.BRep import BRep_Tool
        from OCP.TopAbs import TopAbs_VERTEX
        from OCP.TopExp import TopExp_Explorer
        from OCP.TopoDS import TopoDS

        pts, ex = [], TopExp_Explorer(shape, TopAbs_VERTEX)
        while ex.More():
            p = BRep_Tool.Pnt_s(TopoDS.Vertex(ex.Current()))
            pts.append((p.X(), p.Y(), p.Z()))
            ex.Next()
        pts = np.asarray(pts)
        return pts.min(0) - 1.0, pts.max(0) + 1.0

    boxes = [box(s) for _, s in solids]
    volumes = []
    for i in range(len(solids)):
        for j in range(i + 1, len(solids)):
            (lo1, hi1), (lo2, hi2) = boxes[i], boxes[j]
            if (lo1 > hi2).any() or (lo2 > hi1).any():
                continue
            props = GProp_GProps()
            BRepGProp.VolumeProperties_s(BRepAlgoAPI_Common(solids[i][1], solids[j][1]).Shape(), props)
            if abs(props.Mass()) > 1.0:
                volumes.append(abs(props.Mass()))
    return sorted(volumes, reverse=True)


def small(design: Design) -> Design:
    """The same design on a coarse mesh with few fins: minutes become seconds."""
    spec = design.spec
    params = dict(spec.surface.params)
    nu, nv = params.get("nu", 33), params.get("nv", 17)
    params.update(nu=min(nu, 15), nv=min(nv, 11))
    v, _ = design.__class__(spec.model_copy(update={"surface": spec.surface.model_copy(
        update={"params": params})}))._surface()
    extent = float(np.ptp(v, axis=0).max())
    fins = spec.fins.model_copy(update={"spacing": max(spec.fins.spacing, extent / 8),
                                        "developable_levels": min(spec.fins.developable_levels, 1)})
    return Design(spec.model_copy(update={
        "surface": spec.surface.model_copy(update={"params": params}),
        "fins": fins,
        "outputs": spec.outputs.model_copy(update={"light_samples": 300}),
        # the coarse fin spacing makes single panels longer than a 2.5 m sheet
        "material": spec.material.model_copy(update={"sheet_mm": (4000.0, 2000.0)}),
        "constraints": spec.constraints.model_copy(update={"max_iter": 400}),
    }))


def test_every_figure_has_an_example():
    names = {p.name.split("_")[0] for p in EXAMPLES}
    assert names == {"7a", "7b", "7c", "7d", "9", "10", "11", "13"}


#: the quick set runs 7a end to end (make test); every other example is in the slow set
#: (make test-slow, CI): each is a whole design run with an independent recount, 20-60 s
QUICK_EXAMPLE = "7a"
#: the tests that read conftest.small_7a (the quick example's run, made once per worker) run on
#: one xdist worker (make test's --dist loadgroup), so that it is made once
SMALL_7A = pytest.mark.xdist_group("small-7a")


@pytest.mark.parametrize("path", [
    # the quick example's run is conftest.small_7a, shared with test_report_browser (its group)
    pytest.param(p, marks=SMALL_7A) if p.name.startswith(QUICK_EXAMPLE)
    else pytest.param(p, marks=pytest.mark.slow) for p in EXAMPLES], ids=[p.stem for p in EXAMPLES])
def test_example_runs_small(path, tmp_path, request):
    if path.name.startswith(QUICK_EXAMPLE):
        # (the same design, run the same way, once per worker: conftest.small_7a)
        run = request.getfixturevalue("small_7a")
        d, res, tmp_path = run.design, run.result, run.out
    else:
        d = small(Design.from_toml(path))
        # the verdict is checked below against an independent recount, for every example
        res = d.run(tmp_path, accept_unbuildable=True)
    report = json.loads((tmp_path / "report.json").read_text())
    for section, keys in REPORT_KEYS.items():
        assert keys <= set(report[section]), (section, keys - set(report[section]))
    c, s, li, fa = (report[k] for k in ("congruence", "support", "light", "fabrication"))
    # hyperbolicity holds as measured on the geometry, to the design's own tolerance (the
    # report's constraint entry, c_hyp / delta^2; the augmented Lagrangian ends inside it, not
    # at IPOPT's 1e-9)
    if d.spec.constraints.hyperbolic:
        hyp = c["constraints"]["hyperbolic"]
        assert hyp["max_violation"] <= hyp["tolerance"] and hyp["n_missing"] == 0, hyp
    # the lines' spread, recomputed with plain numpy from the written congruence (the PLY's
    # digits and arccos near 0 leave about 0.003 degrees)
    rows = (tmp_path / "congruence.ply").read_text().split("end_header\n", 1)[1].split("\n")[:c["vertices"]]
    e = np.array([[float(x) for x in ln.split()[3:6]] for ln in rows])
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    mean = e.sum(axis=0) / np.linalg.norm(e.sum(axis=0))
    assert abs(c["line_spread_deg"] - np.degrees(np.arccos(np.clip(e @ mean, -1, 1))).max()) < 0.01
    assert "widest angle of the lines from their mean direction" in (tmp_path / "report.html").read_text()
    # a torsal-angle bound holds as measured on the written congruence (issue 16)
    alpha = d.spec.constraints.min_torsal_angle
    if alpha is not None:
        m = c["constraints"]["min_torsal_angle"]
        assert m["n_missing"] == 0 and m["measured"] >= alpha - 0.1, m
        # re-read the written lines with plain numpy and measure the angle the torsal planes
        # of eq. (1) cross at
        text = (tmp_path / "congruence.ply").read_text().split("end_header\n", 1)[1].split("\n")
        nv = c["vertices"]
        ve = np.array([[float(x) for x in ln.split()] for ln in text[:nv]])
        faces = np.array([[int(x) for x in ln.split()[1:]] for ln in text[nv:nv + c["faces"]]])
        ang = Congruence(ve[:, :3], faces, ve[:, 3:]).torsal_plane_angle()
        assert np.isfinite(ang).all() and ang.min() >= alpha - 0.1
        # the row names which angle it measured (the planes or the directions) before its bound
        assert re.search(r"min_torsal_angle \(measured; [^;]+; bound", (tmp_path / "report.html").read_text())
    if c["working_set"]:            # IPOPT imposed the inequalities on a few faces: say so
        assert sum(c["working_set"].values()) < c["faces"]
        assert "imposed where needed" in (tmp_path / "report.html").read_text()
    assert s["edges"] > 10 and s["delta_pl_optimized"] <= max(1e-4, s["delta_pl_extracted"])
    assert 0.0 <= li["blocked_share"] <= 1.0 and 0.0 <= li["transparency"] <= 1.0
    assert fa["parts"] > 0 and fa["sheets"] > 0 and 0 < fa["utilization"] <= 1
    # the light is measured on the fins as built: every fin but the panels left out
    left = {p["edge"] for p in fa["panels_left_out_list"]}
    assert len(fa["panels_left_out_list"]) == min(fa["panels_left_out"], 50)
    if fa["panels_left_out"] <= 50:
        assert li["fins_measured"] == s["edges"] - len(left)
    # the assembly check, and an independent recount of its interference from fins.step
    a = fa["assembly"]
    assert ASSEMBLY_KEYS <= set(a)
    assert a["pairs_checked"] >= a["interfering_pairs"] and a["parts"] == fa["parts"]
    recount = recount_interference(tmp_path / "fins.step")
    assert a["interfering_pairs"] == len(recount)
    assert a["worst_overlap_mm3"] == pytest.approx(recount[0] if recount else 0.0, rel=1e-6)
    # buildable: the parts fit, go in, and are held to the building (the load path, issue 42)
    held = a["load_path"]
    assert held["checked"] and a["unsupported_parts"] == held["unsupported_parts"]
    assert a["buildable"] == (not recount and not a["blocked_parts"] and not a["failed_pairs"]
                              and not a["unsupported_parts"])
    assert sum(1 for _ in open(tmp_path / "assembly.csv")) == fa["parts"] + 1
    assert "Assembly check" in (tmp_path / "report.html").read_text()
    key = path.name.split("_")[0]
    if key in NOT_YET_BUILDABLE and not a["buildable"]:
        # the report says so truthfully (checked above); the gap stays visible
        pytest.xfail(f"{key} at test size: {a['interfering_pairs']} interfering pairs, "
                     f"{len(a['blocked_parts'])} parts without an insertion path (issue 15)")
    assert a["interfering_pairs"] == 0 and not a["blocked_parts"] and not a["failed_pairs"], (
        a["interfering"], a["blocked_parts"])
    for name in ["report.json", "report.html", "congruence.ply", "support.obj", "fins.step",
                 "fins.3dm", "parts.csv", "fins.png", "torsal_field.png", "blocked_sun.png",
                 "sheets.png", "assembly.csv", "assembly.png", *fa["dxf"]]:
        assert (tmp_path / name).stat().st_size > 0, name
    if d.spec.substructure is not None:
        assert report["substructure"]["edges"] > 10
        assert (tmp_path / "substructure.obj").exists()
    if d.spec.goals.reflect is not None:
        assert 0.0 <= li["reflected_to_target"] <= 1.0
    assert not list(tmp_path.glob("*.tmp*")), "temporary files left behind"
    assert set(res.files) >= {"report_json", "report_html", "congruence", "support"}
    if a["unsupported_parts"]:
        # parts the fixings, bolts and slots do not hold to the building (issue 42's load
        # path; 7a and 7c at full size have them, 2026-11-29): the report names them, the
        # verdict says not buildable (checked above), and the gap stays visible here
        pytest.xfail(f"{key} at test size: {held['message']}")
    assert a["buildable"]


def test_changing_only_the_material_reruns_only_fabrication_and_what_measures_it(tmp_path):
    import tomllib

    from test_cli import tiny_design
    from torsal.pipeline.design_file import DesignSpec

    # the cache is what this test measures, not the size: the command-line tests' tiny facade
    # (60 parts; it was example 10 at test size, 95 parts: 34-36 CPU s of all processes for the
    # three runs, the tiny one 20.5 at a higher load), with every stage the examples have
    # (surface, sun, congruence, remesh, support, light, fabrication, assembly, devices), and
    # no files a workshop reads (the other tests write them)
    d = Design(DesignSpec.model_validate(tomllib.loads(tiny_design(spacing=1.0))))
    d = Design(d.spec.model_copy(update={"outputs": d.spec.outputs.model_copy(update={
        "step": False, "rhino_3dm": False, "dxf": False, "bom": False, "renders": False})}))
    first = d.run(tmp_path, accept_unbuildable=True)
    assert first.cached == []
    again = d.run(tmp_path, accept_unbuildable=True)
    assert set(again.cached) == {"surface", "sun", "congruence", "remesh", "support", "light",
                                 "fabrication", "assembly", "devices"}
    thicker = Design(d.spec.model_copy(update={"material": d.spec.material.model_copy(
        update={"thickness_mm": 5.0})}))
    third = thicker.run(tmp_path, accept_unbuildable=True)
    assert "fabrication" not in third.cached and "assembly" not in third.cached
    # the light is measured on the fins as built, which the plate thickness can change
    assert set(third.cached) == {"surface", "sun", "congruence", "remesh", "support", "devices"}
