"""Torsion-free support structures: corresponding polygon meshes A~, B~ (paper 2.3, 4.2, eq. (8)).

A :class:`SupportStructure` is the combinatorics of the fins: a polygon mesh A~ (mostly
quads) with, at every vertex, a node line through ``a~_i`` and ``b~_i``. Every edge
``a~_i a~_j`` carries one fin, the quad ``a~_i a~_j b~_j b~_i``; it is buildable as a flat
plate when that quad is planar (Def. 3). Edges are labelled by torsal family (0 or 1), and
the edges of one family chain into strips: the discrete developables of Fig. 5.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["SupportStructure", "FinStrip", "fin_planarity"]


def fin_planarity(quads: np.ndarray) -> np.ndarray:
    """Planarity of quads ``p0 p1 p2 p3``: distance of the diagonals / their mean length, (E,).

    Wang et al. 2013, Fig. 12 (delta_pl). For a fin ``a_i a_j b_j b_i`` the diagonals are
    ``a_i b_j`` and ``a_j b_i``. Zero for a planar quad (including diagonals that are parallel,
    which always span a plane).

    Parameters
    ----------
    quads : (E, 4, 3) float
    """
    q = np.asarray(quads, dtype=float)
    d1 = q[:, 2] - q[:, 0]
    d2 = q[:, 3] - q[:, 1]
    n = np.cross(d1, d2)
    nn = np.linalg.norm(n, axis=1)
    l1 = np.linalg.norm(d1, axis=1)
    l2 = np.linalg.norm(d2, axis=1)
    mean_len = 0.5 * (l1 + l2)
    parallel = nn <= 1e-14 * l1 * l2
    with np.errstate(invalid="ignore", divide="ignore"):
        dist = np.abs(np.einsum("ij,ij->i", q[:, 1] - q[:, 0], n)) / np.where(parallel, 1.0, nn)
        return np.where(parallel, 0.0, dist) / mean_len


@dataclass(frozen=True)
class FinStrip:
    """One strip of fins: a chain of edges of one family (a discrete developable).

    Attributes
    ----------
    family : int
        Torsal family, 0 or 1.
    vertices : (m,) int
        Node indices along the strip, in order (closed strips repeat the first at the end).
    edges : (m-1,) int
        Edge indices of the structure between consecutive nodes.
    quads : (m-1, 4, 3) float
        Fin quads ``a_i a_j b_j b_i`` in strip order; consecutive fins share the node line
        ``a_j b_j`` (the fold line).
    """

    family: int
    vertices: np.ndarray
    edges: np.ndarray
    quads: np.ndarray

    @property
    def closed(self) -> bool:
        return len(self.vertices) > 2 and self.vertices[0] == self.vertices[-1]


@dataclass
class SupportStructure:
    """A (near) torsion-free support structure: meshes A~ and B~ with common combinatorics.

    Parameters
    ----------
    vertices_a : (n, 3) float
        Nodes a~_i on the design surface, model units.
    vertices_b : (n, 3) float
        Nodes b~_i; the node line is ``a~_i + lambda (b~_i - a~_i)`` and the fin depth at a
        node is ``|b~_i - a~_i|``.
    faces : list of list of int
        Polygons of A~ (quads inside, clipped polygons along the boundary).
    edges : (E, 2) int
        Undirected edges of A~; every edge is one fin.
    edge_family : (E,) int
        Torsal family (0 or 1) of each edge.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([[0., 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    >>> s = SupportStructure(a, a + [0, 0, 1], [[0, 1, 2, 3]],
    ...                      np.array([[0, 1], [1, 2], [2, 3], [0, 3]]), np.array([0, 1, 0, 1]))
    >>> s.delta_pl
    0.0
    """

    vertices_a: np.ndarray
    vertices_b: np.ndarray
    faces: list
    edges: np.ndarray
    edge_family: np.ndarray
    metadata: dict = field(default_factory=dict)

    def __post_init__(self):
        self.vertices_a = np.asarray(self.vertices_a, dtype=float)
        self.vertices_b = np.asarray(self.vertices_b, dtype=float)
        self.edges = np.asarray(self.edges, dtype=np.int64).reshape(-1, 2)
        self.edge_family = np.asarray(self.edge_family, dtype=np.int64).ravel()
        self.faces = [list(map(int, p)) for p in self.faces]
        n = len(self.vertices_a)
        if self.vertices_a.shape != (n, 3) or self.vertices_b.shape != (n, 3):
            raise ValueError(
                f"vertices_a and vertices_b must both be (n, 3); got {self.vertices_a.shape} "
                f"and {self.vertices_b.shape}"
            )
        if len(self.edge_family) != len(self.edges):
            raise ValueError(f"edge_family has {len(self.edge_family)} entries for {len(self.edges)} edges")
        if len(self.edges) and (self.edges.min() < 0 or self.edges.max() >= n):
            raise ValueError("edges refer to vertices that do not exist")
        if not np.isin(self.edge_family, (0, 1)).all():
            raise ValueError("edge_family must be 0 or 1 for every edge")
        for arr, name in ((self.vertices_a, "vertices_a"), (self.vertices_b, "vertices_b")):
            bad = np.flatnonzero(~np.isfinite(arr).all(axis=1))
            if bad.size:
                raise ValueError(f"{name} of nodes {bad[:10].tolist()} are NaN or infinite")

    # ------------------------------------------------------------------ fins
    @property
    def directions(self) -> np.ndarray:
        """Node line vectors ``e~_i = b~_i - a~_i``, (n, 3)."""
        return self.vertices_b - self.vertices_a

    def fin_quads(self) -> np.ndarray:
        """One quad ``a_i a_j b_j b_i`` per edge, (E, 4, 3), in edge order."""
        i, j = self.edges[:, 0], self.edges[:, 1]
        a, b = self.vertices_a, self.vertices_b
        return np.stack([a[i], a[j], b[j], b[i]], axis=1)

    def planarity(self) -> np.ndarray:
        """Per fin: distance of the diagonals divided by their average length, (E,) (Fig. 12)."""
        return fin_planarity(self.fin_quads())

    @property
    def delta_pl(self) -> float:
        """The paper's delta_pl: the maximum of :meth:`planarity` over all fins (Fig. 12)."""
        p = self.planarity()
        return float(p.max()) if p.size else 0.0

    def strips(self, family: int | None = None) -> list[tuple[int, np.ndarray, np.ndarray]]:
        """Chain the edges of each family into maximal polylines.

        At a node where exactly two edges of a family meet the polyline continues; it ends
        at nodes with one such edge (the boundary) or with three or more (a singularity).

        Returns
        -------
        list of (family, vertices (m,), edges (m-1,))
            Sorted by family, then by the smallest edge index in the strip.
        """
        families = (0, 1) if family is None else (int(family),)
        out = []
        n = len(self.vertices_a)
        for fam in families:
            eid = np.flatnonzero(self.edge_family == fam)
            if eid.size == 0:
                continue
            # incidence lists for this family
            ends = self.edges[eid]
            inc: list[list[int]] = [[] for _ in range(n)]
            for k, (u, v) in zip(eid, ends):
                inc[u].append(k)
                inc[v].append(k)
            deg = np.array([len(x) for x in inc])
            used = np.zeros(len(self.edges), dtype=bool)

            def walk(start: int, first_edge: int):
                verts, es = [start], []
                cur, e = start, first_edge
                while True:
                    used[e] = True
                    es.append(e)
                    u, v = self.edges[e]
                    nxt = v if u == cur else u
                    verts.append(nxt)
                    if deg[nxt] != 2 or nxt == start:
                        break
                    cand = [k for k in inc[nxt] if k != e]
                    if not cand or used[cand[0]]:
                        break
                    cur, e = nxt, cand[0]
                return np.array(verts), np.array(es)

            # open chains start at ends and singular nodes
            for vtx in np.flatnonzero((deg > 0) & (deg != 2)):
                for e in inc[vtx]:
                    if not used[e]:
                        out.append((fam,) + walk(int(vtx), e))
            # what is left are closed loops
            for e in eid:
                if not used[e]:
                    out.append((fam,) + walk(int(self.edges[e, 0]), int(e)))
        out.sort(key=lambda s: (s[0], int(s[2].min())))
        return out

    def fins(self, family: int | None = None) -> list[FinStrip]:
        """The fins grouped into strips by family (see :meth:`strips`), each with its quads
        oriented along the strip (``a_i a_j b_j b_i`` with ``i -> j`` the strip direction)."""
        a, b = self.vertices_a, self.vertices_b
        res = []
        for fam, verts, es in self.strips(family):
            i, j = verts[:-1], verts[1:]
            quads = np.stack([a[i], a[j], b[j], b[i]], axis=1)
            res.append(FinStrip(family=fam, vertices=verts, edges=es, quads=quads))
        return res

    def fin_mesh(self):
        """The fins as a thin-surface ``trimesh.Trimesh`` (two triangles per fin), for ray
        casting and previews. Face ``2k`` and ``2k+1`` belong to edge ``k``."""
        import trimesh

        i, j = self.edges[:, 0], self.edges[:, 1]
        n = len(self.vertices_a)
        verts = np.concatenate([self.vertices_a, self.vertices_b])
        tri = np.empty((2 * len(self.edges), 3), dtype=np.int64)
        tri[0::2] = np.c_[i, j, j + n]
        tri[1::2] = np.c_[i, j + n, i + n]
        return trimesh.Trimesh(verts, tri, process=False)

    # ------------------------------------------------------------------ persistence
    def save(self, path) -> None:
        """Write to a ``.npz`` file (atomically: temporary name, then rename)."""
        import os
        from pathlib import Path

        path = Path(path)
        tmp = path.with_name(path.name + ".tmp.npz")
        offsets = np.cumsum([0] + [len(p) for p in self.faces])
        np.savez(tmp, vertices_a=self.vertices_a, vertices_b=self.vertices_b,
                 face_indices=np.concatenate([np.asarray(p, np.int64) for p in self.faces])
                 if self.faces else np.zeros(0, np.int64),
                 face_offsets=offsets, edges=self.edges, edge_family=self.edge_family)
        os.replace(tmp, path)

    @classmethod
    def load(cls, path) -> "SupportStructure":
        """Read a structure written by :meth:`save`."""
        with np.load(path) as z:
            off, idx = z["face_offsets"], z["face_indices"]
            faces = [idx[off[k]:off[k + 1]].tolist() for k in range(len(off) - 1)]
            return cls(z["vertices_a"], z["vertices_b"], faces, z["edges"], z["edge_family"])
