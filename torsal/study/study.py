"""Design studies: many variants of one design as Dask tasks, one table, a Pareto plot
against the standard shading devices.

:class:`Study` reads a study file (:mod:`torsal.study.study_file`), makes one design per
combination of the axes (or lets optuna propose them, with ``[search]``) and runs each
variant's pipeline as a task on a ``distributed.LocalCluster`` (embedded) or an existing
Dask scheduler. Variants share one stage cache (``OUT/.torsal-cache``, keys from the design
file alone): a variant whose congruence inputs equal another's waits for that one and reuses
its optimized congruence instead of solving again. A failing variant is recorded with its
stage and error; the others go on. A finished variant leaves ``variants/<id>/variant.json``;
a run in the same folder skips every finished variant, so an interrupted study resumes.

Outputs in ``OUT``: ``results.parquet`` and ``results.csv`` (one row per variant and per
standard device of each depth and spacing), ``variants/<id>/`` (each design's full outputs),
``baselines/`` (the devices' measurements), ``study.html`` and ``pareto.png``. With a remote scheduler the
workers write there too: ``OUT`` must be a folder they all see (a shared file system).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

from .._version import __version__
from ..core.atomic import atomic_path, write_json
from ..pipeline.cache import StageCache
from ..pipeline.devices import DEVICES_PIPELINE
from .search import run_search
from ..pipeline.stage import stage_keys
from ..pipeline.stages import DEFAULT_PIPELINE
from .study_file import StudyFileError, StudySpec, Variant, grid_variants, load_study_file
from .study_report import results_table, write_pareto_png, write_study_html
from .study_tasks import (SHARED_STAGE, DaskExecutor, SerialExecutor, StudyProgress,
                          ALL_FILES, measure_devices, run_variant)

__all__ = ["Study", "StudyProgress", "StudyResult", "SHARED_STAGE"]


@dataclass
class StudyResult:
    """What a study run produced.

    Attributes
    ----------
    table : pandas.DataFrame
        ``results.parquet`` as written: one row per variant (kind "torsal") and per device
        of each depth and spacing (kind "baseline").
    files : dict
        {kind: path} of the study's outputs.
    solves : int
        Congruence optimizations run in this run.
    solves_saved : int
        Variants run in this run whose congruence came from the shared cache.
    resumed : int
        Variants (and device sets) found finished from an earlier run: nothing recomputed.
    failed : int
        Variants that failed (recorded in the table with stage and error).
    verdict : str
        The sentence at the top of study.html.
    """

    table: object
    files: dict
    solves: int = 0
    solves_saved: int = 0
    resumed: int = 0
    failed: int = 0
    verdict: str = ""


# ------------------------------------------------------------------ the study
class Study:
    """A design study: a base design, axes to vary, variants run as Dask tasks.

    Examples
    --------
    >>> study = Study.from_toml("examples/studies/7a_depth_spacing.toml")  # doctest: +SKIP
    >>> result = study.run("out/study-7a")                                 # doctest: +SKIP
    >>> result.table[["fins.depth", "fins.spacing", "light.blocked_share"]]  # doctest: +SKIP
    """

    def __init__(self, spec: StudySpec, base: dict, base_dir: Path, *,
                 source: str | Path | None = None):
        self.spec = spec
        self.base = base
        self.base_dir = Path(base_dir)
        self.source = Path(source) if source else None
        # a grid is known (and every design in it validated) before anything runs
        self.variants: list[Variant] = (grid_variants(spec, base, self.base_dir)
                                        if spec.search is None else [])

    @classmethod
    def from_toml(cls, path: str | Path) -> "Study":
        """Read and validate a study file; raises StudyFileError naming the key."""
        spec, base, base_dir = load_study_file(path)
        try:
            return cls(spec, base, base_dir, source=path)
        except StudyFileError as exc:       # a grid point the design file rejects
            raise StudyFileError(f"{path}: {exc}") from None

    # -------------------------------------------------------------- run
    def run(self, out_dir: str | Path, *, workers: int | None = None,
            scheduler: str | None = None, client=None, serial: bool = False,
            progress: Callable[[StudyProgress], None] | None = None,
            retry_failed: bool = False) -> StudyResult:
        """Run every variant not finished in ``out_dir`` and write the table and study.html.

        Parameters
        ----------
        out_dir : path
        workers, scheduler : optional
            Override the study file's ``[run]``: local Dask worker processes (a local
            cluster, also when the file names a scheduler), or the address of a running
            scheduler.
        client : distributed.Client, optional
            Use this client (and its cluster) instead.
        serial : bool
            Run in this process without Dask, on one core (the stages' own process pools
            are capped to this process): the reference for speed-ups.
        progress : callable(StudyProgress), optional
            Told the counts of variants done, failed, running after every change.
        retry_failed : bool
            Run variants again that failed in an earlier run (default: keep their record).
        """
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        (out / "variants").mkdir(exist_ok=True)
        cache_dir = str(out / ".torsal-cache")
        write_json(out / "study.json", {"name": self.spec.name, "source": str(self.source),
                                        "spec": self.spec.model_dump(mode="json"),
                                        "version": __version__})
        def tell(p: StudyProgress) -> None:      # a copy: the counts change as we go
            if progress is not None:
                progress(replace(p))
        if scheduler is None and workers is None:   # a local worker count overrides the file
            scheduler = self.spec.run.scheduler
        workers = workers or self.spec.run.workers
        ex = SerialExecutor() if serial else DaskExecutor(workers, scheduler, client)
        try:
            if self.spec.search is None:
                # a grid's devices are known now: measure them alongside the variants
                pending = self._submit_devices(ex, out, cache_dir, self.variants)
                outcomes, counts = self._run_grid(ex, out, cache_dir, tell, retry_failed)
            else:
                outcomes, counts = self._run_search(ex, out, cache_dir, tell, retry_failed)
                pending = self._submit_devices(ex, out, cache_dir, self.variants)
            devices = self._collect_devices(ex, *pending)
        finally:
            ex.close()
        table = results_table(self, out, outcomes, devices)
        files = {}
        with atomic_path(out / "results.parquet") as tmp:
            table.to_parquet(tmp, index=False)
        files["parquet"] = str(out / "results.parquet")
        with atomic_path(out / "results.csv") as tmp:
            table.to_csv(tmp, index=False)
        files["csv"] = str(out / "results.csv")
        verdict = write_study_html(out / "study.html", self, table)
        files["html"] = str(out / "study.html")
        files["png"] = str(write_pareto_png(out / "pareto.png", self, table))
        ran = [o for o in outcomes.values() if not o.get("resumed")]
        return StudyResult(
            table=table, files=files,
            solves=sum(SHARED_STAGE in o["computed"] for o in ran),
            solves_saved=sum(SHARED_STAGE in o["cached"] or o.get("shared_failure", False)
                             for o in ran),
            resumed=counts.resumed, failed=counts.failed, verdict=verdict)

    # -------------------------------------------------------------- helpers
    @property
    def variant_run(self) -> tuple:
        """``(fabrication, assembly, files)`` of :func:`~.study_tasks.run_variant`: the stages
        and files the study's ``[run]`` asks of its variants."""
        run = self.spec.run
        return run.fabrication, run.assembly, tuple(f.value for f in run.files)

    def _finished(self, out: Path, variant: Variant, retry_failed: bool) -> dict | None:
        """The recorded outcome of a variant finished in an earlier run, if still valid (the
        same design, version and stages)."""
        folder = out / "variants" / variant.id
        try:
            rec = json.loads((folder / "variant.json").read_text())
        except (OSError, ValueError):
            return None
        if rec.get("digest") != variant.digest or rec.get("version") != __version__:
            return None
        run = self.spec.run
        if (rec.get("fabrication", True), rec.get("assembly", True)) != (run.fabrication,
                                                                         run.assembly):
            return None
        if sorted(rec.get("files", ALL_FILES)) != sorted(f.value for f in run.files):
            return None
        if rec["status"] == "done" and (folder / "report.json").exists():
            return rec | {"resumed": True}
        if rec["status"] == "failed" and not retry_failed:
            return rec | {"resumed": True}
        return None

    @staticmethod
    def _collect(ex, jobs: dict, outcomes: dict, counts: StudyProgress, tell,
                 on_outcome=None) -> None:
        """Wait for ``jobs`` ({handle: variant}) and record each outcome as it comes
        (``on_outcome(variant, outcome)`` too, e.g. to tell optuna)."""
        pending = dict(jobs)

        def started():
            counts.running = len(ex.running)
            counts.event = "running " + ", ".join(sorted(ex.running))
            tell(counts)

        while pending:
            for h in ex.wait(list(pending), started):
                v = pending.pop(h)
                o = ex.outcome(h, v)
                outcomes[v.id] = o
                if on_outcome is not None:
                    on_outcome(v, o)
                ex.running.discard(v.id)
                if o["status"] == "done":
                    counts.done += 1
                else:
                    counts.failed += 1
                counts.running = len(ex.running)
                counts.event = f"{v.id} {o['status']}" + (f" at {o['stage']}" if o["stage"] else "")
                tell(counts)

    def _run_grid(self, ex, out: Path, cache_dir: str, tell, retry_failed: bool):
        counts = StudyProgress(total=len(self.variants))
        outcomes: dict[str, dict] = {}
        todo = []
        for v in self.variants:
            rec = self._finished(out, v, retry_failed)
            if rec is None:
                todo.append(v)
            else:
                outcomes[v.id] = rec
                counts.resumed += 1
                counts.done += rec["status"] == "done"
                counts.failed += rec["status"] == "failed"
        counts.event = f"{counts.resumed} finished earlier"
        tell(counts)
        # variants sharing the congruence: the first runs alone, the others wait for it
        # and find its congruence in the cache
        leaders: dict[str, object] = {}
        jobs = {}
        cache = StageCache(cache_dir, prune=False)
        for v in todo:
            k = stage_keys(DEFAULT_PIPELINE, v.spec)[SHARED_STAGE]
            leader = leaders.get(k)
            if leader is None and not cache.has(SHARED_STAGE, k):
                h = ex.submit(run_variant, v, str(out), cache_dir, None, _queue(ex),
                              *self.variant_run)
                leaders[k] = h
            else:
                h = ex.submit(run_variant, v, str(out), cache_dir, leader, _queue(ex),
                              *self.variant_run)
            jobs[h] = v
        self._collect(ex, jobs, outcomes, counts, tell)
        return outcomes, counts

    def _run_search(self, ex, out: Path, cache_dir: str, tell, retry_failed: bool):
        return run_search(self, ex, out, cache_dir, tell, retry_failed)

    def _submit_devices(self, ex, out: Path, cache_dir: str, variants) -> tuple:
        """Measure the standard devices once per distinct (surface, sun, depth, spacing) of
        ``variants``: submit the ones not measured in an earlier run."""
        specs = {}
        for v in variants:
            specs.setdefault(stage_keys(DEVICES_PIPELINE, v.spec)["devices"], v.spec)
        records, jobs = {}, {}
        for k, spec in specs.items():
            try:
                rec = json.loads((out / "baselines" / f"{k}.json").read_text())
                if rec.get("version") == __version__:
                    records[k] = rec | {"resumed": True}
                    continue
            except (OSError, ValueError):
                pass
            jobs[ex.submit(measure_devices, spec, str(out), cache_dir, k)] = k
        return specs, records, jobs

    @staticmethod
    def _collect_devices(ex, specs: dict, records: dict, jobs: dict) -> dict:
        pending = dict(jobs)
        while pending:
            for h in ex.wait(list(pending)):
                records[pending.pop(h)] = ex.result(h)
        return {k: (specs[k], records[k]) for k in specs}      # in the variants' order


def _queue(ex) -> str | None:
    return getattr(ex, "queue_name", None)
