"""NLP assembly: value, gradient, constraint Jacobian and Lagrangian Hessian of a term list.

:class:`Built` maps every term's element kernels over its elements and scatters the local
derivatives into the global sparse matrices with constant 0/1 scatter matrices (linear in the
mesh size). See the package docstring for why the Hessian is assembled by hand.

The steps: :class:`_Layout` places the variables, parameters and constraint rows;
:class:`_Assembly` adds each term's value and derivative pieces (:class:`_Parts`) and
scatters them; :class:`Built` turns the result into casadi Functions and bounds.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import casadi as ca
import numpy as np
import scipy.sparse as sp

from .catalogue import Term
from .kernels import Local, _chart_functions, _jit
from .numeric import NumericFunction
from .projected import Block, ProjectedHessian

def _to_casadi(m: sp.spmatrix) -> ca.DM:
    m = sp.csc_matrix(m)
    m.sort_indices()
    spy = ca.Sparsity(m.shape[0], m.shape[1], m.indptr.astype(np.int64).tolist(),
                      m.indices.astype(np.int64).tolist())
    return ca.DM(spy, m.data)


def _bound_violation(g: np.ndarray, lower, upper) -> np.ndarray:
    """Elementwise violation of ``lower <= g <= upper`` (0 where it holds)."""
    return np.maximum(np.maximum(lower - g, g - upper), 0.0)


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


@dataclass(frozen=True)
class _Layout:
    """Sizes and offsets of one NLP (internal to :class:`Built`).

    Variables: the directions (``n_dir``: ``dof`` per vertex), then the lifted variables
    (``n_lift``: ``(r, t, phi)`` per face of a lifted term, see :meth:`Built._lift`), then the
    elastic slacks (``n_slack``, see :meth:`Built._elastic`). Parameters: the tangent frames
    (``n_frames``), then per term its weight, its ``par`` and its ``data`` (mesh A's points in
    units of delta: a moved vertex is a new parameter value, not a new NLP) from ``p_offsets``,
    then the elastic penalty weight when there are slacks. Constraint rows: the constraint terms'
    rows in order (from ``g_offsets``).
    """
    n_vertices: int
    tangent: bool
    cons: list            # the constraint terms, in row order
    g_offsets: np.ndarray
    elastic_rows: np.ndarray
    lifts: list           # (term, first row, first lifted variable) per lifted term
    n_lift: int
    p_offsets: list
    n_par: int

    @classmethod
    def of(cls, terms: list[Term], n_vertices: int, tangent: bool, elastic: float) -> "_Layout":
        dof = 2 if tangent else 3
        cons = [t for t in terms if t.constraint]
        g_offsets = np.concatenate([[0], np.cumsum([t.size for t in cons])]).astype(np.int64)
        # elastic rows: the one-sided inequalities c >= lower (see Built._elastic)
        el_rows = np.concatenate([np.full(t.size, np.isfinite(t.lower) and not np.isfinite(t.upper))
                                  for t in cons]) if cons and elastic > 0 else np.zeros(0, bool)
        # lifted variables: one per row of a lifted term, after the directions
        lifts, n_lift = [], 0
        for t, go in zip(cons, g_offsets):
            if t.lift:
                lifts.append((t, int(go), dof * n_vertices + n_lift))
                n_lift += t.size
        p_offsets, n_p = [], 9 * n_vertices if tangent else 0
        for t in terms:
            p_offsets.append(n_p)
            n_p += 1 + t.par.size + t.data.size
        n_p += 1 if el_rows.any() else 0      # the elastic penalty weight, last
        return cls(n_vertices, tangent, cons, g_offsets, np.flatnonzero(el_rows), lifts, n_lift,
                   p_offsets, n_p)

    @property
    def dof(self) -> int:
        return 2 if self.tangent else 3

    @property
    def n_dir(self) -> int:
        return self.dof * self.n_vertices

    @property
    def n_slack(self) -> int:
        return int(self.elastic_rows.size)

    @property
    def n_main(self) -> int:
        return self.n_dir + self.n_lift

    @property
    def n_var(self) -> int:
        return self.n_main + self.n_slack

    @property
    def n_frames(self) -> int:
        return 9 * self.n_vertices if self.tangent else 0

    @property
    def n_g(self) -> int:
        return int(self.g_offsets[-1])


class _Parts:
    """Entries of a sparse matrix (or vector: no columns) as pieces ``(values, rows, cols)``;
    entries at the same position are summed when scattered (:func:`_scatter`), so each term
    adds its local derivatives without knowing the others'."""

    def __init__(self):
        self.values, self.rows, self.cols = [], [], []

    def add(self, values, rows: np.ndarray, cols: np.ndarray | None = None) -> None:
        self.values.append(values)
        self.rows.append(rows)
        if cols is not None:
            self.cols.append(cols)

    def vector(self, n: int, dense: list) -> ca.MX:
        """The dense ``(n, 1)`` sum of the pieces plus the ``dense`` columns."""
        out = ca.MX.zeros(n, 1)
        if self.values:
            ukey, S = _scatter(np.concatenate(self.rows))
            out = ca.densify(ca.MX(_ccs(ukey, n, 1), ca.mtimes(S, ca.vertcat(*self.values))))
        for d in dense:
            out = out + d
        return out

    def matrix(self, nrow: int, ncol: int) -> ca.MX:
        """The sparse ``(nrow, ncol)`` sum of the pieces (structural zeros elsewhere)."""
        if not self.values:
            return ca.MX(ca.Sparsity(nrow, ncol))
        rows, cols = np.concatenate(self.rows), np.concatenate(self.cols)
        ukey, S = _scatter(cols * nrow + rows)
        return ca.MX(_ccs(ukey, nrow, ncol), ca.mtimes(S, ca.vertcat(*self.values)))


class _Assembly:
    """The symbolic NLP while its terms are added one by one (internal to :class:`Built`).

    Holds the symbols (``x_all``, ``p``, ``lam_f``, ``lam_g``), the directions ``e_all`` as
    expressions of the variables (the chart in tangent mode) and the accumulated objective,
    energies, constraint rows and derivative pieces; :meth:`finish` scatters the pieces.
    The Hessian is that of the Lagrangian ``lam_f f + lam_g^T g``, upper triangle.
    ``derivatives=False``: the energies, the objective and the rows only (no kernel
    derivatives, no chart Jacobians; the first stage of a lazily built NLP, see :class:`Built`).
    """

    def __init__(self, lay: _Layout, jit: bool, hessian: str, derivatives: bool = True,
                 kernels: dict | None = None):
        self.lay, self.jit, self.hessian = lay, jit, hessian
        self.derivatives = derivatives
        self.x_all = ca.MX.sym("x", lay.n_var)
        # the directions' variables (the lifted variables and slacks come after them)
        self.x = self.x_all[0:lay.n_dir] if lay.n_var > lay.n_dir else self.x_all
        self.p = ca.MX.sym("p", lay.n_par)
        self.lam_f = ca.MX.sym("lam_f")
        self.lam_g = ca.MX.sym("lam_g", lay.n_g)
        self.f = ca.MX(0)
        self.e_vals, self.g_parts = [], []
        self.grad, self.dense_grad = _Parts(), []   # gradient in x (dense: quadratic terms)
        self.lag, self.dense_lag = _Parts(), []     # Lagrangian gradient in e (tangent: chart curvature)
        self.jac, self.hess = _Parts(), _Parts()
        self.blocks: list[Block] = []   # hessian="projected": element Hessians, projected at evaluation
        self.quad_h = []       # (coefficient, upper triangle of Q) of the plain-mode quadratic terms
        # element kernels, shared by the terms with the same function (and, when given, by
        # the other NLPs of the problem: see Built's ``kernels``)
        self.local: dict = {} if kernels is None else kernels
        if lay.tangent:
            self._chart()
        else:
            self.e_all = self.x

    def _chart(self) -> None:
        """Tangent mode: ``e = chart(z, frame)`` per vertex and its 3x2 Jacobian, mapped once."""
        n = self.lay.n_vertices
        self.Z = ca.reshape(self.x, 2, n)
        self.FR = ca.reshape(self.p[0:self.lay.n_frames], 9, n)
        chart, *derivs = _chart_functions()
        self.e_all = ca.vec(chart.map(n)(self.Z, self.FR))
        if not self.derivatives:
            return
        self.chart_jac, self.chart_hess, self.chart_jtg, self.pair_jj = (
            (_jit(f) for f in derivs) if self.jit else derivs)
        self.JV = self.chart_jac.map(n)(self.Z, self.FR)          # (6, n): 3x2 per vertex, column-major
        self.jv_all = ca.vec(self.JV)

    def _energy(self, val, w) -> None:
        self.e_vals.append(val)
        self.f += w * val

    def quadratic(self, t: Term, off: int) -> None:
        """An energy ``scale * e^T Q e`` (``t.matrix``: Q over the term's coordinates)."""
        n_e, lam_f = 3 * self.lay.n_vertices, self.lam_f
        Q = sp.coo_matrix(t.matrix)
        Qg = sp.csc_matrix((Q.data, (Q.row + t.offset, Q.col + t.offset)), shape=(n_e, n_e))
        w = self.p[off]
        qe = ca.mtimes(_to_casadi(Qg), self.e_all)
        self._energy(t.scale * ca.dot(self.e_all, qe), w)
        if not self.derivatives:
            return
        ge = 2.0 * t.scale * w * qe
        coef = 2.0 * t.scale * w * lam_f
        if not self.lay.tangent:   # constant Hessian: added as a whole in finish
            self.dense_grad.append(ge)
            self.quad_h.append((coef, sp.triu(Qg).tocsc()))
            return
        self.dense_grad.append(ca.vec(self.chart_jtg.map(self.lay.n_vertices)(
            self.JV, ca.reshape(ge, 3, self.lay.n_vertices))))
        if self.hessian != "gauss-newton":   # Gauss-Newton: J^T Q J only, no chart curvature
            self.dense_lag.append(lam_f * ge)
        self._quadratic_in_z(t, coef)

    def _quadratic_in_z(self, t: Term, coef) -> None:
        """``coef * J^T Q J`` in the tangent coordinates: Q = Q1 (x) I3 couples vertices i, j
        by q_ij I3, so their 2x2 block is q_ij J_i^T J_j (upper triangle kept)."""
        Q1 = sp.coo_matrix(t.matrix[0::3, 0::3])
        vo = t.offset // 3
        up = Q1.row <= Q1.col
        vi, vj, q = Q1.row[up] + vo, Q1.col[up] + vo, Q1.data[up]
        JI = ca.reshape(self.jv_all[(6 * vi[:, None] + np.arange(6)).ravel().tolist()], 6, len(vi))
        JJ = ca.reshape(self.jv_all[(6 * vj[:, None] + np.arange(6)).ravel().tolist()], 6, len(vj))
        blocks = self.pair_jj.map(len(vi))(JI, JJ, ca.DM(q).T * 1.0) * coef   # (4, m): (00, 10, 01, 11)
        # local entries (a, b) -> z ids (2 vi + a, 2 vj + b); keep the upper triangle
        R = 2 * vi[:, None] + np.array([0, 1, 0, 1])
        C = 2 * vj[:, None] + np.array([0, 0, 1, 1])
        sel = np.flatnonzero((R <= C).ravel())
        self.hess.add(ca.vec(blocks)[sel.tolist()], R.ravel()[sel], C.ravel()[sel])

    def _kernels(self, t: Term) -> Local:
        """The element kernels of ``t`` (Gauss-Newton ones for a least-squares energy when
        asked), compiled once per element function."""
        el = t.element
        gn = self.hessian == "gauss-newton" and not t.constraint and el.residual is not None
        key = (id(el.fn), self.lay.tangent, gn, self.jit, t.constraint)
        kept = self.local.get(key)
        if kept is None or kept[0] is not el.fn:     # (the function is kept: its id is not reused)
            kept = self.local[key] = (el.fn, Local(el.fn, el.k, self.lay.tangent,
                                                   self.jit and not el.fn.name().startswith("custom_"),
                                                   t.constraint, residual=el.residual if gn else None))
        return kept[1]

    def _element_args(self, t: Term, off: int):
        """The kernels' mapped arguments ``(X, D, P, JL)`` over the term's ``m`` elements, and
        the variable ids ``(m, k dof)`` of each element's local derivatives."""
        m, dof = t.size, self.lay.dof
        verts = t.idx[:, ::3] // 3
        xidx = (dof * verts[:, :, None] + np.arange(dof)).reshape(m, -1)
        X, D, P = self._value_args(t, off)
        if self.lay.tangent:   # each element's vertices' chart Jacobians
            jidx = (6 * verts[:, :, None] + np.arange(6)).reshape(m, -1)
            JL = ca.reshape(self.jv_all[jidx.ravel().tolist()], jidx.shape[1], m)
        else:
            JL = ca.MX(0, m)
        return (X, D, P, JL), xidx

    def element(self, t: Term, off: int, go: int | None) -> None:
        """An element term: energy (``go`` None) or constraint rows from ``go`` on."""
        if not self.derivatives:
            self._element_values(t, off, go)
            return
        L = self._kernels(t)
        args, xidx = self._element_args(t, off)
        m = t.size
        if not t.constraint:
            w = self.p[off]
            self._energy(t.scale * ca.sum2(L.val.map(m)(*args)), w)
            self.grad.add(t.scale * w * ca.vec(L.grad.map(m)(*args)), xidx.ravel())
            coef = ca.repmat(t.scale * w * self.lam_f, 1, m)
        else:
            self.g_parts.append(ca.vec(L.val.map(m)(*args)))
            self.jac.add(ca.vec(L.jac.map(m)(*args)), np.repeat(go + np.arange(m), len(L.j_cols)),
                         xidx[:, L.j_cols].ravel())
            coef = ca.reshape(self.lam_g[go:go + m], 1, m)
        if len(L.h_rows):
            hv = L.hess.map(m)(*args, coef)      # (nh, m)
            hr, hc = xidx[:, L.h_rows].ravel(), xidx[:, L.h_cols].ravel()
            if self.projected and (not t.constraint or self.hessian == "projected-all"):
                self.blocks.append(Block(hv, L.h_rows, L.h_cols, xidx, constraint=t.constraint))
            else:
                self.hess.add(ca.vec(hv), np.minimum(hr, hc), np.maximum(hr, hc))
        if self.lay.tangent and not L.gauss_newton:
            self.lag.add(ca.vec(L.lag_e.map(m)(*args, coef)), t.idx.ravel())

    def _value_args(self, t: Term, off: int):
        """The element function's mapped arguments ``(X, D, P)`` over the term's elements: the
        directions, the data, the parameters."""
        m, r, q = t.size, t.element.n_par, t.element.n_data
        X = ca.reshape(self.e_all[t.idx.ravel().tolist()], t.idx.shape[1], m)
        P = ca.reshape(self.p[off + 1:off + 1 + m * r], r, m) if r else ca.MX(0, m)
        start = off + 1 + t.par.size           # the data follow the term's par (see _Layout)
        D = ca.reshape(self.p[start:start + m * q], q, m) if q else ca.DM(0, m)
        return X, D, P

    def _element_values(self, t: Term, off: int, go: int | None) -> None:
        """An element term's values only: the element function itself, mapped (no kernels)."""
        vals = t.element.fn.map(t.size)(*self._value_args(t, off))
        if go is None:
            self._energy(t.scale * ca.sum2(vals), self.p[off])
        else:
            self.g_parts.append(ca.vec(vals))

    def lifted(self, t: Term, go: int, lo: int, off: int, row_term: int) -> None:
        """The lifted variables' part of a lifted term (``row_term``: its index among the
        constraint terms): its rows become ``G(e) - H(y)``."""
        dg, jp, hp = Built._lift(t, go, lo, self.x_all, self.p, self.lam_g, off)
        self.g_parts[row_term] = self.g_parts[row_term] - dg
        if not self.derivatives:
            return
        self.jac.add(*jp)
        self.hess.add(*hp)

    @property
    def projected(self) -> bool:
        # "projected-all" (the augmented Lagrangian's NLP, :mod:`.alm`): the constraints'
        # element Hessians times their multipliers are projected too
        return self.hessian in ("projected", "projected-all")

    def finish(self):
        """``(grad, g, jac, hess)``: the pieces scattered into the global vectors and matrices."""
        lay = self.lay
        grad = self.grad.vector(lay.n_dir, self.dense_grad)
        if lay.n_lift:   # the objective does not depend on the lifted variables
            grad = ca.vertcat(grad, ca.MX.zeros(lay.n_lift, 1))
        g = ca.vertcat(*self.g_parts) if self.g_parts else ca.MX(0, 1)
        jac = self.jac.matrix(lay.n_g, lay.n_main)
        if lay.tangent:   # the chart's own curvature: sum_c (dL/de_c) d2 e_c / dz2, per vertex
            n = lay.n_vertices
            g_lag = self.lag.vector(3 * n, self.dense_lag)
            dz = self.chart_hess.map(n)(self.Z, self.FR, ca.reshape(g_lag, 3, n))   # (3, n)
            base = 2 * np.arange(n)
            if self.projected:
                self.blocks.append(Block(dz, np.array([0, 0, 1]), np.array([0, 1, 1]),
                                         np.stack([base, base + 1], 1)))
            else:
                self.hess.add(ca.vec(dz), np.stack([base, base, base + 1], 1).ravel(),
                              np.stack([base, base + 1, base + 1], 1).ravel())
        hess = self.hess.matrix(lay.n_main, lay.n_main)
        for coef, Qg in self.quad_h:
            Qg.resize((lay.n_main, lay.n_main))
            hess = hess + coef * _to_casadi(Qg)
        return grad, g, jac, hess


class Built:
    """The assembled NLP of one problem structure (internal).

    ``mode``: ``"constraint"`` / ``"renormalize"`` / ``"penalty"`` (variables: the ``3 n``
    direction coordinates) or ``"tangent"`` (``2 n`` gnomonic coordinates around per-vertex
    frames that are NLP parameters, see :func:`_chart_functions`).

    ``lazy=True``: only the values (:meth:`evaluate`) are assembled at first; the derivatives
    and the NLP's expressions (:data:`DERIVED`) on their first use (:meth:`derive`). IPOPT's
    main NLP is built so: where its pass without inequalities answers (Fig. 12 rows 7a, 7b,
    11, 13), the main NLP only evaluates the energies and checks the rows.
    """

    #: the attributes a lazily built NLP assembles on first use (:meth:`derive`)
    DERIVED = frozenset({"x", "p", "f_expr", "g_expr", "grad_f", "jac_g", "point", "value", "hess_lag"})

    def __init__(self, terms: list[Term], n_vertices: int, mode: str, jit: bool = False,
                 hessian: str = "exact", elastic: float = 0.0, lazy: bool = False, kernels: dict | None = None):
        t0 = time.perf_counter()
        self.terms, self.mode, self.n_vertices = terms, mode, n_vertices
        self.hessian = hessian
        self.elastic = float(elastic)
        lay = _Layout.of(terms, n_vertices, mode == "tangent", elastic)
        self.cons, self.elastic_rows, self.lifts = lay.cons, lay.elastic_rows, lay.lifts
        self.n_slack, self.n_dir, self.n_lift = lay.n_slack, lay.n_dir, lay.n_lift
        self.n_main, self.n_var, self.n_frames = lay.n_main, lay.n_var, lay.n_frames
        self.p_offsets, self.n_par = lay.p_offsets, lay.n_par
        self.g_offsets, self.n_g = lay.g_offsets, lay.n_g
        self.g_slices = [slice(int(o), int(o) + t.size) for o, t in zip(lay.g_offsets, lay.cons)]
        self._lay, self._jit, self._derived, self._kernels = lay, jit, not lazy, kernels
        if lazy:
            asm = self._assemble(lay, jit, derivatives=False)
            self._evaluate = self._values_function(asm)
        else:
            self._functions(self._assemble(lay, jit))
        self._bounds()
        self.solvers: dict = {}
        # first Hessian regularization per IPOPT objective scaling (see _hessian_shift)
        self.hessian_shifts: dict[tuple, float] = {}
        self.seconds = time.perf_counter() - t0

    def __getattr__(self, name: str):
        # only called for attributes not set: the derived ones of a lazy NLP, assembled now
        if name in Built.DERIVED and not self.__dict__.get("_derived", True):
            self.derive()
            return getattr(self, name)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    def derive(self) -> float:
        """Assemble the derivatives and the NLP's expressions of a lazily built NLP (once);
        returns the seconds it took (0 when done before)."""
        if self._derived:
            return 0.0
        t0 = time.perf_counter()
        self._derived = True
        self._functions(self._assemble(self._lay, self._jit))
        return time.perf_counter() - t0

    def _assemble(self, lay: _Layout, jit: bool, derivatives: bool = True) -> _Assembly:
        """Every term's pieces, then the lifted terms' variables."""
        asm = _Assembly(lay, jit, self.hessian, derivatives, self._kernels)
        ci = 0
        for t, off in zip(self.terms, lay.p_offsets):
            if t.matrix is not None:
                asm.quadratic(t, off)
            elif t.constraint:
                asm.element(t, off, int(lay.g_offsets[ci]))
                ci += 1
            else:
                asm.element(t, off, None)
        for t, go, lo in lay.lifts:
            off = lay.p_offsets[next(i for i, u in enumerate(self.terms) if u is t)]
            asm.lifted(t, go, lo, off, next(i for i, u in enumerate(lay.cons) if u is t))
        return asm

    def _functions(self, asm: _Assembly) -> None:
        """The casadi Functions of the NLP (with the elastic slacks) and of the plain values."""
        x_all, p, f = asm.x_all, asm.p, asm.f
        grad, g, jac, hess = asm.finish()
        if "_evaluate" not in self.__dict__:     # (a lazy NLP keeps its values-only one)
            self._evaluate = self._values_function(asm, g)
        if self.n_slack:
            f, grad, g, jac, hess = self._elastic(x_all, p, f, grad, g, jac, hess)
        self.x, self.p = x_all, p
        self.f_expr, self.g_expr = f, g
        self.grad_f = ca.Function("nlp_grad_f", [x_all, p], [f, grad], ["x", "p"], ["f", "grad"])
        self.jac_g = ca.Function("nlp_jac_g", [x_all, p], [g, jac], ["x", "p"], ["g", "jac"])
        #: everything of a point at once (the augmented Lagrangian's evaluation: one pass
        #: over the shared chart and gathers)
        self.point = ca.Function("nlp_point", [x_all, p], [f, grad, g, jac], ["x", "p"], ["f", "grad", "g", "jac"])
        #: the objective and the constraint rows only (the augmented Lagrangian's line-search
        #: trials: half the cost of a point)
        self.value = ca.Function("nlp_value", [x_all, p], [f, g], ["x", "p"], ["f", "g"])
        symbols = [x_all, p, asm.lam_f, asm.lam_g]
        if asm.projected:
            self.hess_lag = ProjectedHessian("nlp_hess_l", symbols, hess, asm.blocks, self.n_var)
        else:
            self.hess_lag = ca.Function("nlp_hess_l", symbols, [hess], ["x", "p", "lam_f", "lam_g"], ["hess"])

    @staticmethod
    def _values_function(asm: _Assembly, g=None) -> ca.Function:
        """``[energies, objective, rows]`` of the variables and parameters (``g`` the rows, if
        assembled already)."""
        if g is None:
            g = ca.vertcat(*asm.g_parts) if asm.g_parts else ca.MX(0, 1)
        return ca.Function("evaluate", [asm.x_all, asm.p],
                           [ca.vertcat(*asm.e_vals) if asm.e_vals else ca.MX(0, 1), asm.f, g])

    def _bounds(self) -> None:
        """Constraint and variable bounds and the flags the solvers read."""
        terms, cons = self.terms, self.cons
        self.energy_names = [t.name for t in terms if not t.constraint]
        #: the Lagrangian Hessian is positive semidefinite by construction: no constraint rows
        #: and every energy quadratic (PSD Q) or Gauss-Newton with the chart curvature left out
        self.psd = self.n_g == 0 and (self.hessian in ("projected", "projected-all") or self.hessian == "gauss-newton" and all(
            t.matrix is not None or (t.element.residual is not None) for t in terms))
        self.lbg = np.concatenate([np.full(t.size, t.lower) for t in cons]) if cons else np.zeros(0)
        self.ubg = np.concatenate([np.full(t.size, t.upper) for t in cons]) if cons else np.zeros(0)
        #: variable bounds: the directions are free, elastic slacks are >= 0 (the lifted
        #: variables' bounds depend on the parameters: see variable_bounds)
        self.lbx = np.concatenate([np.full(self.n_main, -np.inf), np.zeros(self.n_slack)])
        self.ubx = np.full(self.n_var, np.inf)
        #: rows of inequality constraints, the lifted forms' included (their equality rows
        #: impose inequalities through the lifted variables' bounds)
        self.inequality_rows = self.lbg < self.ubg
        for t, go, lo in self.lifts:
            self.inequality_rows[go:go + t.size] = True

    def _elastic(self, x_all, p, f, grad, g, jac, hess):
        """The elastic (l1-exact penalty) form of the one-sided inequalities ``c_j >= l_j``.

        Each gets a slack ``p_j >= 0``: ``c_j + p_j >= l_j`` and ``rho / |V| * sum_j p_j`` in
        the objective (``rho``: the last NLP parameter; the energies are means over |V|, IPOPT
        scales the objective by |V|). The slack's column is a unit vector, so the constraint
        Jacobian has full row rank at every point (LICQ holds, also at the apex ``g = 0`` of
        the torsal cones where ``grad c_j = 0``), every start is feasible (``p_j = max(l_j -
        c_j, 0)``), and each multiplier is bounded by ``rho / |V|`` (the slack's dual
        condition), so the constraints' curvature times their multipliers is bounded too.
        For ``rho`` above the multipliers of a KKT point of the original problem, that point
        is a KKT point of the elastic one with ``p = 0`` (exact penalty, Thierry and Biegler
        2020); a positive slack at the answer shows up as a measured violation.
        """
        ns, nd = self.n_slack, self.n_main
        sl = x_all[nd:nd + ns]
        rho = p[self.n_par - 1] / max(self.n_vertices, 1)
        f = f + rho * ca.sum1(sl)
        grad = ca.vertcat(grad, ca.repmat(rho, ns, 1))
        rows = self.elastic_rows
        E = ca.DM(ca.Sparsity(self.n_g, ns, np.arange(ns + 1, dtype=np.int64).tolist(),
                              rows.astype(np.int64).tolist()), 1.0)
        g = g + ca.mtimes(E, sl)
        jac = ca.horzcat(jac, ca.MX(E))
        hess = ca.diagcat(hess, ca.MX(ns, ns))
        return f, grad, g, jac, hess

    @staticmethod
    def _lift(t: Term, go: int, lo: int, x_all, p, lam_g, off: int):
        """The lifted variables' part of a lifted torsal-angle term (see :mod:`.forms`).

        The term's ``3 m`` rows are ``G_k(e)``, the coordinates ``(u, v, w)`` of the torsal
        form of its ``m`` faces (``k``-major: all ``u`` rows, then ``v``, then ``w``). With
        variables ``(r, t, phi)`` per face they become the equality rows::

            G(e) - H(y) = 0,    H(r, t, phi) = (cos(alpha) r t, r cos(phi), r sin(phi))

        and the bounds ``r >= s``, ``-1 <= t <= 1`` (:meth:`variable_bounds`) say
        ``|u| <= cos(alpha) sqrt(v^2 + w^2)`` (torsal angle >= alpha) and strength >= s.
        The inequalities are bounds on variables, no constraint's gradient vanishes (the
        apex ``g = 0`` is outside the bounds), and the nonconvexity of the cone's exterior
        lives in the equality rows (``r cos(phi)``, ``r sin(phi)``). Returns ``H`` as a
        column over the rows and the Jacobian and Hessian-of-the-Lagrangian entries (values,
        rows, columns) in the lifted variables.
        """
        m = t.size // 3
        Y = ca.reshape(x_all[lo:lo + 3 * m], 3, m)
        r, tt, ph = Y[0, :], Y[1, :], Y[2, :]
        c = ca.reshape(p[off + 1:off + 1 + t.size * t.par.shape[1]], t.par.shape[1], t.size)[0, 0:m]
        cs, sn = ca.cos(ph), ca.sin(ph)
        dg = ca.vertcat((c * r * tt).T, (r * cs).T, (r * sn).T)
        f = np.arange(m)
        ru, rv, rw = go + f, go + m + f, go + 2 * m + f
        cr, ct, cp = lo + 3 * f, lo + 3 * f + 1, lo + 3 * f + 2
        jv = ca.vertcat(-(c * tt).T, -(c * r).T, -cs.T, (r * sn).T, -sn.T, -(r * cs).T)
        jr = np.concatenate([ru, ru, rv, rv, rw, rw])
        jc = np.concatenate([cr, ct, cr, cp, cr, cp])
        lu = ca.reshape(lam_g[go:go + m], 1, m)
        lv = ca.reshape(lam_g[go + m:go + 2 * m], 1, m)
        lw = ca.reshape(lam_g[go + 2 * m:go + 3 * m], 1, m)
        hv = ca.vertcat(-(lu * c).T, (lv * sn - lw * cs).T, (r * (lv * cs + lw * sn)).T)
        hr = np.concatenate([cr, cr, cp])
        hc = np.concatenate([ct, cp, cp])
        return dg, (jv, jr, jc), (hv, hr, hc)

    def lifted_values(self, x_dir: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The lifted variables ``(r, t, phi)`` per face that fit the directions' ``x_dir``:
        ``r = max(sqrt(v^2 + w^2), s)``, ``phi = atan2(w, v)``, ``t = u / (cos(alpha) r)``
        clipped to [-1, 1] (so the rows hold exactly where the bounds do)."""
        y = np.zeros(self.n_lift)
        g = self._values(np.concatenate([x_dir, y, np.zeros(self.n_slack)]), p)[2]
        for t, go, lo in self.lifts:
            m = t.size // 3
            u, v, w = g[go:go + m], g[go + m:go + 2 * m], g[go + 2 * m:go + 3 * m]
            off = self.p_offsets[next(i for i, u in enumerate(self.terms) if u is t)]
            par = np.asarray(p, dtype=float)[off + 1:off + 1 + t.par.size].reshape(t.par.shape)
            c, s = par[:m, 0], par[:m, 1]
            r = np.maximum(np.hypot(v, w), s)
            y[lo - self.n_dir:lo - self.n_dir + 3 * m] = np.stack(
                [r, np.clip(u / (c * r), -1.0, 1.0), np.arctan2(w, v)], axis=1).ravel()
        return y

    def variable_bounds(self, current: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
        """``(lbx, ubx)``: lifted ``r >= s`` and ``-1 <= t <= 1`` (``s`` from the ``current``
        terms by name), elastic slacks ``>= 0``, everything else free."""
        lbx, ubx = self.lbx.copy(), self.ubx.copy()
        for t, go, lo in self.lifts:
            m = t.size // 3
            src = (current or {}).get(t.name, t)
            lbx[lo:lo + 3 * m:3] = src.par[:m, 1]
            lbx[lo + 1:lo + 3 * m:3], ubx[lo + 1:lo + 3 * m:3] = -1.0, 1.0
        return lbx, ubx

    def evaluate(self, x: np.ndarray, p: np.ndarray, rows: bool = True):
        """(energies, objective, c) at ``x`` without the elastic slacks and their penalty.

        ``rows=False``: the energies and the objective only (they do not depend on lifted
        variables, which are then not fitted: the rows ``c`` of a lifted form are not valid)."""
        x = np.asarray(x, dtype=float).ravel()
        if not rows and x.size != self.n_var:
            x = np.concatenate([x[:self.n_dir], np.zeros(self.n_lift + self.n_slack)])
        ev, f, g = self._values(self.full(x, p), p)
        return ev, float(f[0]), g

    def _values(self, x: np.ndarray, p: np.ndarray) -> list[np.ndarray]:
        """``[energies, objective (1,), c]`` of :attr:`_evaluate` at all variables ``x`` (numpy
        in and out, through casadi's buffers: :class:`NumericFunction`)."""
        if getattr(self, "_numeric_values", None) is None:
            self._numeric_values = NumericFunction(self._evaluate)
        return self._numeric_values(x, p)

    def derivatives(self, x: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, sp.csc_matrix]:
        """The objective's gradient (n_var,) and the rows' Jacobian (n_g, n_var) at all variables
        ``x`` (through casadi's buffers, :class:`NumericFunction`)."""
        if getattr(self, "_numeric_derivatives", None) is None:
            self._numeric_derivatives = (NumericFunction(self.grad_f), NumericFunction(self.jac_g))
        nf, nj = self._numeric_derivatives
        gs, js = self.grad_f.sparsity_out(1), self.jac_g.sparsity_out(1)
        grad = np.zeros(self.n_var)
        grad[np.asarray(gs.row(), dtype=np.int64)] = nf(x, p)[1]
        jac = sp.csc_matrix((nj(x, p)[1], np.asarray(js.row(), dtype=np.int64),
                             np.asarray(js.colind(), dtype=np.int64)), shape=(self.n_g, self.n_var))
        return grad, jac

    def full(self, x: np.ndarray, p: np.ndarray | None = None) -> np.ndarray:
        """``x`` (directions only, or all variables) as all variables: lifted variables from
        the directions (:meth:`lifted_values`, needs ``p``), slacks kept or 0."""
        x = np.asarray(x, dtype=float).ravel()
        if x.size == self.n_var:
            return x
        y = self.lifted_values(x[:self.n_dir], p) if self.n_lift else np.zeros(0)
        return np.concatenate([x[:self.n_dir], y, np.zeros(self.n_slack)])

    def with_slacks(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """All variables with the elastic slacks just large enough: ``p_j = max(l_j - c_j, 0)``."""
        x = self.full(x, p)
        if self.n_slack:
            c = self._values(np.concatenate([x[:self.n_main], np.zeros(self.n_slack)]), p)[2]
            x = x.copy()
            x[self.n_main:] = np.maximum(self.lbg[self.elastic_rows] - c[self.elastic_rows], 0.0)
        return x

    def penalty(self, x: np.ndarray, p: np.ndarray) -> float:
        """The elastic penalty ``rho / |V| * sum p_j`` at ``x`` (0 without slacks)."""
        if not self.n_slack:
            return 0.0
        return float(p[self.n_par - 1] / max(self.n_vertices, 1) * np.sum(np.asarray(x).ravel()[self.n_main:]))

    # conversions between directions e (n, 3) and the NLP's (x, frames)
    def pack(self, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The directions' variables (``n_dir``; see :meth:`full` for the others) and frames."""
        e = np.asarray(e, dtype=float).reshape(-1, 3)
        if self.mode == "tangent":
            return np.zeros(self.n_dir), tangent_frames(e)
        return e.ravel().copy(), np.zeros((0, 9))

    def unpack(self, x: np.ndarray, frames: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float).ravel()[:self.n_dir]
        if self.mode == "tangent":
            return _from_tangent(x, frames)
        return x.reshape(-1, 3)

    def parameters(self, current: dict | None = None, frames: np.ndarray | None = None) -> np.ndarray:
        """The parameter vector, taking weights, ``par`` and ``data`` (mesh A's points) from
        ``current`` terms by name."""
        current = current or {}
        p = np.empty(self.n_par)
        if self.n_frames:
            p[:self.n_frames] = frames.ravel()
        for t, off in zip(self.terms, self.p_offsets):
            src = current.get(t.name, t)
            p[off] = src.weight if not t.name.startswith("penalty:") else t.weight
            p[off + 1:off + 1 + t.par.size] = src.par.ravel()
            start = off + 1 + t.par.size
            p[start:start + t.data.size] = np.asarray(src.data, dtype=float).ravel()
        if self.n_slack:
            p[-1] = self.elastic
        return p



def _renormalize(x: np.ndarray) -> np.ndarray:
    e = x.reshape(-1, 3)
    n = np.linalg.norm(e, axis=1, keepdims=True)
    return (e / np.where(n > 0, n, 1.0)).ravel()

