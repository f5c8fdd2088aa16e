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
    assert sorted(p.name for p in out.iterdir()) == [".torsal-results.json", "analysis.json",
                                                     "torsal_field.png"]


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
    # the example of the section "In Python" (other sections show fragments)
    code = re.search(r"```python\n(.*?)```", text.split("\n## In Python", 1)[1], re.S).group(1)
    assert len(code.strip().splitlines()) <= 12
    exec(compile(code, "README.md", "exec"), {})


# ---------------------------------------------------------------- the command line as a user meets it
TINY_DESIGN = """
name = "tiny [draft]"
[surface]
generator = "facade_patch"
params = {{ nu = 7, nv = 5, width = {width}, height = 3.0 }}
[sun]
vectors = [[0.3, -0.8, 0.5], [0.5, -0.7, 0.4]]
[fins]
spacing = {spacing}
depth = 0.5
[outputs]
step = false
rhino_3dm = false
renders = false
dxf = false
ifc = false
light_samples = 100
"""


def tiny_design(*, spacing: float = 1.0, width: float = 6.0) -> str:
    """The tiny design file's text: a ``width`` x 3 m facade patch (metres), fins ``spacing``
    apart (metres: a wrong unit is what some tests type)."""
    return TINY_DESIGN.format(spacing=spacing, width=width)


def test_messages_are_printed_literally(tmp_path, capsys):
    bad = tmp_path / "d.toml"
    bad.write_text(tiny_design(spacing=1.0).replace("[sun]\n", "[sun]\nhours = [25, 3]\n"))
    assert main(["design", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    # rich markup used to eat "[h0, h1]" and "[25.0, 3.0]"
    assert "sun.hours = [25.0, 3.0] must be [h0, h1] with 0 <= h0 <= h1 <= 24" in err
    assert "Traceback" not in err


@pytest.mark.parametrize("case", ["empty", "file", "under-file", "unwritable"])
def test_output_folder_problems_exit_2_naming_the_path(facade, tmp_path, capsys, case):
    (tmp_path / "afile").write_text("x")
    out = {"empty": "", "file": str(tmp_path / "afile"), "under-file": str(tmp_path / "afile" / "o"),
           "unwritable": "/proc/torsal-out"}[case]
    assert main(["analyze", str(facade[0]), "--out", out]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --out") and "Traceback" not in err
    assert {"empty": "the path is empty", "file": "is a file, not a folder",
            "under-file": "afile is a file, so there can be no folder under it",
            "unwritable": "/proc/torsal-out: cannot write there"}[case] in err
    assert not Path("report.html").exists()


def test_internal_errors_exit_1_with_one_line_and_debug_shows_the_traceback(facade, capsys,
                                                                            monkeypatch):
    import importlib

    an = importlib.import_module("torsal.pipeline.analyze")  # the module, not the function

    def broken(*a, **k):
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(an, "load_mesh", broken)
    assert main(["analyze", str(facade[0])]) == 1
    err = capsys.readouterr().err
    assert err.splitlines()[0] == "error: internal error: ZeroDivisionError: float division by zero"
    assert "--debug" in err and "Traceback" not in err
    assert main(["analyze", str(facade[0]), "--debug"]) == 1
    assert "Traceback (most recent call last)" in capsys.readouterr().err


def test_design_progress_streams_line_by_line_when_piped(tmp_path):
    """A real `torsal design ... | cat`: progress lines arrive while the run goes on, and the
    output ends with a newline."""
    design = tmp_path / "d.toml"
    design.write_text(tiny_design(spacing=1.0))
    exe = Path(sys.executable).with_name("torsal")
    proc = subprocess.Popen([str(exe), "design", str(design), "--out", str(tmp_path / "o")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = proc.stdout.readline()
    still_running = proc.poll() is None  # the first line came before the run ended
    rest, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert first.startswith("tiny [draft]: ") and still_running
    out = first + rest
    assert re.search(r"^\[ *\d+\.\d s\] congruence: running$", out, re.M)
    assert re.search(r"^\[ *\d+\.\d s\] fabrication: done \(\d+\.\d s\)$", out, re.M)
    assert out.endswith("report.html)\n") and "Traceback" not in err


def _snapshot(folder):
    """Every file under ``folder`` (the stage cache aside) -> its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and ".torsal-cache" not in p.parts}


def test_failed_design_leaves_the_earlier_results_as_they_were(tmp_path, capsys):
    design = tmp_path / "d.toml"
    design.write_text(tiny_design(spacing=1.0))
    out = tmp_path / "o"
    assert main(["design", str(design), "--out", str(out)]) == 0
    assert (out / "report.json").exists() and (out / "parts.csv").exists()
    before = _snapshot(out)
    capsys.readouterr()
    design.write_text(tiny_design(spacing=0.001))  # metres typed as if millimetres
    assert main(["design", str(design), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "stage 'estimate' failed" in err and "fins about" in err and "fins.spacing" in err
    assert "--no-size-limit" in err
    assert "the earlier design results (" in err and "are left as they were" in err
    assert "not this one" in err
    # byte for byte as before (report, parts list, congruence, the results list); cache aside
    assert _snapshot(out) == before
    assert (out / ".torsal-cache").is_dir() and not (out / ".torsal-staging").exists()
    # the cache stays: the good design again reuses every stage up to the results
    design.write_text(tiny_design(spacing=1.0))
    assert main(["design", str(design), "--out", str(out)]) == 0
    assert "congruence: cached" in capsys.readouterr().out
    assert (out / "report.json").exists()


def test_design_on_an_obj_with_uv_seams_runs_on_the_merged_mesh(tmp_path, capsys):
    """Used to fail after a minute with "13 face-connected components"."""
    sys.path.insert(0, str(ROOT / "tests"))
    import mesh_cases as mc

    v, f = facade_patch(nu=7, nv=5, width=6.0, height=3.0)
    (tmp_path / "seams.obj").write_text(mc.obj_text(*mc.split_per_face(v, f), uv=True))
    design = tmp_path / "d.toml"
    design.write_text(tiny_design(spacing=1.0).replace(
        'generator = "facade_patch"\nparams = { nu = 7, nv = 5, width = 6.0, height = 3.0 }',
        'mesh = "seams.obj"'))
    assert main(["design", str(design), "--out", str(tmp_path / "o")]) == 0, capsys.readouterr().err
    surface = json.loads((tmp_path / "o" / "report.json").read_text())["surface"]
    assert surface["vertices"] == len(v) and surface["faces"] == len(f)
    assert surface["mesh_file"]["file_vertices"] == 3 * len(f)
    assert surface["mesh_file"]["merged"] == 3 * len(f) - len(v)
    said = capsys.readouterr().out
    assert (f"surface: {len(v)} vertices from {3 * len(f)} in the file "
            f"({3 * len(f) - len(v)} merged at the same position" in said)
    # the verdict of the assembly check, with the numbers of the report
    a = json.loads((tmp_path / "o" / "report.json").read_text())["fabrication"]["assembly"]
    assert a["buildable"]
    assert (f"assembly: buildable, 0 of {a['pairs_checked']} touching part pairs interfere; "
            f"{a['steps']} assembly steps" in said)


def test_analyze_reports_the_merge_and_ends_with_a_newline(tmp_path, capsys):
    sys.path.insert(0, str(ROOT / "tests"))
    import mesh_cases as mc

    (tmp_path / "cube.obj").write_text(mc.obj_text(mc.CUBE_V, mc.CUBE_QUADS, normals="face"))
    np.savetxt(tmp_path / "d.txt", np.repeat(mc.CUBE_V - 0.5, 1, axis=0))
    assert main(["analyze", str(tmp_path / "cube.obj"), "--directions", str(tmp_path / "d.txt")]) == 0
    out = capsys.readouterr().out
    assert re.search(r"vertices / faces\s+│ 8 / 12", out)
    assert re.search(r"directions rows\s+│ one per vertex", out)
    assert out.endswith("s\n")  # "done in 0.01 s" and a newline: nothing glued to the next line


def test_no_size_limit_runs_a_design_above_the_limits(tmp_path, capsys, monkeypatch):
    import importlib

    checks = importlib.import_module("torsal.pipeline.checks")
    monkeypatch.setitem(checks.SIZE_LIMITS, "fins", 20)  # the tiny design has about 55 fins
    design = tmp_path / "d.toml"
    design.write_text(tiny_design(spacing=1.0))
    assert main(["design", str(design), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert re.search(r"fins about \d+ \(limit 20\): change fins.spacing", err)
    assert main(["design", str(design), "--out", str(tmp_path / "o"), "--no-size-limit"]) == 0
    est = json.loads((tmp_path / "o" / "report.json").read_text())["estimate"]
    fins = json.loads((tmp_path / "o" / "report.json").read_text())["support"]["edges"]
    assert est["fins"] > 20 and est["limits"]["fins"] == 20
    assert 0.5 < est["fins"] / fins < 2  # the estimate is the right size


@pytest.mark.parametrize("which", ["design", "directions", "mesh"])
def test_unreadable_input_files_exit_2(facade, tmp_path, capsys, monkeypatch, which):
    """A file without read permission (simulated: the tests may run as root, who reads anyway)."""
    design = tmp_path / "d.toml"
    design.write_text(tiny_design(spacing=1.0))
    np.savetxt(tmp_path / "d.txt", np.ones((len(facade[1]), 3)))
    target = {"design": design, "directions": tmp_path / "d.txt", "mesh": facade[0]}[which]
    real = Path.read_bytes

    def read_bytes(self):
        if self == target:
            raise PermissionError(13, "Permission denied", str(self))
        return real(self)

    monkeypatch.setattr(Path, "read_bytes", read_bytes)
    argv = (["design", str(design), "--out", str(tmp_path / "o")] if which == "design" else
            ["analyze", str(facade[0]), "--directions", str(tmp_path / "d.txt")])
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"{which} file {target} cannot be read (permission denied)" in err
    assert "Traceback" not in err


def test_value_errors_of_torsal_checks_are_bad_input_of_libraries_are_bugs(facade, capsys, monkeypatch):
    import importlib

    an = importlib.import_module("torsal.pipeline.analyze")

    def library_bug(*a, **k):
        return np.zeros(3).reshape(2, 2)  # numpy raises: a bug, not the input

    monkeypatch.setattr(an, "load_mesh", library_bug)
    assert main(["analyze", str(facade[0])]) == 1
    assert "internal error: ValueError: cannot reshape" in capsys.readouterr().err


def test_a_surface_that_folds_back_is_named(tmp_path, capsys):
    (tmp_path / "fold.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1e-9 1e-9 1e-9\nf 1 2 3\nf 2 4 3\n")
    assert main(["analyze", str(tmp_path / "fold.obj"), "--no-plot"]) == 2
    # vertex 4 merges into vertex 1: the second face is the first one turned over
    assert "faces [0, 1] are the same triangles twice with opposite windings: the surface lies " \
        "on itself there (both sides of it exported, or a fold)" in capsys.readouterr().err


def test_staging_replaces_only_the_results_of_its_own_kind(tmp_path):
    from torsal.pipeline.staging import RESULTS_LIST, Staging

    out = tmp_path / "o"
    out.mkdir()
    (out / "notes.txt").write_text("the user's own file")
    with Staging(out, kind="design") as st:
        (st.folder / "report.json").write_text("design 1")
        (st.folder / "sheets").mkdir()
        (st.folder / "sheets" / "a.dxf").write_text("dxf")
        st.keep_only(["report.json", ["sheets/a.dxf"]])
    with Staging(out, kind="analyze") as st:
        (st.folder / "analysis.json").write_text("analysis 1")
    names = sorted(p.name for p in out.iterdir())
    assert names == [RESULTS_LIST, "analysis.json", "notes.txt", "report.json", "sheets"]
    listed = (out / RESULTS_LIST).read_text()
    # a design run that fails changes nothing: results, sheets, the results list
    with pytest.raises(RuntimeError):
        with Staging(out, kind="design") as st:
            (st.folder / "report.json").write_text("half of design 2")
            (st.folder / "sheets" / "a.dxf").write_text("half a sheet")  # written in place
            raise RuntimeError("stage failed")
    assert sorted(p.name for p in out.iterdir()) == [RESULTS_LIST, "analysis.json", "notes.txt",
                                                     "report.json", "sheets"]
    assert (out / "report.json").read_text() == "design 1"
    assert (out / "sheets" / "a.dxf").read_text() == "dxf"
    assert (out / RESULTS_LIST).read_text() == listed
    note = st.failure_note()
    assert "the earlier design results (report.json, sheets) are left as they were" in note
    assert "from the run finished 20" in note and "not this one" in note
    # a design run that no longer writes sheets/ leaves no stale sheets behind
    with Staging(out, kind="design") as st:
        (st.folder / "report.json").write_text("design 3")
        (st.folder / "sheets").mkdir(exist_ok=True)  # the earlier sheets are copied in
        st.keep_only(["report.json", "sheets"])
    with Staging(out, kind="design") as st:
        (st.folder / "report.json").write_text("design 4")
        st.keep_only(["report.json"])
    assert not (out / "sheets").exists() and (out / "report.json").read_text() == "design 4"
    assert (out / "notes.txt").exists() and (out / "analysis.json").read_text() == "analysis 1"
