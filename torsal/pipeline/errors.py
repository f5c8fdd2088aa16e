"""The pipeline's error and progress protocol."""
from __future__ import annotations

from typing import Callable

from torsal.core.errors import TorsalError

__all__ = ["DesignError", "Progress", "quiet"]

#: ``progress(stage, event, info)``: event is "start", "iteration", "done" or "cached"; long
#: stages without iterations send "progress" with ``{"phase", "done", "total"}``.
Progress = Callable[[str, str, dict], None]


class DesignError(TorsalError, RuntimeError):
    """A pipeline stage failed; ``stage`` names it and the message says why.

    When a design-file value is the cause, ``key`` names it (``"sun.vectors"``) and ``value``
    holds it; both appear in the message.
    """

    def __init__(self, stage: str, message: str, *, key: str | None = None, value=None):
        where = f"{key} = {value!r}: " if key is not None else ""
        super().__init__(f"stage '{stage}' failed: {where}{message}")
        self.stage = stage
        self.key = key
        self.value = value


def quiet(stage: str, event: str, info: dict) -> None:
    """The default progress callback: library calls stay silent."""
