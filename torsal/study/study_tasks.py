"""What a study runs on its workers: one variant's pipeline, one set of standard devices;
and the executors that run them (in this process, or as Dask tasks)."""
from __future__ import annotations

import json
import logging
import time
import uuid
import warnings
from dataclasses import dataclass, replace
from pathlib import Path

from .._version import __version__
from ..core.parallel import limit_workers
from ..core.atomic import atomic_path, write_json
from ..pipeline.cache import StageCache
from ..pipeline.design import Design
from ..pipeline.devices import DEVICES_PIPELINE
from ..pipeline.errors import DesignError
from ..pipeline.stage import Pipeline, StageRun, run_stages, stage_keys
from ..pipeline.stages import DEFAULT_PIPELINE
from .study_file import Variant

__all__ = ["SHARED_STAGE", "StudyProgress", "flatten", "material_kg", "run_variant", "lost_outcome", "measure_devices",
           "SerialExecutor", "DaskExecutor", "LIGHT_PIPELINE", "variant_pipeline", "variant_spec",
           "ALL_FILES"]
#: the stage whose result variants share: its solve is what the cache saves
SHARED_STAGE = "congruence"
_FABRICATION = ("fabrication", "assembly")


def _without_fabrication(pipeline: Pipeline) -> Pipeline:
    return Pipeline(tuple(replace(s, inputs=tuple(i for i in s.inputs if i not in _FABRICATION))
                          for s in pipeline if s.name not in _FABRICATION))


#: a light study's pipeline: the design's stages without fabrication and assembly (the light
#: stage then measures every fin of the support structure)
LIGHT_PIPELINE = _without_fabrication(DEFAULT_PIPELINE)


def variant_pipeline(fabrication: bool, assembly: bool = True) -> Pipeline:
    """The stages a study's variants run: all of them, without the assembly check, or
    without fabrication and assembly."""
    if not fabrication:
        return LIGHT_PIPELINE
    if not assembly:
        return Pipeline(tuple(replace(s, inputs=tuple(i for i in s.inputs if i != "assembly"))
                              for s in DEFAULT_PIPELINE if s.name != "assembly"))
    return DEFAULT_PIPELINE


#: every file a variant can write (the design's own [outputs])
ALL_FILES = ("step", "3dm", "ifc", "dxf", "bom", "report")


def variant_spec(spec, files=ALL_FILES):
    """``spec`` writing only ``files`` (names of :class:`~.study_file.VariantFile`) beside its
    report.json: a study reads the report, so a file no one asked for is not paid for."""
    files = {getattr(f, "value", f) for f in files}
    o = spec.outputs
    return spec.model_copy(update={"outputs": o.model_copy(update={
        "step": o.step and "step" in files, "rhino_3dm": o.rhino_3dm and "3dm" in files,
        "ifc": o.ifc and "ifc" in files, "dxf": o.dxf and "dxf" in files,
        "bom": o.bom and "bom" in files, "renders": o.renders and "report" in files})})


@dataclass
class StudyProgress:
    """Counts told to a study's progress callback after every change."""

    total: int
    done: int = 0
    failed: int = 0
    running: int = 0
    resumed: int = 0
    event: str = ""          # what just happened, e.g. "003 done"


def flatten(d: dict, prefix: str = "") -> dict:
    """Nested report dict -> {dotted key: value}; lists become JSON text.

    >>> flatten({"light": {"blocked_share": 0.9, "baseline_louvers": {"transparency": 0.8}}})
    {'light.blocked_share': 0.9, 'light.baseline_louvers.transparency': 0.8}
    """
    out = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten(v, key + "."))
        elif isinstance(v, (list, tuple)):
            out[key] = json.dumps(v)
        else:
            out[key] = v
    return out


def material_kg(fin_area_m2: float, spec) -> float:
    """Sheet material of fins of one-side area ``fin_area_m2``: area x thickness x density
    (kg); the same rule for torsal's fins and the standard devices."""
    return float(fin_area_m2) * spec.material.thickness_mm / 1000.0 * spec.material.density


# ------------------------------------------------------------------ tasks (run on workers)
def _tell(queue: str | None, event: tuple) -> None:
    if queue is None:
        return
    try:
        from distributed import Queue

        Queue(queue).put(event)
    except Exception:       # progress is a courtesy: never fail a variant over it
        pass


def run_variant(variant: Variant, out_dir: str, cache_dir: str, leader: dict | None = None,
                queue: str | None = None, fabrication: bool = True, assembly: bool = True,
                files=ALL_FILES) -> dict:
    """Run one variant's pipeline into ``out_dir/variants/<id>`` with the shared cache.

    ``leader``: the outcome of the variant this one shares its congruence with (it ran
    first); if that failed at a stage whose inputs this variant shares, the same failure is
    recorded without running it again. ``fabrication``: False skips the fabrication and
    assembly stages (:data:`LIGHT_PIPELINE`); ``assembly``: False skips the assembly check;
    ``files``: the files written beside report.json (:func:`variant_spec`). Never raises:
    returns the outcome (``id``, ``status`` "done" | "failed", ``stage``, ``error``,
    ``wall_s``, ``stage_s`` (seconds of each stage computed), ``cached``, ``computed``,
    ``keys``, ``warnings``, ``fabrication``, ``assembly``, ``files``), also written to
    ``variant.json``.
    """
    _tell(queue, ("start", variant.id))
    t0 = time.perf_counter()
    out = Path(out_dir) / "variants" / variant.id
    out.mkdir(parents=True, exist_ok=True)
    (out / "variant.json").unlink(missing_ok=True)         # not finished until rewritten
    with atomic_path(out / "design.toml") as tmp:
        tmp.write_text(variant.toml)
    pipeline = variant_pipeline(fabrication, assembly)
    spec = variant_spec(variant.spec, files)
    keys = stage_keys(pipeline, spec)
    outcome = {"id": variant.id, "digest": variant.digest, "version": __version__,
               "axes": variant.axes, "status": "done", "stage": None, "error": None,
               "cached": [], "computed": [], "stage_s": {}, "keys": keys,
               "fabrication": bool(fabrication), "assembly": bool(assembly),
               "files": sorted(getattr(f, "value", f) for f in files)}
    shared_failure = (leader is not None and leader["status"] == "failed" and leader["stage"]
                      and leader["keys"].get(leader["stage"]) == keys.get(leader["stage"]))
    if shared_failure:
        outcome.update(status="failed", stage=leader["stage"], shared_failure=True,
                       error=f"{leader['error']} (same inputs as variant {leader['id']})")
    else:
        def record(stage, event, info):     # also known when a later stage fails
            if event in ("cached", "done"):
                outcome["cached" if event == "cached" else "computed"].append(stage)
            if event == "done":
                outcome["stage_s"][stage] = float(info.get("seconds", 0.0))

        try:
            # a worker has no terminal: its warnings go into the variant's record
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                try:
                    # a study compares variants: an unbuildable one is a row whose `buildable`
                    # column says so (its report names the parts), not a failed variant
                    Design(spec, source=out / "design.toml").run(
                        out, cache=StageCache(cache_dir, prune=False), progress=record,
                        accept_unbuildable=True, pipeline=pipeline)
                finally:
                    outcome["warnings"] = sorted({f"{w.category.__name__}: {w.message}"
                                                  for w in caught})
        except DesignError as exc:
            outcome.update(status="failed", stage=exc.stage, error=str(exc))
        except Exception as exc:            # noqa: BLE001 - one variant must not stop a study
            outcome.update(status="failed", error=f"{type(exc).__name__}: {exc}")
    outcome["wall_s"] = time.perf_counter() - t0
    write_json(out / "variant.json", outcome)
    _tell(queue, ("end", variant.id))
    return outcome


def lost_outcome(variant: Variant, exc: BaseException) -> dict:
    """The outcome of a variant whose task did not return (its worker died)."""
    return {"id": variant.id, "digest": variant.digest, "version": __version__,
            "axes": variant.axes, "status": "failed", "stage": None,
            "error": f"the task was lost: {type(exc).__name__}: {exc}", "cached": [],
            "computed": [], "keys": {}, "warnings": [], "wall_s": float("nan")}


def measure_devices(spec, out_dir: str, cache_dir: str, key: str) -> dict:
    """Measure the standard devices of ``spec``'s depth and spacing (the devices stage);
    writes ``out_dir/baselines/<key>.json`` and returns its content."""
    t0 = time.perf_counter()
    run = run_stages(DEVICES_PIPELINE, spec, Path(out_dir) / "baselines",
                     StageCache(cache_dir, prune=False), run=StageRun())
    record = {"key": key, "version": __version__, "devices": run.values["devices"]["measured"],
              "wall_s": time.perf_counter() - t0, "cached": "devices" in run.cached}
    write_json(Path(out_dir) / "baselines" / f"{key}.json", record)
    return record


# ------------------------------------------------------------------ executors
class _Job:
    """A task of :class:`SerialExecutor`: run when waited for."""

    def __init__(self, fn, args):
        self.fn, self.args, self.result = fn, args, None


class _Executor:
    def result(self, handle):
        raise NotImplementedError

    def outcome(self, handle, variant) -> dict:
        """A variant task's outcome; a task that died with its worker (killed, out of
        memory) is a failed variant, recorded like one, and the study goes on."""
        try:
            return self.result(handle)
        except Exception as exc:        # noqa: BLE001
            return lost_outcome(variant, exc)


class SerialExecutor(_Executor):
    """Runs tasks one after another in this process, with one core: the stages' own process
    pools (solids, assembly check) are capped to this process too, so a serial study is the
    one-core reference for the speed-up of a study on Dask workers (which are one core each).
    """

    def __init__(self):
        self._pending: list[_Job] = []
        self.running: set = set()

    def submit(self, fn, *args) -> _Job:
        job = _Job(fn, args)
        self._pending.append(job)
        return job

    def wait(self, jobs, on_change=None) -> list[_Job]:
        """Run the first submitted of ``jobs`` (the order of submission keeps a variant
        after the one it waits for)."""
        job = next(j for j in self._pending if j in jobs)
        self._pending.remove(job)
        vid = getattr(job.args[0], "id", None)
        if vid is not None and on_change is not None:
            self.running = {vid}
            on_change()
        args = [a.result if isinstance(a, _Job) else a for a in job.args]
        with limit_workers(1):
            job.result = job.fn(*args)
        self.running = set()
        return [job]

    def result(self, job: _Job):
        return job.result

    def close(self):
        pass


class DaskExecutor(_Executor):
    """Tasks on a Dask cluster: an embedded LocalCluster or a scheduler at an address."""

    def __init__(self, workers: int, scheduler: str | None, client=None):
        self.workers, self.scheduler = workers, scheduler
        self._own = client is None
        self.cluster = None
        self._client = client
        self._queue = None
        self.queue_name = f"torsal-study-{uuid.uuid4().hex[:8]}"
        self.running: set = set()

    @property
    def client(self):
        """The Dask client, started on first use: a resumed study with nothing left to run
        starts no cluster."""
        if self._client is None:
            from distributed import Client, LocalCluster

            if self.scheduler:
                self._client = Client(self.scheduler, timeout="20s")
            else:
                # one single-threaded process per core: the pipeline holds the GIL
                self.cluster = LocalCluster(n_workers=self.workers, threads_per_worker=1,
                                            processes=True, dashboard_address=None,
                                            silence_logs=logging.ERROR)
                self._client = Client(self.cluster)
        if self._queue is None:
            from distributed import Queue

            self._queue = Queue(self.queue_name, client=self._client)
        return self._client

    def submit(self, fn, *args):
        return self.client.submit(fn, *args, pure=False)

    def wait(self, futures, on_change=None):
        """The futures among ``futures`` that finished (at least one); ``on_change()`` is
        called whenever a variant starts running meanwhile."""
        from distributed import wait

        while True:
            try:
                done = wait(futures, timeout=0.5, return_when="FIRST_COMPLETED").done
            except TimeoutError:
                done = set()
            if self._drain() and on_change is not None and not done:
                on_change()
            if done:
                return list(done)

    def _drain(self) -> bool:
        try:
            n = self._queue.qsize()
            events = self._queue.get(batch=n) if n else []
        except Exception:
            events = []
        before = set(self.running)
        for kind, vid in events:
            (self.running.add if kind == "start" else self.running.discard)(vid)
        return self.running != before

    def result(self, future):
        return future.result()

    def close(self):
        if self._own and self._client is not None:
            self._client.close()
            if self.cluster is not None:
                self.cluster.close()
