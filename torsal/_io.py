"""Atomic file output for the top-level modules; re-exports :mod:`torsal.core.atomic`."""
from torsal.core.atomic import atomic_path, write_json

__all__ = ["atomic_path", "write_json"]
