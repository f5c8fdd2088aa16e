"""``torsal.show``: a design run's fins in the OCP CAD viewer.

The viewer is the one build123d users know: VS Code's "OCP CAD Viewer" extension, or the
standalone viewer in a browser (``python -m ocp_viewer``, then open http://127.0.0.1:3939/viewer).
Both come with ``pip install 'torsal[viewer]'``. The parts are shown in groups, each a
node of the viewer's tree that switches on and off: torsal family 0 (blue), family 1 (orange),
connectors (grey) and the parts the assembly check found interfering or blocked (red).
"""
from __future__ import annotations

import socket
from dataclasses import dataclass, field
from pathlib import Path

from ..core.errors import TorsalError
from ..fabrication.solids import read_step
from .results import GROUP_COLORS, FinsFolder, PartGroup, fins_folder, read_parts

__all__ = ["show", "fins_scene", "FinsScene", "ViewerUnavailableError", "DEFAULT_PORT"]

#: the OCP CAD viewer's port unless configured otherwise
DEFAULT_PORT = 3939

_INSTALL = ("install it with  pip install 'torsal[viewer]'  (ocp_vscode and ocp_viewer), start "
            "the standalone viewer with  python -m ocp_viewer  and open "
            "http://127.0.0.1:3939/viewer, or open VS Code's OCP CAD Viewer")


class ViewerUnavailableError(TorsalError, RuntimeError):
    """The OCP CAD viewer is not installed or not running; the message says how to get it."""


@dataclass
class FinsScene:
    """A run's parts by :class:`~torsal.hosts.results.PartGroup`: ``groups`` maps each group
    that has parts to their names, ``solids`` each name to its OpenCascade solid (mm)."""

    folder: Path
    groups: dict[PartGroup, list[str]]
    solids: dict = field(repr=False, default_factory=dict)

    @property
    def counts(self) -> dict[str, int]:
        """Parts per group, e.g. ``{"family 0": 61, "family 1": 58, "connector": 58}``."""
        return {g.value: len(n) for g, n in self.groups.items()}


def _group_of(name: str, rows: dict, bad: set[str]) -> PartGroup:
    if name in bad:
        return PartGroup.interfering
    if name in rows:
        return PartGroup(rows[name].group)
    # no parts list: torsal's part names say it (F0-..., F1-..., C-N...)
    if name.startswith("C-"):
        return PartGroup.connector
    return PartGroup.family_1 if name.startswith("F1") else PartGroup.family_0


def fins_scene(result_or_folder) -> FinsScene:
    """Read a run's ``fins.step`` (OCP's XCAF reader) and group its parts by family,
    connectors and interference (from ``parts.csv`` and ``report.json``)."""
    run: FinsFolder = fins_folder(result_or_folder)
    rows = {p.name: p for p in read_parts(run.folder)}
    bad = run.interfering
    groups: dict[PartGroup, list[str]] = {}
    solids = {}
    for name, solid in read_step(run.step):
        solids[name] = solid
        groups.setdefault(_group_of(name, rows, bad), []).append(name)
    order = list(PartGroup)
    return FinsScene(run.folder, dict(sorted(groups.items(), key=lambda kv: order.index(kv[0]))),
                     solids)


def _listening(host: str, port: int) -> bool:
    try:
        with socket.create_connection((host, port), timeout=1.0):
            return True
    except OSError:
        return False


def show(result_or_folder, *, port: int | None = None, **viewer_options) -> FinsScene:
    """Show a design run's fins in the OCP CAD viewer, grouped and coloured by torsal family,
    connectors and interfering parts (red).

    Parameters
    ----------
    result_or_folder : DesignResult, path
        What :meth:`torsal.Design.run` returned, its output folder, or a ``fins.step``.
    port : int, optional
        The viewer's port (default: ocp_vscode's, 3939).
    **viewer_options
        Passed to ``ocp_vscode.show`` (e.g. ``reset_camera``, ``black_edges``).

    Returns the :class:`FinsScene` shown.

    Raises :class:`ViewerUnavailableError` when the viewer is not installed or no viewer is
    listening (the message says how to start one), :class:`~torsal.hosts.results.FinsFolderError`
    when there is no ``fins.step``.

    >>> import torsal
    >>> torsal.show("out/7a")   # doctest: +SKIP
    FinsScene(folder=PosixPath('out/7a'), groups={...})
    """
    run = fins_folder(result_or_folder)      # a bad folder is named before anything else
    try:
        import ocp_vscode
    except ImportError:
        raise ViewerUnavailableError(f"the OCP CAD viewer is not installed: {_INSTALL}") from None
    port = port or ocp_vscode.get_port() or DEFAULT_PORT
    host = ocp_vscode.get_host() or "127.0.0.1"
    if not _listening(host, port):
        raise ViewerUnavailableError(f"no OCP CAD viewer is listening on {host}:{port}: start one "
                                     f"with  python -m ocp_viewer --port {port}  (or VS Code's "
                                     "OCP CAD Viewer), then call show again")
    # (build123d, a dependency of torsal, only once a viewer listens: its import takes seconds)
    from build123d import Compound, Solid

    scene = fins_scene(run.folder if run.step.name == "fins.step" else run.step)
    nodes = [Compound(children=[Solid(scene.solids[n]) for n in names], label=group.value)
             for group, names in scene.groups.items()]
    for node, names in zip(nodes, scene.groups.values()):
        for child, name in zip(node.children, names):
            child.label = name
    viewer_options.setdefault("progress", "")   # library calls stay quiet
    ocp_vscode.show(*nodes, names=[g.value for g in scene.groups],
                    colors=[GROUP_COLORS[g] for g in scene.groups], port=port, **viewer_options)
    return scene
