"""A canopy, as a user brings one: a small hyperbolic paraboloid (OBJ) and the sun from an EPW
file, both written here; ``torsal design`` compares the fins with every standard device. Each
device blocks some sun or is reported not applicable with its reason; no warning reaches the
terminal and no NaN or infinity reaches a report."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from torsal.light.devices import DEVICE_NAMES
from torsal.light.sun import write_synthetic_epw

FACADE_DEVICES = ("horizontal louvers", "vertical fins", "egg-crate")


def write_hypar(path: Path, n: int = 9, size: float = 4.5, k: float = 0.16) -> Path:
    """A hyperbolic paraboloid z = 3 + k x y over a size x size square, as an OBJ of quads.
    (4.5 m, 28 fins at 1.5 m: the 6 m one (k = 0.12, the same shape) has 45, its run costs a
    third more and shows nothing more of the devices.)"""
    x = np.linspace(-size / 2, size / 2, n)
    lines = [f"v {a:.6f} {b:.6f} {3.0 + k * a * b:.6f}" for a in x for b in x]
    for i in range(n - 1):
        for j in range(n - 1):
            c = i * n + j + 1
            lines.append(f"f {c} {c + n} {c + n + 1} {c + 1}")
    path.write_text("\n".join(lines) + "\n")
    return path


def write_canopy_design(folder: Path, **outputs) -> Path:
    """The hypar canopy in Vienna with the hot summer hours of a synthetic EPW."""
    folder.mkdir(parents=True, exist_ok=True)
    write_hypar(folder / "hypar.obj")
    write_synthetic_epw(folder / "site.epw", 48.21, 16.37, tz_hours=1.0)
    # no solids (STEP, 3DM, IFC): what is compared is the light, not the files
    opts = {"step": False, "rhino_3dm": False, "ifc": False, "dxf": False, "bom": False,
            "renders": True, "light_samples": 400, **outputs}
    out = "\n".join(f"{k} = {json.dumps(v)}" for k, v in opts.items())
    (folder / "canopy.toml").write_text(f"""name = "hypar canopy"
units = "m"
[surface]
mesh = "hypar.obj"
[sun]
epw = "site.epw"
min_temperature = 26
min_dni = 300
months = [6, 7, 8]
[goals]
block = true
[constraints]
max_iter = 300
[fins]
spacing = 1.5
depth = 0.5
[outputs]
{out}
""")
    return folder / "canopy.toml"


def _strict(text: str) -> dict:
    def refuse(name):
        raise ValueError(f"report.json holds {name}")
    return json.loads(text, parse_constant=refuse)


#: the module's tests share its design runs: one xdist worker runs them all (make test's
#: --dist loadgroup), so each runs once
pytestmark = pytest.mark.xdist_group("canopy-comparison")


@pytest.fixture(scope="module")
def canopy_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("canopy")
    design = write_canopy_design(folder)
    exe = Path(sys.executable).with_name("torsal")
    res = subprocess.run([str(exe), "design", str(design), "--out", str(folder / "out"),
                          "--accept-unbuildable"], capture_output=True, text=True, timeout=900,
                         cwd=folder)
    return folder / "out", res


def test_every_device_blocks_sun_or_says_why_not(canopy_run):
    out, res = canopy_run
    assert res.returncode == 0, res.stderr
    report = _strict((out / "report.json").read_text())
    light = report["light"]
    assert list(light["devices"]) == list(DEVICE_NAMES)
    for name, d in light["devices"].items():
        if d["applicable"]:
            assert d["blocked_share"] > 0.05, name
            assert 0 < d["view_out"] <= 1 and d["fin_area_m2"] > 0
        else:
            assert d["reason"] and "blocked_share" not in d, name
    for name in FACADE_DEVICES:                 # on a canopy: named, with the reason
        assert not light["devices"][name]["applicable"]
        assert "canopy" in light["devices"][name]["reason"]
    assert light["devices"]["optimized parallel fins"]["applicable"]
    assert light["devices"]["optimized egg-crate"]["applicable"]
    assert light["baseline_louvers"] == {"applicable": False,
                                         "reason": light["devices"]["horizontal louvers"]["reason"]}
    # the view out of the fins themselves, from eye points under the canopy
    assert light["view_measure"] == "occupant" and light["view_clear"] == light["view_out"]
    assert light["view_out_detail"]["eye_points"] > 0


def test_the_terminal_and_the_report_name_the_devices_and_no_warning(canopy_run):
    out, res = canopy_run
    text = res.stdout + res.stderr
    assert "Warning" not in text and "invalid value" not in text
    assert "louvers 0.0%" not in text
    assert "not applicable: horizontal louvers, vertical fins, egg-crate" in res.stdout
    assert "optimized parallel fins" in res.stdout
    page = (out / "report.html").read_text()
    assert page.count("not applicable:") == 3 and "optimized egg-crate" in page
    for name in ("report.json",):
        raw = (out / name).read_text()
        assert "NaN" not in raw and "Infinity" not in raw
    for p in out.rglob("*.json"):               # every JSON the run wrote
        _strict(p.read_text())
    assert not any(math.isnan(x) for x in [report_value for report_value in
                                             _numbers(_strict((out / "report.json").read_text()))])


def _numbers(x):
    if isinstance(x, dict):
        for v in x.values():
            yield from _numbers(v)
    elif isinstance(x, list):
        for v in x:
            yield from _numbers(v)
    elif isinstance(x, float):
        yield x


def test_a_light_study_of_the_canopy_has_every_device_in_its_table(tmp_path):
    """``torsal study`` over two fin depths with ``[run] fabrication = false``: each depth has
    its five device rows, the facade ones "not applicable" with the reason, the others
    measured like the torsal variants (and the verdict says which cannot be made)."""
    from torsal import Study
    from torsal.study.study_report import NOT_APPLICABLE, X_KEY, Y_KEY

    write_canopy_design(tmp_path, renders=False)
    study = tmp_path / "study.toml"
    study.write_text('name = "canopy depths"\nbase = "canopy.toml"\n[axes]\n"fins.depth" = [0.4, 0.6]\n'
                     "[run]\nworkers = 1\nfabrication = false\n")
    res = Study.from_toml(study).run(tmp_path / "out", serial=True)
    t = res.table
    torsal, base = t[t["kind"] == "torsal"], t[t["kind"] == "baseline"]
    assert (torsal["status"] == "done").all() and len(torsal) == 2
    assert "fabrication.parts" not in t.columns           # no parts were made
    assert len(base) == 2 * len(DEVICE_NAMES)
    for depth, g in base.groupby("fins.depth"):
        g = g.set_index("device")
        for name in FACADE_DEVICES:
            assert g.loc[name, "status"] == NOT_APPLICABLE and "canopy" in g.loc[name, "note"]
            assert np.isnan(g.loc[name, Y_KEY])               # never a measured 0 %
        for name in ("optimized parallel fins", "optimized egg-crate"):
            assert g.loc[name, "status"] == "done" and g.loc[name, Y_KEY] > 0.05
            assert 0 < g.loc[name, X_KEY] <= 1
    assert "cannot be made on this surface" in res.verdict
    assert "horizontal louvers" in res.verdict and "optimized egg-crate" in res.verdict
    page = (tmp_path / "out" / "study.html").read_text()
    assert page.count(NOT_APPLICABLE) >= 6
    for p in (tmp_path / "out").rglob("*.json"):
        _strict(p.read_text())


def test_the_sun_as_asked_counts_light_let_through_where_the_design_wants_it():
    """A flat roof, its left half a let-through region: a solid plate above blocks everything
    (as asked on the right half only); no fins let everything through (as asked on the left
    half only). With the sample points split by area, each scores its half."""
    import trimesh

    from torsal.geometry.surfaces import grid_faces
    from torsal.pipeline.measure import SunGoals, measure_fins

    x = np.linspace(-2.0, 2.0, 9)
    X, Y = np.meshgrid(x, x, indexing="ij")
    v, f = np.c_[X.ravel(), Y.ravel(), np.zeros(X.size)], grid_faces(9, 9)
    left = np.flatnonzero(v[f].mean(axis=1)[:, 0] < 0)
    sun = {"vectors": np.array([[0.1, 0.2, 1.0]]) / np.linalg.norm([0.1, 0.2, 1.0]),
           "weights": np.ones(1)}
    roof = trimesh.Trimesh([[-9, -9, 1], [9, -9, 1], [9, 9, 1], [-9, 9, 1]], [[0, 1, 2], [0, 2, 3]])
    full, res = measure_fins(roof, (v, f), sun, 2000, 1.0, goals=SunGoals(let_through=left))
    inside = res.points[:, 0] < 0
    assert full["blocked_share"] == 1.0
    assert full["goal_share"] == pytest.approx(1.0 - inside.mean(), abs=1e-12)
    assert full["let_through"]["passed_inside"] == 0.0 and full["let_through"]["blocked_outside"] == 1.0
    none, _ = measure_fins(trimesh.Trimesh(), (v, f), sun, 2000, 1.0, goals=SunGoals(let_through=left))
    assert none["goal_share"] == pytest.approx(inside.mean(), abs=1e-12)
    plain, _ = measure_fins(roof, (v, f), sun, 2000, 1.0)
    assert plain["goal_share"] == plain["blocked_share"] and "let_through" not in plain


def test_a_sun_region_is_measured_against_its_own_sun():
    """Fig. 7d's kind of goal on a flat wall with louvers (depth D, spacing S): the left half
    asks to block a high sun (tan profile 0.9: D 0.9 / S = 75% blocked), the rest the design
    sun (tan 0.3: 25%); the sun as asked weighs each point's own sun."""
    import trimesh

    from torsal.geometry.surfaces import grid_faces
    from torsal.light.devices import horizontal_louvers
    from torsal.pipeline.measure import SunGoals, goal_suns, measure_fins

    x, z = np.linspace(-6.0, 6.0, 25), np.linspace(0.0, 6.0, 13)
    X, Z = np.meshgrid(x, z, indexing="ij")
    v, f = np.c_[X.ravel(), np.zeros(X.size), Z.ravel()], grid_faces(25, 13)
    D, S = 0.5, 0.6
    louvers = horizontal_louvers(v, f, D, S)
    design = np.array([[0.0, -1.0, 0.3]]) / np.linalg.norm([0.0, -1.0, 0.3])
    high = np.array([[0.0, -1.0, 0.9]]) / np.linalg.norm([0.0, -1.0, 0.9])
    left = np.flatnonzero(v[f].mean(axis=1)[:, 0] < 0)
    sun = {"vectors": design, "weights": np.ones(1)}
    m, res = measure_fins(louvers, (v, f), sun, 4000, 1.0, goals=SunGoals(regions=((left, high),)))
    inside = res.points[:, 0] < 0
    # points above the top louver (z > 5.4) see the sun whatever its height: 1/10 of the wall
    below = res.points[:, 2] < 5.4
    expect_in = 0.75 * (below & inside).sum() / inside.sum()
    expect_out = 0.25 * (below & ~inside).sum() / (~inside).sum()
    assert m["sun_regions"][0]["blocked_inside"] == pytest.approx(expect_in, abs=0.03)
    assert m["blocked_share"] == pytest.approx(0.25 * below.mean(), abs=0.03)
    assert m["goal_share"] == pytest.approx(expect_in * inside.mean() + expect_out * (~inside).mean(),
                                            abs=0.03)
    # two regions (Fig. 7d has two): the right half asks for the design sun as its own
    right = np.flatnonzero(v[f].mean(axis=1)[:, 0] >= 0)
    two, _ = measure_fins(louvers, (v, f), sun, 4000, 1.0,
                          goals=SunGoals(regions=((left, high), (right, design))))
    assert [r["blocked_inside"] for r in two["sun_regions"]] == pytest.approx(
        [expect_in, expect_out], abs=0.03)
    assert two["goal_share"] == pytest.approx(m["goal_share"], abs=1e-12)
    # the devices are oriented for both suns, each over its share of the wall (half each)
    vec, w = goal_suns(SunGoals(regions=((left, high),)), v, f, sun)
    np.testing.assert_allclose(vec, [high[0], design[0]])
    np.testing.assert_allclose(w, [0.5, 0.5])
