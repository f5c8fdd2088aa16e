"""Projected Newton: the Lagrangian Hessian as a sum of element blocks, each made positive semidefinite.

The exact Hessian of eq. (9) is indefinite away from the optimum (the unit sphere's chart
curvature, the fairness and light energies' second-order terms, the constraints' curvature
times their multipliers). IPOPT then factors ``W + delta I`` for ``delta = 0`` and again for
growing ``delta`` until the inertia is right: two or more factorizations per iteration, and
steps damped uniformly in every direction by ``delta``. Projected Newton (as in elastic
simulation, Teran et al. 2005) instead clamps each element's local Hessian's negative
eigenvalues to zero: the sum is positive semidefinite by construction, exact where each
element's curvature is, and only the element that curves down is flattened, not the whole
system.

:func:`psd_projection` is the kernel (a batch of small symmetric matrices);
:class:`ProjectedHessian` evaluates the element blocks with casadi, projects them and
scatters them into IPOPT's Hessian sparsity.
"""
from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import casadi as ca
import numpy as np
import scipy.sparse as sp

from . import psd_kernel
from .numeric import NumericFunction

#: IPOPT iterations per run with the projected Hessian; the exact Hessian after them.
#: Projected Newton converges linearly where an element's exact Hessian is indefinite at the
#: optimum (energies whose minimum is not zero): measured on row 9's pass without
#: inequalities, projected throughout cost 300 iterations more than exact. Zero-residual
#: designs converge within this many (row 11: 8; the 7a term set at 100k vertices: 2).
PROJECTED_ITERATIONS = 10


def psd_projection(a: np.ndarray, *, mode: str = "clamp") -> np.ndarray:
    """Positive semidefinite versions of a batch of symmetric matrices.

    Parameters
    ----------
    a : (m, n, n) array
        Symmetric matrices.
    mode : {"clamp", "abs"}
        ``"clamp"``: the nearest positive semidefinite matrix (Frobenius norm),
        ``V max(L, 0) V^T`` for ``a = V L V^T`` (negative eigenvalues clamped to 0).
        ``"abs"``: ``V |L| V^T`` (negative eigenvalues mirrored): keeps the size of the
        curvature along a direction that curves down, so a Newton step along it is not
        unbounded by the projection.

    Returns
    -------
    (m, n, n) array
        Matrices that are already positive semidefinite come back unchanged. 2 x 2 blocks
        (the chart's curvature per vertex) take the closed form of their eigenvalues, larger
        ones numpy's ``eigh`` or the compiled kernel of :mod:`.psd_kernel`
        (:data:`PSD_KERNEL`): the same numbers to rounding.

    Examples
    --------
    >>> psd_projection(np.array([[[1.0, 0.0], [0.0, -2.0]]]))[0]
    array([[1., 0.],
           [0., 0.]])
    >>> psd_projection(np.array([[[1.0, 0.0], [0.0, -2.0]]]), mode="abs")[0]
    array([[1., 0.],
           [0., 2.]])
    """
    a = np.array(a, dtype=float)
    if a.shape[0] == 0:
        return a
    if a.shape[1] == 2:
        return _psd_2x2(a, mode)
    chunks = _chunks(len(a))
    if len(chunks) == 1:
        _psd_eigh(a, mode)
    else:
        # each element's projection is its own: the same numbers in any split
        list(_pool().map(lambda c: _psd_eigh(a[c], mode), chunks))
    return a


#: element matrices per thread at least: :func:`psd_projection` splits a larger batch over
#: :data:`PROJECTION_THREADS` threads (numpy's ``eigh`` releases the GIL), a smaller one is not
#: worth the hand-over
PROJECTION_CHUNK = 1024
#: threads of :func:`psd_projection`: the usable cores, at most 4 (an augmented-Lagrangian
#: step of Fig. 12 row 9 projects about 7,400 element Hessians; on 2 cores the eigenvalue
#: decompositions of 7,400 9 x 9 matrices took 0.65-0.75 s of wall time against 1.1 s in one
#: thread, at the same processor time, on a machine loaded 14 deep)
PROJECTION_THREADS = max(1, min(4, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
                                else (os.cpu_count() or 1)))
_POOL: ThreadPoolExecutor | None = None


def _pool() -> ThreadPoolExecutor:
    """The projection's thread pool, made on first use (one per process)."""
    global _POOL
    if _POOL is None:
        _POOL = ThreadPoolExecutor(PROJECTION_THREADS, thread_name_prefix="torsal-psd")
    return _POOL


def _chunks(m: int) -> list[slice]:
    """Slices of ``m`` element matrices, one per thread of :data:`PROJECTION_THREADS`, each of
    at least :data:`PROJECTION_CHUNK` (one slice for a small batch)."""
    k = max(1, min(PROJECTION_THREADS, m // PROJECTION_CHUNK))
    edges = np.linspace(0, m, k + 1).astype(int)
    return [slice(int(lo), int(hi)) for lo, hi in zip(edges[:-1], edges[1:])]


#: how :func:`psd_projection` decomposes blocks larger than 2 x 2: ``"compiled"`` (:mod:`.psd_kernel`,
#: about 4.5 us for an 8 x 8 matrix; numpy's where there is no C compiler) or ``"numpy"`` (numpy's
#: batched ``eigh``, LAPACK's ``dsyevd`` per matrix, about 11 us). Both give the same projection to
#: rounding. Until the augmented Lagrangian's predicted passes followed their model
#: (:data:`.alm.PREDICT_MODEL`) rounding was enough to move its path where the line search cut
#: steps short: Fig. 12 row 9 took 74 Newton steps with numpy's eigh and 137 with the kernel (136
#: with numpy's eigh of the upper triangle). Now 82 / 82 / 76 steps to one design (energies within
#: 0.02 %), the kernel's the fastest: ``torsal design``'s congruence stage 28.1 s cpu against numpy's
#: 31.2 (row 9), 7c 3.15 against 3.38, the facade at 80 degrees 3.64 against 3.44 (one run each,
#: 2026-11-29 at a load of 14-16: within the noise; the projection alone 0.37 against 0.68-0.92 s
#: of 7c's, measured before). ``benchmarks/optimize_bench.py --tables design --psd numpy`` measures
#: the other
PSD_KERNEL = "compiled"


def _psd_eigh(a: np.ndarray, mode: str) -> None:
    """:func:`psd_projection` of (m, n, n) symmetric matrices ``a`` in place: by the compiled
    kernel (:mod:`.psd_kernel`) where :data:`PSD_KERNEL` asks for it and it is available,
    numpy's ``eigh`` otherwise and for the matrices the kernel leaves (entries not finite,
    eigenvalues not converged)."""
    left = psd_kernel.project(a, mode) if PSD_KERNEL == "compiled" else None
    if left is None:
        _psd_numpy(a, mode)
    elif left.size:
        sub = a[left]
        _psd_numpy(sub, mode)
        a[left] = sub


def _psd_numpy(a: np.ndarray, mode: str) -> None:
    """:func:`psd_projection` of (m, n, n) symmetric matrices ``a`` in place, by numpy's ``eigh``."""
    # eigenvectors at once: on the NLP's element Hessians nearly every element has a negative
    # eigenvalue beyond rounding (measured on row 11), so a cheaper eigenvalue-only pass
    # first would cost more than it saves
    w, v = np.linalg.eigh(a)
    neg = np.flatnonzero(w[:, 0] < 0.0)
    if neg.size:
        v = v[neg]
        wn = np.abs(w[neg]) if mode == "abs" else np.maximum(w[neg], 0.0)
        a[neg] = (v * wn[:, None, :]) @ v.transpose(0, 2, 1)


def _psd_2x2(a: np.ndarray, mode: str) -> np.ndarray:
    """:func:`psd_projection` of (m, 2, 2) symmetric matrices by their closed-form eigenvalues."""
    p, q, r = a[:, 0, 0], a[:, 0, 1], a[:, 1, 1]
    mean, rad = 0.5 * (p + r), np.hypot(0.5 * (p - r), q)
    lo, hi = mean - rad, mean + rad
    neg = lo < 0.0
    if not neg.any():
        return a
    f = np.abs if mode == "abs" else (lambda x: np.maximum(x, 0.0))
    l1, l2 = f(lo[neg]), f(hi[neg])
    # a = lo P_lo + hi P_hi with P_hi = (a - lo I) / (hi - lo) (P_lo = I - P_hi); rad = 0: a = lo I
    d = np.where(rad[neg] > 0, 2.0 * rad[neg], 1.0)
    ph = (a[neg] - lo[neg, None, None] * np.eye(2)) / d[:, None, None]
    ph = np.where((rad[neg] > 0)[:, None, None], ph, 0.0)
    a[neg] = l1[:, None, None] * (np.eye(2) - ph) + l2[:, None, None] * ph
    return a


@dataclass(frozen=True)
class Block:
    """The element Hessians of one term as ``(nh, m)`` values over a local pattern.

    ``values``: column ``e`` holds element ``e``'s local entries at ``(rows[k], cols[k])``
    (upper triangle, ``rows <= cols``) of its ``n x n`` local matrix; ``ids``: ``(m, n)``
    the global variable of each local one.
    """

    values: ca.MX
    rows: np.ndarray
    cols: np.ndarray
    ids: np.ndarray
    constraint: bool = False     # a constraint's element Hessians times its multipliers

    @property
    def n(self) -> int:
        return int(self.ids.shape[1])


def _bound_pieces(name: str, symbols: list, rest: ca.MX, blocks: list) -> NumericFunction:
    """A casadi Function of the Hessian's pieces (the rest's nonzeros, then each block's
    element matrices as ``(m, nh)``) that writes straight into numpy arrays (no copies)."""
    fn = ca.Function(name, symbols, [rest] + [b.values for b in blocks])
    return NumericFunction(fn, copy=False, shapes=[None] + [(b.values.size2(), b.values.size1()) for b in blocks])


class ProjectedHessian(ca.Callback):
    """The Lagrangian Hessian ``rest + sum_b P(block_b)`` as a casadi Function for IPOPT.

    ``rest`` (an MX of the NLP's symbols, upper triangle): the parts that are positive
    semidefinite as they are (quadratic energies ``J^T Q J``) or not element-wise; each
    :class:`Block` is projected element by element with :func:`psd_projection`. Inputs
    ``(x, p, lam_f, lam_g)`` as :attr:`~torsal.geometry.optimize.nlp.Built.hess_lag`; output
    the upper triangle, ``(n_var, n_var)``. With :attr:`project` False the blocks are summed
    as they are: the exact Hessian, in the same sparsity (IPOPT switches between the two in
    one run, see :data:`PROJECTED_ITERATIONS`).
    """

    #: project the blocks (True) or sum them as they are (the exact Hessian)
    project: bool = True
    #: how a block is made positive semidefinite (:func:`psd_projection`)
    mode: str = "clamp"
    #: projected: the constraints' curvature (times their multipliers) projected (True) or
    #: left out (False: the augmented Lagrangian's penalty supplies the curvature across
    #: the constraints, ``rho J^T J``)
    constraint_curvature: bool = True

    def __init__(self, name: str, symbols: list, rest: ca.MX, blocks: list[Block], n_var: int):
        ca.Callback.__init__(self)
        self.blocks = blocks
        self._name, self._symbols, self._rest = name, symbols, rest
        self._all = _bound_pieces(name + "_pieces", symbols, rest, blocks)
        self._energy_only = None     # the pieces without the constraints' blocks (built on first use)
        # per block, the last projection: (mode, the live elements' matrices, their projection)
        self._last: dict[int, tuple] = {}
        self._in = [s.sparsity() for s in symbols]
        # global positions: the rest's nonzeros, then every block's full local upper triangle
        rs = rest.sparsity()
        keys = [np.asarray(rs.get_col(), dtype=np.int64) * n_var + np.asarray(rs.row(), dtype=np.int64)]
        self._upper = []
        for b in blocks:
            iu, ju = np.triu_indices(b.n)
            gi, gj = b.ids[:, iu], b.ids[:, ju]
            keys.append((np.maximum(gi, gj) * n_var + np.minimum(gi, gj)).ravel())
            self._upper.append((iu, ju))
        keys = np.concatenate(keys)
        ukey, pos = np.unique(keys, return_inverse=True)
        self._scatter = sp.csr_matrix((np.ones(keys.size), (pos.ravel(), np.arange(keys.size))),
                                      shape=(ukey.size, keys.size))
        col, row = ukey // n_var, ukey % n_var
        colind = np.searchsorted(col, np.arange(n_var + 1))
        self._out = ca.Sparsity(n_var, n_var, colind.astype(np.int64).tolist(), row.astype(np.int64).tolist())
        self.construct(name, {})

    def get_n_in(self):
        return len(self._in)

    def get_n_out(self):
        return 1

    def get_sparsity_in(self, i):
        return self._in[i]

    def get_sparsity_out(self, i):
        return self._out

    def has_eval_buffer(self):
        return True

    @property
    def sparsity(self) -> ca.Sparsity:
        """The output's sparsity (upper triangle, column-compressed)."""
        return self._out

    def pieces(self, args: list[np.ndarray], constraints: bool = True
               ) -> tuple[np.ndarray, list[np.ndarray | None]]:
        """The rest's nonzeros and every block's element matrices (m, n, n) at ``(x, p, lam_f, lam_g)``.

        ``constraints=False``: the constraints' blocks are not evaluated (None in their place;
        the augmented Lagrangian's projected matrix leaves them out: on Fig. 12 row 9 they are
        10,000 of the 17,400 element Hessians of a step).
        """
        if constraints or not any(b.constraint for b in self.blocks):
            bound, energy_only = self._all, False
        else:
            if self._energy_only is None:
                self._energy_only = _bound_pieces(self._name + "_pieces_e", self._symbols, self._rest,
                                                  [b for b in self.blocks if not b.constraint])
            bound, energy_only = self._energy_only, True
        # an empty input (no constraint rows) is passed as an empty array
        res = bound(*[np.ascontiguousarray(a, dtype=float) if sp_.nnz() else _EMPTY
                      for a, sp_ in zip(args, self._in)])
        if energy_only:
            it = iter(res[1:])
            res = [res[0]] + [None if b.constraint else next(it) for b in self.blocks]
        mats = []
        for b, v in zip(self.blocks, res[1:]):
            if v is None:
                mats.append(None)
                continue
            a = np.zeros((v.shape[0], b.n, b.n))     # v: (m, nh), element-major (casadi column-major)
            a[:, b.rows, b.cols] = v
            a[:, b.cols, b.rows] = v
            mats.append(a)
        return res[0].copy(), mats

    def combine(self, rest: np.ndarray, mats: list[np.ndarray], project: bool) -> np.ndarray:
        """The output's nonzeros (in :attr:`sparsity` order) from :meth:`pieces`: the blocks
        projected (``project``) or summed as they are (the exact Hessian)."""
        vals = [rest]
        for i, (blk, (iu, ju), a) in enumerate(zip(self.blocks, self._upper, mats)):
            if a is None or (project and blk.constraint and not self.constraint_curvature):
                vals.append(np.zeros(blk.ids.shape[0] * iu.size))
                continue
            if project:
                # elements whose matrix is zero (constraint rows without a multiplier) stay zero
                live = np.flatnonzero(np.abs(a).reshape(len(a), -1).max(axis=1, initial=0.0) > 0)
                a = a.copy()
                a[live] = self._projected(i, a[live])
            vals.append(a[:, iu, ju].ravel())
        return self._scatter @ np.concatenate(vals)

    def _projected(self, i: int, a: np.ndarray) -> np.ndarray:
        """:func:`psd_projection` of block ``i``'s live element matrices ``a`` (m, n, n), or the
        last one's where ``a`` is the same to the bit: an energy's blocks depend on the point
        alone, and the augmented Lagrangian projects them again at the same point after a
        multiplier update or a failed line search (Fig. 12 row 7c: 31 projections of its
        3,008 8 x 8 element Hessians, 26 distinct). The projection of equal matrices is equal,
        so the answer is the same numbers; compared per call (1.5 MB, well under 1 ms)."""
        last = self._last.get(i)     # one tuple, replaced whole: safe to read from any thread
        if last is not None and last[0] == self.mode and np.array_equal(last[1], a):
            return last[2]
        out = psd_projection(a, mode=self.mode)
        self._last[i] = (self.mode, a, out)
        return out

    def nonzeros(self, args: list[np.ndarray]) -> np.ndarray:
        """The output's nonzeros (in :attr:`sparsity` order) at ``(x, p, lam_f, lam_g)`` (numpy)."""
        rest, mats = self.pieces(args)
        return self.combine(rest, mats, self.project)

    def eval_buffer(self, arg, res):
        # kept alive during the call; an empty input (no constraint rows) has no buffer
        args = [np.frombuffer(a, dtype=float) if sp_.nnz() else np.zeros(0) for a, sp_ in zip(arg, self._in)]
        np.frombuffer(res[0], dtype=float)[:] = self.nonzeros(args)
        return 0


_EMPTY = np.zeros(0)
