"""Results of the pure joint kernels remembered across the rebuilds of one fin system.

:meth:`~torsal.fabrication.parts.FinSystem._build_until_trimmed` rebuilds the whole structure
a few times; most butt trims, bracket corners, connectors and sheet fits come out the same,
so they are looked up by the bytes of their arguments (:class:`Memo`).

Example
-------
>>> memo = Memo()
>>> memo(max, 2, 3), len(memo.table)
(3, 1)
"""
from __future__ import annotations

import copy

import numpy as np

from ..joints import _Untrimmable


def _memo_key(x):
    """A hashable key of nested arrays, sequences, dicts and scalars (arrays by their bytes)."""
    if isinstance(x, np.ndarray):
        return ("a", x.shape, x.dtype.str, x.tobytes())
    if isinstance(x, (list, tuple)):
        return (type(x).__name__, tuple(_memo_key(y) for y in x))
    if isinstance(x, dict):
        return ("d", tuple(sorted((k, _memo_key(v)) for k, v in x.items())))
    return x


class Memo:
    """``memo(fn, *args, **kw)``: ``fn(*args, **kw)`` of a pure joint kernel, remembered by
    ``fn``'s name and the bytes of its arguments: the same result (a copy), or the same
    :class:`~torsal.fabrication.joints._Untrimmable` raised again."""

    def __init__(self):
        self.table: dict = {}

    def __call__(self, fn, *args, **kw):
        key = (fn.__name__, _memo_key(args), _memo_key(kw))
        hit = self.table.get(key)
        if hit is None:
            try:
                hit = (True, fn(*args, **kw))
            except _Untrimmable as why:
                hit = (False, str(why))
            self.table[key] = hit
        ok, value = hit
        if not ok:
            raise _Untrimmable(value)
        return copy.deepcopy(value)
