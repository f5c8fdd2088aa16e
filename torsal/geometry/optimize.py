"""Congruence optimization as a casadi NLP solved by IPOPT (Wang et al. 2013, 4.1, eq. (9)).

The mesh A is fixed; the variables are the line directions ``e_i`` (3 per vertex), so the
lines are ``a_i + lambda e_i`` and mesh B has vertices ``b_i = a_i + e_i``. A
:class:`CongruenceProblem` collects energies (eq. (9) and section 4.1) and constraints,
each over a vertex, face or edge subset, and :meth:`CongruenceProblem.solve` minimizes::

    f = sum_t w_t f_t(e)    subject to   c_j(e) >= 0,   ||e_i|| = 1

Assembly. Every term is one casadi ``SX`` function of one element
(:mod:`torsal.geometry.terms`) mapped over its elements with ``Function.map``. Value,
gradient, constraint Jacobian and the exact Hessian of the Lagrangian are assembled from
the mapped per-element derivatives (gradient, Jacobian rows, upper triangle of the local
Hessian) by constant sparse scatter matrices, and handed to IPOPT through ``nlpsol``'s
``grad_f`` / ``jac_g`` / ``hess_lag`` options. This keeps building and every Hessian
evaluation linear in the mesh size (casadi's automatic Hessian of a mapped graph colours
the whole problem and was ~100x slower on a 1k-vertex mesh). MUMPS is the linear solver.

Weights, light directions, target points, strokes and constraint margins are NLP
parameters: calling a term method again with the same element subset only changes
parameters, and the next :meth:`~CongruenceProblem.solve` re-uses the built solver,
warm-started from the last solution (the paper's interactive design loop).

Default weights are the paper's Fig. 12 values (the column alignment of that table is
ambiguous; these are the values the rows agree on most): ``normal 2``, ``fair 1``,
``fair_torsal 10``, ``perpendicular 1`` (rows 7b, 9, 11; 7a/7c use 10), ``parallel 0.1``
(row 9; 7c uses .2, 11 uses .01), ``torsal_plane 20`` (7d; 13 uses 5000),
``torsal_direction 0.1`` (7a, 7d), ``align 200`` (11). Terms the paper has no weight for:
``through_points 1``, ``closeness 1``.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable

import casadi as ca
import numpy as np
import scipy.sparse as sp

from . import terms as T
from .congruence import Congruence
from .mesh import edge_face_adjacency, umbrella_laplacian
from torsal.core.errors import TorsalError

__all__ = ["CongruenceProblem", "OptimizationResult", "OptimizationError", "DEFAULT_WEIGHTS"]

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


class OptimizationError(TorsalError, RuntimeError):
    """A solve failed and ``raise_on_failure=True`` was given; ``.result`` holds the details."""

    def __init__(self, message: str, result: "OptimizationResult"):
        super().__init__(message)
        self.result = result


@dataclass
class OptimizationResult:
    """Outcome of :meth:`CongruenceProblem.solve`.

    Attributes
    ----------
    congruence : Congruence
        The optimized congruence (same mesh A, new directions).
    success : bool
        Solver converged, no NaN, and every constraint holds within ``constraint_tol``.
    status : str
        The solver's own words (IPOPT return status, scipy message) plus our diagnosis.
    iterations : int
    build_seconds : float
        Time spent building the NLP and solver in this call (0 when the built solver was re-used).
    solve_seconds : float
    energies_before, energies_after : dict[str, float]
        Unweighted, normalized value of every energy (as printed in the paper), plus
        ``"total"``: the weighted objective of eq. (9).
    max_violation : dict[str, float]
        Largest violation of each constraint (0 where it holds); ``unit_length`` is ``max |
        ||e_i||^2 - 1 |``.
    worst_constraint : tuple or None
        ``(name, element index, violation)`` of the worst violated constraint, None if all hold.
    congruences : tuple of Congruence
        All optimized congruences: this problem's first, then those joined by ``align_with``.
    solver : str
    objective : float
    constraints_active : bool or None
        IPOPT with inequality constraints: False when the solve without them already met
        them (see ``try_unconstrained`` of :meth:`CongruenceProblem.solve`), True when the
        constrained problem was solved; None otherwise.
    working_set : dict[str, ndarray] or None
        When IPOPT imposed only some inequality constraints (the working set, see
        ``try_unconstrained`` of :meth:`CongruenceProblem.solve`): the element ids (faces,
        vertices, ...) it imposed, by constraint name; all others hold with slack. None when
        every inequality was imposed or none was needed.
    """

    congruence: Congruence
    success: bool
    status: str
    iterations: int
    build_seconds: float
    solve_seconds: float
    energies_before: dict
    energies_after: dict
    max_violation: dict
    worst_constraint: tuple | None = None
    congruences: tuple = ()
    solver: str = "ipopt"
    objective: float = float("nan")
    constraints_active: bool | None = None
    working_set: dict | None = None

    def summary(self) -> str:
        """One line per fact, for logs and the CLI."""
        lines = [f"{self.solver}: {'ok' if self.success else 'FAILED'} ({self.status}), "
                 f"{self.iterations} iterations, build {self.build_seconds:.2f} s, "
                 f"solve {self.solve_seconds:.2f} s"]
        if self.constraints_active is False:
            lines.append("  inequality constraints inactive: met by the solve without them")
        if self.working_set is not None:
            n = sum(len(v) for v in self.working_set.values())
            lines.append(f"  inequality constraints imposed on {n} elements (the working set); "
                         "the others hold with slack")
        for k in self.energies_after:
            lines.append(f"  {k:>18}: {self.energies_before.get(k, float('nan')):.4g} -> "
                         f"{self.energies_after[k]:.4g}")
        for k, v in self.max_violation.items():
            lines.append(f"  violation {k:>8}: {v:.3g}")
        return "\n".join(lines)


@dataclass
class _Term:
    """One energy or constraint over a set of elements (internal)."""

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

    @property
    def size(self) -> int:
        return len(self.elements)

    def signature(self):
        k = ("quadratic", self.matrix.shape) if self.element is None else (self.element.fn.name(),
                                                                            self.element.k)
        return (self.constraint, k, self.idx.shape, hash(self.idx.tobytes()),
                hash(np.asarray(self.data).tobytes()), self.par.shape)


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


def _chart_functions():
    """Per-vertex gnomonic chart ``e(z) = (f0 + z1 f1 + z2 f2) / sqrt(1 + |z|^2)``: value (3),
    Jacobian (3x2, column-major), the upper triangle of the Hessian of ``<g, e(z)>`` (3),
    ``J^T g`` (2) and, for a vertex pair, ``q J_i^T J_j`` (2x2 column-major)."""
    z = ca.SX.sym("z", 2)
    fr = ca.SX.sym("fr", 9)
    g = ca.SX.sym("g", 3)
    e = (fr[0:3] + z[0] * fr[3:6] + z[1] * fr[6:9]) / ca.sqrt(1.0 + ca.dot(z, z))
    jac = ca.jacobian(e, z)
    h = ca.hessian(ca.dot(g, e), z)[0]
    j6 = ca.SX.sym("j", 6)
    j6b = ca.SX.sym("jb", 6)
    q = ca.SX.sym("q")
    ja, jb = ca.reshape(j6, 3, 2), ca.reshape(j6b, 3, 2)
    return (ca.Function("chart", [z, fr], [e]),
            ca.Function("chart_jac", [z, fr], [ca.vec(jac)]),
            ca.Function("chart_hess", [z, fr, g], [ca.vertcat(h[0, 0], h[0, 1], h[1, 1])]),
            ca.Function("chart_jtg", [j6, g], [ca.mtimes(ja.T, g)]),
            ca.Function("pair_jj", [j6, j6b, q], [q * ca.vec(ca.mtimes(ja.T, jb))]))


def _kernel_cache_dir():
    import os
    from pathlib import Path

    return Path(os.environ.get("TORSAL_KERNEL_CACHE", Path.home() / ".cache" / "torsal" / "kernels"))


def _jit(fn: ca.Function) -> ca.Function:
    """``fn`` compiled to a shared library with the system C compiler, cached on disk.

    casadi generates the C code; its hash (with the casadi version) names the library in
    :func:`_kernel_cache_dir` (``$TORSAL_KERNEL_CACHE``), so each kernel is compiled once per
    machine (about a second) and loaded with ``casadi.external`` afterwards. Falls back to
    the interpreted ``fn`` if anything fails (no compiler, read-only cache, ...).
    """
    import hashlib
    import os
    import shutil
    import subprocess
    import tempfile

    try:
        cc = shutil.which(os.environ.get("CC", "gcc")) or shutil.which("cc")
        if cc is None:
            return fn
        with tempfile.TemporaryDirectory(prefix="torsal_jit_") as tmp:
            # generated into a private folder (never the caller's working directory); the
            # fixed file name keeps the code, and so the hash, independent of the process
            cg = ca.CodeGenerator("tk.c", {"with_header": False})
            cg.add(fn)
            src = cg.generate(tmp + os.sep)
            code = open(src).read()
            h = hashlib.sha1((ca.__version__ + code).encode()).hexdigest()[:16]
            cache = _kernel_cache_dir()
            lib = cache / f"tk_{h}.so"
            if not lib.exists():
                cache.mkdir(parents=True, exist_ok=True)
                out = os.path.join(tmp, "tk.so")
                subprocess.run([cc, "-O2", "-shared", "-fPIC", src, "-o", out, "-lm"],
                               check=True, capture_output=True, timeout=120)
                # copy under a private name in the cache, then rename: a process that loads
                # the kernel concurrently never sees a half-written library
                fd, part = tempfile.mkstemp(prefix=".tk_", suffix=".so.part", dir=cache)
                os.close(fd)
                try:
                    shutil.copyfile(out, part)
                    os.replace(part, lib)
                finally:
                    if os.path.exists(part):
                        os.unlink(part)
            return ca.external(fn.name(), str(lib))
    except Exception:   # pragma: no cover - any failure keeps the interpreted kernel
        return fn


class _Local:
    """Per-element functions of one term, in the NLP's variables (internal).

    All take ``(x, data, par, jl)`` where ``x`` are the element's ``3k`` direction
    coordinates and ``jl`` the ``3x2`` chart Jacobians of its ``k`` vertices (``6k``, empty
    unless ``tangent``). With ``J = blockdiag(jl)`` (identity without ``tangent``):
    ``grad = J^T g_e``, ``hess = coef * triu(J^T H_e J)`` (the chain rule without the chart's
    curvature, which the assembler adds per vertex), ``jac = g_e^T J``, ``lag_e = coef * g_e``.
    """

    def __init__(self, fn: ca.Function, k: int, tangent: bool, jit: bool = False, constraint: bool = False):
        x = ca.SX.sym("x", 3 * k)
        d = ca.SX.sym("d", fn.size1_in(1))
        p = ca.SX.sym("p", fn.size1_in(2))
        jl = ca.SX.sym("jl", 6 * k if tangent else 0)
        coef = ca.SX.sym("coef")
        v = fn(x, d, p)
        ge = ca.gradient(v, x)
        he = ca.hessian(v, x)[0]
        if tangent:
            jb = ca.diagcat(*[ca.reshape(jl[6 * c:6 * c + 6], 3, 2) for c in range(k)])
            g, h, j = ca.mtimes(jb.T, ge), ca.mtimes([jb.T, he, jb]), ca.mtimes(ge.T, jb)
        else:
            g, h, j = ge, he, ge.T
        ins = [x, d, p, jl]
        h = ca.triu(ca.densify(h) if tangent else h)
        hsp = h.sparsity()
        self.h_rows = np.array(hsp.row(), dtype=np.int64)
        self.h_cols = np.array(hsp.get_col(), dtype=np.int64)
        hnz = ca.vertcat(*[h.nz[i] for i in range(h.nnz())]) if h.nnz() else ca.SX(0, 1)
        j = ca.densify(j) if tangent else j
        self.j_cols = np.array(j.sparsity().get_col(), dtype=np.int64)
        jnz = ca.vertcat(*[j.nz[i] for i in range(j.nnz())]) if j.nnz() else ca.SX(0, 1)
        self.val = ca.Function(fn.name() + "_val", ins, [v])
        self.grad = ca.Function(fn.name() + "_grad", ins, [g])
        self.hess = ca.Function(fn.name() + "_hess", ins + [coef], [coef * hnz])
        self.jac = ca.Function(fn.name() + "_jac", ins, [jnz])
        self.lag_e = ca.Function(fn.name() + "_lag", ins + [coef], [coef * ge])
        if jit:
            # values stay interpreted: casadi differentiates the NLP's f and g itself
            self.grad, self.hess = _jit(self.grad), _jit(self.hess)
            if constraint:
                self.jac = _jit(self.jac)
            if tangent:
                self.lag_e = _jit(self.lag_e)


def _to_casadi(m: sp.spmatrix) -> ca.DM:
    m = sp.csc_matrix(m)
    m.sort_indices()
    spy = ca.Sparsity(m.shape[0], m.shape[1], m.indptr.astype(np.int64).tolist(),
                      m.indices.astype(np.int64).tolist())
    return ca.DM(spy, m.data)


def _bound_violation(g: np.ndarray, lower, upper) -> np.ndarray:
    """Elementwise violation of ``lower <= g <= upper`` (0 where it holds)."""
    return np.maximum(np.maximum(lower - g, g - upper), 0.0)


# pass 2 of a solve (see CongruenceProblem._solve_ipopt) is tried when at most this share of the
# inequality constraints is violated without them: then the answer is close to feasible and
# few elements need barrier terms; otherwise (e.g. a 60 degree torsal angle on a shading
# canopy, where half of them are violated) the working set would grow round after round
_WORKING_SET_MAX_SHARE = 0.05


def _near_bounds(g: np.ndarray, b: "_Built", share: float = 0.1) -> np.ndarray:
    """Inequalities within ``share`` of their constraint's median slack of a bound, or violated."""
    slack = np.minimum(g - b.lbg, b.ubg - g)
    out = np.zeros(g.size, dtype=bool)
    for rows in b.g_slices:
        sl = slack[rows]
        fin = np.isfinite(sl)
        scale = float(np.median(np.abs(sl[fin]))) if fin.any() else 0.0
        out[rows] = ~fin | (sl <= share * scale)
    return out


def _working_ids(b: "_Built", mask: np.ndarray) -> dict:
    """Element ids of the imposed inequality constraints, by constraint name."""
    return {t.name: t.elements[mask[rows]] for t, rows in zip(b.cons, b.g_slices) if t.lower < t.upper}


def _scatter(keys: np.ndarray) -> tuple[np.ndarray, ca.DM]:
    """Unique sorted keys and the 0/1 matrix summing entries with equal keys (CCS order)."""
    ukey, pos = np.unique(keys, return_inverse=True)
    # column c of S has its single 1 in row pos[c]: CCS directly, values filled by casadi
    # (converting a large numpy value array to a DM costs seconds at 100k vertices)
    spy = ca.Sparsity(len(ukey), len(keys), np.arange(len(keys) + 1, dtype=np.int64).tolist(),
                      pos.ravel().astype(np.int64).tolist())
    return ukey, ca.DM(spy, 1.0)


def _ccs(ukey: np.ndarray, nrow: int, ncol: int) -> ca.Sparsity:
    col, row = ukey // nrow, ukey % nrow
    colind = np.searchsorted(col, np.arange(ncol + 1))
    return ca.Sparsity(nrow, ncol, colind.astype(np.int64).tolist(), row.astype(np.int64).tolist())


def tangent_frames(e: np.ndarray) -> np.ndarray:
    """Orthonormal frames ``(f0, f1, f2)`` per direction, ``f0 = e/|e|``, (n, 9)."""
    f0 = e / np.linalg.norm(e, axis=1, keepdims=True)
    axis = np.eye(3)[np.argmin(np.abs(f0), axis=1)]
    f1 = np.cross(f0, axis)
    f1 /= np.linalg.norm(f1, axis=1, keepdims=True)
    f2 = np.cross(f0, f1)
    return np.concatenate([f0, f1, f2], axis=1)


def _from_tangent(z: np.ndarray, frames: np.ndarray) -> np.ndarray:
    z = z.reshape(-1, 2)
    e = frames[:, 0:3] + z[:, :1] * frames[:, 3:6] + z[:, 1:2] * frames[:, 6:9]
    return e / np.sqrt(1.0 + (z * z).sum(axis=1))[:, None]


class _IterationCallback(ca.Callback):
    """casadi iteration callback: forwards (iteration, objective, infeasibility) to Python."""

    def __init__(self, name: str, nx: int, ng: int, np_: int, owner: "CongruenceProblem"):
        ca.Callback.__init__(self)
        self.nx, self.ng, self.np_ = nx, ng, np_
        self.owner = owner
        self.construct(name, {})

    def get_n_in(self):
        return ca.nlpsol_n_out()

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return ca.nlpsol_out(i)

    def get_name_out(self, i):
        return "ret"

    def get_sparsity_in(self, i):
        n = ca.nlpsol_out(i)
        if n == "f":
            return ca.Sparsity.dense(1)
        if n in ("x", "lam_x"):
            return ca.Sparsity.dense(self.nx)
        if n in ("g", "lam_g"):
            return ca.Sparsity.dense(self.ng)
        if n == "lam_p":
            return ca.Sparsity.dense(self.np_)
        return ca.Sparsity(0, 0)

    def eval(self, arg):
        return [ca.DM(1 if self.owner._report_iteration(arg) else 0)]


class _Built:
    """The assembled NLP of one problem structure (internal).

    ``mode``: ``"constraint"`` / ``"renormalize"`` / ``"penalty"`` (variables: the ``3 n``
    direction coordinates) or ``"tangent"`` (``2 n`` gnomonic coordinates around per-vertex
    frames that are NLP parameters, see :func:`_chart_functions`).
    """

    def __init__(self, terms: list[_Term], n_vertices: int, mode: str, jit: bool = False):
        t0 = time.perf_counter()
        self.terms, self.mode, self.n_vertices = terms, mode, n_vertices
        tangent = mode == "tangent"
        dof = 2 if tangent else 3
        n_e = 3 * n_vertices
        n_var = dof * n_vertices
        self.n_var = n_var
        x = ca.MX.sym("x", n_var)
        n_fr = 9 * n_vertices if tangent else 0
        self.n_frames = n_fr
        offsets, n_p = [], n_fr
        for t in terms:
            offsets.append(n_p)
            n_p += 1 + t.par.size
        self.p_offsets, self.n_par = offsets, n_p
        p = ca.MX.sym("p", n_p)
        lam_f = ca.MX.sym("lam_f")
        cons = [t for t in terms if t.constraint]
        g_sizes = [t.size for t in cons]
        self.g_offsets = np.concatenate([[0], np.cumsum(g_sizes)]).astype(np.int64)
        self.g_slices = [slice(int(o), int(o) + n) for o, n in zip(self.g_offsets, g_sizes)]
        n_g = int(sum(g_sizes))
        self.n_g = n_g
        lam_g = ca.MX.sym("lam_g", n_g)

        if tangent:   # e = chart(z, frame) per vertex, mapped once
            Z = ca.reshape(x, 2, n_vertices)
            FR = ca.reshape(p[0:n_fr], 9, n_vertices)
            chart, *derivs = _chart_functions()
            chart_jac, chart_hess, chart_jtg, pair_jj = (_jit(f) for f in derivs) if jit else derivs
            e_all = ca.vec(chart.map(n_vertices)(Z, FR))
            JV = chart_jac.map(n_vertices)(Z, FR)          # (6, n): 3x2 per vertex, column-major
            jv_all = ca.vec(JV)
        else:
            e_all = x

        f = ca.MX(0)
        e_vals, g_parts = [], []
        grad_parts, grad_rows = [], []
        dense_grad = []                 # dense (n_var,) gradient parts (quadratic terms)
        lag_parts, lag_rows = [], []    # Lagrangian gradient in e (tangent: chart curvature)
        dense_lag = []
        h_parts, h_rows, h_cols = [], [], []
        j_parts, j_rows, j_cols = [], [], []
        quad_h = []
        local: dict = {}
        ci = 0
        for t, off in zip(terms, offsets):
            if t.matrix is not None:      # quadratic energy scale * e^T Q e
                Q = sp.coo_matrix(t.matrix)
                Qg = sp.csc_matrix((Q.data, (Q.row + t.offset, Q.col + t.offset)), shape=(n_e, n_e))
                w = p[off]
                qe = ca.mtimes(_to_casadi(Qg), e_all)
                val = t.scale * ca.dot(e_all, qe)
                e_vals.append(val)
                f += w * val
                ge = 2.0 * t.scale * w * qe
                coef = 2.0 * t.scale * w * lam_f
                if not tangent:
                    dense_grad.append(ge)
                    quad_h.append((coef, sp.triu(Qg).tocsc()))
                    continue
                dense_grad.append(ca.vec(chart_jtg.map(n_vertices)(JV, ca.reshape(ge, 3, n_vertices))))
                dense_lag.append(lam_f * ge)
                # J^T Q J: Q = Q1 (x) I3 couples vertices i, j by q_ij I3 -> q_ij J_i^T J_j
                Q1 = sp.coo_matrix(t.matrix[0::3, 0::3])
                vo = t.offset // 3
                up = Q1.row <= Q1.col
                vi, vj, q = Q1.row[up] + vo, Q1.col[up] + vo, Q1.data[up]
                JI = ca.reshape(jv_all[(6 * vi[:, None] + np.arange(6)).ravel().tolist()], 6, len(vi))
                JJ = ca.reshape(jv_all[(6 * vj[:, None] + np.arange(6)).ravel().tolist()], 6, len(vj))
                blocks = pair_jj.map(len(vi))(JI, JJ, ca.DM(q).T * 1.0) * coef   # (4, m): (00, 10, 01, 11)
                # local entries (a, b) -> z ids (2 vi + a, 2 vj + b); keep the upper triangle
                ra = np.array([0, 1, 0, 1])
                rb = np.array([0, 0, 1, 1])
                R = 2 * vi[:, None] + ra
                C = 2 * vj[:, None] + rb
                keep = R <= C
                sel = np.flatnonzero(keep.ravel())
                h_parts.append(ca.vec(blocks)[sel.tolist()])
                h_rows.append(R.ravel()[sel])
                h_cols.append(C.ravel()[sel])
                continue
            el = t.element
            m, r = t.size, el.n_par
            key = (id(el.fn), tangent)
            if key not in local:
                local[key] = _Local(el.fn, el.k, tangent, jit and not el.fn.name().startswith("custom_"),
                                    t.constraint)
            L = local[key]
            verts = t.idx[:, ::3] // 3
            xidx = (dof * verts[:, :, None] + np.arange(dof)).reshape(m, -1)
            X = ca.reshape(e_all[t.idx.ravel().tolist()], t.idx.shape[1], m)
            D = ca.DM(np.ascontiguousarray(t.data.T)) if el.n_data else ca.DM(0, m)
            P = ca.reshape(p[off + 1:off + 1 + m * r], r, m) if r else ca.MX(0, m)
            if tangent:
                jidx = (6 * verts[:, :, None] + np.arange(6)).reshape(m, -1)
                JL = ca.reshape(jv_all[jidx.ravel().tolist()], jidx.shape[1], m)
            else:
                JL = ca.MX(0, m)
            args = (X, D, P, JL)
            if not t.constraint:
                w = p[off]
                val = t.scale * ca.sum2(L.val.map(m)(*args))
                e_vals.append(val)
                f += w * val
                grad_parts.append(t.scale * w * ca.vec(L.grad.map(m)(*args)))
                grad_rows.append(xidx.ravel())
                coef = ca.repmat(t.scale * w * lam_f, 1, m)
            else:
                go = int(self.g_offsets[ci])
                ci += 1
                g_parts.append(ca.vec(L.val.map(m)(*args)))
                j_parts.append(ca.vec(L.jac.map(m)(*args)))
                j_rows.append(np.repeat(go + np.arange(m), len(L.j_cols)))
                j_cols.append(xidx[:, L.j_cols].ravel())
                coef = ca.reshape(lam_g[go:go + m], 1, m)
            if len(L.h_rows):
                h_parts.append(ca.vec(L.hess.map(m)(*args, coef)))
                hr, hc = xidx[:, L.h_rows].ravel(), xidx[:, L.h_cols].ravel()
                h_rows.append(np.minimum(hr, hc))
                h_cols.append(np.maximum(hr, hc))
            if tangent:
                lag_parts.append(ca.vec(L.lag_e.map(m)(*args, coef)))
                lag_rows.append(t.idx.ravel())

        def scatter_dense(parts, rows, n, dense):
            out = ca.MX.zeros(n, 1)
            if parts:
                ukey, S = _scatter(np.concatenate(rows))
                out = ca.densify(ca.MX(_ccs(ukey, n, 1), ca.mtimes(S, ca.vertcat(*parts))))
            for d in dense:
                out = out + d
            return out

        grad = scatter_dense(grad_parts, grad_rows, n_var, dense_grad)
        g = ca.vertcat(*g_parts) if g_parts else ca.MX(0, 1)
        if j_parts:
            jr, jcol = np.concatenate(j_rows), np.concatenate(j_cols)
            ukey, S = _scatter(jcol * n_g + jr)
            jac = ca.MX(_ccs(ukey, n_g, n_var), ca.mtimes(S, ca.vertcat(*j_parts)))
        else:
            jac = ca.MX(n_g, n_var)
        if tangent:   # the chart's own curvature: sum_c (dL/de_c) d2 e_c / dz2, per vertex
            g_lag = scatter_dense(lag_parts, lag_rows, n_e, dense_lag)
            dz = chart_hess.map(n_vertices)(Z, FR, ca.reshape(g_lag, 3, n_vertices))   # (3, n)
            h_parts.append(ca.vec(dz))
            base = 2 * np.arange(n_vertices)
            h_rows.append(np.stack([base, base, base + 1], 1).ravel())
            h_cols.append(np.stack([base, base + 1, base + 1], 1).ravel())
        if h_parts:
            hr, hc = np.concatenate(h_rows), np.concatenate(h_cols)
            ukey, S = _scatter(hc * n_var + hr)
            hess = ca.MX(_ccs(ukey, n_var, n_var), ca.mtimes(S, ca.vertcat(*h_parts)))
        else:
            hess = ca.MX(ca.Sparsity(n_var, n_var))
        for coef, Qg in quad_h:
            hess = hess + coef * _to_casadi(Qg)

        self.x, self.p = x, p
        self.f_expr, self.g_expr = f, g
        self.grad_f = ca.Function("nlp_grad_f", [x, p], [f, grad], ["x", "p"], ["f", "grad"])
        self.jac_g = ca.Function("nlp_jac_g", [x, p], [g, jac], ["x", "p"], ["g", "jac"])
        self.hess_lag = ca.Function("nlp_hess_l", [x, p, lam_f, lam_g], [hess],
                                    ["x", "p", "lam_f", "lam_g"], ["hess"])
        self.energy_names = [t.name for t in terms if not t.constraint]
        self.evaluate = ca.Function("evaluate", [x, p],
                                    [ca.vertcat(*e_vals) if e_vals else ca.MX(0, 1), f, g])
        self.cons = cons
        self.lbg = np.concatenate([np.full(t.size, t.lower) for t in cons]) if cons else np.zeros(0)
        self.ubg = np.concatenate([np.full(t.size, t.upper) for t in cons]) if cons else np.zeros(0)
        self.solvers: dict = {}
        # first Hessian regularization per IPOPT objective scaling (see _hessian_shift)
        self.hessian_shifts: dict[tuple, float] = {}
        self.seconds = time.perf_counter() - t0

    # conversions between directions e (n, 3) and the NLP's (x, frames)
    def pack(self, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        e = np.asarray(e, dtype=float).reshape(-1, 3)
        if self.mode == "tangent":
            return np.zeros(self.n_var), tangent_frames(e)
        return e.ravel().copy(), np.zeros((0, 9))

    def unpack(self, x: np.ndarray, frames: np.ndarray) -> np.ndarray:
        if self.mode == "tangent":
            return _from_tangent(np.asarray(x).ravel(), frames)
        return np.asarray(x, dtype=float).reshape(-1, 3)

    def parameters(self, current: dict | None = None, frames: np.ndarray | None = None) -> np.ndarray:
        """The parameter vector, taking weights and data from ``current`` terms by name."""
        current = current or {}
        p = np.empty(self.n_par)
        if self.n_frames:
            p[:self.n_frames] = frames.ravel()
        for t, off in zip(self.terms, self.p_offsets):
            src = current.get(t.name, t)
            p[off] = src.weight if not t.name.startswith("penalty:") else t.weight
            p[off + 1:off + 1 + t.par.size] = src.par.ravel()
        return p


class CongruenceProblem:
    """An optimization problem over the line directions of a congruence (Wang et al. 2013, 4.1).

    Build it by chaining term and constraint methods, then call :meth:`solve`.

    Parameters
    ----------
    congruence : Congruence
        Mesh A and the initial directions (e.g. ``Congruence.from_normals``).
    weights : dict, optional
        Overrides of :data:`DEFAULT_WEIGHTS` by term name, used when a method gets no ``weight``.
    normalize : {"tangent", "constraint", "renormalize"}
        How ``||e_i|| = 1`` is kept. ``"tangent"`` (default, fastest): every ``e_i`` is a unit
        vector by construction, ``e = (f0 + z1 f1 + z2 f2) / sqrt(1 + z1^2 + z2^2)`` with 2
        variables per vertex around a frame re-centred at the start of every solve (a
        gnomonic chart; halves the KKT system compared to ``"constraint"``).
        ``"constraint"``: ``||e_i||^2 = 1`` as IPOPT equality constraints.
        ``"renormalize"``: the paper's way: no unit constraint; a penalty
        ``mean((||e_i||^2 - 1)^2)`` (weight 1) keeps lengths near 1 during a solve, and the
        directions are renormalized afterwards (and after every round of ``lbfgs``).
    jit : bool, default False
        Compile the per-element kernels to C with the system compiler (casadi codegen; cached
        on disk in ``~/.cache/torsal/kernels`` or ``$TORSAL_KERNEL_CACHE``, so only the first
        build on a machine pays ~1 s per kernel). Evaluations get several times faster:
        use it for large meshes and the interactive loop.

    Notes
    -----
    Every element term sees mesh A in units of ``delta`` (``a / delta``, with unit line
    directions), so the paper's normalizations (``1/delta^2`` in f_norm, ``c_hyp / delta^2``,
    ...) are exact and every kernel is independent of the mesh (compiled once with
    ``jit=True``). For f_fair/t this means ``B = A/delta + e`` in the projection condition
    (its zero set does not depend on the distance of B; see
    :func:`torsal.geometry.terms.fair_torsal_residual_sx`).

    Examples
    --------
    >>> from torsal.geometry.surfaces import facade_patch
    >>> c = Congruence.from_normals(facade_patch(nu=9, nv=7))
    >>> res = (CongruenceProblem(c).normal().fair().perpendicular([0.3, -0.8, -0.5])
    ...        .hyperbolic().solve())
    >>> res.success, bool((res.congruence.hyperbolicity() >= 0).all())
    (True, True)
    """

    def __init__(self, congruence: Congruence, weights: dict | None = None,
                 normalize: str = "tangent", jit: bool = False):
        if not isinstance(congruence, Congruence):
            raise TypeError("CongruenceProblem needs a torsal Congruence (e.g. Congruence.from_normals(mesh))")
        if normalize not in ("tangent", "constraint", "renormalize"):
            raise ValueError(f"normalize must be 'tangent', 'constraint' or 'renormalize', got {normalize!r}")
        weights = dict(weights or {})
        unknown = set(weights) - set(DEFAULT_WEIGHTS)
        if unknown:
            raise ValueError(f"unknown weight names {sorted(unknown)}; known: {sorted(DEFAULT_WEIGHTS)}")
        for k, w in weights.items():
            if not (np.isfinite(w) and w >= 0):
                raise ValueError(f"weight {k!r} must be a finite number >= 0, got {w}")
        self.congruence = congruence
        self.normalize = normalize
        self.jit = bool(jit)
        self.weights = {**DEFAULT_WEIGHTS, **weights}
        self.delta = congruence.delta
        self._blocks: list[Congruence] = [congruence]
        self._offsets: list[int] = [0]
        self._terms: dict[str, _Term] = {}
        self._built: dict[str, _Built] = {}
        self._last: dict | None = None
        self._callback: Callable | None = None
        self._iter = 0
        self._phase_iter, self._iter_cap = 0, None   # iteration cap across solve phases
        self._edges_cache = None

    # ------------------------------------------------------------------ helpers
    @property
    def n_var(self) -> int:
        return int(sum(3 * len(b.vertices) for b in self._blocks))

    @property
    def terms(self) -> dict:
        """Registered terms and constraints by name: ``{name: (kind, weight or None, n_elements)}``."""
        return {k: ("constraint" if t.constraint else "energy", None if t.constraint else t.weight, t.size)
                for k, t in self._terms.items()}

    def _weight(self, name: str, weight) -> float:
        w = self.weights[name] if weight is None else float(weight)
        if not (np.isfinite(w) and w >= 0):
            raise ValueError(f"weight of {name!r} must be a finite number >= 0, got {weight}")
        return w

    def _add(self, term: _Term) -> "CongruenceProblem":
        old = self._terms.get(term.name)
        self._terms[term.name] = term
        if old is not None and old.signature() == term.signature():
            return self   # only parameters / weight changed: keep the built solver
        self._built.clear()
        self._last = None
        return self

    def _face_data(self, faces: np.ndarray, block: int = 0):
        """Corner ids and corner points of A in units of delta (see the class notes)."""
        c = self._blocks[block]
        fv = c.faces[faces]
        return fv, c.vertices[fv].reshape(len(faces), 9) / self.delta

    def _interior_edges(self):
        if self._edges_cache is None:
            f = self.congruence.faces
            edges, ef = edge_face_adjacency(f)
            inner = np.flatnonzero(ef[:, 1] >= 0)
            e, f0, f1 = edges[inner], ef[inner, 0], ef[inner, 1]

            def rotate(face_ids):
                fv = f[face_ids]
                other = (fv != e[:, :1]) & (fv != e[:, 1:])
                c = np.argmax(other, axis=1)
                r = np.arange(len(fv))
                return fv[r, (c + 1) % 3], fv[r, (c + 2) % 3], fv[r, c]

            i, j, k = rotate(f0)
            _, _, l = rotate(f1)
            self._edges_cache = (inner, np.stack([i, j, k, l], axis=1))
        return self._edges_cache

    # ------------------------------------------------------------------ energies
    def fair(self, weight: float | None = None) -> "CongruenceProblem":
        """f_fair = 1/|V| sum ||Delta e_i||^2, umbrella Laplacian (Wang et al. 2013, 4.1).

        Quadratic: ``1/|V| e^T (L^T L (x) I_3) e``; evaluated as a sparse matrix product, its
        Hessian is the constant ``2/|V| L^T L (x) I_3``.

        Examples
        --------
        >>> from torsal.geometry.surfaces import sphere_patch
        >>> p = CongruenceProblem(Congruence.from_normals(sphere_patch(nu=5, nv=5))).fair()
        >>> p.terms["fair"]
        ('energy', 1.0, 25)
        """
        c = self.congruence
        n = len(c.vertices)
        L = umbrella_laplacian(c.faces, n)
        Q = sp.kron((L.T @ L).tocsr(), sp.identity(3), format="csr")
        t = _Term("fair", False, None, np.zeros((n, 0), np.int64), np.zeros((n, 0)), np.zeros((n, 0)),
                  np.arange(n), scale=1.0 / n, weight=self._weight("fair", weight), matrix=Q)
        return self._add(t)

    def normal(self, weight: float | None = None, faces=None) -> "CongruenceProblem":
        """f_norm = 1/(delta^2 |F'|) sum r^2 with r the eq. (7) residual (Wang et al. 2013, 4.1).

        Examples
        --------
        >>> from torsal.geometry.surfaces import sphere_patch
        >>> v, f = sphere_patch(nu=5, nv=5)      # unit sphere: the exact normals are v
        >>> CongruenceProblem(Congruence(v, f, v)).normal().energies()["normal"] < 1e-20
        True
        """
        fi = _as_index(faces, len(self.congruence.faces), "faces")
        fv, a = self._face_data(fi)
        t = _Term("normal", False, T.normality_element(), _var_index(fv, 0), a, np.zeros((len(fi), 0)),
                  fi, scale=1.0 / len(fi), weight=self._weight("normal", weight))
        return self._add(t)

    def fair_torsal(self, weight: float | None = None) -> "CongruenceProblem":
        """f_fair/t: no jump of torsal planes across interior edges (Wang et al. 2013, 4.1).

        ``1/|E_int| sum ||r||^2`` with the residual of
        :func:`torsal.geometry.terms.fair_torsal_residual_sx` (barycentric-coordinate condition,
        denominators cleared, divided by ``delta^4``).

        Examples
        --------
        >>> from torsal.geometry.surfaces import sphere_patch
        >>> p = CongruenceProblem(Congruence.from_normals(sphere_patch(nu=5, nv=5)))
        >>> p.fair_torsal().terms["fair_torsal"][0]
        'energy'
        """
        inner, quad = self._interior_edges()
        if len(inner) == 0:
            raise ValueError("fair_torsal needs interior edges; the mesh has none")
        a = self.congruence.vertices[quad].reshape(len(quad), 12) / self.delta
        t = _Term("fair_torsal", False, T.fair_torsal_element(1.0), _var_index(quad, 0), a,
                  np.zeros((len(quad), 0)), inner, scale=1.0 / len(quad),
                  weight=self._weight("fair_torsal", weight))
        return self._add(t)

    def perpendicular(self, d, vertices=None, weight: float | None = None,
                      name: str = "perpendicular") -> "CongruenceProblem":
        """f_perp: lines orthogonal to the light, 1/|V'| sum <e_i, d_i>^2 (eq. (9)).

        Parameters
        ----------
        d : (3,) or (|V'|, 3) float
            Light (sun) direction(s), any length (normalized here). An NLP parameter.
        vertices : int array or bool mask, optional
            The subset V' (default all vertices).
        name : str
            Use distinct names for several perpendicular terms (e.g. per sun position).

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> round(p.perpendicular([0, 1, 0]).energies()["perpendicular"], 2)
        0.95
        """
        vi = _as_index(vertices, len(self.congruence.vertices), "vertices")
        dd = _unit_rows(d, len(vi), "light direction d")
        t = _Term(name, False, T.perpendicular_element(), _var_index(vi, 0), np.zeros((len(vi), 0)), dd,
                  vi, scale=1.0 / len(vi), weight=self._weight("perpendicular", weight))
        return self._add(t)

    def parallel(self, d, vertices=None, weight: float | None = None,
                 name: str = "parallel") -> "CongruenceProblem":
        """f_par: lines parallel to ``d``, 1/|V'| sum ||e_i x d_i||^2 (eq. (9), Fig. 9).

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> round(p.parallel([0, -1, 0], vertices=[0, 1]).energies()["parallel"], 2)
        0.08
        """
        vi = _as_index(vertices, len(self.congruence.vertices), "vertices")
        dd = _unit_rows(d, len(vi), "direction d")
        t = _Term(name, False, T.parallel_element(), _var_index(vi, 0), np.zeros((len(vi), 0)), dd,
                  vi, scale=1.0 / len(vi), weight=self._weight("parallel", weight))
        return self._add(t)

    def through_points(self, points, vertices, weight: float | None = None,
                       name: str = "through_points") -> "CongruenceProblem":
        """Lines through target points O_i (Fig. 7c see-through areas).

        ``1/(delta^2 |V'|) sum ||(O_i - a_i) x e_i||^2``: for unit ``e_i`` the mean squared
        distance of ``O_i`` from the line ``L_i``, in units of ``delta``.

        Parameters
        ----------
        points : (3,) or (|V'|, 3) float
            Target points O_i (model units). An NLP parameter.
        vertices : int array or bool mask
            The subset V'.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p = p.through_points([0.0, -10.0, 3.0], vertices=[12])
        >>> p.terms["through_points"]
        ('energy', 1.0, 1)
        """
        vi = _as_index(vertices, len(self.congruence.vertices), "vertices")
        pts = _points(points, len(vi), "target points")
        if np.any(np.linalg.norm(pts - self.congruence.vertices[vi], axis=1) < 1e-9 * self.delta):
            raise ValueError("a target point coincides with its vertex; every line passes through it")
        t = _Term(name, False, T.through_point_element(), _var_index(vi, 0),
                  self.congruence.vertices[vi] / self.delta, pts / self.delta, vi, scale=1.0 / len(vi),
                  weight=self._weight("through_points", weight))
        return self._add(t)

    def closeness(self, initial=None, weight: float | None = None) -> "CongruenceProblem":
        """Regularizer 1/|V| sum ||e_i - e_i,0||^2 to stay near ``initial`` (default: the start).

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p.closeness().energies()["closeness"] < 1e-20
        True
        """
        n = len(self.congruence.vertices)
        e0 = self.congruence.directions if initial is None else np.asarray(initial, dtype=float)
        if e0.shape != (n, 3) or not np.isfinite(e0).all():
            raise ValueError(f"initial directions must be a finite ({n}, 3) array, got shape {e0.shape}")
        t = _Term("closeness", False, T.closeness_element(), _var_index(np.arange(n), 0), np.zeros((n, 0)),
                  np.array(e0), np.arange(n), scale=1.0 / n, weight=self._weight("closeness", weight))
        return self._add(t)

    def _strokes(self, fi, segments, normals=None):
        fv, a = self._face_data(fi)
        corners = a.reshape(-1, 3, 3)
        if segments is None:
            if normals is None:
                raise ValueError("give stroke segments, or plane normals to derive them from")
            fn = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
            tdir = np.cross(normals, fn)
        else:
            s = np.asarray(segments, dtype=float)
            if s.shape == (len(fi), 2, 3):
                tdir = s[:, 1] - s[:, 0]
            elif s.shape in ((len(fi), 3), (3,)):
                tdir = np.broadcast_to(s, (len(fi), 3))
            else:
                raise ValueError(f"segments must have shape ({len(fi)}, 2, 3) (endpoints) or "
                                 f"({len(fi)}, 3) (directions), got {s.shape}")
            if not np.isfinite(tdir).all():
                raise ValueError("segments contain NaN or infinite values")
        return fv, _stroke_barycentric(corners, np.asarray(tdir, float))

    def torsal_direction(self, faces, segments, weight: float | None = None,
                         name: str = "torsal_direction") -> "CongruenceProblem":
        """f_dir: prescribed torsal directions (design strokes), Wang et al. 2013, 4.1 and eq. (9).

        ``1/|F'| sum ([a_p2 - a_p1, e_p1, e_p2] / delta)^2``: the lines through the stroke's
        endpoints are coplanar (see :func:`torsal.geometry.terms.torsal_direction_residual_sx`
        for why this replaces the printed ``[e_p1, e_p2, e_c]``). Each stroke only gives a
        direction: it is re-centred at the face barycenter (the paper requires ``c`` on
        ``p1 p2``) and extended to the triangle's boundary; ``e_p`` is interpolated linearly.

        Parameters
        ----------
        faces : int array or bool mask
            The subset F'.
        segments : (|F'|, 2, 3) or (|F'|, 3) float
            Stroke segments (endpoints) or stroke directions, one per face. NLP parameters.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p.torsal_direction([0, 1], [1.0, 0, 0]).terms["torsal_direction"]
        ('energy', 0.1, 2)
        """
        fi = _as_index(faces, len(self.congruence.faces), "faces")
        fv, w = self._strokes(fi, segments)
        t = _Term(name, False, T.torsal_direction_element(1.0), _var_index(fv, 0),
                  self.congruence.vertices[fv].reshape(len(fi), 9) / self.delta, w,
                  fi, scale=1.0 / len(fi), weight=self._weight("torsal_direction", weight))
        return self._add(t)

    def torsal_plane(self, faces, segments=None, normals=None, weight: float | None = None,
                     name: str = "torsal_plane") -> "CongruenceProblem":
        """f_plane = f_dir + <e_c, n>^2: prescribed torsal planes (Wang et al. 2013, 4.1, Fig. 7d).

        Parameters
        ----------
        faces : int array or bool mask
        segments : optional
            As in :meth:`torsal_direction`; default the line where the plane meets the face
            (``n x`` face normal).
        normals : (3,) or (|F'|, 3) float
            Unit normals of the wanted torsal planes (e.g. the light direction).

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p.torsal_plane(None, normals=[0.0, 0.6, 0.8]).terms["torsal_plane"]
        ('energy', 20.0, 32)
        """
        fi = _as_index(faces, len(self.congruence.faces), "faces")
        if normals is None:
            raise ValueError("torsal_plane needs the plane normals n")
        nn = _unit_rows(normals, len(fi), "plane normals")
        fv, w = self._strokes(fi, segments, nn)
        t = _Term(name, False, T.torsal_plane_element(1.0), _var_index(fv, 0),
                  self.congruence.vertices[fv].reshape(len(fi), 9) / self.delta,
                  np.concatenate([w, nn], axis=1), fi, scale=1.0 / len(fi),
                  weight=self._weight("torsal_plane", weight))
        return self._add(t)

    def align_with(self, other: "CongruenceProblem", weight: float | None = None,
                   label: str = "aligned") -> "CongruenceProblem":
        """f_extra: optimize ``other`` together with this problem so torsal directions coincide.

        Wang et al. 2013, 4.3 (Fig. 11): ``1/|F| sum (||g_L x g_L'|| / delta^2)^2`` with
        ``g = (gamma_0, 2 gamma_1, gamma_2)`` (see
        :func:`torsal.geometry.terms.torsal_alignment_element` for the typesetting choice).
        ``other`` must have the same faces (its vertices may differ, e.g. an offset). Its terms
        and constraints at the time of this call are copied in under ``"<label>.<name>"``;
        the result's ``congruences[1]`` is the optimized ``other``.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> v, f = facade_patch(nu=5, nv=5)
        >>> p, q = (CongruenceProblem(Congruence.from_normals((v + s, f))).fair() for s in (0, 0.5))
        >>> sorted(p.align_with(q).terms)
        ['align', 'aligned.fair', 'fair']
        """
        if not isinstance(other, CongruenceProblem) or other is self:
            raise TypeError("align_with needs another CongruenceProblem")
        oc = other.congruence
        if oc.faces.shape != self.congruence.faces.shape or not np.array_equal(oc.faces, self.congruence.faces):
            raise ValueError("align_with needs a congruence over the same faces (combinatorially equal meshes)")
        if len(other._blocks) > 1:
            raise ValueError("the other problem is already aligned with a third one; align pairwise from one problem")
        if any(b is oc for b in self._blocks):
            raise ValueError("this congruence is already aligned")
        off = self.n_var
        self._blocks.append(oc)
        self._offsets.append(off)
        for name, t in other._terms.items():
            nt = _Term(f"{label}.{name}", t.constraint, t.element, t.idx + off, t.data, t.par.copy(),
                       t.elements, t.scale, t.weight, t.lower, t.upper, t.matrix, t.offset + off)
            self._terms[nt.name] = nt
        fv = self.congruence.faces
        idx = np.concatenate([_var_index(fv, 0), _var_index(fv, off)], axis=1)
        data = np.concatenate([self.congruence.vertices[fv].reshape(len(fv), 9),
                               oc.vertices[fv].reshape(len(fv), 9)], axis=1) / self.delta
        t = _Term("align", False, T.torsal_alignment_element(1.0), idx, data,
                  np.zeros((len(fv), 0)), np.arange(len(fv)), scale=1.0 / len(fv),
                  weight=self._weight("align", weight))
        self._built.clear()
        self._last = None
        return self._add(t)

    def add_term(self, name: str, weight: float, fn: Callable, over: str = "faces", elements=None,
                 params=None) -> "CongruenceProblem":
        """A user's own energy: ``weight * mean over elements of fn(e, a[, p])``.

        Parameters
        ----------
        name : str
        weight : float
        fn : callable
            ``fn(e, a)`` or, with ``params``, ``fn(e, a, p)``: casadi ``SX`` matrices ``e``, ``a``
            of shape (k, 3) (line directions and points of the element's vertices: k = 1 for
            vertices, 3 for faces in corner order, 2 for edges) and ``p`` (r,). Returns a
            scalar expression, evaluated once symbolically and mapped over all elements.
        over : {"faces", "vertices", "edges"}
        elements : int array or bool mask, optional
            Subset of the elements (default all).
        params : (r,) or (m, r) float, optional
            Per-element NLP parameters (changeable without rebuilding).

        Examples
        --------
        >>> import casadi as ca
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p = p.add_term("vertical", 1.0, lambda e, a: e[0, 2] ** 2, over="vertices")
        >>> p.energies()["vertical"] < 0.2
        True
        """
        return self._add_custom(name, fn, over, elements, params, weight=weight)

    def add_constraint(self, name: str, fn: Callable, over: str = "faces", elements=None,
                       params=None, lower: float = 0.0, upper: float = math.inf) -> "CongruenceProblem":
        """A user's own constraint ``lower <= fn(e, a[, p]) <= upper`` on every element.

        Arguments as in :meth:`add_term`. IPOPT enforces it; ``lbfgs`` penalizes violations.
        Scale ``fn`` to be dimensionless and of order 1 for good convergence.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p = p.add_constraint("outward", lambda e, a: -e[0, 1], over="vertices", lower=0.1)
        >>> p.terms["outward"][0]
        'constraint'
        """
        if not (lower <= upper):
            raise ValueError(f"constraint {name!r}: lower bound {lower} exceeds upper bound {upper}")
        return self._add_custom(name, fn, over, elements, params, lower=lower, upper=upper)

    def _add_custom(self, name, fn, over, elements, params, weight=None, lower=0.0, upper=math.inf):
        if over not in _KINDS:
            raise ValueError(f"over must be one of {_KINDS}, got {over!r}")
        if not callable(fn):
            raise TypeError("fn must be a callable returning a casadi expression")
        c = self.congruence
        if over == "vertices":
            ids = _as_index(elements, len(c.vertices), "vertices")
            verts = ids[:, None]
        elif over == "faces":
            ids = _as_index(elements, len(c.faces), "faces")
            verts = c.faces[ids]
        else:
            edges, _ = edge_face_adjacency(c.faces)
            ids = _as_index(elements, len(edges), "edges")
            verts = edges[ids]
        m, k = verts.shape
        if params is None:
            par = np.zeros((m, 0))
        else:
            par = np.asarray(params, dtype=float)
            par = np.broadcast_to(par, (m, par.size)) if par.ndim <= 1 else par
            if par.shape[0] != m or not np.isfinite(par).all():
                raise ValueError(f"params must be finite, shape (r,) or ({m}, r); got {np.shape(params)}")
        el = T.custom_element(name, fn, k, par.shape[1])
        t = _Term(name, weight is None, el, _var_index(verts, 0), c.vertices[verts].reshape(m, 3 * k),
                  np.array(par), ids, scale=1.0 / m, weight=1.0 if weight is None else float(weight),
                  lower=float(lower), upper=float(upper))
        return self._add(t)

    # ------------------------------------------------------------------ constraints
    def hyperbolic(self, faces=None, margin: float = 0.0) -> "CongruenceProblem":
        """c_hyp(face) / delta^2 >= margin: two real torsal directions (Wang et al. 2013, 4.1, eq. (2)).

        ``margin`` is dimensionless (``c_hyp`` in units of ``delta^2``, for unit directions); a
        small positive margin keeps faces away from the parabolic limit.

        ``c_hyp = 4 (g1^2 - g0 g2)`` is quadratic in the torsal coefficients ``g`` of eq. (1),
        so its gradient vanishes on a face whose lines are parallel (``g = 0``, a line
        bundle), which satisfies ``c_hyp >= 0``. ``fair`` with ``perpendicular`` or
        ``parallel`` favours parallel lines; when many faces end near a bundle, IPOPT's
        multipliers grow and it may need hundreds of iterations. A ``closeness`` term keeps
        the lines near the start and away from a bundle.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p.hyperbolic().terms["hyperbolic"]
        ('constraint', None, 32)
        """
        if not np.isfinite(margin):
            raise ValueError("margin must be finite")
        fi = _as_index(faces, len(self.congruence.faces), "faces")
        fv, a = self._face_data(fi)
        t = _Term("hyperbolic", True, T.hyperbolicity_element(1.0), _var_index(fv, 0), a,
                  np.full((len(fi), 1), float(margin)), fi)
        return self._add(t)

    def min_torsal_angle(self, alpha_deg: float = 40.0, faces=None,
                         safety_deg: float = 0.01) -> "CongruenceProblem":
        """c_ang >= 0: torsal directions at least ``alpha_deg`` apart (Wang et al. 2013, 4.1).

        The smooth inequality is derived in :func:`torsal.geometry.terms.torsal_angle_sx`; it
        implies hyperbolicity. ``alpha_deg`` must be in (0, 90). The constraint is imposed at
        ``alpha_deg + safety_deg``: c_ang is small near parallel lines, so IPOPT's absolute
        constraint tolerance (1e-9) can be worth a few thousandths of a degree.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p.min_torsal_angle(40).terms["min_torsal_angle"][0]
        'constraint'
        """
        if not (0.0 < alpha_deg < 90.0):
            raise ValueError(f"alpha_deg must be in (0, 90) degrees, got {alpha_deg}; "
                             "torsal directions are at most 90 degrees apart")
        fi = _as_index(faces, len(self.congruence.faces), "faces")
        fv, a = self._face_data(fi)
        c2 = math.cos(math.radians(min(alpha_deg + safety_deg, 89.999))) ** 2
        t = _Term("min_torsal_angle", True, T.torsal_angle_element(1.0), _var_index(fv, 0), a,
                  np.tile([c2, 1.0 - c2], (len(fi), 1)), fi)
        return self._add(t)

    def max_angle_to(self, d, theta_deg: float, vertices=None) -> "CongruenceProblem":
        """<e_i, d_i> - cos(theta) >= 0: lines within ``theta_deg`` of ``d`` (Wang et al. 2013, 4.1).

        Needs unit directions (``normalize="constraint"``).

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p.max_angle_to([0, -1, 0], 30).terms["max_angle_to"][0]
        'constraint'
        """
        if not (0.0 < theta_deg < 180.0):
            raise ValueError(f"theta_deg must be in (0, 180) degrees, got {theta_deg}")
        vi = _as_index(vertices, len(self.congruence.vertices), "vertices")
        dd = _unit_rows(d, len(vi), "direction d")
        par = np.concatenate([dd, np.full((len(vi), 1), math.cos(math.radians(theta_deg)))], axis=1)
        t = _Term("max_angle_to", True, T.max_angle_element(), _var_index(vi, 0), np.zeros((len(vi), 0)),
                  par, vi)
        return self._add(t)

    def set_weight(self, name: str, weight: float) -> "CongruenceProblem":
        """Change one energy's weight (an NLP parameter: no rebuild)."""
        if name not in self._terms or self._terms[name].constraint:
            raise KeyError(f"no energy named {name!r}; energies: "
                           f"{sorted(k for k, t in self._terms.items() if not t.constraint)}")
        if not (np.isfinite(weight) and weight >= 0):
            raise ValueError(f"weight of {name!r} must be a finite number >= 0, got {weight}")
        self._terms[name].weight = float(weight)
        return self

    def remove(self, name: str) -> "CongruenceProblem":
        """Remove a term or constraint (the solver is rebuilt at the next solve)."""
        if name not in self._terms:
            raise KeyError(f"no term named {name!r}; terms: {sorted(self._terms)}")
        del self._terms[name]
        self._built.clear()
        self._last = None
        return self

    # ------------------------------------------------------------------ assembly
    def _mode(self, solver: str) -> str:
        return "penalty" if solver == "lbfgs" else self.normalize

    def _term_list(self, mode: str) -> list[_Term]:
        out = [(_penalty_term(t) if (mode == "penalty" and t.constraint) else t)
               for t in self._terms.values()]
        nv = self.n_var // 3
        allv = np.arange(nv)
        idx = 3 * allv[:, None] + np.arange(3)
        if mode == "constraint":
            out.append(_Term("unit_length", True, T.unit_length_element(), idx, np.zeros((nv, 0)),
                             np.zeros((nv, 0)), allv, lower=0.0, upper=0.0))
        elif mode == "renormalize":
            x, d, p = T.face_symbols(1, n_data=0)
            q = ca.dot(x, x) - 1.0
            el = T.ElementTerm("unit_penalty", ca.Function("f_unit", [x, d, p], [q * q]), 1)
            out.append(_Term("unit_penalty", False, el, idx, np.zeros((nv, 0)), np.zeros((nv, 0)), allv,
                             scale=1.0 / nv, weight=1.0))
        return out

    def build(self, solver: str = "ipopt") -> float:
        """Assemble the NLP (done by :meth:`solve` when needed); returns the seconds it took.

        The built NLP is kept until a term's element subset changes (parameters and weights
        can change freely).
        """
        if solver not in ("ipopt", "lbfgs"):
            raise ValueError(f"solver must be 'ipopt' or 'lbfgs', got {solver!r}")
        mode = self._mode(solver)
        if mode in self._built:
            return 0.0
        if not self._terms:
            raise ValueError("the problem has no terms; add energies (e.g. .normal().fair()) before solving")
        self._built[mode] = _Built(self._term_list(mode), self.n_var // 3, mode, self.jit)
        return self._built[mode].seconds

    def _free_built(self, mode: str) -> tuple[_Built, float]:
        """The NLP of ``mode`` without its inequality constraints (built once, as needed)."""
        key = mode + "/without-inequalities"
        if key in self._built:
            return self._built[key], 0.0
        terms = [t for t in self._term_list(mode) if not (t.constraint and t.lower < t.upper)]
        self._built[key] = _Built(terms, self.n_var // 3, mode, self.jit)
        return self._built[key], self._built[key].seconds

    def _directions(self) -> np.ndarray:
        return np.concatenate([b.directions for b in self._blocks])

    def _current(self) -> dict:
        cur = dict(self._terms)
        for k, t in self._terms.items():
            if t.constraint:
                cur["penalty:" + k] = t
        return cur

    def _evaluate(self, e: np.ndarray):
        """(energies dict, objective, g, built) at stacked directions ``e`` with the main NLP."""
        self.build("ipopt")
        b = self._built[self.normalize]
        x, fr = b.pack(e)
        ev, f, g = b.evaluate(x, b.parameters(self._current(), fr))
        out = {k: float(v) for k, v in zip(b.energy_names, np.asarray(ev).ravel())}
        out["total"] = float(f)
        return out, float(f), np.asarray(g).ravel(), b

    def energies(self, directions=None) -> dict:
        """Unweighted energies and ``"total"`` (weighted, eq. (9)) at ``directions`` (default current).

        ``directions`` is (n, 3) for this congruence or the stacked (N, 3) of all aligned ones.
        """
        e = self._directions() if directions is None else np.asarray(directions, float).reshape(-1, 3)
        if e.size != self.n_var:
            raise ValueError(f"directions must have {self.n_var // 3} rows, got {e.size // 3}")
        return self._evaluate(e)[0]

    def _violations(self, b: _Built, g) -> tuple[dict, tuple | None]:
        out, worst = {}, None
        for t, rows in zip(b.cons, b.g_slices):
            gi = g[rows]
            v = _bound_violation(gi, t.lower, t.upper)
            v = np.where(np.isfinite(v), v, np.inf)
            j = int(np.argmax(v)) if v.size else 0
            out[t.name] = float(v[j]) if v.size else 0.0
            if v.size and v[j] > 0 and (worst is None or v[j] > worst[2]):
                worst = (t.name, int(t.elements[j]), float(v[j]))
        return out, worst

    # ------------------------------------------------------------------ solving
    def _report_iteration(self, arg) -> bool:
        self._iter += 1
        self._phase_iter += 1          # IPOPT reports iteration 0 too
        if self._iter_cap is not None and self._phase_iter - 1 >= self._iter_cap:
            return True
        if self._callback is None:
            return False
        b = self._active
        g = np.asarray(arg[ca.nlpsol_out().index("g")]).ravel()
        inf = float(np.max(_bound_violation(g, b.lbg, b.ubg))) if g.size else 0.0
        f = float(arg[ca.nlpsol_out().index("f")])
        return bool(self._callback({"iteration": self._iter, "objective": f, "infeasibility": inf}))

    def _ipopt(self, b: _Built, warm: bool, max_iter: int, tol: float, verbose: bool, options,
               x0: np.ndarray, p: np.ndarray):
        """The (cached) IPOPT solver; the cold and the warm-start variant are built together.

        ``x0``, ``p``: the start of the first solve, where IPOPT's first Hessian
        regularization is estimated (see :func:`_hessian_shift`).
        """
        key = (warm, max_iter, tol, verbose, tuple(sorted((options or {}).items())))
        if key in b.solvers:
            return b.solvers[key], 0.0
        t0 = time.perf_counter()
        if b.n_g and not warm:
            self._ipopt(b, True, max_iter, tol, verbose, options, x0, p)
        cb = _IterationCallback(f"cb{len(b.solvers)}", b.n_var, b.n_g, b.n_par, self)
        ip = {"linear_solver": "mumps", "print_level": 5 if verbose else 0, "sb": "yes",
              "max_iter": int(max_iter), "tol": float(tol), "acceptable_tol": 10 * float(tol),
              "acceptable_iter": 10, "mu_strategy": "adaptive", "mumps_pivot_order": 5,
              "constr_viol_tol": 1e-9, "acceptable_constr_viol_tol": 1e-7,
              # energies are means over elements: scale to sums so the KKT tolerance is per vertex
              "obj_scaling_factor": float(max(b.n_vertices, 1)),
              # Hessian regularization: the start is estimated (_hessian_shift); where that
              # fails or later, the regularization needed is O(weight) with per-vertex
              # scaling, so search from 1 in steps of 3 (not 1e-4 in steps of 100): fewer
              # trial factorizations, less over-damped steps
              "first_hessian_perturbation": 1.0, "perturb_inc_fact_first": 3.0}
        if warm:
            ip.update({"warm_start_init_point": "yes", "mu_init": 1e-6,
                       "warm_start_bound_push": 1e-9, "warm_start_bound_frac": 1e-9,
                       "warm_start_slack_bound_push": 1e-9, "warm_start_slack_bound_frac": 1e-9,
                       "warm_start_mult_bound_push": 1e-9})
        ip.update(options or {})
        if "first_hessian_perturbation" not in (options or {}):
            # the estimate is in IPOPT's scaled units: one per objective scaling
            skey = tuple(ip.get(k) for k in _SCALING_OPTIONS)
            if skey not in b.hessian_shifts:
                b.hessian_shifts[skey] = _hessian_shift(b, x0, p, ip)
            if b.hessian_shifts[skey] > 0:
                ip["first_hessian_perturbation"] = b.hessian_shifts[skey]
        opts = {"ipopt": ip, "print_time": bool(verbose), "grad_f": b.grad_f, "jac_g": b.jac_g,
                "hess_lag": b.hess_lag, "iteration_callback": cb, "error_on_fail": False,
                "calc_lam_p": False}
        s = ca.nlpsol("congruence", "ipopt", {"x": b.x, "p": b.p, "f": b.f_expr, "g": b.g_expr}, opts)
        b.solvers[key] = (s, cb)
        return b.solvers[key], time.perf_counter() - t0

    def solve(self, solver: str = "ipopt", max_iter: int | None = None, tol: float = 1e-4,
              callback: Callable | None = None, *, warm_start: bool = True, initial=None,
              raise_on_failure: bool = False, verbose: bool = False, constraint_tol: float = 1e-6,
              penalty: float = 1e3, ipopt_options: dict | None = None,
              try_unconstrained: bool = True) -> OptimizationResult:
        """Minimize the energies subject to the constraints.

        Parameters
        ----------
        solver : {"ipopt", "lbfgs"}
            ``"ipopt"``: interior point, exact Hessian, MUMPS, real inequality constraints.
            ``"lbfgs"``: the paper's baseline: scipy L-BFGS-B in rounds of 10 iterations with
            renormalization of the ``e_i`` after each round; constraints become penalties
            ``penalty * mean(min(c, 0)^2)``.
        max_iter : int, optional
            Iteration limit (default 200 for IPOPT, 1000 for L-BFGS).
        tol : float
            IPOPT's KKT tolerance, with the objective scaled by the number of vertices (the
            energies are means, so this makes the criterion per vertex and independent of the
            mesh size). L-BFGS: stop when a round decreases the objective by less than ``tol``
            times the starting objective.
        callback : callable, optional
            Called each iteration with ``{"iteration", "objective", "infeasibility"}``;
            returning True stops the solve.
        warm_start : bool
            Start from the last solution (with IPOPT's constraint multipliers) when the
            problem structure is unchanged; otherwise from the congruence's directions.
        initial : (n, 3) float, optional
            Explicit start directions (overrides the warm start).
        raise_on_failure : bool
            Raise :class:`OptimizationError` instead of returning an unsuccessful result.
        verbose : bool
            Let IPOPT print its log.
        constraint_tol : float
            Violation above which a constraint counts as not met in ``success``.
        penalty : float
            Penalty weight of constraints for ``lbfgs``.
        ipopt_options : dict, optional
            Extra IPOPT options (e.g. ``{"mumps_pivot_order": 7}``).
        try_unconstrained : bool
            IPOPT with inequality constraints: solve in up to three passes.

            1. Without the inequalities (equalities stay). If that answer meets every
               inequality to IPOPT's ``constr_viol_tol`` (1e-9) it is kept: a feasible local
               minimizer of the energy is a local minimizer of the constrained problem. This
               pays off where the constraints are not active but slow IPOPT down, e.g.
               ``hyperbolic`` when the energies favour near-parallel lines (``c_hyp`` is
               degenerate there, see :meth:`hyperbolic`): the bench's row 7a with
               ``hyperbolic()`` needs 14 iterations instead of 200.
            2. If at most 5% of the inequalities are violated: from pass 1's answer, with only
               those and the ones near their bound (the working set) imposed, adding any that
               the answer then violates. The others hold with slack, so their multipliers are
               zero and the answer is a KKT point of the whole problem; IPOPT carries barrier
               terms for a few elements instead of all (Fig. 13's mirror fins: 22 iterations
               instead of 500 without converging).
            3. Otherwise, or if pass 2 does not converge: all constraints, from the start.

            ``max_iter`` bounds the iterations of all passes together (pass 1 gets at most
            half, pass 2 half of the rest; in a re-solve, half). A re-solve (warm start) starts at the pass that
            answered last: pass 2 keeps its working set (and multipliers) and grows it as
            needed; pass 3 keeps all constraints. ``OptimizationResult.constraints_active`` and
            ``.working_set`` say which pass gave the result.

        Returns
        -------
        OptimizationResult
        """
        build_s = self.build(solver)
        build_s += self.build("ipopt")    # the main NLP also evaluates energies and constraints
        mode = self._mode(solver)
        b = self._built[mode]
        e0, lam_g0, warm = self._directions(), None, False
        if initial is not None:
            init = np.asarray(initial, dtype=float)
            if init.size != self.n_var or not np.isfinite(init).all():
                raise ValueError(f"initial must be a finite ({self.n_var // 3}, 3) array")
            e0 = init.reshape(-1, 3)
        elif warm_start and self._last is not None:
            e0 = self._last["e"]
            lam_g0 = self._last.get("lam_g") if solver == "ipopt" else None
            warm = lam_g0 is not None and lam_g0.size == b.n_g and b.n_g > 0
        before = self._evaluate(e0)[0]
        x0, frames = b.pack(e0)
        p = b.parameters(self._current(), frames)
        self._callback, self._iter, self._active = callback, 0, b
        active = None
        working = None
        if solver == "ipopt":
            t0 = time.perf_counter()
            (x, lam_g, iters, status, ok, active, working), extra = self._solve_ipopt(
                b, mode, warm, lam_g0, x0, p, frames, max_iter or 200, tol, verbose, ipopt_options,
                try_unconstrained)
            build_s += extra
            solve_s = time.perf_counter() - t0 - extra
        else:
            t0 = time.perf_counter()
            x, status, ok, iters = self._lbfgs(b, x0, p, max_iter or 1000, tol, penalty)
            solve_s = time.perf_counter() - t0
            lam_g = None
        self._callback = None
        e = b.unpack(x, frames)
        if self.normalize == "renormalize" or solver == "lbfgs":
            e = _renormalize(e.ravel()).reshape(-1, 3)
        finite = bool(np.isfinite(e).all())
        if finite:
            after, fval, g, nb = self._evaluate(e)
            viol, worst = self._violations(nb, g)
        else:
            viol, worst, after, fval = {}, ("NaN", -1, math.inf), {}, math.nan
            status += "; the solution contains NaN"
        if finite and worst is not None and worst[2] > constraint_tol:
            ok = False
            status += f"; worst constraint {worst[0]!r} violated by {worst[2]:.3g} at element {worst[1]}"
        ok = bool(ok and finite)
        congs = []
        if finite:
            start = 0
            for c in self._blocks:
                n = len(c.vertices)
                congs.append(Congruence(c.vertices, c.faces, e[start:start + n]))
                start += n
            self._last = {"e": e, "lam_g": lam_g, "active": active, "working": working}
        else:
            congs = list(self._blocks)
        res = OptimizationResult(congruence=congs[0], success=ok, status=status, iterations=iters,
                                 build_seconds=build_s, solve_seconds=solve_s, energies_before=before,
                                 energies_after=after, max_violation=viol, worst_constraint=worst,
                                 congruences=tuple(congs), solver=solver, objective=float(fval),
                                 constraints_active=active,
                                 working_set=None if working is None else _working_ids(b, working))
        if raise_on_failure and not ok:
            raise OptimizationError(f"congruence optimization failed: {status}", res)
        return res

    def _ipopt_call(self, s, b: _Built, args: dict, cap: int | None):
        """One IPOPT run with at most ``cap`` iterations; (x, lam_g, iterations, status, converged)."""
        self._active = b
        self._phase_iter, self._iter_cap = 0, cap
        r = s(**args)
        stats = s.stats()
        capped = cap is not None and self._phase_iter - 1 >= cap
        self._iter_cap = None
        status = "Maximum_Iterations_Exceeded" if capped else str(stats.get("return_status", "unknown"))
        return (np.asarray(r["x"]).ravel(), np.asarray(r["lam_g"]).ravel(),
                int(stats.get("iter_count", 0)), status, bool(stats.get("success", False)) and not capped)

    def _solve_ipopt(self, b: _Built, mode: str, warm: bool, lam_g0, x0, p, frames, limit: int,
                     tol: float, verbose: bool, options, try_unconstrained: bool):
        """IPOPT in up to three passes (see ``try_unconstrained`` of :meth:`solve`).

        1. without the inequality constraints; kept if it meets them;
        2. with only the inequalities that pass 1 violates or nearly meets (the working set),
           from pass 1's answer, growing the set while the answer violates others;
        3. with all of them, from the start.

        Returns ``((x, lam_g, iterations, status, ok, constraints_active, working), build
        seconds)``; ``working`` is the working-set mask over ``g`` when pass 2 answered.
        """
        # the cold solver; with constraints its warm-start variant is built (and cached) with it
        (s, _), build_s = self._ipopt(b, False, limit, tol, verbose, options, x0, p)
        sw = self._ipopt(b, True, limit, tol, verbose, options, x0, p)[0][0] if warm else None
        ineq = b.lbg < b.ubg
        feas_tol = float((options or {}).get("constr_viol_tol", 1e-9))
        last = self._last or {}
        prev_ws = last.get("working") if warm else None
        iters, status = 0, ""
        if warm and prev_ws is not None and prev_ws.size == b.n_g:
            # the designer's re-solve after a working-set solve: same set, warm multipliers
            out = self._working_set(sw, s, b, x0, p, prev_ws, lam_g0, max(limit // 2, 1), feas_tol)
            if out[4] or out[3] == "User_Requested_Stop":
                return out, build_s
            iters, status = out[2], out[3]
            warm = False     # fall back to all constraints, cold, from the same start
        elif try_unconstrained and ineq.any() and not (warm and last.get("active")):
            bf, extra = self._free_built(mode)
            pf = bf.parameters(self._current(), frames)
            build_s += extra
            (s1, _), extra = self._ipopt(bf, False, limit, tol, verbose, options, x0, pf)
            build_s += extra
            x1, _, iters, status, conv = self._ipopt_call(s1, bf, dict(x0=x0, p=pf, lbg=bf.lbg, ubg=bf.ubg),
                                                         max(limit // 2, 1))
            if status == "User_Requested_Stop":     # the caller's callback
                return (x1, None, iters, status, False, None, None), build_s
            g1 = np.asarray(b.evaluate(x1, p)[2]).ravel()
            viol = _bound_violation(g1, b.lbg, b.ubg) > feas_tol
            if conv and not viol.any():
                return (x1, None, iters, status, True, False, None), build_s
            if conv and viol[ineq].mean() <= _WORKING_SET_MAX_SHARE:
                ws = _near_bounds(g1, b) | viol | ~ineq
                out = self._working_set(s, s, b, x1, p, ws, None, (limit - iters) // 2, feas_tol)
                iters += out[2]
                if out[4] or out[3] == "User_Requested_Stop":
                    return (*out[:2], iters, *out[3:]), build_s
                status = out[3]
            warm = False
        args = dict(x0=x0, p=p, lbg=b.lbg, ubg=b.ubg)
        if warm:
            args.update(lam_g0=lam_g0, lam_x0=np.zeros(b.n_var))
        x, lam_g, it, status, ok = self._ipopt_call(sw if warm else s, b, args,
                                                    (limit - iters) if iters else None)
        return (x, lam_g, iters + it, status, ok, True if ineq.any() else None, None), build_s

    def _working_set(self, s_warm, s_cold, b: _Built, x, p, ws: np.ndarray, lam_g, budget: int,
                     feas_tol: float):
        """Pass 2: IPOPT with the inequalities outside ``ws`` unbounded, adding those the answer
        violates (and their near-active companions) until it violates none.

        An inequality left out and met with slack has a zero multiplier, so the answer is a
        KKT point of the whole problem; IPOPT meanwhile carries barrier terms (and their
        indefinite curvature, see :meth:`hyperbolic`) only for the few elements that matter.
        Returns ``(x, lam_g, iterations, status, converged, True, ws)``.
        """
        iters, status, ok = 0, "", False
        ws = ws.copy()
        while budget - iters > 0:
            args = dict(x0=x, p=p, lbg=np.where(ws, b.lbg, -np.inf), ubg=np.where(ws, b.ubg, np.inf))
            if lam_g is not None:
                args.update(lam_g0=np.where(ws, lam_g, 0.0), lam_x0=np.zeros(b.n_var))
            x, lam_g, it, status, ok = self._ipopt_call(s_warm if lam_g is not None else s_cold, b, args,
                                                       budget - iters)
            iters += it
            if not ok:
                break
            g = np.asarray(b.evaluate(x, p)[2]).ravel()
            new = (_bound_violation(g, b.lbg, b.ubg) > feas_tol) & ~ws
            if not new.any():
                break
            ws |= _near_bounds(g, b) | new
            lam_g, ok = None, False          # cold: the new elements have no multipliers yet
        return x, lam_g, iters, status, ok, True, ws

    def _lbfgs(self, b: _Built, x0, p, max_iter, tol, penalty):
        from scipy.optimize import minimize

        pen = np.array(p)
        for t, off in zip(b.terms, b.p_offsets):
            if t.name.startswith("penalty:"):
                pen[off] = penalty
        fg = b.grad_f
        state = {"it": 0}
        x = _renormalize(np.asarray(x0, float))
        f_prev, f_start = math.inf, None
        status, ok = "maximum iterations", False

        def fun(z):
            f, g = fg(z, pen)
            return float(f), np.asarray(g).ravel()

        def cb(z):
            state["it"] += 1
            if self._callback is not None:
                f, _ = fun(z)
                if self._callback({"iteration": state["it"], "objective": f, "infeasibility": float("nan")}):
                    raise StopIteration

        while state["it"] < max_iter:
            try:
                r = minimize(fun, x, jac=True, method="L-BFGS-B", callback=cb,
                             options={"maxiter": min(10, max_iter - state["it"]), "gtol": 1e-12,
                                      "ftol": 1e-15})
                x = _renormalize(r.x)
            except StopIteration:
                status = "stopped by callback"
                break
            f = fun(x)[0]
            if not np.isfinite(f):
                status = "objective is NaN"
                break
            f_start = f if f_start is None else f_start
            if abs(f_prev - f) <= tol * max(abs(f_start), 1e-300) or r.nit == 0:
                status, ok = "converged (relative decrease per round below tol)", True
                break
            f_prev = f
        return x, status, ok, state["it"]


_SCALING_OPTIONS = ("obj_scaling_factor", "nlp_scaling_method", "nlp_scaling_max_gradient",
                    "nlp_scaling_min_value")


def _hessian_shift(b: _Built, x0: np.ndarray, p: np.ndarray, ip: dict) -> float:
    """First Hessian regularization for IPOPT: 1.25 times the most negative eigenvalue (internal).

    IPOPT makes the Lagrangian Hessian ``W`` of the scaled problem positive definite on the
    search space by factoring ``W + delta I`` for ``delta = 0``, then
    ``first_hessian_perturbation``, then growing by ``perturb_inc_fact_first`` until the
    inertia is right; each trial is a full factorization. Far from the optimum the sphere
    makes ``W`` indefinite (``<e, d>^2`` curves down along the circle around ``d``) with a
    most negative eigenvalue of the order of the weights. A few Lanczos steps (scipy
    ``eigsh``, about 1 % of a factorization) estimate it at the start, so the first
    nonzero trial succeeds instead of the third to fifth, and the damping is not
    overshot. The objective Hessian is scaled as IPOPT scales the objective
    (``obj_scaling_factor`` times the gradient-based factor). Returns 0 when ``W`` is
    positive semidefinite at ``x0`` or the estimate fails (IPOPT then searches as usual).
    """
    from scipy.sparse.linalg import eigsh

    if b.n_var == 0:
        return 0.0
    try:
        scale = float(ip.get("obj_scaling_factor", 1.0))
        if ip.get("nlp_scaling_method", "gradient-based") == "gradient-based":
            g = np.asarray(b.grad_f(x0, p)[1]).ravel()
            gmax = float(np.max(np.abs(g))) if g.size else 0.0
            limit = float(ip.get("nlp_scaling_max_gradient", 100.0))
            if gmax > limit:
                scale *= max(limit / gmax, float(ip.get("nlp_scaling_min_value", 1e-8)))
        h = b.hess_lag(x0, p, scale, np.zeros(b.n_g)).sparse()      # upper triangle
        h = (h + sp.triu(h, 1).T).tocsc()
        if b.n_var <= 200:
            lam = float(np.linalg.eigvalsh(h.toarray())[0])
        else:
            v0 = np.random.default_rng(0).standard_normal(b.n_var)    # same start, same result
            lam = float(eigsh(h, k=1, which="SA", tol=5e-2, maxiter=20 * b.n_var, v0=v0,
                              return_eigenvectors=False)[0])
    except (RuntimeError, ValueError):   # ArpackError (no convergence), LinAlgError, NaN at x0
        return 0.0
    return 1.25 * -lam if np.isfinite(lam) and lam < 0 else 0.0


def _renormalize(x: np.ndarray) -> np.ndarray:
    e = x.reshape(-1, 3)
    n = np.linalg.norm(e, axis=1, keepdims=True)
    return (e / np.where(n > 0, n, 1.0)).ravel()


def _penalty_term(t: _Term) -> _Term:
    """Constraint -> energy ``mean(min(c - lower, 0)^2 + max(c - upper, 0)^2)`` for L-BFGS."""
    fn = t.element.fn
    x, d, p = (ca.SX.sym(s, fn.size1_in(i)) for i, s in enumerate("xdp"))
    c = fn(x, d, p)
    v = ca.fmin(c - t.lower, 0) ** 2 if math.isfinite(t.lower) else 0
    if math.isfinite(t.upper):
        v = v + ca.fmax(c - t.upper, 0) ** 2
    el = T.ElementTerm("penalty:" + t.name, ca.Function("pen_" + fn.name(), [x, d, p], [v]), t.element.k)
    return _Term("penalty:" + t.name, False, el, t.idx, t.data, t.par, t.elements, scale=1.0 / t.size,
                 weight=1e3)
