"""Process parallelism that knows where it runs.

A daemonic process (a Dask or multiprocessing worker running a design study's variant) may not
start children of its own; there the work runs serially, in the worker that was already given
one core by the study's scheduler.

Examples
--------
>>> usable_workers(4) >= 1
True
"""
from __future__ import annotations

import multiprocessing

__all__ = ["usable_workers"]


def usable_workers(requested: int) -> int:
    """``requested`` worker processes, or 1 inside a daemonic process (which cannot fork children)."""
    if multiprocessing.current_process().daemon:
        return 1
    return max(1, int(requested))
