"""MUMPS called directly: one analysis per matrix pattern, a refactorization per Newton step,
and the factor's inertia.

The augmented Lagrangian (:mod:`.alm`) factors matrices of one fixed pattern hundreds of times
per solve. casadi's interface to MUMPS (``casadi.Linsol(..., "mumps", ...)``) runs MUMPS's
analysis (fill-reducing ordering and symbolic factorization) again at every factorization
(``JOB=4``), passes none of MUMPS's error codes on and reads no inertia. This module calls the
same library, the MUMPS that casadi bundles for IPOPT (nothing more to install), through its C
interface ``dmumps_c``: ``JOB=1`` once per pattern with METIS's ordering, then ``JOB=2`` per
matrix and ``JOB=3`` per right-hand side; ``INFOG(12)`` counts the negative pivots of the
symmetric ``LDL^T`` (so a factorization proves a matrix positive definite) and ``INFOG(1)``
says when a factorization failed.

The C structure is MUMPS 5.8's ``DMUMPS_STRUC_C`` (``dmumps_c.h``). The library writes its
version into that structure when an instance starts; where the version read at this layout's
place is not 5.8, :func:`available` is False and callers keep casadi's interface.
"""
from __future__ import annotations

import ctypes as C
import enum
import threading
from pathlib import Path

import numpy as np

#: the MUMPS versions whose ``DMUMPS_STRUC_C`` is :class:`_Struc`
VERSIONS = (b"5.8.",)

#: MUMPS's ``comm_fortran`` for the sequential library (no MPI)
_USE_COMM_WORLD = -987654

#: ``INFOG(1)`` codes of a workspace that was estimated too small: the factorization is
#: repeated with ``ICNTL(14)`` (the workspace's margin over the analysis' estimate, percent)
#: doubled, up to :data:`WORKSPACE_RETRIES` times
_WORKSPACE = (-8, -9, -14, -15, -17, -20)
WORKSPACE_RETRIES = 4


class Ordering(enum.IntEnum):
    """MUMPS's fill-reducing orderings (``ICNTL(7)``)."""

    AMD = 0
    AMF = 2
    PORD = 4
    METIS = 5
    QAMD = 6
    AUTO = 7


#: the ordering of the Newton matrices: METIS's gave the fewest factor entries and the fastest
#: factorizations on Fig. 12's rows 7c, 9, 13 and 11 (MUMPS's automatic choice takes AMF on the
#: smaller ones, with 10-20 % more factor entries)
ORDERING = Ordering.METIS


class MumpsError(RuntimeError):
    """MUMPS reported an error (``INFOG(1) < 0``); ``code`` is that value (MUMPS user guide,
    section 8: -10 is a numerically singular matrix)."""

    def __init__(self, code: int, what: str):
        super().__init__(f"MUMPS {what} failed with INFOG(1) = {code}")
        self.code = code


_I, _I8, _D, _P = C.c_int, C.c_int64, C.c_double, C.c_void_p


class _Struc(C.Structure):
    """``DMUMPS_STRUC_C`` of MUMPS 5.8 (``dmumps_c.h``; ``MUMPS_INT`` 32 bit)."""

    _fields_ = [
        ("sym", _I), ("par", _I), ("job", _I), ("comm_fortran", _I),
        ("icntl", _I * 60), ("keep", _I * 500), ("cntl", _D * 15), ("dkeep", _D * 230),
        ("keep8", _I8 * 150), ("n", _I), ("nblk", _I), ("nz_alloc", _I),
        ("nz", _I), ("nnz", _I8), ("irn", _P), ("jcn", _P), ("a", _P),
        ("nz_loc", _I), ("nnz_loc", _I8), ("irn_loc", _P), ("jcn_loc", _P), ("a_loc", _P),
        ("nelt", _I), ("eltptr", _P), ("eltvar", _P), ("a_elt", _P),
        ("blkptr", _P), ("blkvar", _P), ("perm_in", _P), ("sym_perm", _P), ("uns_perm", _P),
        ("colsca", _P), ("rowsca", _P), ("colsca_from_mumps", _I), ("rowsca_from_mumps", _I),
        ("colsca_loc", _P), ("rowsca_loc", _P), ("rowind", _P), ("colind", _P), ("pivots", _P),
        ("rhs", _P), ("redrhs", _P), ("rhs_sparse", _P), ("sol_loc", _P), ("rhs_loc", _P),
        ("rhsintr", _P), ("irhs_sparse", _P), ("irhs_ptr", _P), ("isol_loc", _P),
        ("irhs_loc", _P), ("glob2loc_rhs", _P), ("glob2loc_sol", _P),
        ("nrhs", _I), ("lrhs", _I), ("lredrhs", _I), ("nz_rhs", _I), ("lsol_loc", _I),
        ("nloc_rhs", _I), ("lrhs_loc", _I), ("nsol_loc", _I),
        ("schur_mloc", _I), ("schur_nloc", _I), ("schur_lld", _I),
        ("mblock", _I), ("nblock", _I), ("nprow", _I), ("npcol", _I), ("ld_rhsintr", _I),
        ("info", _I * 80), ("infog", _I * 80), ("rinfo", _D * 40), ("rinfog", _D * 40),
        ("deficiency", _I), ("pivnul_list", _P), ("mapping", _P), ("singular_values", _P),
        ("size_schur", _I), ("listvar_schur", _P), ("schur", _P), ("wk_user", _P),
        ("version_number", C.c_char * 32), ("ooc_tmpdir", C.c_char * 1024),
        ("ooc_prefix", C.c_char * 256), ("write_problem", C.c_char * 1024), ("lwk_user", _I),
        ("save_dir", C.c_char * 1024), ("save_prefix", C.c_char * 256),
        ("metis_options", _I * 40), ("instance_number", _I),
    ]


#: bytes reserved for one instance: a library whose structure is larger than :class:`_Struc`
#: (another version) writes into this margin, not past it, before its version is checked
_RESERVED = 1 << 16

_lib: C.CDLL | None = None
_checked: bool | None = None
#: one call into MUMPS at a time: ctypes releases the GIL, and the sequential library is not
#: documented as safe for concurrent instances (casadi's interface held the GIL throughout)
_lock = threading.Lock()


def _library() -> C.CDLL | None:
    """casadi's bundled MUMPS (``libcoinmumps``), or None."""
    global _lib
    if _lib is None:
        try:
            import casadi
        except ImportError:
            return None
        for path in sorted(Path(casadi.__file__).parent.glob("libcoinmumps.so*")):
            try:
                lib = C.CDLL(str(path))
                lib.dmumps_c.argtypes = [C.c_void_p]
                lib.dmumps_c.restype = None
                _lib = lib
                break
            except (OSError, AttributeError):
                continue
    return _lib


def available() -> bool:
    """Whether MUMPS can be called directly here: casadi's bundled library is found and its
    version is one whose C structure this module describes (:data:`VERSIONS`).

    Examples
    --------
    >>> isinstance(available(), bool)
    True
    """
    global _checked
    if _checked is None:
        _checked = False
        if _library() is not None:
            try:
                m = Mumps(np.array([0, 1]), np.array([0]))
                m.close()
                _checked = True
            except (MumpsError, OSError):
                pass
    return _checked


class Mumps:
    """One MUMPS instance over a fixed symmetric pattern: ``A = L D L^T`` without pivoting
    (``SYM=1``, the mode for positive definite matrices), the analysis done once.

    Parameters
    ----------
    indptr, indices : (n + 1,), (nnz,) int
        The upper triangle's pattern in compressed columns (sorted row indices).
    ordering : Ordering
        The fill-reducing ordering of the analysis (default :data:`ORDERING`).

    Examples
    --------
    >>> import scipy.sparse as sp
    >>> u = sp.csc_matrix(np.triu([[4.0, 1.0], [1.0, -3.0]]))
    >>> m = Mumps(u.indptr, u.indices)
    >>> m.factor(u.data)          # negative pivots: one negative eigenvalue
    1
    >>> np.round(m.solve(np.array([1.0, 2.0])), 6)
    array([ 0.384615, -0.538462])
    """

    def __init__(self, indptr: np.ndarray, indices: np.ndarray, *, ordering: Ordering = ORDERING):
        lib = _library()
        if lib is None:
            raise OSError("casadi's MUMPS library (libcoinmumps) was not found")
        self._lib, self._open = lib, False
        self._mem = bytearray(_RESERVED)
        self._s = _Struc.from_buffer(self._mem)
        s = self._s
        s.sym, s.par, s.job, s.comm_fortran = 1, 1, -1, _USE_COMM_WORLD
        self._call(-1, "initialization")
        self._open = True
        # silent: no error, warning or statistics streams (ICNTL sits at the same place in every
        # version, so this holds also for the instance closed below)
        s.icntl[0], s.icntl[1], s.icntl[2], s.icntl[3] = -1, -1, -1, 0
        if not s.version_number.startswith(VERSIONS):
            self.close()
            raise MumpsError(0, f"version check (the library is not MUMPS {VERSIONS[0].decode()}x)")
        s.icntl[6] = int(ordering)
        indptr = np.asarray(indptr, dtype=np.int64)
        self.n = int(indptr.size - 1)
        col = np.repeat(np.arange(self.n), np.diff(indptr))
        # MUMPS counts from 1; the arrays stay alive with the instance (MUMPS keeps the pointers)
        self._irn = np.ascontiguousarray(np.asarray(indices) + 1, dtype=np.int32)
        self._jcn = np.ascontiguousarray(col + 1, dtype=np.int32)
        self._a = np.zeros(self._irn.size)
        s.n, s.nz, s.nnz = self.n, self._irn.size, self._irn.size
        s.irn, s.jcn, s.a = self._irn.ctypes.data, self._jcn.ctypes.data, self._a.ctypes.data
        self._call(1, "analysis")
        #: the ordering the analysis used (INFOG(7); MUMPS falls back where METIS is missing)
        self.ordering = Ordering(s.infog[6]) if s.infog[6] in set(Ordering) else None

    def _call(self, job: int, what: str) -> None:
        self._s.job = job
        with _lock:
            self._lib.dmumps_c(C.addressof(self._s))
        if self._s.infog[0] < 0:
            raise MumpsError(int(self._s.infog[0]), what)

    def factor(self, values: np.ndarray) -> int:
        """Factor the matrix with the upper triangle's ``values`` (pattern order); returns the
        number of negative pivots (0: positive definite, where no pivot was zero).

        Raises :class:`MumpsError` where MUMPS fails, e.g. ``code == -10`` for a numerically
        singular matrix.
        """
        self._a[:] = values
        for attempt in range(WORKSPACE_RETRIES + 1):
            try:
                self._call(2, "factorization")
                break
            except MumpsError as exc:
                if exc.code not in _WORKSPACE or attempt == WORKSPACE_RETRIES:
                    raise
                self._s.icntl[13] = max(2 * int(self._s.icntl[13]), 20)
        return int(self._s.infog[11])

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """``A^-1 rhs`` (n,) with the last factorization."""
        x = np.array(rhs, dtype=float).ravel()
        if x.size != self.n:
            raise ValueError(f"rhs has {x.size} entries, the matrix {self.n} rows")
        s = self._s
        s.rhs, s.nrhs, s.lrhs = x.ctypes.data, 1, self.n
        self._call(3, "solve")
        return x

    def close(self) -> None:
        """Free MUMPS's memory of this instance (also done when it is collected)."""
        if getattr(self, "_open", False):
            self._open = False
            try:
                self._call(-2, "termination")
            except Exception:       # interpreter shutdown
                pass

    def __del__(self):
        self.close()
