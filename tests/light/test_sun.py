"""Sun directions: pvlib SPA against the published NREL reference case, frames, EPW hot hours."""
from __future__ import annotations

import datetime as dt

import numpy as np
import pandas as pd
import pytest

from torsal.light.sun import (
    SunDirections,
    hot_hours,
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


def test_hot_hours_from_generated_epw(tmp_path):
    import pvlib

    path = write_synthetic_epw(tmp_path / "site.epw", 48.21, 16.37, tz_hours=1.0,
                               elevation=170.0, year=2023)
    data, meta = pvlib.iotools.read_epw(str(path))
    assert len(data) == 8760 and meta["latitude"] == pytest.approx(48.21)

    sun = hot_hours(path, min_temperature=26.0, min_dni=300.0)
    assert isinstance(sun, SunDirections) and len(sun) > 50
    # every design hour is hot, sunny, above the horizon, weighted by its DNI
    mid = data.index + pd.Timedelta(minutes=30)
    row = data.set_index(mid).loc[sun.times]
    assert (row["temp_air"] >= 26.0).all() and (row["dni"] >= 300.0).all()
    np.testing.assert_allclose(sun.weights, row["dni"].to_numpy())
    assert sun.above_horizon.all() and (sun.vectors[:, 2] > 0).all()
    assert (sun.times.minute == 30).all()
    # and none was missed: the same filter done by hand on the raw data
    expected = ((data["temp_air"] >= 26.0) & (data["dni"] >= 300.0)).sum()
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
