"""The ``annual`` stage: the year's solar irradiance on the glazing, by Radiance.

With ``[annual] enabled = true`` a design run measures, after the light stage, what reaches
mesh A's glazing over a weather year (:mod:`torsal.light.annual`): bare, behind the fins as
built, and behind each standard device of the same depth and spacing, on the same sample
points, under the same sky. The weather is the design's weather file (``sun.weather``: EPW,
TMY3 or TMY2; or ``sun.epw``), or without one the clear-sky year of the ``[site]``. A weather
file whose place lies more than :data:`~torsal.pipeline.design_file.WEATHER_SITE_TOLERANCE_DEG`
from the ``[site]`` is refused (:func:`check_weather_site`) unless
``sun.allow_distant_weather``. The report's ``light.annual`` holds kWh/m^2 per month and
season, the shading factor of each shading against the bare glazing, and the engine's
settings. With a ``[room]`` table, ``light.annual.daylight`` adds the sDA and ASE (IES LM-83)
of a room behind each storey of the facade (:func:`facade_rooms`), bare and behind each
shading.
"""
from __future__ import annotations

import time
from importlib.metadata import PackageNotFoundError, version

import numpy as np
import trimesh

from ..geometry.mesh import average_edge_length
from ..light.annual import (RadianceSettings, Room, SeasonRule, SkyQuantity, annual_irradiance,
                            clear_sky_year, daylight, seasons, shading_factor, sky_year,
                            weather_year)
from ..light.annual.daylight import (BLINDS_LUX, BLINDS_SHARE, GRID_M, Blinds,
                                     WORK_PLANE_M)
from ..light.devices import surface_frame
from ..light.annual.radiance import PACKAGE
from ..light.sun import WeatherFileError
from .design_file import WEATHER_SITE_TOLERANCE_DEG, DesignSpec
from .errors import DesignError
from .measure import design_devices, devices_key
from .report import best_device, plot_annual_map, plot_annual_months, plot_daylight_plans
from .stage import StageInputs

__all__ = ["run_annual", "annual_key", "annual_applies", "design_weather", "glazing_points",
           "annual_summary", "facade_rooms", "room_daylight", "check_weather_site"]


def annual_applies(spec: DesignSpec) -> bool:
    """The stage runs where the design asks for it (``annual.enabled``)."""
    return spec.annual.enabled


def annual_key(spec: DesignSpec) -> tuple:
    """What the stage depends on besides its inputs' results (the weather file's content and
    the site come with the sun stage's key)."""
    return (spec.annual.model_dump(mode="json"), devices_key(spec),
            spec.room.model_dump(mode="json") if spec.room else None,
            spec.view.storey_height_m, spec.outputs.renders)


def _place(latitude: float, longitude: float) -> str:
    """``36.10 N, 79.95 W``."""
    return (f"{abs(latitude):.2f} {'N' if latitude >= 0 else 'S'}, "
            f"{abs(longitude):.2f} {'E' if longitude >= 0 else 'W'}")


def check_weather_site(spec: DesignSpec, latitude: float, longitude: float, place: str = "", *,
                       stage: str) -> None:
    """Refuse a weather file whose place (``latitude``, ``longitude``, the station ``place``)
    lies more than :data:`~torsal.pipeline.design_file.WEATHER_SITE_TOLERANCE_DEG` degrees of
    great circle from the design's ``[site]``: its sun, sky and temperatures are another
    place's, a silently wrong result. No check without a ``[site]`` (the file's place is the
    site then) or with ``sun.allow_distant_weather``.

    Raises
    ------
    DesignError
        Naming the file's key and path, both places and how far apart they are.

    Examples
    --------
    >>> from torsal.pipeline.design_file import DesignSpec
    >>> spec = DesignSpec.model_validate({"surface": {"generator": "flat_facade"},
    ...     "site": {"latitude": 48.21, "longitude": 16.37, "timezone": "Europe/Vienna"},
    ...     "sun": {"weather": "723170TYA.CSV"}, "fins": {"spacing": 0.5, "depth": 0.3}})
    >>> check_weather_site(spec, 48.5, 16.0, stage="sun")      # 0.4 degrees away: the site's
    >>> check_weather_site(spec, 36.1, -79.95, "GREENSBORO, NC", stage="sun")
    Traceback (most recent call last):
    ...
    torsal.pipeline.errors.DesignError: stage 'sun' failed: sun.weather = '723170TYA.CSV': the weather file is for GREENSBORO, NC at 36.10 N, 79.95 W, 67.7 degrees of great circle (7,524 km) from [site] at 48.21 N, 16.37 E: its sun, sky and temperatures are that place's, not the site's. Give the site's own weather file, set [site] to the file's place, or set sun.allow_distant_weather = true to use it anyway
    """
    site, sun = spec.site, spec.sun
    if site is None or sun.allow_distant_weather:
        return
    a, b = np.radians([latitude, longitude]), np.radians([site.latitude, site.longitude])
    cos = (np.sin(a[0]) * np.sin(b[0]) + np.cos(a[0]) * np.cos(b[0]) * np.cos(a[1] - b[1]))
    angle = float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
    if angle <= WEATHER_SITE_TOLERANCE_DEG:
        return
    where = f"{place} at " if place else ""
    raise DesignError(stage, f"the weather file is for {where}{_place(latitude, longitude)}, "
                      f"{angle:.1f} degrees of great circle ({np.radians(angle) * 6371.0:,.0f} km)"
                      f" from [site] at {_place(site.latitude, site.longitude)}: its sun, sky and "
                      "temperatures are that place's, not the site's. Give the site's own weather "
                      "file, set [site] to the file's place, or set sun.allow_distant_weather = "
                      "true to use it anyway", key=sun.weather_key, value=str(sun.weather_file))


def design_weather(spec: DesignSpec):
    """The design's weather year: its weather file (``sun.weather`` or ``sun.epw``: EPW, TMY3
    or TMY2), else the clear-sky year of ``[site]`` (:class:`~torsal.light.annual.Weather`);
    a :class:`DesignError` without either, for a file that cannot be read, or for one whose
    place is far from ``[site]`` (:func:`check_weather_site`)."""
    path = spec.sun.weather_file
    if path is not None:
        try:
            weather = weather_year(path)
        except WeatherFileError as exc:
            raise DesignError("annual", str(exc), key=spec.sun.weather_key,
                              value=str(path)) from None
        check_weather_site(spec, weather.latitude, weather.longitude, weather.place,
                           stage="annual")
        return weather
    if spec.site is None:
        raise DesignError("annual", "the annual irradiance needs a weather year: a [site] "
                          "(its clear-sky year) or a weather file (sun.weather)",
                          key="annual.enabled", value=True)
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
        raise DesignError("annual", "the temperature season rule needs a weather file's "
                          "temperatures (sun.weather or sun.epw); without a weather file use "
                          "season = 'months' (or 'auto')",
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
    plans = {}
    if spec.room is not None:
        report["daylight"], plans = room_daylight(spec, weather, v, f, shadings,
                                                  progress=inp.progress)
        report["seconds"] = time.perf_counter() - t0
    files = (_figures(inp, report, points, results["fins"].per_point, plans)
             if spec.outputs.renders else {})
    report["figures"] = {_FIGURES[kind]: name for kind, name in files.items()}
    return {"report": report, "files": files,
            "map": {"points": points, "bare": bare.per_point, "fins": results["fins"].per_point}}


def facade_rooms(spec: DesignSpec, vertices, faces) -> tuple[list, str | None]:
    """The ``[room]`` behind each storey of the facade (model units): a box behind A's innermost
    point, as wide as A, the first floor at A's foot, as many storeys as fit in A's height.

    Returns
    -------
    rooms : list of torsal.light.annual.Room
    reason : str or None
        Why there are none (a canopy, a facade lower than a storey).
    """
    frame = surface_frame(vertices, faces)
    if not frame.is_facade:
        return [], "a canopy: [room] is the rooms behind a facade"
    r = spec.room
    storey = r.storey_height or spec.view.storey_height_m / spec.metres_per_unit
    v = np.asarray(vertices, float)
    across, z = v @ frame.u, v[:, 2]
    floors = z.min() + storey * np.arange(int(np.floor((np.ptp(z) + 1e-9 * storey) / storey)))
    if not len(floors):
        return [], f"the facade is lower than a storey ({storey:g} model units)"
    corner = frame.u * across.min() + frame.axis * (v @ frame.axis).min()
    return [Room(tuple(corner + (0.0, 0.0, floor)), tuple(frame.u), tuple(-frame.axis),
                 float(np.ptp(across)), r.depth, r.height, r.sill,
                 r.height if r.head is None else r.head, tuple(r.reflectance), r.transmittance)
            for floor in floors], None


def room_daylight(spec: DesignSpec, weather, vertices, faces, shadings: dict, *,
                  progress=None) -> tuple[dict, dict]:
    """sDA and ASE of each storey's room (:func:`facade_rooms`), bare and behind each shading.

    Parameters
    ----------
    spec : DesignSpec
    weather : torsal.light.annual.Weather
    vertices, faces
        Mesh A, oriented.
    shadings : dict of str -> trimesh.Trimesh
        The fins as built (``"fins"``) and the devices.
    progress : callable(event, info), optional

    Returns
    -------
    report : dict
        ``light.annual.daylight``: ``storeys`` (floor heights, model units), ``bare`` and
        every shading's ``sda`` (LM-83's, with its blinds) / ``sda_unshaded`` / ``ase`` and
        ``blinds_hours`` per storey, ``sda_all`` / ``sda_unshaded_all`` / ``ase_all`` over the
        storeys, the settings, or
        ``applicable`` False with the ``reason``.
    plans : dict
        For the figure: ``rooms`` (list of Room), ``bare`` and ``fins`` (list of
        :class:`~torsal.light.annual.Daylight`, one per room); empty without rooms.
    """
    rooms, reason = facade_rooms(spec, vertices, faces)
    if not rooms:
        return {"applicable": False, "reason": reason}, {}
    a, r, k = spec.annual, spec.room, 1.0 / spec.metres_per_unit
    sky = sky_year(weather, subdivision=a.sky, ground_reflectance=a.ground_reflectance,
                   north_angle=spec.site.north_angle if spec.site else 0.0,
                   quantity=SkyQuantity.VISIBLE)
    settings = RadianceSettings(r.ambient_bounces, r.ambient_divisions, a.fin_reflectance)
    out = {"applicable": True, "standard": "IES LM-83-12: sDA 300 lx / 50 % of the occupied "
           "hours, with its operable blinds (2.2.6: closed in each occupied hour in which more "
           f"than {BLINDS_SHARE:.0%} of the points get {BLINDS_LUX:.0f} lx or more of direct sun; "
           f"closed they pass {r.shade_transmittance:.0%} of the window's light); ASE 1000 lx of "
           "direct sun / 250 h. sda_unshaded: the same rooms with no blinds drawn",
           "storeys": [float(room.origin[2]) for room in rooms],
           "occupied_hours": list(r.occupied_hours), "ambient_bounces": r.ambient_bounces,
           "shade_transmittance": r.shade_transmittance,
           "ambient_divisions": r.ambient_divisions, "work_plane_m": WORK_PLANE_M,
           "grid_m": GRID_M}
    plans = {"rooms": rooms}
    for j, (name, fins) in enumerate([("bare", None), *shadings.items()]):
        if progress is not None:
            progress("progress", {"phase": f"daylight: {name}", "done": j,
                                  "total": len(shadings) + 1})
        d = [daylight(room, sky, fins=fins, settings=settings, hours=r.occupied_hours,
                      spacing=GRID_M * k, work_plane=WORK_PLANE_M * k,
                      blinds=Blinds(transmittance=r.shade_transmittance)) for room in rooms]
        out[name] = {"sda": [x.sda for x in d], "ase": [x.ase for x in d],
                     "sda_all": float(np.mean([x.sda for x in d])),
                     "sda_unshaded": [x.sda_unshaded for x in d],
                     "sda_unshaded_all": float(np.mean([x.sda_unshaded for x in d])),
                     "blinds_hours": [x.blinds_hours for x in d],
                     "ase_all": float(np.mean([x.ase for x in d])),
                     "points": int(sum(len(x.points) for x in d))}
        if name in ("bare", "fins"):
            plans[name] = d
    return out, plans


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


#: the stage's figures: file kind -> what the report calls it
_FIGURES = {"annual_map": "annual irradiance map", "annual_months": "monthly irradiance",
            "daylight_plans": "daylight plans"}


def _figures(inp: StageInputs, report: dict, points, fins_kwh, plans: dict) -> dict:
    """The map of the fins' annual irradiance, the monthly bars and (with rooms) the
    daylight plans, as PNGs in the output folder; {kind: file name}."""
    o = inp["orient"]
    files = {"annual_map": plot_annual_map(points, fins_kwh, (o["vertices"], o["faces"]),
                                           inp.out / "annual_map.png").name,
             "annual_months": plot_annual_months(report, inp.out / "annual_months.png").name}
    if plans:
        files["daylight_plans"] = plot_daylight_plans(plans, inp.out / "daylight_plans.png").name
    return files
