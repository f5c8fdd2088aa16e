"""The pipeline's error and progress protocol."""
from __future__ import annotations

from typing import Callable

from torsal.core.errors import TorsalError

__all__ = ["DesignError", "Progress", "quiet"]

#: ``progress(stage, event, info)``: event is "start", "iteration", "done" or "cached"; long
#: stages without iterations send "progress" with ``{"phase", "done", "total"}``.
Progress = Callable[[str, str, dict], None]


class DesignError(TorsalError, RuntimeError):
    """A pipeline stage failed; ``stage`` names it and the message says why."""

    def __init__(self, stage: str, message: str):
        super().__init__(f"stage '{stage}' failed: {message}")
        self.stage = stage


def quiet(stage: str, event: str, info: dict) -> None:
    """The default progress callback: library calls stay silent."""
