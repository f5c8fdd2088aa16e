"""Worker processes of the assembly check: its pair and path jobs mapped over forked processes.

Each forked worker inherits the :class:`~.checker.AssemblyChecker` that started it (nothing is
pickled: OpenCascade shapes do not pickle) through the pool's initializer, and keeps it for
the pool's life; the process that runs the check keeps nothing once the pool is closed.
:class:`JobPool` keeps one pool for several maps (the check's pairs, then its paths, try after
try): what a worker made for one map (a solid's face records, cover and triangles) serves the
next, where a pool per map forked fresh workers that made it all again. The workers are forked
at the first map with enough jobs to pay for them (a check whose pairs and paths all come
from its memo forks none).

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

__all__ = ["map_jobs", "JobPool"]

#: the checker a forked worker inherited (set by :func:`_adopt` in the worker only)
_ADOPTED = None


def _adopt(checker) -> None:
    """Pool initializer: keep the inherited checker in this worker process."""
    global _ADOPTED
    _ADOPTED = checker


def _run(job):
    method, arg = job
    return getattr(_ADOPTED, method)(arg)


#: fewer jobs than this run in the calling process (forking costs more than they do)
MIN_FORKED_JOBS = 8


def _serial(owner, method: str, jobs: list, progress, what: str) -> list:
    out = []
    fn = getattr(owner, method)
    for n, job in enumerate(jobs):
        out.append(fn(job))
        if progress:
            progress(what, n + 1, len(jobs))
    return out


def _imap(pool, workers: int, method: str, jobs: list, progress, what: str) -> list:
    out = []
    tasks = [(method, job) for job in jobs]
    for n, r in enumerate(pool.imap(_run, tasks, chunksize=max(1, len(jobs) // (8 * workers)))):
        out.append(r)
        if progress:
            progress(what, n + 1, len(jobs))
    return out


def _forks(workers: int) -> int:
    """Worker processes to fork: ``workers`` as far as this process may (0: run here)."""
    workers = usable_workers(workers)
    return workers if workers > 1 and "fork" in multiprocessing.get_all_start_methods() else 0


def map_jobs(owner, method: str, jobs: list, *, workers: int,
             progress: Callable[[str, int, int], None] | None = None, what: str = "") -> list:
    """``[owner.<method>(job) for job in jobs]`` in order, over forked processes when
    ``workers > 1`` and there are enough jobs (each worker inherits ``owner``)."""
    with JobPool(owner, workers=workers if len(jobs) >= MIN_FORKED_JOBS else 1) as pool:
        return pool.map(method, jobs, progress=progress, what=what)


class JobPool:
    """Forked worker processes that inherit ``owner`` (as it is when the pool opens: set what
    the jobs read first) and run several maps of its methods, keeping what they made between
    them; with one worker (or where this process may not fork) the jobs run here. A context
    manager: the processes end when it closes.

    >>> class Twice:
    ...     def double(self, x):
    ...         return 2 * x
    >>> with JobPool(Twice(), workers=1) as pool:
    ...     pool.map("double", [1, 2]), pool.map("double", [3])
    ([2, 4], [6])
    """

    def __init__(self, owner, *, workers: int):
        self.owner, self.workers = owner, _forks(workers)
        self._pool = None

    def __enter__(self) -> "JobPool":
        return self

    def _forked(self):
        """The worker processes, forked at the first map that needs them (a check whose
        pairs and paths all come from its memo forks none)."""
        if self._pool is None:
            ctx = multiprocessing.get_context("fork")
            self._pool = ctx.Pool(self.workers, initializer=_adopt, initargs=(self.owner,))
        return self._pool

    def __exit__(self, *exc) -> None:
        if self._pool is not None:
            if exc[0] is None:           # every map has returned: the workers end of themselves
                self._pool.close()       # (and count their time, as a process killed does not)
            else:
                self._pool.terminate()   # as ``with Pool()`` does
            self._pool.join()
            self._pool = None

    def map(self, method: str, jobs: list, *,
            progress: Callable[[str, int, int], None] | None = None, what: str = "") -> list:
        """``[owner.<method>(job) for job in jobs]`` in order (few jobs: in this process)."""
        if not self.workers or len(jobs) < MIN_FORKED_JOBS:
            return _serial(self.owner, method, jobs, progress, what)
        return _imap(self._forked(), self.workers, method, jobs, progress, what)
