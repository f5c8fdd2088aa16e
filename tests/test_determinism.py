"""The same design file gives the same cutting files, however busy the machine (issue 40).

A small version of example 7a runs up to its fabrication twice, the second time beside a
process that keeps a core busy, each with a cache of its own (nothing is reused): parts.csv
and every DXF sheet are byte-identical, by the rows of every run and by the final cut's search.
"""
import hashlib
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from test_examples import small
from torsal.design import Design
from torsal.pipeline import DEFAULT_PIPELINE, StageCache

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "7a_facade_block.toml"


def _design(final_cut: bool) -> Design:
    spec = small(Design.from_toml(EXAMPLE)).spec
    return Design(spec.model_copy(update={
        # what a workshop cuts from; the solids' files are not what this test is about
        "outputs": spec.outputs.model_copy(update={"step": False, "rhino_3dm": False,
                                                   "ifc": False, "renders": False}),
        # (a search of 40 counted tries: what is tested is that the search repeats itself,
        # not how far it gets; the default 600 took 57 s of this test, 80 took 30 s in a
        # fresh clone's make test, beside the other worker)
        "nesting": spec.nesting.model_copy(update={"final_cut": final_cut, "tries": 40})}))


def _cut_files(folder: Path) -> dict:
    files = [folder / "parts.csv", *sorted((folder / "sheets").glob("*.dxf"))]
    return {f.relative_to(folder).as_posix(): hashlib.sha256(f.read_bytes()).hexdigest()
            for f in files}


def _run(design: Design, out: Path) -> dict:
    design.run(out, cache=StageCache(out.parent / f"{out.name}-cache"),
               pipeline=DEFAULT_PIPELINE.until("fabrication"))
    return _cut_files(out)


#: the tests that read ``quiet_runs`` run on one xdist worker, so that each quiet run (the
#: final cut's: 12 s) is made once for the two tests that read it
QUIET_RUNS = pytest.mark.xdist_group("determinism-quiet-runs")


@pytest.fixture(scope="module")
def quiet_runs(tmp_path_factory):
    """``{final_cut: (folder, cut files)}`` of small 7a run on a quiet worker, made once each
    (the folder holds the run's cache beside it, ``<folder>-cache``)."""
    made = {}

    def run(final_cut: bool):
        if final_cut not in made:
            out = tmp_path_factory.mktemp("quiet") / "out"
            made[final_cut] = (out, _run(_design(final_cut), out))
        return made[final_cut]

    return run


@QUIET_RUNS
@pytest.mark.parametrize("final_cut", [False, True], ids=["rows", "final-cut"])
def test_cut_files_are_byte_identical_under_load(tmp_path, quiet_runs, final_cut):
    design = _design(final_cut)
    _, quiet = quiet_runs(final_cut)
    busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
    try:
        loaded = _run(design, tmp_path / "loaded")
    finally:
        busy.kill()
        busy.wait()
    assert len(quiet) > 2 and quiet == loaded


@QUIET_RUNS
def test_the_final_cut_is_kept_with_the_design(tmp_path, quiet_runs):
    """Asked for again after a change that leaves the flat parts as they are (here: no parts
    list), the final cut's sheets are read back from the design's cache, not searched again."""
    design = _design(final_cut=True)
    made, first = quiet_runs(True)
    out = tmp_path / "out"                  # a copy of the run: this test writes into it
    shutil.copytree(made, out)
    shutil.copytree(made.parent / f"{made.name}-cache", out.parent / f"{out.name}-cache")
    spec = design.spec
    again = Design(spec.model_copy(update={"outputs": spec.outputs.model_copy(update={"bom": False})}))
    res = again.run(out, cache=StageCache(out.parent / f"{out.name}-cache"),
                    pipeline=DEFAULT_PIPELINE.until("fabrication"))
    assert "fabrication" not in res.cached                  # the stage ran again...
    nesting = res.report["fabrication"]["nesting"]
    assert "kept from an earlier run" in nesting["nester"]   # ... its sheets did not
    assert nesting["deterministic"] and not nesting["time_limited"]
    sheets = {k: v for k, v in first.items() if k.startswith("sheets/")}
    again_sheets = {f"sheets/{f.name}": hashlib.sha256(f.read_bytes()).hexdigest()
                    for f in sorted((out / "sheets").glob("*.dxf"))}
    assert sheets and again_sheets == sheets


_WRITE_SHEETS = """
import sys
from shapely.geometry import Polygon, box
from torsal.fabrication.nesting import Nester, nest_parts
parts = {f"p{i}": box(0, 0, 300, 100 + 10 * i) for i in range(5)}
parts["tri"] = Polygon([(0, 0), (400, 0), (0, 150)])
nest_parts(parts, sheet=(1000, 500), nester=Nester.ROWS).export_dxf(sys.argv[1], svg=False)
"""


def test_sheets_do_not_depend_on_the_process(tmp_path):
    """Two processes with different string hashing (PYTHONHASHSEED) write the same bytes: ezdxf
    adds the CLASS entries of the entity types in use from a set, whose order changed with it."""
    import os

    digests = set()
    for seed in ("1", "4", "7"):
        out = tmp_path / seed / "f.dxf"
        subprocess.run([sys.executable, "-c", _WRITE_SHEETS, str(out)], check=True,
                       env={**os.environ, "PYTHONHASHSEED": seed})
        (sheet,) = sorted(out.parent.glob("*.dxf"))
        digests.add(hashlib.sha256(sheet.read_bytes()).hexdigest())
    assert len(digests) == 1
