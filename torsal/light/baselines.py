"""What a designer would otherwise use: horizontal louvers and vertical fins.

The conventional shades of Ladybug/Honeybee-style workflows, generated along the design
surface A so that they can be measured with exactly the same code as torsal's fins:
A is cut by a family of parallel planes ``spacing`` apart (horizontal planes for louvers,
vertical planes across the facade for fins), and each section polyline is extruded
outwards by ``depth`` along A's normal projected into the cutting plane, so every louver
or fin lies in its cutting plane (flat, buildable) and leaves A at right angles in plan
or section.

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

__all__ = ["horizontal_louvers", "vertical_fins", "egg_crate", "section_fins", "grid_normal_fins",
           "baselines"]


def _unit3(v, name) -> np.ndarray:
    v = np.asarray(v, float).reshape(3)
    n = np.linalg.norm(v)
    if not np.isfinite(v).all() or n < 1e-12:
        raise ValueError(f"{name} must be a finite non-zero 3-vector, got {v}")
    return v / n


def section_fins(surface_vertices, surface_faces, plane_normal, depth: float, spacing: float,
                 *, origin: float = 0.0) -> trimesh.Trimesh:
    """Fins along the sections of A with the planes ``<plane_normal, x> = origin + k spacing``.

    Parameters
    ----------
    surface_vertices : (n, 3) float
    surface_faces : (F, 3) int
        Design surface A, normals outside.
    plane_normal : (3,) float
        Normal of the cutting planes.
    depth : float
        Fin depth, model units, measured from A outwards.
    spacing : float
        Distance between consecutive planes.
    origin : float, default 0
        Offset of the plane family: plane ``k`` is at ``origin + k * spacing``.

    Returns
    -------
    trimesh.Trimesh
        Thin-surface fins, two triangles per section segment (empty if no plane cuts A).
    """
    if not (np.isfinite(depth) and depth > 0):
        raise ValueError(f"depth must be positive, got {depth}")
    if not (np.isfinite(spacing) and spacing > 0):
        raise ValueError(f"spacing must be positive, got {spacing}")
    v = np.asarray(surface_vertices, float)
    f = np.asarray(surface_faces, np.int64)
    if v.ndim != 2 or v.shape[1] != 3 or not np.isfinite(v).all():
        raise ValueError("surface_vertices must be a finite (n, 3) array")
    pn = _unit3(plane_normal, "plane_normal")
    mesh = trimesh.Trimesh(v, f, process=False)
    h = v @ pn
    k0 = int(np.ceil((h.min() - origin) / spacing))
    k1 = int(np.floor((h.max() - origin) / spacing))
    levels = origin + spacing * np.arange(k0, k1 + 1)
    size = float(np.ptp(v, axis=0).max())
    tol = 1e-9 * size
    levels = levels[(levels > h.min() + tol) & (levels < h.max() - tol)]
    verts, tris = [], []
    count = 0
    face_normals = mesh.face_normals
    for c in levels:
        seg, seg_faces = trimesh.intersections.mesh_plane(mesh, pn, pn * c, return_faces=True)
        if len(seg) == 0:
            continue
        # outward direction of each segment: A's normal projected into the cutting plane
        m = face_normals[seg_faces]
        m = m - (m @ pn)[:, None] * pn
        ml = np.linalg.norm(m, axis=1)
        ok = ml > 1e-9  # faces lying in the plane give no direction
        seg, m = seg[ok], m[ok] / ml[ok, None]
        if len(seg) == 0:
            continue
        # merge segment end points so neighbouring quads share their edge (no light leaks)
        ends = seg.reshape(-1, 3)
        key = np.round(ends / max(tol * 10, 1e-12)).astype(np.int64)
        _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
        inv = inv.ravel()
        pts = ends[first]
        dirs = np.zeros_like(pts)
        np.add.at(dirs, inv, np.repeat(m, 2, axis=0))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        e = inv.reshape(-1, 2)
        e = e[e[:, 0] != e[:, 1]]
        e = np.unique(np.sort(e, axis=1), axis=0)  # drop duplicate segments
        nb = len(pts)
        verts.append(np.concatenate([pts, pts + depth * dirs]))
        a0, a1 = e[:, 0] + count, e[:, 1] + count
        b0, b1 = a0 + nb, a1 + nb
        tris.append(np.concatenate([np.c_[a0, a1, b1], np.c_[a0, b1, b0]]))
        count += 2 * nb
    if not verts:
        return trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), process=False)
    return trimesh.Trimesh(np.concatenate(verts), np.concatenate(tris), process=False)


def _mean_normal(v, f) -> np.ndarray:
    return _unit3(area_vector(v, f), "the mean normal of A")


def horizontal_louvers(surface_vertices, surface_faces, depth: float, spacing: float, *,
                       up=(0.0, 0.0, 1.0), origin: float = 0.0) -> trimesh.Trimesh:
    """Horizontal louvers of ``depth`` every ``spacing`` along ``up`` (planes z = k*spacing).

    See :func:`section_fins`; ``origin`` shifts the family (louver heights
    ``origin + k * spacing``). Returns a thin-surface ``trimesh.Trimesh``.
    """
    return section_fins(surface_vertices, surface_faces, up, depth, spacing, origin=origin)


def vertical_fins(surface_vertices, surface_faces, depth: float, spacing: float, *,
                  up=(0.0, 0.0, 1.0), along=None, origin: float = 0.0) -> trimesh.Trimesh:
    """Vertical fins of ``depth`` every ``spacing`` across the facade.

    The cutting planes are vertical, with normal ``along`` (default: the horizontal
    direction in A's mean tangent plane, ``up x mean_normal``; for the x-z facade of
    :func:`torsal.geometry.surfaces.facade_patch` that is +-x, planes ``x = k*spacing``).
    """
    if along is None:
        u = _unit3(up, "up")
        along = np.cross(u, _mean_normal(surface_vertices, surface_faces))
        if np.linalg.norm(along) < 1e-9:
            raise ValueError("A is horizontal on average; give `along` for vertical fins")
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


def baselines(surface_vertices, surface_faces, depth: float, spacing: float, *,
              grid_shape: tuple[int, int] | None = None, every: int | None = None,
              up=(0.0, 0.0, 1.0)) -> dict[str, trimesh.Trimesh]:
    """The conventional shades of equal depth and spacing, by name, ready for
    :func:`torsal.light.shading.compare`: horizontal louvers, vertical fins, the egg-crate
    of both, and (given ``grid_shape``) the unoptimized normal-congruence fins with lines
    ``every`` grid steps apart (default: the step closest to ``spacing``)."""
    out = {
        "horizontal louvers": horizontal_louvers(surface_vertices, surface_faces, depth, spacing, up=up),
        "vertical fins": vertical_fins(surface_vertices, surface_faces, depth, spacing, up=up),
    }
    # the egg-crate of both (what :func:`egg_crate` builds), without cutting A twice
    out["egg-crate"] = trimesh.util.concatenate([out["horizontal louvers"], out["vertical fins"]])
    if grid_shape is not None:
        if every is None:
            v = np.asarray(surface_vertices, float).reshape(*grid_shape, 3)
            step = np.mean([np.linalg.norm(np.diff(v, axis=0), axis=2).mean(),
                            np.linalg.norm(np.diff(v, axis=1), axis=2).mean()])
            every = max(1, int(round(spacing / step)))
        out["normal congruence (unoptimized)"] = grid_normal_fins(
            surface_vertices, surface_faces, grid_shape, depth, every=every)
    return out
