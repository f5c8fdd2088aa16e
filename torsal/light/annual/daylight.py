"""Daylight in a room behind the glazing: sDA and ASE as IES LM-83-12 defines them.

A :class:`Room` is a box behind a window wall, glazed across its width from a sill to a head
height. Its work plane (0.76 m above the floor, points every 0.6 m at most, LM-83's) gets, every
occupied hour (8:00 to 18:00 local standard time, LM-83's), the illuminance of the visible sky
(``gendaymtx -O0``: the Perez all-weather model's luminance with its luminous efficacy), its
sun and what the room and the fins reflect, by the machinery of
:mod:`torsal.light.annual.irradiance` with the room in the scene (``rcontrib``, interior
reflections ``ambient_bounces - 1``; illuminance = 179 lm/W times Radiance's visible
irradiance).

- **sDA 300 / 50 %** (spatial daylight autonomy): the share of the work-plane points with at
  least 300 lx for at least half of the occupied hours, **with operable blinds as LM-83
  operates them** (IES LM-83-12 section 2.2.6, "Blinds/Shades Operation"): the blinds of a
  space are closed in every occupied hour in which more than 2 % of its analysis points receive
  1000 lx or more of direct sunlight (the sun alone, through the glazing, no interreflections:
  the direct-sun illuminance ASE counts), and open in the others; sDA is then counted from the
  hourly illuminance with the blinds in that state (:func:`blinds_closed`,
  :class:`Blinds`). A closed blind is a neutral shade behind the glazing that passes a fraction
  :data:`SHADE_TRANSMITTANCE` of all the light the window lets in (sky, ground, sun and their
  reflections; LM-83-12 section 2.2.7 asks for the actual blinds' properties and leaves the
  choice to the modeller; 5 % is the closed-shade transmittance that Ladybug Tools'
  honeybee-radiance-postprocess uses by default for LEED v4.1 Daylight Option 1, which follows
  LM-83). One room is one space with one window group. The room without blinds (the room as
  built, the fins its only shading) is reported beside it: :attr:`Daylight.sda_unshaded`.
  Checked against rooms computed by hand in ``tests/light/test_annual_daylight.py``.
- **ASE 1000 / 250** (annual sunlight exposure): the share of the points that get at least
  1000 lx of direct sun (no reflections) for more than 250 occupied hours a year.

Glazing: Radiance's ``glass`` of the given normal-incidence visible transmittance (its
transmission falls with the angle of incidence as a single pane's, Fresnel), or an open
window (``transmittance=None``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from torsal.light.annual.irradiance import RadianceSettings, Source, _sensors, fins_text, hourly_sums
from torsal.light.annual.radiance import Radiance, polygons_text
from torsal.light.annual.sky import SkyQuantity, SkyYear

__all__ = ["Room", "Daylight", "daylight", "LUMINOUS_EFFICACY", "SDA_LUX", "SDA_SHARE",
           "ASE_LUX", "ASE_HOURS", "OCCUPIED_HOURS", "WORK_PLANE_M", "GRID_M",
           "ROOM_REFLECTANCE", "GLAZING_TRANSMITTANCE", "ROOM_BOUNCES", "ROOM_DIVISIONS",
           "Blinds", "blinds_closed", "SHADE_TRANSMITTANCE", "BLINDS_LUX", "BLINDS_SHARE"]

#: lm/W: Radiance's white-light efficacy (illuminance = 179 x visible irradiance)
LUMINOUS_EFFICACY = 179.0
#: sDA's illuminance (lx) and share of the occupied hours
SDA_LUX, SDA_SHARE = 300.0, 0.5
#: ASE's direct-sun illuminance (lx) and hours (more than this many)
ASE_LUX, ASE_HOURS = 1000.0, 250
#: LM-83's occupied hours: from 8:00 to 18:00 local standard time, every day
OCCUPIED_HOURS = (8.0, 18.0)
#: LM-83's work plane above the floor (30 in) and largest point spacing (2 ft), metres
WORK_PLANE_M, GRID_M = 0.76, 0.6
#: LM-83's interior reflectances: floor, walls, ceiling
ROOM_REFLECTANCE = (0.2, 0.5, 0.7)
#: visible transmittance at normal incidence of the glazing (double glazing, low-e)
GLAZING_TRANSMITTANCE = 0.6
#: rcontrib -ab and -ad in a room (LM-83's Radiance parameters: -ab 6 -ad 1000)
ROOM_BOUNCES, ROOM_DIVISIONS = 6, 1024
#: LM-83-12 2.2.6: the blinds close in an hour where more than BLINDS_SHARE of the points get
#: BLINDS_LUX (lx) or more of direct sunlight
BLINDS_LUX, BLINDS_SHARE = 1000.0, 0.02
#: the share of the light through the window that closed blinds pass (see the module docstring)
SHADE_TRANSMITTANCE = 0.05


@dataclass(frozen=True)
class Blinds:
    """Operable blinds behind a room's window, operated as IES LM-83-12 2.2.6 states.

    Attributes
    ----------
    transmittance : float, default :data:`SHADE_TRANSMITTANCE`
        The share of the light through the window that the closed blinds pass, in [0, 1).
    lux : float, default :data:`BLINDS_LUX`
        Direct-sun illuminance (lx) at which a point counts as sunlit.
    share : float, default :data:`BLINDS_SHARE`
        The blinds close when more than this share of the points is sunlit.

    Examples
    --------
    >>> Blinds().transmittance, Blinds().share
    (0.05, 0.02)
    """

    transmittance: float = SHADE_TRANSMITTANCE
    lux: float = BLINDS_LUX
    share: float = BLINDS_SHARE

    def __post_init__(self):
        if not 0.0 <= self.transmittance < 1.0:
            raise ValueError(f"blinds' transmittance must be in [0, 1), got {self.transmittance}")
        if not (self.lux > 0 and 0.0 <= self.share < 1.0):
            raise ValueError("blinds need lux > 0 and a share in [0, 1)")


def blinds_closed(direct_lux, blinds: Blinds = Blinds()) -> np.ndarray:
    """LM-83-12 2.2.6's schedule: the hours in which the blinds are closed.

    Parameters
    ----------
    direct_lux : (n, H) float
        Direct-sun illuminance (lx) at each of n points in each of H occupied hours.
    blinds : Blinds

    Returns
    -------
    (H,) bool
        True where more than ``blinds.share`` of the points get at least ``blinds.lux``.

    Examples
    --------
    >>> lux = np.zeros((50, 3)); lux[:1, 1] = lux[:2, 2] = 2000.0
    >>> blinds_closed(lux).tolist()          # 1 of 50 points is 2 %, not more: open
    [False, False, True]
    """
    d = np.asarray(direct_lux, float)
    return (d >= blinds.lux).sum(axis=0) > blinds.share * d.shape[0]


@dataclass(frozen=True)
class Room:
    """A box room behind a window wall, model units.

    Attributes
    ----------
    origin : (3,) float
        The floor corner at the inside of the window wall, at the start of ``along``.
    along : (3,) float
        Unit, horizontal: along the window wall.
    inward : (3,) float
        Unit, horizontal: into the room (the window wall's inward normal).
    width, depth, height : float
        Along the wall, into the room, floor to ceiling.
    sill, head : float
        The window's bottom and top above the floor; it spans the whole width.
    reflectance : (float, float, float)
        Floor, walls, ceiling (default :data:`ROOM_REFLECTANCE`).
    transmittance : float or None
        The glazing's visible transmittance at normal incidence; None: an open window.
    """

    origin: tuple
    along: tuple
    inward: tuple
    width: float
    depth: float
    height: float
    sill: float
    head: float
    reflectance: tuple = ROOM_REFLECTANCE
    transmittance: float | None = GLAZING_TRANSMITTANCE

    def __post_init__(self):
        a, i = np.asarray(self.along, float), np.asarray(self.inward, float)
        if abs(np.linalg.norm(a) - 1) > 1e-9 or abs(np.linalg.norm(i) - 1) > 1e-9 or \
                abs(a @ i) > 1e-9 or abs(a[2]) > 1e-9 or abs(i[2]) > 1e-9:
            raise ValueError("along and inward must be horizontal unit vectors at right angles")
        if not (min(self.width, self.depth, self.height) > 0 and
                0 <= self.sill < self.head <= self.height):
            raise ValueError("a room needs positive width, depth and height and "
                             "0 <= sill < head <= height")

    def _corner(self, u, v, w) -> np.ndarray:
        """Points at ``u`` along the wall, ``v`` into the room, ``w`` up, (..., 3)."""
        return (np.asarray(self.origin, float) + np.multiply.outer(u, self.along)
                + np.multiply.outer(v, self.inward) + np.multiply.outer(w, (0.0, 0.0, 1.0)))

    def _quads(self) -> dict[str, list]:
        """The room's surfaces as quads (u, v, w corner lists) by material."""
        W, D, H = self.width, self.depth, self.height
        return {
            "room_floor": [[(0, 0, 0), (W, 0, 0), (W, D, 0), (0, D, 0)]],
            "room_ceiling": [[(0, 0, H), (W, 0, H), (W, D, H), (0, D, H)]],
            "room_wall": [[(0, D, 0), (W, D, 0), (W, D, H), (0, D, H)],
                          [(0, 0, 0), (0, D, 0), (0, D, H), (0, 0, H)],
                          [(W, 0, 0), (W, D, 0), (W, D, H), (W, 0, H)],
                          [(0, 0, 0), (W, 0, 0), (W, 0, self.sill), (0, 0, self.sill)],
                          [(0, 0, self.head), (W, 0, self.head), (W, 0, H), (0, 0, H)]],
            "room_glass": [[(0, 0, self.sill), (W, 0, self.sill), (W, 0, self.head),
                            (0, 0, self.head)]]}

    def scene(self) -> str:
        """The room as Radiance text: ``plastic`` floor, walls and ceiling, ``glass`` window
        (none for an open one); degenerate quads (a sill at the floor) left out."""
        floor, wall, ceiling = (f"{r:.6g}" for r in self.reflectance)
        text = "".join(f"void plastic {name} 0 0 5 {r} {r} {r} 0 0\n" for name, r in
                       (("room_floor", floor), ("room_wall", wall), ("room_ceiling", ceiling)))
        if self.transmittance is not None:
            t = float(self.transmittance)
            tn = (np.sqrt(0.8402528435 + 0.0072522239 * t * t) - 0.9166530661) / 0.0036261119 / t
            text += f"void glass room_glass 0 0 3 {tn:.6g} {tn:.6g} {tn:.6g}\n"
        for name, quads in self._quads().items():
            if name == "room_glass" and self.transmittance is None:
                continue
            for q in quads:
                c = self._corner(*np.asarray(q, float).T)
                if np.linalg.norm(np.cross(c[1] - c[0], c[3] - c[0])) > 0:
                    text += polygons_text(c, [[0, 1, 2], [0, 2, 3]], name)
        return text

    def work_plane(self, *, spacing: float, height: float) -> np.ndarray:
        """(n, 3) cell centres of a grid at most ``spacing`` apart over the floor, ``height``
        above it (model units)."""
        nu, nv = (max(1, int(np.ceil(x / spacing - 1e-9))) for x in (self.width, self.depth))
        u = (np.arange(nu) + 0.5) * self.width / nu
        v = (np.arange(nv) + 0.5) * self.depth / nv
        uu, vv = np.meshgrid(u, v, indexing="ij")
        return self._corner(uu.ravel(), vv.ravel(), np.full(uu.size, height))


@dataclass(frozen=True)
class Daylight:
    """sDA and ASE of a room (:func:`daylight`).

    Attributes
    ----------
    points : (n, 3) float
        The work-plane points.
    occupied_hours : int
        The year's occupied hours H.
    hours_sda : (n,) int
        Occupied hours with at least :data:`SDA_LUX` at each point, the blinds operated as
        LM-83 states (:func:`blinds_closed`; without blinds the same as ``hours_sda_unshaded``).
    hours_ase : (n,) int
        Occupied hours with at least :data:`ASE_LUX` of direct sun at each point.
    hours_sda_unshaded : (n,) int
        Occupied hours with at least :data:`SDA_LUX` at each point, no blinds drawn.
    blinds : (H,) bool
        The occupied hours in which the blinds are closed (all False without blinds).
    shade_transmittance : float or None
        The closed blinds' :attr:`Blinds.transmittance`; None: no blinds.
    """

    points: np.ndarray
    occupied_hours: int
    hours_sda: np.ndarray
    hours_ase: np.ndarray
    hours_sda_unshaded: np.ndarray
    blinds: np.ndarray
    shade_transmittance: float | None = SHADE_TRANSMITTANCE

    @property
    def sda(self) -> float:
        """sDA 300/50% as LM-83 defines it, with its blinds: share of the points lit to 300 lx
        for half the occupied hours."""
        return float(np.mean(self.hours_sda >= SDA_SHARE * self.occupied_hours))

    @property
    def sda_unshaded(self) -> float:
        """sDA 300/50% with no blinds drawn (the room as built, its fins the only shading)."""
        return float(np.mean(self.hours_sda_unshaded >= SDA_SHARE * self.occupied_hours))

    @property
    def blinds_hours(self) -> int:
        """Occupied hours with the blinds closed."""
        return int(np.count_nonzero(self.blinds))

    @property
    def ase(self) -> float:
        """ASE 1000/250: share of the points with direct sun of 1000 lx over 250 hours."""
        return float(np.mean(self.hours_ase > ASE_HOURS))

    def as_dict(self) -> dict:
        """JSON-ready: ``sda`` (LM-83's, with blinds), ``sda_unshaded``, ``ase``,
        ``blinds_hours``, ``shade_transmittance``, ``points``, ``occupied_hours``."""
        return {"sda": self.sda, "sda_unshaded": self.sda_unshaded, "ase": self.ase,
                "blinds_hours": self.blinds_hours,
                "shade_transmittance": self.shade_transmittance,
                "points": int(len(self.points)), "occupied_hours": int(self.occupied_hours)}


def occupied(sky: SkyYear, hours=OCCUPIED_HOURS) -> np.ndarray:
    """(T,) bool: the weather's hours whose middle is within ``hours`` (local standard time)."""
    t = sky.weather.times
    mid = (t.hour + t.minute / 60.0).to_numpy(float)
    return (mid >= hours[0]) & (mid < hours[1])


def daylight(room: Room, sky: SkyYear, *, fins=None, settings: RadianceSettings | None = None,
             hours=OCCUPIED_HOURS, spacing: float = GRID_M, work_plane: float = WORK_PLANE_M,
             radiance: Radiance | None = None, blinds: Blinds | None = Blinds()) -> Daylight:
    """sDA (with LM-83's operable blinds, and without) and ASE of ``room`` behind ``fins``
    over the weather year.

    Parameters
    ----------
    room : Room
    sky : SkyYear
        A visible sky (``sky_year(..., quantity=SkyQuantity.VISIBLE)``).
    fins : trimesh.Trimesh, optional
        The shading outside the window.
    settings : RadianceSettings, optional
        Default: :data:`ROOM_BOUNCES` ambient bounces, :data:`ROOM_DIVISIONS` divisions.
    hours : (float, float), default :data:`OCCUPIED_HOURS`
        The occupied hours of each day, local standard time.
    spacing, work_plane : float
        The grid's largest spacing and its height above the floor, model units (LM-83's
        0.6 m and 0.76 m in metres).
    radiance : Radiance, optional
    blinds : Blinds or None, default ``Blinds()``
        The operable blinds LM-83's sDA draws; None: none (``sda`` is ``sda_unshaded``).

    Returns
    -------
    Daylight

    Examples
    --------
    >>> room = Room((0, 0, 0), (1, 0, 0), (0, 1, 0), 6.0, 9.0, 3.0, 0.9, 2.7)
    >>> d = daylight(room, sky_year(w, quantity=SkyQuantity.VISIBLE))     # doctest: +SKIP
    >>> d.sda, d.sda_unshaded, d.blinds_hours                             # doctest: +SKIP
    (0.55, 0.9, 1210)
    """
    if sky.quantity is not SkyQuantity.VISIBLE:
        raise ValueError("daylight needs a visible sky: sky_year(..., quantity=SkyQuantity.VISIBLE)")
    settings = settings or RadianceSettings(ROOM_BOUNCES, ROOM_DIVISIONS)
    points = room.work_plane(spacing=spacing, height=work_plane)
    _, _, sensors = _sensors(points, np.tile([0.0, 0.0, 1.0], (len(points), 1)), 0.0)
    mask = occupied(sky, hours)
    group = np.full(len(mask), -1)
    group[mask] = np.arange(mask.sum())
    scene = room.scene() + fins_text(fins, settings.fin_reflectance)
    lux = LUMINOUS_EFFICACY * hourly_sums(sensors, scene, sky, group, int(mask.sum()),
                                          bounces=int(settings.ambient_bounces),
                                          settings=settings, radiance=radiance or Radiance.bundled())
    direct, total = lux[:, :, list(Source).index(Source.SUN)], lux.sum(axis=2)
    unshaded = (total >= SDA_LUX).sum(axis=1)
    if blinds is None:
        return Daylight(points, int(mask.sum()), unshaded, (direct >= ASE_LUX).sum(axis=1),
                        unshaded, np.zeros(int(mask.sum()), bool), None)
    closed = blinds_closed(direct, blinds)
    # one window group: closed blinds scale everything the window lets in
    shaded = np.where(closed[None, :], blinds.transmittance * total, total)
    return Daylight(points, int(mask.sum()), (shaded >= SDA_LUX).sum(axis=1),
                    (direct >= ASE_LUX).sum(axis=1), unshaded, closed, blinds.transmittance)
