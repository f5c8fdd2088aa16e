"""Sparse Cholesky factorization of a fixed pattern: analysed once, refactored every Newton step.

The augmented Lagrangian (:mod:`.alm`) factors one symmetric positive definite matrix per
Newton step, always over the same sparsity pattern (the union of every row's pattern, see
:class:`~torsal.geometry.optimize.alm.NewtonSystem`). A backend that can keep the
fill-reducing ordering and the symbolic factorization (MUMPS called directly, qdldl, CHOLMOD)
computes them once per pattern, kept with the NLP across re-solves.

Backends (:data:`BACKENDS`, the first available is the default; chosen by measurement on
the Newton matrices of the Fig. 12 rows, ``benchmarks/optimize_bench.py --tables factor``):
``"mumps"`` (MUMPS, the library IPOPT uses, as casadi bundles it, so nothing more to install:
multifrontal, dense BLAS on the fronts. Called directly (:mod:`.mumps`): analysed once per
pattern with METIS's ordering, refactored per step, its negative pivots read, so a
factorization proves the matrix positive definite; faster per factor + solve on every Fig. 12
row than casadi's interface, which analyses at every call, and than qdldl (the table prints
both, dated measurements in ``examples/README.md``). Where the library is not the MUMPS
version :mod:`.mumps` describes, casadi's interface is used: it reads no inertia, see
:attr:`SparseCholesky.definite`), ``"qdldl"`` (LDL^T with AMD ordering, ``Solver.update``
refactors on the same pattern: the symbolic analysis is done once; not supernodal, so its
time grows with the fill: row 11's factor has 7.6 million entries), ``"cholmod"``
(SuiteSparse CHOLMOD, supernodal, through ``sksparse`` where it is installed), ``"csparse"``
(casadi's own ``csparsecholesky``; up-looking, no supernodes, so slower on these matrices),
``"splu"`` (scipy's SuperLU, a fallback that always works: it refactors from scratch). The
wheels that bundle CHOLMOD without a refactorization call (cholespy, sksparse-minimal)
repeat the analysis at every step.
"""
from __future__ import annotations

import ctypes
import os
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from . import mumps

#: the backends in order of preference (the first that imports is the default)
BACKENDS = ("mumps", "qdldl", "cholmod", "cholmod-minimal", "csparse", "splu")

#: routes (:attr:`SparseCholesky.route`) whose :meth:`SparseCholesky.factor` proves the matrix
#: positive definite (their pivots are read): MUMPS called directly does, MUMPS through casadi's
#: interface (``"mumps/casadi"``) does not, see :meth:`SparseCholesky.definite`
PROVES_DEFINITE = ("mumps", "qdldl", "cholmod", "cholmod-minimal", "csparse", "splu")

#: largest backward error ``|A x - b| / (|A| |x| + |b|)`` (infinity norms) of a MUMPS solve
#: through casadi's interface that is accepted: it passes none of MUMPS's error codes on, a
#: failed factorization shows in the residual (a backward stable one leaves ~1e-16 even where
#: ``A`` is ill-conditioned)
MUMPS_BACKWARD_ERROR = 1e-8


class NotPositiveDefinite(ArithmeticError):
    """The matrix handed to :meth:`SparseCholesky.factor` is not positive definite.

    ``negative``: the number of negative pivots where the backend counts them (MUMPS called
    directly: its inertia), else None.
    """

    def __init__(self, message: str, negative: int | None = None):
        super().__init__(message)
        self.negative = negative


class SparseCholesky:
    """Factor ``A`` (symmetric positive definite, given by its upper triangle) over one pattern.

    Parameters
    ----------
    pattern : scipy.sparse.csc_matrix
        The upper triangle's pattern (sorted indices; the values are ignored), (n, n).
    backend : str, optional
        One of :data:`BACKENDS`; default the first one available.

    Examples
    --------
    >>> a = sp.csc_matrix(np.triu([[4.0, 1.0], [1.0, 3.0]]))
    >>> f = SparseCholesky(a)
    >>> f.factor(a.data)
    >>> np.round(f.solve(np.array([1.0, 2.0])), 6)
    array([0.090909, 0.636364])
    """

    def __init__(self, pattern: sp.csc_matrix, backend: str | None = None):
        pattern = sp.csc_matrix(pattern)
        pattern.sort_indices()
        self.n = pattern.shape[0]
        self.indptr, self.indices = pattern.indptr.copy(), pattern.indices.copy()
        self.nnz = int(self.indices.size)
        self.backend = backend or default_backend()
        if self.backend not in BACKENDS:
            raise ValueError(f"backend must be one of {BACKENDS}, got {self.backend!r}")
        #: the backend as a report names it: ``"mumps/casadi"`` where MUMPS is reached through
        #: casadi's interface (no inertia, analysed at every call), else :attr:`backend`
        self.route = "mumps/casadi" if self.backend == "mumps" and not mumps.available() else self.backend
        self.factorizations = 0
        self.analyses = 0
        self._impl = None
        # the full symmetric matrix from the upper triangle: positions of each entry in it
        col = np.repeat(np.arange(self.n), np.diff(self.indptr))
        row = self.indices
        off = row != col
        r = np.concatenate([row, col[off]])
        c = np.concatenate([col, row[off]])
        src = np.concatenate([np.arange(self.nnz), np.flatnonzero(off)])
        order = np.lexsort((r, c))
        self._full_src = src[order]
        self._full_indices = r[order].astype(np.int32)
        self._full_indptr = np.searchsorted(c[order], np.arange(self.n + 1)).astype(np.int32)

    def upper(self, data: np.ndarray) -> sp.csc_matrix:
        return sp.csc_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))

    def full(self, data: np.ndarray) -> sp.csc_matrix:
        return sp.csc_matrix((np.asarray(data)[self._full_src], self._full_indices, self._full_indptr),
                             shape=(self.n, self.n))

    def factor(self, data: np.ndarray) -> None:
        """Numeric factorization with the upper triangle's values ``data`` (pattern order).

        Raises :class:`NotPositiveDefinite` if a pivot is not positive.
        """
        self.factorizations += 1
        getattr(self, "_factor_" + self.backend.replace("-", "_"))(np.asarray(data, dtype=float))

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``A^-1 rhs`` with the last :meth:`factor`'s matrix.

        Raises :class:`NotPositiveDefinite` where the backend factors only here (MUMPS) and
        its factorization failed.
        """
        return np.asarray(getattr(self, "_solve_" + self.backend.replace("-", "_"))(np.asarray(rhs, dtype=float))).ravel()

    @property
    def definite(self) -> bool:
        """Whether :meth:`factor` raises :class:`NotPositiveDefinite` for every matrix that is
        not positive definite. MUMPS through casadi's interface (where it cannot be called
        directly) factors an indefinite matrix without saying so: a caller that needs the
        proof (a Newton step from an exact Hessian) then uses another backend, see
        :data:`PROVES_DEFINITE`."""
        return self.route in PROVES_DEFINITE

    # ------------------------------------------------------------------ MUMPS
    def _factor_mumps(self, data):
        if not np.all(np.isfinite(data)):
            raise NotPositiveDefinite("the matrix has entries that are not finite")
        direct = self.route == "mumps"
        if self._impl is None:
            self._impl = (mumps.Mumps(self.indptr, self.indices) if direct
                          else _mumps_solve(self.n, self.indptr, self.indices))
            self.analyses += 1
        if not direct:
            self._data = data        # casadi's interface factors inside the solve
            return
        try:
            negative = self._impl.factor(data)
        except mumps.MumpsError as exc:
            raise NotPositiveDefinite(str(exc)) from None
        if negative:
            raise NotPositiveDefinite(f"{negative} pivots of MUMPS's LDL^T are negative", negative)

    def _solve_mumps(self, rhs):
        if self.route == "mumps":
            return self._impl.solve(rhs)
        # casadi's interface analyses and factors inside the solve: one call per Newton step
        x = self._impl(self._data, rhs)[0]
        if not np.all(np.isfinite(x)) or _backward_error(self.upper(self._data), x, rhs) > MUMPS_BACKWARD_ERROR:
            raise NotPositiveDefinite("MUMPS's factorization failed (the solve's residual is large)")
        return x

    # ------------------------------------------------------------------ CHOLMOD (sksparse)
    def _factor_cholmod(self, data):
        from sksparse.cholmod import CholmodNotPositiveDefiniteError, analyze

        a = self.full(data)
        if self._impl is None:
            self._impl = analyze(a, mode="supernodal", ordering_method="best")
            self.analyses += 1
        try:
            self._impl.cholesky_inplace(a)
        except CholmodNotPositiveDefiniteError as exc:
            raise NotPositiveDefinite(str(exc)) from None

    def _solve_cholmod(self, rhs):
        return self._impl(rhs)

    # ------------------------------------------------------------------ CHOLMOD (sksparse-minimal)
    def _factor_cholmod_minimal(self, data):
        # no refactorization call in this wheel: ordering and symbolic analysis every time
        from sksparse_minimal import SparseCholesky as Chol

        try:
            self._impl = Chol(self.full(data))
            inv_d = self._impl.solve_D(np.ones(self.n))     # 1 / D of LDL^T (1 for LL^T)
        except Exception as exc:      # CHOLMOD's "not positive definite"
            raise NotPositiveDefinite(str(exc)) from None
        if not np.all(np.isfinite(inv_d) & (inv_d > 0)):
            raise NotPositiveDefinite("a pivot of CHOLMOD's factorization is not positive")

    def _solve_cholmod_minimal(self, rhs):
        return self._impl.solve_A(rhs)

    # ------------------------------------------------------------------ QDLDL
    def _factor_qdldl(self, data):
        import qdldl

        a = self.upper(data)
        if self._impl is None:
            self._impl = qdldl.Solver(a, upper=True)
            self.analyses += 1
        else:
            self._impl.update(a, upper=True)
        # LDL^T without pivoting (a quasi-definite solver): positive definite iff every pivot
        # of D is positive (factors() returns L, D and the ordering)
        if np.any(np.asarray(self._impl.factors()[1]) <= 0):
            raise NotPositiveDefinite("a pivot of the LDL^T factorization is not positive")

    def _solve_qdldl(self, rhs):
        return self._impl.solve(rhs)

    # ------------------------------------------------------------------ casadi csparsecholesky
    def _factor_csparse(self, data):
        import casadi as ca

        if self._impl is None:
            spy = ca.Sparsity(self.n, self.n, self._full_indptr.astype(np.int64).tolist(),
                              self._full_indices.astype(np.int64).tolist())
            self._impl = (ca.Linsol("alm_kkt", "csparsecholesky", spy), spy)
            self.analyses += 1
        solver, spy = self._impl
        a = ca.DM(spy, np.asarray(data)[self._full_src])
        if self.analyses == 1 and self.factorizations == 1:
            solver.sfact(a)
        try:
            solver.nfact(a)
        except RuntimeError as exc:
            raise NotPositiveDefinite(str(exc)) from None
        self._a = a

    def _solve_csparse(self, rhs):
        import casadi as ca

        return np.asarray(self._impl[0].solve(self._a, ca.DM(rhs)))

    # ------------------------------------------------------------------ scipy SuperLU
    def _factor_splu(self, data):
        from scipy.sparse.linalg import splu

        try:
            self._impl = splu(self.full(data), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                              options={"SymmetricMode": True})
        except RuntimeError as exc:     # exactly singular
            raise NotPositiveDefinite(str(exc)) from None
        if np.any(self._impl.U.diagonal() <= 0):
            raise NotPositiveDefinite("a pivot of the LU factorization is not positive")

    def _solve_splu(self, rhs):
        return self._impl.solve(rhs)


def _mumps_solve(n: int, indptr: np.ndarray, indices: np.ndarray):
    """``(upper triangle's values, rhs) -> [A^-1 rhs]`` by MUMPS through casadi's interface
    (where :mod:`.mumps` cannot call it directly), a casadi Function called
    through its buffers (:class:`~.numeric.NumericFunction`: converting the values to a DM on
    every call cost 2.3 ms of 7c's 11 ms per step)."""
    import casadi as ca

    from .numeric import NumericFunction

    spy = ca.Sparsity(n, n, indptr.astype(np.int64).tolist(), indices.astype(np.int64).tolist())
    # symmetric, given by the upper triangle; casadi's "posdef" False selects MUMPS's positive
    # definite mode (SYM=1: no pivoting)
    solver = ca.Linsol("alm_kkt", "mumps", spy, {"symmetric": True, "posdef": False})
    # one factorization through the solver's own memory sets MUMPS's print levels to silent
    # (else freeing that memory prints to standard output); the Function's calls reuse it
    eye = ca.DM(spy, (indices == np.repeat(np.arange(n), np.diff(indptr))).astype(float))
    solver.sfact(eye)
    solver.nfact(eye)
    a, b = ca.MX.sym("a", spy), ca.MX.sym("b", n)
    return NumericFunction(ca.Function("alm_kkt_solve", [a, b], [solver.solve(a, b)]))


def _backward_error(upper: sp.csc_matrix, x: np.ndarray, b: np.ndarray) -> float:
    """``|A x - b| / (|A| |x| + |b|)`` in infinity norms, ``A`` given by its upper triangle."""
    ax = upper @ x + upper.T @ x - upper.diagonal() * x
    a = abs(upper)
    norm_a = float(np.max(a @ np.ones(a.shape[0]) + a.T @ np.ones(a.shape[0]) - a.diagonal(), initial=0.0))
    den = norm_a * float(np.max(np.abs(x), initial=0.0)) + float(np.max(np.abs(b), initial=0.0))
    return float(np.max(np.abs(ax - b), initial=0.0)) / den if den > 0 else 0.0


#: threads of casadi's bundled OpenBLAS, the BLAS under MUMPS (IPOPT's linear solver and
#: the augmented Lagrangian's; ``$TORSAL_BLAS_THREADS`` overrides): on these matrices' fronts
#: (a few hundred rows) a second thread measured slower on 2 cores and erratic (7c's Newton
#: matrix: 7 ms per factor + solve on one thread, 7-51 ms on two; row 11 by IPOPT: 10.5 s wall
#: against 12.7 s, 9.9 s processor time against 12.9 s; row 7c, 80 IPOPT iterations at load 11:
#: 28.5 s against 45.0 s, same iterates), and it competes with a design study's other workers
MUMPS_BLAS_THREADS = 1

_blas_threads: int | None = None


def limit_mumps_threads() -> int | None:
    """Set casadi's bundled OpenBLAS to :data:`MUMPS_BLAS_THREADS` threads (or
    ``$TORSAL_BLAS_THREADS``), once per process.

    A thread count the user chose for every OpenBLAS (``OPENBLAS_NUM_THREADS`` or
    ``OMP_NUM_THREADS`` in the environment, without ``TORSAL_BLAS_THREADS``) is left as it is;
    numpy's own BLAS is never touched.

    Returns
    -------
    int or None
        The thread count now set, or None where it was left alone (the user's choice, or no
        OpenBLAS of casadi's found).

    Examples
    --------
    >>> limit_mumps_threads() in (None, MUMPS_BLAS_THREADS)
    True
    """
    global _blas_threads
    chosen = os.environ.get("TORSAL_BLAS_THREADS")
    if _blas_threads is not None or chosen is None and (
            "OPENBLAS_NUM_THREADS" in os.environ or "OMP_NUM_THREADS" in os.environ):
        return _blas_threads
    import casadi

    try:
        n = int(chosen) if chosen is not None else MUMPS_BLAS_THREADS
    except ValueError:
        n = MUMPS_BLAS_THREADS
    for lib in sorted(Path(casadi.__file__).parent.glob("libcasadi-tp-openblas*")):
        try:
            blas = ctypes.CDLL(str(lib))
            blas.openblas_set_num_threads(ctypes.c_int(n))
            _blas_threads = int(blas.openblas_get_num_threads())
            break
        except (OSError, AttributeError):
            continue
    return _blas_threads


def available(backend: str) -> bool:
    """Whether ``backend``'s package imports on this machine."""
    try:
        if backend == "cholmod":
            import sksparse.cholmod  # noqa: F401
        elif backend == "cholmod-minimal":
            import sksparse_minimal  # noqa: F401
        elif backend == "qdldl":
            import qdldl  # noqa: F401
        elif backend == "csparse":
            import casadi  # noqa: F401
        elif backend == "mumps":
            import casadi

            if not casadi.Linsol.has_plugin("mumps"):
                return False
    except ImportError:
        return False
    return backend in BACKENDS


def default_backend() -> str:
    """The first of :data:`BACKENDS` that is available."""
    return next(b for b in BACKENDS if available(b))
