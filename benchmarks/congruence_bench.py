"""Time every per-face congruence quantity on meshes of 1k to 1M faces (one core).

    python benchmarks/congruence_bench.py [--sizes 1e3 1e4 1e5 1e6] [--repeat 3]

Each quantity is timed on a fresh ``Congruence`` (so it pays for the shared face frame it
needs), then "all" times every quantity in a row on one object, which is how a user calls
them. Mesh construction and validation are reported separately. Target (issue 2): the 1M
row's "all" under 2 s.
"""
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the target says
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from torsal.geometry.congruence import Congruence  # noqa: E402
from torsal.geometry.surfaces import graph_surface  # noqa: E402

QUANTITIES = [
    "hyperbolicity",
    "torsal_directions",
    "focal_parameters",
    "focal_points",
    "normality_residual",
    "torsal_planes",
    "torsal_angle",
    "is_bundle",
]


def make(faces: int, seed: int = 0):
    n = int(round(np.sqrt(faces / 2))) + 1
    v, f = graph_surface(lambda x, y: 0.3 * x * y + 0.2 * x**2 - 0.1 * y**2, nu=n, nv=n)
    rng = np.random.default_rng(seed)
    e = np.c_[-0.6 * v[:, 1], -0.6 * v[:, 0], np.ones(len(v))] + 0.05 * rng.normal(size=v.shape)
    return v, f, e


def best(fn, repeat):
    t = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        t.append(time.perf_counter() - t0)
    return min(t)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", nargs="+", type=float, default=[1e3, 1e4, 1e5, 1e6])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    cols = ["faces", "build"] + QUANTITIES + ["all"]
    short = {"torsal_directions": "torsal_dir", "focal_parameters": "focal_par",
             "normality_residual": "normality", "hyperbolicity": "hyperbol."}
    head = [short.get(c, c) for c in cols]
    print("seconds, best of", args.repeat, "(one core)")
    print(" ".join(f"{h:>11}" for h in head))
    for size in args.sizes:
        v, f, e = make(int(size))
        row = [len(f)]
        row.append(best(lambda: Congruence(v, f, e), args.repeat))
        c = Congruence(v, f, e)
        for q in QUANTITIES:
            row.append(best(lambda q=q: getattr(_fresh(c), q)(), args.repeat))

        def everything():
            cc = _fresh(c)
            for q in QUANTITIES:
                getattr(cc, q)()

        row.append(best(everything, args.repeat))
        print(f"{row[0]:>11d} " + " ".join(f"{x:>11.4f}" for x in row[1:]), flush=True)


def _fresh(c: Congruence) -> Congruence:
    """A new Congruence over the same (already validated) arrays, with empty caches."""
    cc = Congruence.__new__(Congruence)
    cc._v, cc._f, cc._d, cc.bundle_rtol = c._v, c._f, c._d, c.bundle_rtol
    return cc


if __name__ == "__main__":
    main()
