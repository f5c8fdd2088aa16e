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
from functools import partial
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
        order like any other stage: the same result either way. The process is started
        when the run starts (unless the stage's result is in the cache): it imports the
        stage function's module and ``preload`` while the stages before it run, then waits
        for its inputs.
    preload : tuple of str
        Modules a concurrent stage's process imports before its inputs come (those its
        function imports when it runs: the pictures' matplotlib), so that the seconds of
        the imports are spent while the earlier stages run.
    low_priority : bool
        A concurrent stage whose result is read long after it starts (the devices, read by
        the light after the fabrication) runs at a lower priority
        (:data:`~torsal.fabrication.workers.BACKGROUND_NICE`): the stages the run waits for
        get the cores first. Not for one the end of the run waits for (the pictures, beside
        the assembly check): it would be left to finish alone.
    """

    name: str
    run: Callable[["StageInputs"], dict]
    inputs: tuple[str, ...] = ()
    key: Callable[[DesignSpec], tuple] = _no_key
    applies: Callable[[DesignSpec], bool] = _always
    cache: bool = True
    section: str | None = None
    concurrent: bool = False
    preload: tuple[str, ...] = ()
    low_priority: bool = False


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
    #: takes the work a stage leaves running when it returns (:meth:`defer`); None: the
    #: stage waits for it itself (outside :func:`run_stages`, in a concurrent stage's process)
    _defer: Callable[[object], None] | None = None

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

    def defer(self, pending) -> None:
        """A file the stage's result names that a process of its own is still writing
        (``pending``: ``result()`` waits for it, raising its error; ``cancel()`` stops it):
        the run goes on to the next stages and waits for it before it ends (and before the
        stage's result is cached); a failure of the run cancels it. Where nothing takes it,
        it is waited for here.

        >>> inputs.defer(fs.start_ifc(inputs.out / "fins.ifc"))   # doctest: +SKIP
        """
        if self._defer is None:
            pending.result()
        else:
            self._defer(pending)


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


def _compute_in_child(conn, preload: tuple[str, ...] = (), low_priority: bool = False) -> None:
    """Process of a concurrent stage: imports ``preload`` (modules), then reads the pickled
    ``(stage, inputs)`` from ``conn`` and answers ``("done", (result, seconds))`` or
    ``("error", exception)``; ends quietly when the run closes ``conn`` without sending
    (the stage was not needed). ``low_priority``: :attr:`Stage.low_priority`."""
    import importlib
    import pickle

    if low_priority:              # the stages the run waits for come first
        from ..fabrication.workers import run_in_background

        run_in_background()
    for name in preload:          # a warm-up only: a module that fails fails again below
        try:
            importlib.import_module(name)
        except Exception:
            pass
    try:
        payload = conn.recv_bytes()
    except (EOFError, OSError):
        return
    try:
        s, inputs = pickle.loads(payload)
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
    """The process of a concurrent stage (:attr:`Stage.concurrent`), started ahead: a thread
    starts it (the first start waits for the fork server's imports), it imports ``preload``
    and waits; :meth:`send` hands it the pickled ``(stage, inputs)``, which the thread
    sends once the process is up, so this process goes on at once."""

    def __init__(self, name: str, preload: tuple[str, ...] = (), low_priority: bool = False):
        import multiprocessing as mp
        import queue
        import threading

        ctx = mp.get_context("forkserver" if "forkserver" in mp.get_all_start_methods()
                             else "spawn")
        self._conn, self._child = ctx.Pipe(duplex=True)
        self._process = ctx.Process(target=_compute_in_child, args=(self._child, preload, low_priority),
                                    name=f"torsal-stage-{name}", daemon=True)
        self._payload: queue.Queue = queue.Queue(maxsize=1)
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            self._process.start()
        except BaseException as exc:          # raised by result()
            self._error = exc
            return
        finally:
            self._child.close()
        payload = self._payload.get()
        try:
            if payload is None:               # not needed: the process ends on EOF
                self._conn.close()
            else:
                self._conn.send_bytes(payload)
        except OSError:          # the process ended (cancelled): result() says so
            pass

    def send(self, payload: bytes) -> None:
        """Hand the process its pickled ``(stage, inputs)`` (once)."""
        self._payload.put(payload)

    def result(self) -> tuple[dict, float]:
        """``(result, seconds)`` of the stage (waits); its error raised again here."""
        self._thread.join()
        if self._error is not None:
            raise self._error
        from ..core.parallel import child_answer

        kind, value = child_answer(self._conn, self._process, f"the process of {self._process.name}")
        if kind == "design":
            message, stage, key, value = value
            exc = DesignError(stage, "")
            exc.args, exc.key, exc.value = (message,), key, value
            raise exc
        if kind == "error":
            raise value
        return value

    def release(self) -> None:
        """Tell a process that has no inputs yet that none will come (it ends at once);
        returns at once."""
        try:
            self._payload.put_nowait(None)
        except Exception:                     # sent already
            pass

    def cancel(self) -> None:
        """Stop the process (a failed run, or a stage not needed after all)."""
        self.release()
        self._thread.join()
        if self._error is None and self._process.is_alive():
            self._process.terminate()
            self._process.join()
        self._conn.close()


def _function_module(s: Stage) -> tuple[str, ...]:
    """``(module,)`` of stage ``s``'s function (which unpickling the stage imports), or ()."""
    fn = getattr(s.run, "func", s.run)        # a functools.partial's function
    module = getattr(fn, "__module__", None)
    return (module,) if module else ()


def _concurrent_modules(s: Stage) -> tuple[str, ...]:
    """What the process of concurrent stage ``s`` imports ahead: its function's module and
    its :attr:`Stage.preload`."""
    return _function_module(s) + tuple(s.preload)


def concurrent_modules(pipeline: Pipeline, spec: DesignSpec) -> tuple[str, ...]:
    """The modules of the functions of ``pipeline``'s concurrent stages that apply to
    ``spec`` (what unpickling them imports: a fork server that imported them spares each
    stage's process the seconds; their :attr:`Stage.preload` is left to the stage's own
    process).

    >>> concurrent_modules(DEFAULT_PIPELINE, spec)                 # doctest: +SKIP
    ('torsal.pipeline.measure', 'torsal.pipeline.stages')
    """
    out: list[str] = []
    for s in pipeline:
        if s.concurrent and s.applies(spec):
            out += [m for m in _function_module(s) if m not in out]
    return tuple(out)


def _start_ahead(pipeline: Pipeline, spec: DesignSpec, cache: StageCache,
                 keys: dict) -> dict[str, _Concurrent]:
    """``{stage: process}``: a process started now for every concurrent stage that applies
    and is not in the cache (none where no second process may be started)."""
    from ..core.parallel import usable_workers

    if usable_workers(2) < 2:
        return {}
    return {s.name: _Concurrent(s.name, _concurrent_modules(s), s.low_priority) for s in pipeline
            if s.concurrent and s.applies(spec) and not (s.cache and cache.has(s.name, keys[s.name]))}


def _start_concurrent(s: Stage, inputs: "StageInputs",
                      ahead: _Concurrent | None) -> _Concurrent | None:
    """``s`` started in a process of its own (``ahead``, the one started for it when the run
    started, else a new one), or None where it runs in order (no second process may be
    started, or its inputs do not pickle)."""
    import pickle

    from ..core.parallel import usable_workers

    if ahead is None and usable_workers(2) < 2:
        return None
    try:
        payload = pickle.dumps((s, inputs), protocol=pickle.HIGHEST_PROTOCOL)
    except Exception:           # a stage built from a closure, inputs holding a live object
        if ahead is not None:
            ahead.cancel()
        return None
    pending = (ahead if ahead is not None else
               _Concurrent(s.name, _concurrent_modules(s), s.low_priority))
    pending.send(payload)
    return pending


def run_stages(pipeline: Pipeline, spec: DesignSpec, out: Path, cache: StageCache, *,
               progress: Progress = quiet, run: StageRun | None = None) -> StageRun:
    """Run the stages that apply to ``spec`` in order; raises :class:`DesignError` naming
    the stage that failed when its input is the cause (a :class:`TorsalError`, or a
    ``ValueError`` raised by torsal's own checks); any other exception is a bug and
    propagates with a note naming the stage. Results of earlier stages stay cached.
    Concurrent stages (:attr:`Stage.concurrent`) run beside the later ones, started as soon
    as the stages they read are done (the devices beside the congruence and the fins); a
    failure stops them."""
    return _StageRunner(pipeline, spec, out, cache, progress,
                        run if run is not None else StageRun()).run()


class _StageRunner:
    """One :func:`run_stages`: the stages in order, the concurrent ones started ahead and
    collected where a later stage reads them."""

    def __init__(self, pipeline: Pipeline, spec: DesignSpec, out: Path, cache: StageCache,
                 progress: Progress, run: StageRun):
        self.spec, self.out, self.cache, self.progress = spec, out, cache, progress
        self.result = run
        self.keys = stage_keys(pipeline, spec)
        self.memo = Memo(cache.folder / "memo", enabled=cache.enabled)
        self.running: dict[str, tuple[Stage, _Concurrent]] = {}
        self.stages = [s for s in pipeline if s.applies(spec)]
        self.tried: set[str] = set()          # concurrent stages started (or tried) ahead
        #: {stage: [pending work]} of :meth:`StageInputs.defer`, waited for at the end
        self.deferred: dict[str, list] = {}
        # the concurrent stages' processes start now: their imports run beside the stages before
        self.ahead = _start_ahead(pipeline, spec, cache, self.keys)

    def run(self) -> StageRun:
        stages = self.stages
        try:
            for k, s in enumerate(stages):
                if s.name not in self.running:      # else: started ahead of its turn
                    self._run_one(s)
                self._start_ready(stages[k + 1:])
            for name in list(self.running):
                self._collect(name)
            self._settle()
        finally:
            for _, pending in self.running.values():
                pending.cancel()
            for pending in (p for items in self.deferred.values() for p in items):
                pending.cancel()
            for pending in self.ahead.values():  # found in the cache, or the run failed
                pending.cancel()
        return self.result

    def _run_one(self, s: Stage) -> None:
        """Stage ``s`` in its turn: read from the cache, started beside the later ones (a
        concurrent stage) or computed here."""
        for name in s.inputs:
            if name in self.running:
                self._collect(name)
        value = self.cache.load(s.name, self.keys[s.name]) if s.cache else MISSING
        if value is not MISSING and not _files_present(value, self.out):
            value = MISSING             # outputs deleted since the cached run: make them again
        if value is MISSING:
            self.progress(s.name, "start", {})
            t0 = time.perf_counter()
            if s.concurrent and self._start(s):
                return
            value = _compute(s, self._inputs_of(s))
            self.result.stage_seconds[s.name] = time.perf_counter() - t0
            self._finish(s, value)
        else:
            self.progress(s.name, "cached", {})
            self.result.cached.append(s.name)
            if s.name in self.ahead:              # its files were there after all
                self.ahead[s.name].release()
            self._record(s, value)

    def _record(self, s: Stage, value: dict) -> None:
        run = self.result
        run.values[s.name], run.keys[s.name] = value, self.keys[s.name]
        if "report" in value:
            _put_section(run.report, s.section or s.name, value["report"])
        run.files.update(value.get("files", {}))

    def _finish(self, s: Stage, value: dict) -> None:
        if s.cache and s.name not in self.deferred:     # else once its files are written
            self.cache.store(s.name, self.keys[s.name], value)
        self.progress(s.name, "done", {"seconds": self.result.stage_seconds[s.name]})
        self._record(s, value)

    def _defer(self, name: str, pending) -> None:
        self.deferred.setdefault(name, []).append(pending)

    def _settle(self) -> None:
        """Wait for the work the stages deferred (:meth:`StageInputs.defer`), then cache
        their results: a cached result's files are all written."""
        for name in list(self.deferred):
            s = next(t for t in self.stages if t.name == name)
            # its errors as the stage's own (a DesignError naming it, or a bug with a note)
            _compute(replace(s, run=lambda _, items=self.deferred[name]: [p.result() for p in items]),
                     None)
            del self.deferred[name]
            if s.cache:
                self.cache.store(name, self.keys[name], self.result.values[name])

    def _collect(self, name: str) -> None:
        s, pending = self.running.pop(name)
        try:
            value, self.result.stage_seconds[name] = pending.result()
        except BaseException:
            pending.cancel()
            raise
        self._finish(s, value)

    def _inputs_of(self, s: Stage) -> StageInputs:
        return StageInputs(spec=self.spec, out=self.out, stage=s.name,
                           results={i: self.result.values[i] for i in s.inputs
                                    if i in self.result.values},
                           report=self.result.report, _progress=self.progress, memo=self.memo,
                           _defer=partial(self._defer, s.name))

    def _start(self, s: Stage) -> bool:
        """``s`` started in a process of its own (True), else it is to run here."""
        inputs = replace(self._inputs_of(s), report=dict(self.result.report), _progress=quiet,
                         _defer=None)              # its process waits for what it defers
        pending = _start_concurrent(s, inputs, self.ahead.pop(s.name, None))
        if pending is not None:
            self.running[s.name] = (s, pending)
        return pending is not None

    def _start_ready(self, later: list[Stage]) -> None:
        """Start the concurrent stages among ``later`` whose inputs are all done and whose
        result is not in the cache (a cached one is read in its turn, in order)."""
        names = {t.name for t in self.stages}
        for t in later:
            if (t.concurrent and t.name not in self.tried
                    and all(i in self.result.values for i in t.inputs if i in names)
                    and not (t.cache and self.cache.has(t.name, self.keys[t.name]))):
                self.tried.add(t.name)
                if self._start(t):
                    self.progress(t.name, "start", {})
