"""The strongest simple device: one family of parallel planar fins whose plane orientation is
optimized for the design's sun.

The planes' normal ``p`` is searched over every orientation within ``max_tilt`` of standing
square on A's mean plane: ``p = cos(t) (cos(phi) e1 + sin(phi) e2) + sin(t) n`` with ``n`` A's
mean normal, ``e1`` the frame's first axis across A (horizontal on a facade, so ``phi = 90``
gives horizontal louvers and ``phi = 0`` vertical fins), ``phi`` in [0, 180) and the tilt ``t``
in [-max_tilt, max_tilt]. The objective is the weighted share of direct sun the fins block at
the given depth and spacing (:func:`~torsal.light.shading.direct_sun_blocked`, the same
measurement as every other device, on one seeded set of sample points for all candidates);
among orientations within 0.1 percentage points of the best, the least tilted wins (fins
square off the surface are the simpler part).

The search: a coarse grid (phi every 15 degrees, t every 15 degrees), then a pattern search
around the best point with steps 7.5, 3.75 and 1.875 degrees. Sun paths of more than
:data:`SEARCH_DIRECTIONS` directions are thinned for the search (every j-th direction in time
order, carrying the weights of the ones it stands for); the device is then measured with all.

Examples
--------
>>> from torsal.geometry.surfaces import flat_facade
>>> from torsal.light.shading import direct_sun_blocked
>>> from torsal.light.devices import vertical_fins
>>> v, f = flat_facade(nu=9, nv=5)
>>> sun = [[1.0, -1.0, 0.3]]                         # a low sun from the south-east
>>> best = optimize_fin_orientation(v, f, sun, depth=0.4, spacing=0.5)
>>> fins = vertical_fins(v, f, 0.4, 0.5)
>>> best.blocked_share >= direct_sun_blocked(fins, (v, f), sun, samples=300).share
True
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from ..shading import direct_sun_blocked
from .frame import surface_frame
from torsal.geometry.mesh import average_edge_length
from .sections import SurfaceSections

__all__ = ["FinOrientation", "optimize_fin_orientation", "plane_normal", "SEARCH_DIRECTIONS",
           "MAX_TILT_DEG"]

#: sun directions the search uses at most (thinned in time order beyond)
SEARCH_DIRECTIONS = 48
#: largest tilt of the fin planes from A's normal the search tries (degrees)
MAX_TILT_DEG = 45.0
_COARSE_STEP = 15.0
_REFINE_STEPS = (7.5, 3.75, 1.875)
_TIE = 1e-3


@dataclass(frozen=True)
class FinOrientation:
    """The plane orientation of the optimized parallel fins.

    Attributes
    ----------
    plane_normal : (3,) float
        Unit normal of the fin planes (model frame).
    rotation_deg : float
        ``phi``: direction of ``p``'s in-plane part from the frame's first axis across A,
        degrees in [0, 180) (on a facade: 90 = horizontal louvers, 0 = vertical fins).
    tilt_deg : float
        ``t``: tilt of the planes away from standing square on A's mean plane, degrees.
    blocked_share : float
        Weighted share of the sun blocked on the search's sample points.
    evaluations : int
        Orientations measured.
    """

    plane_normal: np.ndarray
    rotation_deg: float
    tilt_deg: float
    blocked_share: float
    evaluations: int

    def as_dict(self) -> dict:
        return {"plane_normal": [float(x) for x in self.plane_normal],
                "rotation_deg": float(self.rotation_deg), "tilt_deg": float(self.tilt_deg),
                "search_blocked_share": float(self.blocked_share),
                "evaluations": int(self.evaluations)}


def plane_normal(frame, rotation_deg: float, tilt_deg: float) -> np.ndarray:
    """``p(phi, t)`` (3,) in the frame of :func:`~torsal.light.devices.frame.surface_frame`."""
    n = frame.normal
    e1 = frame.u - (frame.u @ n) * n
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    phi, t = np.radians(rotation_deg), np.radians(tilt_deg)
    return np.cos(t) * (np.cos(phi) * e1 + np.sin(phi) * e2) + np.sin(t) * n


def _thinned(sun, weights):
    s = np.asarray(sun, float).reshape(-1, 3)
    w = np.ones(len(s)) if weights is None else np.asarray(weights, float).ravel()
    if len(s) <= SEARCH_DIRECTIONS:
        return s, w
    j = int(np.ceil(len(s) / SEARCH_DIRECTIONS))
    groups = np.arange(len(s)) // j
    return s[::j], np.bincount(groups, weights=w)


def _wrap(phi: float, t: float) -> tuple[float, float]:
    """(phi, t) and (phi + 180, -t) are the same plane family: keep phi in [0, 180)."""
    while phi >= 180.0:
        phi, t = phi - 180.0, -t
    while phi < 0.0:
        phi, t = phi + 180.0, -t
    return phi, t


def optimize_fin_orientation(surface_vertices, surface_faces, sun, depth: float, spacing: float,
                             *, weights=None, samples: int = 300, seed: int | None = 0,
                             max_tilt: float = MAX_TILT_DEG,
                             up=(0.0, 0.0, 1.0)) -> FinOrientation:
    """The plane orientation of parallel fins (``depth`` deep, ``spacing`` apart) that blocks
    the most of the design's sun on A (see the module's description of the search).

    Parameters
    ----------
    surface_vertices : (n, 3) float
    surface_faces : (F, 3) int
        Design surface A, normals outside (towards the sun).
    sun : (k, 3) float
        Sun vectors, site -> sun (above the horizon).
    depth, spacing : float
        Model units.
    weights : (k,) float, optional
        Per-direction weights (e.g. DNI); default 1.
    samples : int, default 300
        Seeded sample points on A for the search.
    max_tilt : float, default 45
        Degrees, in [0, 80].
    up : (3,) float

    Returns
    -------
    FinOrientation
    """
    if not 0.0 <= max_tilt <= 80.0:
        raise ValueError(f"max_tilt must be in [0, 80] degrees, got {max_tilt}")
    v = np.asarray(surface_vertices, float)
    f = np.asarray(surface_faces, np.int64)
    frame = surface_frame(v, f, up=up)
    s, w = _thinned(sun, weights)
    surface = trimesh.Trimesh(v, f, process=False)
    cut = SurfaceSections(v, f)
    offset = 1e-4 * average_edge_length(v, f)        # direct_sun_blocked's default
    seen: dict[tuple[float, float], float] = {}
    pts = None

    def share(phi: float, t: float) -> float:
        nonlocal pts
        phi, t = _wrap(phi, float(np.clip(t, -max_tilt, max_tilt)))
        key = (round(phi, 6), round(t, 6))
        if key not in seen:
            fins = cut.fins(plane_normal(frame, phi, t), depth, spacing)
            res = direct_sun_blocked(fins, surface, s, samples=samples if pts is None else pts,
                                     weights=w, seed=seed, offset=offset)
            pts = (res.points, res.normals)
            seen[key] = float(np.nan_to_num(res.share))    # no sun on A: nothing to block
        return seen[key]

    tilts = np.arange(0.0, max_tilt + 1e-9, _COARSE_STEP)
    tilts = np.unique(np.r_[-tilts, tilts, max_tilt, -max_tilt])
    for phi in np.arange(0.0, 180.0, _COARSE_STEP):
        for t in tilts:
            share(phi, t)
    best = max(seen, key=seen.get)
    for step in _REFINE_STEPS:
        improved = True
        while improved:
            improved = False
            phi0, t0 = best
            for dp, dt in ((step, 0), (-step, 0), (0, step), (0, -step), (step, step),
                           (step, -step), (-step, step), (-step, -step)):
                share(phi0 + dp, t0 + dt)
            top = max(seen, key=seen.get)
            if seen[top] > seen[best]:
                best, improved = top, True
    top = seen[best]
    # the least tilted of the orientations as good as the best (within 0.1 points)
    chosen = min((k for k, x in seen.items() if x >= top - _TIE),
                 key=lambda k: (abs(k[1]), -seen[k]))
    phi, t = chosen
    return FinOrientation(plane_normal(frame, phi, t), phi, t, seen[chosen], len(seen))
