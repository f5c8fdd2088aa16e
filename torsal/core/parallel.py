"""Process parallelism that knows where it runs.

A daemonic process (a Dask or multiprocessing worker running a design study's variant) may not
start children of its own; there the work runs serially, in the worker that was already given
one core by the study's scheduler. :func:`limit_workers` caps the processes of the code it
wraps the same way, e.g. a study run serially as the one-core reference for its speed-up.

Examples
--------
>>> usable_workers(4) >= 1
True
>>> with limit_workers(1):
...     usable_workers(4)
1
"""
from __future__ import annotations

import multiprocessing
import pickle
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Iterator

__all__ = ["usable_workers", "limit_workers", "portable_error", "child_answer", "ForkedCall"]

#: the cap set by the innermost :func:`limit_workers` (None: no cap)
_CAP: ContextVar[int | None] = ContextVar("torsal_worker_cap", default=None)


def usable_workers(requested: int) -> int:
    """``requested`` worker processes, or 1 inside a daemonic process (which cannot fork
    children), at most the cap of an enclosing :func:`limit_workers`."""
    if multiprocessing.current_process().daemon:
        return 1
    cap = _CAP.get()
    n = max(1, int(requested))
    return n if cap is None else min(n, cap)


@contextmanager
def limit_workers(n: int) -> Iterator[None]:
    """Run the enclosed code with at most ``n`` (>= 1) worker processes per parallel step
    (solids, assembly check): ``n = 1`` keeps all of it in this one process."""
    if int(n) < 1:
        raise ValueError(f"limit_workers needs n >= 1, got {n}")
    token = _CAP.set(int(n))
    try:
        yield
    finally:
        _CAP.reset(token)


def portable_error(exc: BaseException) -> BaseException:
    """``exc`` as it may cross from a child process to its parent: itself where it survives
    pickling both ways, else a ``RuntimeError`` with its type, message and notes (an
    exception of a C extension, or one whose constructor takes other arguments).

    >>> portable_error(ValueError("bad"))
    ValueError('bad')
    >>> class Odd(Exception):
    ...     def __init__(self, a, b):
    ...         super().__init__(f"{a}{b}")
    >>> portable_error(Odd("x", "y"))
    RuntimeError('Odd: xy')
    """
    try:
        pickle.loads(pickle.dumps(exc))
        return exc
    except Exception:
        return RuntimeError(f"{type(exc).__name__}: {exc}" + "".join(
            f"; {n}" for n in getattr(exc, "__notes__", ())))


def child_answer(conn, process, what: str) -> tuple[str, object]:
    """The one ``(kind, value)`` message a child process sends on ``conn`` (waits), then
    ``conn`` closed and the process joined; a RuntimeError naming ``what`` (and the exit
    code) if it ended without one.

    >>> kind, value = child_answer(conn, process, "the IFC export")   # doctest: +SKIP
    """
    try:
        message = conn.recv()
    except EOFError:
        raise RuntimeError(f"{what} ended without a result (exit code "
                           f"{process.join() or process.exitcode})") from None
    finally:
        conn.close()
    process.join()
    return message


def _answer(conn, fn, args: tuple) -> None:
    """A :class:`ForkedCall`'s process: ``fn(*args)``'s value, or its error, sent back."""
    try:
        answer = ("value", fn(*args))
    except BaseException as e:         # crosses to the parent, raised again there
        answer = ("error", portable_error(e))
    conn.send(answer)
    conn.close()


class ForkedCall:
    """``fn(*args)`` in a process forked from this one, started at once: nothing but the
    answer is pickled (the arguments are inherited, OpenCascade shapes among them).
    :meth:`result` waits for the value, the call's error raised again here; :meth:`cancel`
    stops it. Where this process may not start one (no ``fork``, a daemonic worker of a
    study: :func:`usable_workers`) the call runs here, now.

    >>> ForkedCall(pow, 2, 10).result()
    1024
    """

    def __init__(self, fn, *args):
        self._process = self._conn = None
        self._done: tuple | None = None
        if "fork" not in multiprocessing.get_all_start_methods() or usable_workers(2) < 2:
            try:
                self._done = ("value", fn(*args))
            except Exception as e:
                self._done = ("error", e)
            return
        ctx = multiprocessing.get_context("fork")
        self._conn, child = ctx.Pipe(duplex=False)
        self._process = ctx.Process(target=_answer, args=(child, fn, args), daemon=True,
                                    name=f"torsal-{getattr(fn, '__name__', 'call')}")
        self._process.start()
        child.close()

    def result(self):
        """The call's value (waits); its error raised again here."""
        if self._done is None:
            self._done = child_answer(self._conn, self._process,
                                      f"the process {self._process.name}")
        kind, value = self._done
        if kind == "error":
            raise value
        return value

    def cancel(self) -> None:
        """Stop the call (a later step failed)."""
        if self._process is not None and self._process.is_alive():
            self._process.terminate()
            self._process.join()
