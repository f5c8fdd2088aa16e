"""NLP assembly: value, gradient, constraint Jacobian and Lagrangian Hessian of a term list.

:class:`Built` maps every term's element kernels over its elements and scatters the local
derivatives into the global sparse matrices with constant 0/1 scatter matrices (linear in the
mesh size). See the package docstring for why the Hessian is assembled by hand.
"""
from __future__ import annotations

import time

import casadi as ca
import numpy as np
import scipy.sparse as sp

from .catalogue import Term
from .kernels import Local, _chart_functions, _jit

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


class Built:
    """The assembled NLP of one problem structure (internal).

    ``mode``: ``"constraint"`` / ``"renormalize"`` / ``"penalty"`` (variables: the ``3 n``
    direction coordinates) or ``"tangent"`` (``2 n`` gnomonic coordinates around per-vertex
    frames that are NLP parameters, see :func:`_chart_functions`).
    """

    def __init__(self, terms: list[Term], n_vertices: int, mode: str, jit: bool = False,
                 hessian: str = "exact", elastic: float = 0.0):
        t0 = time.perf_counter()
        self.terms, self.mode, self.n_vertices = terms, mode, n_vertices
        self.hessian = hessian
        tangent = mode == "tangent"
        dof = 2 if tangent else 3
        n_e = 3 * n_vertices
        n_var = dof * n_vertices
        cons = [t for t in terms if t.constraint]
        # elastic rows: the one-sided inequalities c >= lower (see _elastic)
        el_rows = np.concatenate([np.full(t.size, np.isfinite(t.lower) and not np.isfinite(t.upper))
                                  for t in cons]) if cons and elastic > 0 else np.zeros(0, bool)
        self.elastic_rows = np.flatnonzero(el_rows)
        self.n_slack = int(self.elastic_rows.size)
        self.elastic = float(elastic)
        # lifted torsal forms (see _lift): 3 variables (r, t, phi) per face of a lifted term,
        # one per row; after the directions, before the elastic slacks
        self.lifts = []
        n_lift = 0
        g_start = np.concatenate([[0], np.cumsum([c.size for c in cons])]).astype(np.int64)
        for t, go in zip(cons, g_start):
            if t.lift:
                self.lifts.append((t, int(go), n_var + n_lift))
                n_lift += t.size
        self.n_dir, self.n_lift = n_var, n_lift
        self.n_main = n_var + n_lift
        self.n_var = self.n_main + self.n_slack
        x_all = ca.MX.sym("x", self.n_var)
        x = x_all[0:n_var] if self.n_var > n_var else x_all
        n_fr = 9 * n_vertices if tangent else 0
        self.n_frames = n_fr
        offsets, n_p = [], n_fr
        for t in terms:
            offsets.append(n_p)
            n_p += 1 + t.par.size
        n_p += 1 if self.n_slack else 0      # the elastic penalty weight, last
        self.p_offsets, self.n_par = offsets, n_p
        p = ca.MX.sym("p", n_p)
        lam_f = ca.MX.sym("lam_f")
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
                if hessian == "exact":   # Gauss-Newton: J^T Q J only, no chart curvature
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
            gn = hessian == "gauss-newton" and not t.constraint and el.residual is not None
            key = (id(el.fn), tangent, gn)
            if key not in local:
                local[key] = Local(el.fn, el.k, tangent, jit and not el.fn.name().startswith("custom_"),
                                   t.constraint, residual=el.residual if gn else None)
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
            if tangent and not L.gauss_newton:
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
        if n_lift:   # the objective does not depend on the lifted variables
            grad = ca.vertcat(grad, ca.MX.zeros(n_lift, 1))
        n_main = self.n_main
        for t, go, lo in self.lifts:
            off = offsets[next(i for i, u in enumerate(terms) if u is t)]
            dg, jp, hp = self._lift(t, go, lo, x_all, p, lam_g, off)
            ci = next(i for i, u in enumerate(cons) if u is t)
            g_parts[ci] = g_parts[ci] - dg
            for parts, (vals, rr, cc) in ((j_parts, jp), (h_parts, hp)):
                parts.append(vals)
                (j_rows if parts is j_parts else h_rows).append(rr)
                (j_cols if parts is j_parts else h_cols).append(cc)
        g = ca.vertcat(*g_parts) if g_parts else ca.MX(0, 1)
        if j_parts:
            jr, jcol = np.concatenate(j_rows), np.concatenate(j_cols)
            ukey, S = _scatter(jcol * n_g + jr)
            jac = ca.MX(_ccs(ukey, n_g, n_main), ca.mtimes(S, ca.vertcat(*j_parts)))
        else:
            jac = ca.MX(n_g, n_main)
        if tangent:   # the chart's own curvature: sum_c (dL/de_c) d2 e_c / dz2, per vertex
            g_lag = scatter_dense(lag_parts, lag_rows, n_e, dense_lag)
            dz = chart_hess.map(n_vertices)(Z, FR, ca.reshape(g_lag, 3, n_vertices))   # (3, n)
            h_parts.append(ca.vec(dz))
            base = 2 * np.arange(n_vertices)
            h_rows.append(np.stack([base, base, base + 1], 1).ravel())
            h_cols.append(np.stack([base, base + 1, base + 1], 1).ravel())
        if h_parts:
            hr, hc = np.concatenate(h_rows), np.concatenate(h_cols)
            ukey, S = _scatter(hc * n_main + hr)
            hess = ca.MX(_ccs(ukey, n_main, n_main), ca.mtimes(S, ca.vertcat(*h_parts)))
        else:
            hess = ca.MX(ca.Sparsity(n_main, n_main))
        for coef, Qg in quad_h:
            Qg.resize((n_main, n_main))
            hess = hess + coef * _to_casadi(Qg)

        self._evaluate = ca.Function("evaluate", [x_all, p],
                                     [ca.vertcat(*e_vals) if e_vals else ca.MX(0, 1), f, g])
        if self.n_slack:
            f, grad, g, jac, hess = self._elastic(x_all, p, f, grad, g, jac, hess)
        self.x, self.p = x_all, p
        self.f_expr, self.g_expr = f, g
        self.grad_f = ca.Function("nlp_grad_f", [x_all, p], [f, grad], ["x", "p"], ["f", "grad"])
        self.jac_g = ca.Function("nlp_jac_g", [x_all, p], [g, jac], ["x", "p"], ["g", "jac"])
        self.hess_lag = ca.Function("nlp_hess_l", [x_all, p, lam_f, lam_g], [hess],
                                    ["x", "p", "lam_f", "lam_g"], ["hess"])
        self.energy_names = [t.name for t in terms if not t.constraint]
        #: the Lagrangian Hessian is positive semidefinite by construction: no constraint rows
        #: and every energy quadratic (PSD Q) or Gauss-Newton with the chart curvature left out
        self.psd = n_g == 0 and hessian == "gauss-newton" and all(
            t.matrix is not None or (t.element.residual is not None) for t in terms)
        self.cons = cons
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
        self.solvers: dict = {}
        # first Hessian regularization per IPOPT objective scaling (see _hessian_shift)
        self.hessian_shifts: dict[tuple, float] = {}
        self.seconds = time.perf_counter() - t0

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
        g = np.asarray(self._evaluate(np.concatenate([x_dir, y, np.zeros(self.n_slack)]), p)[2]).ravel()
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

    def evaluate(self, x: np.ndarray, p: np.ndarray):
        """(energies, objective, c) at ``x`` without the elastic slacks and their penalty."""
        return self._evaluate(self.full(x, p), p)

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
            c = np.asarray(self._evaluate(np.concatenate([x[:self.n_main], np.zeros(self.n_slack)]), p)[2]).ravel()
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
        """The parameter vector, taking weights and data from ``current`` terms by name."""
        current = current or {}
        p = np.empty(self.n_par)
        if self.n_frames:
            p[:self.n_frames] = frames.ravel()
        for t, off in zip(self.terms, self.p_offsets):
            src = current.get(t.name, t)
            p[off] = src.weight if not t.name.startswith("penalty:") else t.weight
            p[off + 1:off + 1 + t.par.size] = src.par.ravel()
        if self.n_slack:
            p[-1] = self.elastic
        return p



def _renormalize(x: np.ndarray) -> np.ndarray:
    e = x.reshape(-1, 3)
    n = np.linalg.norm(e, axis=1, keepdims=True)
    return (e / np.where(n > 0, n, 1.0)).ravel()

