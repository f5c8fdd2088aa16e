"""The term catalogue: default weights, one term's data (:class:`Term`) and input checks.

Every energy and constraint that :class:`~torsal.geometry.optimize.CongruenceProblem` offers
is a :class:`Term`: an element function of :mod:`torsal.geometry.optimize.terms` with the variable
indices, mesh data and NLP parameters of its elements.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import casadi as ca
import numpy as np
import scipy.sparse as sp

from . import terms as T

#: Default weight per energy (Wang et al. 2013, Fig. 12; see the module docstring).
DEFAULT_WEIGHTS: dict[str, float] = {
    "normal": 2.0,
    "fair": 1.0,
    "fair_torsal": 10.0,
    "perpendicular": 1.0,
    "parallel": 0.1,
    "through_points": 1.0,
    "torsal_direction": 0.1,
    "torsal_plane": 20.0,
    "align": 200.0,
    "closeness": 1.0,
}

_KINDS = ("vertices", "faces", "edges")


@dataclass
class Term:
    """One energy or constraint over a set of elements."""

    name: str
    constraint: bool
    element: T.ElementTerm | None      # None for the quadratic fair term
    idx: np.ndarray                    # (m, 3k) global variable indices
    data: np.ndarray                   # (m, q)
    par: np.ndarray                    # (m, r) current parameter values
    elements: np.ndarray               # (m,) element ids (vertex / face / edge index)
    scale: float = 1.0                 # normalization of an energy (1/|V'|, ...)
    weight: float = 1.0
    lower: float = 0.0                 # constraint bounds on the element value
    upper: float = math.inf
    matrix: sp.spmatrix | None = None   # quadratic energy scale * e^T Q e over this block
    offset: int = 0                      # first direction coordinate of the block (quadratic terms)
    kind: str = "value"                  # how a constraint is measured (see measure.KINDS)
    bound: float = math.nan              # the user's bound, in the constraint's own units
    block: int = 0                       # the aligned congruence its elements belong to
    lift: bool = False                   # rows k . (u, v, w) = lifted variables (nlp.Built._lift)
    between: str = "planes"              # a torsal-angle bound's angle (terms.TorsalAngleBetween)
    element_weights: np.ndarray | None = None   # (m,) each element's factor, folded into ``par``
    #                      (f_perp, f_par: ``vertex_weights``; f_dir: ``face_weights``); None: all 1

    @property
    def size(self) -> int:
        return len(self.elements)

    def signature(self):
        """What the built NLP depends on: the kernel, the elements, the bounds and the shapes
        of ``par`` and ``data``. Their values are NLP parameters (a weight, a light direction,
        a bound, mesh A's points: a moved vertex re-solves the built NLP)."""
        k = (("quadratic", self.matrix.shape, hash(sp.csr_matrix(self.matrix).data.tobytes()))
             if self.element is None else (self.element.fn.name(), self.element.k))
        return (self.constraint, k, self.idx.shape, hash(self.idx.tobytes()),
                np.shape(self.data), self.par.shape, self.lower, self.upper)


def _as_index(sel, n: int, what: str) -> np.ndarray:
    """Vertex/face subset -> sorted unique int array; accepts None (all), ints or a bool mask."""
    if sel is None:
        return np.arange(n)
    arr = np.asarray(sel)
    if arr.dtype == bool:
        if arr.shape != (n,):
            raise ValueError(f"a boolean {what} mask needs shape ({n},), got {arr.shape}")
        return np.flatnonzero(arr)
    arr = np.atleast_1d(arr)
    if arr.size == 0:
        raise ValueError(f"the {what} subset is empty; pass None for all {what}")
    if not np.issubdtype(arr.dtype, np.integer):
        raise TypeError(f"{what} must be integer indices or a boolean mask, got dtype {arr.dtype}")
    bad = arr[(arr < 0) | (arr >= n)]
    if bad.size:
        raise IndexError(f"{what} indices {bad[:10].tolist()} are out of range; the mesh has {n} {what}")
    if np.unique(arr).size != arr.size:
        raise ValueError(f"{what} indices repeat; pass each element once")
    return arr.astype(np.int64)


def _points(p, m: int, what: str) -> np.ndarray:
    """(3,) or (m, 3) points -> finite (m, 3) array, with a clear error for bad input."""
    p = np.asarray(p, dtype=float)
    if p.shape == (3,):
        p = np.broadcast_to(p, (m, 3))
    if p.shape != (m, 3):
        raise ValueError(f"{what} must have shape (3,) or ({m}, 3), got {p.shape}")
    if not np.isfinite(p).all():
        raise ValueError(f"{what} contains NaN or infinite values")
    return np.array(p)


def _unit_rows(d, m: int, what: str) -> np.ndarray:
    """(3,) or (m, 3) directions -> (m, 3) unit rows, with a clear error for bad input."""
    d = _points(d, m, what)
    n = np.linalg.norm(d, axis=1)
    if np.any(n < 1e-12):
        raise ValueError(f"{what} rows {np.flatnonzero(n < 1e-12)[:10].tolist()} are zero vectors; "
                         "a direction needs a length")
    return d / n[:, None]


def _var_index(vertices: np.ndarray, offset: int) -> np.ndarray:
    """Vertex ids (m, k) -> variable ids (m, 3k) ``[3v0, 3v0+1, 3v0+2, 3v1, ...]``."""
    v = np.asarray(vertices, dtype=np.int64)
    if v.ndim == 1:
        v = v[:, None]
    return (offset + 3 * v[:, :, None] + np.arange(3)).reshape(len(v), -1)


def _stroke_barycentric(a: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Barycentric coordinates of a segment through each face barycenter along ``t``.

    ``a`` (m, 3, 3) corners, ``t`` (m, 3) wanted direction. ``t`` is projected into the face
    plane and written ``alpha a_u + beta a_v``; the endpoints are ``c -+ s (-alpha-beta, alpha,
    beta)`` with ``s`` as large as keeps them in the triangle. Returns (m, 6): ``w(p1), w(p2)``.
    """
    a_u, a_v = a[:, 1] - a[:, 0], a[:, 2] - a[:, 0]
    g = np.stack([np.stack([np.einsum("ij,ij->i", a_u, a_u), np.einsum("ij,ij->i", a_u, a_v)], -1),
                  np.stack([np.einsum("ij,ij->i", a_u, a_v), np.einsum("ij,ij->i", a_v, a_v)], -1)], 1)
    rhs = np.stack([np.einsum("ij,ij->i", a_u, t), np.einsum("ij,ij->i", a_v, t)], -1)
    ab = np.linalg.solve(g, rhs[..., None])[..., 0]
    db = np.stack([-ab[:, 0] - ab[:, 1], ab[:, 0], ab[:, 1]], -1)
    big = np.abs(db).max(axis=1)
    if np.any(big < 1e-12):
        bad = np.flatnonzero(big < 1e-12)[:10].tolist()
        raise ValueError(f"strokes of rows {bad} are orthogonal to their faces (or zero); "
                         "draw them along the surface")
    s = (1.0 / 3.0) / big
    c = np.full((len(t), 3), 1.0 / 3.0)
    return np.concatenate([c - s[:, None] * db, c + s[:, None] * db], axis=1)


def _penalty_term(t: Term) -> Term:
    """Constraint -> energy ``mean(min(c - lower, 0)^2 + max(c - upper, 0)^2)`` for L-BFGS."""
    fn = t.element.fn
    x, d, p = (ca.SX.sym(s, fn.size1_in(i)) for i, s in enumerate("xdp"))
    c = fn(x, d, p)
    v = ca.fmin(c - t.lower, 0) ** 2 if math.isfinite(t.lower) else 0
    if math.isfinite(t.upper):
        v = v + ca.fmax(c - t.upper, 0) ** 2
    el = T.ElementTerm("penalty:" + t.name, ca.Function("pen_" + fn.name(), [x, d, p], [v]), t.element.k)
    return Term("penalty:" + t.name, False, el, t.idx, t.data, t.par, t.elements, scale=1.0 / t.size,
                 weight=1e3)
