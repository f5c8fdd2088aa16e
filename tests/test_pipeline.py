"""The pipeline as stages: declared inputs, cache keys from the design file alone, inserting
a stage, one source of default weights."""
import tomllib

import numpy as np
import pytest

from torsal.design import STAGES, Design, DesignError
from torsal.pipeline.design_file import DesignSpec, WeightsSpec
from torsal.geometry.optimize import DEFAULT_WEIGHTS
from torsal.pipeline import (DEFAULT_PIPELINE, Pipeline, Stage, StageCache, run_stages,
                             stage_keys, term_weights)

SPEC = DesignSpec.model_validate(tomllib.loads("""
[surface]
generator = "facade_patch"
params = { nu = 9, nv = 5 }
[sun]
vectors = [[0.0, -1.0, 0.5]]
[fins]
spacing = 1.5
depth = 0.4
"""))


def _depth(spec, depth):
    return spec.model_copy(update={"fins": spec.fins.model_copy(update={"depth": depth})})


def test_default_stage_order_and_public_names():
    assert STAGES == DEFAULT_PIPELINE.names
    assert STAGES[:5] == ("surface", "estimate", "sun", "orient", "congruence")
    assert STAGES.index("fabrication") < STAGES.index("report") == len(STAGES) - 1
    assert STAGES.index("fabrication") < STAGES.index("light")    # it measures the built fins


def test_keys_follow_the_inputs_only():
    a, b = stage_keys(DEFAULT_PIPELINE, SPEC), stage_keys(DEFAULT_PIPELINE, _depth(SPEC, 0.6))
    # a change of fin depth keeps every key upstream of the remeshing
    assert [s for s in STAGES if s in a and a[s] == b[s]] == ["surface", "estimate", "sun",
                                                              "orient", "congruence"]
    assert "substructure" not in a          # does not apply without a [substructure] table
    thicker = SPEC.model_copy(update={"material": SPEC.material.model_copy(
        update={"thickness_mm": 5.0})})
    c = stage_keys(DEFAULT_PIPELINE, thicker)
    # the light stage measures the fins as built: the plate thickness decides which panels
    # the fabrication leaves out
    assert {s for s in a if a[s] != c[s]} == {"fabrication", "light", "pictures", "assembly",
                                              "report"}


def test_unset_weights_come_from_the_optimizer_defaults():
    w, given = term_weights(WeightsSpec())
    assert w == DEFAULT_WEIGHTS and given == set()
    w, given = term_weights(WeightsSpec(perp=10, dir=0.4))
    assert w["perpendicular"] == 10 and w["torsal_direction"] == 0.4 and w["fair"] == DEFAULT_WEIGHTS["fair"]
    assert given == {"perpendicular", "torsal_direction"}


def _toy_pipeline(calls):
    def src(inp):
        calls.append("src")
        return {"x": inp.spec.fins.spacing, "report": {"x": inp.spec.fins.spacing}}

    def double(inp):
        calls.append("double")
        return {"y": 2 * inp["src"]["x"]}

    return Pipeline((Stage("src", src, key=lambda s: (s.fins.spacing,)),
                     Stage("double", double, inputs=("src",))))


def test_a_stage_inserted_after_another_reads_its_inputs_and_caches(tmp_path):
    calls = []

    def triple(inp):
        calls.append("triple")
        return {"report": {"z": 3 * inp["double"]["y"]}}

    p = _toy_pipeline(calls).insert(Stage("triple", triple, inputs=("double",),
                                          key=lambda s: (s.fins.depth,)), after="double")
    assert p.names == ("src", "double", "triple")
    cache = StageCache(tmp_path / "cache")
    run = run_stages(p, SPEC, tmp_path, cache)
    assert run.report == {"src": {"x": 1.5}, "triple": {"z": 9.0}} and run.cached == []
    # a change of depth: only the stage whose key names it runs again
    calls.clear()
    run = run_stages(p, _depth(SPEC, 0.9), tmp_path, cache)
    assert calls == ["triple"] and run.cached == ["src", "double"]
    assert len(list((tmp_path / "cache").glob("triple-*.pkl"))) == 1   # pruned: one per stage
    shared = StageCache(tmp_path / "shared", prune=False)
    run_stages(p, SPEC, tmp_path, shared)
    run_stages(p, _depth(SPEC, 0.9), tmp_path, shared)
    assert len(list((tmp_path / "shared").glob("triple-*.pkl"))) == 2


def test_undeclared_inputs_and_bad_pipelines_are_errors(tmp_path):
    def sneaky(inp):
        return {"y": inp["src"]["x"]}

    p = Pipeline((Stage("src", lambda inp: {"x": 1}), Stage("sneaky", sneaky)))
    with pytest.raises(DesignError, match="stage 'sneaky'.*reads 'src'.*not among its declared"):
        run_stages(p, SPEC, tmp_path, StageCache(tmp_path / "c"))
    with pytest.raises(ValueError, match="reads \\['nope'\\]"):
        Pipeline((Stage("a", sneaky, inputs=("nope",)),))
    with pytest.raises(ValueError, match="unique"):
        DEFAULT_PIPELINE.insert(Stage("light", sneaky), after="fabrication")
    with pytest.raises(KeyError, match="no stage 'nope'"):
        DEFAULT_PIPELINE.insert(Stage("x", sneaky), after="nope")


def test_design_run_takes_a_pipeline(tmp_path):
    seen = {}

    def stop(inp):
        seen["faces"] = len(inp["orient"]["faces"])
        return {"report": {"faces": seen["faces"]}}

    p = DEFAULT_PIPELINE.until("orient").insert(Stage("count", stop, inputs=("orient",)),
                                                after="orient")
    res = Design(SPEC).run(tmp_path, pipeline=p)
    assert res.report["count"]["faces"] == res.report["surface"]["faces"] == seen["faces"] > 0


# ---------------------------------------------------------------- worker caps (core.parallel)
def test_limit_workers_caps_nested_and_restores():
    from torsal.core.parallel import limit_workers, usable_workers

    assert usable_workers(3) == 3
    with limit_workers(2):
        assert usable_workers(3) == 2
        assert usable_workers(1) == 1
        with limit_workers(1):
            assert usable_workers(8) == 1
        assert usable_workers(3) == 2
    assert usable_workers(3) == 3
    with pytest.raises(ValueError, match="n >= 1"):
        with limit_workers(0):
            pass


def test_serial_study_executor_runs_its_tasks_on_one_process():
    from torsal.core.parallel import usable_workers
    from torsal.study.study_tasks import SerialExecutor

    ex = SerialExecutor()
    job = ex.submit(usable_workers, 4)
    assert ex.wait([job]) == [job]
    assert ex.result(job) == 1          # inside: the stages' pools are capped to this process
    assert usable_workers(4) == 4       # outside: not


def test_built_structure_leaves_out_the_fins_the_fabrication_did_not_build():
    from torsal.geometry.support import SupportStructure
    from torsal.pipeline.stages import built_structure

    a = np.array([[0., 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [1, 1, 0], [2, 1, 0]])
    s = SupportStructure(a, a + [0, 0, 1], [[0, 1, 4, 3], [1, 2, 5, 4]],
                         np.array([[0, 1], [1, 2], [3, 4], [4, 5], [0, 3], [1, 4], [2, 5]]),
                         np.array([0, 0, 0, 0, 1, 1, 1]))
    assert built_structure(s, []) is s
    b = built_structure(s, [5, 1])
    assert b.edges.tolist() == [[0, 1], [3, 4], [4, 5], [0, 3], [2, 5]]
    assert b.edge_family.tolist() == [0, 0, 0, 1, 1]
    # each fin is one planar quad a_i a_j b_j b_i of unit area: 5 left of 7
    m = b.fin_mesh()
    assert np.isclose(m.area, 5.0)


def test_the_report_says_when_the_optimized_lines_are_nearly_parallel():
    """Below NEARLY_PARALLEL_DEG the report's row says the fins all contain nearly one direction
    (examples 7a and 7b end at 0.2 degrees); above, it gives the number only."""
    from torsal.pipeline.report import NEARLY_PARALLEL_DEG, _spread_rows

    rows = _spread_rows({"line_spread_deg": 0.16, "substructure_line_spread_deg": 7.0})
    assert [r[0].split(" the ")[1].split(" from")[0] for r in rows] == ["lines", "substructure lines"]
    assert rows[0][1].startswith("0.16 (nearly parallel") and rows[1][1] == "7.00"
    assert "nearly parallel" not in _spread_rows({"line_spread_deg": NEARLY_PARALLEL_DEG})[0][1]
    assert _spread_rows({}) == []        # a report cached before the key existed


def test_the_support_report_counts_each_familys_strips_fins_and_area():
    """report.json support.families: spacing and depth as asked, and each family's strips,
    fins and one-side fin area as built (a 3 x 3 grid of vertical 0.4 m node lines, rows 0.3 m
    and columns 0.2 m long, family 1 half as deep)."""
    import numpy as np

    from torsal.geometry.support import SupportStructure
    from torsal.pipeline.design_file import validate_design
    from torsal.pipeline.stages import family_figures

    spec = validate_design({"surface": {"generator": "flat_facade"},
                            "sun": {"vectors": [[0, -1, 1]]},
                            "fins": {"spacing": [0.2, 0.3], "depth": [0.4, 0.2]}})
    x, y = np.meshgrid(np.arange(3) * 0.3, np.arange(3) * 0.2)
    a = np.stack([x, y, 0 * x], axis=-1).reshape(-1, 3)
    idx = np.arange(9).reshape(3, 3)
    edges = np.r_[np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()],
                  np.c_[idx[:-1, :].ravel(), idx[1:, :].ravel()]]
    s = SupportStructure(a, a + [0, 0, 0.4], [], edges, np.r_[[0] * 6, [1] * 6],
                         family_depth_ratio=(1.0, 0.5))
    f = family_figures(s, spec)
    assert f["spacing"] == [0.2, 0.3] and f["depth"] == [0.4, 0.2]
    assert f["strips"] == [3, 3] and f["fins"] == [6, 6]
    assert np.allclose(f["fin_area_m2"], [6 * 0.3 * 0.4, 6 * 0.2 * 0.2])


def test_support_obj_and_3d_view_draw_each_family_at_its_depth(tmp_path):
    """support.obj's fins_family_1 quads and the 3D view's family-1 triangles end at family 1's
    depth (half of the node line here), family 0's at B."""
    import numpy as np

    from torsal.geometry.support import SupportStructure
    from torsal.pipeline.outputs import write_structure_obj
    from torsal.pipeline.report_3d import _fin_triangles

    a = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    s = SupportStructure(a, a + [0, 0, 0.4], [[0, 1, 2, 3]],
                         np.array([[0, 1], [1, 2], [3, 2], [0, 3]]), np.array([0, 1, 0, 1]),
                         family_depth_ratio=(1.0, 0.5))
    write_structure_obj(tmp_path / "s.obj", s)
    lines = (tmp_path / "s.obj").read_text().splitlines()
    v = np.array([[float(x) for x in ln.split()[1:]] for ln in lines if ln.startswith("v ")])
    group, top = None, {0: set(), 1: set()}
    for ln in lines:
        if ln.startswith("g "):
            group = ln.split()[1]
        elif ln.startswith("f ") and group.startswith("fins_family_"):
            top[int(group[-1])] |= {round(v[int(i) - 1, 2], 9) for i in ln.split()[1:]}
    assert top == {0: {0.0, 0.4}, 1: {0.0, 0.2}}
    nodes, tris, _ = _fin_triangles(s, 10)
    assert set(np.round(nodes[tris[0].ravel(), 2], 9)) == {0.0, 0.4}
    assert set(np.round(nodes[tris[1].ravel(), 2], 9)) == {0.0, 0.2}


def test_support_obj_of_two_depths_reads_back_for_the_hosts(tmp_path):
    """The hosts' reader of support.obj (the notebook's figure) finds each family's far ends:
    family 1 at half the depth, family 0 at B; equal depths read as before."""
    import numpy as np

    from torsal.geometry.support import SupportStructure
    from torsal.hosts.figure import read_support_obj
    from torsal.pipeline.outputs import write_structure_obj
    from torsal.pipeline.report_3d import _fin_triangles

    a = np.array([[0.0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    edges, fam = np.array([[0, 1], [1, 2], [3, 2], [0, 3]]), np.array([0, 1, 0, 1])
    for ratio, top1 in (((1.0, 0.5), 0.2), ((1.0, 1.0), 0.4)):
        s = SupportStructure(a, a + [0, 0, 0.4], [[0, 1, 2, 3]], edges, fam,
                             family_depth_ratio=ratio)
        write_structure_obj(tmp_path / "s.obj", s)
        back = read_support_obj(tmp_path / "s.obj")
        np.testing.assert_allclose(back.vertices_a, a, atol=1e-12)
        np.testing.assert_allclose(back.family_vertices_b(0)[:, 2], 0.4, atol=1e-12)
        np.testing.assert_allclose(back.family_vertices_b(1)[:, 2], top1, atol=1e-12)
        assert back.family_depth_ratio == pytest.approx(ratio)
        nodes, tris, _ = _fin_triangles(back, 10)
        assert set(np.round(nodes[tris[1].ravel(), 2], 9)) == {0.0, top1}


# ---------------------------------------------------------------- concurrent stages
def _src(inp):
    return {"x": inp.spec.fins.spacing, "report": {"x": inp.spec.fins.spacing}}


def _pid(inp):
    import os

    from torsal.core.errors import TorsalError

    if inp.spec.fins.depth > 1:
        raise TorsalError("fins.depth above 1 refused (the test's bad input)")
    return {"pid": os.getpid(), "y": 2 * inp["src"]["x"], "report": {"y": 2 * inp["src"]["x"]}}


def _pid_key(spec):
    return (spec.fins.depth,)


def _after(inp):
    return {"report": {"z": inp["pid"]["y"] + 1}}


def _preloaded(inp):
    import os
    import sys

    return {"pid": os.getpid(), "imported": "colorsys" in sys.modules, "nice": os.nice(0)}


def test_a_concurrent_stage_starts_once_its_inputs_are_done_its_modules_imported(tmp_path,
                                                                               monkeypatch):
    import os

    from torsal.fabrication.workers import BACKGROUND_NICE
    from torsal.pipeline import stage as stage_module

    events = []
    made = []
    real = stage_module._Concurrent

    def counted(name, preload=(), low_priority=False):
        made.append((name, preload))
        return real(name, preload, low_priority)

    monkeypatch.setattr(stage_module, "_Concurrent", counted)
    p = Pipeline((Stage("src", _src), Stage("other", _src), Stage("third", _src),
                  Stage("pid", _preloaded, inputs=("src",), key=_pid_key, concurrent=True,
                        preload=("colorsys",), low_priority=True),
                  Stage("after", _after_preloaded, inputs=("pid",))))
    run = run_stages(p, SPEC, tmp_path, StageCache(tmp_path / "c"),
                     progress=lambda stage, event, info: events.append((stage, event)))
    # listed after "other" and "third", started as soon as "src" was done; one process
    # each, made when the run started, which imported the stage's module and its preload
    assert events.index(("pid", "start")) < events.index(("other", "start"))
    assert made == [("pid", ("test_pipeline", "colorsys"))]
    assert run.values["pid"]["pid"] != os.getpid() and run.values["pid"]["imported"]
    # low_priority: at a lower priority than the stages the run waits for
    assert run.values["pid"]["nice"] == min(19, os.nice(0) + BACKGROUND_NICE)
    assert run.report["after"] == {"imported": True}
    # found in the cache: no process is started for it
    made.clear()
    again = run_stages(p, SPEC, tmp_path, StageCache(tmp_path / "c"))
    assert made == [] and "pid" in again.cached and again.report == run.report


def _after_preloaded(inp):
    return {"report": {"imported": inp["pid"]["imported"]}}


def _refused(inp):
    from torsal.core.errors import TorsalError

    raise TorsalError("the test's bad input")


def test_a_failed_run_stops_the_processes_started_for_later_stages(tmp_path):
    import multiprocessing as mp

    p = Pipeline((Stage("src", _src), Stage("bad", _refused),
                  Stage("pid", _preloaded, inputs=("bad",), concurrent=True)))
    with pytest.raises(DesignError, match="stage 'bad' failed"):
        run_stages(p, SPEC, tmp_path, StageCache(tmp_path / "c"))
    assert not [c for c in mp.active_children() if c.name.startswith("torsal-stage-")]


def test_a_concurrent_stage_runs_in_a_process_of_its_own_with_the_same_result(tmp_path):
    import os

    from torsal.core.parallel import limit_workers

    events = []
    p = Pipeline((Stage("src", _src), Stage("pid", _pid, inputs=("src",), key=_pid_key,
                                                       concurrent=True),
                  Stage("other", _src), Stage("after", _after, inputs=("pid",))))
    run = run_stages(p, SPEC, tmp_path, StageCache(tmp_path / "c"),
                     progress=lambda stage, event, info: events.append((stage, event)))
    assert run.values["pid"]["pid"] != os.getpid()          # computed in another process
    assert run.report == {"src": {"x": 1.5}, "pid": {"y": 3.0}, "other": {"x": 1.5},
                          "after": {"z": 4.0}}
    # started in order, collected when a later stage reads it; its seconds are its own
    assert events.index(("pid", "start")) < events.index(("other", "start"))
    assert events.index(("pid", "done")) < events.index(("after", "start"))
    assert run.stage_seconds["pid"] >= 0
    with limit_workers(1):                                   # no second process: in order
        alone = run_stages(p, SPEC, tmp_path, StageCache(tmp_path / "c", enabled=False))
    assert alone.values["pid"]["pid"] == os.getpid() and alone.report == run.report
    # the input's fault, found in the other process, names the stage as in this one
    with pytest.raises(DesignError, match="stage 'pid' failed: fins.depth above 1") as err:
        run_stages(p, _depth(SPEC, 1.5), tmp_path, StageCache(tmp_path / "c"))
    assert err.value.stage == "pid"


def _write_after(path, seconds, text):
    import time

    time.sleep(seconds)
    path.write_text(text)
    return path


def _writes_in_a_process(inp):
    from torsal.core.parallel import ForkedCall

    inp.defer(ForkedCall(_write_after, inp.out / "late.txt", 0.5, "written"))
    return {"files": {"late": "late.txt"}, "report": {"deferred": True}}


def test_a_deferred_file_is_written_before_the_run_ends_and_then_cached(tmp_path):
    cache = StageCache(tmp_path / "c")
    seen = []

    def after(inp):                     # runs while the deferred process still writes
        seen.append((inp.out / "late.txt").exists())
        return {}

    p = Pipeline((Stage("late", _writes_in_a_process), Stage("after", after, inputs=("late",))))
    run = run_stages(p, SPEC, tmp_path, cache)
    assert seen == [False]              # the next stage did not wait for it
    assert (tmp_path / "late.txt").read_text() == "written" and run.files["late"] == "late.txt"
    assert cache.has("late", run.keys["late"])          # cached once its file was there
    assert run_stages(p, SPEC, tmp_path, cache).cached == ["late", "after"]


def test_a_failed_run_stops_a_deferred_process_and_caches_nothing(tmp_path):
    import multiprocessing as mp

    cache = StageCache(tmp_path / "c")
    p = Pipeline((Stage("late", _writes_in_a_process), Stage("bad", _refused, inputs=("late",))))
    with pytest.raises(DesignError, match="stage 'bad' failed"):
        run_stages(p, SPEC, tmp_path, cache)
    assert not [c for c in mp.active_children() if c.name == "torsal-_write_after"]
    assert not (tmp_path / "late.txt").exists()
    assert not cache.has("late", stage_keys(p, SPEC)["late"])


def _fails_in_a_process(inp):
    from torsal.core.parallel import ForkedCall

    inp.defer(ForkedCall(_write_after, inp.out / "missing" / "late.txt", 0.0, "x"))
    return {"files": {"late": "missing/late.txt"}}


def test_a_deferred_process_s_error_fails_the_run_naming_the_stage(tmp_path):
    cache = StageCache(tmp_path / "c")
    with pytest.raises(FileNotFoundError) as e:
        run_stages(Pipeline((Stage("late", _fails_in_a_process),)), SPEC, tmp_path, cache)
    assert "in stage 'late'" in e.value.__notes__    # a bug's error, named like the stage's own
    assert not cache.has("late", stage_keys(Pipeline((Stage("late", _fails_in_a_process),)),
                                            SPEC)["late"])
