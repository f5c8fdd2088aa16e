"""A finished design run as the hosts show it: its folder, its parts and their groups.

The hosts (the FreeCAD object, the OCP viewer) read what :meth:`torsal.Design.run` wrote, as a
user's CAD would: ``fins.step`` (the solids, in the order of ``parts.csv``), ``parts.csv``
(names, families, kinds) and ``report.json`` (which parts interfere or cannot be inserted).
"""
from __future__ import annotations

import csv
import json
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

from ..core.errors import TorsalError

__all__ = ["PartGroup", "PartRow", "FinsFolder", "FinsFolderError", "fins_folder", "read_parts",
           "GROUP_COLORS"]


class PartGroup(str, Enum):
    """How a host colours a part: by torsal family, connectors apart, clashes in red."""

    family_0 = "family 0"
    family_1 = "family 1"
    connector = "connector"
    interfering = "interfering"


#: sRGB colour of each group (the report's family colours; interfering parts red)
GROUP_COLORS: dict[PartGroup, tuple[float, float, float]] = {
    PartGroup.family_0: (0.16, 0.45, 0.75),
    PartGroup.family_1: (0.95, 0.6, 0.1),
    PartGroup.connector: (0.55, 0.55, 0.55),
    PartGroup.interfering: (0.9, 0.05, 0.05),
}


@dataclass(frozen=True)
class PartRow:
    """One row of ``parts.csv``: the part's name (as in the STEP file), its torsal family
    (0 or 1, for connectors the family of the plate they fasten) and kind (plate, bracket,
    splice ...)."""

    name: str
    family: int
    kind: str

    @property
    def group(self) -> str:
        """The part's :class:`PartGroup` value, interference aside."""
        if self.kind != "plate":
            return PartGroup.connector.value
        return (PartGroup.family_1 if self.family == 1 else PartGroup.family_0).value


class FinsFolderError(TorsalError, ValueError):
    """Not a finished design run: the message names what is missing."""


@dataclass(frozen=True)
class FinsFolder:
    """A design run's output folder: ``step`` (fins.step), ``report`` (report.json's data,
    empty when there is none)."""

    folder: Path
    step: Path
    report: dict

    @property
    def interfering(self) -> set[str]:
        """Parts that interfere or cannot be inserted (the assembly check's verdict)."""
        a = self.report.get("fabrication", {}).get("assembly", {})
        return set(a.get("interfering_parts", [])) | set(a.get("blocked_parts", []))


def fins_folder(result_or_folder) -> FinsFolder:
    """Where a run's files are: a :class:`~torsal.pipeline.DesignResult` (its report names
    the folder only through its files, so give the folder for those), a folder holding
    ``fins.step``, or a ``.step`` file.

    Raises :class:`FinsFolderError` naming the missing file.

    >>> fins_folder("no/such/folder")
    Traceback (most recent call last):
    ...
    torsal.hosts.results.FinsFolderError: no/such/folder: no fins.step here; give the output folder of `torsal design` (or Design.run) or a .step file
    """
    target = getattr(result_or_folder, "folder", result_or_folder)
    path = Path(target)
    step = path if path.suffix.lower() in (".step", ".stp") else path / "fins.step"
    if not step.is_file():
        raise FinsFolderError(f"{target}: no fins.step here; give the output folder of `torsal "
                              "design` (or Design.run) or a .step file")
    report_path = step.parent / "report.json"
    report = json.loads(report_path.read_text()) if report_path.is_file() else {}
    return FinsFolder(folder=step.parent, step=step, report=report)


def read_parts(folder: str | Path) -> list[PartRow]:
    """The parts of a run in ``parts.csv`` order, which is the order of the solids in
    ``fins.step``; [] when the run wrote no parts list."""
    path = Path(folder) / "parts.csv"
    if not path.is_file():
        return []
    with open(path, newline="") as fh:
        return [PartRow(r["part_id"], int(r["family"]), r.get("kind") or "plate")
                for r in csv.DictReader(fh)]
