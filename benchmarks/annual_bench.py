"""Annual irradiance benchmark (issue 41): Radiance's year on bare planes against pvlib's
transposition models, infinite louvers against their analytic shares, and the seconds.

For a weather year (a synthetic clear-sky EPW written by ``write_synthetic_epw``, or pvlib's
Ineichen clear-sky year), each bare plane (vertical facing S, E, N, W; 30 degrees facing S;
horizontal) gets its year by :func:`torsal.light.annual.annual_irradiance` and by
``pvlib.irradiance.get_total_irradiance`` with the Perez and the Hay-Davies models; then
infinite horizontal louvers (spacing 1, depth ``d``) get their direct share against the
cut-off profile angle and, under a uniform sky, their diffuse share against their sky view
factor. Printed: one table each, with the seconds of each Radiance run.

Run::

    nice -n 10 .venv/bin/python benchmarks/annual_bench.py [--weather clear-sky|epw]

Measured 2026-11-28 19:05 UTC (pyradiance 1.3.1, defaults: -ab 2 -ad 2048, Tregenza sky;
the louvers black, -ab 1 -ad 4096; the shared 2-core machine, ``nice -n 10``), Vienna, the
synthetic EPW (``--weather epw``), 27 s in all::

    | plane | Radiance kWh/m2 | pvlib Perez | Hay-Davies | Radiance / Perez | s |
    |---|---|---|---|---|---|
    | vertical S | 1715 | 1736 | 1673 | -1.2 % | 0.5 |
    | vertical E | 1159 | 1186 | 1110 | -2.3 % | 0.4 |
    | vertical N | 369 | 384 | 301 | -3.9 % | 0.2 |
    | vertical W | 1159 | 1186 | 1110 | -2.3 % | 0.4 |
    | 30 deg S | 2264 | 2284 | 2259 | -0.9 % | 0.6 |
    | horizontal | 1774 | 1775 | 1775 | -0.1 % | 0.7 |

    | depth / spacing | direct share | cut-off analytic | diffuse share | view factor | s |
    |---|---|---|---|---|---|
    | 0.4 | 0.5928 | 0.5929 | 0.6783 | 0.6771 | 3.3 |
    | 0.8 | 0.3529 | 0.3530 | 0.4809 | 0.4806 | 2.7 |
    | 1.2 | 0.2249 | 0.2250 | 0.3624 | 0.3621 | 2.4 |

Radiance's sky is the Perez all-weather *luminance* model, pvlib's Perez is the *transposition*
model: on walls Radiance's diffuse light lies between Perez and Hay-Davies; the direct sun is
the same to 0.01 %.
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pvlib
import trimesh

from torsal.light.annual import (RadianceSettings, SeasonRule, SkySubdivision, SkyYear,
                                 annual_irradiance, clear_sky_year, epw_year, seasons, sky_year)
from torsal.light.annual.weather import Weather, WeatherSource
from torsal.light.sun import write_synthetic_epw

VIENNA = dict(latitude=48.21, longitude=16.37)
PLANES = {"vertical S": (90, 180), "vertical E": (90, 90), "vertical N": (90, 0),
          "vertical W": (90, 270), "30 deg S": (30, 180), "horizontal": (0, 180)}


def _normal(tilt, azimuth):
    t, a = np.radians(tilt), np.radians(azimuth)
    return np.array([np.sin(t) * np.sin(a), np.sin(t) * np.cos(a), np.cos(t)])


def _pvlib_year(weather, tilt, azimuth, model):
    pos = pvlib.solarposition.get_solarposition(weather.times, weather.latitude,
                                                weather.longitude, altitude=weather.elevation)
    poa = pvlib.irradiance.get_total_irradiance(
        tilt, azimuth, pos["apparent_zenith"], pos["azimuth"], weather.dni, weather.ghi,
        weather.dhi, dni_extra=pvlib.irradiance.get_extra_radiation(weather.times),
        airmass=pvlib.atmosphere.get_relative_airmass(pos["apparent_zenith"]), albedo=0.2,
        model=model).fillna(0.0)
    return float(poa["poa_global"].sum() / 1000.0)


def planes_table(weather) -> list[str]:
    """Each bare plane's year by Radiance and by pvlib (Perez, Hay-Davies)."""
    sky, split = sky_year(weather), seasons(weather)
    rows = ["| plane | Radiance kWh/m2 | pvlib Perez | Hay-Davies | Radiance / Perez | s |",
            "|---|---|---|---|---|---|"]
    for name, (tilt, azimuth) in PLANES.items():
        t = time.perf_counter()
        r = annual_irradiance(np.c_[np.arange(8.0), np.zeros(8), np.ones(8)],
                              np.tile(_normal(tilt, azimuth), (8, 1)), sky, split)
        s = time.perf_counter() - t
        perez, hay = (_pvlib_year(weather, tilt, azimuth, m) for m in ("perez", "haydavies"))
        rows.append(f"| {name} | {r.annual:.0f} | {perez:.0f} | {hay:.0f} | "
                    f"{100 * (r.annual / perez - 1):+.1f} % | {s:.1f} |")
    return rows


def _louvers(spacing, depth, half_length=100.0, count=12):
    z = np.arange(-count, count + 1) * spacing
    corners = np.array([[-half_length, 0, 0], [half_length, 0, 0], [half_length, -depth, 0],
                        [-half_length, -depth, 0]])
    v = (corners[None] + np.c_[np.zeros((len(z), 2)), z][:, None]).reshape(-1, 3)
    b = 4 * np.arange(len(z))[:, None]
    return trimesh.Trimesh(v, np.concatenate([b + [0, 1, 2], b + [0, 2, 3]]), process=False)


def _uniform_sky():
    times = pd.DatetimeIndex(["2023-06-21 12:30"]).tz_localize("Etc/GMT-1")
    w = Weather(48.21, 16.37, 0.0, 1.0, times, np.zeros(1), np.zeros(1), np.zeros(1), None,
                WeatherSource.CLEAR_SKY, "a uniform sky")
    sky = np.ones((SkySubdivision.TREGENZA.patches + 1, 1))
    sky[0] = 0.0
    return SkyYear(w, SkySubdivision.TREGENZA, 0.0, 0.0, sky, np.zeros_like(sky),
                   np.zeros((0, 3)), np.zeros(0, int), np.zeros(0))


def louvers_table(weather, depths=(0.4, 0.8, 1.2)) -> list[str]:
    """Infinite louvers (spacing 1): direct share against the cut-off profile angle, diffuse
    share under a uniform sky against the sky view factor."""
    sky, split = sky_year(weather), seasons(weather)
    uniform = _uniform_sky()
    n = 40
    z = (np.arange(n) + 0.5) / n
    points, normals = np.c_[np.zeros(n), np.zeros(n), z], np.tile([0.0, -1.0, 0.0], (n, 1))
    black = RadianceSettings(ambient_bounces=1, ambient_divisions=4096)
    bare = annual_irradiance(points, normals, sky, split, settings=black)
    bare_u = annual_irradiance(points, normals, uniform, seasons(uniform.weather,
                               SeasonRule.MONTHS), settings=black)
    cos = sky.sun_vectors @ [0.0, -1.0, 0.0]
    front = cos > 0
    tan_p = np.where(front, sky.sun_vectors[:, 2] / np.where(front, cos, 1.0), 0.0)
    weight = sky.sun_dni * np.clip(cos, 0.0, None)
    rows = ["| depth / spacing | direct share | cut-off analytic | diffuse share | view factor | s |",
            "|---|---|---|---|---|---|"]
    for d in depths:
        t = time.perf_counter()
        fins = _louvers(1.0, d)
        r = annual_irradiance(points, normals, sky, split, fins=fins, settings=black)
        u = annual_irradiance(points, normals, uniform, seasons(uniform.weather,
                              SeasonRule.MONTHS), fins=fins, settings=black)
        s = time.perf_counter() - t
        direct = (weight * np.clip(1.0 - d * tan_p, 0.0, 1.0)).sum() / weight.sum()
        rows.append(f"| {d:g} | {r.by_source()['sun'] / bare.by_source()['sun']:.4f} | "
                    f"{direct:.4f} | {u.by_source()['sky'] / bare_u.by_source()['sky']:.4f} | "
                    f"{np.sin(np.arctan((1.0 - z) / d)).mean():.4f} | {s:.1f} |")
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--weather", choices=("clear-sky", "epw"), default="epw")
    args = ap.parse_args()
    if args.weather == "epw":
        path = Path(tempfile.mkdtemp()) / "vienna.epw"
        weather = epw_year(write_synthetic_epw(path, **VIENNA, tz_hours=1.0, elevation=170.0))
    else:
        weather = clear_sky_year(**VIENNA, timezone="Europe/Vienna", elevation=170.0)
    print(f"weather: {weather.description}")
    print("\n".join(planes_table(weather)))
    print()
    print("\n".join(louvers_table(weather)))


if __name__ == "__main__":
    main()
