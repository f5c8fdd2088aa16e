"""Result files of a run (``torsal design``, ``torsal analyze``) are swapped in together, only
when the run succeeds; a failed run leaves the output folder as it found it.

A run writes into a staging folder inside the output folder (``OUT/.torsal-staging``). At the
start, the previous run's results (of the same kind, as ``OUT/.torsal-results.json`` lists
them) are *copied* into it, so stages whose cached result refers to a file still find it; the
originals in ``OUT`` are not touched. When every stage succeeded, :meth:`Staging._publish`
moves the staged files over the old ones, removes earlier results the run did not produce
again (:meth:`Staging.keep_only`) and updates the results list.

If the run fails (or is killed), only the staging folder is removed: every earlier result in
``OUT`` - and the results list that says which run wrote it - is as it was. The stage cache
(``OUT/.torsal-cache``) keeps what the failed run computed, so the next run resumes.
:meth:`Staging.failure_note` says so, naming the earlier results and when they were made, so
they are not taken for the failed run's.

Examples
--------
>>> import tempfile, pathlib
>>> out = pathlib.Path(tempfile.mkdtemp())
>>> with Staging(out, kind="design") as st:
...     _ = (st.folder / "report.json").write_text("{}")
>>> sorted(p.name for p in out.iterdir())
['.torsal-results.json', 'report.json']
>>> try:
...     with Staging(out, kind="design") as st:
...         _ = (st.folder / "report.json").write_text("half")
...         raise ValueError("stage failed")
... except ValueError:
...     pass
>>> (out / "report.json").read_text(), sorted(p.name for p in out.iterdir())
('{}', ['.torsal-results.json', 'report.json'])
"""
from __future__ import annotations

import datetime as _dt
import json
import os
import shutil
from pathlib import Path

from ..core.atomic import write_json
from .stage import _flat  # the file paths in a stage's nested "files"

__all__ = ["Staging", "RESULTS_LIST", "STAGING_FOLDER"]

STAGING_FOLDER = ".torsal-staging"
RESULTS_LIST = ".torsal-results.json"
# results of runs from before the list existed: these names are torsal's own
_KNOWN_RESULTS = {
    "design": ("report.json", "report.html", "parts.csv", "fins.step", "fins.3dm",
               "congruence.ply", "support.obj", "substructure.obj", "sheets"),
    "analyze": ("analysis.json", "torsal_field.png"),
}
_MARKER = {"design": "report.json", "analyze": "analysis.json"}


class Staging:
    """Context manager: a staging folder for a run's results, swapped in on success only.

    Parameters
    ----------
    out : Path
        The output folder (exists, writable).
    kind : str
        Which command's results (``"design"``, ``"analyze"``): a run replaces the earlier
        results of its own kind only; the results list keeps one entry per kind.

    Attributes
    ----------
    folder : Path
        Where the run writes (``out / ".torsal-staging"``).
    earlier : list of str
        Top-level names of the previous run's results (copied into ``folder`` at the start).
    earlier_finished : str or None
        When that run finished (ISO time, from the results list).
    """

    def __init__(self, out: Path, kind: str = "design"):
        self.out = Path(out)
        self.kind = kind
        self.folder = self.out / STAGING_FOLDER
        self.earlier: list[str] = []
        self.earlier_finished: str | None = None
        self.failed = False
        self.keep: set[str] | None = None

    def _runs(self) -> dict:
        """The results list: ``{kind: {"files": [...], "finished": iso time}}``."""
        try:
            runs = json.loads((self.out / RESULTS_LIST).read_text()).get("runs", {})
            return runs if isinstance(runs, dict) else {}
        except (ValueError, AttributeError, OSError):
            return {}

    def _write_runs(self, runs: dict) -> None:
        if runs:
            write_json(self.out / RESULTS_LIST, {"runs": runs})
        else:
            (self.out / RESULTS_LIST).unlink(missing_ok=True)

    def _previous_results(self) -> list[str]:
        runs = self._runs()
        if self.kind in runs:
            names = [str(n) for n in runs[self.kind].get("files", [])]
            self.earlier_finished = runs[self.kind].get("finished")
        elif not (self.out / RESULTS_LIST).exists() and (self.out / _MARKER.get(self.kind, "-")).exists():
            names = list(_KNOWN_RESULTS.get(self.kind, ()))
        else:
            names = []
        # top-level entries only, never outside OUT, never our own bookkeeping
        top = {Path(n).parts[0] for n in names if n and not Path(n).is_absolute()
               and ".." not in Path(n).parts}
        return sorted(n for n in top if n not in (STAGING_FOLDER, RESULTS_LIST, ".torsal-cache")
                      and (self.out / n).exists())

    def __enter__(self) -> "Staging":
        if self.folder.exists():  # left by a run that was killed
            shutil.rmtree(self.folder)
        self.folder.mkdir()
        self.earlier = self._previous_results()
        # copies, not moves: a failure anywhere from here on leaves OUT as it was (a stage that
        # writes a file in place cannot change the earlier result either)
        for name in self.earlier:
            src = self.out / name
            if src.is_dir() and not src.is_symlink():
                shutil.copytree(src, self.folder / name, symlinks=True)
            else:
                shutil.copy2(src, self.folder / name, follow_symlinks=False)
        return self

    def keep_only(self, files) -> None:
        """Name this run's result files (relative paths, nested lists/dicts allowed): on success,
        earlier results not among them are removed instead of published again."""
        self.keep = {Path(p).parts[0] for p in _flat(files)}

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is None:
            self._publish()
        else:
            self.failed = True
            shutil.rmtree(self.folder, ignore_errors=True)
        return False

    def _publish(self) -> None:
        if self.keep is not None:
            for name in self.earlier:
                stale = self.folder / name
                if name not in self.keep and stale.exists():
                    shutil.rmtree(stale) if stale.is_dir() and not stale.is_symlink() else stale.unlink()
        names = sorted(p.name for p in self.folder.iterdir())
        for name in names:
            target = self.out / name
            if target.is_dir() and not target.is_symlink():
                shutil.rmtree(target)
            os.replace(self.folder / name, target)
        self.folder.rmdir()
        for name in self.earlier:  # earlier results this run did not write again
            stale = self.out / name
            if name not in names and (stale.exists() or stale.is_symlink()):
                shutil.rmtree(stale) if stale.is_dir() and not stale.is_symlink() else stale.unlink()
        runs = self._runs()
        for other in runs.values():  # a file this run wrote again is this run's now
            other["files"] = [n for n in other.get("files", []) if Path(n).parts[0] not in names]
        runs[self.kind] = {"files": names, "finished": _dt.datetime.now(
            _dt.timezone.utc).isoformat(timespec="seconds")}
        self._write_runs(runs)

    def failure_note(self) -> str:
        """What a failed run left in the output folder, for the error message."""
        if self.earlier:
            shown = ", ".join(self.earlier[:6]) + (" ..." if len(self.earlier) > 6 else "")
            when = f" finished {self.earlier_finished}" if self.earlier_finished else ""
            earlier = (f"the earlier {self.kind} results ({shown}) are left as they were: they are "
                       f"from the run{when}, not this one; ")
        else:
            earlier = ""
        cache = self.out / ".torsal-cache"
        kept = (f"the stage cache ({cache}) keeps what this run computed, so the next run "
                "resumes" if cache.exists() else "nothing else was changed")
        return f"{self.out} holds no results of this run: {earlier}{kept}"
