"""Output folders: checked and created before any work, with errors that name the path.

Examples
--------
>>> import tempfile, pathlib
>>> base = pathlib.Path(tempfile.mkdtemp())
>>> output_folder(base / "out").is_dir()
True
>>> (base / "a-file").write_text("x")
1
>>> output_folder(base / "a-file" / "out")
Traceback (most recent call last):
...
torsal.core.outputs.OutputFolderError: ... is a file, so there can be no folder under it; give another path
"""
from __future__ import annotations

import contextlib
import os
from pathlib import Path

from .errors import TorsalError

__all__ = ["OutputFolderError", "output_folder", "new_output_folder"]


class OutputFolderError(TorsalError, ValueError):
    """An output folder that cannot be used: empty path, a file, under a file, not writable."""


def output_folder(path: str | Path | None, *, option: str = "--out") -> Path:
    """Check that ``path`` can be an output folder, create it, and return it as a Path.

    An empty path, an existing file, a path under a file, or a folder that cannot be created or
    written raises :class:`OutputFolderError` naming the path (``option`` is how the user gave
    it). Writing is tried with a probe file, removed at once: permission bits alone do not tell
    (root, read-only mounts).
    """
    if path is None or not str(path).strip():
        raise OutputFolderError(f"{option}: the path is empty; give an output folder, "
                                f"e.g. {option} out/")
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise OutputFolderError(f"{option} {p}: is a file, not a folder; give a folder path")
    for parent in p.parents:
        if parent.exists():
            if not parent.is_dir():
                raise OutputFolderError(f"{option} {p}: {parent} is a file, so there can be no "
                                        "folder under it; give another path")
            break
    try:
        p.mkdir(parents=True, exist_ok=True)
        probe = p / f".torsal-write-test-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise OutputFolderError(f"{option} {p}: cannot write there ({exc.strerror or exc}); "
                                "give a folder you can write to") from None
    return p


@contextlib.contextmanager
def new_output_folder(path: str | Path | None, *, option: str = "--out"):
    """:func:`output_folder` for one run: yields the folder; if the run fails and the folder
    did not exist before, it is removed again when it is still empty (a failed run leaves the
    file system as it found it).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> target = pathlib.Path(tempfile.mkdtemp()) / "out"
    >>> try:
    ...     with new_output_folder(target) as out:
    ...         raise ValueError("the run failed")
    ... except ValueError:
    ...     pass
    >>> target.exists()
    False
    """
    existed = path is not None and str(path).strip() != "" and Path(path).exists()
    out = output_folder(path, option=option)
    try:
        yield out
    except BaseException:
        if not existed:
            try:
                out.rmdir()  # only when empty: a stage cache or anything else stays
            except OSError:
                pass
        raise
