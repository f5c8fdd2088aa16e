"""A stage: a plain function with declared inputs and outputs, and the loop that runs them.

A :class:`Stage` names the results of earlier stages it reads (``inputs``) and the parts of
the design file its result depends on (``key``); its function takes a :class:`StageInputs`
and returns a dict. Documented keys of that dict:

- ``"report"``: the stage's section of ``report.json`` (stored under ``Stage.section``);
- ``"files"``: ``{kind: path relative to the output folder}`` of files the stage wrote; a
  cached result whose files are gone is recomputed;
- anything else: values for later stages (arrays, structures, ...).

:func:`run_stages` runs a list of stages in order, reusing cached results whose key did not
change. A stage marked ``concurrent`` runs in a process of its own while the stages after it
go on (the report's pictures while the assembly is checked); the first stage that reads it,
or the end of the run, waits for its result. A :class:`Pipeline` is an ordered list of
stages with ways to insert one::

    from torsal.pipeline import DEFAULT_PIPELINE, Stage
    pipeline = DEFAULT_PIPELINE.insert(Stage("assembly", run_assembly,
                                             inputs=("support", "fabrication")),
                                       after="fabrication")
    Design.from_toml("d.toml").run("out", pipeline=pipeline)
"""
from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Iterator

from .design_file import DesignSpec
from .cache import MISSING, StageCache, stage_key
from .memo import Memo
from ..core.errors import TorsalError, raised_in_torsal
from .errors import DesignError, Progress, quiet

__all__ = ["Stage", "StageInputs", "Pipeline", "StageRun", "run_stages", "stage_keys"]


def _always(spec: DesignSpec) -> bool:
    return True


def _no_key(spec: DesignSpec) -> tuple:
    return ()


@dataclass(frozen=True)
class Stage:
    """One step of the pipeline.

    Parameters
    ----------
    name : str
        Unique; the cache file and the progress events use it.
    run : callable(StageInputs) -> dict
        The work; see the module docstring for the keys of its result.
    inputs : tuple of str
        Names of earlier stages whose results ``run`` reads (``inputs["congruence"]``).
    key : callable(DesignSpec) -> tuple
        The parts of the design file the result depends on (JSON-able values). With the
        inputs' keys and the torsal version they make the cache key.
    applies : callable(DesignSpec) -> bool
        False: the stage is skipped for this design (e.g. no ``[substructure]`` table).
    cache : bool
        Store the result. Cheap stages, and stages that must run every time (the report),
        say False; their key is still computed, so later stages cache normally.
    section : str, optional
        The report section for the result's ``"report"``; default ``name``. A dotted name
        (``"fabrication.assembly"``) nests the section inside another stage's.
    concurrent : bool
        Run in a process of its own (forked from a clean server process) while the later
        stages go on; the first stage that reads it, or the end of the run, waits for it.
        Its inputs and result must pickle, it sees the report as it was when it started and
        reports no progress of its own. Where no second process may be started
        (:func:`~torsal.core.parallel.limit_workers` ``(1)``, a daemonic process) it runs in
        order like any other stage: the same result either way.
    """

    name: str
    run: Callable[["StageInputs"], dict]
    inputs: tuple[str, ...] = ()
    key: Callable[[DesignSpec], tuple] = _no_key
    applies: Callable[[DesignSpec], bool] = _always
    cache: bool = True
    section: str | None = None
    concurrent: bool = False


@dataclass
class StageInputs(Mapping):
    """What a stage's function sees: the design, the output folder, its declared inputs
    (``inputs["sun"]["vectors"]``), the report so far, and a progress callback for its own
    events (``inputs.progress("iteration", {...})``)."""

    spec: DesignSpec
    out: Path
    stage: str
    results: dict
    report: Mapping
    _progress: Progress = quiet
    #: results kept by their content beside the stage cache (:class:`~.memo.Memo`); None
    #: outside :func:`run_stages`
    memo: Memo | None = None

    def __getitem__(self, name: str) -> dict:
        try:
            return self.results[name]
        except KeyError:
            # a pipeline built wrong (a custom stage's declaration): named like bad input
            raise DesignError(self.stage, f"reads '{name}', which is not among its declared "
                              f"inputs {sorted(self.results)}") from None

    def __contains__(self, name) -> bool:  # not via __getitem__, which raises for a missing one
        return name in self.results

    def __iter__(self) -> Iterator[str]:
        return iter(self.results)

    def __len__(self) -> int:
        return len(self.results)

    def progress(self, event: str, info: dict) -> None:
        self._progress(self.stage, event, info)


@dataclass(frozen=True)
class Pipeline:
    """An ordered list of stages; immutable, so inserting returns a new pipeline.

    >>> p = DEFAULT_PIPELINE.insert(Stage("check", check, inputs=("surface",)),
    ...                             before="congruence")  # doctest: +SKIP
    >>> p.names  # doctest: +SKIP
    ('surface', 'sun', 'orient', 'check', 'congruence', ...)
    """

    stages: tuple[Stage, ...]

    def __post_init__(self):
        names = [s.name for s in self.stages]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise ValueError(f"stage names must be unique; repeated: {sorted(dup)}")
        for k, s in enumerate(self.stages):
            unknown = set(s.inputs) - set(names[:k])
            if unknown:
                raise ValueError(f"stage '{s.name}' reads {sorted(unknown)}, which no earlier "
                                 "stage produces")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.stages)

    def __iter__(self) -> Iterator[Stage]:
        return iter(self.stages)

    def __getitem__(self, name: str) -> Stage:
        for s in self.stages:
            if s.name == name:
                return s
        raise KeyError(f"no stage '{name}'; stages: {', '.join(self.names)}")

    def _index(self, name: str) -> int:
        return self.names.index(self[name].name)

    def insert(self, stage: Stage, *, after: str | None = None,
               before: str | None = None) -> "Pipeline":
        """A pipeline with ``stage`` placed after or before the named stage (exactly one)."""
        if (after is None) == (before is None):
            raise ValueError("give exactly one of after= or before=")
        k = self._index(after) + 1 if after is not None else self._index(before)
        return Pipeline(self.stages[:k] + (stage,) + self.stages[k:])

    def replace(self, stage: Stage) -> "Pipeline":
        """A pipeline with the stage of the same name swapped for ``stage``."""
        k = self._index(stage.name)
        return Pipeline(self.stages[:k] + (stage,) + self.stages[k + 1:])

    def until(self, name: str) -> "Pipeline":
        """The stages up to and including ``name`` (to warm a shared cache)."""
        return Pipeline(self.stages[: self._index(name) + 1])


def stage_keys(pipeline: Pipeline, spec: DesignSpec) -> dict[str, str]:
    """The cache key of every stage that applies to ``spec``, without running anything."""
    keys: dict[str, str] = {}
    for s in pipeline:
        if s.applies(spec):
            keys[s.name] = stage_key(s.name, *(keys[i] for i in s.inputs if i in keys), *s.key(spec))
    return keys


@dataclass
class StageRun:
    """What :func:`run_stages` produced: each stage's result and key, the report sections,
    the files written, the seconds of each computed stage and the stages found in the cache."""

    values: dict = field(default_factory=dict)
    keys: dict = field(default_factory=dict)
    report: dict = field(default_factory=dict)
    files: dict = field(default_factory=dict)
    stage_seconds: dict = field(default_factory=dict)
    cached: list = field(default_factory=list)


def _flat(x):
    if isinstance(x, (list, tuple)):
        for y in x:
            yield from _flat(y)
    elif isinstance(x, dict):
        for y in x.values():
            yield from _flat(y)
    elif x:
        yield x


def _files_present(value: dict, out: Path) -> bool:
    return all((out / p).exists() for p in _flat(value.get("files", {})))


def _put_section(report: dict, section: str, value) -> None:
    """``report[section] = value``; a dotted section (``fabrication.assembly``) nests inside
    a copy of the parent section, so the parent stage's own result is left as it was."""
    *parents, last = section.split(".")
    node = report
    for name in parents:
        node[name] = dict(node.get(name, {}))
        node = node[name]
    node[last] = value


def _compute(s: Stage, inputs: "StageInputs") -> dict:
    """``s.run(inputs)``; an error the input causes as a :class:`DesignError` naming the
    stage, any other exception (a bug) with a note naming it."""
    try:
        return s.run(inputs)
    except DesignError:
        raise
    except (TorsalError, ValueError) as exc:
        if not isinstance(exc, TorsalError) and not raised_in_torsal(exc):
            exc.add_note(f"in stage '{s.name}'")
            raise                       # a ValueError inside numpy/scipy: a bug
        # the input is the cause (stages raise these for what they reject)
        raise DesignError(s.name, str(exc)) from exc
    except Exception as exc:
        # a bug, not the input: not a DesignError, so the command line says "internal"
        exc.add_note(f"in stage '{s.name}'")
        raise


def _compute_in_child(conn) -> None:
    """Process of a concurrent stage: reads the pickled ``(stage, inputs)`` from ``conn``,
    answers ``("done", (result, seconds))`` or ``("error", exception)``."""
    import pickle

    try:
        s, inputs = pickle.loads(conn.recv_bytes())
        t0 = time.perf_counter()
        message = ("done", (_compute(s, inputs), time.perf_counter() - t0))
    except BaseException as exc:            # raised again in the parent
        message = _portable(exc)
    try:
        conn.send(message)
        conn.close()
    except OSError:                          # the run stopped waiting (it failed)
        pass


def _portable(exc: BaseException) -> tuple:
    """An exception of a concurrent stage's process as it crosses to the run's:
    ``("design", (message, stage, key, value))`` for a :class:`DesignError` (its
    constructor takes other arguments than its message), else ``("error", exc)``, or its
    type and message where it does not pickle."""
    from ..core.parallel import portable_error

    if isinstance(exc, DesignError):
        return "design", (str(exc), exc.stage, exc.key, exc.value)
    return "error", portable_error(exc)


class _Concurrent:
    """A concurrent stage running in a process of its own (:attr:`Stage.concurrent`):
    ``payload`` is its pickled ``(stage, inputs)``, sent by a thread (the process reads it
    once it has started) so that this process goes on at once."""

    def __init__(self, name: str, payload: bytes):
        import multiprocessing as mp
        import threading

        ctx = mp.get_context("forkserver" if "forkserver" in mp.get_all_start_methods()
                             else "spawn")
        self._conn, child = ctx.Pipe(duplex=True)
        self._process = ctx.Process(target=_compute_in_child, args=(child,),
                                    name=f"torsal-stage-{name}", daemon=True)
        self._process.start()
        child.close()
        self._sender = threading.Thread(target=self._send, args=(payload,), daemon=True)
        self._sender.start()

    def _send(self, payload: bytes) -> None:
        try:
            self._conn.send_bytes(payload)
        except OSError:          # the process ended (cancelled): result() says so
            pass

    def result(self) -> tuple[dict, float]:
        """``(result, seconds)`` of the stage (waits); its error raised again here."""
        try:
            kind, value = self._conn.recv()
        except EOFError:
            raise RuntimeError(f"the process of {self._process.name} ended without a result "
                               f"(exit code {self._process.join() or self._process.exitcode})"
                               ) from None
        finally:
            self._conn.close()
        self._process.join()
        self._sender.join()
        if kind == "design":
            message, stage, key, value = value
            exc = DesignError(stage, "")
            exc.args, exc.key, exc.value = (message,), key, value
            raise exc
        if kind == "error":
            raise value
        return value

    def cancel(self) -> None:
        if self._process.is_alive():
            self._process.terminate()
            self._process.join()


def _start_concurrent(s: Stage, inputs: "StageInputs") -> _Concurrent | None:
    """``s`` started in a process of its own, or None where it runs in order (no second
    process may be started, or its inputs do not pickle)."""
    import pickle

    from ..core.parallel import usable_workers

    if usable_workers(2) < 2:
        return None
    try:
        payload = pickle.dumps((s, inputs), protocol=pickle.HIGHEST_PROTOCOL)
    except Exception:           # a stage built from a closure, inputs holding a live object
        return None
    return _Concurrent(s.name, payload)


def run_stages(pipeline: Pipeline, spec: DesignSpec, out: Path, cache: StageCache, *,
               progress: Progress = quiet, run: StageRun | None = None) -> StageRun:
    """Run the stages that apply to ``spec`` in order; raises :class:`DesignError` naming
    the stage that failed when its input is the cause (a :class:`TorsalError`, or a
    ``ValueError`` raised by torsal's own checks); any other exception is a bug and
    propagates with a note naming the stage. Results of earlier stages stay cached.
    Concurrent stages (:attr:`Stage.concurrent`) run beside the later ones; a failure
    stops them."""
    run = run if run is not None else StageRun()
    keys = stage_keys(pipeline, spec)
    memo = Memo(cache.folder / "memo", enabled=cache.enabled)
    running: dict[str, tuple[Stage, _Concurrent]] = {}

    def record(s: Stage, value: dict) -> None:
        run.values[s.name], run.keys[s.name] = value, keys[s.name]
        if "report" in value:
            _put_section(run.report, s.section or s.name, value["report"])
        run.files.update(value.get("files", {}))

    def finish(s: Stage, value: dict) -> None:
        if s.cache:
            cache.store(s.name, keys[s.name], value)
        progress(s.name, "done", {"seconds": run.stage_seconds[s.name]})
        record(s, value)

    def collect(name: str) -> None:
        s, pending = running.pop(name)
        try:
            value, run.stage_seconds[name] = pending.result()
        except BaseException:
            pending.cancel()
            raise
        finish(s, value)

    try:
        for s in pipeline:
            if not s.applies(spec):
                continue
            for name in s.inputs:
                if name in running:
                    collect(name)
            key = keys[s.name]
            value = cache.load(s.name, key) if s.cache else MISSING
            if value is not MISSING and not _files_present(value, out):
                value = MISSING             # outputs deleted since the cached run: make them again
            if value is MISSING:
                progress(s.name, "start", {})
                t0 = time.perf_counter()
                inputs = StageInputs(spec=spec, out=out, stage=s.name,
                                     results={i: run.values[i] for i in s.inputs if i in run.values},
                                     report=run.report, _progress=progress, memo=memo)
                if s.concurrent:
                    pending = _start_concurrent(s, replace(inputs, report=dict(run.report),
                                                           _progress=quiet))
                    if pending is not None:
                        running[s.name] = (s, pending)
                        continue
                value = _compute(s, inputs)
                run.stage_seconds[s.name] = time.perf_counter() - t0
                finish(s, value)
            else:
                progress(s.name, "cached", {})
                run.cached.append(s.name)
                record(s, value)
        for name in list(running):
            collect(name)
    finally:
        for _, pending in running.values():
            pending.cancel()
    return run
