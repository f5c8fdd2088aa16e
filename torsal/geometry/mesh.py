"""Triangle-mesh helpers: loading, validation, adjacency, Laplacian, normals.

Everything here takes and returns plain numpy arrays (vertices ``(n, 3)`` float,
faces ``(F, 3)`` int) and is built on trimesh where trimesh already has the piece.
Lengths are in model units (whatever the mesh file uses).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.sparse as sp
import trimesh
from torsal.core.errors import TorsalError

__all__ = [
    "MeshError",
    "load_mesh",
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

_SUPPORTED = (".obj", ".ply", ".stl", ".off")
_MAX_LISTED = 10


class MeshError(TorsalError, ValueError):
    """A mesh that torsal cannot work on; the message names the problem and the fix."""


def _listed(idx) -> str:
    idx = np.asarray(idx).ravel()
    shown = ", ".join(str(int(i)) for i in idx[:_MAX_LISTED])
    more = f" and {idx.size - _MAX_LISTED} more" if idx.size > _MAX_LISTED else ""
    return f"[{shown}{more}]"


def load_mesh(path: str | Path, *, validate: bool = True) -> trimesh.Trimesh:
    """Load a triangle mesh from OBJ, PLY, STL or OFF and validate it.

    Vertex order is kept as in the file (so per-vertex direction files stay valid),
    except for STL, which has no shared vertices: there coincident vertices are merged.
    Nothing is silently repaired: see :func:`validate_mesh` for what is checked.

    Parameters
    ----------
    path : str or Path
        Mesh file in model units.
    validate : bool, default True
        Run :func:`validate_mesh` and raise :class:`MeshError` on a bad mesh.

    Returns
    -------
    trimesh.Trimesh
        With ``process=False``: vertices and faces exactly as read.

    Examples
    --------
    >>> mesh = load_mesh("examples/facade_7a.obj")  # doctest: +SKIP
    >>> mesh.faces.shape  # doctest: +SKIP
    (2048, 3)
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"mesh file not found: {path}")
    if path.suffix.lower() not in _SUPPORTED:
        raise MeshError(
            f"{path}: unsupported mesh format {path.suffix!r}; use one of {', '.join(_SUPPORTED)}"
        )
    if path.stat().st_size == 0:
        raise MeshError(f"{path}: the file is empty; export the surface again")
    try:
        loaded = trimesh.load(path, force="mesh", process=False)
    except Exception as exc:  # trimesh raises many types for broken files
        raise MeshError(f"{path}: could not be read as a mesh ({exc})") from exc
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise MeshError(f"{path}: contains no triangle faces; export the surface as a triangle mesh")
    mesh = loaded
    if path.suffix.lower() == ".stl":
        mesh.merge_vertices()
    if validate:
        try:
            validate_mesh(mesh.vertices, mesh.faces)
        except MeshError as exc:
            raise MeshError(f"{path}: {exc}") from None
    return mesh


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
            "Split the surface so every edge has at most two faces."
        )
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

    Checks, in order: at least one face; vertices finite (no NaN/inf); face indices in
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
    bad_v = np.flatnonzero(~np.isfinite(v).all(axis=1))
    if bad_v.size:
        raise MeshError(f"vertices {_listed(bad_v)} have NaN or infinite coordinates; fix or remove them")
    if f.min() < 0 or f.max() >= len(v):
        bad = np.flatnonzero(((f < 0) | (f >= len(v))).any(axis=1))
        raise MeshError(f"faces {_listed(bad)} refer to vertices that do not exist (mesh has {len(v)})")
    repeated = np.flatnonzero((f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 2] == f[:, 0]))
    if repeated.size:
        raise MeshError(f"degenerate faces {_listed(repeated)} use the same vertex twice; remove them")
    area = face_areas(v, f)
    edges, face_edges = unique_edges(f)
    delta = np.linalg.norm(v[edges[:, 0]] - v[edges[:, 1]], axis=1).mean()
    degenerate = np.flatnonzero(area <= 1e-12 * delta**2)
    if degenerate.size:
        raise MeshError(
            f"degenerate faces {_listed(degenerate)} have zero area (collinear vertices); "
            "remove or re-triangulate them"
        )
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
            "(e.g. trimesh.repair.fix_winding)"
        )


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
