"""Worker processes of the assembly check: its pair and path jobs mapped over forked processes.

Each forked worker inherits the :class:`~.checker.AssemblyChecker` that started it (nothing is
pickled: OpenCascade shapes do not pickle) through the pool's initializer, and keeps it for
the pool's life; the process that runs the check keeps nothing once the pool is closed.

Example
-------
>>> class Twice:
...     def double(self, x):
...         return 2 * x
>>> map_jobs(Twice(), "double", [1, 2, 3], workers=1)
[2, 4, 6]
"""
from __future__ import annotations

import multiprocessing
from typing import Callable

from torsal.core.parallel import usable_workers

__all__ = ["map_jobs"]

#: the checker a forked worker inherited (set by :func:`_adopt` in the worker only)
_ADOPTED = None


def _adopt(checker) -> None:
    """Pool initializer: keep the inherited checker in this worker process."""
    global _ADOPTED
    _ADOPTED = checker


def _run(job):
    method, arg = job
    return getattr(_ADOPTED, method)(arg)


def map_jobs(owner, method: str, jobs: list, *, workers: int,
             progress: Callable[[str, int, int], None] | None = None, what: str = "") -> list:
    """``[owner.<method>(job) for job in jobs]`` in order, over forked processes when
    ``workers > 1`` and there are enough jobs (each worker inherits ``owner``)."""
    out = []
    workers = usable_workers(workers)
    if workers <= 1 or len(jobs) < 8 or "fork" not in multiprocessing.get_all_start_methods():
        fn = getattr(owner, method)
        for n, job in enumerate(jobs):
            out.append(fn(job))
            if progress:
                progress(what, n + 1, len(jobs))
        return out
    ctx = multiprocessing.get_context("fork")
    with ctx.Pool(workers, initializer=_adopt, initargs=(owner,)) as pool:
        tasks = [(method, job) for job in jobs]
        for n, r in enumerate(pool.imap(_run, tasks, chunksize=max(1, len(jobs) // (8 * workers)))):
            out.append(r)
            if progress:
                progress(what, n + 1, len(jobs))
    return out
