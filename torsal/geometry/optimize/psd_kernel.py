"""The positive semidefinite projection of small symmetric matrices, compiled from C.

:func:`~torsal.geometry.optimize.projected.psd_projection` decomposes every element Hessian of
an energy at every Newton step (Fig. 12 row 7c: 3,008 8 x 8 matrices a step). numpy's batched
``eigh`` calls LAPACK's ``dsyevd`` once per matrix, about 11 us for an 8 x 8 one on this
project's 2-core machine; the same algorithm written out for small matrices (Householder
tridiagonalization and the implicit QL method, EISPACK's ``tred2`` / ``tql2``; Wilkinson 1971,
as JAMA gives them) takes about 4.5 us, without LAPACK's calls, workspace queries and its
correctly rounded ``hypot``. The library is compiled once per machine with the system C
compiler into the kernel cache (:func:`.kernels.c_library`); where that fails the caller keeps
numpy's ``eigh``. The projection is ``V max(L, 0) V^T`` (or ``V |L| V^T``) as numpy's, equal to
it to rounding (a few units of 1e-16 of the matrix's largest entry). It is used where
:data:`.projected.PSD_KERNEL` is ``"compiled"``, the default (numpy's ``eigh`` where it is ``"numpy"``).
"""
from __future__ import annotations

import ctypes

import numpy as np

from .kernels import c_library

#: largest matrix order the C kernel takes (larger ones keep numpy's ``eigh``)
NMAX = 32

#: the C source (``torsal_psd_project``): one matrix at a time, in place
SOURCE = r"""/* torsal: small symmetric matrices made positive semidefinite, one at a time: Householder
   tridiagonalization and the implicit QL method (EISPACK's tred2 / tql2 as JAMA gives them,
   public domain), then V f(L) V^T where an eigenvalue is negative. */
#include <math.h>

#define NMAX 32

/* sqrt(a^2 + b^2) without overflow or underflow (a few units in the last place, as the
   rotations need; libm's correctly rounded hypot cost a third of the time) */
static double hyp(double a, double b) {
  double m, r;
  a = fabs(a);
  b = fabs(b);
  m = a > b ? a : b;
  if (m == 0.0) return 0.0;
  r = (a > b ? b : a) / m;
  return m * sqrt(1.0 + r * r);
}

static void tred2(int n, double V[NMAX][NMAX], double *d, double *e) {
  int i, j, k;
  for (j = 0; j < n; j++) d[j] = V[n - 1][j];
  for (i = n - 1; i > 0; i--) {
    double scale = 0.0, h = 0.0;
    for (k = 0; k < i; k++) scale += fabs(d[k]);
    if (scale == 0.0) {
      e[i] = d[i - 1];
      for (j = 0; j < i; j++) {
        d[j] = V[i - 1][j];
        V[i][j] = 0.0;
        V[j][i] = 0.0;
      }
    } else {
      double f, g, hh;
      for (k = 0; k < i; k++) {
        d[k] /= scale;
        h += d[k] * d[k];
      }
      f = d[i - 1];
      g = sqrt(h);
      if (f > 0) g = -g;
      e[i] = scale * g;
      h = h - f * g;
      d[i - 1] = f - g;
      for (j = 0; j < i; j++) e[j] = 0.0;
      for (j = 0; j < i; j++) {
        f = d[j];
        V[j][i] = f;
        g = e[j] + V[j][j] * f;
        for (k = j + 1; k <= i - 1; k++) {
          g += V[k][j] * d[k];
          e[k] += V[k][j] * f;
        }
        e[j] = g;
      }
      f = 0.0;
      for (j = 0; j < i; j++) {
        e[j] /= h;
        f += e[j] * d[j];
      }
      hh = f / (h + h);
      for (j = 0; j < i; j++) e[j] -= hh * d[j];
      for (j = 0; j < i; j++) {
        f = d[j];
        g = e[j];
        for (k = j; k <= i - 1; k++) V[k][j] -= (f * e[k] + g * d[k]);
        d[j] = V[i - 1][j];
        V[i][j] = 0.0;
      }
    }
    d[i] = h;
  }
  for (i = 0; i < n - 1; i++) {
    double h;
    V[n - 1][i] = V[i][i];
    V[i][i] = 1.0;
    h = d[i + 1];
    if (h != 0.0) {
      for (k = 0; k <= i; k++) d[k] = V[k][i + 1] / h;
      for (j = 0; j <= i; j++) {
        double g = 0.0;
        for (k = 0; k <= i; k++) g += V[k][i + 1] * V[k][j];
        for (k = 0; k <= i; k++) V[k][j] -= g * d[k];
      }
    }
    for (k = 0; k <= i; k++) V[k][i + 1] = 0.0;
  }
  for (j = 0; j < n; j++) {
    d[j] = V[n - 1][j];
    V[n - 1][j] = 0.0;
  }
  V[n - 1][n - 1] = 1.0;
  e[0] = 0.0;
}

/* 0 on success, 1 where an eigenvalue took more than 60 iterations */
static int tql2(int n, double V[NMAX][NMAX], double *d, double *e) {
  int i, k, l, m;
  double f = 0.0, tst1 = 0.0;
  const double eps = 2.220446049250313e-16;
  for (i = 1; i < n; i++) e[i - 1] = e[i];
  e[n - 1] = 0.0;
  for (l = 0; l < n; l++) {
    double t = fabs(d[l]) + fabs(e[l]);
    if (t > tst1) tst1 = t;
    m = l;
    while (m < n - 1 && !(fabs(e[m]) <= eps * tst1)) m++;
    if (m > l) {
      int iter = 0;
      do {
        double g, p, r, dl1, h, c, c2, c3, el1, s, s2;
        if (++iter > 60) return 1;
        g = d[l];
        p = (d[l + 1] - g) / (2.0 * e[l]);
        r = hyp(p, 1.0);
        if (p < 0) r = -r;
        d[l] = e[l] / (p + r);
        d[l + 1] = e[l] * (p + r);
        dl1 = d[l + 1];
        h = g - d[l];
        for (i = l + 2; i < n; i++) d[i] -= h;
        f += h;
        p = d[m];
        c = 1.0; c2 = c; c3 = c;
        el1 = e[l + 1];
        s = 0.0; s2 = 0.0;
        for (i = m - 1; i >= l; i--) {
          c3 = c2;
          c2 = c;
          s2 = s;
          g = c * e[i];
          h = c * p;
          r = hyp(p, e[i]);
          e[i + 1] = s * r;
          s = e[i] / r;
          c = p / r;
          p = c * d[i] - s * g;
          d[i + 1] = h + s * (c * g + s * d[i]);
          {
            double *zi = V[i], *zj = V[i + 1];   /* V holds the eigenvectors as rows here */
            for (k = 0; k < n; k++) {
              h = zj[k];
              zj[k] = s * zi[k] + c * h;
              zi[k] = c * zi[k] - s * h;
            }
          }
        }
        p = -s * s2 * c3 * el1 * e[l] / dl1;
        e[l] = s * p;
        d[l] = c * p;
      } while (!(fabs(e[l]) <= eps * tst1));
    }
    d[l] = d[l] + f;
    e[l] = 0.0;
  }
  return 0;
}

/* a: m row-major n x n symmetric matrices, projected in place (mode 0: negative eigenvalues
   clamped to 0, mode 1: mirrored); a matrix whose eigenvalues did not converge or that is not
   finite is left as it is and flagged in fail[] (1). Returns the number flagged. */
int torsal_psd_project(long m, int n, double *a, int mode, signed char *fail) {
  long q;
  int bad = 0;
  if (n < 1 || n > NMAX) return -1;
  for (q = 0; q < m; q++) {
    double V[NMAX][NMAX], d[NMAX], e[NMAX], w[NMAX];
    double *x = a + q * (long)n * n;
    int i, j, k, neg = 0, finite = 1;
    fail[q] = 0;
    for (i = 0; i < n; i++)
      for (j = 0; j < n; j++) {
        V[i][j] = x[i * n + j];
        if (!isfinite(V[i][j])) finite = 0;
      }
    if (!finite) {
      fail[q] = 1;
      bad++;
      continue;
    }
    tred2(n, V, d, e);
    for (i = 0; i < n; i++)
      for (j = i + 1; j < n; j++) {
        double t = V[i][j];
        V[i][j] = V[j][i];
        V[j][i] = t;
      }
    if (tql2(n, V, d, e)) {
      fail[q] = 1;
      bad++;
      continue;
    }
    for (k = 0; k < n; k++) {
      if (d[k] < 0.0) neg = 1;
      w[k] = d[k] < 0.0 ? (mode == 1 ? -d[k] : 0.0) : d[k];
    }
    if (!neg) continue;  /* positive semidefinite already: unchanged */
    for (i = 0; i < n; i++)
      for (j = i; j < n; j++) {
        double s = 0.0;
        for (k = 0; k < n; k++) s += V[k][i] * w[k] * V[k][j];
        x[i * n + j] = s;
        x[j * n + i] = s;
      }
  }
  return bad;
}
"""

#: the loaded library: None before the first call, False where it could not be built
_LIB = None


def _kernel():
    """``torsal_psd_project`` of the compiled library, or None (no C compiler, ...)."""
    global _LIB
    if _LIB is None:
        lib = c_library(SOURCE, "psd")
        if lib is None:
            _LIB = False
        else:
            fn = lib.torsal_psd_project
            fn.restype = ctypes.c_int
            fn.argtypes = [ctypes.c_long, ctypes.c_int, ctypes.c_void_p, ctypes.c_int, ctypes.c_void_p]
            _LIB = fn
    return _LIB or None


def available() -> bool:
    """Whether the compiled kernel is in use here (else :func:`project` returns None).

    >>> isinstance(available(), bool)
    True
    """
    return _kernel() is not None


def project(a: np.ndarray, mode: str) -> np.ndarray | None:
    """Make the symmetric matrices ``a`` positive semidefinite in place, by the C kernel.

    Parameters
    ----------
    a : (m, n, n) float64 array, C-contiguous
        Symmetric matrices (``n <= NMAX``); each with a negative eigenvalue becomes
        ``V f(L) V^T`` (``f``: ``max(., 0)`` for ``mode="clamp"``, ``abs`` for ``"abs"``), the
        others stay as they are, bit for bit.
    mode : {"clamp", "abs"}

    Returns
    -------
    (k,) int array or None
        The matrices the kernel left as they were because their entries are not finite or their
        eigenvalues did not converge (the caller decomposes those with numpy); None where the
        kernel is not available or ``n > NMAX`` (nothing done).

    Examples
    --------
    >>> a = np.array([[[1.0, 0.0], [0.0, -2.0]]])
    >>> left = project(a, "abs")
    >>> left is None or (left.size == 0 and np.allclose(a[0], [[1.0, 0.0], [0.0, 2.0]]))
    True
    """
    if mode not in ("clamp", "abs"):
        raise ValueError(f"mode must be 'clamp' or 'abs', got {mode!r}")
    fn = _kernel()
    if fn is None or a.ndim != 3 or a.shape[1] != a.shape[2] or not 0 < a.shape[1] <= NMAX:
        return None
    if a.dtype != np.float64 or not a.flags.c_contiguous or not a.flags.writeable:
        raise ValueError("project needs a writeable C-contiguous float64 array")
    fail = np.zeros(len(a), dtype=np.int8)
    if len(a):
        fn(len(a), a.shape[1], a.ctypes.data, 1 if mode == "abs" else 0, fail.ctypes.data)
    return np.flatnonzero(fail)
