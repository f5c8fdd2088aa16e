"""Weather files other than EPW: pvlib's own TMY3 and TMY2 sample years read into the same hours
as an EPW, checked against their lines read by hand (the NREL manuals' field positions and
words) and against the physics of the hour (global = direct x cos(zenith) + diffuse holds when
the sun is taken at the middle of the hour the reader says)."""
from __future__ import annotations

import csv
import datetime as dt
from pathlib import Path

import numpy as np
import pandas as pd
import pvlib
import pytest

from torsal.light.annual import WeatherSource, weather_year
from torsal.light.sun import (EPWError, WeatherFileError, hot_hours, read_weather,
                              sun_directions, write_synthetic_epw)

DATA = Path(pvlib.__file__).parent / "data"
GREENSBORO = DATA / "723170TYA.CSV"      # TMY3, Greensboro NC
SAND_POINT = DATA / "703165TY.csv"       # TMY3, Sand Point AK
MIAMI = DATA / "12839.tm2"               # TMY2, Miami FL


def _tmy3_by_hand(path):
    """[(start, end, GHI, DNI, DHI, dry bulb)] from a TMY3 file read with the csv module as the
    TMY3 manual (NREL/TP-581-43156) says: line 1 the station (time zone the 4th field), line 2
    the header; ``Time (HH:MM)`` local standard time ends the 60 minutes whose irradiance the
    row holds (24:00 is the end of the day), the dry bulb is read at that time."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    tz = dt.timezone(dt.timedelta(hours=float(rows[0][3])))
    col = {name: k for k, name in enumerate(rows[1])}
    out = []
    for r in rows[2:]:
        month, day, year = (int(x) for x in r[col["Date (MM/DD/YYYY)"]].split("/"))
        hour = int(r[col["Time (HH:MM)"]].split(":")[0])
        end = dt.datetime(year, month, day, tzinfo=tz) + dt.timedelta(hours=hour)
        out.append((end - dt.timedelta(hours=1), end,
                    *(float(r[col[c]]) for c in ("GHI (W/m^2)", "DNI (W/m^2)", "DHI (W/m^2)",
                                                 "Dry-bulb (C)"))))
    return out


def _tmy2_by_hand(path):
    """[(month, day, start hour, GHI, DNI, DHI, dry bulb degC)] from a TMY2 file's fixed
    columns as the TMY2 manual (NREL/TP-463-7668) numbers them: 004-005 month, 006-007 day,
    008-009 hour (1..24, the end of its hour), 018-021 global, 024-027 direct normal, 030-033
    diffuse horizontal (Wh/m^2 over the hour), 068-071 dry bulb (tenths of degC)."""
    out = []
    for line in Path(path).read_text().splitlines()[1:]:
        field = lambda a, b: int(line[a - 1:b])                          # noqa: E731
        out.append((field(4, 5), field(6, 7), field(8, 9) - 1, field(18, 21), field(24, 27),
                    field(30, 33), field(68, 71) / 10.0))
    return out


def test_tmy3_hours_follow_the_manual():
    h, meta = read_weather(GREENSBORO)
    by_hand = _tmy3_by_hand(GREENSBORO)
    assert meta["format"] == "tmy3" and len(h) == len(by_hand) == 8760
    assert (meta["latitude"], meta["longitude"], meta["TZ"], meta["altitude"]) == \
        (36.1, -79.95, -5.0, 273.0)
    assert meta["name"] == "GREENSBORO PIEDMONT TRIAD INT, NC"
    start, end, ghi, dni, dhi, temp = (list(x) for x in zip(*by_hand))
    assert list(h["start"]) == start and list(h["end"]) == end
    assert (h.index == pd.DatetimeIndex(start) + pd.Timedelta(minutes=30)).all()
    np.testing.assert_array_equal(h["ghi"], ghi)
    np.testing.assert_array_equal(h["dni"], dni)
    np.testing.assert_array_equal(h["dhi"], dhi)
    np.testing.assert_array_equal(h["temp_end"], temp)                   # read at the stamp
    np.testing.assert_array_equal(h["temp_start"], np.roll(temp, 1))     # ... at the start
    np.testing.assert_allclose(h["temp_air"], (np.roll(temp, 1) + np.array(temp)) / 2)
    # the hour ending 13:00 on 1 January (the file's 13th row) is 12:00-13:00, its middle 12:30
    assert h.index[12] == pd.Timestamp("1988-01-01 12:30", tz="Etc/GMT+5")


def test_tmy2_hours_follow_the_manual():
    h, meta = read_weather(MIAMI)
    by_hand = _tmy2_by_hand(MIAMI)
    assert meta["format"] == "tmy2" and len(h) == len(by_hand) == 8760
    assert meta["name"] == "MIAMI, FL" and meta["TZ"] == -5.0
    assert meta["latitude"] == pytest.approx(25.8) and meta["longitude"] == pytest.approx(-80.2667,
                                                                                          abs=1e-4)
    month, day, hour, ghi, dni, dhi, temp = (np.array(x) for x in zip(*by_hand))
    np.testing.assert_array_equal(h["start"].dt.month, month)
    np.testing.assert_array_equal(h["start"].dt.day, day)
    np.testing.assert_array_equal(h["start"].dt.hour, hour)
    assert (h.index.minute == 30).all()
    np.testing.assert_array_equal(h["ghi"], ghi)
    np.testing.assert_array_equal(h["dni"], dni)
    np.testing.assert_array_equal(h["dhi"], dhi)
    np.testing.assert_allclose(h["temp_end"], temp)                       # degC, not tenths
    assert 20.0 < h["temp_air"].mean() < 28.0                             # Miami


@pytest.mark.parametrize("path", [GREENSBORO, SAND_POINT, MIAMI], ids=lambda p: p.name)
def test_direct_plus_diffuse_closes_at_mid_hour(path):
    """GHI = DNI cos(zenith) + DHI for each sunny hour, the zenith at the middle of the hour as
    read: within 6 W/m^2 on average; taken half an hour earlier or later (the hour's start or
    end, the two stamps pvlib's readers use) the mean error is four times as large or more."""
    h, meta = read_weather(path)
    error = {}
    for shift in (-30, 0, 30):
        t = h.index + pd.Timedelta(minutes=shift)
        zenith = pvlib.solarposition.get_solarposition(t, meta["latitude"],
                                                       meta["longitude"])["zenith"]
        cos = np.cos(np.radians(zenith.to_numpy()))
        sunny = (h["dni"].to_numpy() > 300) & (cos > 0.2)
        residual = (h["ghi"] - h["dni"] * cos - h["dhi"]).to_numpy()[sunny]
        error[shift] = np.abs(residual).mean()
    assert error[0] < 6.0
    assert min(error[-30], error[30]) > 4 * error[0] and min(error[-30], error[30]) > 20.0


def test_epw_reads_as_before(tmp_path):
    """An EPW through the one reader: the same hours as read_epw + epw_hours, its place named."""
    from torsal.light.sun import epw_hours, read_epw

    path = write_synthetic_epw(tmp_path / "site.epw", 48.21, 16.37, tz_hours=1.0)
    h, meta = read_weather(path)
    pd.testing.assert_frame_equal(h, epw_hours(read_epw(path)[0]))
    assert meta["format"] == "epw" and meta["name"] == "Synthetic, XXX"
    # told by the content: the same EPW under another name
    other = tmp_path / "site.csv"
    other.write_bytes(path.read_bytes())
    assert read_weather(other)[1]["format"] == "epw"


def test_weather_year_of_each_format(tmp_path):
    w = weather_year(GREENSBORO)
    assert w.source is WeatherSource.TMY3 and w.description == "TMY3 weather file 723170TYA.CSV"
    assert w.place == "GREENSBORO PIEDMONT TRIAD INT, NC" and w.utc_offset_hours == -5.0
    assert len(w) == 8760 and (w.times.minute == 30).all() and w.temp_air is not None
    # a measured year: cloudy hours, far less direct sun than pvlib's clear sky there
    from torsal.light.annual import clear_sky_year

    clear = clear_sky_year(36.1, -79.95, timezone=-5.0, elevation=273.0)
    assert 0.4 < w.dni.sum() / clear.dni.sum() < 0.8
    assert weather_year(MIAMI).source is WeatherSource.TMY2
    epw = write_synthetic_epw(tmp_path / "site.epw", 48.21, 16.37, tz_hours=1.0)
    assert weather_year(epw).source is WeatherSource.EPW


def test_hot_hours_of_a_tmy3_file():
    """The design sun of a TMY3 year: every hour kept hot at mid-hour and sunny, weighted by its
    DNI, the sun at mid-hour at the station."""
    sun = hot_hours(GREENSBORO, min_temperature=26.0, min_dni=300.0)
    h, _ = read_weather(GREENSBORO)
    kept = h.loc[sun.times]
    assert len(sun) > 100 and (kept["temp_air"] >= 26.0).all() and (kept["dni"] >= 300.0).all()
    np.testing.assert_array_equal(sun.weights, kept["dni"])
    ref = sun_directions(36.1, -79.95, sun.times, elevation=273.0)
    np.testing.assert_allclose(sun.vectors, ref.vectors, atol=1e-12)
    assert set(sun.times.month) <= set(range(3, 11))


def test_files_that_are_not_weather_files_are_named(tmp_path):
    junk = tmp_path / "notes.txt"
    junk.write_text("hello\nworld\n")
    with pytest.raises(WeatherFileError, match=r"notes\.txt: not a weather file torsal reads"):
        read_weather(junk)
    csv_file = tmp_path / "table.csv"
    csv_file.write_text("a,b,c\n1,2,3\n")
    with pytest.raises(WeatherFileError, match=r"table\.csv: not a TMY3 file"):
        read_weather(csv_file)
    lines = GREENSBORO.read_text().splitlines()
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(["723170,X,NC,-5.0,north,-79.95,273", *lines[1:5]]) + "\n")
    with pytest.raises(WeatherFileError, match=r"line 1: time zone, latitude"):
        read_weather(bad)
    half = tmp_path / "half.csv"
    half.write_text("\n".join([lines[0], lines[1], lines[2].replace(",01:00,", ",01:30,")]) + "\n")
    with pytest.raises(WeatherFileError, match="hourly"):
        read_weather(half)
    tm2 = tmp_path / "bad.tm2"
    tm2.write_text("not a station line\n")
    with pytest.raises(WeatherFileError, match=r"bad\.tm2: not a TMY2 file"):
        read_weather(tm2)
    epw = tmp_path / "bad.epw"
    epw.write_text("hello,world\n")
    with pytest.raises(EPWError, match="not an EPW weather file"):
        read_weather(epw)
    with pytest.raises(FileNotFoundError):
        read_weather(tmp_path / "missing.csv")
