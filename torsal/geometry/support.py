"""Torsion-free support structures: corresponding polygon meshes A~, B~ (paper 2.3, 4.2, eq. (8)).

A :class:`SupportStructure` is the combinatorics of the fins: a polygon mesh A~ (mostly
quads) with, at every vertex, a node line through ``a~_i`` and ``b~_i``. Every edge
``a~_i a~_j`` carries one fin, the quad ``a~_i a~_j b~_j b~_i``; it is buildable as a flat
plate when that quad is planar (Def. 3). Edges are labelled by torsal family (0 or 1), and
the edges of one family chain into strips: the discrete developables of Fig. 5.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from torsal.core.atomic import atomic_path

__all__ = ["SupportStructure", "FinStrip", "fin_planarity", "per_family", "optimize_support", "PLANARITY_TOL",
           "crossing_folds",
           "SupportOptimizationResult", "SupportWeights", "graph_laplacian", "closest_points"]


def per_family(value, name: str = "length") -> tuple[float, float]:
    """``(x0, x1)`` of a length given for both torsal families (a number) or per family (two),
    e.g. a fin spacing or depth (``fins.spacing = [s0, s1]``); a ValueError naming ``name``
    unless they are positive and finite.

    >>> per_family(0.5), per_family([0.5, 1.0])
    ((0.5, 0.5), (0.5, 1.0))
    """
    x = np.asarray(value, float).ravel()
    x = np.repeat(x, 2) if x.size == 1 else x
    if not (x.size == 2 and np.isfinite(x).all() and (x > 0).all()):
        raise ValueError(f"{name} must be a positive length in model units, or two (family 0, "
                         f"family 1); got {value}")
    return float(x[0]), float(x[1])


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


def crossing_folds(structure: "SupportStructure") -> tuple[np.ndarray, np.ndarray]:
    """Fold of each family's strip at every crossing, degrees.

    A crossing is a node that a strip of family 0 and a strip of family 1 both pass through
    (the node is interior to both). The fold of a strip at a node is the angle between the
    normals of its two fins there (0: the strip is flat across the node line).

    Returns
    -------
    nodes : (c,) int
        Crossing nodes, ascending.
    folds : (c, 2) float
        Fold of the family-0 and the family-1 strip at each, degrees in [0, 180].

    Examples
    --------
    >>> a = np.array([[x, y, 0.0] for y in (0, 1, 2) for x in (0, 1, 2)])
    >>> a[4] += [0.5, 0, 0]          # the column strip bends at the middle node, the row stays flat
    >>> b = a + [0, 0, 1]
    >>> s = SupportStructure(a, b, [[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]],
    ...                      np.array([[0, 1], [1, 2], [3, 4], [4, 5], [6, 7], [7, 8],
    ...                                [0, 3], [3, 6], [1, 4], [4, 7], [2, 5], [5, 8]]),
    ...                      np.array([0] * 6 + [1] * 6))
    >>> nodes, folds = crossing_folds(s)
    >>> nodes.tolist(), np.round(folds, 1).tolist()
    ([4], [[0.0, 53.1]])
    """
    fold: dict[tuple[int, int], float] = {}
    for st in structure.fins():
        q = st.quads
        n = np.cross(q[:, 2] - q[:, 0], q[:, 3] - q[:, 1])
        with np.errstate(invalid="ignore", divide="ignore"):
            n = n / np.linalg.norm(n, axis=1, keepdims=True)
        k = len(q)
        i1 = np.arange(1, k)
        if st.closed and k >= 2:
            i1 = np.r_[i1, 0]
        i0 = np.where(i1 > 0, i1 - 1, k - 1)
        # atan2 of sine and cosine: accurate for small folds too (arccos is not); all of the
        # strip's nodes at once (one np.cross per node cost a tenth of a second on 7a)
        ang = np.degrees(np.arctan2(np.linalg.norm(np.cross(n[i0], n[i1]), axis=1),
                                    np.einsum("ij,ij->i", n[i0], n[i1])))
        for node, a in zip(st.vertices[i1].tolist(), ang.tolist()):
            fold[(st.family, int(node))] = a if np.isfinite(a) else 180.0
    nodes = sorted({v for f, v in fold if f == 0} & {v for f, v in fold if f == 1})
    return (np.asarray(nodes, dtype=np.int64),
            np.array([[fold[(0, v)], fold[(1, v)]] for v in nodes]).reshape(-1, 2))


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
    family_depth_ratio : (2,) float, default (1, 1)
        How far along its node lines each family's fins reach, as a share of ``b~_i -
        a~_i``: a family-``f`` fin is ``a~_i a~_j c~_j c~_i`` with ``c~ = a~ + r_f (b~ -
        a~)`` (:meth:`family_vertices_b`). Fins of one family may be shallower than the
        other's (``fins.depth = [d0, d1]``); a fin planar at one depth is planar at any,
        since its two node lines are coplanar (Def. 3), so eq. (8) is solved once, on the
        deeper fins, and each family is then cut to its own depth. Each ratio is in (0, 1].

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
    family_depth_ratio: tuple[float, float] = (1.0, 1.0)

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
        r = np.broadcast_to(np.asarray(self.family_depth_ratio, float), (2,))
        if not (np.isfinite(r).all() and (r > 0).all() and (r <= 1).all()):
            raise ValueError(f"family_depth_ratio must be two shares in (0, 1]; got "
                             f"{self.family_depth_ratio}")
        self.family_depth_ratio = (float(r[0]), float(r[1]))
        for arr, name in ((self.vertices_a, "vertices_a"), (self.vertices_b, "vertices_b")):
            bad = np.flatnonzero(~np.isfinite(arr).all(axis=1))
            if bad.size:
                raise ValueError(f"{name} of nodes {bad[:10].tolist()} are NaN or infinite")

    # ------------------------------------------------------------------ fins
    @property
    def directions(self) -> np.ndarray:
        """Node line vectors ``e~_i = b~_i - a~_i``, (n, 3)."""
        return self.vertices_b - self.vertices_a

    def family_vertices_b(self, family: int) -> np.ndarray:
        """Where the fins of ``family`` end on the node lines, (n, 3): ``a~ + r_f (b~ - a~)``
        (``vertices_b`` itself where the family reaches all the way).

        >>> a = np.zeros((2, 3))
        >>> s = SupportStructure(a, a + [0, 0, 0.4], [], np.array([[0, 1]]), np.array([1]),
        ...                      family_depth_ratio=(1.0, 0.5))
        >>> s.family_vertices_b(1)[:, 2].tolist()
        [0.2, 0.2]
        """
        r = self.family_depth_ratio[int(family)]
        if r == 1.0:
            return self.vertices_b
        return self.vertices_a + r * (self.vertices_b - self.vertices_a)

    def _edge_b(self) -> np.ndarray:
        """(E, 2, 3): the ``b`` end of each fin at both its nodes, at its family's depth."""
        i, j = self.edges[:, 0], self.edges[:, 1]
        r = np.asarray(self.family_depth_ratio)[self.edge_family][:, None]
        a, e = self.vertices_a, self.directions
        return np.stack([a[i] + r * e[i], a[j] + r * e[j]], axis=1)

    def fin_quads(self) -> np.ndarray:
        """One quad ``a_i a_j b_j b_i`` per edge, (E, 4, 3), in edge order (``b`` at the
        edge's family depth, :meth:`family_vertices_b`)."""
        i, j = self.edges[:, 0], self.edges[:, 1]
        a, b = self.vertices_a, self._edge_b()
        return np.stack([a[i], a[j], b[:, 1], b[:, 0]], axis=1)

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
        a = self.vertices_a
        res = []
        for fam, verts, es in self.strips(family):
            b = self.family_vertices_b(fam)
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
        # the b ends of family 1 after family 0's where the families reach differently deep
        two = self.family_depth_ratio[0] != self.family_depth_ratio[1]
        verts = np.concatenate([self.vertices_a, self.family_vertices_b(0)]
                               + ([self.family_vertices_b(1)] if two else []))
        k = n * (1 + self.edge_family) if two else n
        tri = np.empty((2 * len(self.edges), 3), dtype=np.int64)
        tri[0::2] = np.c_[i, j, j + k]
        tri[1::2] = np.c_[i, j + k, i + k]
        return trimesh.Trimesh(verts, tri, process=False)

    # ------------------------------------------------------------------ persistence
    def save(self, path) -> None:
        """Write to a ``.npz`` file (atomically: temporary name, then rename).

        The file is written to exactly ``path``, whatever its suffix (no ``.npz`` appended).
        """
        offsets = np.cumsum([0] + [len(p) for p in self.faces])
        # a file object, not a name: np.savez would append ".npz" to a name lacking it
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            np.savez(f, vertices_a=self.vertices_a, vertices_b=self.vertices_b,
                     face_indices=np.concatenate([np.asarray(p, np.int64) for p in self.faces])
                     if self.faces else np.zeros(0, np.int64),
                     face_offsets=offsets, edges=self.edges, edge_family=self.edge_family,
                     family_depth_ratio=np.asarray(self.family_depth_ratio))

    @classmethod
    def load(cls, path) -> "SupportStructure":
        """Read a structure written by :meth:`save`."""
        with np.load(path) as z:
            off, idx = z["face_offsets"], z["face_indices"]
            faces = [idx[off[k]:off[k + 1]].tolist() for k in range(len(off) - 1)]
            ratio = (tuple(z["family_depth_ratio"].tolist()) if "family_depth_ratio" in z.files
                     else (1.0, 1.0))            # a file written before the families had depths
            return cls(z["vertices_a"], z["vertices_b"], faces, z["edges"], z["edge_family"],
                       family_depth_ratio=ratio)


# ============================================================================ eq. (8)
#: The planarity a flat sheet part needs (the paper's delta_pl, Fig. 12): the default target
#: of :func:`optimize_support` and of a design file's ``fins.planarity_tol``
PLANARITY_TOL = 1e-4


@dataclass
class SupportWeights:
    """Weights of eq. (8) (Wang et al. 2013, Fig. 12 uses plnr 20, prox 1, fair 1 for 7c).

    Attributes
    ----------
    plnr : float
        Planarity: squared distance of the fin diagonals, normalized by ``delta~^2 |E|``.
    prox : float
        Proximity: ``|e~ - e~_0|^2`` plus squared distance of ``a~`` to the tangent plane of A at
        its closest point (normalized by ``delta``), averaged over vertices. Nodes flagged in
        ``structure.metadata['boundary']`` and their fin neighbours use the distance to the
        closest point itself, so they do not slide off the patch.
    prox_e : float
        Relative weight of the ``|e~ - e~_0|^2`` part inside the proximity term.
    fair : float
        Fairness: squared umbrella Laplacian of ``a~`` along the edges, normalized by
        ``delta~^2 |V|``.
    prox_t : float
        Weak regularizer ``|a~ - a~_start|^2 / delta^2`` (not in the paper): tangential sliding
        is otherwise free, which makes IPOPT crawl along the fairness flow.
    """

    plnr: float = 20.0
    prox: float = 1.0
    prox_e: float = 1.0
    fair: float = 0.001
    prox_t: float = 0.01


@dataclass
class SupportOptimizationResult:
    """Outcome of :func:`optimize_support`, shaped like the congruence solver's result.

    Attributes
    ----------
    structure : SupportStructure
        The optimized structure (a new object; the input is not modified).
    success : bool
        IPOPT converged in the last round and the requested planarity (if any) is met.
    status : str
        IPOPT's return status of the last round (or a message naming the problem).
    solve_seconds : float
        Wall time of all rounds (NLP construction included).
    iterations : int
        IPOPT iterations summed over rounds.
    delta_pl_before, delta_pl_after : float
        The paper's delta_pl (Fig. 12) before and after.
    distance_to_reference : float
        Largest distance of a node a~ to the reference surface A, divided by A's average
        edge length delta (NaN when no reference was given).
    history : list of dict
        Per outer round: objective, delta_pl, IPOPT status and iterations.
    """

    structure: "SupportStructure"
    success: bool
    status: str
    solve_seconds: float
    iterations: int
    delta_pl_before: float
    delta_pl_after: float
    distance_to_reference: float
    history: list = field(default_factory=list)


def graph_laplacian(edges: np.ndarray, n: int):
    """Umbrella Laplacian of a graph, (n, n) sparse: ``(L x)_i = x_i - mean_{j~i} x_j``."""
    import scipy.sparse as sp

    e = np.asarray(edges, np.int64).reshape(-1, 2)
    i = np.r_[e[:, 0], e[:, 1]]
    j = np.r_[e[:, 1], e[:, 0]]
    adj = sp.csr_matrix((np.ones(len(i)), (i, j)), shape=(n, n))
    adj.data[:] = 1.0
    deg = np.asarray(adj.sum(1)).ravel()
    inv = np.divide(1.0, deg, out=np.zeros_like(deg), where=deg > 0)
    return (sp.diags((deg > 0).astype(float)) - sp.diags(inv) @ adj).tocsr()


def _near_boundary(structure) -> np.ndarray:
    """Nodes on the boundary of A (``metadata['boundary']``) and their fin neighbours, (n,) bool:
    these use the distance to the closest point of A (not to its tangent plane) so that they
    cannot slide off the patch."""
    n = len(structure.vertices_a)
    bnd = np.asarray(structure.metadata.get("boundary", np.zeros(n, bool)), bool)
    if bnd.shape != (n,):
        return np.zeros(n, bool)
    e = structure.edges
    near = bnd.copy()
    near[e[bnd[e[:, 0]], 1]] = True
    near[e[bnd[e[:, 1]], 0]] = True
    return near


def closest_points(vertices, faces, points):
    """Closest points on a triangle mesh: ``(points (m, 3), distances (m,), faces (m,))``.

    libigl's AABB ``point_mesh_squared_distance`` (exact, C++); trimesh's proximity query as a
    fallback when libigl is missing.
    """
    pts = np.ascontiguousarray(points, dtype=float)
    try:
        import igl

        d2, tri, cp = igl.point_mesh_squared_distance(pts, np.ascontiguousarray(vertices, dtype=float),
                                                      np.ascontiguousarray(faces, dtype=np.int64))
        return np.asarray(cp), np.sqrt(np.maximum(d2, 0.0)), np.asarray(tri)
    except ImportError:  # pragma: no cover
        import trimesh

        m = trimesh.Trimesh(vertices, faces, process=False)
        cp, d, tri = trimesh.proximity.closest_point(m, pts)
        return cp, d, tri


def _face_normals(vertices, faces):
    v = np.asarray(vertices, float)
    f = np.asarray(faces)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def _reference_arrays(reference):
    if reference is None:
        return None
    if hasattr(reference, "vertices") and hasattr(reference, "faces"):
        return np.asarray(reference.vertices, float), np.asarray(reference.faces, np.int64)
    v, f = reference
    return np.asarray(v, float), np.asarray(f, np.int64)


class _SupportScales(NamedTuple):
    """Normalizations of eq. (8) and the reference surface's arrays."""

    fin_length: float            # delta~: mean length of the a~ edges
    edge_length: float           # delta: mean edge length of A (fin_length without A)
    reference: tuple | None      # (vertices, faces) of A
    face_normals: np.ndarray | None
    laplacian: "scipy.sparse.csr_matrix"   # (n, n) graph Laplacian of A~


def _support_scales(structure: "SupportStructure", reference) -> _SupportScales:
    a = structure.vertices_a
    i, j = structure.edges[:, 0], structure.edges[:, 1]
    dtil = float(np.linalg.norm(a[j] - a[i], axis=1).mean())
    ref = _reference_arrays(reference)
    if ref is None:
        return _SupportScales(dtil, dtil, None, None, graph_laplacian(structure.edges, len(a)))
    from .mesh import average_edge_length

    return _SupportScales(dtil, average_edge_length(*ref), ref, _face_normals(*ref),
                          graph_laplacian(structure.edges, len(a)))


def _fin_kernel(ca):
    """casadi Function of one fin (a_i, a_j, e_i, e_j) -> (diagonal distance, vol).

    With a hard constraint, fin_planarity = dist / mean diagonal = vol / sin(angle of the
    diagonals), with vol = det / (|d1| |d2| mean diagonal). On sliver fins the diagonals are
    nearly parallel (sin ~ 1e-3) and dist / mean diagonal swings wildly under tiny moves:
    IPOPT's linearized steps then overshoot, its line search stalls and the restoration phase
    ends in "Infeasible_Problem_Detected" at a feasible point. vol is a smooth, bounded
    function of the nodes; |vol| <= tol * sin, with sin frozen at the start of each round
    (updated between rounds), is the same constraint, well conditioned."""
    sa, sb_, sc, sd = (ca.SX.sym(nm, 3) for nm in ("ai", "aj", "ei", "ej"))
    d1 = sb_ + sd - sa           # b_j - a_i
    d2 = sa + sc - sb_           # b_i - a_j
    cr = ca.cross(d1, d2)
    det = ca.dot(sb_ - sa, cr)
    dist_k = det / ca.sqrt(ca.dot(cr, cr) + 1e-300)
    n1, n2 = ca.norm_2(d1), ca.norm_2(d2)
    vol_k = det / (n1 * n2 * 0.5 * (n1 + n2))
    return ca.Function("fin", [sa, sb_, sc, sd], [dist_k, vol_k])


def _support_solver(ca, s0: "SupportStructure", sc: _SupportScales, weights: SupportWeights, *,
                    hard: bool, fixed_e: bool, max_iter: int, ipopt_options: dict | None,
                    exact_hessian: str):
    """The casadi NLP of eq. (8) (one per-fin SX kernel mapped over all fins, nodes stored
    column-wise (3, n)) and its IPOPT solver. Parameters: the closest points on A and their
    normals (6 n), updated per round. With ``hard``, g = the fins' vol (bounded per round)."""
    n, E = len(s0.vertices_a), len(s0.edges)
    a0, e0 = s0.vertices_a, s0.directions
    i, j = s0.edges[:, 0], s0.edges[:, 1]
    dtil, delta, ref = sc.fin_length, sc.edge_length, sc.reference
    fin = _fin_kernel(ca)
    x = ca.MX.sym("x", 3 * n if fixed_e else 6 * n)
    A = ca.reshape(x[:3 * n], 3, n)
    Em = ca.DM(e0.T) if fixed_e else ca.reshape(x[3 * n:], 3, n)
    p_pt, p_n = ca.MX.sym("p", 3 * n), ca.MX.sym("q", 3 * n)
    P_, N_ = ca.reshape(p_pt, 3, n), ca.reshape(p_n, 3, n)
    il, jl = i.tolist(), j.tolist()
    dist, plan = fin.map(E, "serial")(A[:, il], A[:, jl], Em[:, il], Em[:, jl])
    # with a hard planarity constraint the planarity summand is replaced by the constraint
    # (keeping both makes the Lagrangian Hessian indefinite and IPOPT crawls)
    w_pl = 0.0 if hard else weights.plnr
    f_pl = w_pl / (dtil ** 2 * E) * ca.sumsqr(dist)
    bnd = _near_boundary(s0) if ref is not None else None
    if ref is not None:
        f_tan = ca.sumsqr(ca.sum1((A - P_) * N_) / delta)
        # nodes on the boundary of A would slide off the patch along the tangent plane:
        # for them the distance to the closest point itself is used
        if bnd.any():
            bl = np.flatnonzero(bnd).tolist()
            f_tan = f_tan + ca.sumsqr(A[:, bl] - P_[:, bl]) / delta ** 2
    else:
        f_tan = ca.sumsqr(A - P_) / delta ** 2
    f_prox = weights.prox / n * f_tan
    if not fixed_e:
        f_prox = f_prox + weights.prox / n * weights.prox_e * ca.sumsqr(Em - ca.DM(e0.T))
    Lc = sc.laplacian.tocoo()
    Ls = ca.DM.triplet(Lc.row.tolist(), Lc.col.tolist(), ca.DM(Lc.data), n, n)
    f_fair = weights.fair / (dtil ** 2 * n) * ca.sumsqr(ca.mtimes(A, Ls.T))
    f_reg = weights.prox_t / n * ca.sumsqr(A - ca.DM(a0.T)) / delta ** 2
    par = ca.vertcat(p_pt, p_n)
    nlp = {"x": x, "f": f_pl + f_prox + f_fair + f_reg, "p": par}
    if hard:
        nlp["g"] = plan.T
    opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.linear_solver": "mumps",
            "ipopt.max_iter": int(max_iter), "ipopt.tol": 1e-9, "ipopt.sb": "yes",
            "ipopt.mumps_pivot_order": 5}
    if ipopt_options:
        opts.update({(k if k.startswith("ipopt.") else "ipopt." + k): v for k, v in ipopt_options.items()})
    if exact_hessian == "assembled":
        opts["hess_lag"] = _assembled_hessian(
            ca, fin, x, par, N_, n, E, i, j, fixed_e, hard, ref is not None, bnd,
            c_pl=w_pl / (dtil ** 2 * E), c_tan=weights.prox / (n * delta ** 2),
            c_e=weights.prox * weights.prox_e / n, c_fair=weights.fair / (dtil ** 2 * n),
            c_reg=weights.prox_t / (n * delta ** 2), L=sc.laplacian)
    return ca.nlpsol("support", "ipopt", nlp, opts)


class _Rounds(NamedTuple):
    a: np.ndarray          # (n, 3) final a~
    e: np.ndarray          # (n, 3) final e~
    ok: bool               # IPOPT's success flag of the last solve
    status: str
    iterations: int
    history: list


def _solve_rounds(solver, s0: "SupportStructure", sc: _SupportScales, a_cur, e_cur, *,
                  rounds: int, hard_tol: float | None, fixed_e: bool, history: list,
                  stop_unconverged: bool = False) -> _Rounds:
    """Outer rounds (Fig. 8c): tangent planes of A at the current closest points, then IPOPT.
    With a hard constraint the diagonals' sines that bound vol are refreshed and the round
    re-solved (warm) until the planarity itself holds: sliver fins turn their diagonals as
    they move. ``stop_unconverged``: no round after one IPOPT did not converge."""
    n = len(s0.vertices_a)
    i, j = s0.edges[:, 0], s0.edges[:, 1]
    ref = sc.reference
    iters, status, ok = 0, "not run", False
    for rnd in range(max(1, int(rounds))):
        if ref is not None:
            cp, _, tri = closest_points(ref[0], ref[1], a_cur)
            pn = sc.face_normals[tri]
        else:
            cp, pn = s0.vertices_a, np.zeros_like(s0.vertices_a)
        p_round = np.r_[np.asarray(cp).ravel(), np.asarray(pn).ravel()]
        for _ in range(4 if hard_tol is not None else 1):
            x0 = a_cur.ravel() if fixed_e else np.r_[a_cur.ravel(), e_cur.ravel()]
            args = {"x0": x0, "p": p_round}
            if hard_tol is not None:
                bound = 0.9 * float(hard_tol) * _diagonal_sine(a_cur, e_cur, s0.edges)
                args.update(lbg=-bound, ubg=bound)
            sol = solver(**args)
            st = solver.stats()
            status = st.get("return_status", "unknown")
            ok = bool(st.get("success", False))
            iters += int(st.get("iter_count", 0))
            xs = np.asarray(sol["x"]).ravel()
            a_cur = xs[:3 * n].reshape(n, 3).copy()
            if not fixed_e:
                e_cur = xs[3 * n:].reshape(n, 3).copy()
            if hard_tol is None or not ok or np.abs(fin_planarity(np.stack(
                    [a_cur[i], a_cur[j], a_cur[j] + e_cur[j], a_cur[i] + e_cur[i]], axis=1))).max() <= hard_tol:
                break
        cur = SupportStructure(a_cur, a_cur + e_cur, s0.faces, s0.edges, s0.edge_family,
                               metadata=dict(s0.metadata),
                               family_depth_ratio=s0.family_depth_ratio)
        history.append({"round": rnd, "objective": float(sol["f"]), "delta_pl": cur.delta_pl,
                        "status": status, "iterations": int(st.get("iter_count", 0))})
        if stop_unconverged and not ok:
            break
    return _Rounds(a_cur, e_cur, ok, status, iters, history)


def optimize_support(structure: "SupportStructure", reference=None, weights: SupportWeights | dict | None = None,
                     *, hard_tol: float | None = None, rounds: int = 2, max_iter: int = 200,
                     fixed_e: bool = False, ipopt_options: dict | None = None,
                     method: str = "ipopt", exact_hessian: str = "assembled",
                     start: str = "input",
                     planarity_tol: float | None = PLANARITY_TOL,
                     stop_unconverged: bool = False) -> SupportOptimizationResult:
    """Optimize a support structure towards planar fins, eq. (8) of Wang et al. 2013.

    Minimizes, over ``a~`` and ``e~ = b~ - a~``::

        w_plnr / (delta~^2 |E|) sum_E dist(a_i v b_j, a_j v b_i)^2
      + w_prox / |V| sum_V (|e_i - e_i0|^2 + (dist(a_i, T_i) / delta)^2)
      + w_fair / (delta~^2 |V|) sum_V |Laplace a_i|^2

    with ``T_i`` the tangent plane of the reference surface A at the closest point of
    ``a_i`` from the previous round (updated each of ``rounds`` outer rounds, Fig. 8c).
    The diagonal distance is ``det[a_j - a_i, b_j - a_i, b_i - a_j] / |(b_j - a_i) x (b_i - a_j)|``.
    Built as one vectorized casadi SX NLP and solved with IPOPT (MUMPS).

    Parameters
    ----------
    structure : SupportStructure
    reference : (vertices, faces) or trimesh.Trimesh, optional
        Surface A; without it the proximity term keeps ``a~`` near its start instead.
    weights : SupportWeights or dict, optional
    hard_tol : float, optional
        If given, planarity becomes a hard constraint: every fin's
        :func:`fin_planarity` (signed) lies in ``[-hard_tol, hard_tol]`` (a 0.9 safety factor
        is applied internally), i.e. ``delta_pl <= hard_tol``; the planarity summand of
        eq. (8) is then dropped (the constraint replaces it).
    rounds : int, default 2
        Outer rounds (tangent planes updated between them).
    max_iter : int, default 200
        IPOPT iterations per round.
    fixed_e : bool, default False
        Keep the node directions e~ fixed (only a~ moves).
    ipopt_options : dict, optional
        Extra IPOPT options (``{"tol": 1e-10}``, ...).
    planarity_tol : float or None, default :data:`PLANARITY_TOL` (1e-4)
        The planarity a flat sheet part needs. Without ``hard_tol``, the soft eq. (8) is
        solved first; if its ``delta_pl`` is above ``planarity_tol`` the result is solved
        again with planarity as a hard constraint (``hard_tol=planarity_tol``). ``success``
        is False, and ``status`` says why, unless ``delta_pl <= planarity_tol`` in the end.
        ``None``: the paper's soft formulation only (``success`` is IPOPT's verdict).
    stop_unconverged : bool, default False
        With ``planarity_tol=None`` or ``hard_tol``: end the rounds at the first one IPOPT
        does not converge in (``max_iter``): for a caller that then does not take the result
        as the design's (a live session's preview projects such fins instead,
        :func:`torsal.session.preview.preview_support`). The rounds before are as without it.
    start : {"input", "projection"}, default "input"
        Starting point of IPOPT when ``hard_tol`` is given: the (feasible, planar) result of the
        projection method, or the input structure. Proximity is always measured from the input.
    exact_hessian : {"assembled", "casadi"}, default "assembled"
        How IPOPT gets the exact Hessian of the Lagrangian: ``"assembled"`` maps a 12x12
        per-fin SX Hessian over all fins and sums the blocks with one sparse product (fast);
        ``"casadi"`` lets casadi differentiate the whole MX graph (slow for large meshes).
    method : {"ipopt", "projection"}, default "ipopt"
        ``"ipopt"``: the NLP above (casadi + IPOPT). ``"projection"``: a fast Gauss-Newton
        projection onto the constraint set {every fin planar, every a~ on its tangent plane}
        with minimal weighted change (``x <- x - W^-1 J^T (J W^-1 J^T)^-1 r``, one sparse solve
        per step; in the spirit of guided projection, Tang et al. 2014). It needs ``hard_tol``
        (default 1e-4) and ignores the fairness term; use it for large structures.

    Returns
    -------
    SupportOptimizationResult

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([[0., 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    >>> b = a + [[0, 0, 1], [0, 0, 1], [0.1, 0, 1], [0, 0, 1]]
    >>> s = SupportStructure(a, b, [[0, 1, 2, 3]], np.array([[0, 1], [1, 2], [2, 3], [0, 3]]),
    ...                      np.array([0, 1, 0, 1]))
    >>> r = optimize_support(s, hard_tol=1e-6)
    >>> r.success, r.structure.delta_pl <= 1e-6
    (True, True)
    """
    import time

    import casadi as ca

    t_start = time.perf_counter()
    if method == "projection":
        return _project_support(structure, reference, hard_tol=1e-4 if hard_tol is None else hard_tol,
                                rounds=rounds, max_iter=max_iter, fixed_e=fixed_e)
    if method != "ipopt":
        raise ValueError(f"method must be 'ipopt' or 'projection', got {method!r}")
    if hard_tol is None and planarity_tol is not None:
        return _soft_then_hard(structure, reference, weights, planarity_tol, rounds=rounds,
                               max_iter=max_iter, fixed_e=fixed_e, ipopt_options=ipopt_options,
                               exact_hessian=exact_hessian)
    if weights is None:
        weights = SupportWeights()
    elif isinstance(weights, dict):
        weights = SupportWeights(**weights)
    s0 = structure
    before = s0.delta_pl
    if len(s0.edges) == 0:
        return SupportOptimizationResult(s0, True, "no edges", 0.0, 0, before, before, float("nan"))
    sc = _support_scales(s0, reference)
    solver = _support_solver(ca, s0, sc, weights, hard=hard_tol is not None, fixed_e=fixed_e,
                             max_iter=max_iter, ipopt_options=ipopt_options,
                             exact_hessian=exact_hessian)
    a_cur, e_cur = s0.vertices_a.copy(), s0.directions.copy()
    history = []
    if start == "projection" and hard_tol is not None:
        pr = _project_support(s0, reference, hard_tol=hard_tol, rounds=1, max_iter=50, fixed_e=fixed_e)
        a_cur, e_cur = pr.structure.vertices_a.copy(), pr.structure.directions.copy()
        history.append({"round": "start", "delta_pl": pr.delta_pl_after, "status": pr.status,
                        "iterations": pr.iterations})
    r = _solve_rounds(solver, s0, sc, a_cur, e_cur, rounds=rounds, hard_tol=hard_tol,
                      fixed_e=fixed_e, history=history, stop_unconverged=stop_unconverged)
    out = SupportStructure(r.a, r.a + r.e, s0.faces, s0.edges, s0.edge_family,
                           metadata=dict(s0.metadata), family_depth_ratio=s0.family_depth_ratio)
    dist_ref = float("nan")
    if sc.reference is not None:
        _, dref, _ = closest_points(sc.reference[0], sc.reference[1], r.a)
        dist_ref = float(np.max(dref) / sc.edge_length)
    after = out.delta_pl
    success = r.ok and (hard_tol is None or after <= hard_tol)
    status = r.status
    if r.ok and not success:
        status = f"{status}; delta_pl {after:.3g} above hard_tol {hard_tol:.3g}"
    return SupportOptimizationResult(out, success, status, time.perf_counter() - t_start,
                                     r.iterations, before, after, dist_ref, r.history)


#: IPOPT stops whose last iterate is a usable answer (the others are failures)
_USABLE_STATUS = ("Solve_Succeeded", "Solved_To_Acceptable_Level", "Maximum_Iterations_Exceeded",
                  "Search_Direction_Becomes_Too_Small", "Maximum_CpuTime_Exceeded")


def _soft_then_hard(structure, reference, weights, planarity_tol: float,
                    **options) -> SupportOptimizationResult:
    """Eq. (8) with soft planarity, then (if ``delta_pl`` is still above ``planarity_tol``)
    with planarity as a hard constraint from that result; one result for both."""
    if not planarity_tol > 0:
        raise ValueError(f"planarity_tol must be > 0, got {planarity_tol}")
    soft = optimize_support(structure, reference, weights, planarity_tol=None, **options)
    if soft.delta_pl_after <= planarity_tol and soft.status in _USABLE_STATUS:
        # planar enough: an IPOPT stop at its iteration limit only leaves fairness and
        # proximity short of their optimum
        return dataclasses.replace(soft, success=True, status=(
            soft.status if soft.success else f"delta_pl {soft.delta_pl_after:.3g} <= "
            f"{planarity_tol:.3g}; IPOPT stopped: {soft.status}"))
    hard = optimize_support(soft.structure, reference, weights, hard_tol=planarity_tol,
                            planarity_tol=None, **options)
    status = (f"soft planarity left delta_pl {soft.delta_pl_after:.3g} (> {planarity_tol:.3g}); "
              f"with planarity as a hard constraint: {hard.status}")
    if not hard.success:
        status += (f". The fins are not planar enough for flat sheet parts (delta_pl "
                   f"{hard.delta_pl_after:.3g}); try a finer fin spacing, more rounds, or "
                   "method='projection'")
    return SupportOptimizationResult(
        hard.structure, hard.success, status, soft.solve_seconds + hard.solve_seconds,
        soft.iterations + hard.iterations, soft.delta_pl_before, hard.delta_pl_after,
        hard.distance_to_reference, soft.history + [dict(h, stage="hard") for h in hard.history])


def _diagonal_sine(a, e, edges) -> np.ndarray:
    """Sine of the angle between the diagonals ``b_j - a_i`` and ``b_i - a_j`` of every fin, (E,)."""
    i, j = edges[:, 0], edges[:, 1]
    d1 = a[j] + e[j] - a[i]
    d2 = a[i] + e[i] - a[j]
    den = np.linalg.norm(d1, axis=1) * np.linalg.norm(d2, axis=1)
    return np.linalg.norm(np.cross(d1, d2), axis=1) / np.where(den > 0, den, 1.0)


def _fin_residual_jacobian(a, e, edges):
    """Normalized signed fin planarity (E,) and its gradient blocks w.r.t. a_i, a_j, e_i, e_j."""
    i, j = edges[:, 0], edges[:, 1]
    u = a[j] - a[i]
    d1 = a[j] + e[j] - a[i]
    d2 = a[i] + e[i] - a[j]
    c12 = np.cross(d1, d2)
    c2u = np.cross(d2, u)
    cu1 = np.cross(u, d1)
    det = np.einsum("ij,ij->i", u, c12)
    scale = np.linalg.norm(c12, axis=1) * 0.5 * (np.linalg.norm(d1, axis=1) + np.linalg.norm(d2, axis=1))
    scale = np.maximum(scale, 1e-300)
    r = det / scale
    g_ai = (-c12 - c2u + cu1) / scale[:, None]
    g_aj = -g_ai
    g_ei = cu1 / scale[:, None]
    g_ej = c2u / scale[:, None]
    return r, g_ai, g_aj, g_ei, g_ej


def _project_support(structure, reference, *, hard_tol, rounds, max_iter, fixed_e):
    """Gauss-Newton projection onto planar fins with a~ on the tangent planes of A."""
    import time

    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    t_start = time.perf_counter()
    s0 = structure
    n, E = len(s0.vertices_a), len(s0.edges)
    a, e = s0.vertices_a.copy(), s0.directions.copy()
    before = s0.delta_pl
    ref = _reference_arrays(reference)
    if ref is not None:
        from .mesh import average_edge_length

        delta = average_edge_length(*ref)
        fnrm = _face_normals(*ref)
    else:
        delta = float(np.linalg.norm(a[s0.edges[:, 1]] - a[s0.edges[:, 0]], axis=1).mean())
    i, j = s0.edges[:, 0], s0.edges[:, 1]
    # metric: moving a node costs 1 per unit/delta, changing e costs 1 per unit (e ~ fin depth)
    wa, we = 1.0 / delta ** 2, 1.0 / max(float(np.linalg.norm(e, axis=1).mean()), 1e-12) ** 2
    iters, history, status = 0, [], "max_iter reached"
    target = 0.5 * hard_tol
    converged = False
    for rnd in range(max(1, int(rounds))):
        if ref is not None:
            cp, _, tri = closest_points(ref[0], ref[1], a)
            nrm = fnrm[tri]
        else:
            cp, nrm = None, None
        for _ in range(int(max_iter)):
            r, g_ai, g_aj, g_ei, g_ej = _fin_residual_jacobian(a, e, s0.edges)
            res_t = np.einsum("ij,ij->i", a - cp, nrm) / delta if ref is not None else np.zeros(0)
            if np.abs(r).max() <= target and (res_t.size == 0 or np.abs(res_t).max() <= 1e-10):
                converged = True
                break
            iters += 1
            cols_a = lambda v: (3 * v[:, None] + np.arange(3)[None]).ravel()
            rows = [np.repeat(np.arange(E), 3), np.repeat(np.arange(E), 3)]
            cols = [cols_a(i), cols_a(j)]
            vals = [g_ai.ravel(), g_aj.ravel()]
            if not fixed_e:
                rows += [np.repeat(np.arange(E), 3), np.repeat(np.arange(E), 3)]
                cols += [3 * n + cols_a(i), 3 * n + cols_a(j)]
                vals += [g_ei.ravel(), g_ej.ravel()]
            nr = E
            rr = [r]
            if ref is not None:
                rows.append(E + np.repeat(np.arange(n), 3))
                cols.append(cols_a(np.arange(n)))
                vals.append((nrm / delta).ravel())
                rr.append(res_t)
                nr += n
            J = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                              shape=(nr, 6 * n))
            winv = np.r_[np.full(3 * n, 1.0 / wa), np.full(3 * n, 1.0 / we if not fixed_e else 0.0)]
            JW = J @ sp.diags(winv)
            K = (JW @ J.T).tocsc()
            K = K + sp.identity(nr) * (1e-12 * K.diagonal().mean())
            lam = spla.spsolve(K, np.concatenate(rr))
            dx = -(JW.T @ lam)
            a = a + dx[:3 * n].reshape(n, 3)
            e = e + dx[3 * n:].reshape(n, 3)
        cur = SupportStructure(a, a + e, s0.faces, s0.edges, s0.edge_family, metadata=dict(s0.metadata),
                               family_depth_ratio=s0.family_depth_ratio)
        history.append({"round": rnd, "delta_pl": cur.delta_pl, "iterations": iters})
    out = SupportStructure(a, a + e, s0.faces, s0.edges, s0.edge_family, metadata=dict(s0.metadata),
                           family_depth_ratio=s0.family_depth_ratio)
    after = out.delta_pl
    if ref is not None:
        _, dref, _ = closest_points(ref[0], ref[1], a)
        dist_ref = float(np.max(dref) / delta)
    else:
        dist_ref = float("nan")
    success = converged and after <= hard_tol
    status = "converged" if success else f"not converged: delta_pl {after:.3g} (target {hard_tol:.3g})"
    return SupportOptimizationResult(out, success, status, time.perf_counter() - t_start, iters,
                                     before, after, dist_ref, history)


class _HessianEntries:
    """Entries of the Lagrangian Hessian, gathered block by block: symbolic values (casadi)
    and, per value, the global (row, column) it adds to. :meth:`function` sums them into the
    upper triangle with one constant sparse matrix product."""

    def __init__(self) -> None:
        self.values: list = []
        self.rows: list[np.ndarray] = []
        self.cols: list[np.ndarray] = []
        self.src: list[np.ndarray] = []
        self.size = 0

    def add(self, values, rows, cols, order=None) -> None:
        """``values`` (m,) symbolic; entry ``order[k]`` of them adds to ``(rows[k], cols[k])``
        (``order`` defaults to ``arange(m)``)."""
        m = len(rows)
        self.values.append(values)
        self.rows.append(np.asarray(rows))
        self.cols.append(np.asarray(cols))
        self.src.append(self.size + (np.arange(m) if order is None else np.asarray(order)))
        self.size += m

    def function(self, ca, x, par, lam_f, lam_g):
        """casadi Function (x, p, lam_f, lam_g) -> upper triangle of the summed Hessian."""
        import scipy.sparse as sp

        rows, cols = np.concatenate(self.rows), np.concatenate(self.cols)
        src = np.concatenate(self.src)
        # upper triangle only (symmetric blocks: mirror the lower entries)
        lo = rows > cols
        rows[lo], cols[lo] = cols[lo], rows[lo].copy()
        nx = int(x.numel())
        ukey, inv = np.unique(cols.astype(np.int64) * nx + rows, return_inverse=True)
        ur, uc = (ukey % nx).astype(np.int64), (ukey // nx).astype(np.int64)
        # entries mirrored from the lower triangle must not be double counted: keep the
        # strictly-lower copies out (the per-fin and L^T L blocks contain both halves)
        keep = ~lo | (rows == cols)
        S = sp.csr_matrix((np.ones(int(keep.sum())), (inv[keep], src[keep])),
                          shape=(len(ukey), self.size)).tocoo()
        Sdm = ca.DM.triplet(S.row.tolist(), S.col.tolist(), ca.DM(S.data), len(ukey), self.size)
        values = ca.mtimes(Sdm, ca.vertcat(*self.values))
        H = ca.MX(ca.Sparsity.triplet(nx, nx, ur.tolist(), uc.tolist()), values)
        return ca.Function("nlp_hess_l", [x, par, lam_f, lam_g], [H],
                           ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])


def _fin_blocks(entries: _HessianEntries, ca, fin, x, n, E, i, j, fixed_e, constrained,
                lam_f, lam_g, c_pl) -> None:
    """Per fin the 12x12 (6x6 with e fixed) Hessian of ``lam_f c_pl dist^2 + lam_g plan``
    (SX, mapped over all ``E`` fins), placed at the fin's nodes ``i``, ``j``."""
    nv = 6 if fixed_e else 12
    z = ca.SX.sym("z", 12)
    lf, lg = ca.SX.sym("lf"), ca.SX.sym("lg")
    d_k, p_k = fin(z[0:3], z[3:6], z[6:9], z[9:12])
    hk = ca.hessian(lf * c_pl * d_k ** 2 + lg * p_k, z[:nv])[0]
    hk_map = ca.Function("fin_hess", [z, lf, lg], [ca.vec(ca.densify(hk))]).map(E, "serial")
    A = ca.reshape(x[:3 * n], 3, n)
    Em = ca.DM(np.zeros((3, n))) if fixed_e else ca.reshape(x[3 * n:], 3, n)
    il, jl = i.tolist(), j.tolist()
    Z = ca.vertcat(A[:, il], A[:, jl], Em[:, il], Em[:, jl])
    values = ca.vec(hk_map(Z, ca.repmat(lam_f, 1, E), lam_g.T if constrained else ca.DM.zeros(1, E)))
    # global index of each of the nv local variables of every fin, (E, nv)
    three = np.arange(3)
    gl = [3 * i[:, None] + three, 3 * j[:, None] + three]
    if not fixed_e:
        gl += [3 * n + 3 * i[:, None] + three, 3 * n + 3 * j[:, None] + three]
    gl = np.concatenate(gl, axis=1)
    r_loc, c_loc = np.meshgrid(np.arange(nv), np.arange(nv), indexing="ij")  # value q = c*nv + r
    q = (c_loc * nv + r_loc).ravel()
    entries.add(values, gl[:, r_loc.ravel()].ravel(), gl[:, c_loc.ravel()].ravel(),
                order=(np.arange(E)[:, None] * nv * nv + q[None, :]).ravel())


def _tangent_blocks(entries: _HessianEntries, ca, N_, n, lam_f, c_tan) -> None:
    """Tangent-plane proximity ``c_tan (n_k . (a_k - p_k))^2``: 3x3 blocks ``2 c_tan n n^T``
    per node, with the normals ``N_`` (3, n) an NLP parameter."""
    ab = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]
    nn = ca.vertcat(*[N_[a, :] * N_[b, :] for a, b in ab])  # (6, n), node-major when vec'd
    k = np.arange(n)
    rows = np.stack([3 * k + a for a, _ in ab], axis=1).ravel()
    cols = np.stack([3 * k + b for _, b in ab], axis=1).ravel()
    entries.add(lam_f * 2.0 * c_tan * ca.vec(nn), rows, cols)


def _constant_blocks(entries: _HessianEntries, ca, n, fixed_e, with_ref, bnd_mask, lam_f, *,
                     c_tan, c_e, c_fair, c_reg, L) -> None:
    """Constant blocks of eq. (8)'s quadratic terms: fairness (``L^T L`` per coordinate),
    the regularizer, tangent distance without a reference (or on the boundary) and the
    proximity of e."""
    LtL = (L.T @ L).tocoo()
    cr = [3 * LtL.row + d for d in range(3)]
    cc = [3 * LtL.col + d for d in range(3)]
    cv = [2.0 * c_fair * LtL.data] * 3
    diag_a = np.full(n, 2.0 * c_reg)
    if not with_ref:
        diag_a = diag_a + 2.0 * c_tan
    elif bnd_mask is not None:
        diag_a = diag_a + 2.0 * c_tan * bnd_mask
    cr.append(np.arange(3 * n))
    cc.append(np.arange(3 * n))
    cv.append(np.repeat(diag_a, 3))
    if not fixed_e:
        cr.append(3 * n + np.arange(3 * n))
        cc.append(3 * n + np.arange(3 * n))
        cv.append(np.full(3 * n, 2.0 * c_e))
    entries.add(lam_f * ca.DM(np.concatenate(cv)), np.concatenate(cr), np.concatenate(cc))


def _assembled_hessian(ca, fin, x, par, N_, n, E, i, j, fixed_e, constrained, with_ref, bnd_mask, *,
                       c_pl, c_tan, c_e, c_fair, c_reg, L):
    """casadi Function (x, p, lam_f, lam_g) -> upper triangle of the Lagrangian Hessian.

    Per fin the 12x12 Hessian of ``lam_f c_pl dist^2 + lam_g plan`` (SX, mapped over all
    fins); the quadratic terms of eq. (8) add constant (or parameter-bilinear) blocks. All
    entries are summed into the global sparsity by one constant sparse matrix product.
    """
    lam_f = ca.MX.sym("lam_f")
    lam_g = ca.MX.sym("lam_g", E if constrained else 0)
    entries = _HessianEntries()
    _fin_blocks(entries, ca, fin, x, n, E, i, j, fixed_e, constrained, lam_f, lam_g, c_pl)
    if with_ref:
        _tangent_blocks(entries, ca, N_, n, lam_f, c_tan)
    _constant_blocks(entries, ca, n, fixed_e, with_ref, bnd_mask, lam_f, c_tan=c_tan, c_e=c_e,
                     c_fair=c_fair, c_reg=c_reg, L=L)
    return entries.function(ca, x, par, lam_f, lam_g)
