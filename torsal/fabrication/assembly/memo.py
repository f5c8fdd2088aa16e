"""What the assembly check proved, kept by the content of the solids it proved it for.

A touching pair's verdict depends on its two solids alone, a path into place on the moving
solid, its direction and travel, and the solids near the path. :class:`AssemblyMemo` keeps
both under digests of those solids (:func:`solid_digest`: the solid's vertices, rounded far
below the check's tolerance, and its face count), so a study's variants and a design's
re-runs skip every pair and path whose parts did not change. The check counts the hits
(:attr:`~.result.AssemblyCheck.memo_hits`).

A memo is a plain object: pickle it to keep it between processes (the pipeline keeps it in the
design's cache, :mod:`torsal.pipeline.memo`).

>>> memo = AssemblyMemo()
>>> memo.pair(("a", "b", 1.0, 1.0)) is None
True
"""
from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np

from .occ import _vertices

__all__ = ["AssemblyMemo", "solid_digest", "DIGEST_DECIMALS"]

#: vertices are compared to this many decimals of the unit (mm: 1e-6 mm)
DIGEST_DECIMALS = 6


def solid_digest(shape, vertices: np.ndarray | None = None) -> str:
    """A hash (24 hex digits) of an OCC solid's vertex coordinates (rounded to
    :data:`DIGEST_DECIMALS` decimals, in the explorer's order; ``vertices`` (k, 3) if known)
    and its face count: the same solid read again, or built again from the same part, gets
    the same digest."""
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer

    v = _vertices(shape) if vertices is None else vertices
    v = np.round(np.asarray(v, float).reshape(-1, 3), DIGEST_DECIMALS) + 0.0
    faces, ex = 0, TopExp_Explorer(shape, TopAbs_FACE)
    while ex.More():
        faces += 1
        ex.Next()
    h = hashlib.sha256(np.ascontiguousarray(v).tobytes())
    h.update(str(faces).encode())
    return h.hexdigest()[:24]


@dataclass
class AssemblyMemo:
    """Verdicts of touching pairs and of paths into place, by solid digests.

    ``pairs``: ``(digest, digest, tolerance, min_volume) -> (distance, volume, error)`` with
    the digests in sorted order; ``paths``: ``(digest, vector, others' digests, min_volume) ->
    [swept overlap with each other]``. ``limit`` bounds each (the oldest entries go first).
    """

    pairs: dict = field(default_factory=dict)
    paths: dict = field(default_factory=dict)
    limit: int = 200_000

    def pair(self, key):
        return self.pairs.get(key)

    def path(self, key):
        return self.paths.get(key)

    def keep_pair(self, key, value) -> None:
        self._keep(self.pairs, key, value)

    def keep_path(self, key, value) -> None:
        self._keep(self.paths, key, value)

    def _keep(self, table: dict, key, value) -> None:
        table.pop(key, None)
        table[key] = value                 # newest last: dicts keep insertion order
        while len(table) > self.limit:
            table.pop(next(iter(table)))
