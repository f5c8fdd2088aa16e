"""Reading an input file the user named, with errors that name the file and what to do.

A missing file raises :class:`MissingInputError` (also a ``FileNotFoundError``); a folder, a
file without read permission or another OS refusal raises :class:`InputFileError`. Both are
:class:`~torsal.core.errors.TorsalError`, so the command line reports them as bad input.

Examples
--------
>>> read_input("no/such/file.obj", "mesh file")
Traceback (most recent call last):
...
torsal.core.inputs.MissingInputError: mesh file not found: no/such/file.obj
"""
from __future__ import annotations

from pathlib import Path

from .errors import TorsalError

__all__ = ["InputFileError", "MissingInputError", "read_input", "check_input"]


class InputFileError(TorsalError, OSError):
    """An input file that exists but cannot be read (a folder, no permission, ...)."""


class MissingInputError(InputFileError, FileNotFoundError):
    """An input file that does not exist."""


def check_input(path: str | Path, what: str) -> Path:
    """Return ``path`` as a Path if it names a readable file; raise naming ``what`` otherwise."""
    p = Path(path)
    if str(path) == "":
        raise MissingInputError(f"{what}: the path is empty")
    if not p.exists():
        raise MissingInputError(f"{what} not found: {p}")
    if p.is_dir():
        raise InputFileError(f"{what} {p} is a folder, not a file")
    return p


def read_input(path: str | Path, what: str, *, text: bool = False) -> bytes | str:
    """The bytes (or UTF-8 text, undecodable bytes replaced) of an input file.

    Parameters
    ----------
    path : str or Path
    what : str
        What the file is, for messages: ``"mesh file"``, ``"design file"``.
    text : bool
        Decode as UTF-8 (undecodable bytes replaced, a leading byte-order mark dropped).
    """
    p = check_input(path, what)
    try:
        data = p.read_bytes()
    except PermissionError:
        raise InputFileError(f"{what} {p} cannot be read (permission denied); "
                             "check its permissions") from None
    except OSError as exc:
        raise InputFileError(f"{what} {p} cannot be read ({exc.strerror or exc})") from None
    if not text:
        return data
    # a byte-order mark (Windows editors) is not part of the text
    return data.decode("utf-8", errors="replace").removeprefix("\ufeff")
