"""The torsal command line and the README example, run as a user would."""
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from torsal.cli import main
from torsal.geometry.surfaces import facade_patch

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def facade(tmp_path):
    v, f = facade_patch(nu=13, nv=9)
    path = tmp_path / "facade.obj"
    trimesh.Trimesh(v, f, process=False).export(path)
    return path, v, f


def test_analyze_writes_json_and_png(facade, tmp_path, capsys):
    path, v, f = facade
    out = tmp_path / "out"
    assert main(["analyze", str(path), "--out", str(out)]) == 0
    data = json.loads((out / "analysis.json").read_text())
    assert data["vertices"] == len(v) and data["faces"] == len(f)
    assert data["hyperbolic_share"] == 1.0
    assert 0 < data["focal_distance"]["min"] <= data["focal_distance"]["max"]
    assert data["normality_residual_relative"]["max"] < 0.05
    png = (out / "torsal_field.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000
    assert "hyperbolic faces" in capsys.readouterr().out
    # a second run replaces the files and leaves no temporary files behind
    assert main(["analyze", str(path), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["analysis.json", "torsal_field.png"]


def test_analyze_with_directions_file(facade, tmp_path):
    path, v, f = facade
    d = np.tile([0.0, -1.0, 0.2], (len(v), 1)) + 0.3 * np.c_[v[:, 0] / 6, np.zeros(len(v)), v[:, 2] / 6]
    for name, save in (("d.txt", lambda p: np.savetxt(p, d)),
                       ("d.csv", lambda p: np.savetxt(p, d, delimiter=",")),
                       ("d.npy", lambda p: np.save(p, d))):
        save(tmp_path / name)
        out = tmp_path / ("out_" + name)
        assert main(["analyze", str(path), "--directions", str(tmp_path / name), "--out", str(out),
                     "--no-plot"]) == 0
        data = json.loads((out / "analysis.json").read_text())
        assert data["directions"].endswith(name)
        assert data["normality_residual_relative"]["max"] > 1e-3  # not a normal congruence


@pytest.mark.parametrize("problem, match", [
    ("missing", "not found"),
    ("nan", "NaN"),
    ("rows", "5 rows, but the mesh has 117 vertices"),
])
def test_bad_input_exits_2_with_a_message(facade, tmp_path, capsys, problem, match):
    path, v, f = facade
    args = ["analyze", str(path), "--out", str(tmp_path / "o")]
    if problem == "missing":
        args[1] = str(tmp_path / "nope.obj")
    elif problem == "nan":
        bad = tmp_path / "nan.obj"
        lines = path.read_text().splitlines()
        i = next(k for k, line in enumerate(lines) if line.startswith("v "))
        lines[i] = "v nan 0 0"
        bad.write_text("\n".join(lines))
        args[1] = str(bad)
    else:
        np.savetxt(tmp_path / "short.txt", np.ones((5, 3)))
        args += ["--directions", str(tmp_path / "short.txt")]
    assert main(args) == 2
    assert re.search(match, capsys.readouterr().err)
    assert not (tmp_path / "o" / "analysis.json").exists()


def test_console_script_is_installed(facade, tmp_path):
    exe = Path(sys.executable).with_name("torsal")
    res = subprocess.run([str(exe), "analyze", str(facade[0]), "--no-plot"],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert "hyperbolic faces" in res.stdout


def test_readme_python_example_runs():
    text = (ROOT / "README.md").read_text()
    code = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    assert len(code.strip().splitlines()) <= 12
    exec(compile(code, "README.md", "exec"), {})
