"""The parametric FreeCAD object in a real, headless FreeCAD (``freecadcmd``).

``make test`` installs Debian's ``freecad-python3`` (FreeCAD 0.20, Python 3.11 like the venv)
with apt-get when it is missing and it runs as root; otherwise the FreeCAD test is skipped and
says why. The workbench is installed the way a user does it (``torsal freecad install``), into
a scratch HOME, so the machine's FreeCAD is left alone.
"""
import json
import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

from torsal.fabrication.solids import read_step
from torsal.hosts.freecad.feature import FinsError, run_in_torsal
from torsal.hosts.freecad.install import (FreeCADInstallError, install_workbench,
                                          uninstall_workbench)
from torsal.hosts.freecad.job import (FinsJob, SurfaceGrid, effective_design, grid_mesh,
                                      write_design)
from torsal.hosts.results import read_parts

HERE = Path(__file__).parent
FREECADCMD = shutil.which("freecadcmd")
TORSAL = Path(sys.executable).with_name("torsal")

# the hosts' test-size facade: 28 vertices, about 90 parts; no DXF, 3DM or renders
EXAMPLES = HERE.parents[1] / "examples" / "hosts"
DESIGN = (EXAMPLES / "facade.toml").read_text()


#: the tests that read the scenario (minutes: whole design runs and a live session's builds in
#: freecadcmd) are in the slow set (make test-slow, CI), on one xdist worker so it runs once
def in_freecad(test):
    return pytest.mark.slow(pytest.mark.xdist_group("freecad-scenario")(test))


def _scratch_home(tmp_path_factory) -> tuple[dict, Path]:
    """A scratch HOME for FreeCAD (the machine's FreeCAD is left alone): its environment and
    folder; skipped without freecadcmd."""
    if FREECADCMD is None:
        pytest.skip("freecadcmd (FreeCAD) is missing, so the FreeCAD object is not tested; `make "
                    "test` installs it as root, or:  sudo apt-get install -y freecad-python3")
    tmp = tmp_path_factory.mktemp("freecad")
    (tmp / "home").mkdir()
    env = {**os.environ, "HOME": str(tmp / "home"), "XDG_CACHE_HOME": str(tmp / "cache")}
    env.pop("XDG_DATA_HOME", None)
    return env, tmp


@pytest.fixture(scope="module")
def workbench(tmp_path_factory):
    """The workbench installed with the CLI, as a user does: ``(environment, tmp folder, the
    install's output)``."""
    env, tmp = _scratch_home(tmp_path_factory)
    installed = subprocess.run([str(TORSAL), "freecad", "install"], env=env, capture_output=True,
                               text=True, timeout=300)
    assert installed.returncode == 0, installed.stderr
    return env, tmp, installed.stdout


@pytest.fixture(scope="module")
def quick_workbench(tmp_path_factory):
    """The workbench installed in this process into FreeCAD 0.20's user Mod folder (what the
    CLI finds by asking freecadcmd, a start of FreeCAD saved): ``(environment, tmp folder)``."""
    env, tmp = _scratch_home(tmp_path_factory)
    install_workbench(tmp / "home" / ".local" / "share" / "FreeCAD" / "Mod", python=sys.executable)
    return env, tmp


def _freecadcmd(code: str, env: dict, cwd: Path, timeout: float):
    run = subprocess.run([FREECADCMD, "-c", code], env=env, capture_output=True, text=True,
                         timeout=timeout, cwd=cwd)
    out = Path(env["TORSAL_SCENARIO_OUT"])
    assert run.returncode == 0 and out.exists(), run.stdout[-3000:] + run.stderr[-3000:]
    return json.loads(out.read_text()), run.stdout + run.stderr


@pytest.fixture(scope="module")
def scenario(workbench):
    """Run freecad_scenario.py in freecadcmd, return what it measured."""
    env, tmp, installed = workbench
    design = tmp / "design.toml"
    design.write_text(DESIGN)
    env = {**env, "TORSAL_SCENARIO_DESIGN": str(design), "TORSAL_SCENARIO_DIR": str(tmp),
           "TORSAL_SCENARIO_OUT": str(tmp / "scenario.json"), "TORSAL_EXAMPLES": str(EXAMPLES)}
    code = (f"import runpy; runpy.run_path({str(HERE / 'freecad_scenario.py')!r}, "
            "run_name='__main__')")
    # minutes: five whole runs and a live session's two builds (15 at a load of 10 on 2 cores)
    data, output = _freecadcmd(code, env, tmp, 1800)
    return {"data": data, "install": installed, "home": tmp / "home", "output": output,
            "tmp": tmp, "env": env}


#: the hosts' facade with a sparse, shallower second family
FAMILIES = DESIGN.replace("spacing = 1.5", "spacing = [1.5, 3.0]").replace(
    "depth = 0.4", "depth = [0.4, 0.25]")


@pytest.fixture(scope="module")
def families(quick_workbench):
    """freecad_scenario.families() in freecadcmd (seconds: no design run)."""
    env, tmp = quick_workbench
    assert FAMILIES != DESIGN
    (tmp / "families.toml").write_text(FAMILIES)
    (tmp / "one.toml").write_text(DESIGN)
    env = {**env, "TORSAL_SCENARIO_DESIGN": str(tmp / "families.toml"),
           "TORSAL_SCENARIO_DESIGN_ONE": str(tmp / "one.toml"), "TORSAL_SCENARIO_DIR": str(tmp),
           "TORSAL_SCENARIO_OUT": str(tmp / "families.json")}
    code = (f"import runpy; runpy.run_path({str(HERE / 'freecad_scenario.py')!r})['families']()")
    return _freecadcmd(code, env, tmp, 300)[0]


def _fins_of(job: dict) -> tuple:
    """The job's design as torsal loads it: (spacings, depths) of the two families, m."""
    from torsal.pipeline.design_file import load_design_file

    path, _ = write_design(FinsJob.from_dict(job))
    fins = load_design_file(path).fins
    return fins.spacings, fins.depths


def test_a_design_file_with_two_spacings_gives_the_family_properties(families):
    """fins.spacing = [1.5, 3.0], depth = [0.4, 0.25] m: Spacing / Spacing1 and Depth /
    Depth1 in mm; the job runs the same two families; Spacing1 = 0 means one spacing."""
    assert families["properties"] == {"Spacing": 1500.0, "Spacing1": 3000.0, "Depth": 400.0,
                                      "Depth1": 250.0}
    spacings, depths = _fins_of(families["job"])
    assert spacings == pytest.approx((1.5, 3.0)) and depths == pytest.approx((0.4, 0.25))
    spacings, depths = _fins_of(families["job_one_spacing"])
    assert spacings == pytest.approx((1.5, 1.5)) and depths == pytest.approx((0.4, 0.45))


def test_a_document_from_before_the_family_properties_opens_with_one_spacing(families):
    assert families["old_before"] == ["Depth", "Spacing"]
    old = families["old_reopened"]
    assert old["properties"] == {"Spacing": 1500.0, "Spacing1": 0.0, "Depth": 400.0,
                                 "Depth1": 0.0}
    assert "Invalid" not in old["state"]
    assert _fins_of(old["job"]) == (pytest.approx((1.5, 1.5)), pytest.approx((0.4, 0.4)))


@in_freecad
def test_install_says_where_and_how_to_remove(scenario):
    mod = scenario["home"] / ".local" / "share" / "FreeCAD" / "Mod" / "Torsal"
    assert (mod / "Init.py").is_file() and (mod / "InitGui.py").is_file()
    assert str(mod) in scenario["install"]
    assert "torsal freecad uninstall" in scenario["install"] and f"rm -r {mod}" in scenario["install"]


@in_freecad
def test_properties_mirror_the_design_file(scenario):
    p = scenario["data"]["properties"]
    assert (p["Spacing"], p["Depth"], p["Thickness"]) == (1500.0, 400.0, 3.0)   # m -> mm
    assert p["MinTorsalAngle"] == 0.0                                           # unset: off
    assert (p["SunStart"], p["SunEnd"], p["SunHours"]) == ("2026-06-01", "2026-06-07", [13.0, 17.0])
    assert p["read_only"]["Buildable"] == p["read_only"]["Report"] == ["ReadOnly"]
    assert p["read_only"]["Spacing"] == []


def _step_volumes(step):
    """The STEP's solids read with OCP's XCAF reader, not FreeCAD's (names, volumes mm^3)."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    out = []
    for name, solid in read_step(step):
        props = GProp_GProps()
        BRepGProp.VolumeProperties_s(solid, props)
        out.append((name, props.Mass()))
    return out


@in_freecad
def test_recompute_gives_one_valid_solid_per_part(scenario):
    first = scenario["data"]["first"]
    assert first["state"] == ["Up-to-date"] and first["valid"]
    assert first["n"] == len(first["parts"]) == first["report_parts"] > 50
    assert first["parts"] == first["csv_parts"]
    assert first["buildable"] == first["report_buildable"]
    assert first["sun_blocked"] == pytest.approx(first["report_blocked"])
    assert set(first["groups"]) <= {"family 0", "family 1", "connector", "interfering"}
    assert Path(first["report"]).is_file()
    # the solids FreeCAD holds are the STEP's, read by another reader: same volumes in order
    # (the job folder holds the last recompute's STEP: the reopened document's solids)
    reopened = scenario["data"]["after_reopen"]
    job = Path(reopened["design_run"]).parent
    names, volumes = zip(*_step_volumes(job / "out" / "fins.step"))
    assert list(names) == reopened["parts"] == [p.name for p in read_parts(job / "out")]
    np.testing.assert_allclose(reopened["volumes"], volumes, rtol=1e-6)


@in_freecad
def test_changing_spacing_reruns_from_the_remeshing_and_changes_the_solids(scenario):
    first, second = scenario["data"]["first"], scenario["data"]["spacing"]
    assert second["state"] == ["Up-to-date"] and second["valid"]
    assert {"surface", "sun", "congruence"} <= set(second["stages_cached"])
    assert {"remesh", "support", "fabrication"} <= set(second["stages_run"])
    assert first["stages_cached"] == []
    assert second["n"] < first["n"]               # wider spacing, fewer fins
    assert second["parts"] != first["parts"]


@in_freecad
def test_a_linked_bspline_face_carries_the_fins(scenario):
    s = scenario["data"]["surface"]
    assert s["surface_type"] == "BSplineSurface"
    assert s["state"] == ["Up-to-date"] and s["valid"] and s["n"] == len(s["parts"]) > 20
    assert "surface" in s["stages_run"] and "sun" in s["stages_cached"]
    # the fins stand on the face: each sampled fin plate touches it (up to the tessellation's
    # chord error, a few mm at 0.94 m edges) and they cover its extent
    assert max(s["distances"]) < 25.0
    fb, sb = np.array(s["face_bbox"]), np.array(s["bbox"])
    assert np.all(np.abs(sb[[0, 2, 3, 5]] - fb[[0, 2, 3, 5]]) < 0.1 * (fb[3] - fb[0]))
    job = Path(s["design_run"]).parent
    assert (job / "surface.obj").is_file()
    assert "surface.obj" in (job / "design.toml").read_text()


@in_freecad
def test_the_document_saves_and_reopens_with_the_fins(scenario):
    s, r, again = (scenario["data"][k] for k in ("surface", "reopened", "after_reopen"))
    assert r["proxy"] == "FinsFeature" and r["is_fins_feature"]
    assert r["surface_link"] == ["Facade", ["Face1"]]
    assert r["n"] == s["n"] and r["parts"] == s["parts"] and r["valid"]
    np.testing.assert_allclose(r["volumes"], s["volumes"], rtol=1e-9)
    # recomputed after reopening: torsal is found again and every costly stage is cached
    assert again["state"] == ["Up-to-date"] and again["n"] == s["n"]
    assert {"congruence", "fabrication", "assembly"} <= set(again["stages_cached"])
    np.testing.assert_allclose(again["volumes"], s["volumes"], rtol=1e-9)


@in_freecad
def test_a_bad_value_marks_the_object_invalid_and_keeps_its_solids(scenario):
    bad = scenario["data"]["bad"]
    assert "Invalid" in bad["state"]
    assert bad["n"] == scenario["data"]["after_reopen"]["n"]
    assert "sun.hours = [18.0, 9.0]" in scenario["output"]


@in_freecad
def test_the_live_object_shows_the_preview_at_once_and_the_solids_when_built(scenario):
    """On a live session (the default), a recompute sets Shape to the preview: one face per
    fin (mm), no solids; the built solids follow (one per part, the job folder's STEP). A
    change of spacing re-runs from the remesh, one of the sun hours re-solves the congruence;
    each preview comes within seconds (printed: the measured latency)."""
    live = scenario["data"]["live"]
    for name in ("first", "spacing", "spacing1", "sun"):
        p = live[name]
        print(f"FreeCAD live, {name:>7}: preview {p['recompute']:.2f} s in the recompute "
              f"({p['seconds']:.2f} s in torsal: {', '.join(p['stages_run'])})")
        assert p["answer"] == "preview" and p["state"] == ["Up-to-date"]
        assert p["solids"] == 0 and p["faces"] > 10 and p["parts"] == []
        assert len(p["groups"]) == p["faces"] and set(p["groups"]) <= {"family 0", "family 1"}
    for name in ("spacing", "sun"):             # the first build: cancelled by the change
        p, b = live[name], live[name + "_built"]
        print(f"FreeCAD live, {name:>7}: solids {p['recompute'] + b['wait']:.1f} s after the "
              f"change ({b['solids']} parts)")
        assert p["faces"] >= len(b["parts"]) // 4
        assert b["ok"] and b["answer"] == "built" and not b["touched"]
        assert b["solids"] == len(b["parts"]) > 20 and b["valid"]
        # the preview's fins are where the solids are (mm): the same extent, to a plate
        assert np.allclose(p["bbox"], b["bbox"], atol=50.0), (p["bbox"], b["bbox"])
    first, spacing, sun = live["first"], live["spacing"], live["sun"]
    assert {"congruence", "sun"} <= set(spacing["stages_cached"]) and "remesh" in spacing["stages_run"]
    assert "congruence" in sun["stages_run"] and "surface" in sun["stages_cached"]
    assert spacing["faces"] < first["faces"]
    # Spacing1 = 2 Spacing: every other family-1 fin (fewer nodes, so family 0 has fewer faces
    # too, each longer); Depth1 = 250 mm is in the sun change's build
    family1 = [live[k]["groups"].count("family 1") for k in ("spacing", "spacing1")]
    assert family1[1] < 0.75 * family1[0], family1
    ran = tomllib.loads(Path(live["sun_built"]["design_run"]).read_text())["fins"]
    assert ran["depth"] == [pytest.approx(0.4), pytest.approx(0.25)]
    assert not isinstance(ran["spacing"], list)
    # warm: a change's preview answers without the build (about 0.3 s at this size, idle;
    # printed, not asserted: a busy machine is slower, benchmarks/session_bench.py measures)
    for name, p in (("spacing", spacing), ("sun", sun)):
        print(f"FreeCAD live preview of a {name} change: {p['seconds']:.2f} s, recompute "
              f"{p['recompute']:.2f} s")
    # the solids FreeCAD shows are the job's STEP, read by another reader
    job = Path(live["sun_built"]["design_run"]).parent
    names, volumes = zip(*_step_volumes(job / "out" / "fins.step"))
    assert list(names) == live["sun_built"]["parts"]
    np.testing.assert_allclose(live["sun_built"]["volumes"], volumes, rtol=1e-6)
    # a bad value: invalid, with torsal's message, the built solids kept
    assert "Invalid" in live["bad"]["state"] and live["bad"]["solids"] == live["sun_built"]["solids"]


# ------------------------------------------------------------------ without FreeCAD
def test_a_job_applies_the_properties_in_the_design_units(tmp_path):
    design = tmp_path / "d.toml"
    design.write_text(DESIGN.replace('units = "m"', 'units = "cm"'))
    grid = SurfaceGrid(nu=3, nv=3, points=[[i * 1000.0, 0.0, j * 1000.0] for i in range(3)
                                           for j in range(3)], inside=[True] * 9)
    job = FinsJob(design=str(design), folder=str(tmp_path / "job"), spacing_mm=1200,
                  depth_mm=300, thickness_mm=4, min_torsal_angle=25, sun_start="2026-07-01",
                  sun_end="2026-07-02", sun_hours=[12, 15], surface=grid,
                  strokes=[[[0, 0, 0], [2000, 0, 2000]]], stroke_width_mm=500)
    data = effective_design(job)
    assert data["fins"]["spacing"] == pytest.approx(120) and data["fins"]["depth"] == pytest.approx(30)
    assert data["material"]["thickness_mm"] == 4
    assert data["constraints"]["min_torsal_angle"] == 25
    assert (data["sun"]["start"], data["sun"]["end"], data["sun"]["hours"]) == \
        ("2026-07-01", "2026-07-02", [12, 15])
    assert data["goals"]["strokes"] == [{"points": [[0, 0, 0], [200, 0, 200]], "width": 50}]
    v, f = grid_mesh(grid, 0.1)
    assert v.shape == (9, 3) and f.shape == (8, 3) and v.max() == pytest.approx(200)
    assert data["surface"] == {"mesh": str(tmp_path / "job" / "surface.obj")}
    assert (tmp_path / "job" / "surface.obj").read_text().count("\nf ") == 8
    # 0 switches the constraint off
    job.min_torsal_angle = 0
    assert "min_torsal_angle" not in effective_design(job).get("constraints", {})


def test_a_bad_property_is_reported_by_key(tmp_path):
    design = tmp_path / "d.toml"
    design.write_text(DESIGN)
    job = FinsJob(design=str(design), folder=str(tmp_path / "job"), sun_hours=[18, 9])
    with pytest.raises(FinsError, match=r"(?s)bad input.*sun.hours = \[18.0, 9.0\]"):
        run_in_torsal(job)
    assert not (tmp_path / "job" / "out").exists()


def test_install_refuses_a_folder_that_is_not_its_own(tmp_path):
    (tmp_path / "Torsal").mkdir()
    (tmp_path / "Torsal" / "mine.txt").write_text("someone's")
    with pytest.raises(FreeCADInstallError, match="not torsal's workbench"):
        install_workbench(tmp_path)
    with pytest.raises(FreeCADInstallError, match="left alone"):
        uninstall_workbench(tmp_path)
    assert (tmp_path / "Torsal" / "mine.txt").exists()
    other = tmp_path / "mods"
    folder = install_workbench(other, python="/opt/torsal/bin/python")
    assert "/opt/torsal/bin/python" in (folder / "Init.py").read_text()
    compile((folder / "Init.py").read_text(), "Init.py", "exec")
    compile((folder / "InitGui.py").read_text(), "InitGui.py", "exec")
    assert uninstall_workbench(other) == folder and not folder.exists()
    assert uninstall_workbench(other) is None


def test_the_cli_names_a_mod_folder_it_cannot_use(tmp_path, capsys):
    from torsal.cli import main

    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    assert main(["freecad", "install", "--mod-dir", str(blocker)]) == 2
    err = capsys.readouterr().err
    assert "cannot create" in err and str(blocker) in err and "Traceback" not in err
    assert main(["freecad", "uninstall", "--mod-dir", str(tmp_path)]) == 0
    assert "no torsal workbench was installed there" in capsys.readouterr().out


def _previews(tmp_path, jobs: list[FinsJob]) -> list[dict]:
    """The live session's preview of each job in turn (torsal's side of the protocol)."""
    import io
    from dataclasses import asdict

    from torsal.hosts.freecad.live import serve

    lines = [json.dumps({"op": "edit", "id": k, "job": asdict(job)}) + "\n"
             for k, job in enumerate(jobs, 1)]
    out = io.StringIO()
    assert serve(io.StringIO("".join(lines) + '{"op": "close"}\n'), out) == 0
    answers = [json.loads(line) for line in out.getvalue().splitlines()]
    previews = [m for m in answers if m["kind"] == "preview"]
    assert len(previews) == len(jobs), answers
    return previews


def _family_fins(fins: dict, family: int) -> tuple[float, float]:
    """(total length along A, median depth) of one family's fins in a preview, mm."""
    a, e = np.asarray(fins["a"]), np.asarray(fins["edges"])
    b = np.asarray(fins["b" if family == 0 else "b1"])
    e = e[np.asarray(fins["families"]) == family]
    return (float(np.linalg.norm(a[e[:, 0]] - a[e[:, 1]], axis=1).sum()),
            float(np.median(np.linalg.norm(b[e] - a[e], axis=2))))


def test_the_live_session_makes_a_sparse_shallow_second_family(tmp_path):
    """Spacing1 = 2 Spacing and Depth1 through the live path: family 1's fins are half as
    long in total (every other line) and as deep as Depth1; family 0's stay as they were."""
    design = tmp_path / "d.toml"
    design.write_text(DESIGN)
    job = dict(design=str(design), folder=str(tmp_path / "job"), spacing_mm=1500.0)
    one, two = _previews(tmp_path, [FinsJob(**job),
                                    FinsJob(**job, spacing1_mm=3000.0, depth1_mm=250.0)])
    assert "congruence" not in two["stages_run"] and "remesh" in two["stages_run"]
    (len0, d0), (len1, d1) = (_family_fins(one["fins"], f) for f in (0, 1))
    (len0_, d0_), (len1_, d1_) = (_family_fins(two["fins"], f) for f in (0, 1))
    assert (d0, d1, d0_) == pytest.approx((400.0, 400.0, 400.0), abs=0.5)
    assert d1_ == pytest.approx(250.0, abs=0.5)
    assert len0_ == pytest.approx(len0, rel=0.05)
    assert len1_ == pytest.approx(len1 / 2, rel=0.15)
