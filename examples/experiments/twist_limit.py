"""Experiment: a twist limit that depends on the fin spacing, plus a user's own fairness term.

Neighbouring lines of a congruence become neighbouring fins; if they twist too much from
one vertex to the next, the fin between them is hard to bend. This script bounds the angle
between the lines at the two ends of every edge by ``max_twist_per_m * edge length`` (a
limit per metre, so it follows the fin spacing) with ``add_constraint`` over edges, adds
a user's own energy (lines tilted down, e_z near -0.5, so fins shed rain) with
``add_term``, solves with IPOPT and prints the measured effect.

Run:  .venv/bin/python examples/experiments/twist_limit.py [--nu 25 --nv 13]
"""
from __future__ import annotations

import argparse

import numpy as np

from torsal.geometry import Congruence, CongruenceProblem
from torsal.geometry.mesh import edge_face_adjacency
from torsal.geometry.surfaces import facade_patch

SUN = np.array([0.3, -0.8, -0.5]) / np.linalg.norm([0.3, -0.8, -0.5])   # site -> sun


def edge_twist_deg(c: Congruence, edges: np.ndarray) -> np.ndarray:
    """Measured angle (degrees) between the lines at the two ends of each edge."""
    e = c.directions / np.linalg.norm(c.directions, axis=1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", e[edges[:, 0]], e[edges[:, 1]]), -1, 1)))


def run(nu: int = 25, nv: int = 13, max_twist_per_m: float = 3.0) -> dict:
    c = Congruence.from_normals(facade_patch(nu=nu, nv=nv))
    edges, _ = edge_face_adjacency(c.faces)
    length = np.linalg.norm(c.vertices[edges[:, 1]] - c.vertices[edges[:, 0]], axis=1)
    limit = np.radians(max_twist_per_m * length)          # per edge, in radians
    def problem():
        return (CongruenceProblem(c).normal().fair().perpendicular(SUN, weight=10)
                .add_term("low_vertical", 0.05, lambda e, a: (e[0, 2] + 0.5) ** 2, over="vertices"))

    p = (problem()
         # |e_i - e_j| <= chord of the limit angle, scaled to 1: of order 1 and with a gradient
         # even for parallel lines (1 - cos has none there); each edge's own chord is a parameter
         .add_constraint("twist", lambda e, a, q: 1.0 - ((e[0, 0] - e[1, 0]) ** 2 + (e[0, 1] - e[1, 1]) ** 2
                                                         + (e[0, 2] - e[1, 2]) ** 2) / q[0] ** 2,
                         over="edges", params=(2 * np.sin(limit / 2))[:, None]))
    free = problem().solve()
    plain = CongruenceProblem(c).normal().fair().perpendicular(SUN, weight=10).solve()
    # the constrained pass takes 180 to 190 IPOPT iterations here (13 x 9), close to
    # solve()'s default limit of 200: give it room
    res = p.solve(max_iter=500)
    excess_free = edge_twist_deg(free.congruence, edges) - np.degrees(limit)
    excess = edge_twist_deg(res.congruence, edges) - np.degrees(limit)
    return {"success": res.success, "worst_excess_free_deg": float(excess_free.max()),
            "worst_excess_deg": float(excess.max()), "edges_over_limit": int((excess > 1e-3).sum()),
            "vertical_without_term": float(plain.congruence.directions[:, 2].mean()),
            "vertical_with_term": float(free.congruence.directions[:, 2].mean())}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nu", type=int, default=25)
    ap.add_argument("--nv", type=int, default=13)
    ap.add_argument("--max-twist-per-m", type=float, default=3.0)
    a = ap.parse_args(argv)
    r = run(a.nu, a.nv, a.max_twist_per_m)
    print(f"twist limit {a.max_twist_per_m} deg/m: worst twist above the limit without it "
          f"{r['worst_excess_free_deg']:+.2f} deg, with it {r['worst_excess_deg']:+.4f} deg "
          f"({r['edges_over_limit']} edges over), solve {'ok' if r['success'] else 'FAILED'}")
    print(f"mean e_z without / with the user's term low_vertical (target -0.5): {r['vertical_without_term']:+.3f} / "
          f"{r['vertical_with_term']:+.3f}")
    return r


if __name__ == "__main__":
    main()
