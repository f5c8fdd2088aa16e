"""Benchmark: torsal remeshing and eq. (8) support optimization vs libigl planarize_quad_mesh.

For support structures of about 1.7k, 8.5k and 100k edges (Wang et al. 2013, Fig. 12 sizes
and beyond) on the normal congruence of a smooth graph surface, prints: remeshing time,
delta_pl after extraction, optimize_support time (planarity as a hard constraint,
delta_pl <= 1e-4) and delta_pl after, and side by side on the same fin quads libigl's
``planarize_quad_mesh``: delta_pl reached within the same time budget and the time it needs
to reach delta_pl <= 1e-4 (doubling its iteration cap until it does, or until it has used
20x our time). The optimizer timed against libigl is ``optimize_support(method="projection")``; the IPOPT
NLP of eq. (8) with planarity as a hard constraint is timed too (up to 20k edges).

Run:  .venv/bin/python benchmarks/support_bench.py [--sizes small,medium,large]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from torsal.geometry.congruence import Congruence
from torsal.geometry.remesh import remesh_torsal
from torsal.geometry.support import fin_planarity, optimize_support
from torsal.geometry.surfaces import graph_surface


def surface(x, y):
    return 0.3 * (x ** 2 - 0.5 * y ** 2) + 0.1 * x ** 3


CASES = {
    # name: (A grid resolution, fins per unit length) -> ~1.7k, 8.5k, 100k edges
    "small": (41, 29),
    "medium": (81, 65),
    "large": (161, 224),
}


def fin_quad_mesh(s):
    n = len(s.vertices_a)
    V = np.concatenate([s.vertices_a, s.vertices_b])
    i, j = s.edges[:, 0], s.edges[:, 1]
    Q = np.stack([i, j, j + n, i + n], axis=1).astype(np.int64)
    return V, Q


def _igl_worker(V, Q, max_iter, queue):
    import igl

    t = time.perf_counter()
    Vo = igl.planarize_quad_mesh(V, Q, max_iter, 0.0)
    queue.put((time.perf_counter() - t, float(fin_planarity(Vo[Q]).max())))


def igl_run(V, Q, max_iter, timeout=None):
    """libigl planarize_quad_mesh in a child process (killed after ``timeout`` seconds).
    Returns (seconds, delta_pl) or (inf, nan) on timeout."""
    import multiprocessing as mp

    ctx = mp.get_context("fork")
    q = ctx.Queue()
    p = ctx.Process(target=_igl_worker, args=(V, Q, max_iter, q))
    p.start()
    p.join(timeout)
    if p.is_alive():
        p.terminate()
        p.join()
        return float("inf"), float("nan")
    return q.get()


def igl_profile(V, Q, tol, budget, cap_seconds):
    """Run libigl with 1, 2, 4, ... iterations. Returns the planarity reached within ``budget``
    seconds (None if one iteration already takes longer), the first (time, iterations) that
    reaches ``tol`` (None if not within ``cap_seconds``), and the list of runs."""
    runs, at_budget, reach, it = [], None, None, 1
    while True:
        dt, dpl = igl_run(V, Q, it, timeout=cap_seconds)
        runs.append((it, dt, dpl))
        if not np.isfinite(dt):
            break
        if dt <= budget:
            at_budget = dpl
        if dpl <= tol:
            reach = (dt, it)
            break
        if dt > cap_seconds or it >= 4096:
            break
        it *= 2
    return at_budget, reach, runs


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="small,medium,large")
    ap.add_argument("--tol", type=float, default=1e-4)
    ap.add_argument("--igl-cap", type=float, default=120.0,
                    help="seconds per libigl run before it is killed")
    args = ap.parse_args()
    rows = []
    for name in args.sizes.split(","):
        res, per_unit = CASES[name]
        V, F = graph_surface(surface, nu=res, nv=res)
        c = Congruence.from_normals((V, F))
        t = time.perf_counter()
        s = remesh_torsal(c, 1.0 / per_unit)
        t_remesh = time.perf_counter() - t
        r = optimize_support(s, (V, F), hard_tol=args.tol, method="projection")
        if len(s.edges) <= 20000:
            ri = optimize_support(s, (V, F), hard_tol=args.tol, rounds=1)
            ipopt = f"{ri.solve_seconds:.2f} s -> {ri.delta_pl_after:.1e} (dist {ri.distance_to_reference:.0e})"
        else:
            ipopt = "skipped (> 20k edges)"
        Vq, Q = fin_quad_mesh(s)
        at_budget, reach, runs = igl_profile(Vq, Q, args.tol, r.solve_seconds, args.igl_cap)
        rows.append(dict(case=name, E=len(s.edges), F=len(s.faces), remesh=t_remesh, dpl0=s.delta_pl,
                         t_opt=r.solve_seconds, dpl1=r.delta_pl_after, dist=r.distance_to_reference,
                         ok=r.success, ipopt=ipopt, igl_budget=at_budget, igl_reach=reach,
                         igl_first=runs[0], igl_last=runs[-1], cap=args.igl_cap))
        print_table(rows)


def print_table(rows):
    hdr = ("case", "|E~|", "|F~|", "remesh s", "dpl extracted", "optimize s", "dpl optimized",
           "max dist(a~,A)/delta", "IPOPT eq.(8) hard", "libigl 1 iter (s, dpl)", "libigl dpl in our time",
           "libigl to 1e-4 (s, iters)", "speed-up")
    print(" | ".join(hdr))
    for r in rows:
        last = r["igl_last"]
        if r["igl_reach"]:
            reach = f"{r['igl_reach'][0]:.2f}, {r['igl_reach'][1]}"
        elif not np.isfinite(last[1]):
            reach = f"not reached ({last[0]} it > {r['cap']:.0f} s, killed)"
        else:
            reach = f"not reached ({last[1]:.1f} s, {last[0]} it: {last[2]:.1e})"
        budget = f"{r['igl_budget']:.1e}" if r["igl_budget"] is not None else "- (1 iter > budget)"
        if r["igl_reach"]:
            speed = f"{r['igl_reach'][0] / r['t_opt']:.0f}x"
        else:
            longest = max([x[1] for x in [r["igl_first"], last] if np.isfinite(x[1])] + [r["cap"]])
            speed = f"> {longest / r['t_opt']:.0f}x"
        first = (f"({r['igl_first'][1]:.2f}, {r['igl_first'][2]:.1e})" if np.isfinite(r["igl_first"][1])
                 else f"(> {r['cap']:.0f} s, killed)")
        print(f"{r['case']} | {r['E']} | {r['F']} | {r['remesh']:.2f} | {r['dpl0']:.1e} | {r['t_opt']:.2f} | "
              f"{r['dpl1']:.1e} | {r['dist']:.0e} | {r['ipopt']} | {first} | "
              f"{budget} | {reach} | {speed}")
    print(flush=True)


if __name__ == "__main__":
    main()
