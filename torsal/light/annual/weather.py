"""The weather year an annual irradiance run is driven by: a weather file (EPW, TMY3 or TMY2),
or a clear-sky year.

Each row of a :class:`Weather` is one hour of a year, stamped at its middle in local standard
time (the convention the three formats share, as :func:`torsal.light.sun.read_weather` and
:func:`torsal.light.sun.epw_hours` read it): the hour's mean
direct normal (DNI), diffuse horizontal (DHI) and global horizontal (GHI) irradiance in W/m^2,
which over the hour is Wh/m^2.

Without a weather file the year is pvlib's clear sky: the Ineichen-Perez model
(``pvlib.location.Location.get_clearsky(model="ineichen")``) with the Linke turbidity of
pvlib's monthly climatology at the site (``pvlib.clearsky.lookup_linke_turbidity``, SoDa),
every hour cloudless. It is an upper bound of the sun a site gets, not a typical year, and a
run says so (:attr:`Weather.description`).

Examples
--------
>>> w = clear_sky_year(48.21, 16.37, timezone="Europe/Vienna", elevation=170.0)
>>> len(w), w.source.value, w.utc_offset_hours
(8760, 'clear sky', 1.0)
>>> print(wea_text(w).splitlines()[2])
longitude -16.370000
"""
from __future__ import annotations

import datetime as _dt
import warnings
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from torsal.light.sun import read_weather

if TYPE_CHECKING:           # pandas is imported where it is used (seconds, with pyarrow)
    import pandas as pd

__all__ = ["Weather", "WeatherSource", "epw_year", "weather_year", "clear_sky_year",
           "wea_text", "CLEAR_SKY_YEAR"]

#: the calendar year of a clear-sky year (not a leap year: 8760 hours, as an EPW file)
CLEAR_SKY_YEAR = 2023


class WeatherSource(str, Enum):
    """Where a weather year comes from."""

    EPW = "epw"
    TMY3 = "tmy3"
    TMY2 = "tmy2"
    CLEAR_SKY = "clear sky"


@dataclass(frozen=True)
class Weather:
    """An hourly weather year at a site.

    Attributes
    ----------
    latitude, longitude : float
        Degrees, north and east positive.
    elevation : float
        Metres above sea level.
    utc_offset_hours : float
        Local standard time minus UTC, hours (no daylight saving).
    times : pandas.DatetimeIndex
        (T,) the middle of each hour, timezone-aware (a fixed offset: local standard time).
    dni, dhi, ghi : (T,) float
        Direct normal, diffuse horizontal and global horizontal irradiance, W/m^2 (the
        hour's mean; Wh/m^2 over the hour).
    temp_air : (T,) float or None
        Dry-bulb temperature at the middle of the hour, degC; None for a clear-sky year.
    source : WeatherSource
    description : str
        What the year is, in words, for the report.
    place : str
        The weather file's station or city ("" for a clear-sky year).
    """

    latitude: float
    longitude: float
    elevation: float
    utc_offset_hours: float
    times: pd.DatetimeIndex
    dni: np.ndarray
    dhi: np.ndarray
    ghi: np.ndarray
    temp_air: np.ndarray | None
    source: WeatherSource
    description: str
    place: str = ""

    def __len__(self) -> int:
        return len(self.times)


def weather_year(path, *, format: str | None = None) -> Weather:
    """The hours of a weather file, EPW, TMY3 or TMY2 (:func:`torsal.light.sun.read_weather`:
    irradiance as the hour's mean, temperature at mid-hour, stamped at mid-hour).

    Parameters
    ----------
    path : str or Path
    format : {"epw", "tmy3", "tmy2"}, optional
        Default: told from the file.

    Returns
    -------
    Weather
        ``source`` the file's format; raises :class:`torsal.light.sun.WeatherFileError`
        (:class:`~torsal.light.sun.EPWError` for an EPW) for a file that is not usable.

    Examples
    --------
    >>> import os, pvlib
    >>> w = weather_year(os.path.join(os.path.dirname(pvlib.__file__), "data", "12839.tm2"))
    >>> w.source.value, w.place, len(w), round(float(w.temp_air.mean()), 1)
    ('tmy2', 'MIAMI, FL', 8760, 24.3)
    """
    import pandas as pd

    path = Path(path)
    h, meta = read_weather(path, format=format)
    source = WeatherSource(meta["format"])
    return Weather(float(meta["latitude"]), float(meta["longitude"]), float(meta["altitude"]),
                   float(meta["TZ"]), pd.DatetimeIndex(h.index),
                   *(h[c].to_numpy(float).clip(min=0.0) for c in ("dni", "dhi", "ghi")),
                   h["temp_air"].to_numpy(float), source,
                   f"{source.name} weather file {path.name}", meta.get("name", ""))


def epw_year(path) -> Weather:
    """The hours of an EPW file: :func:`weather_year` read as an EPW.

    Returns
    -------
    Weather
        ``source`` :attr:`WeatherSource.EPW`; raises :class:`torsal.light.sun.EPWError` for a
        file that is not a usable EPW.
    """
    return weather_year(path, format="epw")


def standard_utc_offset(timezone: str, year: int = CLEAR_SKY_YEAR) -> float:
    """The standard-time (winter) UTC offset of an IANA time zone, hours.

    The smaller of the offsets on 1 January and 1 July: daylight saving only ever adds.

    >>> standard_utc_offset("Europe/Vienna"), standard_utc_offset("Australia/Sydney")
    (1.0, 10.0)
    """
    import zoneinfo

    zone = zoneinfo.ZoneInfo(timezone)
    offsets = [_dt.datetime(year, m, 1, 12, tzinfo=zone).utcoffset() for m in (1, 7)]
    return min(o.total_seconds() for o in offsets) / 3600.0


def clear_sky_year(latitude: float, longitude: float, *, timezone: str | float,
                   elevation: float = 0.0, year: int = CLEAR_SKY_YEAR) -> Weather:
    """Every hour of a year under pvlib's Ineichen-Perez clear sky with the site's Linke
    turbidity (pvlib's monthly climatology).

    Parameters
    ----------
    latitude, longitude : float
        Degrees, north and east positive.
    timezone : str or float
        IANA name (its standard-time offset is used, :func:`standard_utc_offset`) or the UTC
        offset of local standard time in hours.
    elevation : float, default 0
        Metres above sea level.
    year : int, default :data:`CLEAR_SKY_YEAR`
        Calendar year of the 8760 hours (29 February left out of a leap year).

    Returns
    -------
    Weather
        ``source`` :attr:`WeatherSource.CLEAR_SKY`, ``temp_air`` None.
    """
    import pandas as pd
    import pvlib

    offset = standard_utc_offset(timezone, year) if isinstance(timezone, str) else float(timezone)
    tz = _dt.timezone(_dt.timedelta(hours=offset))
    starts = pd.date_range(pd.Timestamp(year=year, month=1, day=1, tz=tz),
                           pd.Timestamp(year=year + 1, month=1, day=1, tz=tz),
                           freq="1h", inclusive="left")
    starts = starts[~((starts.month == 2) & (starts.day == 29))]
    mid = starts + pd.Timedelta(minutes=30)
    site = pvlib.location.Location(latitude, longitude, tz=offset, altitude=elevation)
    with warnings.catch_warnings():      # pvlib 0.16 asks pandas for the deprecated dayofyear
        warnings.simplefilter("ignore", DeprecationWarning)
        cs = site.get_clearsky(mid, model="ineichen").fillna(0.0).clip(lower=0.0)
    return Weather(float(latitude), float(longitude), float(elevation), offset, mid,
                   *(cs[c].to_numpy(float) for c in ("dni", "dhi", "ghi")), None,
                   WeatherSource.CLEAR_SKY,
                   "clear-sky year: pvlib's Ineichen-Perez model with the site's Linke turbidity "
                   "(pvlib's monthly climatology), no clouds")


def wea_text(weather: Weather, *, place: str = "torsal") -> str:
    """The year as a Radiance ``.wea`` file (gendaymtx's input): longitude and time-zone
    meridian west positive, one line ``month day hour DNI DHI`` per hour at its middle
    (decimal local standard time), irradiance in W/m^2 (``weather_data_file_units 1``).

    Returns
    -------
    str
    """
    t = weather.times
    hour = t.hour + t.minute / 60.0 + t.second / 3600.0
    rows = np.c_[t.month, t.day, hour, weather.dni, weather.dhi]
    body = "\n".join(f"{int(m)} {int(d)} {h:.4f} {a:.2f} {b:.2f}" for m, d, h, a, b in rows)
    header = (f"place {place}\nlatitude {weather.latitude:.6f}\n"
              f"longitude {-weather.longitude:.6f}\n"
              f"time_zone {-15.0 * weather.utc_offset_hours:.2f}\n"
              f"site_elevation {weather.elevation:.1f}\nweather_data_file_units 1\n")
    return header + body + "\n"
