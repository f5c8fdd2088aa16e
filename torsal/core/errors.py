"""The base error class of torsal.

Every domain error (``MeshError``, ``DesignError``, ``OptimizationError`` ...) derives from
:class:`TorsalError`, so a caller (the CLI, a study) can tell "the input or the design is the
cause, here is what to change" from a bug, with one ``except TorsalError``.

Examples
--------
>>> issubclass(TorsalError, Exception)
True
"""
from __future__ import annotations

__all__ = ["TorsalError"]


class TorsalError(Exception):
    """A problem torsal can name: the message says what is wrong and what to do."""
