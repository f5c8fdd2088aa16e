"""Where the sun is: sun directions from a site and times, or from a weather file.

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
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from torsal.core.atomic import atomic_path
from torsal.core.errors import TorsalError
from torsal.core.inputs import read_input

__all__ = [
    "SunDirections",
    "sun_directions",
    "sun_path",
    "hot_hours",
    "read_epw",
    "epw_hours",
    "EPWError",
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
              coerce_year: int | None = None) -> SunDirections:
    """Design sun directions from an EnergyPlus weather file: the hot, sunny hours.

    Every hour of the file is read as :func:`epw_hours` does (the EPW convention, see there
    and the README): the hour from ``(h-1):00`` to ``h:00`` local standard time, its direct
    normal irradiance the file's value for hour ``h`` (an hourly total), its temperature the
    mean of the readings at its start and end (hours ``h-1`` and ``h``: the value at the middle
    of the hour, as EnergyPlus interpolates), the sun at the middle of the hour. Kept: the
    hours with that temperature ``>= min_temperature`` and DNI ``>= min_dni`` while the sun is
    above the horizon at mid-hour, each weighted by its DNI.

    Parameters
    ----------
    epw_path : str or Path
        EPW file (see :func:`write_synthetic_epw` for a generated one).
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
        Passed to ``read_epw`` (EPW files mix years; one year gives a continuous index).

    Returns
    -------
    SunDirections
        Above-horizon directions with ``weights`` = DNI in W/m^2, ``times`` at mid-hour.
    """
    path = Path(epw_path)
    data, meta = read_epw(path, coerce_year=coerce_year)
    h = epw_hours(data)
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


class EPWError(TorsalError, ValueError):
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
