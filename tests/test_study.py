"""Design studies: a grid of 7a at test size on a 2-worker LocalCluster, the standard devices
on the same axes, resuming, failures, a search, and study files checked before anything runs."""
import html
import json
import os
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import tomli_w

from torsal import Study, StudyFileError
from torsal.light.devices import DEVICE_NAMES
from torsal.cli import main
from torsal.study.study_report import X_KEY, Y_KEY

ROOT = Path(__file__).resolve().parents[1]
AXES = {"fins.spacing": [1.5, 2.0], "fins.depth": [0.3, 0.5], "weights.perp": [1, 10]}


def _base(folder: Path, **outputs) -> Path:
    """7a at test size (the sizes of tests/test_examples.small), as a design file."""
    d = tomllib.loads((ROOT / "examples" / "7a_facade_block.toml").read_text())
    # (the copy lies elsewhere: its rates file named from the examples)
    d["costs"]["file"] = str(ROOT / "examples" / d["costs"]["file"])
    d["surface"]["params"] = {"nu": 15, "nv": 11}
    d["fins"]["spacing"] = 1.5
    d["outputs"] = {"light_samples": 300, "step": False, "rhino_3dm": False, **outputs}
    d["material"]["sheet_mm"] = [4000, 2000]
    d["constraints"]["max_iter"] = 400
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "designs").mkdir(exist_ok=True)
    path = folder / "designs" / "7a_small.toml"
    path.write_text(tomli_w.dumps(d))
    return path


def _study(folder: Path, axes=AXES, extra: str = "", **outputs) -> Path:
    _base(folder, **outputs)
    text = 'name = "7a test"\nbase = "designs/7a_small.toml"\n' + tomli_w.dumps({"axes": axes})
    path = folder / "study.toml"
    path.write_text(text + "[run]\nworkers = 2\n" + extra)
    return path


def _mtimes(folder: Path) -> dict:
    return {p: p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file()}


#: the tests that read the grid (8 variants on a Dask cluster, a minute or more) are in the
#: slow set (make test-slow, CI), on one xdist worker (--dist loadgroup), so its study runs once
ONE_WORKER = pytest.mark.xdist_group("study-grid")
#: the study mechanics' tests measure the light only: what they test is the study, not the parts
LIGHT = "fabrication = false\n"


@pytest.fixture(scope="module")
def grid(tmp_path_factory):
    folder = tmp_path_factory.mktemp("study")
    seen = []
    # the parts and sheets of every variant, not their assembly check (see
    # test_a_variant_writes_the_files_its_study_asks_for)
    res = Study.from_toml(_study(folder, extra="assembly = false\n")).run(
        folder / "out", progress=seen.append)
    return folder / "out", res, seen


@ONE_WORKER
@pytest.mark.slow
def test_grid_rows_and_axis_values_from_each_variants_report(grid):
    out, res, seen = grid
    t = res.table
    torsal, base = t[t["kind"] == "torsal"], t[t["kind"] == "baseline"]
    assert len(torsal) == 8 and (torsal["status"] == "done").all()
    # five devices for each of the 4 (depth, spacing) pairs, all of them made on a facade
    assert len(base) == 20 and (base["status"] == "done").all()
    assert set(base["device"]) == set(DEVICE_NAMES)
    assert set(zip(base["fins.depth"], base["fins.spacing"])) == {(d, s) for d in (0.3, 0.5)
                                                                  for s in (1.5, 2.0)}
    assert set(zip(torsal["fins.spacing"], torsal["fins.depth"], torsal["weights.perp"])) == {
        (s, d, w) for s in (1.5, 2.0) for d in (0.3, 0.5) for w in (1, 10)}
    for _, row in torsal.iterrows():
        folder = out / "variants" / row["id"]
        report = json.loads((folder / "report.json").read_text())
        design = report["design"]
        assert (design["fins"]["spacing"], design["fins"]["depth"], design["weights"]["perp"]) == (
            row["fins.spacing"], row["fins.depth"], row["weights.perp"])
        # and the geometry has that depth: |b - a| of the support structure's nodes
        v = np.array([[float(x) for x in line.split()[1:]]
                      for line in (folder / "support.obj").read_text().splitlines()
                      if line.startswith("v ")])
        n = len(v) // 2
        assert np.median(np.linalg.norm(v[n:] - v[:n], axis=1)) == pytest.approx(row["fins.depth"], rel=1e-3)
        assert row["light.blocked_share"] == report["light"]["blocked_share"]
        # a variant writes the files its study reads: report.json, no solids, sheets or pictures
        assert row["report"] == f"variants/{row['id']}/report.json" and (out / row["report"]).exists()
        assert not [f for f in ("fins.step", "fins.3dm", "fins.ifc", "parts.csv", "report.html")
                    if (folder / f).exists()] and not (folder / "sheets").exists()
        assert row["stage_s.fabrication"] > 0 and pd.isna(row.get("stage_s.assembly"))
        # the louvers in the variant's own report and the study's louver row: the same rays
        louvers = base[(base["device"] == "horizontal louvers") & (base["fins.depth"] == row["fins.depth"])
                       & (base["fins.spacing"] == row["fins.spacing"])].iloc[0]
        assert louvers["light.blocked_share"] == pytest.approx(
            report["light"]["baseline_louvers"]["blocked_share"], abs=1e-12)
        # every device of the variant's own report is the study's row (one devices stage)
        for name, m in report["light"]["devices"].items():
            row_d = base[(base["device"] == name) & (base["fins.depth"] == row["fins.depth"])
                         & (base["fins.spacing"] == row["fins.spacing"])].iloc[0]
            assert row_d["light.blocked_share"] == m["blocked_share"]
            assert row_d[X_KEY] == m["view_clear"] == m["view_out"]
        assert row[X_KEY] == report["light"]["view_out"]
        # material = one-side fin area x 3 mm x 2700 kg/m^3
        assert row["material_kg"] == pytest.approx(report["light"]["fin_area_m2"] * 0.003 * 2700)
    assert torsal["buildable"].isna().all() or set(torsal["buildable"]) <= {True, False}
    # egg-crate = louvers + vertical fins: it blocks at least what either blocks; the same
    # for the optimized family and its egg-crate
    for (d, s), g in base.groupby(["fins.depth", "fins.spacing"]):
        b = g.set_index("device")["light.blocked_share"]
        assert b["egg-crate"] >= max(b["horizontal louvers"], b["vertical fins"]) - 1e-12
        assert b["optimized egg-crate"] >= b["optimized parallel fins"] - 1e-12
    # two weights -> two congruence solves; the other six variants found theirs in the cache
    assert (res.solves, res.solves_saved) == (2, 6)
    assert seen[-1].done == 8 and seen[-1].failed == 0 and max(p.running for p in seen) == 2


@ONE_WORKER
@pytest.mark.slow
def test_table_files_and_page(grid):
    out, res, _ = grid
    parquet, csv = pd.read_parquet(out / "results.parquet"), pd.read_csv(out / "results.csv")
    assert len(parquet) == len(csv) == 28
    for col in ["id", "kind", "fins.spacing", "fins.depth", "weights.perp", "light.blocked_share",
                "light.transparency", X_KEY, "fabrication.parts", "buildable", "material_kg", "wall_s"]:
        assert col in parquet.columns and col in csv.columns, col
    page = (out / "study.html").read_text()
    assert res.verdict and html.escape(res.verdict) in page
    assert "variants/000/report.json" in page and "plotly" in page.lower()
    assert (out / "pareto.png").read_bytes()[:4] == b"\x89PNG"
    # the verdict's number, computed independently: the additive epsilon indicator
    ok = res.table[res.table["status"] == "done"]
    t, b = ok[ok["kind"] == "torsal"], ok[ok["kind"] == "baseline"]
    # (the sun axis is the sun as asked: blocked, the design has no let-through region)
    assert (ok[Y_KEY] == ok["light.blocked_share"]).all()
    lead = max(min(max(x - bx, y - by) for bx, by in zip(b[X_KEY], b[Y_KEY]))
               for x, y in zip(t[X_KEY], t[Y_KEY]))
    assert f"{100 * abs(lead):.1f} percentage points" in res.verdict
    assert ("lie beyond" in res.verdict) == (lead > 0)


@ONE_WORKER
@pytest.mark.slow
def test_a_resumed_study_recomputes_nothing(grid):
    out, first, _ = grid
    before = _mtimes(out / "variants") | _mtimes(out / ".torsal-cache") | _mtimes(out / "baselines")
    seen = []
    again = Study.from_toml(out.parent / "study.toml").run(out, progress=seen.append)
    after = _mtimes(out / "variants") | _mtimes(out / ".torsal-cache") | _mtimes(out / "baselines")
    assert after == before
    assert again.resumed == 8 and again.solves == 0 and seen[-1].done == 8
    pd.testing.assert_frame_equal(again.table.drop(columns="wall_s"),
                                  first.table.drop(columns="wall_s"))


@ONE_WORKER
@pytest.mark.slow
def test_an_interrupted_study_resumes_where_it_stopped(grid, tmp_path):
    out, first, _ = grid
    # a copy of the finished study, with variant 005 cut off before it finished
    import shutil

    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    (copy / "variants" / "005" / "variant.json").unlink()
    (copy / "variants" / "005" / "report.json").unlink()
    before = _mtimes(copy / "variants" / "004")
    res = Study.from_toml(out.parent / "study.toml").run(copy, serial=True)
    assert res.resumed == 7 and (res.solves, res.solves_saved) == (0, 1)
    assert (copy / "variants" / "005" / "report.json").exists()
    assert _mtimes(copy / "variants" / "004") == before
    row = res.table.set_index("id").loc["005"]
    assert row["status"] == "done" and row["light.blocked_share"] == first.table.set_index(
        "id").loc["005", "light.blocked_share"]


def test_a_failing_variant_is_recorded_and_the_others_go_on(tmp_path):
    # fins 40 m apart on a 12 m facade: no fin to build
    path = _study(tmp_path, {"fins.spacing": [1.5, 40.0], "fins.depth": [0.3]}, extra=LIGHT)
    res = Study.from_toml(path).run(tmp_path / "out", serial=True)
    t = res.table[res.table["kind"] == "torsal"].set_index("fins.spacing")
    assert t.loc[1.5, "status"] == "done" and t.loc[40.0, "status"] == "failed"
    assert t.loc[40.0, "failed_stage"] in ("remesh", "support", "light")
    assert t.loc[40.0, "error"]
    assert res.failed == 1 and (res.solves, res.solves_saved) == (1, 1)
    rec = json.loads((tmp_path / "out" / "variants" / t.loc[40.0, "id"] / "variant.json").read_text())
    assert rec["status"] == "failed" and rec["stage"] == t.loc[40.0, "failed_stage"]


def test_a_variant_writes_the_files_its_study_asks_for(tmp_path):
    """[run] files and assembly: the report with its pictures and the cutting sheets, and the
    assembly check's verdict in the table; the stage seconds of each variant are columns."""
    path = _study(tmp_path, {"fins.depth": [0.3]}, extra='files = ["report", "dxf"]\n')
    res = Study.from_toml(path).run(tmp_path / "out", serial=True)
    row = res.table[res.table["kind"] == "torsal"].iloc[0]
    folder = tmp_path / "out" / "variants" / row["id"]
    assert row["status"] == "done" and row["buildable"] in (True, False)
    assert row["report"] == f"variants/{row['id']}/report.html" and (folder / "report.html").exists()
    assert list((folder / "sheets").glob("*.dxf")) and not (folder / "fins.step").exists()
    stages = {c.split(".", 1)[1] for c in res.table.columns if c.startswith("stage_s.")}
    assert {"fabrication", "assembly", "light"} <= stages
    assert row["stage_s.assembly"] > 0


def test_search_runs_trials_and_continues(tmp_path):
    path = _study(tmp_path, {"fins.depth": {"low": 0.2, "high": 0.6}},
                  extra=LIGHT + '[search]\ntrials = 2\nobjectives = { "light.blocked_share" = '
                  '"max", "material_kg" = "min" }\n')
    res = Study.from_toml(path).run(tmp_path / "out", serial=True)
    t = res.table[res.table["kind"] == "torsal"]
    assert list(t["id"]) == ["t000", "t001"] and (t["status"] == "done").all()
    assert t["fins.depth"].between(0.2, 0.6).all()
    path.write_text(path.read_text().replace("trials = 2", "trials = 3"))
    more = Study.from_toml(path).run(tmp_path / "out", serial=True)
    assert more.resumed == 2 and len(more.table[more.table["kind"] == "torsal"]) == 3


@pytest.mark.parametrize("text, words", [
    ('nmae = "x"\n', ["nmae", "unknown key"]),
    ('[run]\nworkers = "two"\n', ["run.workers"]),
    ('[axes]\n"fins.dpeth" = [0.2]\n', ['axes."fins.dpeth"', "'dpeth' is not a key of [fins]"]),
    ('[axes]\n"fins" = [0.2]\n', ['axes."fins" names the table']),
    ('[axes]\n"fins.depth" = ["deep"]\n', ["fins.depth", "deep"]),
    ('[axes]\n"fins.depth" = [-0.2]\n', ["fins.depth", "greater than 0"]),
    ('[axes]\n"fins.depth" = []\n', ['axes."fins.depth"', "empty"]),
    ('[axes]\n"fins.depth" = { low = 0.2, high = 0.4 }\n', ["fins.depth", "[search]"]),
    ('[axes]\n"fins.depth" = [0.2]\n[search]\ntrials = 3\nobjectives = { "light.shade" = "max" }\n',
     ["search.objectives", "light.shade"]),
])
def test_bad_study_files_name_the_key_and_nothing_runs(tmp_path, capsys, text, words):
    _base(tmp_path)
    head = 'name = "bad"\nbase = "designs/7a_small.toml"\n'
    if "[axes]" not in text:
        text += '[axes]\n"fins.depth" = [0.2]\n'
    path = tmp_path / "study.toml"
    path.write_text(head + text)
    with pytest.raises(StudyFileError) as exc:
        Study.from_toml(path)
    for w in words:
        assert w in str(exc.value), (w, str(exc.value))
    assert main(["study", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and words[0].split("\n")[0][:10] in err.replace("\n", " ")
    assert not (tmp_path / "out").exists()


def test_missing_base_design(tmp_path, capsys):
    path = tmp_path / "study.toml"
    path.write_text('base = "nowhere.toml"\n[axes]\n"fins.depth" = [0.2]\n')
    assert main(["study", str(path), "--out", str(tmp_path / "out")]) == 2
    assert "nowhere.toml" in capsys.readouterr().err


def test_a_study_runs_on_an_existing_scheduler(tmp_path):
    """--scheduler ADDRESS: the study uses a running cluster and leaves it running."""
    import logging

    from distributed import Client, LocalCluster

    path = _study(tmp_path, {"fins.depth": [0.3]}, extra=LIGHT)
    with LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=None,
                      silence_logs=logging.ERROR) as cluster:
        res = Study.from_toml(path).run(tmp_path / "out", scheduler=cluster.scheduler_address)
        assert list(res.table.loc[res.table["kind"] == "torsal", "status"]) == ["done"]
        with Client(cluster.scheduler_address) as client:       # still up
            assert len(client.scheduler_info()["workers"]) == 1


def test_a_lost_task_is_a_failed_variant(tmp_path):
    """A task that does not come back (its worker died) is recorded as failed, not fatal."""
    from torsal.study import study_tasks

    class Crashing(study_tasks.SerialExecutor):
        def result(self, job):
            if getattr(job.args[0], "id", None) == "001":
                raise RuntimeError("worker killed (out of memory)")
            return super().result(job)

    path = _study(tmp_path, {"fins.depth": [0.3, 0.5]}, extra=LIGHT)
    study = Study.from_toml(path)
    orig = study_tasks.SerialExecutor
    import torsal.study.study as study_module

    study_module.SerialExecutor = Crashing
    try:
        res = study.run(tmp_path / "out", serial=True)
    finally:
        study_module.SerialExecutor = orig
    t = res.table[res.table["kind"] == "torsal"].set_index("id")
    assert t.loc["000", "status"] == "done" and t.loc["001", "status"] == "failed"
    assert "worker killed" in t.loc["001", "error"]


def _table(torsal, devices):
    rows = [{"id": f"{k:03d}", "kind": "torsal", "device": "torsal", "status": "done",
             "fins.depth": 0.3, "fins.spacing": 0.6, X_KEY: x,
             Y_KEY: y, "material_kg": 100.0} for k, (x, y) in enumerate(torsal)]
    rows += [{"id": f"b{k}", "kind": "baseline", "device": "horizontal louvers", "status": "done",
              "fins.depth": 0.3, "fins.spacing": 0.6, X_KEY: x,
              Y_KEY: y, "material_kg": 80.0} for k, (x, y) in enumerate(devices)]
    return pd.DataFrame(rows)


def test_verdict_beyond_and_behind_by_hand():
    from torsal.study.study_report import verdict

    # devices (0.9, 0.5), (0.6, 0.8); torsal (0.7, 0.9): beyond by min(max(-0.2, 0.4),
    # max(0.1, 0.1)) = 0.1; torsal (0.5, 0.4): behind (0.9, 0.5) by max(-0.4, -0.1) = -0.1 ...
    # and (0.6, 0.8) by max(-0.1, -0.4) = -0.1: 10 points behind
    text, n = verdict(_table([(0.7, 0.9), (0.5, 0.4)], [(0.9, 0.5), (0.6, 0.8)]), [])
    assert text.startswith("1 of 2 torsal variants lie beyond")
    assert "by 10.0 percentage points" in text and "no device blocks more than 80.0%" in text
    assert "1 lie behind it, the furthest behind, 001" in text and "by 10.0 points" in text
    assert n["lead"] == pytest.approx(0.1) and n["lag"] == pytest.approx(-0.1)
    text, n = verdict(_table([(0.5, 0.4)], [(0.9, 0.5), (0.6, 0.8)]), [])
    assert text.startswith("No torsal variant lies beyond") and "is 10.0 percentage points behind" in text
    # failed variants and missing devices: said, not guessed
    t = _table([(0.7, 0.9)], [])
    assert verdict(t, [])[0] == "No comparison: no standard device was measured."


SDA = "light.annual.daylight.fins.sda_all"
ASE = "light.annual.daylight.fins.ase_all"
AVOIDED = "light.annual.fins.shading_factor.cooling_gains_avoided_kwh_m2"
KEPT = "light.annual.fins.shading_factor.heating_gains_kept_kwh_m2"


@pytest.mark.parametrize("table, words", [
    ('[pareto]\nx = "light.shade"\n', ["pareto", "light.shade"]),
    (f'[pareto]\nx = "{SDA}"\ny = "{AVOIDED}"\n', ["pareto", "[annual] enabled"]),
    (f'[pareto]\ny = "{KEPT}"\n', ["pareto", "[annual] enabled"]),
])
def test_pareto_axes_are_report_figures_the_variants_have(tmp_path, table, words):
    """[pareto] x / y: figures the study may judge by; the annual stage's need the base
    design's [annual] enabled (and the daylight's a [room]), checked before anything runs."""
    path = _study(tmp_path, axes={"fins.depth": [0.3]}, extra=table)
    with pytest.raises(StudyFileError) as exc:
        Study.from_toml(path)
    assert all(w in str(exc.value) for w in words), str(exc.value)


def test_annual_figures_as_pareto_axes_load_with_the_annual_stage(tmp_path):
    _study(tmp_path, axes={"fins.spacing": [1.5, [1.5, 3.0]]})
    base = tmp_path / "designs" / "7a_small.toml"
    with_room = base.read_text() + "[annual]\nenabled = true\n"
    base.write_text(with_room)
    path = tmp_path / "study.toml"
    path.write_text(path.read_text() + f'[pareto]\nx = "{SDA}"\ny = "{AVOIDED}"\n')
    with pytest.raises(StudyFileError, match=r"\[room\]"):        # sDA needs the rooms
        Study.from_toml(path)
    base.write_text(with_room + "[room]\ndepth = 6.0\nheight = 3.0\n")
    study = Study.from_toml(path)
    p = study.spec.pareto
    assert (p.x, p.y, p.better("x"), p.better("y")) == (SDA, AVOIDED, "max", "max")
    assert [v.spec.fins.spacings for v in study.variants] == [(1.5, 1.5), (1.5, 3.0)]
    from torsal.study.study_file import ParetoSpec
    assert ParetoSpec(y=ASE).better("y") == "min" and ParetoSpec().is_default


def test_device_rows_carry_their_own_annual_figures():
    """A device row takes the annual stage's figures of that device (light.annual.devices.X,
    light.annual.daylight.X) under the fins' keys, so it stands on the same Pareto axes."""
    from torsal.study.study_report import _device_annual

    report = {"light": {"annual": {
        "fins": {"shading_factor": {"cooling_gains_avoided_kwh_m2": 300.0}},
        "devices": {"egg-crate": {"cooling_kwh_m2": 90.0, "seconds": 4.0,
                                  "shading_factor": {"cooling_gains_avoided_kwh_m2": 250.0}},
                    "vertical fins": {"applicable": False, "reason": "x"}},
        "daylight": {"fins": {"sda_all": 0.4}, "egg-crate": {"sda_all": 0.55, "ase_all": 0.1}}}}}
    row = _device_annual(report, "egg-crate")
    assert row[AVOIDED] == 250.0 and row[SDA] == 0.55 and row[ASE] == 0.1
    assert row["light.annual.fins.cooling_kwh_m2"] == 90.0
    assert not any(k.endswith("seconds") for k in row)
    assert _device_annual(report, "vertical fins") == {}
    assert _device_annual({"light": {}}, "egg-crate") == {}


def test_verdict_on_annual_figures_by_hand():
    """Cooling-season gains avoided (max) against ASE (min): the front and the lead are
    taken with each figure's own sense, scaled by its span over the table."""
    from torsal.study.study_file import ParetoSpec
    from torsal.study.study_report import _front, verdict

    p = ParetoSpec(x=ASE, y=AVOIDED)
    rows = [("000", "torsal", 0.10, 300.0), ("001", "torsal", 0.30, 200.0),
            ("b0", "baseline", 0.20, 250.0), ("b1", "baseline", 0.05, 100.0)]
    t = pd.DataFrame([{"id": i, "kind": k, "device": "torsal" if k == "torsal" else "egg-crate",
                       "status": "done", "fins.depth": 0.3, "fins.spacing": [0.6, 1.2],
                       ASE: x, AVOIDED: y} for i, k, x, y in rows])
    # spans: ASE 0.25, avoided 200. 000 against b0: max((0.2 - 0.1) / 0.25, (300 - 250) / 200)
    # = 0.4, against b1: max(-0.2, 1.0) = 1.0 -> lead 0.4 over b0; 001 lies behind b0 by
    # max(-0.4, -0.25) = -0.25
    text, n = verdict(t, [], pareto=p)
    assert n["beyond"] == 1 and n["best"] == "000" and n["nearest"] == "b0"
    assert n["lead"] == pytest.approx(0.4)
    assert "by 40.0% of the figures' spans" in text and "ASE 10.0%" in text
    assert "less ASE" in text and "more cooling-season gains avoided (kWh/m2)" in text
    assert "spacing [0.6, 1.2]" in text
    assert _front(t[t["kind"] == "baseline"], p)["id"].tolist() == ["b1", "b0"]
    # every variant failed before the annual stage: said, not a KeyError
    failed = t.drop(columns=[ASE, AVOIDED]).assign(status="failed")
    assert verdict(failed, [], pareto=p)[0].startswith("No comparison: no design has")
