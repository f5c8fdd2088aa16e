"""Which way a design surface faces: a facade or a canopy, and a frame to place devices and
occupants in.

A surface is a **facade** when at least half of its area is wall-like, i.e. its normal lies
within :data:`WALL_LIMIT_DEG` (45 degrees) of the horizontal; otherwise it is a **canopy**
(a roof or any surface seen from below). Horizontal louvers and vertical fins are facade
devices; the occupant view looks out horizontally through a facade and up through a canopy.

Examples
--------
>>> from torsal.geometry.surfaces import canopy, facade_patch
>>> surface_frame(*facade_patch()).kind, surface_frame(*canopy()).kind
('facade', 'canopy')
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from torsal.geometry.mesh import area_vector
from .sections import unit_vector

__all__ = ["SurfaceFrame", "surface_frame", "WALL_LIMIT_DEG"]

#: a face is wall-like when its normal is within this angle of the horizontal (degrees)
WALL_LIMIT_DEG = 45.0


@dataclass(frozen=True)
class SurfaceFrame:
    """Orientation of a design surface A.

    Attributes
    ----------
    kind : {"facade", "canopy"}
    normal : (3,) float
        A's mean outward normal (unit area vector).
    axis : (3,) float
        The outward view axis: for a facade the mean normal made horizontal, for a canopy the
        mean normal.
    u, w : (3,) float
        Unit vectors across A completing ``(axis, u, w)`` to a right-handed frame; for a
        facade ``u`` is horizontal (along the facade) and ``w`` is up.
    wall_share : float
        Share of A's area that is wall-like.
    normal_elevation_deg : float
        Elevation of the mean normal above the horizon (degrees; 90 for a flat roof).
    """

    kind: str
    normal: np.ndarray
    axis: np.ndarray
    u: np.ndarray
    w: np.ndarray
    wall_share: float
    normal_elevation_deg: float

    @property
    def is_facade(self) -> bool:
        return self.kind == "facade"


def surface_frame(vertices, faces, *, up=(0.0, 0.0, 1.0)) -> SurfaceFrame:
    """Classify A as a facade or a canopy and give its frame (see :class:`SurfaceFrame`).

    Parameters
    ----------
    vertices : (n, 3) float
    faces : (F, 3) int
        Normals outside.
    up : (3,) float
        The vertical (model frame, default +z).
    """
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64)
    up = unit_vector(up, "up")
    cross = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    area = np.linalg.norm(cross, axis=1)
    total = float(area.sum())
    if total <= 0:
        raise ValueError("the surface has no area")
    vertical = np.abs(cross @ up) / np.maximum(area, 1e-300)      # |sin(elevation)| per face
    wall = float(area[vertical <= np.sin(np.radians(WALL_LIMIT_DEG))].sum() / total)
    normal = unit_vector(area_vector(v, f), "the mean normal of A")
    elevation = float(np.degrees(np.arcsin(np.clip(normal @ up, -1.0, 1.0))))
    horizontal = normal - (normal @ up) * up
    if wall >= 0.5 and np.linalg.norm(horizontal) > 1e-6:
        axis = horizontal / np.linalg.norm(horizontal)
        w = up
        u = np.cross(w, axis)
        return SurfaceFrame("facade", normal, axis, u, w, wall, elevation)
    axis = normal
    # across a canopy: its longest horizontal extent first (principal axis, made horizontal)
    c = v - v.mean(axis=0)
    _, _, vt = np.linalg.svd(c - np.outer(c @ axis, axis), full_matrices=False)
    u = vt[0] - (vt[0] @ axis) * axis
    u /= np.linalg.norm(u)
    w = np.cross(axis, u)
    return SurfaceFrame("canopy", normal, axis, u, w, wall, elevation)
