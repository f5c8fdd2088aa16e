"""Output files: atomic writes (a failed write leaves the previous file and no temporary), and a
run's results swapped in on success only (a failed run leaves the output folder as it was)."""
import pytest

from torsal.core.atomic import atomic_path


def test_failed_write_leaves_previous_file_and_no_temporary(tmp_path):
    target = tmp_path / "sheet01.dxf"
    target.write_text("previous")

    with pytest.raises(RuntimeError, match="mid-write"):
        with atomic_path(target) as tmp:
            assert tmp.parent == tmp_path and tmp.suffix == ".dxf"  # writers pick format by suffix
            tmp.write_text("half")
            raise RuntimeError("writer failed mid-write")

    assert target.read_text() == "previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sheet01.dxf"]

    with pytest.raises(RuntimeError):
        with atomic_path(tmp_path / "new.csv") as tmp:
            tmp.write_text("half")
            raise RuntimeError("writer failed mid-write")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sheet01.dxf"]


# ---------------------------------------------------------------- results swapped in on success only
def _files(folder):
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _good_run(out, kind="design", **files):
    from torsal.pipeline.staging import Staging

    with Staging(out, kind=kind) as st:
        for name, text in files.items():
            path = st.folder / name.replace("__", "/")
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
        st.keep_only([name.replace("__", "/") for name in files])
    return st


def test_a_failed_run_leaves_the_folder_as_it_found_it(tmp_path):
    from torsal.pipeline.staging import STAGING_FOLDER, Staging

    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("the user's own")
    _good_run(out, report_json="r1", parts_csv="p1", sheets__a_dxf="a1")
    _good_run(out, kind="analyze", analysis_json="x1")
    before = _files(out)
    # a stage that fails after writing in place into the staged copies of the earlier results
    with pytest.raises(RuntimeError):
        with Staging(out, kind="design") as st:
            assert (st.folder / "parts_csv").read_text() == "p1"    # stages still find them
            with open(st.folder / "parts_csv", "w") as fh:           # written in place
                fh.write("half")
            (st.folder / "sheets" / "a_dxf").write_text("half")
            (st.folder / "report_json").unlink()
            raise RuntimeError("stage failed")
    assert _files(out) == before and not (out / STAGING_FOLDER).exists()
    note = st.failure_note()
    assert "the earlier design results (parts_csv, report_json, sheets) are left as they were" in note
    assert "not this one" in note and "nothing else was changed" in note


def test_a_killed_run_changes_nothing_and_the_next_run_cleans_up(tmp_path):
    from torsal.pipeline.staging import STAGING_FOLDER, Staging

    out = tmp_path / "out"
    out.mkdir()
    _good_run(out, report_json="r1")
    before = _files(out)
    st = Staging(out, kind="design").__enter__()        # killed: __exit__ never runs
    (st.folder / "report_json").write_text("half")
    assert {k: v for k, v in _files(out).items() if not k.startswith(STAGING_FOLDER)} == before
    _good_run(out, report_json="r2")                    # the next run starts afresh
    assert (out / "report_json").read_text() == "r2" and not (out / STAGING_FOLDER).exists()


def test_a_good_run_replaces_only_its_own_results(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    _good_run(out, report_json="r1", parts_csv="p1", sheets__a_dxf="a1")
    _good_run(out, kind="analyze", analysis_json="x1")
    _good_run(out, report_json="r2")                    # no parts list, no sheets this time
    assert sorted(p.name for p in out.iterdir()) == [".torsal-results.json", "analysis_json",
                                                     "report_json"]
    assert (out / "report_json").read_text() == "r2" and (out / "analysis_json").read_text() == "x1"


def test_a_failed_run_into_a_new_folder_leaves_no_folder(tmp_path, capsys):
    from torsal.cli import main

    (tmp_path / "bad.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1.0 2.0 3.0\n")
    assert main(["analyze", str(tmp_path / "bad.obj"), "--out", str(tmp_path / "new" / "out")]) == 2
    assert "line 4: face corner '1.0'" in capsys.readouterr().err
    assert not (tmp_path / "new" / "out").exists()
    (tmp_path / "d.toml").write_text('[surface]\nmesh = "bad.obj"\n[sun]\nvectors = [[0, -1, 1]]\n'
                                     '[fins]\nspacing = 1.0\ndepth = 0.5\n')
    assert main(["design", str(tmp_path / "d.toml"), "--out", str(tmp_path / "d_out")]) == 2
    assert "stage 'surface' failed" in capsys.readouterr().err
    assert not (tmp_path / "d_out").exists()
    # a folder that was there stays, even empty
    (tmp_path / "mine").mkdir()
    assert main(["analyze", str(tmp_path / "bad.obj"), "--out", str(tmp_path / "mine")]) == 2
    assert (tmp_path / "mine").is_dir()
