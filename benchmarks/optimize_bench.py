"""Congruence optimization timings: IPOPT (exact Hessian, MUMPS) vs the paper's L-BFGS baseline.

Wang et al. 2013, Fig. 12 sizes and term sets (rows 7a, 9, 11), plus 20k and 100k vertices
with the 7a term set. For each row: the first build, the first solve, and a re-solve after a
designer changed the sun direction and a weight (same built solver, warm start), side by side
with the paper's T column. Targets: re-solve < T, build + solve < 2 T, 100k in < 120 s.

Run:  .venv/bin/python benchmarks/optimize_bench.py [--max-vertices 100000] [--no-lbfgs] [--no-jit]

Columns: build / solve / it = first build (NLP assembly + IPOPT setup), first solve, its
iterations; b+s vs 2T; all = wall time from an empty problem to the first result (problem
set-up, build, solve, energy reports; in the 100k row "<2T" checks all < 120 s); re-solve =
wall time of a re-solve after the designer's change (same solver, warm start) vs T; E =
weighted objective of eq. (9) at the start, after the first solve and after the re-solve;
worst viol = largest constraint violation; |<e,d>| = mean |<e_i, d>| for the moved sun;
hyp% = share of faces with c_hyp >= 0. Grids approximate the paper's sizes.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from torsal.geometry.congruence import Congruence
from torsal.geometry.mesh import edge_face_adjacency
from torsal.geometry.optimize import CongruenceProblem
from torsal.geometry.surfaces import facade_patch

SUN = np.array([0.3, -0.8, -0.5]) / np.linalg.norm([0.3, -0.8, -0.5])
OPTS = {"jit": True}     # compiled kernels (cached in ~/.cache/torsal/kernels after the first run)


def _rotated_sun(deg: float) -> np.ndarray:
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]) @ SUN


def _boundary_strokes(c: Congruence):
    """Faces with a boundary edge and the edge's direction (Fig. 7a: align with the boundary)."""
    edges, edge_faces = edge_face_adjacency(c.faces)
    bd = edge_faces[:, 1] < 0
    faces, keep = np.unique(edge_faces[bd, 0], return_index=True)
    e = edges[bd][keep]
    return faces, c.vertices[e[:, 1]] - c.vertices[e[:, 0]]


def _window(c: Congruence, frac=0.25):
    """Vertices of a central window (the see-through area V' of Fig. 9)."""
    v = c.vertices
    lo, hi = v.min(0), v.max(0)
    mid, half = (lo + hi) / 2, (hi - lo) * frac / 2
    return np.flatnonzero((np.abs(v[:, 0] - mid[0]) < half[0]) & (np.abs(v[:, 2] - mid[2]) < half[2]))


def problem_7a(c, sun):
    faces, dirs = _boundary_strokes(c)
    return (CongruenceProblem(c, **OPTS).normal(weight=2).fair(weight=1).perpendicular(sun, weight=10)
            .torsal_direction(faces, dirs, weight=0.1))


def problem_9(c, sun):
    win = _window(c)
    rest = np.setdiff1d(np.arange(len(c.vertices)), win)
    return (CongruenceProblem(c, **OPTS).fair(weight=1).fair_torsal(weight=10)
            .perpendicular(sun, vertices=rest, weight=1).parallel(sun, vertices=win, weight=0.1)
            .hyperbolic().min_torsal_angle(60))


def problem_11(c, sun):
    v, f = c.vertices, c.faces
    support = Congruence(v - 0.3 * c.directions, f, c.directions)     # the steel substructure L'
    q = CongruenceProblem(support, **OPTS).normal(weight=2).fair(weight=1)
    win = _window(c)
    return (CongruenceProblem(c, **OPTS).normal(weight=2).fair(weight=1).fair_torsal(weight=10)
            .perpendicular(sun, weight=1).parallel(_rotated_sun(30), vertices=win, weight=0.01)
            .align_with(q, weight=200))


def change(problem_fn, p, c):
    """The designer's change: the sun moves by 5 degrees and one weight changes."""
    sun = _rotated_sun(5.0)
    if problem_fn is problem_9:
        win = _window(c)
        rest = np.setdiff1d(np.arange(len(c.vertices)), win)
        p.perpendicular(sun, vertices=rest, weight=1.2).parallel(sun, vertices=win, weight=0.1)
    else:
        p.perpendicular(sun, weight=12 if problem_fn is problem_7a else 1.2)
    return sun


ROWS = [  # name, (nu, nv), paper |V|, |F|, T, problem
    ("7a", (33, 33), 1073, 2048, 0.4, problem_7a),
    ("9", (65, 41), 2633, 5120, 29.0, problem_9),
    ("11", (71, 71), 5087, 9182, 11.0, problem_11),
    ("20k", (141, 141), None, None, None, problem_7a),
    ("100k", (317, 317), None, None, None, problem_7a),
]


def run_row(name, grid, T, problem_fn, solvers, lbfgs_iter):
    v, f = facade_patch(nu=grid[0], nv=grid[1], width=12.0 * grid[0] / 33, height=6.0 * grid[1] / 33)
    c = Congruence.from_normals((v, f))
    out = []
    for solver in solvers:
        t0 = time.perf_counter()
        p = problem_fn(c, SUN)
        r1 = p.solve(solver=solver, max_iter=None if solver == "ipopt" else lbfgs_iter)
        first = time.perf_counter() - t0
        sun = change(problem_fn, p, c)
        t1 = time.perf_counter()
        r2 = p.solve(solver=solver, max_iter=None if solver == "ipopt" else lbfgs_iter)
        again = time.perf_counter() - t1
        worst = max(r2.max_violation.values(), default=0.0)
        perp = float(np.abs(r2.congruence.directions @ sun).mean())
        hyp = float((r2.congruence.hyperbolicity() >= 0).mean())
        out.append(dict(row=name, V=len(v), F=len(f), T=T, solver=solver, build=r1.build_seconds,
                        solve=r1.solve_seconds, first=first, it1=r1.iterations, ok1=r1.success,
                        resolve=again, rebuild=r2.build_seconds, it2=r2.iterations, ok2=r2.success,
                        E0=r1.energies_before["total"], E1=r1.energies_after["total"],
                        E2=r2.energies_after["total"], worst=worst, perp=perp, hyp=hyp,
                        status=r2.status))
    return out


def _fmt(x, spec):
    return "-" if x is None else format(x, spec)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--max-vertices", type=int, default=100_000)
    ap.add_argument("--no-lbfgs", action="store_true")
    ap.add_argument("--lbfgs-iter", type=int, default=500)
    ap.add_argument("--rows", nargs="*", default=None)
    ap.add_argument("--no-jit", action="store_true", help="interpreted casadi kernels")
    args = ap.parse_args()
    OPTS["jit"] = not args.no_jit
    head = (f"{'row':>5} {'|V|':>7} {'|F|':>7} {'T':>5} {'solver':>6} | {'build':>6} {'solve':>7} "
            f"{'it':>4} {'b+s':>7} {'all':>7} {'<2T':>4} | {'re-solve':>8} {'it':>4} {'<T':>4} | "
            f"{'E start':>9} {'E first':>9} {'E re':>9} {'worst viol':>10} {'|<e,d>|':>8} {'hyp%':>5} ok")
    print(head)
    print("-" * len(head))
    for name, grid, pv, pf, T, fn in ROWS:
        if args.rows and name not in args.rows:
            continue
        if grid[0] * grid[1] > args.max_vertices * 1.01:
            continue
        solvers = ["ipopt"] + ([] if args.no_lbfgs or grid[0] * grid[1] > 30_000 else ["lbfgs"])
        for r in run_row(name, grid, T, fn, solvers, args.lbfgs_iter):
            bs = r["build"] + r["solve"]
            t_ok = "" if T is None else ("yes" if bs < 2 * T else "NO")
            if name == "100k":   # target: 100k vertices in < 120 s in all (problem, build, solve)
                t_ok = "yes" if r["first"] < 120 else "NO"
            r_ok = "" if T is None else ("yes" if r["resolve"] < T else "NO")
            print(f"{r['row']:>5} {r['V']:>7} {r['F']:>7} {_fmt(T, '5.1f'):>5} {r['solver']:>6} | "
                  f"{r['build']:6.2f} {r['solve']:7.2f} {r['it1']:>4} {bs:7.2f} {r['first']:7.2f} {t_ok:>4} | "
                  f"{r['resolve']:8.2f} {r['it2']:>4} {r_ok:>4} | {r['E0']:9.3e} {r['E1']:9.3e} "
                  f"{r['E2']:9.3e} {r['worst']:10.2e} {r['perp']:8.4f} {100 * r['hyp']:5.1f} "
                  f"{'ok' if r['ok1'] and r['ok2'] else 'FAIL: ' + r['status'][:60]}", flush=True)


if __name__ == "__main__":
    main()
