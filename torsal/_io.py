"""Atomic file output for the top-level modules; see :mod:`torsal.geometry._atomic`.

The implementation lives in the leaf module :mod:`torsal.geometry._atomic` so that every
room (geometry, light, fabrication) can use the same helper; this module re-exports it.
"""
from torsal.geometry._atomic import atomic_path, write_json

__all__ = ["atomic_path", "write_json"]
