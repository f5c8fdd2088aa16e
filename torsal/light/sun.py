"""Where the sun is: sun directions from a site and times, or from a weather file.

Weather files: EPW (EnergyPlus), TMY3 (NREL, ``.csv``) and TMY2 (NREL, ``.tm2``), read by
:func:`read_weather` into one hourly frame (:func:`epw_hours`'s); all three stamp each hour at
its end and hold the irradiance received over the hour before it.

All solar positions come from pvlib's implementation of the NREL Solar Position
Algorithm (SPA, Reda & Andreas 2004), ``pvlib.solarposition.get_solarposition(...,
method="nrel_numpy")``: stated uncertainty +/-0.0003 degrees for years -2000..6000.
Directions use the *apparent* (refraction-corrected) zenith, i.e. where the sun is seen.

Model frame (default): x east, y north, z up. ``north_angle`` (degrees) rotates true north
counter-clockwise (seen from above, about +z) away from +y, as Ladybug's ``north`` input
does: with ``north_angle=90`` true north points to -x.

Units: degrees for angles, metres for elevations, W/m^2 for irradiance, degC for temperature.

Examples
--------
>>> import pandas as pd
>>> t = pd.date_range("2024-06-21 09:00", periods=4, freq="3h", tz="Europe/Vienna")
>>> sun = sun_directions(48.21, 16.37, t)
>>> sun.vectors.shape, bool(sun.above_horizon.all())
((4, 3), True)
>>> d, w = sun.light_directions()          # d = -sun vector, weights sum to 1
"""
from __future__ import annotations

import datetime as _dt
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from torsal.core.atomic import atomic_path
from torsal.core.errors import TorsalError
from torsal.core.inputs import read_input

if TYPE_CHECKING:           # pandas is imported where it is used (seconds, with pyarrow)
    import pandas as pd

__all__ = [
    "SunDirections",
    "sun_directions",
    "sun_path",
    "hot_hours",
    "read_epw",
    "read_weather",
    "epw_hours",
    "EPWError",
    "WeatherFileError",
    "WEATHER_FORMATS",
    "light_directions",
    "write_synthetic_epw",
]

_SPA_METHOD = "nrel_numpy"


@dataclass(frozen=True)
class SunDirections:
    """Sun directions at a site for a set of times.

    Attributes
    ----------
    vectors : (k, 3) float
        Unit vectors from the site towards the sun in the model frame. Never NaN (also
        computed for times when the sun is below the horizon; see ``above_horizon``).
    above_horizon : (k,) bool
        True where the apparent solar elevation is above 0 degrees.
    times : pandas.DatetimeIndex
        The timezone-aware times, length k.
    apparent_zenith : (k,) float
        Refraction-corrected zenith angle, degrees.
    azimuth : (k,) float
        Solar azimuth, degrees eastward from true north.
    weights : (k,) float
        Non-negative weights: 1 for plain times, direct normal irradiance (W/m^2) for
        :func:`hot_hours`.
    """

    vectors: np.ndarray
    above_horizon: np.ndarray
    times: pd.DatetimeIndex
    apparent_zenith: np.ndarray
    azimuth: np.ndarray
    weights: np.ndarray

    def __len__(self) -> int:
        return len(self.vectors)

    @property
    def elevation(self) -> np.ndarray:
        """Apparent solar elevation, (k,) degrees."""
        return 90.0 - self.apparent_zenith

    def select(self, mask) -> "SunDirections":
        """A subset by boolean mask or index array."""
        m = np.asarray(mask)
        return SunDirections(self.vectors[m], self.above_horizon[m], self.times[m],
                             self.apparent_zenith[m], self.azimuth[m], self.weights[m])

    def above(self) -> "SunDirections":
        """Only the times with the sun above the horizon."""
        return self.select(self.above_horizon)

    def light_directions(self, *, normalize: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """See :func:`light_directions`."""
        return light_directions(self, normalize=normalize)


def light_directions(sun, weights=None, *, normalize: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Directions of light propagation for the optimizer's ``perpendicular`` goal.

    The light travels from the sun to the site, so ``d = -sun_vector`` (paper, 4.3: the
    lines of the congruence are made orthogonal to ``d``). Times with the sun below the
    horizon are dropped.

    Parameters
    ----------
    sun : SunDirections or (k, 3) array
        Sun vectors (site -> sun). A plain array is taken as all above the horizon.
    weights : (k,) float, optional
        Overrides ``sun.weights`` (default 1 per direction for a plain array).
    normalize : bool, default True
        Scale the weights to sum to 1.

    Returns
    -------
    d : (m, 3) float
        Unit light directions (sun -> site).
    w : (m,) float
        Non-negative weights.
    """
    if isinstance(sun, SunDirections):
        v, keep = sun.vectors, sun.above_horizon
        w = sun.weights if weights is None else np.asarray(weights, float)
    else:
        v = _unit_vectors(sun, "sun")
        keep = np.ones(len(v), bool)
        w = np.ones(len(v)) if weights is None else np.asarray(weights, float)
    if w.shape != (len(v),):
        raise ValueError(f"weights must have shape ({len(v)},), got {w.shape}")
    if np.any(~np.isfinite(w)) or np.any(w < 0):
        raise ValueError("weights must be finite and non-negative")
    d, w = -v[keep], w[keep].astype(float)
    if normalize and len(w):
        total = w.sum()
        if total <= 0:
            raise ValueError("all weights are zero; nothing to normalize")
        w = w / total
    return d, w


def _unit_vectors(v, name: str) -> np.ndarray:
    v = np.atleast_2d(np.asarray(v, dtype=float))
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"{name} must be (k, 3) vectors, got shape {v.shape}")
    if not np.isfinite(v).all():
        bad = np.flatnonzero(~np.isfinite(v).all(axis=1))
        raise ValueError(f"{name} vectors {bad[:10].tolist()} are NaN or infinite")
    n = np.linalg.norm(v, axis=1)
    if np.any(n < 1e-12):
        bad = np.flatnonzero(n < 1e-12)
        raise ValueError(f"{name} vectors {bad[:10].tolist()} have zero length")
    return v / n[:, None]


def _as_aware_index(times) -> pd.DatetimeIndex:
    import pandas as pd

    if isinstance(times, (str, _dt.date)) and not isinstance(times, pd.DatetimeIndex):
        times = [times]
    elif isinstance(times, pd.Series):
        times = times.to_list()
    if not isinstance(times, pd.DatetimeIndex):
        times = list(times)
        if not times:
            raise ValueError("times is empty")
        stamps = [pd.Timestamp(t) for t in times]
        if any(s.tzinfo is None for s in stamps):
            raise ValueError(
                "times must be timezone-aware; localize them first, e.g. "
                "pd.DatetimeIndex(times).tz_localize('Europe/Vienna') or "
                "datetime(..., tzinfo=zoneinfo.ZoneInfo('Europe/Vienna'))"
            )
        try:  # one common timezone is kept as is, mixed ones go to UTC
            times = pd.DatetimeIndex(stamps)
        except (ValueError, TypeError):
            times = pd.DatetimeIndex([s.tz_convert("UTC") for s in stamps])
        if times.tz is None:  # pragma: no cover - pandas gave an object-like index
            times = pd.DatetimeIndex([s.tz_convert("UTC") for s in stamps])
    if times.tz is None:
        raise ValueError(
            "times must be timezone-aware; localize them first, e.g. "
            "times.tz_localize('Europe/Vienna') (local clock) or times.tz_localize('UTC')"
        )
    if len(times) == 0:
        raise ValueError("times is empty")
    return times


def _check_site(latitude: float, longitude: float) -> None:
    if not np.isfinite(latitude) or not -90.0 <= latitude <= 90.0:
        raise ValueError(f"latitude must be in [-90, 90] degrees (north positive), got {latitude}")
    if not np.isfinite(longitude) or not -180.0 <= longitude <= 180.0:
        raise ValueError(f"longitude must be in [-180, 180] degrees (east positive), got {longitude}")


def _model_vectors(zenith_deg, azimuth_deg, north_angle: float) -> np.ndarray:
    z, a = np.radians(zenith_deg), np.radians(azimuth_deg)
    # east-north-up: azimuth measured from north towards east
    v = np.c_[np.sin(z) * np.sin(a), np.sin(z) * np.cos(a), np.cos(z)]
    c, s = np.cos(np.radians(north_angle)), np.sin(np.radians(north_angle))
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])  # counter-clockwise about +z
    v = v @ rot.T
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def sun_directions(latitude: float, longitude: float, times, *, elevation: float = 0.0,
                   north_angle: float = 0.0, pressure: float | None = None,
                   temperature: float = 12.0, delta_t: float | None = None,
                   weights=None) -> SunDirections:
    """Unit vectors from the site towards the sun, in the model frame.

    Solar position by pvlib's NREL SPA (``method="nrel_numpy"``), refraction-corrected
    (apparent) zenith.

    Parameters
    ----------
    latitude, longitude : float
        Site, degrees; north and east positive.
    times : pandas.DatetimeIndex or sequence of datetime
        Timezone-aware times (any timezone). Naive times raise ``ValueError``.
    elevation : float, default 0
        Site altitude above sea level, metres.
    north_angle : float, default 0
        Counter-clockwise rotation (degrees, seen from above) of true north away from +y.
    pressure : float, optional
        Air pressure in Pa for the refraction correction; default from ``elevation``
        (``pvlib.atmosphere.alt2pres``).
    temperature : float, default 12
        Air temperature, degC, for the refraction correction.
    delta_t : float, optional
        TT - UT1 in seconds; default pvlib's estimate for the year.
    weights : (k,) float, optional
        Weights to carry along (default 1).

    Returns
    -------
    SunDirections
        ``vectors`` (k, 3), ``above_horizon`` (k,) bool, angles and weights.

    Examples
    --------
    >>> import pandas as pd
    >>> t = pd.DatetimeIndex(["2003-10-17 12:30:30"]).tz_localize("Etc/GMT+7")
    >>> s = sun_directions(39.742476, -105.1786, t, elevation=1830.14,
    ...                    pressure=82000, temperature=11, delta_t=67)
    >>> round(float(s.apparent_zenith[0]), 4), round(float(s.azimuth[0]), 4)
    (50.1116, 194.3402)
    """
    import pvlib

    _check_site(latitude, longitude)
    if not np.isfinite(north_angle):
        raise ValueError(f"north_angle must be finite, got {north_angle}")
    idx = _as_aware_index(times)
    kw = {} if delta_t is None else {"delta_t": float(delta_t)}
    pos = pvlib.solarposition.get_solarposition(
        idx, latitude, longitude, altitude=float(elevation), pressure=pressure,
        method=_SPA_METHOD, temperature=float(temperature), **kw)
    zen = pos["apparent_zenith"].to_numpy(float)
    azi = pos["azimuth"].to_numpy(float)
    if not (np.isfinite(zen).all() and np.isfinite(azi).all()):  # pragma: no cover - pvlib guard
        raise RuntimeError("pvlib returned NaN solar positions; check times and site")
    w = np.ones(len(idx)) if weights is None else np.asarray(weights, float).ravel()
    if w.shape != (len(idx),):
        raise ValueError(f"weights must have one value per time ({len(idx)}), got {w.shape}")
    return SunDirections(
        vectors=_model_vectors(zen, azi, north_angle),
        above_horizon=zen < 90.0,
        times=idx,
        apparent_zenith=zen,
        azimuth=azi,
        weights=w,
    )


def _hour_of_day(idx: pd.DatetimeIndex) -> np.ndarray:
    return (idx.hour + idx.minute / 60.0 + idx.second / 3600.0).to_numpy(float)


def sun_path(latitude: float, longitude: float, start, end, *, timezone: str,
             hours: tuple[float, float] = (0.0, 24.0), freq: str = "1h",
             months=None, above_horizon_only: bool = True, **kwargs) -> SunDirections:
    """Sun directions over a date range, within a daily window of local clock hours.

    Parameters
    ----------
    latitude, longitude : float
        Site, degrees.
    start, end : str or date
        First and last day (both included), e.g. ``"2024-06-01"``, ``"2024-08-31"``.
    timezone : str
        IANA name of the local clock, e.g. ``"Europe/Vienna"`` (daylight saving applies).
    hours : (float, float), default (0, 24)
        Daily window ``[h0, h1]`` of local clock hours, both ends included, e.g. ``(12, 16)``
        for early afternoon.
    freq : str, default "1h"
        Time step (pandas frequency string).
    months : iterable of int, optional
        Keep only these months (1..12).
    above_horizon_only : bool, default True
        Drop the times with the sun below the horizon.
    **kwargs
        Passed to :func:`sun_directions` (``elevation``, ``north_angle``, ...).

    Examples
    --------
    >>> s = sun_path(48.21, 16.37, "2024-07-01", "2024-07-07", timezone="Europe/Vienna",
    ...              hours=(12, 16))
    >>> len(s)
    35
    """
    import pandas as pd

    h0, h1 = map(float, hours)
    if not 0.0 <= h0 <= h1 <= 24.0:
        raise ValueError(f"hours must be a window 0 <= h0 <= h1 <= 24, got {hours}")
    first = pd.Timestamp(start).normalize()
    last = pd.Timestamp(end).normalize()
    if first.tzinfo is not None or last.tzinfo is not None:
        first, last = first.tz_localize(None), last.tz_localize(None)
    if last < first:
        raise ValueError(f"end ({end}) is before start ({start})")
    naive = pd.date_range(first, last + pd.Timedelta(days=1), freq=freq, inclusive="left")
    hod = _hour_of_day(naive)
    keep = (hod >= h0) & (hod <= h1)
    if months is not None:
        keep &= np.isin(naive.month, list(months))
    naive = naive[keep]
    if len(naive) == 0:
        raise ValueError("no times in the given dates, hours and months")
    idx = naive.tz_localize(timezone, ambiguous="NaT", nonexistent="NaT")
    idx = idx[~idx.isna()]
    sun = sun_directions(latitude, longitude, idx, **kwargs)
    return sun.above() if above_horizon_only else sun


def hot_hours(epw_path, min_temperature: float = 26.0, min_dni: float = 200.0, *,
              north_angle: float = 0.0, months=None, hours=None,
              coerce_year: int | None = None, weather=None) -> SunDirections:
    """Design sun directions from a weather file (EPW, TMY3 or TMY2): the hot, sunny hours.

    Every hour of the file is read as :func:`read_weather` does (the convention the three
    formats share, see :func:`epw_hours` and the README): the hour from ``(h-1):00`` to
    ``h:00`` local standard time, its direct normal irradiance the file's value for hour ``h``
    (an hourly total), its temperature the mean of the readings at its start and end (hours
    ``h-1`` and ``h``: the value at the middle of the hour, as EnergyPlus interpolates), the sun
    at the middle of the hour. Kept: the hours with that temperature ``>= min_temperature`` and
    DNI ``>= min_dni`` while the sun is above the horizon at mid-hour, each weighted by its DNI.
    The sun is placed at the file's latitude, longitude and elevation.

    Parameters
    ----------
    epw_path : str or Path
        EPW, TMY3 or TMY2 file (see :func:`write_synthetic_epw` for a generated one).
    min_temperature : float, default 26
        Dry-bulb threshold, degC.
    min_dni : float, default 200
        Direct normal irradiance threshold, W/m^2 (Wh/m^2 over the hour).
    north_angle : float, default 0
        See :func:`sun_directions`.
    months : iterable of int, optional
        Keep only these months (of the mid-hour time).
    hours : (float, float), optional
        Keep only hours whose middle is within this window of local standard-time hours.
    coerce_year : int, optional
        Passed to :func:`read_weather` (files mix years; one year gives a continuous index).
    weather : (pandas.DataFrame, dict), optional
        The file as :func:`read_weather` returned it, when the caller has read it already
        (``epw_path`` then only names it in messages).

    Returns
    -------
    SunDirections
        Above-horizon directions with ``weights`` = DNI in W/m^2, ``times`` at mid-hour.
    """
    path = Path(epw_path)
    h, meta = read_weather(path, coerce_year=coerce_year) if weather is None else weather
    mid = h.index
    temp = h["temp_air"].to_numpy(float)
    dni = h["dni"].to_numpy(float)
    keep = (temp >= min_temperature) & (dni >= min_dni) & (dni > 0)
    if months is not None:
        keep &= np.isin(mid.month, list(months))
    if hours is not None:
        hod = _hour_of_day(mid)
        keep &= (hod >= hours[0]) & (hod <= hours[1])
    if not keep.any():
        raise ValueError(
            f"no hour in {path.name} has temp_air >= {min_temperature} degC and dni >= "
            f"{min_dni} W/m^2; lower the thresholds")
    sun = sun_directions(float(meta["latitude"]), float(meta["longitude"]), mid[keep],
                         elevation=float(meta["altitude"]), north_angle=north_angle,
                         weights=dni[keep])
    return sun.above()


def epw_hours(data: pd.DataFrame) -> pd.DataFrame:
    """The hours of an EPW file as torsal reads them: one row per hourly interval.

    The EPW data dictionary (EnergyPlus, Auxiliary Programs, "Weather Converter"): the Hour
    field ``h`` (1..24) is the interval from ``(h-1):00`` to ``h:00`` local standard time;
    temperatures are *instantaneous* readings at ``h:00`` ("at the time indicated");
    irradiance fields are *totals* over the interval ("received during the 60 minutes
    preceding the time indicated", Wh/m^2, i.e. the hour's mean in W/m^2). pvlib's
    ``read_epw`` stamps each row with the interval *start* ``(h-1):00``; ladybug-core stamps
    temperatures with ``h:00`` and irradiance with ``(h-1):00``. Pairing one row's temperature
    with its irradiance (pvlib) takes the temperature at the end of the hour; pairing by
    ladybug's stamps takes it at the start. Here the hour's temperature is the mean of both
    readings - the value at mid-hour, where the sun position for the irradiance is taken
    (EnergyPlus interpolates linearly between "last hour's" and "this hour's" readings).

    Parameters
    ----------
    data : pandas.DataFrame
        From :func:`read_epw` (pvlib's columns, index at interval starts, in file order).

    Returns
    -------
    pandas.DataFrame
        Indexed by the middle of each hour (``start + 30 min``, the file's standard time
        zone), with columns ``start`` and ``end`` (times), ``dni``, ``ghi``, ``dhi`` (W/m^2,
        the hour's mean), ``temp_air`` (degC at mid-hour), ``temp_start`` and ``temp_end``
        (the readings at the hour's start and end). The reading at the start of the file's
        first hour is the file's last row when the file is a full year (8760 rows: 24:00 on
        31 December is 0:00 on 1 January of the typical year), else the first reading itself.

    Examples
    --------
    >>> import pandas as pd
    >>> idx = pd.date_range("2023-07-01 11:00", periods=3, freq="1h", tz="Etc/GMT-1")
    >>> data = pd.DataFrame({"temp_air": [25.0, 27.0, 28.0], "dni": [500.0, 600, 650],
    ...                      "ghi": 0.0, "dhi": 0.0}, index=idx)
    >>> h = epw_hours(data)
    >>> h.index[1].strftime("%H:%M"), float(h["temp_air"].iloc[1]), float(h["dni"].iloc[1])
    ('12:30', 26.0, 600.0)
    """
    import pandas as pd

    end_reading = data["temp_air"].to_numpy(float)
    start_reading = np.roll(end_reading, 1)
    if len(data) != 8760:
        start_reading[:1] = end_reading[:1]
    start = data.index
    out = pd.DataFrame({
        "start": start, "end": start + pd.Timedelta(hours=1),
        "dni": data["dni"].to_numpy(float), "ghi": data["ghi"].to_numpy(float),
        "dhi": data["dhi"].to_numpy(float),
        "temp_air": 0.5 * (start_reading + end_reading),
        "temp_start": start_reading, "temp_end": end_reading,
    }, index=start + pd.Timedelta(minutes=30))
    out.index.name = "middle"
    return out


_EPW_COLUMNS = 35
_EPW_HEADER_LINES = 8


class WeatherFileError(TorsalError, ValueError):
    """A weather file that is not a usable EPW, TMY3 or TMY2 file; the message names the file
    (and the line where it can)."""


class EPWError(WeatherFileError):
    """A weather file that is not a usable EPW; the message names the file and the line."""


def read_epw(path, *, coerce_year: int | None = None):
    """Read an EPW weather file with ``pvlib.iotools.read_epw`` after checking its content.

    pvlib reads an empty or foreign file as a table without columns (a ``KeyError`` later);
    here the LOCATION line (latitude, longitude, time zone, elevation as numbers), the eight
    header lines and every data row (35 fields, numeric temperature and DNI) are checked, and
    :class:`EPWError` names the file and the first bad line.

    Returns
    -------
    data : pandas.DataFrame
        pvlib's columns (``temp_air`` degC, ``dni`` W/m^2, ...), one row per hour.
    meta : dict
        ``latitude``, ``longitude`` (degrees), ``TZ`` (hours), ``altitude`` (m), ...

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "w.epw"
    >>> _ = p.write_text("hello,world")
    >>> read_epw(p)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    torsal.light.sun.EPWError: ...w.epw: not an EPW weather file (the first line must be 'LOCATION,...
    """
    import io

    import pvlib

    path = Path(path)
    raw = read_input(path, "EPW weather file")
    text = raw.decode("utf-8") if _is_utf8(raw) else raw.decode("latin-1")
    lines = text.splitlines()
    loc = lines[0].split(",") if lines else []
    if len(loc) < 10 or loc[0].strip().upper() != "LOCATION":
        first = repr(lines[0][:40]) if lines else "an empty file"
        raise EPWError(f"{path}: not an EPW weather file (the first line must be "
                       f"'LOCATION,city,...,latitude,longitude,timezone,elevation'; got {first})")
    try:
        lat, lon, tz, elev = (float(x) for x in loc[6:10])
    except ValueError:
        raise EPWError(f"{path}: line 1: latitude, longitude, time zone and elevation (fields "
                       f"7-10) must be numbers, got {','.join(loc[6:10])!r}") from None
    if not (-90 <= lat <= 90 and -180 <= lon <= 180 and -12 <= tz <= 14):
        raise EPWError(f"{path}: line 1: latitude {lat}, longitude {lon}, time zone {tz} out of "
                       "range")
    periods = lines[_EPW_HEADER_LINES - 1].split(",") if len(lines) >= _EPW_HEADER_LINES else []
    if len(periods) > 2 and periods[0].strip().upper() == "DATA PERIODS":
        per_hour = periods[2].strip()
        if per_hour not in ("1", ""):
            raise EPWError(f"{path}: line {_EPW_HEADER_LINES}: {per_hour} records per hour; torsal "
                           "reads hourly EPW files (one record per hour), convert it to hourly")
    rows = lines[_EPW_HEADER_LINES:]
    if not any(r.strip() for r in rows):
        raise EPWError(f"{path}: no hourly data rows after the {_EPW_HEADER_LINES} header lines")
    for k, row in enumerate(rows):
        fields = row.split(",")
        line_no = _EPW_HEADER_LINES + k + 1
        if not row.strip() and k == len(rows) - 1:
            continue
        if len(fields) < _EPW_COLUMNS:
            raise EPWError(f"{path}: line {line_no}: {len(fields)} fields, an EPW data row has "
                           f"{_EPW_COLUMNS} (truncated or damaged file?)")
        try:
            float(fields[6]), float(fields[14])  # dry-bulb temperature, direct normal irradiance
        except ValueError:
            raise EPWError(f"{path}: line {line_no}: temperature {fields[6]!r} or DNI "
                           f"{fields[14]!r} is not a number") from None
    try:
        return pvlib.iotools.read_epw(io.StringIO(text), coerce_year=coerce_year)
    except (ValueError, KeyError, IndexError) as exc:
        raise EPWError(f"{path}: pvlib could not read it as EPW ({type(exc).__name__}: {exc})"
                       ) from None


#: the weather-file formats :func:`read_weather` reads: name -> what it is
WEATHER_FORMATS = {
    "epw": "EPW (EnergyPlus weather file, .epw)",
    "tmy3": "TMY3 (NREL typical meteorological year, 3rd series, .csv)",
    "tmy2": "TMY2 (NREL typical meteorological year, 2nd series, .tm2)",
}

_TMY3_HEADER = "Date (MM/DD/YYYY)"
# TMY2's first line: WBAN, city, state, time zone, N/S dd mm, E/W ddd mm, elevation (m)
_TMY2_LOCATION = re.compile(r"^\s*(\d+)\s+(.*?)\s+([A-Z]{2})\s+(-?\d+)\s+([NS])\s*(\d+)\s+(\d+)"
                            r"\s+([EW])\s*(\d+)\s+(\d+)\s+(-?\d+)\s*$")


def _weather_format(path: Path, lines: list[str]) -> str | None:
    """The format of a weather file from its first two lines (EPW: ``LOCATION,...``; TMY3: a
    station line, then the ``Date (MM/DD/YYYY),...`` header; TMY2: the fixed-width station
    line), else from its name's suffix; None when neither tells."""
    first = lines[0] if lines else ""
    second = lines[1] if len(lines) > 1 else ""
    if first.split(",", 1)[0].strip().upper() == "LOCATION":
        return "epw"
    if second.startswith(_TMY3_HEADER):
        return "tmy3"
    if _TMY2_LOCATION.match(first):
        return "tmy2"
    return {".epw": "epw", ".csv": "tmy3", ".tm2": "tmy2"}.get(path.suffix.lower())


def read_weather(path, *, format: str | None = None, coerce_year: int | None = None):
    """A weather file's hours, whatever its format: EPW, TMY3 or TMY2 (:data:`WEATHER_FORMATS`).

    The format is told by the file's first lines (an EPW's ``LOCATION`` line, a TMY3's
    ``Date (MM/DD/YYYY),Time (HH:MM),...`` header on its second line, a TMY2's fixed-width
    station line), else by its suffix (``.epw``, ``.csv``, ``.tm2``).

    The three formats share one convention: a row stamped ``h:00`` (EPW: Hour field ``h`` of
    1..24; TMY3: ``Time (HH:MM)`` 01:00..24:00; TMY2: hour 1..24) is the hour from ``(h-1):00``
    to ``h:00`` local standard time, its irradiance the total received over that hour (Wh/m^2,
    the hour's mean in W/m^2: the TMY3 and TMY2 manuals' "during the 60-minute period ending
    at the timestamp", the EPW data dictionary's "during the 60 minutes preceding"), its
    dry-bulb temperature the reading at ``h:00`` ("at the time indicated"). pvlib's readers
    stamp the rows differently: ``read_epw`` and ``read_tmy2`` at the hour's start,
    ``read_tmy3`` at its end (24:00 as 0:00 of the next day, and 24:00 on 28 February of a
    leap year as 1 March); ``read_tmy2`` also keeps the dry bulb in tenths of degC. Here every
    row is stamped at its hour's start (a TMY3's from its own date and time, ``HH:00`` minus
    an hour; a midnight written 00:00, as SolarAnywhere does, ends the day before), the TMY2
    temperature is divided by 10, and :func:`epw_hours` makes the hourly frame: indexed at the
    middle of the hour, the temperature at mid-hour.

    Parameters
    ----------
    path : str or Path
    format : {"epw", "tmy3", "tmy2"}, optional
        Read as this format (default: told from the file).
    coerce_year : int, optional
        One calendar year for every row of an EPW or TMY3 (the files mix years, a month from
        each). TMY2 rows take the first row's year already (pvlib).

    Returns
    -------
    hours : pandas.DataFrame
        :func:`epw_hours`'s frame: index at mid-hour (the file's standard time zone),
        ``start``, ``end``, ``dni``, ``ghi``, ``dhi`` (W/m^2), ``temp_air`` (degC at mid-hour),
        ``temp_start``, ``temp_end``.
    meta : dict
        ``format`` (a key of :data:`WEATHER_FORMATS`), ``name`` (the station or city),
        ``latitude``, ``longitude`` (degrees, north and east positive), ``TZ`` (hours of local
        standard time from UTC), ``altitude`` (m), and the rest of pvlib's metadata.

    Raises
    ------
    WeatherFileError
        Not a weather file of these formats, or a damaged one (:class:`EPWError` for an EPW);
        the message names the file.

    Examples
    --------
    >>> import os, pvlib
    >>> h, meta = read_weather(os.path.join(os.path.dirname(pvlib.__file__), "data",
    ...                                     "723170TYA.CSV"))
    >>> meta["format"], meta["name"], meta["latitude"], meta["longitude"], len(h)
    ('tmy3', 'GREENSBORO PIEDMONT TRIAD INT, NC', 36.1, -79.95, 8760)
    >>> str(h.index[0]), str(h["start"].iloc[0]), str(h["end"].iloc[0])
    ('1988-01-01 00:30:00-05:00', '1988-01-01 00:00:00-05:00', '1988-01-01 01:00:00-05:00')
    """
    path = Path(path)
    if format is not None and format not in WEATHER_FORMATS:
        raise ValueError(f"format must be one of {sorted(WEATHER_FORMATS)}, got {format!r}")
    raw = read_input(path, "weather file")
    text = raw.decode("utf-8") if _is_utf8(raw) else raw.decode("latin-1")
    text = text.removeprefix("\ufeff")
    lines = text.splitlines()
    fmt = format or _weather_format(path, lines[:2])
    if fmt is None:
        first = repr(lines[0][:60]) if lines else "an empty file"
        raise WeatherFileError(
            f"{path}: not a weather file torsal reads: an EPW (first line 'LOCATION,...'), a "
            f"TMY3 (.csv: a station line, then '{_TMY3_HEADER},Time (HH:MM),...') or a TMY2 "
            f"(.tm2: a fixed-width station line); got {first}")
    if fmt == "epw":
        data, meta = read_epw(path, coerce_year=coerce_year)
        meta = {**meta, "name": ", ".join(str(meta.get(k, "")).strip() for k in
                                          ("city", "state-prov", "country")
                                          if str(meta.get(k, "")).strip() not in ("", "-"))}
    elif fmt == "tmy3":
        data, meta = _read_tmy3(path, text, lines, coerce_year)
    else:
        data, meta = _read_tmy2(path, lines)
    return epw_hours(data), {**meta, "format": fmt}


def _read_tmy3(path: Path, text: str, lines: list[str], coerce_year):
    """A TMY3 file checked, then read by ``pvlib.iotools.read_tmy3``: the rows restamped at
    their hour's start (pvlib stamps the end)."""
    import io

    import pandas as pd
    import pvlib

    loc = lines[0].split(",") if lines else []
    if len(loc) < 7:
        raise WeatherFileError(f"{path}: not a TMY3 file (the first line must be 'USAF,name,"
                               "state,time zone,latitude,longitude,elevation')")
    try:
        tz, lat, lon, _ = (float(x) for x in loc[-4:])
    except ValueError:
        raise WeatherFileError(f"{path}: line 1: time zone, latitude, longitude and elevation "
                               f"must be numbers, got {','.join(loc[-4:])!r}") from None
    if not (-90 <= lat <= 90 and -180 <= lon <= 180 and -12 <= tz <= 14):
        raise WeatherFileError(f"{path}: line 1: latitude {lat}, longitude {lon}, time zone "
                               f"{tz} out of range")
    if len(lines) < 2 or not lines[1].startswith(_TMY3_HEADER):
        raise WeatherFileError(f"{path}: line 2 must be the TMY3 column header "
                               f"'{_TMY3_HEADER},Time (HH:MM),...'")
    if len(loc) > 7:          # a station name with commas in it: pvlib splits on every comma
        loc = [loc[0], " ".join(x.strip() for x in loc[1:-5]), *loc[-5:]]
        text = "\n".join([",".join(loc), *lines[1:]])
    try:
        data, meta = pvlib.iotools.read_tmy3(io.StringIO(text))
        cols = data[["ghi", "dni", "dhi", "temp_air"]].apply(pd.to_numeric, errors="raise")
        day = pd.to_datetime(data["Date (MM/DD/YYYY)"], format="%m/%d/%Y")
        hh, mm = (data["Time (HH:MM)"].str.split(":").str[k].astype(int) for k in (0, 1))
    except (ValueError, KeyError, IndexError, TypeError, AttributeError) as exc:
        raise WeatherFileError(f"{path}: pvlib could not read it as TMY3 "
                               f"({type(exc).__name__}: {exc})") from None
    if not len(data):
        raise WeatherFileError(f"{path}: no hourly data rows after the 2 header lines")
    if (mm != 0).any():
        raise WeatherFileError(f"{path}: rows at minutes past the hour; torsal reads hourly "
                               "weather files (one row per hour), convert it to hourly")
    if coerce_year is not None:
        day = day.map(lambda d: d.replace(year=coerce_year))
    # the hour's start from the file's own date and time (HH:00 ends the hour): pvlib's stamp
    # moves 24:00 on 28 February of a leap year to 1 March (its leap-day shift), a day late
    start = pd.DatetimeIndex(day + pd.to_timedelta(hh - 1, unit="h"))
    cols.index = start.tz_localize(_dt.timezone(_dt.timedelta(hours=float(meta["TZ"]))))
    name = ", ".join(str(meta[k]).strip().strip('"') for k in ("Name", "State")
                     if str(meta.get(k, "")).strip())
    return cols, {**meta, "name": name}


def _read_tmy2(path: Path, lines: list[str]):
    """A TMY2 file checked, then read by ``pvlib.iotools.read_tmy2`` (stamped at the hour's
    start already); the dry bulb from tenths of degC to degC."""
    import pandas as pd
    import pvlib

    m = _TMY2_LOCATION.match(lines[0]) if lines else None
    if m is None:
        raise WeatherFileError(f"{path}: not a TMY2 file (the first line must be the station: "
                               "WBAN, city, state, time zone, N/S degrees minutes, E/W degrees "
                               "minutes, elevation)")
    if len(m.group(2).split()) != 1:
        raise WeatherFileError(f"{path}: line 1: pvlib reads a TMY2 city name of one word, got "
                               f"{m.group(2)!r}; join its words with '_'")
    if len(lines) < 2:
        raise WeatherFileError(f"{path}: no hourly data rows after the station line")
    try:
        data, meta = pvlib.iotools.read_tmy2(str(path))
    except (ValueError, KeyError, IndexError, TypeError) as exc:
        raise WeatherFileError(f"{path}: pvlib could not read it as TMY2 "
                               f"({type(exc).__name__}: {exc})") from None
    cols = pd.DataFrame({"ghi": data["GHI"], "dni": data["DNI"], "dhi": data["DHI"],
                         "temp_air": data["DryBulb"] / 10.0}, index=data.index).astype(float)
    name = ", ".join(str(meta[k]).strip().replace("_", " ") for k in ("City", "State")
                     if str(meta.get(k, "")).strip())
    return cols, {**meta, "name": name, "TZ": float(meta["TZ"])}


def _is_utf8(raw: bytes) -> bool:
    try:
        raw.decode("utf-8")
        return True
    except UnicodeDecodeError:
        return False


def write_synthetic_epw(path, latitude: float, longitude: float, *, tz_hours: float,
                        elevation: float = 0.0, year: int = 2023, city: str = "Synthetic",
                        t_mean: float = 15.0, t_season: float = 10.0, t_day: float = 6.0,
                        linke_turbidity: float = 3.0) -> Path:
    """Write a full-year (8760 h) EPW file with clear-sky irradiance and a smooth climate.

    As the EPW data dictionary has it (see :func:`epw_hours`): row ``h`` holds the irradiance
    of the hour ending at ``h:00`` - pvlib's Ineichen-Perez clear sky (``linke_turbidity``
    fixed) at its midpoint - and the dry-bulb temperature read at ``h:00``,
    ``t_mean + t_season * season + t_day * day`` with ``season`` a cosine peaking on
    21 July (21 January south of the equator) and ``day`` a cosine peaking at 15:00.
    Meant for tests and examples without downloading a weather file; not a climate model.
    Written atomically (temporary name, then rename).

    Returns
    -------
    Path
    """
    import pandas as pd
    import pvlib

    _check_site(latitude, longitude)
    path = Path(path)
    tz = _dt.timezone(_dt.timedelta(hours=tz_hours))
    start = pd.Timestamp(year=year, month=1, day=1, tz=tz)
    idx = pd.date_range(start, periods=8760, freq="1h")  # interval starts, local standard time
    idx = idx[~((idx.month == 2) & (idx.day == 29))]
    if len(idx) < 8760:  # leap year: extend into the next days to keep 8760 rows
        idx = pd.date_range(start, periods=8784, freq="1h")
        idx = idx[~((idx.month == 2) & (idx.day == 29))][:8760]
    mid = idx + pd.Timedelta(minutes=30)
    pos = pvlib.solarposition.get_solarposition(mid, latitude, longitude, altitude=elevation,
                                                method=_SPA_METHOD)
    am = pvlib.atmosphere.get_absolute_airmass(
        pvlib.atmosphere.get_relative_airmass(pos["apparent_zenith"]),
        pvlib.atmosphere.alt2pres(elevation))
    cs = pvlib.clearsky.ineichen(pos["apparent_zenith"], am, linke_turbidity, altitude=elevation)
    cs = cs.fillna(0.0).clip(lower=0.0)
    stamp = idx + pd.Timedelta(hours=1)  # temperatures are readings at the row's time, h:00
    doy = stamp.day_of_year.to_numpy(float) + _hour_of_day(stamp) / 24.0
    peak = 202.0 if latitude >= 0 else 21.0
    season = np.cos(2 * np.pi * (doy - peak) / 365.0)
    hod = _hour_of_day(stamp)
    day = np.cos(2 * np.pi * (hod - 15.0) / 24.0)
    temp = t_mean + t_season * season + t_day * day
    pressure = pvlib.atmosphere.alt2pres(elevation)

    header = [
        f"LOCATION,{city},,XXX,Synthetic,000000,{latitude:.4f},{longitude:.4f},{tz_hours:.1f},"
        f"{elevation:.1f}",
        "DESIGN CONDITIONS,0",
        "TYPICAL/EXTREME PERIODS,0",
        "GROUND TEMPERATURES,0",
        "HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0",
        "COMMENTS 1,Synthetic clear-sky year written by torsal.light.sun.write_synthetic_epw",
        "COMMENTS 2,Not measured data",
        "DATA PERIODS,1,1,Data,Sunday, 1/ 1,12/31",
    ]
    ghi, dni, dhi = (cs[c].to_numpy(float) for c in ("ghi", "dni", "dhi"))
    lines = []
    for i, t in enumerate(idx):
        row = [year, t.month, t.day, t.hour + 1, 60, "?9?9?9?9E0?9?9?9?9*9?9?9?9?9?9?9?9?9*_*9*9*9*9*9",
               f"{temp[i]:.1f}", f"{temp[i] - 8:.1f}", 50, f"{pressure:.0f}", 0, 1367, 300,
               f"{ghi[i]:.0f}", f"{dni[i]:.0f}", f"{dhi[i]:.0f}", 999999, 999999, 999999, 9999,
               180, 2.0, 0, 0, 9999, 77777, 9, 999999999, 0, 0.1, 0, 88, 0.2, 0, 1]
        assert len(row) == _EPW_COLUMNS
        lines.append(",".join(map(str, row)))
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(header + lines) + "\n")
    return path
