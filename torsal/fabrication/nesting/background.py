"""Nesting in a process of its own, while this one goes on (writes the solids' files).

The yield nester (:func:`~.yield_.nest_for_yield`) is an anytime search with a wall-clock
budget; the fabrication stage meanwhile collects the solids and writes the STEP and 3DM files,
work of this process that does not need the sheets. :func:`start_nesting` starts
:func:`~.api.nest_parts` in a separate process (forked from the clean server the solids'
workers come from) and returns at once; :meth:`PendingNesting.result` waits for its
:class:`~torsal.fabrication.layout.Layout` (the parts list is written from it afterwards). Asked
to, that process also writes the DXF sheets (:func:`write_sheets`), which needs nothing but
the layout. The nest is the same as in this process: same parts, options, seed and budget.
Progress is relayed from the nesting process by a thread of this one; an error in the nester is
raised again by :meth:`~PendingNesting.result` (same type where it pickles).

Where no second process may be started (a daemonic worker, :func:`limit_workers` ``(1)``)
the nest runs in this process when :meth:`~PendingNesting.result` is called.

Example
-------
>>> from shapely.geometry import box
>>> from torsal.fabrication.nesting import Nester
>>> parts = {f"p{i}": box(0, 0, 300, 100) for i in range(4)}
>>> pending = start_nesting(parts, sheet=(1000, 500), nester=Nester.ROWS)
>>> pending.result().n_sheets
1
"""
from __future__ import annotations

import multiprocessing as mp
import queue
import threading
from pathlib import Path
from typing import Callable, NamedTuple

from torsal.core.parallel import portable_error, usable_workers

__all__ = ["start_nesting", "PendingNesting", "SheetFiles", "write_sheets"]


class SheetFiles(NamedTuple):
    """The cutting sheets written: ``paths`` one DXF per sheet, ``area_read_back`` the parts'
    area (unit^2) in those files as :func:`~..layout.read_dxf_parts` reads them back, taken
    from the drawings they were written from (:func:`~..layout.drawing_parts`: the same
    polygons from the same numbers, so the same floats, without reading 40 files again)."""

    paths: list
    area_read_back: float


def write_sheets(layout, path) -> SheetFiles:
    """Write the DXF (and SVG) sheets of ``layout`` next to ``path``; the parts' area in them.

    The report's ``utilization_dxf`` is that area over the sheets'. It was the files read back
    with ezdxf (2.1 of the nester's 5.2 CPU s for 7a): the same number, since
    :func:`~..layout.drawing_parts` builds the parts as the reader does from the numbers the
    files hold; tests/fabrication/test_sheet_dxf.py reads the files with ezdxf and with a
    reader of its own and finds the same parts and area."""
    from ..layout import drawing_parts

    written = layout.write_sheet_files(path)
    area = sum(p.area for _, drawing in written for p in drawing_parts(drawing))
    return SheetFiles([Path(f) for f, _ in written], float(area))


def _nest_and_write(unrolled, options: dict, dxf, progress):
    """``(layout, SheetFiles or None)``: the nest, and its sheets written to ``dxf``."""
    from .api import nest_parts

    layout = nest_parts(unrolled, progress=progress, **options)
    return layout, (write_sheets(layout, dxf) if dxf is not None else None)


def _counts_tries(options: dict) -> bool:
    """Whether the nest ``options`` ask for gives the same sheets however fast it runs: no time
    limit and not :attr:`~.stats.Nester.SPARROW` (which stops on the clock)."""
    from .stats import Nester

    return options.get("time_limit") is None and options.get("nester") != Nester.SPARROW


def _nest_in_child(unrolled, options: dict, dxf, queue) -> None:
    """Nesting process: ``("progress", (done, left))`` while it runs, then ``("done",
    (layout, sheets))`` or ``("error", exception)`` on ``queue``."""
    def progress(done: int, left: int) -> None:
        queue.put(("progress", (done, left)))

    if _counts_tries(options):
        # the design's solids (and the files after them) come first; a nester that counts
        # its tries nests the same sheets at any priority (not sparrow: it stops on the clock)
        from ..workers import run_in_background

        run_in_background()
    try:
        layout = _nest_and_write(unrolled, options, dxf, progress)
    except BaseException as exc:            # re-raised in the parent
        queue.put(("error", portable_error(exc)))
        return
    queue.put(("done", layout))


class PendingNesting:
    """A nest started by :func:`start_nesting`: :meth:`result` waits for its layout,
    :meth:`cancel` stops it."""

    def __init__(self, unrolled, options: dict, progress: Callable[[int, int], None] | None,
                 dxf=None):
        self._unrolled, self._options, self._progress, self._dxf = unrolled, options, progress, dxf
        self._layout = self._error = None
        #: the sheets written (:class:`SheetFiles`, with ``dxf``), after :meth:`result`
        self.sheets: SheetFiles | None = None
        self._process = None
        if usable_workers(2) < 2:
            return                            # nested in this process, when asked for
        ctx = mp.get_context("forkserver" if "forkserver" in mp.get_all_start_methods() else "spawn")
        self._queue = ctx.Queue()
        self._process = ctx.Process(target=_nest_in_child,
                                    args=(unrolled, options, dxf, self._queue),
                                    name="torsal-nesting", daemon=True)
        self._process.start()
        self._done = threading.Event()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _next(self):
        """The nesting process's next message, or ``None`` when it ended and left none.

        A message put just before the process ends can arrive after a ``get`` timed out and
        before ``is_alive`` says it ended (a busy machine widens that window): what an ended
        process put is already in the pipe (its queue's feeder thread is joined at exit), so
        the queue is read once more before the process is said to have left no result."""
        while True:
            try:
                return self._queue.get(timeout=1.0)
            except queue.Empty:
                if self._process.is_alive():
                    continue
            try:
                return self._queue.get(timeout=1.0)
            except queue.Empty:
                return None

    def _read(self) -> None:
        """Relay the nesting process's progress; keep its layout or error."""
        try:
            while True:
                message = self._next()
                if message is None:
                    self._error = RuntimeError(
                        f"the nesting process ended without a result (exit code "
                        f"{self._process.exitcode})")
                    return
                kind, value = message
                if kind == "progress":
                    if self._progress is not None:
                        self._progress(*value)
                    continue
                if kind == "done":
                    self._layout, self.sheets = value
                else:
                    self._error = value
                return
        finally:
            self._done.set()

    def result(self):
        """The :class:`~torsal.fabrication.layout.Layout` (waits for the nesting process)."""
        if self._process is None:
            if self._layout is None:
                self._layout, self.sheets = _nest_and_write(self._unrolled, self._options,
                                                            self._dxf, self._progress)
            return self._layout
        self._done.wait()
        self._process.join()
        if self._error is not None:
            raise self._error
        return self._layout

    def cancel(self) -> None:
        """Stop the nesting process (a later step failed)."""
        if self._process is not None and self._process.is_alive():
            self._process.terminate()
            self._process.join()


def start_nesting(unrolled, *, progress: Callable[[int, int], None] | None = None, dxf=None,
                  **options) -> PendingNesting:
    """Start :func:`~.api.nest_parts` of ``unrolled`` (``{name: Unrolled or Polygon}``) with
    ``options`` (its keyword arguments) in a process of its own and return at once; with
    ``dxf`` (a path) that process also writes the sheets there (:func:`write_sheets`;
    ``PendingNesting.sheets``)."""
    return PendingNesting(unrolled, options, progress, dxf)
