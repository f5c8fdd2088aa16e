"""The background build of a live session: the whole design run (solids, sheets, the
assembly check, every file) in a worker thread, one at a time; a newer request cancels the
running one.

A build is :meth:`torsal.pipeline.Design.run`: its result files appear together when every
stage succeeded (:class:`~torsal.pipeline.staging.Staging`), so a cancelled build leaves the
output folder as it found it. Cancelling is cooperative: the run's progress callback raises
:class:`BuildCancelled` at the next stage boundary or progress event after :meth:`Builder.cancel`.
A build starts once its design has stood :data:`BUILD_SETTLE_S` seconds without a newer edit.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from ..pipeline.cache import StageCache
from ..pipeline.design import Design, DesignResult
from ..pipeline.design_file import DesignSpec
from ..pipeline.errors import Progress, quiet
from ..pipeline.stage import Pipeline

__all__ = ["BuildCancelled", "BuildRequest", "Builder", "BUILD_SETTLE_S"]

#: seconds a build waits for a newer edit before it starts. Edits come in bursts (a slider
#: dragged, a value typed): each preview takes 0.1-0.6 s, and a build started between two of
#: them runs on in its fabrication stage, which reports no progress to cancel it at, for
#: seconds after the next edit, sharing the processor with that edit's preview. The notebook's
#: two slider moves (0.6 s apart) started the first one's build, and it made its parts (13.7 s
#: at a load of 30) before the second's began: 28.5 s from the first move to the built
#: answer, against 17.8 s with the build waiting for the moves to settle (and the second
#: move's preview 0.94 -> 0.58 s, with no build beside it)
BUILD_SETTLE_S = 1.0


class BuildCancelled(BaseException):
    """Raised inside a cancelled build (like ``asyncio.CancelledError``, not an
    ``Exception``: no stage's error handling takes it for a failure of its own)."""


@dataclass(frozen=True)
class BuildRequest:
    """A design to build: the session's ``revision`` of it and when its edit came
    (``time.perf_counter()`` seconds)."""

    revision: int
    spec: DesignSpec
    edited_at: float


#: ``on_done(request, result, error)``: exactly one of result and error is None
BuildDone = Callable[[BuildRequest, "DesignResult | None", "BaseException | None"], None]


class Builder:
    """Runs :class:`BuildRequest` s in a worker thread, the newest only.

    Parameters
    ----------
    out : Path
        The output folder.
    cache : StageCache
        Shared with the session's previews (their congruence, remesh and support are found
        there: the build computes the rest).
    pipeline : Pipeline
    on_done : callable(request, result, error)
        Called in the worker thread when a build ends (not when it is cancelled).
    progress : callable(stage, event, info)
    settle : float
        Seconds a request waits for a newer one before its build starts (default
        :data:`BUILD_SETTLE_S`).

    Examples
    --------
    >>> b = Builder(Path("out"), StageCache("out/.torsal-cache"), DEFAULT_PIPELINE,
    ...             on_done=print)                           # doctest: +SKIP
    >>> b.submit(BuildRequest(1, spec, time.perf_counter()))  # doctest: +SKIP
    """

    def __init__(self, out: Path, cache: StageCache, pipeline: Pipeline, *, on_done: BuildDone,
                 progress: Progress = quiet, settle: float = BUILD_SETTLE_S):
        self.out, self.cache, self.pipeline = Path(out), cache, pipeline
        self.settle = float(settle)
        self._submitted = 0.0               # time.monotonic() of the last submit
        self.on_done, self.progress = on_done, progress
        self.cancelled = 0                  # builds cancelled so far
        self._cond = threading.Condition()
        self._pending: BuildRequest | None = None
        self._running: BuildRequest | None = None
        self._cancel = threading.Event()
        self._closing = False
        self._thread: threading.Thread | None = None

    @property
    def busy(self) -> bool:
        """A build runs or waits to run."""
        with self._cond:
            return self._running is not None or self._pending is not None

    def submit(self, request: BuildRequest) -> None:
        """Build ``request`` next; a running build is cancelled, a waiting one replaced."""
        with self._cond:
            if self._closing:
                raise RuntimeError("the session's builder is closed")
            self._pending = request
            self._submitted = time.monotonic()
            self._cancel.set()
            if self._thread is None:
                self._thread = threading.Thread(target=self._loop, name="torsal-session-build",
                                                daemon=True)
                self._thread.start()
            self._cond.notify_all()

    def cancel(self) -> None:
        """Cancel the running build and drop a waiting one."""
        with self._cond:
            self._pending = None
            self._cancel.set()

    def wait_idle(self, timeout: float | None = None) -> bool:
        """Wait until no build runs or waits (True), or ``timeout`` seconds (False)."""
        end = None if timeout is None else time.monotonic() + timeout
        with self._cond:
            while self._running is not None or self._pending is not None:
                left = None if end is None else end - time.monotonic()
                if left is not None and left <= 0:
                    return False
                self._cond.wait(left)
        return True

    def close(self, timeout: float | None = None) -> None:
        """Cancel, and end the worker thread (waiting up to ``timeout`` seconds)."""
        with self._cond:
            self._closing = True
            self._pending = None
            self._cancel.set()
            self._cond.notify_all()
        if self._thread is not None:
            self._thread.join(timeout)

    def _next(self) -> BuildRequest | None:
        with self._cond:
            self._running = None
            self._cond.notify_all()
            while not self._closing:
                # the newest request, once no newer one came for ``settle`` seconds
                left = self._submitted + self.settle - time.monotonic()
                if self._pending is not None and left <= 0:
                    break
                self._cond.wait(None if self._pending is None else left)
            if self._closing:
                return None
            req, self._pending = self._pending, None
            self._cancel = threading.Event()
            self._running = req
            return req

    def _loop(self) -> None:
        while (req := self._next()) is not None:
            cancel = self._cancel

            def watch(stage, event, info, cancel=cancel):
                if cancel.is_set():
                    raise BuildCancelled(f"build of revision {req.revision} cancelled")
                self.progress(stage, event, info)

            try:
                result = Design(req.spec).run(self.out, cache=self.cache, pipeline=self.pipeline,
                                              progress=watch, accept_unbuildable=True)
            except BuildCancelled:
                self.cancelled += 1
                continue
            except BaseException as exc:       # reported to the session, never lost in a thread
                self.on_done(req, None, exc)
                continue
            self.on_done(req, result, None)
