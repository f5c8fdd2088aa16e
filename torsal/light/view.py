"""The occupant's view out through the fins: eye points behind the surface, a documented field
of sight lines, the share of them that pass the fins.

Two view measures are reported for every fin set. **Along the normal**
(:func:`~torsal.light.shading.transparency`) asks, at seeded points on A, whether the line
along A's normal is free (and, as ``transparency_cone``, the share of free lines in a 60 degree
cone about it): the system seen head-on, the sense in which the paper calls well placed fins
"shallow and transparent" (Wang et al. 2013, Fig. 1) and a screen "almost transparent when
viewed from the inside" (Fig. 13b). It is a property of the fins alone, blind to where people
are: fins square to A hide nothing along the normal however dense they are. **View out** (this
module) asks what occupants see:

Eye points (:func:`eye_points`)
    On a **facade** (:func:`~torsal.light.devices.frame.surface_frame`): a grid behind A,
    ``distances`` (default 1, 2 and 3 m) inside along the horizontal view axis, at
    ``eye_height`` (default 1.2 m) above A's lowest point and every ``storey_height``
    (default 3 m) above that while inside A's height, and every ``grid`` (default 1 m) across
    A's width, half a grid step in from its ends. On a **canopy** the grid lies ``distances``
    below A along its mean normal, every ``grid`` across its plan. A grid point whose line
    along the view axis misses A (outside its outline) has no eye point.
Field of sight lines (:func:`sight_lines`)
    Directions at azimuth ``-azimuth .. +azimuth`` (default +-60 degrees, the binocular
    visual field) about the outward view axis and elevation ``elevation`` (default -30 .. +30
    degrees, so sky, landscape and ground are all in it), in cells of ``step`` (default 5)
    degrees, each weighted by its solid angle (``cos(elevation)``). On a facade the view axis
    is A's mean normal made horizontal and elevation is measured from the horizon; on a
    canopy the axis is A's mean normal (the field is the patch of sky above the occupant).
The measure (:func:`view_out`)
    ``share``: over the eye points, the mean of the solid-angle weighted share of the sight
    lines **through A** that pass the fins (sight lines that miss A are wall, floor or
    ceiling: not a view through this surface). ``sight_angle_deg``: per eye point, the
    clear horizontal sight angle, the total azimuth of the eye-level (elevation 0) sight
    lines through A that pass the fins, and the share of eye points reaching EN 17037's
    thresholds for it, 14 / 28 / 54 degrees (minimum / medium / high).

Sources of the view out. EN 17037:2018 *Daylight in buildings*, view out: assessed from occupants' positions
in the utilised area, by the horizontal sight angle (14 / 28 / 54 degrees for the minimum,
medium and high level), the outside distance of the view and the layers seen (sky,
landscape, ground). LEED v4 EQ credit *Quality Views*: a direct line of sight to the outdoors
for 75 % of the regularly occupied floor area, sight lines drawn from seated eye height (42
in, 1.07 m, in the LEED documentation guidance), occupants within three times the head
height of the glazing. Ko, Kent, Schiavon, Levitt and Betti (2022), *A window view quality
assessment framework*, LEUKOS 18(3):268-293: *view access* (how much of the view an occupant
sees through the window) and *view clarity* (how clear it appears, e.g. through shading). The
measure here is a view-access share with the fins as the obstruction, from a grid of
occupant positions; the thresholds are EN 17037's; the defaults (1.2 m seated eye height,
1-3 m from the facade, +-60 degrees) are torsal's choices within those sources.

Examples
--------
>>> import numpy as np, trimesh
>>> from torsal.geometry.surfaces import flat_facade
>>> v, f = flat_facade()
>>> res = view_out(trimesh.Trimesh(), (v, f))     # no fins: every sight line is clear
>>> res.share, res.levels
(1.0, {'minimum': 1.0, 'medium': 1.0, 'high': 1.0})
>>> len(res.eyes.points)     # 12 m x 6 m: 12 columns, 2 storeys, 3 distances
72
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from .devices.frame import SurfaceFrame, surface_frame
from .shading import _as_mesh, _scene, rays_blocked

__all__ = ["ViewField", "EyePoints", "SightLines", "ViewOutResult", "eye_points", "sight_lines",
           "view_out", "EN17037_SIGHT_ANGLES"]

#: EN 17037 horizontal sight angle thresholds (degrees): minimum, medium, high
EN17037_SIGHT_ANGLES = {"minimum": 14.0, "medium": 28.0, "high": 54.0}


@dataclass(frozen=True)
class ViewField:
    """Where occupants sit and where they look (lengths in model units; the defaults are
    metres, see :meth:`in_units`)."""

    eye_height: float = 1.2
    storey_height: float = 3.0
    distances: tuple[float, ...] = (1.0, 2.0, 3.0)
    grid: float = 1.0
    azimuth: float = 60.0
    elevation: tuple[float, float] = (-30.0, 30.0)
    step: float = 5.0

    def __post_init__(self):
        for name in ("eye_height", "storey_height", "grid", "step"):
            x = getattr(self, name)
            if not (np.isfinite(x) and x > 0):
                raise ValueError(f"view {name} must be positive, got {x}")
        if not self.distances or not all(np.isfinite(d) and d > 0 for d in self.distances):
            raise ValueError(f"view distances must be positive, got {list(self.distances)}")
        if not 0 < self.azimuth <= 90:
            raise ValueError(f"view azimuth (half width) must be in (0, 90] degrees, got {self.azimuth}")
        lo, hi = self.elevation
        if not -90 <= lo < hi <= 90:
            raise ValueError(f"view elevation must be [low, high] within [-90, 90] degrees, got "
                             f"{list(self.elevation)}")

    def in_units(self, metres_per_unit: float) -> "ViewField":
        """The same field with its lengths (given in metres) in model units."""
        k = 1.0 / float(metres_per_unit)
        return ViewField(self.eye_height * k, self.storey_height * k,
                         tuple(d * k for d in self.distances), self.grid * k, self.azimuth,
                         self.elevation, self.step)


@dataclass(frozen=True)
class EyePoints:
    """Occupant eye points behind A.

    Attributes
    ----------
    points : (p, 3) float
    distance : (p,) float
        How far behind A each one is (model units).
    frame : SurfaceFrame
        A's orientation; ``frame.axis`` is the outward view axis.
    """

    points: np.ndarray
    distance: np.ndarray
    frame: SurfaceFrame


@dataclass(frozen=True)
class SightLines:
    """The field of sight lines: unit ``directions`` (m, 3), solid-angle ``weights`` (m,),
    ``azimuth`` and ``elevation`` (m,) of each cell centre (degrees); ``level`` (h, 3) are
    the eye-level directions (elevation 0) of the horizontal sight angle, one per ``step``."""

    directions: np.ndarray
    weights: np.ndarray
    azimuth: np.ndarray
    elevation: np.ndarray
    level: np.ndarray


@dataclass(frozen=True)
class ViewOutResult:
    """Outcome of :func:`view_out`.

    Attributes
    ----------
    share : float or None
        Mean over the eye points of the weighted share of sight lines through A that pass
        the fins; None when no sight line passes through A.
    per_point : (p,) float
        That share per eye point (NaN for an eye point that sees nothing through A).
    sight_angle_deg : (p,) float
        Clear horizontal sight angle per eye point (degrees).
    levels : dict
        Share of the eye points (with a view through A) whose clear horizontal sight angle
        reaches each of :data:`EN17037_SIGHT_ANGLES`.
    eyes : EyePoints
    lines : SightLines
    through, blocked : (p, m) bool
        Sight line passes A; it is blocked by a fin.
    """

    share: float | None
    per_point: np.ndarray
    sight_angle_deg: np.ndarray
    levels: dict
    eyes: EyePoints
    lines: SightLines
    through: np.ndarray
    blocked: np.ndarray

    def summary(self) -> dict:
        """JSON-ready numbers (no NaN): ``share``, ``eye_points``, ``sight_angle_median_deg``
        and ``en17037`` (share of eye points at each level)."""
        seen = np.isfinite(self.per_point)
        return {"share": self.share, "eye_points": int(len(self.per_point)),
                "eye_points_with_view": int(seen.sum()),
                "sight_angle_median_deg": float(np.median(self.sight_angle_deg[seen]))
                if seen.any() else None,
                "en17037": dict(self.levels)}


def _grid(lo: float, hi: float, step: float) -> np.ndarray:
    """Points every ``step`` from half a step inside ``lo``, centred on [lo, hi] (the middle
    when the range is shorter than a step)."""
    n = int(np.floor((hi - lo) / step + 1e-9))
    if n < 1:
        return np.array([(lo + hi) / 2])
    return (lo + hi) / 2 + (np.arange(n) - (n - 1) / 2) * step


def eye_points(surface_vertices, surface_faces, field: ViewField = ViewField(), *,
               up=(0.0, 0.0, 1.0)) -> EyePoints:
    """The occupant eye points behind A (see the module's description).

    Parameters
    ----------
    surface_vertices : (n, 3) float
    surface_faces : (F, 3) int
        Normals outside.
    field : ViewField
        In model units.
    up : (3,) float

    Returns
    -------
    EyePoints
    """
    v = np.asarray(surface_vertices, float)
    f = np.asarray(surface_faces, np.int64)
    frame = surface_frame(v, f, up=up)
    a, u, w = frame.axis, frame.u, frame.w
    x, y = v @ u, v @ w
    xs = _grid(x.min(), x.max(), field.grid)
    if frame.is_facade:   # storeys: eye height above A's foot, every storey while inside A
        ys = y.min() + field.eye_height + field.storey_height * np.arange(
            int(np.floor((y.max() - y.min() - field.eye_height) / field.storey_height)) + 1)
        ys = ys[ys <= y.max()] if (y.min() + field.eye_height <= y.max()) else np.array(
            [(y.min() + y.max()) / 2])
    else:
        ys = _grid(y.min(), y.max(), field.grid)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    reach = 2.0 * float(np.ptp(v, axis=0).max()) + max(field.distances) + 1.0
    base = X.reshape(-1, 1) * u + Y.reshape(-1, 1) * w + (v.mean(axis=0) @ a + reach) * a
    # the point of A on each grid line along the view axis, seen from outside
    t, _ = _scene(_as_mesh((v, f))).first_hit(base, np.broadcast_to(-a, base.shape))
    hit = np.isfinite(t)
    on_a = base[hit] - t[hit, None] * a
    d = np.asarray(field.distances, float)
    points = (on_a[:, None, :] - d[None, :, None] * a).reshape(-1, 3)
    return EyePoints(points, np.tile(d, len(on_a)), frame)


def sight_lines(frame: SurfaceFrame, field: ViewField = ViewField()) -> SightLines:
    """The field of sight lines about ``frame.axis`` (see the module's description)."""
    s = float(field.step)
    az = _grid(-field.azimuth, field.azimuth, s)
    el = _grid(field.elevation[0], field.elevation[1], s)
    AZ, EL = np.meshgrid(az, el, indexing="ij")
    AZ, EL = AZ.ravel(), EL.ravel()

    def direction(azimuth, elevation):
        ra, re = np.radians(azimuth)[:, None], np.radians(elevation)[:, None]
        return np.cos(re) * (np.cos(ra) * frame.axis + np.sin(ra) * frame.u) + np.sin(re) * frame.w

    return SightLines(direction(AZ, EL), np.cos(np.radians(EL)), AZ, EL,
                      direction(az, np.zeros_like(az)))


def view_out(fins: trimesh.Trimesh, surface, field: ViewField = ViewField(), *,
             up=(0.0, 0.0, 1.0)) -> ViewOutResult:
    """The occupants' view out past the fins (see the module's description).

    Parameters
    ----------
    fins : trimesh.Trimesh
        Thin-surface fins (an empty mesh: no fins).
    surface : trimesh.Trimesh or (vertices, faces)
        Design surface A, normals outside.
    field : ViewField
        Eye points and sight lines, in model units.
    up : (3,) float

    Returns
    -------
    ViewOutResult
    """
    mesh = _as_mesh(surface)
    eyes = eye_points(mesh.vertices, mesh.faces, field, up=up)
    lines = sight_lines(eyes.frame, field)
    a_scene = _scene(mesh)
    p, m, h = len(eyes.points), len(lines.directions), len(lines.level)
    dirs = np.concatenate([lines.directions, lines.level])
    o = np.repeat(eyes.points, m + h, axis=0)
    d = np.tile(dirs, (len(eyes.points), 1))
    t_a, _ = a_scene.first_hit(o, d)
    through = np.isfinite(t_a).reshape(p, m + h)
    blocked = rays_blocked(fins, eyes.points, dirs) if p else np.zeros((0, m + h), bool)
    clear = through & ~blocked
    wt = lines.weights
    seen = (through[:, :m] * wt).sum(axis=1)
    per_point = np.full(p, np.nan)
    ok = seen > 0
    per_point[ok] = (clear[ok, :m] * wt).sum(axis=1) / seen[ok]
    angle = clear[:, m:].sum(axis=1) * float(field.step)
    share = float(per_point[ok].mean()) if ok.any() else None
    levels = {name: float((angle[ok] >= deg).mean()) if ok.any() else None
              for name, deg in EN17037_SIGHT_ANGLES.items()}
    return ViewOutResult(share, per_point, angle.astype(float), levels, eyes, lines,
                         through[:, :m], blocked[:, :m])
