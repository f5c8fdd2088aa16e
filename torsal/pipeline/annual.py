"""The ``annual`` stage: the year's solar irradiance on the glazing, by Radiance.

With ``[annual] enabled = true`` a design run measures, after the light stage, what reaches
mesh A's glazing over a weather year (:mod:`torsal.light.annual`): bare, behind the fins as
built, and behind each standard device of the same depth and spacing, on the same sample
points, under the same sky. The weather is ``sun.epw``, or without one the clear-sky year of
the ``[site]``. The report's ``light.annual`` holds kWh/m^2 per month and season, the
shading factor of each shading against the bare glazing, and the engine's settings.
"""
from __future__ import annotations

import time
from importlib.metadata import PackageNotFoundError, version

import numpy as np
import trimesh

from ..geometry.mesh import average_edge_length
from ..light.annual import (RadianceSettings, SeasonRule, annual_irradiance, clear_sky_year,
                            epw_year, seasons, shading_factor, sky_year)
from ..light.annual.radiance import PACKAGE
from ..light.sun import EPWError
from .design_file import DesignSpec
from .errors import DesignError
from .measure import design_devices, devices_key
from .report import best_device, plot_annual_map, plot_annual_months
from .stage import StageInputs

__all__ = ["run_annual", "annual_key", "annual_applies", "design_weather", "glazing_points",
           "annual_summary"]


def annual_applies(spec: DesignSpec) -> bool:
    """The stage runs where the design asks for it (``annual.enabled``)."""
    return spec.annual.enabled


def annual_key(spec: DesignSpec) -> tuple:
    """What the stage depends on besides its inputs' results (the weather file's content and
    the site come with the sun stage's key)."""
    return (spec.annual.model_dump(mode="json"), devices_key(spec))


def design_weather(spec: DesignSpec):
    """The design's weather year: ``sun.epw``, else the clear-sky year of ``[site]``
    (:class:`~torsal.light.annual.Weather`); a :class:`DesignError` without either."""
    if spec.sun.epw is not None:
        try:
            return epw_year(spec.sun.epw)
        except EPWError as exc:
            raise DesignError("annual", str(exc), key="sun.epw", value=str(spec.sun.epw)) from None
    if spec.site is None:
        raise DesignError("annual", "the annual irradiance needs a weather year: a [site] "
                          "(its clear-sky year) or sun.epw", key="annual.enabled", value=True)
    s = spec.site
    return clear_sky_year(s.latitude, s.longitude, timezone=s.timezone, elevation=s.elevation)


def glazing_points(vertices, faces, count: int, *, seed: int = 0):
    """``count`` area-uniform points on mesh A and their outward unit normals (the faces'),
    each (count, 3); the same points for every seed-equal call."""
    mesh = trimesh.Trimesh(np.asarray(vertices, float), np.asarray(faces, np.int64), process=False)
    points, face = trimesh.sample.sample_surface(mesh, int(count), seed=seed)
    return np.asarray(points, float), np.asarray(mesh.face_normals[face], float)


def _built_fins(structure, left_out) -> trimesh.Trimesh:
    """The fins the fabrication builds: the structure's fin mesh without the two triangles
    (``2k``, ``2k + 1``) of each left-out edge ``k``."""
    mesh = structure.fin_mesh()
    keep = np.ones(len(structure.edges), bool)
    keep[np.asarray(sorted(left_out), np.int64)] = False
    return trimesh.Trimesh(mesh.vertices, mesh.faces[np.repeat(keep, 2)], process=False)


def _season_rule(spec: DesignSpec, weather):
    rule = spec.annual.season
    if rule is SeasonRule.TEMPERATURE and weather.temp_air is None:
        raise DesignError("annual", "the temperature season rule needs sun.epw's temperatures; "
                          "without a weather file use season = 'months' (or 'auto')",
                          key="annual.season", value=rule.value)
    return seasons(weather, rule, balance_temperature=spec.annual.balance_temperature_c)


def _engine(spec: DesignSpec, settings: RadianceSettings, sky, points: int) -> dict:
    a = spec.annual
    try:
        package = f"{PACKAGE} {version(PACKAGE)}"
    except PackageNotFoundError:          # Radiance found elsewhere (a checkout): say so
        package = PACKAGE
    return {"engine": f"Radiance (gendaymtx, rcontrib; {package})",
            "ambient_bounces": settings.ambient_bounces,
            "ambient_divisions": settings.ambient_divisions,
            "sky": a.sky.value, "sky_patches": a.sky.patches,
            "sun": "one source per hour (0.533 deg disc), pvlib's SPA at mid-hour",
            "fin_reflectance": settings.fin_reflectance,
            "ground_reflectance": sky.ground_reflectance, "points": int(points)}


def run_annual(inp: StageInputs) -> dict:
    """Annual irradiance of the bare glazing, the fins as built and the standard devices.

    Returns the ``report`` section (``light.annual``: ``engine``, ``weather``, ``seasons``,
    ``bare``, ``fins``, ``devices``, each shading with its ``shading_factor``, ``seconds`` and
    ``figures``), ``files`` (with ``outputs.renders``: ``annual_map``, ``annual_months``, PNG)
    and ``map`` (``points`` (p, 3), ``bare`` and ``fins`` (p,) kWh/m^2 over the year).
    """
    spec, a = inp.spec, inp.spec.annual
    t0 = time.perf_counter()
    v, f = inp["orient"]["vertices"], inp["orient"]["faces"]
    weather = design_weather(spec)
    split = _season_rule(spec, weather)
    north = spec.site.north_angle if spec.site else 0.0
    sky = sky_year(weather, subdivision=a.sky, ground_reflectance=a.ground_reflectance,
                   north_angle=north)
    settings = RadianceSettings(a.ambient_bounces, a.ambient_divisions, a.fin_reflectance)
    points, normals = glazing_points(v, f, a.points)
    offset = 1e-4 * average_edge_length(v, f)
    left_out = inp["fabrication"].get("left_out_edges", []) if "fabrication" in inp else []
    shadings = {"fins": _built_fins(inp["support"]["structure"], left_out)}
    devices = design_devices(spec, v, f, inp["sun"]) if a.devices else {}
    shadings.update({name: d.fins for name, d in devices.items() if d.applicable})
    total = len(shadings) + 1
    results, seconds = {}, {}
    for k, (name, fins) in enumerate([("bare", None), *shadings.items()]):
        inp.progress("progress", {"phase": f"annual irradiance: {name}", "done": k, "total": total})
        t = time.perf_counter()
        results[name] = annual_irradiance(points, normals, sky, split, fins=fins,
                                          settings=settings, offset=offset)
        seconds[name] = time.perf_counter() - t
    bare = results["bare"]

    def row(name):
        return {**results[name].as_dict(), "seconds": seconds[name],
                "shading_factor": shading_factor(bare, results[name]).as_dict()}

    report = {
        **_engine(spec, settings, sky, len(points)),
        "weather": {"source": weather.source.value, "description": weather.description,
                    "hours": int(len(weather))},
        "seasons": {"rule": split.rule.value, "description": split.description,
                    "cooling_hours": int(split.cooling.sum())},
        "bare": {**bare.as_dict(), "seconds": seconds["bare"]},
        "fins": row("fins"),
        "devices": {name: (row(name) if d.applicable else
                           {"applicable": False, "reason": d.reason})
                    for name, d in devices.items()},
        "seconds": time.perf_counter() - t0}
    files = _figures(inp, report, points, results["fins"].per_point) if spec.outputs.renders else {}
    report["figures"] = {"annual irradiance map": files.get("annual_map"),
                         "monthly irradiance": files.get("annual_months")} if files else {}
    return {"report": report, "files": files,
            "map": {"points": points, "bare": bare.per_point, "fins": results["fins"].per_point}}


def annual_summary(annual: dict) -> str:
    """``light.annual`` in a line: the year's kWh/m^2 bare and behind the fins, and the
    cooling-season gains the fins and the best device avoid with their shading factors.

    >>> row = lambda y, c, f: {"annual_kwh_m2": y, "cooling_kwh_m2": c, "shading_factor": {
    ...     "cooling_gains_avoided_kwh_m2": 600 - c, "f_sh_cooling": c / 600}}
    >>> annual_summary({"weather": {"source": "clear sky"}, "bare": {"annual_kwh_m2": 1500,
    ...     "cooling_kwh_m2": 600}, "fins": row(540, 180, 0.3), "devices": {
    ...     "egg-crate": row(700, 240, 0.4), "vertical fins": {"applicable": False}}})
    'annual irradiance on the glazing (clear sky): bare 1500 kWh/m2, fins 540; cooling season gains avoided: fins 420 kWh/m2 (F_sh 0.30), best device egg-crate 360 (F_sh 0.40)'
    """
    f = annual["fins"]
    text = (f"annual irradiance on the glazing ({annual['weather']['source']}): bare "
            f"{annual['bare']['annual_kwh_m2']:.0f} kWh/m2, fins {f['annual_kwh_m2']:.0f}; "
            f"cooling season gains avoided: fins "
            f"{f['shading_factor']['cooling_gains_avoided_kwh_m2']:.0f} kWh/m2 (F_sh "
            f"{f['shading_factor']['f_sh_cooling']:.2f})")
    best = best_device(annual)
    if best is not None:
        d = annual["devices"][best]["shading_factor"]
        text += (f", best device {best} {d['cooling_gains_avoided_kwh_m2']:.0f} (F_sh "
                 f"{d['f_sh_cooling']:.2f})")
    return text


def _figures(inp: StageInputs, report: dict, points, fins_kwh) -> dict:
    """The map of the fins' annual irradiance and the monthly bars, as PNGs in the output
    folder; {kind: file name}."""
    o = inp["orient"]
    return {"annual_map": plot_annual_map(points, fins_kwh, (o["vertices"], o["faces"]),
                                          inp.out / "annual_map.png").name,
            "annual_months": plot_annual_months(report, inp.out / "annual_months.png").name}
