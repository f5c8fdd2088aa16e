"""Kept so that ``torsal.geometry._atomic`` stays importable; the helper lives in :mod:`torsal.core.atomic`."""
from torsal.core.atomic import atomic_path, write_json

__all__ = ["atomic_path", "write_json"]
