"""A design run as a plotly figure, for notebooks: the same 3D view as ``report.html``
(:func:`~torsal.pipeline.report_3d.design_view_figure`), rebuilt from the run's files, so it
works on any output folder (``congruence.ply``: mesh A; ``support.obj``: the fins by torsal
family)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..geometry.mesh_files import read_mesh_file
from ..pipeline.report_3d import design_view_figure
from ..session import SessionAnswer
from .results import FinsFolderError

__all__ = ["fins_figure", "read_support_obj", "SupportFins"]


@dataclass(frozen=True)
class SupportFins:
    """The fins of ``support.obj``: nodes on the surface ``vertices_a`` (n, 3), their far ends
    ``vertices_b`` (n, 3), one fin per edge ``edges`` (m, 2) of torsal family ``edge_family``
    (m,). Model units."""

    vertices_a: np.ndarray
    vertices_b: np.ndarray
    edges: np.ndarray
    edge_family: np.ndarray

    @property
    def directions(self) -> np.ndarray:
        return self.vertices_b - self.vertices_a


def read_support_obj(path: str | Path) -> SupportFins:
    """Read the ``support.obj`` a design run writes (vertices of A~ then B~, fin quads
    ``i j j+n i+n`` in groups ``fins_family_0`` / ``fins_family_1``)."""
    verts, edges, family, group = [], [], [], None
    for line in Path(path).read_text().splitlines():
        head, _, rest = line.partition(" ")
        if head == "v":
            verts.append([float(x) for x in rest.split()])
        elif head == "g":
            group = rest.strip()
        elif head == "f" and group and group.startswith("fins_family_"):
            i, j = (int(x) - 1 for x in rest.split()[:2])
            edges.append((i, j))
            family.append(int(group.removeprefix("fins_family_")))
    v = np.asarray(verts, float)
    n = len(v) // 2
    return SupportFins(v[:n], v[n:], np.asarray(edges, np.int64).reshape(-1, 2),
                       np.asarray(family, np.int64))


def fins_figure(result_or_folder, *, title: str | None = None):
    """The plotly figure of a run: mesh A and the fins by torsal family.

    ``result_or_folder``: what :meth:`torsal.Design.run` returned, its output folder, or an
    answer of a live session (:class:`torsal.session.SessionAnswer`: a preview is drawn from
    its values, no files needed).

    >>> fig = fins_figure("out/7a")   # doctest: +SKIP
    >>> fig.show()                    # doctest: +SKIP
    >>> fins_figure(session.set_fins(spacing=0.7), title="spacing 0.7")   # doctest: +SKIP
    """
    if isinstance(result_or_folder, SessionAnswer):
        answer = result_or_folder
        if answer.structure is None:
            raise FinsFolderError("the session has no good design yet: nothing to draw")
        o = answer.values["orient"]
        name = title if title is not None else f"{answer.spec.name} ({answer.kind.value})"
        return design_view_figure((o["vertices"], o["faces"]), answer.structure, title=name)
    folder = Path(getattr(result_or_folder, "folder", None) or result_or_folder)
    ply, obj = folder / "congruence.ply", folder / "support.obj"
    for f in (ply, obj):
        if not f.is_file():
            raise FinsFolderError(f"{folder}: no {f.name} here; give the output folder of "
                                  "`torsal design` (or what Design.run returned)")
    mesh = read_mesh_file(ply)
    fins = read_support_obj(obj)
    name = title if title is not None else folder.name
    return design_view_figure((mesh.vertices, mesh.faces), fins, title=name)
