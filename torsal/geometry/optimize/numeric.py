"""casadi Functions evaluated from and into numpy arrays through their buffers (no DM conversions)."""
from __future__ import annotations

import casadi as ca
import numpy as np


class NumericFunction:
    """A casadi Function evaluated from and into numpy arrays through its buffers.

    A call with numpy arguments converts each to a DM and each output back (about 1.5 ms per
    30,000 parameters, several times the evaluation itself on Fig. 12 row 7d); here casadi
    reads the arguments and writes the outputs in place. Returns copies of the outputs (flat
    nonzeros), or with ``copy=False`` the buffers themselves (valid until the next call);
    ``shapes`` gives an output a numpy shape over its nonzeros (None: flat), e.g. ``(m, n)``
    for a dense ``n x m`` output read one column per row.

    >>> x = ca.MX.sym("x", 3)
    >>> f = NumericFunction(ca.Function("f", [x], [2 * x, ca.sum1(x)]))
    >>> [a.tolist() for a in f(np.array([1.0, 2.0, 3.0]))]
    [[2.0, 4.0, 6.0], [6.0]]
    """

    def __init__(self, fn: ca.Function, *, copy: bool = True, shapes: list | None = None):
        self.fn, self.copy = fn, copy
        self.buffer, self.call = fn.buffer()
        self.out = [np.zeros(fn.nnz_out(i)) for i in range(fn.n_out())]
        for i, r in enumerate(self.out):
            self.buffer.set_res(i, memoryview(r))
        self.views = [r if shape is None else r.reshape(shape)
                      for r, shape in zip(self.out, shapes or [None] * len(self.out))]

    def __call__(self, *args) -> list[np.ndarray]:
        keep = [np.ascontiguousarray(a, dtype=float).ravel() for a in args]   # alive during the call
        for i, (a, n) in enumerate(zip(keep, (self.fn.nnz_in(i) for i in range(len(keep))))):
            if a.size != n:
                raise ValueError(f"{self.fn.name()}: argument {i} has {a.size} entries, expected {n}")
            self.buffer.set_arg(i, memoryview(a))
        self.call()
        return [r.copy() for r in self.views] if self.copy else list(self.views)
