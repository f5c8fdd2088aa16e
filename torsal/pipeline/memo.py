"""Results kept by the content of what they were computed from, beside the stage cache.

A stage's cache key comes from the design file alone (:mod:`.cache`), so a stage whose input
changed is run again in full. Some of its work depends on less than that: the final cut's
sheets on the flat parts only, the assembly check's verdict on a pair of parts on those two
solids only. A :class:`Memo` keeps such results under a hash of their actual inputs, in
``<cache folder>/memo/``: a design re-run with a changed light setting, a study variant whose
parts did not change, or a final cut asked for again, finds them there.

Entries are pickles written atomically; unreadable ones are recomputed. ``keep`` bounds the
entries per name (the oldest go first).

>>> memo = Memo(tmp_path)                                        # doctest: +SKIP
>>> memo.get("sheets", content_key(parts, options), lambda: nest(parts))  # doctest: +SKIP
"""
from __future__ import annotations

import hashlib
import pickle
from pathlib import Path
from typing import Callable

from .._version import __version__
from .cache import CACHE_VERSION, MISSING, read_pickle, write_pickle

__all__ = ["Memo", "content_key"]


def content_key(*parts) -> str:
    """A hash (32 hex digits) of ``parts`` by their pickled bytes: the same values give the
    same key in every process (pickles of numpy arrays, shapely geometry, dataclasses and
    dicts in insertion order are byte-stable for the same values)."""
    h = hashlib.sha256(f"{CACHE_VERSION}|{__version__}|".encode())
    for p in parts:
        h.update(pickle.dumps(p, protocol=4))
        h.update(b"|")
    return h.hexdigest()[:32]


class Memo:
    """Content-keyed results in ``folder`` (see the module docstring).

    Parameters
    ----------
    folder : path
        Created on first store.
    enabled : bool
        False: :meth:`get` computes every time (and still stores).
    keep : int
        Entries kept per name.
    """

    def __init__(self, folder: str | Path, *, enabled: bool = True, keep: int = 64):
        self.folder, self.enabled, self.keep = Path(folder), enabled, keep
        self.hits = self.misses = 0

    def _path(self, name: str, key: str) -> Path:
        return self.folder / f"{name}-{key}.pkl"

    def load(self, name: str, key: str):
        """The stored value, or None."""
        value = read_pickle(self._path(name, key)) if self.enabled else MISSING
        return None if value is MISSING else value

    def store(self, name: str, key: str, value) -> None:
        write_pickle(self._path(name, key), value, protocol=4)
        old = sorted(self.folder.glob(f"{name}-*.pkl"), key=lambda p: p.stat().st_mtime_ns)
        for p in old[:max(0, len(old) - self.keep)]:
            p.unlink(missing_ok=True)

    def get(self, name: str, key: str, make: Callable[[], object]):
        """The value stored under ``(name, key)``, else ``make()`` stored there."""
        value = self.load(name, key)
        if value is not None:
            self.hits += 1
            return value
        self.misses += 1
        value = make()
        self.store(name, key, value)
        return value
