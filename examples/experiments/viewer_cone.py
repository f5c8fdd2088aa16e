"""Experiment: fins that open towards a viewer, with a user's own per-vertex constraint.

A cafe table stands in front of the facade; from there the fins should look open, so every
line must lie within ``theta`` degrees of the sight line from its vertex to the viewer. The
sight line differs per vertex: it is passed as per-vertex parameters of ``add_constraint``,
``<e_i, s_i> - cos(theta) >= 0`` with ``s_i`` the unit vector from ``a_i`` to the viewer. A
user's own energy added with ``add_term`` keeps the lines orthogonal to the noon sun
(``<e, d>^2``, like the paper's f_perp). It solves with IPOPT and prints the measured worst
angle to the sight lines and the shading energy it costs.

Run:  .venv/bin/python examples/experiments/viewer_cone.py [--nu 25 --nv 13 --theta 40]
"""
from __future__ import annotations

import argparse

import numpy as np

from torsal.geometry import Congruence, CongruenceProblem
from torsal.geometry.surfaces import facade_patch

NOON = np.array([0.0, -0.55, 0.83]) / np.linalg.norm([0.0, -0.55, 0.83])   # site -> sun
VIEWER = np.array([0.0, -6.0, 1.2])                                     # eye of a seated person


def sight_angle_deg(c: Congruence) -> np.ndarray:
    """Measured angle (degrees) between each line and its sight line to the viewer, (n,)."""
    e = c.directions / np.linalg.norm(c.directions, axis=1, keepdims=True)
    s = VIEWER - c.vertices
    s /= np.linalg.norm(s, axis=1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", e, s), -1, 1)))


def run(nu: int = 25, nv: int = 13, theta: float = 40.0) -> dict:
    c = Congruence.from_normals(facade_patch(nu=nu, nv=nv))
    s = VIEWER - c.vertices
    s /= np.linalg.norm(s, axis=1, keepdims=True)
    p = (CongruenceProblem(c).normal().fair()
         .add_term("noon_shade", 5.0, lambda e, a, d: (e[0, 0] * d[0] + e[0, 1] * d[1] + e[0, 2] * d[2]) ** 2,
                   over="vertices", params=NOON))
    free = p.solve()
    p.add_constraint("viewer", lambda e, a, q: e[0, 0] * q[0] + e[0, 1] * q[1] + e[0, 2] * q[2] - q[3],
                     over="vertices", params=np.column_stack([s, np.full(len(s), np.cos(np.radians(theta)))]))
    res = p.solve()
    return {"success": res.success, "worst_free_deg": float(sight_angle_deg(free.congruence).max()),
            "worst_deg": float(sight_angle_deg(res.congruence).max()),
            "shade_free": free.energies_after["noon_shade"], "shade": res.energies_after["noon_shade"]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nu", type=int, default=25)
    ap.add_argument("--nv", type=int, default=13)
    ap.add_argument("--theta", type=float, default=40.0)
    a = ap.parse_args(argv)
    r = run(a.nu, a.nv, a.theta)
    print(f"worst angle between a line and its sight line to the viewer: without the constraint "
          f"{r['worst_free_deg']:.1f} deg, with it {r['worst_deg']:.2f} deg (bound {a.theta:g}; "
          f"solve {'ok' if r['success'] else 'FAILED'})")
    print(f"user term noon_shade (mean <e, d>^2): {r['shade_free']:.4f} -> {r['shade']:.4f}")
    return r


if __name__ == "__main__":
    main()
