"""Triangle-mesh helpers: loading, validation, adjacency, Laplacian, normals.

Everything here takes and returns plain numpy arrays (vertices ``(n, 3)`` float,
faces ``(F, 3)`` int) and is built on trimesh where trimesh already has the piece.
Lengths are in model units (whatever the mesh file uses).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import trimesh
from torsal.core.inputs import check_input

from .mesh_files import SUPPORTED_FORMATS, MeshError, RawMesh, read_mesh_file

__all__ = [
    "MeshError",
    "MeshMerge",
    "MERGE_TOLERANCE",
    "load_mesh",
    "merge_vertices",
    "drop_duplicate_faces",
    "rows_per_vertex",
    "read_mesh_file",
    "validate_mesh",
    "edge_face_adjacency",
    "unique_edges",
    "average_edge_length",
    "face_areas",
    "area_vector",
    "vertex_normals",
    "umbrella_laplacian",
    "boundary_edges",
    "boundary_vertices",
]

_SUPPORTED = SUPPORTED_FORMATS
_MAX_LISTED = 10

#: Vertices closer than this times the bounding-box diagonal are one vertex: files split them
#: at texture seams or per-face normals (PLY), or never share them (STL). A design surface has no
#: two distinct vertices a millionth of its size apart; single-precision files (binary STL) round
#: coordinates to about 1e-7 of it.
MERGE_TOLERANCE = 1e-6


def _listed(idx) -> str:
    idx = np.asarray(idx).ravel()
    shown = ", ".join(str(int(i)) for i in idx[:_MAX_LISTED])
    more = f" and {idx.size - _MAX_LISTED} more" if idx.size > _MAX_LISTED else ""
    return f"[{shown}{more}]"


@dataclass(frozen=True)
class MeshMerge:
    """How a file's vertices became the mesh's vertices (see :func:`merge_vertices`).

    Attributes
    ----------
    file_vertices : int
        Vertex records in the file (STL: three per triangle).
    vertices : int
        Vertices of the mesh after merging and dropping unused ones.
    file_to_merged : (file_vertices,) int
        The mesh vertex of each file vertex; -1 for a file vertex in no face.
    tolerance : float
        Absolute merge distance used, model units (``MERGE_TOLERANCE`` times the diagonal).
    polygons : int
        Faces with more than three corners that were fan-triangulated.
    format : str
        The file format as read (``"obj"``, ``"stl binary"`` ...).
    duplicate_faces : int
        Triangles the file lists more than once (same corners, same winding, after merging:
        slicers write every STL facet twice), dropped; see :func:`drop_duplicate_faces`.
    """

    file_vertices: int
    vertices: int
    file_to_merged: np.ndarray
    tolerance: float
    polygons: int = 0
    format: str = ""
    duplicate_faces: int = 0

    @property
    def unused(self) -> int:
        """File vertices that are in no face (dropped)."""
        return int((self.file_to_merged < 0).sum())

    @property
    def merged(self) -> int:
        """File vertices that were merged into another one at the same position."""
        return self.file_vertices - self.unused - self.vertices

    @property
    def identity(self) -> bool:
        """True when the mesh's vertices are the file's, one for one, in file order."""
        return self.vertices == self.file_vertices

    def describe(self) -> str:
        """One line for people, e.g. ``8 vertices (24 in the file: 16 merged ...)``."""
        if self.identity:
            text = f"{self.vertices} vertices as in the file"
        else:
            parts = []
            if self.merged:
                parts.append(f"{self.merged} merged with a vertex at the same position "
                             f"(within {self.tolerance:.3g})")
            if self.unused:
                parts.append(f"{self.unused} in no face, dropped")
            text = f"{self.vertices} vertices ({self.file_vertices} in the file: {'; '.join(parts)})"
        if self.polygons:
            text += f"; {self.polygons} polygons split into triangles"
        if self.duplicate_faces:
            text += (f"; {self.duplicate_faces} duplicate faces dropped (the file lists the same "
                     "triangle more than once)")
        return text

    @property
    def vertex_order(self) -> str:
        """How the mesh's vertices are ordered, in words (for report files)."""
        if self.identity:
            return "as in the file"
        return ("the file's vertex records merged by position, in the order each position "
                "first appears in the file" + (" (facet by facet, corner by corner)"
                                               if self.format.startswith("stl") else ""))

    def row_convention(self, per: str) -> str:
        """Which mesh vertex row ``i`` of a per-vertex file belongs to, in words.

        ``per`` is what :meth:`to_merged` returned (or ``"position"`` for rows that carry
        their point). Written into analysis.json and printed, so the order used is never
        implicit.
        """
        if per == "vertex":
            return "row i is vertex i of the file (the mesh keeps the file's vertices one for one)"
        if per == "file vertex":
            return ("row i is vertex record i of the file" + (
                " (corner i % 3 of facet i // 3)" if self.format.startswith("stl") else "")
                + "; rows of records merged into one vertex agree")
        if per == "position":
            return "each row 'x y z dx dy dz' is matched to the mesh vertex at x y z"
        return (f"row i is mesh vertex i: {self.vertex_order}"
                + ("; an STL file has no vertex order of its own, so give one row per facet "
                   "corner or 'x y z dx dy dz' rows to be independent of it"
                   if self.format.startswith("stl") else ""))

    def as_dict(self) -> dict:
        """For report files: counts, the tolerance and the vertex order (no per-vertex map)."""
        return {"format": self.format, "file_vertices": self.file_vertices,
                "vertices": self.vertices, "merged": self.merged, "unused": self.unused,
                "merge_tolerance": self.tolerance, "polygons_triangulated": self.polygons,
                "duplicate_faces_dropped": self.duplicate_faces, "vertex_order": self.vertex_order}

    def to_merged(self, values, *, what: str = "values", rtol: float = 1e-6):
        """Per-vertex rows given per merged vertex or per file vertex -> per merged vertex.

        Parameters
        ----------
        values : (k, ...) array
            ``k`` is either :attr:`vertices` (used as given) or :attr:`file_vertices` (rows of
            file vertices merged into one must agree to ``rtol`` of the largest value; rows of
            unused vertices are ignored).
        what : str
            What the rows are, for messages (``"directions file d.txt"``).

        Returns
        -------
        values : (vertices, ...) array
        per : str
            ``"vertex"`` (file and mesh vertices are the same), ``"merged vertex"`` or
            ``"file vertex"``: which the rows were taken as.

        Examples
        --------
        >>> m = MeshMerge(4, 3, np.array([0, 1, 0, 2]), 0.0)
        >>> rows, per = m.to_merged(np.array([[1.], [2.], [1.], [3.]]))
        >>> rows.ravel().tolist(), per
        ([1.0, 2.0, 3.0], 'file vertex')
        """
        values = np.asarray(values)
        k = len(values)
        if self.identity and k == self.vertices:
            return values, "vertex"
        if k == self.vertices:
            return values, "merged vertex"
        if k != self.file_vertices:
            raise MeshError(
                f"{what}: {k} rows, but the mesh has {self.vertices} vertices"
                + (f" ({self.file_vertices} in the file before merging); give one row per vertex "
                   "of either" if not self.identity else "; give one row per vertex"))
        out = rows_per_vertex(
            values, self.file_to_merged, self.vertices, what=what, rtol=rtol,
            same="file vertices at the same position",
            fix=f"give the same row to vertices at one position, or one row per merged vertex "
                f"({self.vertices})")
        return out, "file vertex"


def rows_per_vertex(values, row_vertex, n_vertices: int, *, what: str = "values",
                    same: str = "the same vertex", fix: str = "give one row per vertex",
                    rtol: float = 1e-6) -> np.ndarray:
    """Rows that each name a mesh vertex -> one row per vertex; rows of one vertex must agree.

    Parameters
    ----------
    values : (k, ...) array
    row_vertex : (k,) int
        The mesh vertex of each row; -1: the row is ignored.
    n_vertices : int
        Every vertex ``0 .. n_vertices - 1`` needs at least one row.
    what, same, fix : str
        For messages: what the rows are, what rows of one vertex have in common, what to do.
    rtol : float
        Rows of one vertex agree to ``rtol`` times the largest value.

    Returns
    -------
    (n_vertices, ...) array
        The first row of each vertex.

    Examples
    --------
    >>> rows_per_vertex(np.array([[1.], [2.], [1.]]), np.array([1, 0, 1]), 2).ravel().tolist()
    [2.0, 1.0]
    """
    values = np.asarray(values)
    row_vertex = np.asarray(row_vertex, dtype=np.int64)
    used = np.flatnonzero(row_vertex >= 0)
    target = row_vertex[used]
    missing = np.setdiff1d(np.arange(n_vertices), target)
    if missing.size:
        raise MeshError(f"{what}: mesh vertices {_listed(missing)} have no row; {fix}")
    out = np.empty((n_vertices,) + values.shape[1:], dtype=values.dtype)
    out[target[::-1]] = values[used[::-1]]  # the first row of each vertex wins
    scale = float(np.nanmax(np.abs(values[used]))) if used.size else 0.0
    diff = np.abs(values[used] - out[target]).reshape(len(used), -1).max(axis=1)
    bad = np.flatnonzero(~(diff <= rtol * max(scale, 1e-300)))
    if bad.size:
        r = used[bad[0]]
        first = int(np.flatnonzero(row_vertex == row_vertex[r])[0])
        raise MeshError(
            f"{what}: rows {first} and {r} belong to {same} (mesh vertex {row_vertex[r]}) but "
            f"differ ({_listed(used[bad])} disagree); {fix}")
    return out


#: Coordinates beyond this (any unit) are a broken file, not a building: squared, they overflow.
MAX_COORDINATE = 1e30


def _check_coordinates(v: np.ndarray) -> None:
    """Raise :class:`MeshError` for NaN, infinite or absurdly large coordinates, (n, 3) float."""
    bad_v = np.flatnonzero(~np.isfinite(v).all(axis=1))
    if bad_v.size:
        raise MeshError(f"vertices {_listed(bad_v)} have NaN or infinite coordinates; fix or remove them")
    huge = np.flatnonzero((np.abs(v) > MAX_COORDINATE).any(axis=1))
    if huge.size:
        raise MeshError(f"vertices {_listed(huge)} have coordinates beyond {MAX_COORDINATE:g}; "
                        "the file is damaged or in the wrong units")


def merge_vertices(vertices: np.ndarray, faces: np.ndarray, *,
                   tolerance: float | None = MERGE_TOLERANCE):
    """Merge vertices at the same position and drop vertices in no face.

    Vertices closer than ``tolerance`` times the bounding-box diagonal of the used vertices
    (pairs found with a k-d tree, merged transitively) become one vertex at the position of the
    first of them in the file. Merged vertices keep the file's order (by their first file
    vertex), so a file without duplicates and unused vertices comes back unchanged.

    Parameters
    ----------
    vertices : (n, 3) float
        The file's vertices.
    faces : (F, 3) int
        Indices into ``vertices``.
    tolerance : float or None
        Relative merge distance; ``None`` merges nothing (unused vertices are still dropped).

    Returns
    -------
    vertices : (m, 3) float
    faces : (F, 3) int
        Same faces, same order, indices into the merged vertices.
    merge : MeshMerge

    Examples
    --------
    >>> v = np.array([[0., 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [5, 5, 5]])
    >>> mv, mf, m = merge_vertices(v, np.array([[0, 1, 2], [3, 5, 4]]))
    >>> mf.tolist(), m.vertices, m.merged, m.unused
    ([[0, 1, 2], [1, 3, 2]], 4, 2, 1)
    """
    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces, dtype=np.int64)
    n = len(v)
    used = np.zeros(n, bool)
    used[f.ravel()] = True
    used_idx = np.flatnonzero(used)
    label = np.arange(n)  # the group of each file vertex: the smallest file index in it
    tol_abs = 0.0
    pts = v[used_idx]
    if tolerance is not None and used_idx.size and np.isfinite(pts).all():
        diag = float(np.linalg.norm(np.ptp(pts, axis=0)))
        tol_abs = float(tolerance) * diag
        # exact duplicates first (STL has each vertex ~6 times), then near ones between those
        uniq, first, inverse = np.unique(pts, axis=0, return_index=True, return_inverse=True)
        inverse = inverse.ravel()
        group = np.arange(len(uniq))
        if tol_abs > 0 and len(uniq) > 1:
            from scipy.sparse.csgraph import connected_components
            from scipy.spatial import cKDTree

            pairs = cKDTree(uniq).query_pairs(tol_abs, output_type="ndarray")
            if len(pairs):
                graph = sp.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                                      shape=(len(uniq), len(uniq)))
                group = connected_components(graph, directed=False)[1]
        # representative of each group: its smallest file index
        rep = np.full(group.max() + 1, n, dtype=np.int64)
        np.minimum.at(rep, group[inverse], used_idx)
        label[used_idx] = rep[group[inverse]]
    reps = np.unique(label[used_idx])  # sorted: file order
    new_index = np.full(n, -1, dtype=np.int64)
    new_index[reps] = np.arange(len(reps))
    file_to_merged = np.full(n, -1, dtype=np.int64)
    file_to_merged[used_idx] = new_index[label[used_idx]]
    merge = MeshMerge(file_vertices=n, vertices=len(reps), file_to_merged=file_to_merged,
                      tolerance=tol_abs)
    return v[reps], file_to_merged[f], merge


def drop_duplicate_faces(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop triangles listed more than once with the same winding; refuse opposite windings.

    Two faces are the same when their corners are the same vertices in the same cyclic order
    (``(0, 1, 2)``, ``(1, 2, 0)``); the first in the file is kept. Slicers and some STL
    exporters write every facet twice; after :func:`merge_vertices` those are such duplicates.
    The same triangle with the opposite winding is the two sides of a surface (a double-sided
    export) or a fold onto itself: that raises :class:`MeshError` naming both faces, since which
    side is meant is not in the file.

    Parameters
    ----------
    faces : (F, 3) int

    Returns
    -------
    faces : (G, 3) int
        The faces kept, in file order.
    kept : (G,) int
        Their indices into the given faces.

    Examples
    --------
    >>> f, kept = drop_duplicate_faces(np.array([[0, 1, 2], [1, 2, 3], [2, 0, 1]]))
    >>> f.tolist(), kept.tolist()
    ([[0, 1, 2], [1, 2, 3]], [0, 1])
    """
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(f) < 2:
        return f, np.arange(len(f))
    # each face rotated to start at its smallest index: equal rows are the same oriented face
    start = np.argmin(f, axis=1)
    rolled = f[np.arange(len(f))[:, None], (start[:, None] + np.arange(3)) % 3]
    _, first = np.unique(rolled, axis=0, return_index=True)
    kept = np.sort(first)
    # the same corners in the opposite cyclic order: rows (a, b, c) and (a, c, b)
    flipped = rolled[:, [0, 2, 1]]
    uniq = rolled[kept]
    key = np.unique(np.concatenate([uniq, flipped[kept]]), axis=0, return_counts=True)
    if key[1].max(initial=1) > 1:
        both = {tuple(r) for r in key[0][key[1] > 1]}
        bad = [int(k) for k in kept if tuple(rolled[k]) in both and rolled[k, 1] != rolled[k, 2]]
        if bad:
            raise MeshError(
                f"faces {_listed(bad)} are the same triangles twice with opposite windings: the "
                "surface lies on itself there (both sides of it exported, or a fold); export one "
                "side, one face per triangle", faces=bad)
    return f[kept], kept


def load_mesh(path: str | Path, *, validate: bool = True,
              merge_tolerance: float | None = MERGE_TOLERANCE) -> trimesh.Trimesh:
    """Load a triangle mesh from OBJ, PLY, STL or OFF, keeping the file's vertices, and validate it.

    The file is read as it is (:func:`~torsal.geometry.mesh_files.read_mesh_file`: OBJ corners
    index the file's ``v`` records whatever their texture or normal indices; headers are checked
    against the content; a truncated file is an error naming the line). Then vertices at the same
    position (within ``merge_tolerance`` times the bounding-box diagonal: STL, and files split at
    seams or normals) are merged and vertices in no face dropped, by :func:`merge_vertices`; the
    merge is reported in ``mesh.metadata["merge"]`` (a :class:`MeshMerge`). A file without
    duplicates or unused vertices keeps its vertices one for one, in file order. Triangles the
    file lists twice (the same corners and winding after merging: slicers' STL) are dropped and
    counted (:func:`drop_duplicate_faces`). Nothing else is repaired: see :func:`validate_mesh`
    for what is checked; its messages name the file lines of the faces concerned.

    Parameters
    ----------
    path : str or Path
        Mesh file in model units.
    validate : bool, default True
        Run :func:`validate_mesh` and raise :class:`MeshError` on a bad mesh.
    merge_tolerance : float or None, default ``MERGE_TOLERANCE`` (1e-6)
        Relative merge distance; ``None``: keep coincident vertices apart.

    Returns
    -------
    trimesh.Trimesh
        With ``process=False``: the merged vertices and faces; ``metadata["merge"]`` says how.

    Examples
    --------
    >>> mesh = load_mesh("examples/facade_patch.obj")  # doctest: +SKIP
    >>> mesh.metadata["merge"].describe()  # doctest: +SKIP
    '1089 vertices as in the file'
    """
    path = check_input(path, "mesh file")
    raw: RawMesh = read_mesh_file(path)
    if len(raw.faces) == 0:
        raise MeshError(f"{path}: contains no triangle faces ({len(raw.vertices)} vertices only); "
                        "export the surface as a triangle mesh")
    try:
        _check_coordinates(raw.vertices)
    except MeshError as exc:
        raise MeshError(f"{path}: {exc}") from None
    v, f, merge = merge_vertices(raw.vertices, raw.faces, tolerance=merge_tolerance)
    kept = np.arange(len(f))
    try:
        f, kept = drop_duplicate_faces(f)
        if validate:
            validate_mesh(v, f)
    except MeshError as exc:
        note = (f" (after merging {merge.merged} file vertices within {merge.tolerance:.3g} "
                "of another)") if merge.merged else ""
        where = "" if exc.faces is None else _file_place(path, raw, kept[exc.faces])
        raise MeshError(f"{path}: {exc}{where}{note}", faces=exc.faces) from None
    merge = dataclasses.replace(merge, polygons=raw.polygons, format=raw.format,
                                duplicate_faces=len(raw.faces) - len(f))
    return trimesh.Trimesh(v, f, process=False, metadata={"merge": merge, "file": str(path)})


def _file_place(path: Path, raw: RawMesh, faces: np.ndarray) -> str:
    """Where faces (indices into ``raw.faces``) are in the file, for a message: its lines, or
    for a binary file its face / facet records."""
    faces = np.asarray(faces, dtype=np.int64)
    lines = raw.face_lines
    if lines is None and raw.format == "obj":  # read by the fast reader: read again for lines
        lines = read_mesh_file(path, face_lines=True).face_lines
    if lines is not None:
        shown = np.unique(lines[faces])
        return f"; file {'line' if shown.size == 1 else 'lines'} {_listed(shown)[1:-1]}"
    if raw.polygons == 0:  # binary, one face per record: the face index is the record
        what = "facets" if raw.format.startswith("stl") else "face records"
        return f"; {what} {_listed(faces)} of the file, counted from 0"
    return ""


def _edge_keys(pairs: np.ndarray, n: int) -> np.ndarray:
    """Encode vertex pairs as int64 keys ``i * n + j`` (1-D sorting is far faster than rows)."""
    return pairs[:, 0].astype(np.int64) * np.int64(n) + pairs[:, 1]


def unique_edges(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique undirected edges of a triangle mesh.

    Parameters
    ----------
    faces : (F, 3) int

    Returns
    -------
    edges : (E, 2) int
        Sorted vertex pairs ``i < j``, in lexicographic order.
    face_edges : (F, 3) int
        ``face_edges[f, k]`` is the edge opposite to corner ``k`` of face ``f``
        (edge between corners ``k+1`` and ``k+2``).

    Examples
    --------
    >>> edges, fe = unique_edges(np.array([[0, 1, 2], [2, 1, 3]]))
    >>> edges.tolist(), fe.tolist()
    ([[0, 1], [0, 2], [1, 2], [1, 3], [2, 3]], [[2, 1, 0], [3, 4, 2]])
    """
    faces = np.asarray(faces, dtype=np.int64)
    n = int(faces.max()) + 1 if faces.size else 1
    # edge k of a face is opposite to corner k: (v1, v2), (v2, v0), (v0, v1)
    directed = np.stack([faces[:, [1, 2]], faces[:, [2, 0]], faces[:, [0, 1]]], axis=1).reshape(-1, 2)
    lo, hi = np.minimum(directed[:, 0], directed[:, 1]), np.maximum(directed[:, 0], directed[:, 1])
    keys, inverse = np.unique(lo * np.int64(n) + hi, return_inverse=True)
    edges = np.stack([keys // n, keys % n], axis=1)
    return edges, inverse.reshape(-1, 3)


def edge_face_adjacency(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Edge-face adjacency.

    Parameters
    ----------
    faces : (F, 3) int

    Returns
    -------
    edges : (E, 2) int
        Unique undirected edges, ``i < j``.
    edge_faces : (E, 2) int
        The faces on either side of each edge; ``-1`` on a boundary edge.
        Raises :class:`MeshError` if an edge has more than two faces.

    Examples
    --------
    >>> edges, ef = edge_face_adjacency(np.array([[0, 1, 2], [2, 1, 3]]))
    >>> ef[(edges == [1, 2]).all(1)]
    array([[0, 1]])
    """
    edges, face_edges = unique_edges(faces)
    return edges, _edge_faces(edges, face_edges)


def _edge_faces(edges: np.ndarray, face_edges: np.ndarray) -> np.ndarray:
    """(E, 2) faces of each edge (-1 on the boundary); raises on non-manifold edges."""
    flat = face_edges.ravel()
    counts = np.bincount(flat, minlength=len(edges))
    if np.any(counts > 2):
        bad = np.flatnonzero(counts > 2)
        bad_faces = np.flatnonzero(np.isin(face_edges, bad).any(axis=1))
        raise MeshError(
            f"non-manifold: {bad.size} edges are shared by more than two faces "
            f"(e.g. edge {edges[bad[0]].tolist()}); faces {_listed(bad_faces)} touch them. "
            "Split the surface so every edge has at most two faces.", faces=bad_faces)
    face_of = np.repeat(np.arange(len(face_edges)), 3)
    order = np.argsort(flat, kind="stable")
    sorted_edges = flat[order]
    edge_faces = np.full((len(edges), 2), -1, dtype=np.int64)
    first = np.ones(len(sorted_edges), dtype=bool)
    first[1:] = sorted_edges[1:] != sorted_edges[:-1]
    edge_faces[sorted_edges[first], 0] = face_of[order][first]
    edge_faces[sorted_edges[~first], 1] = face_of[order][~first]
    return edge_faces


def face_areas(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Triangle areas, (F,), in model units squared."""
    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces)
    return 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)


def polygon_areas(vertices: np.ndarray, faces) -> np.ndarray:
    """Areas of polygons given by vertex index lists (any number of corners, planar or not),
    (F,), in model units squared: each polygon split into the fan of triangles from its first
    corner; faces of fewer than 3 corners have area 0.

    Examples
    --------
    >>> polygon_areas(np.array([[0., 0, 0], [2, 0, 0], [2, 1, 0], [0, 1, 0]]), [[0, 1, 2, 3], [0, 1, 2]])
    array([2., 1.])
    """
    v = np.asarray(vertices, dtype=float)
    out = np.zeros(len(faces))
    for k, face in enumerate(faces):
        p = v[np.asarray(face, dtype=np.int64)]
        if len(p) >= 3:
            out[k] = 0.5 * np.linalg.norm(np.cross(p[1:-1] - p[0], p[2:] - p[0]), axis=1).sum()
    return out


def area_vector(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Vector area of the mesh, (3,): the sum of face normals times face areas.

    Its direction is the mean outward normal (which side a facade or canopy faces); its
    length the area of the mesh projected on the plane orthogonal to it.

    Examples
    --------
    >>> area_vector(np.array([[0., 0, 0], [2, 0, 0], [0, 1, 0]]), np.array([[0, 1, 2]]))
    array([0., 0., 1.])
    """
    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces, dtype=np.int64)
    return 0.5 * np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]).sum(axis=0)


def average_edge_length(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Mean length of the unique edges: the paper's normalizing length delta (Wang et al. 2013, 4.1)."""
    edges, _ = unique_edges(faces)
    v = np.asarray(vertices, dtype=float)
    return float(np.linalg.norm(v[edges[:, 0]] - v[edges[:, 1]], axis=1).mean())


def validate_mesh(vertices: np.ndarray, faces: np.ndarray) -> None:
    """Raise :class:`MeshError` naming the problem if the mesh cannot carry a congruence.

    Checks, in order: at least one face; vertices finite (no NaN/inf, none beyond
    ``MAX_COORDINATE``); face indices in
    range; no face that repeats a vertex or has (relative) zero area; every edge shared
    by at most two faces (manifold); neighbouring faces consistently oriented.

    Parameters
    ----------
    vertices : (n, 3) float
    faces : (F, 3) int
    """
    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces)
    if f.ndim != 2 or len(f) == 0:
        raise MeshError("the mesh has no faces; torsal needs a triangle mesh with at least one face")
    if f.shape[1] != 3:
        raise MeshError(f"faces must be triangles, got {f.shape[1]} vertices per face; triangulate the mesh")
    if v.ndim != 2 or v.shape[1] != 3:
        raise MeshError(f"vertices must be an (n, 3) array, got shape {v.shape}")
    _check_coordinates(v)
    if f.min() < 0 or f.max() >= len(v):
        bad = np.flatnonzero(((f < 0) | (f >= len(v))).any(axis=1))
        raise MeshError(f"faces {_listed(bad)} refer to vertices that do not exist (mesh has {len(v)})",
                        faces=bad)
    repeated = np.flatnonzero((f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 2] == f[:, 0]))
    if repeated.size:
        raise MeshError(f"degenerate faces {_listed(repeated)} use the same vertex twice; remove them",
                        faces=repeated)
    area = face_areas(v, f)
    edges, face_edges = unique_edges(f)
    delta = np.linalg.norm(v[edges[:, 0]] - v[edges[:, 1]], axis=1).mean()
    degenerate = np.flatnonzero(area <= 1e-12 * delta**2)
    if degenerate.size:
        raise MeshError(
            f"degenerate faces {_listed(degenerate)} have zero area (collinear vertices); "
            "remove or re-triangulate them", faces=degenerate)
    _edge_faces(edges, face_edges)  # raises on non-manifold edges
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    keys = np.sort(_edge_keys(directed, len(v)))
    repeated_keys = keys[1:][keys[1:] == keys[:-1]]
    if repeated_keys.size:
        dup = np.stack([repeated_keys // len(v), repeated_keys % len(v)], axis=1)
        bad_faces = np.flatnonzero(
            np.isin(f, dup[:, 0]).any(axis=1) & np.isin(f, dup[:, 1]).any(axis=1)
        )
        raise MeshError(
            f"inconsistent orientation: neighbouring faces {_listed(bad_faces)} traverse a shared "
            "edge in the same direction; flip them so all faces wind the same way "
            "(e.g. trimesh.repair.fix_winding)", faces=bad_faces)


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals, (n, 3).

    Each face contributes its unit normal times its area (that is, half its cross
    product) to its three vertices; trimesh's sparse vertex-face incidence does the sum.
    Vertices in no face get NaN.
    """
    v = np.asarray(vertices, dtype=float)
    f = np.asarray(faces, dtype=np.int64)
    weighted = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    incidence = trimesh.geometry.index_sparse(len(v), f)
    n = np.asarray(incidence @ weighted)
    length = np.linalg.norm(n, axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return n / length


def umbrella_laplacian(faces: np.ndarray, n_vertices: int | None = None) -> sp.csr_matrix:
    """The paper's umbrella Laplacian ``L`` with ``(L x)_i = x_i - 1/deg(i) sum_{j~i} x_j``.

    Wang et al. 2013, 4.1 (f_fair). Returns an (n, n) sparse matrix; isolated vertices
    get a zero row.
    """
    edges, _ = unique_edges(faces)
    n = int(n_vertices if n_vertices is not None else np.asarray(faces).max() + 1)
    i = np.concatenate([edges[:, 0], edges[:, 1]])
    j = np.concatenate([edges[:, 1], edges[:, 0]])
    adj = sp.csr_matrix((np.ones(len(i)), (i, j)), shape=(n, n))
    deg = np.asarray(adj.sum(axis=1)).ravel()
    inv = np.divide(1.0, deg, out=np.zeros_like(deg), where=deg > 0)
    return (sp.diags((deg > 0).astype(float)) - sp.diags(inv) @ adj).tocsr()


def boundary_edges(faces: np.ndarray) -> np.ndarray:
    """Edges with exactly one face, (B, 2) int."""
    edges, edge_faces = edge_face_adjacency(faces)
    return edges[edge_faces[:, 1] < 0]


def boundary_vertices(faces: np.ndarray) -> np.ndarray:
    """Sorted indices of vertices on a boundary edge, (b,) int."""
    return np.unique(boundary_edges(faces))
