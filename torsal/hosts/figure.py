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
    #: each family's far ends (n, 3) where it stops short of B (``fins.depth = [d0, d1]``)
    family_ends: tuple = (None, None)

    @property
    def directions(self) -> np.ndarray:
        return self.vertices_b - self.vertices_a

    def family_vertices_b(self, family: int) -> np.ndarray:
        """(n, 3) far ends of the fins of ``family`` (B, or its own where it is shallower)."""
        ends = self.family_ends[family]
        return self.vertices_b if ends is None else ends

    @property
    def family_depth_ratio(self) -> tuple[float, float]:
        """Each family's depth over the deeper one's, as the file's far ends give them (the
        mean over the nodes; the support structure's own field, read back)."""
        full = np.linalg.norm(self.directions, axis=1)
        full = np.where(full > 0, full, 1.0)
        return tuple(float(np.mean(np.linalg.norm(self.family_vertices_b(f) - self.vertices_a,
                                                  axis=1) / full)) for f in (0, 1))


def read_support_obj(path: str | Path) -> SupportFins:
    """Read the ``support.obj`` a design run writes (vertices of A~ then B~, then the far ends
    of a family that stops short of B; fin quads ``i j j+k i+k`` in groups ``fins_family_0`` /
    ``fins_family_1``, ``k`` = n where a family's fins end on B)."""
    verts, edges, family, group = [], [], [], None
    offset: dict[int, int] = {}          # family -> index offset of its fins' far ends
    for line in Path(path).read_text().splitlines():
        head, _, rest = line.partition(" ")
        if head == "v":
            verts.append([float(x) for x in rest.split()])
        elif head == "g":
            group = rest.strip()
        elif head == "f" and group and group.startswith("fins_family_"):
            i, j, _, far = (int(x) - 1 for x in rest.split()[:4])
            edges.append((i, j))
            family.append(int(group.removeprefix("fins_family_")))
            offset[family[-1]] = far - i
    v = np.asarray(verts, float)
    # A, B, then the far ends of a family that stops short of B (n each): the quads say where
    n = min(offset.values(), default=len(v) // 2)
    ends = tuple(None if offset.get(f, n) == n else v[offset[f]:offset[f] + n] for f in (0, 1))
    return SupportFins(v[:n], v[n:2 * n], np.asarray(edges, np.int64).reshape(-1, 2),
                       np.asarray(family, np.int64), ends)


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
