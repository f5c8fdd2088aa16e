"""Generators of design surfaces and analytic test surfaces, as triangle meshes.

Every generator returns ``(vertices (n, 3) float, faces (F, 3) int)`` in model units
(metres unless said otherwise), consistently oriented with normals pointing to +z /
outwards / towards the outside of a facade, and lays its vertices on a regular
``(nu, nv)`` grid (row-major, ``index = i * nv + j``) so callers can address rows and columns.

Examples
--------
>>> v, f = facade_patch(nu=33, nv=17)
>>> v.shape, f.shape
((561, 3), (1024, 3))
"""
from __future__ import annotations

from typing import Callable

import numpy as np

__all__ = [
    "grid_faces",
    "graph_surface",
    "sphere_patch",
    "cylinder_patch",
    "surface_of_revolution",
    "facade_patch",
    "canopy",
    "flat_facade",
    "GENERATORS",
]


def grid_faces(nu: int, nv: int, *, alternate: bool = True) -> np.ndarray:
    """Triangles of a ``nu x nv`` vertex grid (row-major), two per cell, counter-clockwise
    in the (i, j) parameter plane. ``alternate`` flips the diagonal in a checkerboard so the
    triangulation has no preferred direction."""
    if nu < 2 or nv < 2:
        raise ValueError(f"a grid needs at least 2 x 2 vertices, got {nu} x {nv}")
    idx = np.arange(nu * nv).reshape(nu, nv)
    p00, p10 = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel()
    p11, p01 = idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    ii, jj = np.meshgrid(np.arange(nu - 1), np.arange(nv - 1), indexing="ij")
    flip = ((ii + jj).ravel() % 2 == 1) if alternate else np.zeros(p00.size, bool)
    t1 = np.where(flip[:, None], np.c_[p00, p10, p01], np.c_[p00, p10, p11])
    t2 = np.where(flip[:, None], np.c_[p10, p11, p01], np.c_[p00, p11, p01])
    return np.concatenate([t1, t2]).astype(np.int64)


def graph_surface(f: Callable[[np.ndarray, np.ndarray], np.ndarray], *,
                  x_range=(-0.5, 0.5), y_range=(-0.5, 0.5), nu: int = 21, nv: int = 21,
                  alternate: bool = True):
    """Triangulated graph ``z = f(x, y)`` on a regular grid, normals towards +z."""
    x = np.linspace(*x_range, nu)
    y = np.linspace(*y_range, nv)
    X, Y = np.meshgrid(x, y, indexing="ij")
    V = np.c_[X.ravel(), Y.ravel(), np.asarray(f(X, Y), float).ravel()]
    return V, grid_faces(nu, nv, alternate=alternate)


def sphere_patch(radius: float = 1.0, *, theta_max_deg: float = 60.0, nu: int = 17, nv: int = 17,
                 center=(0.0, 0.0, 0.0)):
    """A patch of the sphere around its north pole, sampled on a square (x, y) grid and
    lifted to the sphere; outward normals. ``theta_max_deg`` bounds the polar angle."""
    s = np.sin(np.radians(theta_max_deg)) / np.sqrt(2.0)
    V, F = graph_surface(lambda x, y: np.sqrt(np.maximum(1.0 - x * x - y * y, 0.0)),
                         x_range=(-s, s), y_range=(-s, s), nu=nu, nv=nv)
    return V * radius + np.asarray(center, float), F


def cylinder_patch(radius: float = 1.0, *, angle_deg: float = 90.0, height: float = 1.0,
                   nu: int = 17, nv: int = 11):
    """A patch of the cylinder ``x^2 + y^2 = radius^2`` (axis z), outward normals.
    Rows (index i) go around the axis, columns (j) along it."""
    th = np.radians(np.linspace(-angle_deg / 2, angle_deg / 2, nu))
    z = np.linspace(0.0, height, nv)
    T, Z = np.meshgrid(th, z, indexing="ij")
    V = np.c_[radius * np.cos(T).ravel(), radius * np.sin(T).ravel(), Z.ravel()]
    return V, grid_faces(nu, nv)


def surface_of_revolution(profile_r: Callable[[np.ndarray], np.ndarray], *, z_range=(0.0, 1.0),
                          angle_deg: float = 120.0, nu: int = 25, nv: int = 25):
    """Surface ``(r(z) cos phi, r(z) sin phi, z)``; rows follow parallels (i: angle),
    columns meridians (j: height). Outward normals."""
    phi = np.radians(np.linspace(-angle_deg / 2, angle_deg / 2, nu))
    z = np.linspace(*z_range, nv)
    P, Z = np.meshgrid(phi, z, indexing="ij")
    R = profile_r(Z)
    V = np.c_[(R * np.cos(P)).ravel(), (R * np.sin(P)).ravel(), Z.ravel()]
    return V, grid_faces(nu, nv)


def facade_patch(*, width: float = 12.0, height: float = 6.0, bulge: float = 0.9,
                 sag: float = 0.4, twist: float = 0.6, nu: int = 33, nv: int = 17):
    """A doubly curved facade: a vertical wall in the x-z plane (x east, z up) bulging
    ``bulge`` towards -y (south, the outside) in plan, curving back by ``sag`` towards the
    top and bottom, with a saddle ``twist``. The outside faces -y.

    The curvature is anticlastic everywhere (negative Gaussian curvature), so the normal
    congruence has no umbilics and its torsal directions are defined on every face.
    Sizes in metres; ``nu x nv`` vertices: 33 x 33 gives the paper's Fig. 7a size
    (1089 vertices, 2048 faces), 33 x 17 the Fig. 7d size (561 vertices, 1024 faces).
    """
    s = np.linspace(-0.5, 0.5, nu)
    t = np.linspace(-0.5, 0.5, nv)
    S, T = np.meshgrid(s, t, indexing="ij")
    x = S * width
    z = (T + 0.5) * height
    y = -bulge * (1.0 - 4.0 * S**2) - sag * 4.0 * T**2 - twist * S * T
    V = np.c_[x.ravel(), y.ravel(), z.ravel()]
    # grid_faces winds counter-clockwise in (x, z), so the normals point to -y (outside)
    return V, grid_faces(nu, nv)


def canopy(*, span: float = 10.0, rise: float = 2.5, sag: float = 0.8, nu: int = 25, nv: int = 25):
    """A doubly curved roof canopy over a square plan, normals up (+z): a hyperbolic
    paraboloid-like saddle with a dome term, so torsal families are non-trivial."""
    x = np.linspace(-span / 2, span / 2, nu)
    y = np.linspace(-span / 2, span / 2, nv)
    X, Y = np.meshgrid(x, y, indexing="ij")
    Z = rise * (1 - (X / span) ** 2 * 2) - sag * (Y / span) ** 2 * 4 + 0.3 * rise * X * Y / span**2 * 4
    V = np.c_[X.ravel(), Y.ravel(), Z.ravel()]
    return V, grid_faces(nu, nv)


def flat_facade(*, width: float = 12.0, height: float = 6.0, nu: int = 33, nv: int = 17):
    """A truly flat facade (Fig. 7d): the plane y = 0 over ``width x height`` metres
    (x east, z up), outside towards -y."""
    x = np.linspace(-width / 2, width / 2, nu)
    z = np.linspace(0.0, height, nv)
    X, Z = np.meshgrid(x, z, indexing="ij")
    V = np.c_[X.ravel(), np.zeros(X.size), Z.ravel()]
    return V, grid_faces(nu, nv)


#: Named generators for design files: name -> callable(**params) -> (vertices, faces)
GENERATORS: dict[str, Callable[..., tuple[np.ndarray, np.ndarray]]] = {
    "facade_patch": facade_patch,
    "canopy": canopy,
    "sphere_patch": sphere_patch,
    "cylinder_patch": cylinder_patch,
    "flat_facade": flat_facade,
}
