"""Synthetic support structures for the fabrication tests (exactly planar fins).

Shared by the test modules (imported by name: pytest puts this folder on sys.path).

Grids of ``nu x nv`` nodes, node ``r * nu + c``; family 0 = rows (c -> c+1),
family 1 = columns (r -> r+1). Coordinates in metres.
"""
from __future__ import annotations

import numpy as np

from torsal.geometry.support import SupportStructure


def grid_structure(a: np.ndarray, b: np.ndarray, nu: int, nv: int) -> SupportStructure:
    idx = np.arange(nu * nv).reshape(nv, nu)
    e0 = np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()]
    e1 = np.c_[idx[:-1, :].ravel(), idx[1:, :].ravel()]
    edges = np.r_[e0, e1]
    fam = np.r_[np.zeros(len(e0), int), np.ones(len(e1), int)]
    faces = [[idx[r, c], idx[r, c + 1], idx[r + 1, c + 1], idx[r + 1, c]]
             for r in range(nv - 1) for c in range(nu - 1)]
    return SupportStructure(a.reshape(-1, 3), b.reshape(-1, 3), faces, edges, fam)


def sphere_structure(nu: int = 4, nv: int = 3, radius: float = 3.0, step: float = 0.1,
                     depth: float = 0.15) -> SupportStructure:
    """Lat/long patch of a sphere; node lines through the centre: every fin exactly planar."""
    th = (np.arange(nu) - (nu - 1) / 2) * step
    ph = (np.arange(nv) - (nv - 1) / 2) * step
    T, P = np.meshgrid(th, ph)
    d = np.stack([np.cos(P) * np.cos(T), np.cos(P) * np.sin(T), np.sin(P)], axis=-1)
    return grid_structure(radius * d, (radius + depth) * d, nu, nv)


def cylinder_structure(nu: int = 4, nv: int = 3, radius: float = 2.0, step: float = 0.15,
                       height: float = 0.3, depth: float = 0.12, tilt: float = 0.6,
                       closed: bool = False) -> SupportStructure:
    """Quad grid on a cylinder (axis z). Node lines ``radial + tilt * z``: the lines of a row
    meet on the axis (fins of a row are planar and fold like a cone), those of a column are
    parallel. ``closed=True`` wraps the rows all the way round (closed strips)."""
    th = np.arange(nu) * (2 * np.pi / nu if closed else step)
    z = np.arange(nv) * height
    T, Z = np.meshgrid(th, z)
    d = np.stack([np.cos(T), np.sin(T), tilt * np.ones_like(T)], axis=-1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    a = radius * np.stack([np.cos(T), np.sin(T), 0 * T], axis=-1) + np.stack([0 * T, 0 * T, Z], axis=-1)
    s = grid_structure(a, a + depth * d, nu, nv)
    if closed:
        idx = np.arange(nu * nv).reshape(nv, nu)
        wrap = np.c_[idx[:, -1], idx[:, 0]]
        faces = s.faces + [[idx[r, -1], idx[r, 0], idx[r + 1, 0], idx[r + 1, -1]] for r in range(nv - 1)]
        s = SupportStructure(s.vertices_a, s.vertices_b, faces, np.r_[s.edges, wrap],
                             np.r_[s.edge_family, np.zeros(nv, int)])
    return s


def flat_structure(nu: int = 4, nv: int = 3, step: float = 0.3, depth: float = 0.1) -> SupportStructure:
    x, y = np.meshgrid(np.arange(nu) * step, np.arange(nv) * step)
    a = np.stack([x, y, 0 * x], axis=-1)
    return grid_structure(a, a + [0, 0, depth], nu, nv)


def developable_strip(k: int = 6, seed: int = 0, max_fold_deg: float = 40.0, length: float = 0.3,
                      depth: float = 0.15):
    """A generic strip of k exactly planar quads ``a_i a_j b_j b_i`` (metres) and the fold
    angles (radians) it was built with: each next panel is the previous one's plane turned
    about the shared node line by a random angle, with random lengths and line directions."""
    rng = np.random.default_rng(seed)
    a = [np.zeros(3)]
    u = np.array([0.0, 0.0, 1.0])       # node line direction
    w = np.array([1.0, 0.0, 0.0])       # forward, in the panel plane
    b = [a[0] + depth * u]
    folds = []
    for j in range(k):
        if j > 0:
            phi = np.radians(rng.uniform(-max_fold_deg, max_fold_deg))
            folds.append(phi)
            c, s = np.cos(phi), np.sin(phi)
            w = w * c + np.cross(u, w) * s + u * (u @ w) * (1 - c)
        step = length * rng.uniform(0.7, 1.3)
        a_next = a[-1] + step * w + rng.uniform(-0.2, 0.2) * depth * u
        beta = rng.uniform(-0.3, 0.3)
        u_next = np.cos(beta) * u + np.sin(beta) * w
        b_next = a_next + depth * rng.uniform(0.8, 1.2) * u_next
        a.append(a_next)
        b.append(b_next)
        u = u_next / np.linalg.norm(u_next)
        w = w - (w @ u) * u
        w /= np.linalg.norm(w)
    a, b = np.array(a), np.array(b)
    quads = np.stack([a[:-1], a[1:], b[1:], b[:-1]], axis=1)
    return quads, np.array(folds)


def crossing_strips_structure() -> SupportStructure:
    """:func:`flat_structure` (4 x 3 nodes, rows y = 0, 0.3, 0.6 m) with one more family-0 fin
    from node 5 (x 0.3, y 0.3) to a new node 12 at (0.5, -0.15): a strip of its own (node 5
    has three family-0 edges), butted at node 5, whose panel passes through row 0's panel
    1 -> 2 (structure edge 1) at x = 0.433 m, where no joint joins them."""
    s = flat_structure()
    extra = np.array([[0.5, -0.15, 0.0]])
    a = np.r_[s.vertices_a, extra]
    b = np.r_[s.vertices_b, extra + [0.0, 0.0, 0.1]]
    return SupportStructure(a, b, s.faces, np.r_[s.edges, [[5, len(a) - 1]]],
                            np.r_[s.edge_family, [0]])


def blocked_slide_structure(*, behind: bool = False) -> SupportStructure:
    """A T junction with plates in the way of its butted part (metres; node lines vertical,
    ``a`` at the bottom, depth 0.1 m).

    Row ``W`` (family 0, nodes 0-1-2 along x at y = 0) passes node 1, where column ``P``
    (family 1, nodes 1-3-4 along y at x = 0) ends: P is butted against W and slides into place
    along the line where their planes meet (z), from above or from below, or head on (along
    -y, towards W). Two single-fin rows of family 0 that nothing joins cross P's plane at
    y = 0.3 m, 50 mm above it (``U``, z 0.15 to 0.25) and 50 mm below it (``L``, z -0.15 to
    -0.05): both slides along z pass through one of them (P is 100 mm deep), the head-on slide
    passes neither. With ``behind``, a third such row at y = 0.65 m, level with P (``B``, 50 mm
    beyond P's free end), is in the way of the head-on slide too."""
    x = [(-0.3, 0.0, 0.0), (0.0, 0.0, 0.0), (0.3, 0.0, 0.0), (0.0, 0.3, 0.0), (0.0, 0.6, 0.0),
         (-0.15, 0.3, 0.15), (0.15, 0.3, 0.15), (-0.15, 0.3, -0.15), (0.15, 0.3, -0.15)]
    edges = [[0, 1], [1, 2], [5, 6], [7, 8], [1, 3], [3, 4]]
    family = [0, 0, 0, 0, 1, 1]
    if behind:
        x += [(-0.15, 0.65, 0.0), (0.15, 0.65, 0.0)]
        edges.insert(4, [9, 10])
        family.insert(4, 0)
    a = np.array(x, float)
    return SupportStructure(a, a + [0.0, 0.0, 0.1], [], np.array(edges), np.array(family))
