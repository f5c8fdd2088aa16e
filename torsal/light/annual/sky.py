"""The sky of a weather year, hour by hour: sky patches, the ground and the suns.

The sky is Radiance's ``gendaymtx`` of the year (the Perez all-weather sky model fitted to
each hour's DNI and DHI, solar radiance ``-O1``, grey ``-c 1 1 1``): the radiance of every
sky patch and of the ground for every hour. Patches follow the Tregenza subdivision (145
patches: rows of 30, 30, 24, 24, 18, 12 and 6 patches 12 degrees apart, and the zenith
patch) or Reinhart's subdivision of it (each Tregenza patch split ``MF x MF``, the zenith
kept whole: ``144 MF^2 + 1`` patches), numbered from the horizon row up, each row from north
towards east, as ``reinhartb.cal`` bins them. Row 0 of a matrix is the ground: radiance
``ground_reflectance * GHI / pi``, the same in every direction below the horizon.

The suns are kept apart from the sky: ``gendaymtx -s`` gives the sky without its sun, and
each hour's sun is a source of its own (direction by pvlib's SPA at mid-hour, as
:mod:`torsal.light.sun`, irradiance the hour's DNI): a shadow edge as sharp as the sun's.
:attr:`SkyYear.sun_patches` (the whole sky minus the sky without the sun) is the sun spread
over the patches near it, which only the reflections off the fins use (the five-phase
method: see :mod:`torsal.light.annual.irradiance`).

Seasons split the year's hours in two (:class:`SeasonRule`): the cooling season, whose solar
gains a building would rather not have, and the heating season, whose gains it keeps.
"""
from __future__ import annotations

import tempfile
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

import numpy as np

from torsal.light.annual.radiance import Program, Radiance
from torsal.light.annual.weather import Weather, wea_text
from torsal.light.sun import sun_directions

__all__ = ["SkySubdivision", "SkyQuantity", "SkyYear", "sky_year", "SeasonRule", "Seasons", "seasons",
           "GROUND_REFLECTANCE", "BALANCE_TEMPERATURE_C", "COOLING_MONTHS_NORTH"]

#: the ground's solar reflectance (albedo): gendaymtx's and pvlib's default, grass or concrete
GROUND_REFLECTANCE = 0.2
#: degC; a day whose mean outdoor temperature is at or below this is a heating day (Eurostat's
#: heating-degree-day threshold: heating degree days count 18 - T_mean on days with T_mean <= 15)
BALANCE_TEMPERATURE_C = 15.0
#: the cooling-season months north of the equator (May to September); south of it the same
#: months six months later (November to March)
COOLING_MONTHS_NORTH = (5, 6, 7, 8, 9)


class SkySubdivision(str, Enum):
    """How finely the sky is divided into patches (``reinhartb.cal``'s ``MF``)."""

    TREGENZA = "tregenza"      # MF 1: 145 patches of about 12 x 12 degrees
    REINHART = "reinhart"      # MF 2: 577 patches of about 6 x 6 degrees
    REINHART4 = "reinhart4"    # MF 4: 2305 patches of about 3 x 3 degrees

    @property
    def mf(self) -> int:
        """Reinhart's subdivision factor."""
        return {"tregenza": 1, "reinhart": 2, "reinhart4": 4}[self.value]

    @property
    def patches(self) -> int:
        """Sky patches (the ground not counted).

        >>> SkySubdivision.TREGENZA.patches, SkySubdivision.REINHART.patches
        (145, 577)
        """
        return 144 * self.mf ** 2 + 1

    def directions(self) -> np.ndarray:
        """(P, 3) unit vectors to the patch centres in ``reinhartb.cal``'s order, model frame
        (z up; the bins are fixed in the model, +y their north: ``gendaymtx -r`` turns the
        sky into them by the design's north angle).

        >>> d = SkySubdivision.TREGENZA.directions()
        >>> d.shape, np.round(d[0], 3).tolist(), np.round(d[-1], 3).tolist()
        ((145, 3), [0.0, 0.995, 0.105], [0.0, 0.0, 1.0])
        """
        mf = self.mf
        per_row = np.repeat([30, 30, 24, 24, 18, 12, 6], mf) * mf          # patches per row
        alpha = 90.0 / (7 * mf + 0.5)                                       # row height, deg
        row = np.repeat(np.arange(len(per_row)), per_row)
        first = np.r_[0, np.cumsum(per_row)[:-1]]
        azimuth = np.radians(np.r_[(np.arange(len(row)) - first[row]) * 360.0 / per_row[row], 0])
        alt = np.radians(np.r_[(row + 0.5) * alpha, 90.0])                 # the zenith patch last
        return np.c_[np.cos(alt) * np.sin(azimuth), np.cos(alt) * np.cos(azimuth), np.sin(alt)]

    def solid_angles(self) -> np.ndarray:
        """(P,) sr of each patch, in :meth:`directions`' order; they add up to 2 pi.

        >>> w = SkySubdivision.REINHART.solid_angles()
        >>> w.shape, round(float(w.sum() / np.pi), 12)
        ((577,), 2.0)
        """
        mf = self.mf
        per_row = np.repeat([30, 30, 24, 24, 18, 12, 6], mf) * mf
        alpha = np.radians(90.0 / (7 * mf + 0.5))
        rows = np.arange(len(per_row))
        band = 2 * np.pi * (np.sin((rows + 1) * alpha) - np.sin(rows * alpha)) / per_row
        return np.r_[np.repeat(band, per_row), 2 * np.pi * (1 - np.sin(len(per_row) * alpha))]


class SkyQuantity(str, Enum):
    """What a sky matrix holds (``gendaymtx -O``)."""

    SOLAR = "solar"         # solar radiance, W/(m^2 sr): irradiance in W/m^2
    VISIBLE = "visible"     # Radiance's visible radiance: illuminance = 179 lm/W x irradiance


@dataclass(frozen=True)
class SkyYear:
    """A weather year as Radiance sees it.

    Attributes
    ----------
    weather : Weather
        The year, T hours.
    subdivision : SkySubdivision
        P = ``subdivision.patches`` sky patches.
    ground_reflectance : float
    north_angle : float
        Degrees; true north turned counter-clockwise from +y (as :mod:`torsal.light.sun`).
    sky : (P + 1, T) float
        Radiance of the ground (row 0) and of each patch without the sun, W/(m^2 sr).
    sun_patches : (P + 1, T) float
        The sun spread over the patches near it, W/(m^2 sr) (row 0 zero).
    sun_vectors : (J, 3) float
        The suns: unit vectors site -> sun, model frame, one per hour with the sun above the
        horizon and DNI > 0.
    sun_hours : (J,) int
        Each sun's hour (index into the weather's T hours).
    sun_dni : (J,) float
        Each sun's direct normal irradiance: W/m^2 for a solar sky (the weather's DNI), in
        Radiance's visible units for a visible one (the sun of ``gendaymtx -O0``: times 179
        lm/W, the direct normal illuminance in lux).
    quantity : SkyQuantity, default solar
    """

    weather: Weather
    subdivision: SkySubdivision
    ground_reflectance: float
    north_angle: float
    sky: np.ndarray
    sun_patches: np.ndarray
    sun_vectors: np.ndarray
    sun_hours: np.ndarray
    sun_dni: np.ndarray
    quantity: SkyQuantity = SkyQuantity.SOLAR


def _read_matrix(raw: bytes, rows: int, cols: int) -> np.ndarray:
    """The first channel of a float Radiance matrix (gendaymtx ``-of``): (rows, cols)."""
    start = raw.index(b"\n\n") + 2
    m = np.frombuffer(raw[start:], np.float32)
    if m.size != rows * cols * 3:
        raise ValueError(f"gendaymtx gave {m.size} values, expected {rows} x {cols} x 3")
    return m.reshape(rows, cols, 3)[:, :, 0].astype(float)


def sky_year(weather: Weather, *, subdivision: SkySubdivision = SkySubdivision.TREGENZA,
             ground_reflectance: float = GROUND_REFLECTANCE, north_angle: float = 0.0,
             quantity: SkyQuantity = SkyQuantity.SOLAR,
             radiance: Radiance | None = None) -> SkyYear:
    """The sky matrices (``gendaymtx``) and the suns of a weather year.

    Parameters
    ----------
    weather : Weather
    subdivision : SkySubdivision, default Tregenza
    ground_reflectance : float, default :data:`GROUND_REFLECTANCE`
        In [0, 1].
    north_angle : float, default 0
        Degrees (``gendaymtx -r``; the suns by :func:`torsal.light.sun.sun_directions`).
    quantity : SkyQuantity, default solar
        Solar radiance (``-O1``) or visible (``-O0``, for daylight: the Perez luminous
        efficacy of each hour's sky and sun).
    radiance : Radiance, optional
        Default :meth:`Radiance.bundled`.

    Returns
    -------
    SkyYear
    """
    if not 0.0 <= ground_reflectance <= 1.0:
        raise ValueError(f"ground_reflectance must be in [0, 1], got {ground_reflectance}")
    radiance = radiance or Radiance.bundled()
    sub = SkySubdivision(subdivision)
    rows, cols = sub.patches + 1, len(weather)
    g = f"{ground_reflectance:g}"
    quantity = SkyQuantity(quantity)
    out = "-O1" if quantity is SkyQuantity.SOLAR else "-O0"
    args = [out, "-m", sub.mf, "-c", 1, 1, 1, "-g", g, g, g, "-r", f"{north_angle:g}", "-of"]
    with tempfile.TemporaryDirectory(prefix="torsal-sky-") as tmp:
        (Path(tmp) / "year.wea").write_text(wea_text(weather))
        sky = _read_matrix(radiance.run(Program.GENDAYMTX, ["-s", *args, "year.wea"], cwd=tmp),
                           rows, cols)
        whole = _read_matrix(radiance.run(Program.GENDAYMTX, [*args, "year.wea"], cwd=tmp),
                             rows, cols)
    sun_patches = np.clip(whole - sky, 0.0, None)
    sun_patches[0] = 0.0
    sun = sun_directions(weather.latitude, weather.longitude, weather.times,
                         elevation=weather.elevation, north_angle=north_angle)
    # the visible sun: gendaymtx's, spread over its patches (their radiance times solid angle
    # adds up to the direct normal value, as the solar one adds up to the weather's DNI)
    dni = (weather.dni if quantity is SkyQuantity.SOLAR else
           sub.solid_angles() @ sun_patches[1:])
    keep = np.flatnonzero(sun.above_horizon & (weather.dni > 0) & (dni > 0))
    return SkyYear(weather, sub, float(ground_reflectance), float(north_angle), sky,
                   sun_patches, sun.vectors[keep], keep, dni[keep], quantity)


# ------------------------------------------------------------------ seasons
class SeasonRule(str, Enum):
    """Which hours are the cooling season.

    - ``months``: May to September north of the equator, November to March south of it
      (:data:`COOLING_MONTHS_NORTH`);
    - ``temperature``: the days whose mean outdoor temperature is above
      :data:`BALANCE_TEMPERATURE_C` (needs a weather file's temperatures);
    - ``auto``: ``temperature`` where the weather has temperatures (an EPW), else ``months``.
    """

    AUTO = "auto"
    MONTHS = "months"
    TEMPERATURE = "temperature"


@dataclass(frozen=True)
class Seasons:
    """The year's hours by month and season.

    Attributes
    ----------
    rule : SeasonRule
        The rule applied (``months`` or ``temperature``, never ``auto``).
    month : (T,) int
        1..12, of the hour's middle.
    cooling : (T,) bool
        The hour is in the cooling season (else the heating season).
    description : str
        The rule in words, for the report.
    """

    rule: SeasonRule
    month: np.ndarray
    cooling: np.ndarray
    description: str

    def group(self) -> np.ndarray:
        """(T,) int: each hour's group ``2 (month - 1) + cooling`` in [0, 24), month-major: a
        (..., 24) total over the groups reshapes to (..., 12, 2), season 0 heating, 1 cooling."""
        return 2 * (self.month - 1) + self.cooling.astype(int)


def seasons(weather: Weather, rule: SeasonRule = SeasonRule.AUTO, *,
            balance_temperature: float = BALANCE_TEMPERATURE_C) -> Seasons:
    """Split the weather's hours into the cooling and the heating season.

    Parameters
    ----------
    weather : Weather
    rule : SeasonRule, default auto
    balance_temperature : float, default :data:`BALANCE_TEMPERATURE_C`
        degC; the ``temperature`` rule's threshold on the day's mean.

    Returns
    -------
    Seasons
    """
    rule = SeasonRule(rule)
    if rule is SeasonRule.AUTO:
        rule = SeasonRule.TEMPERATURE if weather.temp_air is not None else SeasonRule.MONTHS
    month = weather.times.month.to_numpy()
    if rule is SeasonRule.MONTHS:
        north = weather.latitude >= 0.0
        cool = np.array(COOLING_MONTHS_NORTH)
        if not north:                                  # six months later: 11, 12, 1, 2, 3
            cool = (cool + 5) % 12 + 1
        names = "May to September" if north else "November to March"
        return Seasons(rule, month, np.isin(month, cool),
                       f"months: cooling season {names} "
                       f"({'northern' if north else 'southern'} hemisphere), heating the rest")
    if weather.temp_air is None:
        raise ValueError("the temperature season rule needs a weather file's temperatures; the "
                         "clear-sky year has none (use the months rule)")
    _, day = np.unique(weather.times.normalize(), return_inverse=True)   # (T,) day index
    daily_mean = np.bincount(day, weather.temp_air) / np.bincount(day)
    cooling = daily_mean[day] > balance_temperature
    return Seasons(rule, month, cooling,
                   f"temperature: cooling season the days whose mean outdoor temperature is "
                   f"above {balance_temperature:g} degC, heating the others")
