"""Experiment: keep every line within a cone around the planes orthogonal to the sun path.

A fin blocks a sun position best when its line is orthogonal to the light (f_perp, eq. (9)).
This script takes a few sun positions of a summer afternoon, adds a user's own energy (the
mean of ``<e, d_k>^2`` over the sun positions, weighted lightly against f_norm) with
``add_term``, and one user constraint per sun position with ``add_constraint``: the line
may deviate at most ``theta`` degrees from the plane orthogonal to ``d_k``, written
``1 - <e, d_k>^2 / sin(theta)^2 >= 0`` (of order 1). It solves with IPOPT and prints the
measured worst deviation, which the constraint bounds and the energy alone does not.

Run:  .venv/bin/python examples/experiments/sun_path_cone.py [--nu 25 --nv 13 --theta 4]
"""
from __future__ import annotations

import argparse

import numpy as np

from torsal.geometry import Congruence, CongruenceProblem
from torsal.geometry.surfaces import facade_patch

# site -> sun at 9, 13 and 17 h on a summer day for a facade facing -y (model frame)
SUNS = np.array([[-0.75, -0.45, 0.48], [0.05, -0.55, 0.83], [0.75, -0.45, 0.48]])
SUNS /= np.linalg.norm(SUNS, axis=1, keepdims=True)


def deviation_deg(c: Congruence) -> np.ndarray:
    """Measured angle (degrees) between each line and the plane orthogonal to each sun
    direction, (n, k)."""
    e = c.directions / np.linalg.norm(c.directions, axis=1, keepdims=True)
    return np.degrees(np.arcsin(np.clip(np.abs(e @ SUNS.T), 0, 1)))


def run(nu: int = 25, nv: int = 13, theta: float = 4.0) -> dict:
    c = Congruence.from_normals(facade_patch(nu=nu, nv=nv))
    sun_term = lambda e, a, d: sum((e[0, 0] * d[3 * k] + e[0, 1] * d[3 * k + 1] + e[0, 2] * d[3 * k + 2]) ** 2
                                   for k in range(len(SUNS))) / len(SUNS)
    p = (CongruenceProblem(c).normal().fair()
         .add_term("sun_path", 0.2, sun_term, over="vertices", params=SUNS.ravel()))
    free = p.solve()
    s2 = np.sin(np.radians(theta)) ** 2
    for k, d in enumerate(SUNS):
        p.add_constraint(f"sun_cone_{k}", lambda e, a, q: 1.0 - (e[0, 0] * q[0] + e[0, 1] * q[1] + e[0, 2] * q[2]) ** 2 / q[3],
                         over="vertices", params=np.append(d, s2))
    res = p.solve()
    return {"success": res.success, "worst_free_deg": float(deviation_deg(free.congruence).max()),
            "worst_deg": float(deviation_deg(res.congruence).max()),
            "energy_free": free.energies_after["sun_path"], "energy": res.energies_after["sun_path"]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nu", type=int, default=25)
    ap.add_argument("--nv", type=int, default=13)
    ap.add_argument("--theta", type=float, default=4.0)
    a = ap.parse_args(argv)
    r = run(a.nu, a.nv, a.theta)
    print(f"worst deviation from the planes orthogonal to the sun path: energy only "
          f"{r['worst_free_deg']:.2f} deg, with the {a.theta:g} deg cone {r['worst_deg']:.2f} deg "
          f"(solve {'ok' if r['success'] else 'FAILED'})")
    print(f"user term sun_path (mean <e, d_k>^2): {r['energy_free']:.4f} -> {r['energy']:.4f}")
    return r


if __name__ == "__main__":
    main()
