"""Sun directions: pvlib SPA against the published NREL reference case, frames, EPW hot hours."""
from __future__ import annotations

import datetime as dt

import numpy as np
import pandas as pd
import pytest

from torsal.light.sun import (
    SunDirections,
    epw_hours,
    hot_hours,
    read_epw,
    light_directions,
    sun_directions,
    sun_path,
    write_synthetic_epw,
)

# Reda & Andreas, "Solar Position Algorithm for Solar Radiation Applications", NREL/TP-560-34302
# (2004, rev. 2008), Table A5.1: 17 Oct 2003, 12:30:30 local time (UTC-7), Golden, Colorado.
SPA_CASE = dict(latitude=39.742476, longitude=-105.1786, elevation=1830.14,
                pressure=82000.0, temperature=11.0, delta_t=67.0)
SPA_TIME = pd.DatetimeIndex(["2003-10-17 12:30:30"]).tz_localize(dt.timezone(dt.timedelta(hours=-7)))
SPA_ZENITH = 50.11162   # topocentric zenith angle, refraction corrected
SPA_AZIMUTH = 194.34024  # topocentric azimuth, eastward from north


def test_spa_reference_case_within_0_02_degrees():
    s = sun_directions(SPA_CASE["latitude"], SPA_CASE["longitude"], SPA_TIME,
                       elevation=SPA_CASE["elevation"], pressure=SPA_CASE["pressure"],
                       temperature=SPA_CASE["temperature"], delta_t=SPA_CASE["delta_t"])
    assert abs(s.apparent_zenith[0] - SPA_ZENITH) < 0.02
    assert abs(s.azimuth[0] - SPA_AZIMUTH) < 0.02
    # tighter: SPA's own accuracy; the true (unrefracted) zenith 50.12795 would fail this
    assert abs(s.apparent_zenith[0] - SPA_ZENITH) < 1e-3
    assert abs(s.azimuth[0] - SPA_AZIMUTH) < 1e-3
    # and the vector encodes the same angles in the x east / y north / z up frame
    v = s.vectors[0]
    zen = np.degrees(np.arccos(v[2]))
    azi = np.degrees(np.arctan2(v[0], v[1])) % 360.0
    assert abs(zen - SPA_ZENITH) < 0.02
    assert abs(azi - SPA_AZIMUTH) < 0.02
    assert s.above_horizon[0]


def test_same_instant_in_other_timezones_gives_same_direction():
    utc = SPA_TIME.tz_convert("UTC")
    a = sun_directions(39.742476, -105.1786, SPA_TIME)
    b = sun_directions(39.742476, -105.1786, [utc[0].to_pydatetime()])
    np.testing.assert_allclose(a.vectors, b.vectors, atol=1e-12)


def test_naive_times_are_refused_with_a_hint_to_localize():
    with pytest.raises(ValueError, match="localize"):
        sun_directions(48.0, 16.0, pd.DatetimeIndex(["2024-06-21 12:00"]))
    with pytest.raises(ValueError, match="localize"):
        sun_directions(48.0, 16.0, [dt.datetime(2024, 6, 21, 12)])


@pytest.mark.parametrize("lat, lon", [(91.0, 0.0), (-90.5, 0.0), (np.nan, 0.0), (0.0, 181.0)])
def test_site_out_of_range(lat, lon):
    with pytest.raises(ValueError, match="latitude|longitude"):
        sun_directions(lat, lon, SPA_TIME)


def test_vectors_unit_nan_free_and_horizon_mask():
    t = pd.date_range("2024-03-20 00:00", periods=24, freq="1h", tz="Europe/Vienna")
    s = sun_directions(48.21, 16.37, t)
    assert s.vectors.shape == (24, 3) and np.isfinite(s.vectors).all()
    np.testing.assert_allclose(np.linalg.norm(s.vectors, axis=1), 1.0)
    np.testing.assert_array_equal(s.above_horizon, s.vectors[:, 2] > 0)
    assert not s.above_horizon[0] and s.above_horizon[12]   # midnight below, noon above
    # near the equinox the sun rises roughly in the east and sets roughly in the west
    first = s.vectors[np.flatnonzero(s.above_horizon)[0]]
    last = s.vectors[np.flatnonzero(s.above_horizon)[-1]]
    assert first[0] > 0.9 and last[0] < -0.9


def test_north_angle_rotates_counter_clockwise_about_z():
    t = pd.date_range("2024-06-21 08:00", periods=5, freq="2h", tz="Europe/Vienna")
    a = sun_directions(48.21, 16.37, t)
    b = sun_directions(48.21, 16.37, t, north_angle=90.0)
    # north_angle=90: north is -x, east is +y, so (x, y, z) -> (-y, x, z)
    np.testing.assert_allclose(b.vectors, np.c_[-a.vectors[:, 1], a.vectors[:, 0], a.vectors[:, 2]],
                               atol=1e-12)


def test_sun_path_hour_window_and_noon_elevation():
    s = sun_path(48.21, 16.37, "2024-06-21", "2024-06-21", timezone="Europe/Vienna",
                 hours=(11, 15), freq="15min")
    hod = s.times.hour + s.times.minute / 60
    assert hod.min() >= 11 and hod.max() <= 15 and len(s) == 17
    assert s.above_horizon.all()
    # solstice solar noon: elevation = 90 - latitude + obliquity (23.44) plus ~0.01 refraction
    assert abs(s.elevation.max() - (90 - 48.21 + 23.44)) < 0.1
    # below-horizon times are dropped by default and kept on request
    night = sun_path(48.21, 16.37, "2024-06-21", "2024-06-21", timezone="Europe/Vienna",
                     hours=(0, 3), above_horizon_only=False)
    assert len(night) == 4 and not night.above_horizon.any()


def test_light_directions_are_minus_sun_with_normalized_weights():
    t = pd.date_range("2024-06-21 04:00", periods=20, freq="1h", tz="Europe/Vienna")
    s = sun_directions(48.21, 16.37, t, weights=np.arange(20.0) + 1.0)
    d, w = light_directions(s)
    np.testing.assert_allclose(d, -s.vectors[s.above_horizon])
    np.testing.assert_allclose(w.sum(), 1.0)
    np.testing.assert_allclose(w, s.weights[s.above_horizon] / s.weights[s.above_horizon].sum())
    d2, w2 = light_directions([[0.0, -1.0, 1.0]], normalize=False)
    np.testing.assert_allclose(d2, [[0.0, np.sqrt(0.5), -np.sqrt(0.5)]])
    np.testing.assert_allclose(w2, [1.0])
    with pytest.raises(ValueError, match="zero length"):
        light_directions([[0.0, 0.0, 0.0]])


# ------------------------------------------------------------------ EPW hours
# The EPW data dictionary (EnergyPlus Auxiliary Programs): Hour h (1..24) is the interval
# (h-1):00 .. h:00 local standard time; temperatures are readings at h:00; irradiance is the
# total over the 60 minutes before h:00. The reader below follows those words with the standard
# library only, independent of pvlib and of torsal's reader.
def _epw_by_hand(path):
    """[(start, end, temperature read at end, DNI over the hour)], the file's time zone."""
    lines = path.read_text().splitlines()
    tz = dt.timezone(dt.timedelta(hours=float(lines[0].split(",")[8])))
    out = []
    for line in lines[8:]:
        f = line.split(",")
        year, month, day, hour = (int(x) for x in f[:4])
        end = dt.datetime(year, month, day, tzinfo=tz) + dt.timedelta(hours=hour)
        out.append((end - dt.timedelta(hours=1), end, float(f[6]), float(f[14])))
    return out


def _write_small_epw(path, temps, dni, *, start=dt.datetime(2023, 7, 1), tz=1.0):
    """An EPW of len(temps) hourly rows from ``start`` (hour fields 1..24), written by hand."""
    rows = []
    for k, (t, d) in enumerate(zip(temps, dni)):
        end = start + dt.timedelta(hours=k + 1)
        stamp = end - dt.timedelta(hours=1)  # hour 24 of a day is that day's last hour
        fields = [stamp.year, stamp.month, stamp.day, stamp.hour + 1, 60, "?", f"{t:.1f}", 10.0, 50,
                  101325, 0, 1367, 300, d, d, 0] + [0] * 19
        rows.append(",".join(map(str, fields)))
    head = [f"LOCATION,Here,-,NLD,test,000000,52.30,4.77,{tz:.1f},-2.0", "DESIGN CONDITIONS,0",
            "TYPICAL/EXTREME PERIODS,0", "GROUND TEMPERATURES,0", "HOLIDAYS/DAYLIGHT SAVINGS,No,0,0,0",
            "COMMENTS 1,tests/light/test_sun.py", "COMMENTS 2,", "DATA PERIODS,1,1,Data,Saturday, 7/ 1,7/ 2"]
    path.write_text("\n".join(head + rows) + "\n")
    return path


def test_epw_hours_follow_the_data_dictionary(tmp_path):
    temps = [15.0 + 0.7 * k + (k % 5) for k in range(48)]  # every hour its own reading
    dni = [0.0 if not 6 <= k % 24 <= 19 else 100.0 + 11.0 * k for k in range(48)]
    path = _write_small_epw(tmp_path / "w.epw", temps, dni)
    data, _ = read_epw(path)
    h = epw_hours(data)
    by_hand = _epw_by_hand(path)
    assert len(h) == len(by_hand) == 48
    for k, (start, end, temp, d) in enumerate(by_hand):
        assert h["start"].iloc[k] == start and h["end"].iloc[k] == end
        assert h.index[k] == start + dt.timedelta(minutes=30)       # the sun is taken mid-hour
        assert h["dni"].iloc[k] == d                                 # the hour's own total
        assert h["temp_end"].iloc[k] == temp                         # read at the stamp h:00
        start_reading = by_hand[k - 1][2] if k else temp             # read at (h-1):00
        assert h["temp_start"].iloc[k] == start_reading
        assert h["temp_air"].iloc[k] == pytest.approx((start_reading + temp) / 2)
    # the first hour of a file: 00:00-01:00 on 1 July, its middle 00:30 at UTC+1
    assert h.index[0] == pd.Timestamp("2023-07-01 00:30", tz="Etc/GMT-1")


def test_hot_hours_take_the_mid_hour_temperature(tmp_path):
    """Hours whose end reading is hot but whose start is not (and the reverse) are decided
    by the mean: the hour's temperature at its middle, where its sun is."""
    # readings 25 at 11:00, 27 at 12:00, 24.8 at 13:00: the hour 11-12 is hot (mean 26), the
    # hour 12-13 is not (mean 25.9)
    temps = [20.0] * 10 + [25.0, 27.0, 24.8] + [20.0] * 11
    dni = [0.0] * 9 + [500.0] * 6 + [0.0] * 9
    path = _write_small_epw(tmp_path / "w.epw", temps, dni)
    sun = hot_hours(path, min_temperature=26.0, min_dni=300.0)
    assert [t.strftime("%H:%M") for t in sun.times] == ["11:30"]      # the hour 11:00-12:00
    # the other pairings agree on that hour but not on the next: the reading at the hour's
    # end (one row of pvlib's table) keeps 11-12, the reading at its start (ladybug's stamps)
    # keeps 12-13, whose mid-hour temperature is 25.9
    by_hand = _epw_by_hand(path)
    end_hot = [s for s, _, t, d in by_hand if t >= 26 and d >= 300]
    start_hot = [by_hand[k][0] for k in range(1, len(by_hand))
                 if by_hand[k - 1][2] >= 26 and by_hand[k][3] >= 300]
    assert [t.hour for t in end_hot] == [11] and [t.hour for t in start_hot] == [12]
    mean_hot = [by_hand[k][0] for k in range(1, len(by_hand))
                if (by_hand[k - 1][2] + by_hand[k][2]) / 2 >= 26 and by_hand[k][3] >= 300]
    assert [t + dt.timedelta(minutes=30) for t in mean_hot] == list(sun.times)


def test_epw_hours_agree_with_ladybug(tmp_path):
    """ladybug-core, an independent EPW reader, stamps temperatures at their reading time and
    irradiance at the start of its hour: our hours line up with both, for a whole year."""
    epw_mod = pytest.importorskip("ladybug.epw")
    path = write_synthetic_epw(tmp_path / "site.epw", 52.30, 4.77, tz_hours=1.0, year=2023)
    h = epw_hours(read_epw(path)[0])
    lb = epw_mod.EPW(str(path))
    temp = np.array(lb.dry_bulb_temperature.values)
    dni = np.array(lb.direct_normal_radiation.values, dtype=float)
    stamps = lb.dry_bulb_temperature.datetimes
    assert len(h) == len(temp) == 8760
    # ladybug's stamp k is hour k of the year: our hour k starts there
    assert [(d.month, d.day, d.hour) for d in stamps[4000:4003]] == \
        [(t.month, t.day, t.hour) for t in h["start"].iloc[4000:4003]]
    np.testing.assert_allclose(h["dni"], dni, atol=0.5)                    # ladybug rounds to Wh
    np.testing.assert_allclose(h["temp_start"], temp, atol=1e-9)           # the reading at start
    np.testing.assert_allclose(h["temp_end"], np.roll(temp, -1), atol=1e-9)  # ... and at end
    np.testing.assert_allclose(h["temp_air"], (temp + np.roll(temp, -1)) / 2, atol=1e-9)


def test_hot_hours_from_generated_epw(tmp_path):
    import pvlib

    path = write_synthetic_epw(tmp_path / "site.epw", 48.21, 16.37, tz_hours=1.0,
                               elevation=170.0, year=2023)
    data, meta = pvlib.iotools.read_epw(str(path))
    assert len(data) == 8760 and meta["latitude"] == pytest.approx(48.21)

    sun = hot_hours(path, min_temperature=26.0, min_dni=300.0)
    assert isinstance(sun, SunDirections) and len(sun) > 50
    # every design hour is hot at mid-hour, sunny, above the horizon, weighted by its DNI:
    # checked against the file read by hand
    by_hand = _epw_by_hand(path)
    mid = {start + dt.timedelta(minutes=30): ((by_hand[k - 1][2] + t) / 2, d)
           for k, (start, _, t, d) in enumerate(by_hand)}
    for time, w in zip(sun.times, sun.weights):
        temp, d = mid[time]
        assert temp >= 26.0 and d >= 300.0 and w == d
    assert sun.above_horizon.all() and (sun.vectors[:, 2] > 0).all()
    assert (sun.times.minute == 30).all()
    # and none was missed: the same filter on the hand-read hours (sun above the horizon there)
    cand = pd.DatetimeIndex([t for t, (temp, d) in mid.items() if temp >= 26.0 and d >= 300.0])
    expected = sun_directions(48.21, 16.37, cand, elevation=170.0).above_horizon.sum()
    assert len(sun) == expected
    # directions are the SPA ones at the interval midpoints
    ref = sun_directions(48.21, 16.37, sun.times, elevation=170.0)
    np.testing.assert_allclose(sun.vectors, ref.vectors, atol=1e-12)
    # the synthetic climate is hottest on July afternoons: summer months, no mornings or nights
    assert set(sun.times.month) <= {5, 6, 7, 8, 9} and 7 in set(sun.times.month)
    assert sun.times.hour.min() >= 9 and sun.times.hour.max() <= 20

    with pytest.raises(ValueError, match="lower the thresholds"):
        hot_hours(path, min_temperature=60.0, min_dni=300.0)
    with pytest.raises(FileNotFoundError):
        hot_hours(tmp_path / "missing.epw")
