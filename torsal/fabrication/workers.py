"""Worker processes that build the solids of a fin system, and the build itself.

The solids (:mod:`.plates`) are independent per part: a :class:`WorkerPool` of processes
(forked from a clean server that has imported OpenCascade) builds them and sends them back as
OpenCascade binary BReps, with their preview meshes and the 3DM's Breps if asked. The
fabrication stage starts the pool ahead (:func:`prepare_workers`: the processes take seconds
to start, while the stage builds its parts), :func:`start_solids` hands the parts to it and
returns at once (:class:`PendingSolids`), and the exports collect the shapes
(:func:`solid_shapes`). The prepared pool is held in a context variable (one per thread or
task), not in a module global: the pool object owns its processes and its start-up thread.

Units: the ``unit`` of the fin system (mm by default).
"""
from __future__ import annotations

import threading
from collections.abc import Mapping
from contextvars import ContextVar
from typing import NamedTuple

import numpy as np

from torsal.core.parallel import child_answer, usable_workers  # noqa: F401  (re-exported)

from .plates import MESH_TOLERANCE, InvalidSolidError, _build_one, _downcast, _labelled, _mesh
from .rhino import brep_record

__all__ = ["WorkerPool", "PendingSolids", "default_workers", "prepare_workers",
           "release_workers", "start_solids", "build_solids", "solid_shapes", "solid_bytes",
           "map_prepared", "start_fork_server", "child_answer", "BACKGROUND_NICE",
           "run_in_background", "check_solids", "check_record"]


def _to_bytes(shape) -> bytes:
    """OpenCascade binary BRep of a shape (OCC shapes do not pickle; bytes do)."""
    import io

    from OCP.BinTools import BinTools

    buf = io.BytesIO()
    BinTools.Write_s(shape, buf)
    return buf.getvalue()


def _from_bytes(data: bytes):
    """The OCC shape of :func:`_to_bytes`."""
    import io

    from OCP.BinTools import BinTools
    from OCP.TopoDS import TopoDS_Shape

    shape = TopoDS_Shape()
    BinTools.Read_s(shape, io.BytesIO(data))
    return _downcast(shape)


def check_record(data: bytes, tolerance: float) -> tuple[bytes, object]:
    """The assembly check's solid of the binary BRep ``data`` (:func:`_to_bytes` of a built
    solid): read, its triangles (if any) dropped and meshed at the check's touching
    ``tolerance`` (unit) as the check meshes, with the records of its cheap tests
    (:func:`~.assembly.prepared.solid_records`). Returns ``(BRep bytes with those triangles,
    records)``: made by a solids' worker or by the process that checks, the same bytes and
    records of the same ``data``.

    >>> data, records = check_record(solid_bytes(fs)["F0-S000-P00"], 1.0)   # doctest: +SKIP
    """
    from OCP.BRepTools import BRepTools

    from .assembly.occ import _mesh as _check_mesh
    from .assembly.prepared import solid_records

    shape = _from_bytes(data)
    BRepTools.Clean_s(shape)        # the previews' triangles, where the worker meshed for them
    _check_mesh([shape], tolerance)
    return _to_bytes(shape), solid_records(shape)


def _build_chunk(args):
    """Worker: build the solids of some parts and return them as binary BReps (OCP only: a
    worker never imports build123d or rhino3dm), and the CPU seconds that took. With
    ``mesh`` each is meshed at the default tolerance first (the triangles travel with the
    BRep) and comes with its 3DM record (:func:`~.rhino.brep_record` at that tolerance: bytes,
    None where the 3DM joins the part's mesh), made from the shape in hand rather than from
    the bytes read again; the CPU seconds of the records separately. With ``check`` (the
    assembly check's touching tolerance, or None) each also comes with the check's solid
    (:func:`check_record` of the bytes sent)."""
    import time

    parts, thickness, repair, mesh, check = args
    cpu, record_cpu = time.process_time(), 0.0
    out = []
    for p in parts:
        status, shape, detail = _build_one(p, thickness, repair)
        record = None
        if shape is not None and mesh:
            _mesh(shape, MESH_TOLERANCE * thickness, threads=False)
            t0 = time.process_time()
            record = brep_record(shape, MESH_TOLERANCE * thickness, threads=False)
            record_cpu += time.process_time() - t0
        data = None if shape is None else _to_bytes(shape)
        checked = None if data is None or check is None else check_record(data, check)
        out.append((p.name, status, data, detail, record, checked))
    return out, time.process_time() - cpu, record_cpu


#: niceness a process adds to its own when the run does not wait for it yet (a concurrent
#: stage's, the IFC's): on two cores the processes the run waits for (the fin system, the
#: solids' workers, the STEP reader) get the cores first, the others what is left over;
#: where nothing else runs they run at full speed (it orders the work; results do not change)
BACKGROUND_NICE = 5


def run_in_background() -> None:
    """Lower this process's priority by :data:`BACKGROUND_NICE` (nothing where the system
    does not allow it).

    >>> run_in_background()        # doctest: +SKIP
    """
    import os

    try:
        os.nice(BACKGROUND_NICE)
    except (AttributeError, OSError):
        pass


def default_workers(n_parts: int) -> int:
    """Processes for building ``n_parts`` solids: one per available core, 1 for small jobs
    (starting the workers, which import OpenCascade, costs about as much as building 200
    parts)."""
    import os

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, min(cores, n_parts // 200))


class WorkerPool:
    """A pool of worker processes being started (from a thread: the first start waits seconds
    for the fork server to import OpenCascade), to build solids with later."""

    def __init__(self, workers: int, mesh: bool = False, check: float | None = None):
        from concurrent.futures import ProcessPoolExecutor

        self.workers, self.mesh, self.check = workers, mesh, check
        # a fork of a process that runs threads (OpenCascade, BLAS, a test runner) can
        # deadlock in the child: workers are forked from a clean server that has imported
        # this module
        self.pool = ProcessPoolExecutor(max_workers=workers, mp_context=_context())
        self.error: BaseException | None = None
        self._starter = threading.Thread(target=self._start, daemon=True)
        self._starter.start()

    def _start(self) -> None:
        try:              # each submission starts one more process, up to ``workers``
            for _ in range(self.workers):
                self.pool.submit(_ready)
        except BaseException as e:        # re-raised by PendingSolids.result()
            self.error = e

    def started(self) -> None:
        """Wait until the processes are started (or failed to)."""
        self._starter.join()

    def shutdown(self, cancel: bool = False) -> None:
        """Stop the pool: wait for its work, or (``cancel``) drop it and return at once: a
        process still being started holds the pool's lock for seconds, so a thread waits for
        it and shuts the pool down."""
        if not cancel:
            self._starter.join()
            self.pool.shutdown(wait=True)
            return
        threading.Thread(target=self.pool.shutdown, kwargs={"wait": False, "cancel_futures": True},
                         daemon=True).start()


#: what the fork server imports before it forks a worker (OpenCascade: seconds)
_PRELOAD = ["torsal.fabrication.workers", "OCP.BRepAlgoAPI"]
#: what it imports last: its imports' objects frozen (gc), shared with its children as they are
_PRELOAD_LAST = "torsal.core.freeze_imports"


def _context(also: tuple[str, ...] = ()):
    """The workers' multiprocessing context: forked from a clean server that has imported
    :data:`_PRELOAD` (and ``also``, when it starts now) and frozen the objects they made
    (:mod:`torsal.core.freeze_imports`), where there is one, else spawned."""
    import multiprocessing as mp

    if "forkserver" not in mp.get_all_start_methods():
        return mp.get_context("spawn")
    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(_PRELOAD + [m for m in also if m not in _PRELOAD] + [_PRELOAD_LAST])
    return ctx


def start_fork_server(*, also: tuple[str, ...] = ()) -> None:
    """Start the server the solids' workers are forked from now, in the background: its
    imports (OpenCascade, about a second and a half) then run while this process optimizes,
    and the fabrication's workers start at once. ``also``: more modules it imports, once,
    for every process forked from it (a design's concurrent stages: the pipeline's modules,
    which each of them would import again). Nothing where no worker may be started (a
    daemonic process, :func:`~torsal.core.parallel.limit_workers` ``(1)``) or where
    processes are spawned.

    >>> start_fork_server()
    """
    from multiprocessing import forkserver

    from torsal.core.parallel import usable_workers

    if usable_workers(2) < 2 or _context(also).get_start_method() != "forkserver":
        return
    forkserver.ensure_running()


def _ready() -> None:
    """Worker: nothing (a submission that makes the pool start a process)."""


#: worker processes started ahead by :func:`prepare_workers`, taken by the next build (in this
#: thread or task)
_PREPARED: ContextVar[WorkerPool | None] = ContextVar("torsal_prepared_workers", default=None)


def prepare_workers(n_parts: int, *, workers: int | None = None, mesh: bool = False,
                    check: float | None = None) -> int:
    """Start the worker processes for about ``n_parts`` solids now (in the background), so
    that :func:`start_solids` finds them ready: the caller builds its parts meanwhile (the
    fabrication stage: its FinSystem takes as long as the workers take to start). With
    ``mesh`` they also mesh every solid for the previews (3DM, glTF, STL at the default
    tolerance), which then only read the triangles, and make the 3DM's records of the solids
    (:func:`~.rhino.brep_record`). With ``check`` (the assembly check's touching tolerance)
    they make the check's solids too (:func:`check_record`, taken by :func:`check_solids`).
    Returns the number of processes started (0: the solids will be built in this process).
    :func:`release_workers` stops them if no build comes."""
    release_workers()
    n = _workers_for(n_parts, workers)
    if n > 1:
        _PREPARED.set(WorkerPool(n, mesh, check))
    return n if n > 1 else 0


def release_workers() -> None:
    """Stop worker processes started by :func:`prepare_workers` and not used."""
    w = _PREPARED.get()
    if w is not None:
        _PREPARED.set(None)
        w.shutdown(cancel=True)


#: what this process imports while it waits for the workers (:func:`_preload_while_waiting`):
#: OpenCascade (one extension of about 2-3 s to load) to read their BReps and write the STEP
#: file, and rhino3dm for the 3DM
_WAIT_IMPORTS = ("OCP.BinTools", "OCP.TopoDS")
_WAIT_IMPORTS_MESH = ("rhino3dm",)
_preloader: threading.Thread | None = None


def _preload_while_waiting(mesh: bool = False) -> None:
    """Import what this process needs once the solids come back (:data:`_WAIT_IMPORTS`; with
    ``mesh`` the 3DM's rhino3dm too) in a thread, now that it is about to wait for the
    workers: loading OpenCascade takes its 2-3 s of the one core the waiting process leaves
    idle, not of the process's own work after the wait (the first BRep read back, the STEP
    file). Once per process; the same modules either way, so nothing else changes.
    :func:`_preloaded` waits for it."""
    global _preloader
    import sys

    names = _WAIT_IMPORTS + (_WAIT_IMPORTS_MESH if mesh else ())
    if _preloader is not None or all(n in sys.modules for n in names):
        return

    def load():
        import importlib

        for n in names:
            try:
                importlib.import_module(n)
            except Exception:        # the import that needs it raises it, with its message
                pass

    _preloader = threading.Thread(target=load, name="torsal-preload", daemon=True)
    _preloader.start()


def _preloaded() -> None:
    """Wait for :func:`_preload_while_waiting`'s imports (none started: nothing to wait for):
    the process may fork after it, and a fork must not copy a half-done import."""
    if _preloader is not None:
        _preloader.join()


def _call_chunk(args):
    """Worker: ``[fn(item) for item in items]`` of ``(fn, items)``."""
    fn, items = args
    return [fn(x) for x in items]


def map_prepared(fn, items: list) -> list:
    """``[fn(x) for x in items]``, in the worker processes :func:`prepare_workers` started if
    there are any (they wait for the solids meanwhile), else in this process. ``fn`` is a
    module-level function and ``items`` pickle; the results come back in order, the same
    as in this process (each item is computed on its own). Used for the seams' local
    assembly checks, which the fin system runs while the prepared workers are idle.

    >>> map_prepared(abs, [-1, 2])
    [1, 2]
    """
    w = _PREPARED.get()
    if w is None or len(items) < 2:
        return [fn(x) for x in items]
    _preload_while_waiting(w.mesh)       # this process waits from here: its imports meanwhile
    w.started()
    if w.error is not None:              # the workers could not start: build here
        return [fn(x) for x in items]
    n_chunks = min(len(items), 4 * w.workers)
    # contiguous chunks (results are put back in order), a few per worker so none waits long
    bounds = np.linspace(0, len(items), n_chunks + 1).astype(int)
    futures = [w.pool.submit(_call_chunk, (fn, items[a:b])) for a, b in zip(bounds[:-1], bounds[1:])]
    return [r for f in futures for r in f.result()]


def _take_workers(workers: int) -> WorkerPool:
    """The prepared workers if there are ``workers`` of them, else new ones."""
    w = _PREPARED.get()
    if w is not None and w.workers == workers:
        _PREPARED.set(None)
        return w
    release_workers()
    return WorkerPool(workers)


class PendingSolids:
    """Solids being built by worker processes (:func:`start_solids`): the caller goes on with
    other work (unrolling, nesting, DXF) and :meth:`result` collects them. Holds the pool
    until then; :meth:`cancel` drops work not yet started."""

    def __init__(self, parts: list, thickness: float, repair: bool, workers: int):
        self.parts, self.thickness, self.repair, self.workers = parts, thickness, repair, workers
        # interleaved chunks of about equal work; a few per worker so that none waits long
        n_chunks = min(len(parts), 4 * workers)
        chunks = [parts[i::n_chunks] for i in range(n_chunks)]
        self._workers = _take_workers(workers)
        self._pool = self._workers.pool
        self._futures: list = []
        self._records: dict | None = None
        self._error: BaseException | None = None
        # submitting waits for the processes to start: a thread does that, so the caller
        # goes on at once
        self._starter = threading.Thread(target=self._submit, args=(chunks,), daemon=True)
        self._starter.start()

    def _submit(self, chunks) -> None:
        try:
            self._workers.started()
            if self._workers.error is not None:
                raise self._workers.error
            for c in chunks:
                self._futures.append(self._pool.submit(
                    _build_chunk, (c, self.thickness, self.repair, self._workers.mesh,
                                   self._workers.check)))
        except BaseException as e:        # re-raised by result()
            self._error = e

    def result(self) -> list:
        """``[(name, status, OCC shape, detail)]`` in the order of the parts (waits), then
        stops the workers. With ``mesh`` the workers made the 3DM's records too
        (:meth:`breps`)."""
        _preload_while_waiting(self._workers.mesh)
        self._starter.join()
        res, records = {}, {}
        #: {part name: the binary BRep a worker sent} (what another process reads the solid from)
        self.brep_bytes: dict[str, bytes] = {}
        #: {part name: the assembly check's solid, :func:`check_record`} (with ``check``)
        self.check_rows: dict[str, tuple] = {}
        #: CPU seconds the workers spent building, the 3DM's records included (what the
        #: caller's clock does not see), and those of the records alone
        self.cpu_seconds = self.brep_cpu_seconds = 0.0
        try:
            if self._error is not None:
                raise self._error
            # each chunk's shapes are read back as it comes, while the workers build the
            # last ones (a second of this process's time on 7a that the STEP file waited for)
            for i, f in enumerate(self._futures):
                rows, cpu, record_cpu = f.result()
                if i == 0:
                    _preloaded()
                self.cpu_seconds += cpu
                self.brep_cpu_seconds += record_cpu
                for name, status, data, detail, record, checked in rows:
                    res[name] = (status, None if data is None else _from_bytes(data), detail)
                    if data is not None:
                        records[name] = record
                        self.brep_bytes[name] = data
                    if checked is not None:
                        self.check_rows[name] = checked
        finally:
            self._pool.shutdown(wait=True)
        self._records = records if self._workers.mesh else None
        return [(p.name,) + res[p.name] for p in self.parts]

    def breps(self) -> dict | None:
        """With ``mesh``, after :meth:`result`: {part name: 3DM record (:func:`~.rhino.brep_record`
        of the solid :meth:`result` gave, bytes) or None (the 3DM joins its mesh)}; a part
        without a solid is not listed. None without ``mesh``."""
        return self._records

    def cancel(self) -> None:
        """Stop: chunks not yet started are dropped, the workers end after their current one
        (the thread that hands them out stops at the first it finds cancelled or refused)."""
        self._pool.shutdown(wait=False, cancel_futures=True)


def _workers_for(n_parts: int, workers: int | None) -> int:
    """Worker processes for ``n_parts`` solids: ``workers`` or :func:`default_workers`, no more
    than this process may use (:func:`~torsal.core.parallel.usable_workers`)."""
    return usable_workers(default_workers(n_parts) if workers is None else workers)


def start_solids(fin_system, *, repair: bool = True, workers: int | None = None) -> PendingSolids | None:
    """Start building the solids of a :class:`~.parts.FinSystem` in worker processes and return
    at once (:class:`PendingSolids`), or None if they would be built in this process (one
    worker: small jobs, one core) or are built already. :func:`build_solids` with ``pending``
    collects them; meanwhile this process can unroll, nest and write the sheets."""
    memo = getattr(fin_system, "_solid_shapes", None)
    if getattr(fin_system, "_solids", None) is not None or (
            memo is not None and memo[0] == _parts_key(fin_system)):
        return None
    parts = list(fin_system.parts)
    prepared = _PREPARED.get()
    if workers is None and prepared is not None and len(parts) > 1:
        workers = prepared.workers      # started already (prepare_workers): their start is paid
    workers = _workers_for(len(parts), workers)
    if workers <= 1:
        return None
    return PendingSolids(parts, fin_system.thickness, repair, workers)


def build_solids(fin_system, *, repair: bool = True, workers: int | None = None,
                 pending: PendingSolids | None = None) -> dict:
    """``{part name: Solid}`` for every part of a :class:`~.parts.FinSystem` (plates and
    connectors), build123d solids labelled with the part id and coloured by family.

    Solids are independent per part: with ``workers > 1`` (default :func:`default_workers`)
    they are built in worker processes (forked from a clean server process) and sent back as
    OpenCascade binary BReps; ``pending`` (:func:`start_solids`) collects such a build
    started earlier. All parts are attempted; if any is invalid an
    :class:`InvalidSolidError` listing every invalid part id is raised. Shapes built already
    for the exports (:func:`solid_shapes`) are labelled, not built again.
    """
    memo = getattr(fin_system, "_solid_shapes", None)
    if pending is None and memo is not None and memo[0] == _parts_key(fin_system):
        shapes = memo[1]
    else:
        shapes = _collect(fin_system, repair, workers, pending)
    by_name = {p.name: p for p in fin_system.parts}
    return {name: _labelled(shape, by_name[name]) for name, shape in shapes.items()}


def solid_shapes(fin_system, *, repair: bool = True, workers: int | None = None) -> dict:
    """``{part name: OCC solid}`` of a :class:`~.parts.FinSystem`: the shapes of its build123d
    solids if it has them, else built (or collected from :meth:`~.parts.FinSystem.start_solids`)
    as :func:`build_solids` does and kept on the fin system, without build123d (what the
    exports need)."""
    built = getattr(fin_system, "_solids", None)
    if built is not None:
        return {name: s.wrapped for name, s in built.items()}
    key = _parts_key(fin_system)
    memo = getattr(fin_system, "_solid_shapes", None)
    if memo is not None and memo[0] == key:
        return memo[1]
    pending, fin_system._pending = getattr(fin_system, "_pending", None), None
    shapes = _collect(fin_system, repair, workers, pending)
    fin_system._solid_shapes = (key, shapes)
    return shapes


def solid_bytes(fin_system) -> dict[str, bytes]:
    """``{part name: OpenCascade binary BRep}`` of :func:`solid_shapes`: the bytes the workers
    sent where they built them (the shapes are read from those very bytes), else written
    here. A process that reads them back has the same shapes as this one.

    >>> {name: len(b) for name, b in solid_bytes(fs).items()}      # doctest: +SKIP
    {'F0-S000-P00': 41213, ...}
    """
    shapes = solid_shapes(fin_system)
    kept = getattr(fin_system, "_solid_bytes", None)
    if kept is not None and kept[0] == _parts_key(fin_system) and kept[1].keys() == shapes.keys():
        return kept[1]
    return {name: _to_bytes(shape) for name, shape in shapes.items()}


class WorkerBreps(NamedTuple):
    """The 3DM records the solids' workers made with the solids (:func:`~.rhino.brep_record`):
    for which parts (``key``, :func:`_parts_key`), at which ``tolerance``, and ``breps``
    {part name: record (bytes) or None (the 3DM joins the part's mesh)}."""

    key: tuple
    tolerance: float
    breps: Mapping


class CheckSolids(NamedTuple):
    """The assembly check's solids the solids' workers made (:func:`check_record`): for which
    parts (``key``, :func:`_parts_key`), at which touching ``tolerance``, and ``rows``
    {part name: (BRep bytes, records)}."""

    key: tuple
    tolerance: float
    rows: Mapping


def check_solids(fin_system, tolerance: float, *, release: bool = False) -> list[tuple[str, object]]:
    """``[(part name, PreparedSolid)]`` of :func:`solid_shapes`, in the parts' order: each
    solid as the assembly check takes it (:func:`check_record` of its :func:`solid_bytes`:
    read, meshed at the touching ``tolerance``, with the records of the check's cheap tests),
    made by the solids' workers where :func:`prepare_workers` asked them to, else here: the
    same solids and records either way. ``release``: the fin system lets go of the workers'
    copies once they are taken (their bytes and records: tens of MB for a thousand parts;
    a later call makes them here again).

    >>> solids = check_solids(fs, 1.0)          # doctest: +SKIP
    """
    from .assembly.prepared import PreparedSolid

    shapes = solid_shapes(fin_system)
    kept = getattr(fin_system, "_check_solids", None)
    if release:
        fin_system._check_solids = None
    rows = (kept.rows if kept is not None and kept.key == _parts_key(fin_system)
            and kept.tolerance == tolerance else {})
    data = None if rows.keys() >= shapes.keys() else solid_bytes(fin_system)
    out = []
    for name in shapes:
        made = rows.get(name) or check_record(data[name], tolerance)
        out.append((name, PreparedSolid(_from_bytes(made[0]), made[1])))
    return out


def cancel_breps(fin_system) -> None:
    """Forget the 3DM records the solids' workers made for ``fin_system`` (they come with the
    solids: nothing is left to stop); :func:`~.exports.export_3dm` then makes its own."""
    if getattr(fin_system, "_breps", None) is not None:
        fin_system._breps = None


def _parts_key(fin_system) -> tuple:
    """Which parts (objects) the fin system has: shapes kept for other parts are stale."""
    return tuple(id(p) for p in fin_system.parts)


def _collect(fin_system, repair: bool, workers: int | None, pending: PendingSolids | None) -> dict:
    """``{part name: OCC solid}``: built here or by worker processes, or collected from
    ``pending``; sets ``fin_system.unslotted_solids`` (and warns); InvalidSolidError naming
    every invalid part."""
    import time

    parts = list(fin_system.parts)
    t = fin_system.thickness
    workers = _workers_for(len(parts), workers)
    if pending is None and workers > 1:
        pending = PendingSolids(parts, t, repair, workers)
    if pending is not None:
        rows = pending.result()
        cpu = pending.cpu_seconds
        fin_system._solid_bytes = (_parts_key(fin_system), pending.brep_bytes)
        if pending._workers.check is not None:     # the assembly check's solids, made there
            fin_system._check_solids = CheckSolids(_parts_key(fin_system), pending._workers.check,
                                                   pending.check_rows)
        records = pending.breps()
        if records is not None:      # the 3DM's records, made by the workers with the solids
            fin_system._breps = WorkerBreps(_parts_key(fin_system), MESH_TOLERANCE * t, records)
            fin_system.breps_cpu_seconds = pending.brep_cpu_seconds
    else:
        cpu = time.process_time()
        rows = [(p.name,) + _build_one(p, t, repair) for p in parts]
        cpu = time.process_time() - cpu
    # CPU seconds of the last build, in whichever process it ran (for benchmarks; with the
    # 3DM's records the workers made, breps_cpu_seconds of them)
    fin_system.solids_cpu_seconds = cpu
    out, bad, detail, unslotted = {}, [], [], []
    for name, status, shape, info in rows:
        if status == "bad":
            bad.append(name)
            detail.append(info)
            continue
        out[name] = shape
        if status == "unslotted":
            unslotted.append((name, info[0], info[1]))
    fin_system.unslotted_solids = unslotted
    if unslotted:
        import warnings

        warnings.warn(
            f"{len(unslotted)} parts are modelled without their slots (OpenCascade could not cut "
            f"them into the thin, oblique plate; the unrolled cutting outlines do have them): "
            + "; ".join(f"{n} (slots at nodes {v})" for n, v, _ in unslotted[:8])
            + (" ..." if len(unslotted) > 8 else "") + "; see FinSystem.unslotted_solids",
            stacklevel=4)
    if bad:
        cancel_breps(fin_system)        # no 3DM of an invalid set of solids
        raise InvalidSolidError(bad, "; ".join(detail))
    return out
