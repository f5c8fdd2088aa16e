"""Fins along the sections of a surface by a family of parallel planes.

Every standard device of :mod:`torsal.light.devices` is one or two such families: the design
surface A is cut by the planes ``<p, x> = origin + k spacing`` and each section polyline is
extruded outwards by ``depth`` along A's normal projected into its cutting plane, so every fin
lies in its plane (flat, buildable) and leaves A at right angles in the plane's section.

Examples
--------
>>> from torsal.geometry.surfaces import flat_facade
>>> v, f = flat_facade()
>>> fins = section_fins(v, f, [0, 0, 1], depth=0.4, spacing=0.5)
>>> round(float(fins.metadata["stand_out_deg"]), 6)     # louvers stand square off a wall
90.0
"""
from __future__ import annotations

import numpy as np
import trimesh

from torsal.geometry.mesh import unique_edges

__all__ = ["section_fins", "SurfaceSections", "unit_vector", "empty_fins"]


def unit_vector(v, name) -> np.ndarray:
    """``v`` (3,) as a unit vector; a non-finite or zero vector raises ``ValueError`` naming ``name``."""
    v = np.asarray(v, float).reshape(3)
    n = np.linalg.norm(v)
    if not np.isfinite(v).all() or n < 1e-12:
        raise ValueError(f"{name} must be a finite non-zero 3-vector, got {v}")
    return v / n


def empty_fins() -> trimesh.Trimesh:
    """A fin set without a fin (blocks nothing)."""
    m = trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), process=False)
    m.metadata["stand_out_deg"] = None
    return m


def _levels(h: np.ndarray, origin: float, spacing: float, size: float) -> np.ndarray:
    """Plane offsets ``origin + k spacing`` strictly inside the range of ``h`` (a plane
    touching A only at its extreme is no fin)."""
    tol = 1e-9 * size
    k0 = int(np.ceil((h.min() - origin) / spacing))
    k1 = int(np.floor((h.max() - origin) / spacing))
    levels = origin + spacing * np.arange(k0, k1 + 1)
    return levels[(levels > h.min() + tol) & (levels < h.max() - tol)]


class SurfaceSections:
    """Mesh A prepared for cutting by many plane families (its edges and face normals
    computed once): what an orientation search needs.

    >>> from torsal.geometry.surfaces import flat_facade
    >>> cut = SurfaceSections(*flat_facade())
    >>> len(cut.fins([0, 0, 1], 0.4, 0.5).faces) > 0
    True
    """

    def __init__(self, vertices, faces):
        v = np.asarray(vertices, float)
        f = np.asarray(faces, np.int64)
        if v.ndim != 2 or v.shape[1] != 3 or not np.isfinite(v).all():
            raise ValueError("surface_vertices must be a finite (n, 3) array")
        self.vertices, self.faces = v, f
        self.edges, self.face_edges = unique_edges(f)
        cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        self.face_normals = cross / np.maximum(np.linalg.norm(cross, axis=1, keepdims=True), 1e-300)
        self.size = float(np.ptp(v, axis=0).max()) if len(v) else 0.0

    def _crossings(self, h, levels):
        """The (face, level) pairs whose triangle a plane cuts, with the two cut edges of each.

        A vertex counts on the positive side of a plane when ``h >= level``, so a plane
        through a vertex or an edge cuts each edge once and neighbouring faces share their
        cut points. Returns ``face`` (c,), ``level`` (c,) indices and ``edge_pairs`` (c, 2)
        unique-edge ids.
        """
        hf = h[self.faces]
        lo = np.searchsorted(levels, hf.min(axis=1), side="right")   # first level above the min
        hi = np.searchsorted(levels, hf.max(axis=1), side="right")   # levels <= the max
        count = np.maximum(hi - lo, 0)
        face = np.repeat(np.arange(len(self.faces)), count)
        level = np.repeat(lo, count) + (np.arange(count.sum())
                                        - np.repeat(np.cumsum(count) - count, count))
        # edge k of a face joins its corners k+1 and k+2 (unique_edges' order)
        side = hf[face] >= levels[level][:, None]                   # (c, 3)
        cut = side[:, [1, 2, 0]] != side[:, [2, 0, 1]]
        # exactly two cut edges per pair: the classes of its corners are mixed
        k = np.argsort(~cut, axis=1, kind="stable")[:, :2]
        edge_pairs = np.take_along_axis(self.face_edges[face], k, axis=1)
        return face, level, edge_pairs

    def fins(self, plane_normal, depth: float, spacing: float, *,
             origin: float = 0.0) -> trimesh.Trimesh:
        """The fins of one plane family; see :func:`section_fins`."""
        if not (np.isfinite(depth) and depth > 0):
            raise ValueError(f"depth must be positive, got {depth}")
        if not (np.isfinite(spacing) and spacing > 0):
            raise ValueError(f"spacing must be positive, got {spacing}")
        v, pn = self.vertices, unit_vector(plane_normal, "plane_normal")
        h = v @ pn
        if not len(self.faces):
            return empty_fins()
        levels = _levels(h, float(origin), float(spacing), self.size)
        if not len(levels):
            return empty_fins()
        face, level, edge_pairs = self._crossings(h, levels)
        # A's normal of each cut face projected into the cutting plane: the fin's direction
        fn = self.face_normals[face]
        m = fn - (fn @ pn)[:, None] * pn
        ml = np.linalg.norm(m, axis=1)
        ok = ml > 1e-9                               # a face lying in its plane gives no direction
        if not ok.any():
            return empty_fins()
        level, edge_pairs, m, ml = level[ok], edge_pairs[ok], m[ok], ml[ok]
        m = m / ml[:, None]
        # one cut point per (edge, level), or per (vertex, level) where a plane passes through
        # a vertex: neighbouring fin quads share it exactly (no leaks)
        nl = len(levels)
        ids, inv = np.unique((edge_pairs * nl + level[:, None]).ravel(), return_inverse=True)
        e, lv = self.edges[ids // nl], ids % nl
        ha, hb = h[e[:, 0]], h[e[:, 1]]
        t = (levels[lv] - ha) / (hb - ha)            # the cut edges' ends lie on both sides
        # within rounding of a vertex (levels k * spacing are rounded too): the vertex itself
        at = np.where(t <= 1e-9, e[:, 0], np.where(t >= 1.0 - 1e-9, e[:, 1], -1))
        where = np.where(at >= 0, at, len(v) + ids // nl)
        pid, first, back = np.unique(where * nl + lv, return_index=True, return_inverse=True)
        inv = back[inv].reshape(-1, 2)
        e, t, at = e[first], np.clip(t[first], 0.0, 1.0), at[first]
        pts = v[e[:, 0]] + t[:, None] * (v[e[:, 1]] - v[e[:, 0]])
        pts[at >= 0] = v[at[at >= 0]]
        dirs = np.zeros_like(pts)
        np.add.at(dirs, inv.ravel(), np.repeat(m, 2, axis=0))
        dl = np.linalg.norm(dirs, axis=1)
        # directions of neighbouring segments that cancel (a fold of A) keep one segment's
        fallback = np.zeros_like(pts)
        fallback[inv.ravel()] = np.repeat(m, 2, axis=0)
        dirs = np.where(dl[:, None] > 1e-9, dirs / np.maximum(dl, 1e-300)[:, None], fallback)
        seg = inv[inv[:, 0] != inv[:, 1]]
        keep = np.unique(np.sort(seg, axis=1), axis=0, return_index=True)[1]
        a0, a1 = seg[np.sort(keep)].T
        nb = len(pts)
        tris = np.concatenate([np.c_[a0, a1, a1 + nb], np.c_[a0, a1 + nb, a0 + nb]])
        out = trimesh.Trimesh(np.concatenate([pts, pts + depth * dirs]), tris, process=False)
        # the angle at which each fin leaves A: its direction m makes the angle asin(|m|)
        # with A's tangent plane (|m| = sin of the angle between A's normal and the plane's)
        length = np.linalg.norm(pts[inv[:, 1]] - pts[inv[:, 0]], axis=1)
        out.metadata["stand_out_deg"] = _weighted_median(
            np.degrees(np.arcsin(np.clip(ml, 0, 1))), length)
        return out


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
        ``metadata["stand_out_deg"]``: the length-weighted median angle at which the fins
        leave A (90 degrees: square off the surface, 0: lying in it; None without fins).
    """
    if not (np.isfinite(depth) and depth > 0):
        raise ValueError(f"depth must be positive, got {depth}")
    if not (np.isfinite(spacing) and spacing > 0):
        raise ValueError(f"spacing must be positive, got {spacing}")
    return SurfaceSections(surface_vertices, surface_faces).fins(plane_normal, depth, spacing,
                                                                 origin=origin)


def _weighted_median(x: np.ndarray, w: np.ndarray) -> float | None:
    if not len(x) or w.sum() <= 0:
        return None
    order = np.argsort(x)
    c = np.cumsum(w[order])
    return float(x[order][np.searchsorted(c, 0.5 * c[-1])])
