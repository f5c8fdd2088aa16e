"""Per-element derivative kernels: the gnomonic chart, C compilation (jit) and :class:`Local`."""
from __future__ import annotations

import casadi as ca
import numpy as np

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


#: kernels loaded in this process, by their library (named by the hash of their code): a build
#: of another problem with the same terms loads no library again
_LOADED: dict[str, ca.Function] = {}


def _jit(fn: ca.Function) -> ca.Function:
    """``fn`` compiled to a shared library with the system C compiler, cached on disk.

    casadi generates the C code; its hash (with the casadi version) names the library in
    :func:`_kernel_cache_dir` (``$TORSAL_KERNEL_CACHE``), so each kernel is compiled once per
    machine (about a second) and loaded with ``casadi.external`` afterwards, once per process.
    The code is hashed from memory: a kernel already compiled costs no temporary folder (37 of
    them were 0.1 of row 7a's 0.65 s build). Falls back to the interpreted ``fn`` if anything
    fails (no compiler, read-only cache, ...).
    """
    import hashlib

    try:
        cc = _cc()
        if cc is None:
            return fn
        # the fixed file name keeps the code, and so the hash, independent of the process
        cg = ca.CodeGenerator("tk.c", {"with_header": False})
        cg.add(fn)
        h = hashlib.sha1((ca.__version__ + cg.dump()).encode()).hexdigest()[:16]
        lib = _kernel_cache_dir() / f"tk_{h}.so"
        if str(lib) not in _LOADED:
            if not lib.exists():
                _compile(cg, lib, cc)
            _LOADED[str(lib)] = ca.external(fn.name(), str(lib))
        return _LOADED[str(lib)]
    except Exception:   # pragma: no cover - any failure keeps the interpreted kernel
        return fn


def _cc() -> str | None:
    """The system C compiler (``$CC``, else gcc or cc), None where there is none."""
    import os
    import shutil

    return shutil.which(os.environ.get("CC", "gcc")) or shutil.which("cc")


def _compile(cg: ca.CodeGenerator, lib, cc: str) -> None:
    """Compile the code of ``cg`` into the library ``lib`` (a path in the kernel cache)."""
    import os
    import tempfile

    with tempfile.TemporaryDirectory(prefix="torsal_jit_") as tmp:
        # generated into a private folder (never the caller's working directory)
        _compile_file(cg.generate(tmp + os.sep), lib, cc)


def _compile_file(src: str, lib, cc: str) -> None:
    """Compile the C file ``src`` into the library ``lib`` (a path in the kernel cache)."""
    import os
    import shutil
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory(prefix="torsal_cc_") as tmp:
        lib.parent.mkdir(parents=True, exist_ok=True)
        out = os.path.join(tmp, "tk.so")
        subprocess.run([cc, "-O2", "-shared", "-fPIC", src, "-o", out, "-lm"],
                       check=True, capture_output=True, timeout=120)
        # copy under a private name in the cache, then rename: a process that loads the
        # kernel concurrently never sees a half-written library
        fd, part = tempfile.mkstemp(prefix=".tk_", suffix=".so.part", dir=lib.parent)
        os.close(fd)
        try:
            shutil.copyfile(out, part)
            os.replace(part, lib)
        finally:
            if os.path.exists(part):
                os.unlink(part)


def c_library(source: str, prefix: str):
    """The shared library of the C ``source``, compiled once per machine into the kernel cache
    (:func:`_kernel_cache_dir`, named by the hash of the source) and loaded with ctypes; None
    where there is no C compiler or anything fails (the caller keeps its numpy path).

    >>> lib = c_library("int twice(int x) { return 2 * x; }", "doc")
    >>> lib is None or lib.twice(21) == 42
    True
    """
    import ctypes
    import hashlib
    import os
    import tempfile

    try:
        cc = _cc()
        if cc is None:
            return None
        lib = _kernel_cache_dir() / f"{prefix}_{hashlib.sha1(source.encode()).hexdigest()[:16]}.so"
        if not lib.exists():
            with tempfile.TemporaryDirectory(prefix="torsal_src_") as tmp:
                src = os.path.join(tmp, prefix + ".c")
                with open(src, "w") as fh:
                    fh.write(source)
                _compile_file(src, lib, cc)
        return ctypes.CDLL(str(lib))
    except Exception:   # pragma: no cover - no compiler, read-only cache, ...: the numpy path
        return None


class Local:
    """Per-element functions of one term, in the NLP's variables (internal).

    All take ``(x, data, par, jl)`` where ``x`` are the element's ``3k`` direction
    coordinates and ``jl`` the ``3x2`` chart Jacobians of its ``k`` vertices (``6k``, empty
    unless ``tangent``). With ``J = blockdiag(jl)`` (identity without ``tangent``):
    ``grad = J^T g_e``, ``hess = coef * triu(J^T H_e J)`` (the chain rule without the chart's
    curvature, which the assembler adds per vertex), ``jac = g_e^T J``, ``lag_e = coef * g_e``.
    """

    def __init__(self, fn: ca.Function, k: int, tangent: bool, jit: bool = False, constraint: bool = False,
                 residual: ca.Function | None = None):
        x = ca.SX.sym("x", 3 * k)
        d = ca.SX.sym("d", fn.size1_in(1))
        p = ca.SX.sym("p", fn.size1_in(2))
        jl = ca.SX.sym("jl", 6 * k if tangent else 0)
        coef = ca.SX.sym("coef")
        v = fn(x, d, p)
        ge = ca.gradient(v, x)
        #: Gauss-Newton: 2 J_r^T J_r for a sum of squares ||r||^2 (positive semidefinite);
        #: the assembler then also leaves out this term's share of the chart curvature
        self.gauss_newton = residual is not None
        if residual is not None:
            jr = ca.jacobian(residual(x, d, p), x)
            he = 2.0 * ca.mtimes(jr.T, jr)
        else:
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
            # nothing differentiates the NLP's f and g symbolically (IPOPT's nlpsol is built
            # without its nlp_grad, see ipopt.IpoptPasses.solver): the values compile too
            # (Fig. 12 row 7d: an evaluation of f 2.3 -> 0.6 ms, of g 2.4 -> 0.7 ms)
            self.val = _jit(self.val)
            self.grad, self.hess = _jit(self.grad), _jit(self.hess)
            if constraint:
                self.jac = _jit(self.jac)
            if tangent and not self.gauss_newton:
                self.lag_e = _jit(self.lag_e)

