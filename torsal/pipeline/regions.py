"""Where on the surface a goal applies: regions of vertices and faces, and the one design
light direction of a sun path."""
from __future__ import annotations

import numpy as np

from .design_file import Region

__all__ = ["select_vertices", "select_faces", "dominant_light_direction"]


def _box_mask(region: Region, points: np.ndarray) -> np.ndarray | None:
    """Points inside the region's axis ranges; None when the region gives no range."""
    inside, boxed = np.ones(len(points), bool), False
    for k, name in enumerate("xyz"):
        r = getattr(region, name)
        if r is not None:
            boxed = True
            inside &= (points[:, k] >= r[0]) & (points[:, k] <= r[1])
    return inside if boxed else None


def _indices(idx, n: int, what: str) -> np.ndarray:
    idx = np.asarray(idx, np.int64)
    if idx.size and (idx.min() < 0 or idx.max() >= n):
        raise ValueError(f"region.{what} has indices outside 0..{n - 1}")
    return idx


def select_vertices(region: Region | None, vertices: np.ndarray) -> np.ndarray:
    """Indices of the vertices inside a :class:`Region` (all when ``region`` is None).

    >>> select_vertices(Region(x=(0, 1)), np.array([[0.5, 0, 0], [2, 0, 0]]))
    array([0])
    """
    n = len(vertices)
    if region is None:
        return np.arange(n)
    mask = _box_mask(region, vertices)
    idx = np.flatnonzero(mask) if mask is not None else np.zeros(0, np.int64)
    if region.vertices is not None:
        idx = np.union1d(idx, _indices(region.vertices, n, "vertices"))
    return idx


def select_faces(region: Region | None, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Indices of the faces whose barycenter is inside a :class:`Region`, listed in
    ``region.faces``, or with all corners in ``region.vertices``."""
    nf = len(faces)
    if region is None:
        return np.arange(nf)
    mask = _box_mask(region, vertices[faces].mean(axis=1))
    idx = np.flatnonzero(mask) if mask is not None else np.zeros(0, np.int64)
    if region.faces is not None:
        idx = np.union1d(idx, _indices(region.faces, nf, "faces"))
    if region.vertices is not None:
        vin = np.zeros(len(vertices), bool)
        vin[_indices(region.vertices, len(vertices), "vertices")] = True
        idx = np.union1d(idx, np.flatnonzero(vin[faces].all(axis=1)))
    return idx


def dominant_light_direction(d: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The one design light direction for f_perp from many weighted directions, (3,) unit.

    The eigenvector of ``M = sum_k w_k d_k d_k^T`` with the largest eigenvalue: the direction
    that carries most of ``sum_k w_k <e, d_k>^2``, signed like the weighted mean. The paper
    uses one light direction per goal (4.3); making the lines orthogonal to the whole span of
    a sun path instead would force them parallel to M's weakest eigenvector, a parallel
    bundle without torsal directions.
    """
    d = np.asarray(d, float)
    w = np.asarray(w, float)
    M = (d * w[:, None]).T @ d
    q = np.linalg.eigh(M)[1][:, -1]
    return q if q @ (d * w[:, None]).sum(0) >= 0 else -q
