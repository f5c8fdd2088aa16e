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

from pathlib import Path

__all__ = ["TorsalError", "raised_in_torsal"]

_PACKAGE = Path(__file__).resolve().parents[1]


class TorsalError(Exception):
    """A problem torsal can name: the message says what is wrong and what to do."""


def raised_in_torsal(exc: BaseException) -> bool:
    """True if the innermost frame of ``exc`` is torsal's own code: a ``ValueError`` torsal
    raises is a check of a value it was given (the input); one raised inside numpy or scipy
    is a bug.

    >>> try:
    ...     raise ValueError("x")
    ... except ValueError as exc:
    ...     raised_in_torsal(exc)
    False
    """
    tb, last = exc.__traceback__, None
    while tb is not None:
        last, tb = tb, tb.tb_next
    if last is None:
        return False
    return Path(last.tb_frame.f_code.co_filename).resolve().is_relative_to(_PACKAGE)
