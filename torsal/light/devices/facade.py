"""What a designer would otherwise put on a facade: horizontal louvers, vertical fins and the
orthogonal egg-crate of both (the conventional shades of Ladybug/Honeybee-style workflows),
and the unoptimized normal-congruence fins torsal starts from.

Each is a family of :func:`~torsal.light.devices.sections.section_fins` on the design
surface A, so it is measured with exactly the same code as torsal's fins.

Examples
--------
>>> from torsal.geometry.surfaces import facade_patch
>>> v, f = facade_patch(bulge=0.0, twist=0.0)
>>> louvers = horizontal_louvers(v, f, depth=0.4, spacing=0.5)
>>> len(louvers.faces) > 0
True
"""
from __future__ import annotations

import numpy as np
import trimesh

from torsal.geometry.mesh import area_vector, vertex_normals
from .sections import section_fins, unit_vector

__all__ = ["horizontal_louvers", "vertical_fins", "egg_crate", "grid_normal_fins",
           "vertical_fin_normal"]


def horizontal_louvers(surface_vertices, surface_faces, depth: float, spacing: float, *,
                       up=(0.0, 0.0, 1.0), origin: float = 0.0) -> trimesh.Trimesh:
    """Horizontal louvers of ``depth`` every ``spacing`` along ``up`` (planes z = k*spacing).

    See :func:`~torsal.light.devices.sections.section_fins`; ``origin`` shifts the family
    (louver heights ``origin + k * spacing``). Returns a thin-surface ``trimesh.Trimesh``.
    """
    return section_fins(surface_vertices, surface_faces, up, depth, spacing, origin=origin)


def vertical_fin_normal(surface_vertices, surface_faces, *, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """The normal of vertical fin planes across A: the horizontal direction in A's mean
    tangent plane, ``up x mean_normal`` (unit, (3,)); for the x-z facade of
    :func:`torsal.geometry.surfaces.facade_patch` that is +-x. Raises ``ValueError`` when A
    faces straight up or down on average (no direction across it is horizontal)."""
    u = unit_vector(up, "up")
    n = unit_vector(area_vector(surface_vertices, surface_faces), "the mean normal of A")
    along = np.cross(u, n)
    if np.linalg.norm(along) < 1e-6:
        raise ValueError("A is horizontal on average; give `along` for vertical fins")
    return along / np.linalg.norm(along)


def vertical_fins(surface_vertices, surface_faces, depth: float, spacing: float, *,
                  up=(0.0, 0.0, 1.0), along=None, origin: float = 0.0) -> trimesh.Trimesh:
    """Vertical fins of ``depth`` every ``spacing`` across the facade.

    The cutting planes are vertical, with normal ``along`` (default:
    :func:`vertical_fin_normal`, planes ``x = k*spacing`` on the x-z facade).
    """
    if along is None:
        along = vertical_fin_normal(surface_vertices, surface_faces, up=up)
    return section_fins(surface_vertices, surface_faces, along, depth, spacing, origin=origin)


def egg_crate(surface_vertices, surface_faces, depth: float, spacing: float, *,
              up=(0.0, 0.0, 1.0), along=None) -> trimesh.Trimesh:
    """The orthogonal egg-crate: horizontal louvers and vertical fins of the same ``depth``
    and ``spacing`` together (cells ``spacing`` x ``spacing`` in plan of A).

    >>> from torsal.geometry.surfaces import facade_patch
    >>> v, f = facade_patch(bulge=0.0, twist=0.0)
    >>> crate = egg_crate(v, f, depth=0.4, spacing=0.5)
    >>> len(crate.faces) == len(horizontal_louvers(v, f, 0.4, 0.5).faces) + len(
    ...     vertical_fins(v, f, 0.4, 0.5).faces)
    True
    """
    return trimesh.util.concatenate([
        horizontal_louvers(surface_vertices, surface_faces, depth, spacing, up=up),
        vertical_fins(surface_vertices, surface_faces, depth, spacing, up=up, along=along)])


def grid_normal_fins(surface_vertices, surface_faces, grid_shape: tuple[int, int], depth: float,
                     *, families=(0, 1), every: int = 1) -> trimesh.Trimesh:
    """Fins of the *unoptimized normal congruence* along the grid lines of a grid surface.

    For a surface sampled on a regular ``(nu, nv)`` vertex grid (row-major, as the
    generators of :mod:`torsal.geometry.surfaces` produce), every ``every``-th grid line of
    the chosen families becomes a strip of fins between ``a_i`` and
    ``b_i = a_i + depth * n_i`` (area-weighted vertex normals of A). This is the congruence
    torsal starts from, before any optimization and without remeshing along its torsal
    directions; the fins are generally not planar. (The remeshed normal-congruence baseline
    comes from ``SupportStructure.fin_mesh()``; every measurement accepts either.)

    Parameters
    ----------
    surface_vertices : (nu * nv, 3) float
    surface_faces : (F, 3) int
        Used for the vertex normals only.
    grid_shape : (int, int)
        ``(nu, nv)``; vertex ``i * nv + j``.
    depth : float
    families : iterable of {0, 1}, default (0, 1)
        0: lines of constant ``i`` (along j), 1: lines of constant ``j`` (along i).
    every : int, default 1
        Keep every ``every``-th line of each family (fin spacing in grid steps).

    Returns
    -------
    trimesh.Trimesh
        Two triangles per fin quad, vertices ``[a; b]``.
    """
    v = np.asarray(surface_vertices, float)
    nu, nv = map(int, grid_shape)
    if nu * nv != len(v):
        raise ValueError(f"grid_shape {grid_shape} does not match {len(v)} vertices")
    if not (np.isfinite(depth) and depth > 0):
        raise ValueError(f"depth must be positive, got {depth}")
    if every < 1:
        raise ValueError(f"every must be at least 1, got {every}")
    n = vertex_normals(v, surface_faces)
    idx = np.arange(nu * nv).reshape(nu, nv)
    edges = []
    if 0 in families:  # along j on rows i = 0, every, 2 every, ...
        rows = idx[::every]
        edges.append(np.c_[rows[:, :-1].ravel(), rows[:, 1:].ravel()])
    if 1 in families:
        cols = idx[:, ::every]
        edges.append(np.c_[cols[:-1, :].ravel(), cols[1:, :].ravel()])
    if not edges:
        raise ValueError("families must contain 0 and/or 1")
    e = np.concatenate(edges)
    i, j = e[:, 0], e[:, 1]
    m = len(v)
    tri = np.concatenate([np.c_[i, j, j + m], np.c_[i, j + m, i + m]])
    return trimesh.Trimesh(np.concatenate([v, v + depth * n]), tri, process=False)
