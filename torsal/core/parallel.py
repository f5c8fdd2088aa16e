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

__all__ = ["usable_workers", "limit_workers", "portable_error"]

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
