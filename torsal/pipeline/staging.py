"""Result files of a run (``torsal design``, ``torsal analyze``) appear together or not at all.

A run writes into a staging folder inside the output folder (``OUT/.torsal-staging``) and
moves the files into ``OUT`` only when every stage succeeded (earlier results the run did not
produce again are dropped, :meth:`Staging.keep_only`); ``OUT/.torsal-results.json`` then
lists them, per kind of run. The previous run's results (the files that list names) are moved into the
staging folder at the start, so stages whose cached result refers to them still find them.

If the run fails, the staging folder is removed with everything in it, the earlier run's
results included: afterwards ``OUT`` holds no result file that could be mistaken for the
failed run's. The stage cache (``OUT/.torsal-cache``) stays, so the next run resumes.
:meth:`Staging.failure_note` says what was left.

Examples
--------
>>> import tempfile, pathlib
>>> out = pathlib.Path(tempfile.mkdtemp())
>>> with Staging(out, kind="design") as st:
...     _ = (st.folder / "report.json").write_text("{}")
>>> sorted(p.name for p in out.iterdir())
['.torsal-results.json', 'report.json']
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
    """Context manager: a fresh staging folder for a run's results, swapped in on success.

    Parameters
    ----------
    out : Path
        The output folder (exists, writable).
    kind : str
        Which command's results (``"design"``, ``"analyze"``): a run replaces the earlier
        results of its own kind only; the results list keeps one entry per kind.
    """

    def __init__(self, out: Path, kind: str = "design"):
        self.out = Path(out)
        self.kind = kind
        self.folder = self.out / STAGING_FOLDER
        self.earlier: list[str] = []   # top-level names of the previous run's results
        self.removed: list[str] = []   # set on failure: what of them is gone
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
        for name in self.earlier:
            os.replace(self.out / name, self.folder / name)
        runs = self._runs()
        runs.pop(self.kind, None)
        self._write_runs(runs)
        return self

    def keep_only(self, files) -> None:
        """Name this run's result files (relative paths, nested lists/dicts allowed): on success,
        earlier results not among them are removed instead of published again."""
        self.keep = {Path(p).parts[0] for p in _flat(files)}

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is None:
            self._publish()
        else:
            self.removed = list(self.earlier)
            shutil.rmtree(self.folder, ignore_errors=True)
        return False

    def _publish(self) -> None:
        if self.keep is not None:
            for name in self.earlier:
                stale = self.folder / name
                if name not in self.keep and stale.exists():
                    shutil.rmtree(stale) if stale.is_dir() else stale.unlink()
        names = sorted(p.name for p in self.folder.iterdir())
        for name in names:
            target = self.out / name
            if target.is_dir() and not target.is_symlink():
                shutil.rmtree(target)
            os.replace(self.folder / name, target)
        self.folder.rmdir()
        runs = self._runs()
        for other in runs.values():  # a file this run wrote again is this run's now
            other["files"] = [n for n in other.get("files", []) if Path(n).parts[0] not in names]
        runs[self.kind] = {"files": names, "finished": _dt.datetime.now(
            _dt.timezone.utc).isoformat(timespec="seconds")}
        self._write_runs(runs)

    def failure_note(self) -> str:
        """What a failed run left in the output folder, for the error message."""
        earlier = (f"the earlier {self.kind} results ({', '.join(self.removed[:6])}"
                   f"{' ...' if len(self.removed) > 6 else ''}) were removed so they cannot be "
                   "taken for this run's; " if self.removed else "")
        cache = self.out / ".torsal-cache"
        kept = (f"the stage cache ({cache}) is kept, so the next run resumes" if cache.exists()
                else "nothing else was changed")
        return f"{self.out} holds no results of this run: {earlier}{kept}"
