"""Annual irradiance by Radiance against independent values: pvlib's transposition of the same
weather for bare planes, the cut-off profile angle for infinite louvers."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pvlib
import pytest
import trimesh

from torsal.light.annual import (
    Radiance,
    RadianceNotFound,
    RadianceSettings,
    SeasonRule,
    SkyQuantity,
    SkySubdivision,
    SkyYear,
    annual_irradiance,
    clear_sky_year,
    epw_year,
    seasons,
    shading_factor,
    sky_year,
    weather_year,
)
from torsal.light.annual import radiance as radiance_module
from torsal.light.annual.daylight import Room, daylight, occupied
from torsal.light.annual.irradiance import sun_coefficients
from torsal.light.annual.radiance import Program
from torsal.light.annual.weather import Weather, WeatherSource
from torsal.light.sun import write_synthetic_epw
from torsal.pipeline.design_file import RoomSpec, SunSpec

VIENNA = dict(latitude=48.21, longitude=16.37)
#: a measured typical year that pvlib ships: TMY3 of Greensboro, North Carolina
GREENSBORO_TMY3 = Path(pvlib.__file__).parent / "data" / "723170TYA.CSV"
GREENSBORO = dict(latitude=36.1, longitude=-79.95)


@pytest.fixture(scope="module")
def epw_weather(tmp_path_factory):
    path = tmp_path_factory.mktemp("weather") / "vienna.epw"
    write_synthetic_epw(path, **VIENNA, tz_hours=1.0, elevation=170.0)
    return epw_year(path)


@pytest.fixture(scope="module")
def clear_weather():
    return clear_sky_year(**VIENNA, timezone="Europe/Vienna", elevation=170.0)


@pytest.fixture(scope="module")
def tmy3_weather():
    return weather_year(GREENSBORO_TMY3)


def _normal(tilt, azimuth):
    """Outward unit normal of a plane of ``tilt`` (degrees from horizontal) facing ``azimuth``
    (degrees east of north), model frame x east, y north."""
    t, a = np.radians(tilt), np.radians(azimuth)
    return np.array([np.sin(t) * np.sin(a), np.sin(t) * np.cos(a), np.cos(t)])


def _pvlib_poa(weather: Weather, tilt, azimuth, albedo=0.2) -> pd.DataFrame:
    """pvlib's Perez transposition of the weather's hours, W/m^2 per hour."""
    pos = pvlib.solarposition.get_solarposition(weather.times, weather.latitude,
                                                weather.longitude, altitude=weather.elevation)
    return pvlib.irradiance.get_total_irradiance(
        tilt, azimuth, pos["apparent_zenith"], pos["azimuth"], weather.dni, weather.ghi,
        weather.dhi, dni_extra=pvlib.irradiance.get_extra_radiation(weather.times),
        airmass=pvlib.atmosphere.get_relative_airmass(pos["apparent_zenith"]), albedo=albedo,
        model="perez").fillna(0.0)


@pytest.mark.parametrize("which", ["epw", "clear sky", "tmy3"])
@pytest.mark.parametrize("tilt", [90.0, 30.0])
def test_bare_plane_matches_pvlib_perez_within_3_percent(which, tilt, epw_weather, clear_weather,
                                                         tmy3_weather):
    """A south-facing vertical and a 30-degree plane, bare: the year's kWh/m^2 within 3 % of
    pvlib's Perez transposition of the same hours (Radiance's sky is the Perez all-weather
    luminance model, a different model of the same sky: its diffuse share on a vertical plane
    is 8 % below Perez transposition's, in the winter months 4 % below, on a north wall the
    total is 4 % below); the cooling season (months or days, whichever the rule picked) within
    3 %; the direct sun, which both take from the same DNI and sun path, within 0.5 % over the
    year and 1 % in each month and season. The years: a synthetic clear-sky EPW and pvlib's
    clear sky at Vienna, and a measured typical year with its clouds (TMY3, Greensboro)."""
    weather = {"epw": epw_weather, "clear sky": clear_weather, "tmy3": tmy3_weather}[which]
    sky, split = sky_year(weather), seasons(weather)
    normal = _normal(tilt, 180.0)
    points = np.c_[np.arange(8.0), np.zeros(8), np.ones(8)]
    r = annual_irradiance(points, np.tile(normal, (8, 1)), sky, split,
                          settings=RadianceSettings())
    poa = _pvlib_poa(weather, tilt, 180.0)
    total = poa["poa_global"].to_numpy() / 1000.0
    assert r.annual == pytest.approx(total.sum(), rel=0.03)
    assert r.by_source()["sun"] == pytest.approx(poa["poa_direct"].sum() / 1000.0, rel=0.005)
    assert r.cooling == pytest.approx(total[split.cooling].sum(), rel=0.03)
    direct = poa["poa_direct"].to_numpy() / 1000.0
    sun = r.kwh[..., 0].mean(axis=0)                                    # (12, 2) month, season
    np.testing.assert_allclose(sun.sum(axis=1), np.bincount(weather.times.month - 1, direct),
                               rtol=0.01)
    assert sun[:, 1].sum() == pytest.approx(direct[split.cooling].sum(), rel=0.01)
    assert r.by_source()["sun reflected"] == 0.0           # nothing to reflect it
    # the ground: an infinite plane of reflectance 0.2 seen over (1 - cos tilt) / 2
    assert r.by_source()["ground"] == pytest.approx(poa["poa_ground_diffuse"].sum() / 1000.0,
                                                     rel=0.02)


def _louvers(spacing, depth, half_length=100.0, count=12):
    """Horizontal louvers on the vertical plane y = 0 (facing -y, south), from z = -count *
    spacing to count * spacing, ``depth`` deep, ``2 half_length`` long: infinite for the points
    near x = 0, z in (0, spacing)."""
    z = np.arange(-count, count + 1) * spacing
    corners = np.array([[-half_length, 0, 0], [half_length, 0, 0], [half_length, -depth, 0],
                        [-half_length, -depth, 0]])
    v = (corners[None] + np.c_[np.zeros((len(z), 2)), z][:, None]).reshape(-1, 3)
    b = 4 * np.arange(len(z))[:, None]
    f = np.concatenate([b + [0, 1, 2], b + [0, 2, 3]])
    return trimesh.Trimesh(v, f, process=False)


def test_infinite_louvers_direct_share_matches_the_cut_off_profile_angle(clear_weather):
    """Behind infinite horizontal louvers (spacing s, depth d) the sun of profile angle p lights
    the share ``max(0, 1 - d tan p / s)`` of the glazing between two louvers (none above the
    cut-off profile angle atan(s / d)); weighted by each hour's DNI cos(incidence), that share
    of the year's direct sun reaches the glazing. Radiance's within 2 points; the fins take
    sun and sky, and give some back as reflections."""
    sky, split = sky_year(clear_weather), seasons(clear_weather)
    s, d, n = 1.0, 0.8, 40
    points = np.c_[np.zeros(n), np.zeros(n), (np.arange(n) + 0.5) / n * s]
    normals = np.tile([0.0, -1.0, 0.0], (n, 1))
    settings = RadianceSettings(ambient_bounces=2, ambient_divisions=512)
    bare = annual_irradiance(points, normals, sky, split, settings=settings)
    shaded = annual_irradiance(points, normals, sky, split, fins=_louvers(s, d), settings=settings)
    sun = sky.sun_vectors
    cos = sun @ [0.0, -1.0, 0.0]
    front = cos > 0
    tan_profile = np.where(front, sun[:, 2] / np.where(front, cos, 1.0), 0.0)
    lit = np.clip(1.0 - d * tan_profile / s, 0.0, 1.0)
    weight = sky.sun_dni * np.clip(cos, 0.0, None)
    expected = (weight * lit).sum() / weight.sum()
    measured = shaded.by_source()["sun"] / bare.by_source()["sun"]
    assert abs(measured - expected) < 0.02
    assert 0.2 < expected < 0.6                                   # the test is not trivial
    by = shaded.by_source()
    assert by["sky"] < bare.by_source()["sky"] and by["sun reflected"] > 0.0
    f = shading_factor(bare, shaded)
    # high summer sun is cut off, low winter sun gets in: a stronger reduction in summer
    assert f.cooling < f.heating < 1.0
    assert f.cooling_avoided_kwh_m2 == pytest.approx(bare.cooling - shaded.cooling)


def test_low_sun_counts_as_much_as_its_cosine(tmp_path):
    """rcontrib drops suns of zero radiance and, without -V+, suns within a degree of the
    horizon: here each sun is counted at cos(incidence), down to 0.3 degrees."""
    elevation = np.radians([0.3, 0.8, 5.0, 40.0])
    sun = np.c_[np.zeros(4), -np.cos(elevation), np.sin(elevation)]
    sensors = b"0 0 0 0 -1 0\n0 0 0 0 0 1\n"
    coef = sun_coefficients(sensors, "", sun, radiance=Radiance.bundled(), folder=tmp_path)
    np.testing.assert_allclose(coef, np.c_[np.cos(elevation), np.sin(elevation)].T, atol=1e-4)


def test_missing_radiance_names_the_package(tmp_path, monkeypatch):
    with pytest.raises(RadianceNotFound, match="pyradiance"):
        Radiance(tmp_path, tmp_path).run(Program.RCONTRIB, ["-version"], cwd=tmp_path)
    monkeypatch.setattr(radiance_module.importlib.util, "find_spec", lambda name: None)
    with pytest.raises(RadianceNotFound, match=r"pip install 'pyradiance>=1\.3'"):
        Radiance.bundled()


def test_season_rules(epw_weather, clear_weather):
    """Months: May-September cooling in the north, November-March in the south; temperature:
    the days whose mean is above 15 degC, counted here by hand."""
    north = seasons(clear_weather)
    assert north.rule is SeasonRule.MONTHS
    assert set(np.unique(north.month[north.cooling])) == {5, 6, 7, 8, 9}
    south_weather = clear_sky_year(-33.87, 151.21, timezone="Australia/Sydney")
    south = seasons(south_weather)
    assert set(np.unique(south.month[south.cooling])) == {11, 12, 1, 2, 3}
    by_temperature = seasons(epw_weather)
    assert by_temperature.rule is SeasonRule.TEMPERATURE
    days = pd.Series(epw_weather.temp_air, index=epw_weather.times).groupby(
        epw_weather.times.date).mean()
    hot_days = set(days.index[days > 15.0])
    assert set(pd.Index(epw_weather.times.date)[by_temperature.cooling]) == hot_days
    assert 100 < len(hot_days) < 250
    with pytest.raises(ValueError, match="temperature"):
        seasons(clear_weather, SeasonRule.TEMPERATURE)
    assert clear_weather.source is WeatherSource.CLEAR_SKY and clear_weather.temp_air is None


def test_north_angle_turns_the_sky_with_the_suns(clear_weather):
    """The sky matrix's sun (gendaymtx -r) lies in the patch next to the sun vector (pvlib)
    for the design's north angle."""
    for north in (0.0, 90.0):
        sky = sky_year(clear_weather, north_angle=north)
        high = np.flatnonzero(sky.sun_vectors[:, 2] > 0.3)
        brightest = sky.sun_patches[1:, sky.sun_hours[high]].argmax(axis=0)
        patch = sky.subdivision.directions()[brightest]
        angle = np.degrees(np.arccos(np.clip((patch * sky.sun_vectors[high]).sum(1), -1, 1)))
        assert np.median(angle) < 6.0 and np.percentile(angle, 99) < 10.0



def _uniform_sky(subdivision_patches: int) -> SkyYear:
    """One hour (a June noon) of a sky of unit radiance everywhere above the horizon, a black
    ground and no sun."""
    times = pd.DatetimeIndex(["2023-06-21 12:30"]).tz_localize("Etc/GMT-1")
    weather = Weather(48.21, 16.37, 0.0, 1.0, times, np.zeros(1), np.zeros(1), np.zeros(1),
                      None, WeatherSource.CLEAR_SKY, "a uniform sky")
    sky = np.ones((subdivision_patches + 1, 1))
    sky[0] = 0.0
    return SkyYear(weather, SkySubdivision.TREGENZA, 0.0, 0.0, sky, np.zeros_like(sky),
                   np.zeros((0, 3)), np.zeros(0, int), np.zeros(0))


def test_infinite_louvers_diffuse_share_matches_their_sky_view_factor():
    """Under a sky of uniform radiance, a point at height z between black infinite louvers
    (spacing s, depth d) sees the sky up to the upper louver's edge, elevation atan((s - z) /
    d): view factor sin(atan((s - z) / d)) / 2 against the bare wall's 1 / 2 (the differential
    element to an infinite strip). Radiance's share within 2 points."""
    sky = _uniform_sky(SkySubdivision.TREGENZA.patches)
    split = seasons(sky.weather, SeasonRule.MONTHS)
    s, d, n = 1.0, 0.8, 40
    z = (np.arange(n) + 0.5) / n * s
    points = np.c_[np.zeros(n), np.zeros(n), z]
    normals = np.tile([0.0, -1.0, 0.0], (n, 1))
    settings = RadianceSettings(ambient_bounces=1, ambient_divisions=4096)
    bare = annual_irradiance(points, normals, sky, split, settings=settings)
    shaded = annual_irradiance(points, normals, sky, split, fins=_louvers(s, d), settings=settings)
    assert bare.by_source()["sky"] == pytest.approx(np.pi / 2 / 1000.0, rel=0.01)   # pi L / 2
    expected = np.sin(np.arctan((s - z) / d)).mean()
    assert abs(shaded.by_source()["sky"] / bare.by_source()["sky"] - expected) < 0.02
    assert 0.3 < expected < 0.7


def _toy_design(**annual):
    from torsal.pipeline.design_file import DesignSpec

    return DesignSpec.model_validate({
        "surface": {"generator": "flat_facade", "params": {"width": 3.0, "height": 2.0,
                                                           "nu": 7, "nv": 5}},
        "site": {**VIENNA, "timezone": "Europe/Vienna"},
        "sun": {"start": "2026-06-01", "end": "2026-06-02", "hours": [12, 16]},
        "fins": {"spacing": 0.5, "depth": 0.3},
        "annual": {"enabled": True, "points": 24, "ambient_bounces": 1,
                   "ambient_divisions": 128, **annual}})


def _stage_inputs(spec, tmp_path, left_out=()):
    """What the annual stage reads: mesh A facing the sun (south, -y), the sun, louvers of the
    design's depth every 0.5 m as the support structure, the fabrication's left-out fins."""
    from torsal.geometry.support import SupportStructure
    from torsal.pipeline.stage import StageInputs
    from torsal.pipeline.stages import sun_directions, surface_mesh

    v, f = surface_mesh(spec)
    if np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]).sum(0)[1] > 0:
        f = f[:, ::-1].copy()
    vec, w = sun_directions(spec)
    x, zs = np.linspace(-1.5, 1.5, 7), np.arange(0.0, 2.01, 0.5)
    a = np.array([[xi, 0.0, zi] for zi in zs for xi in x])
    edges = np.array([[r * 7 + k, r * 7 + k + 1] for r in range(len(zs)) for k in range(6)])
    structure = SupportStructure(a, a + [0.0, -0.3, 0.0], [], edges, np.zeros(len(edges), int))
    results = {"orient": {"vertices": v, "faces": f}, "sun": {"vectors": vec, "weights": w},
               "support": {"structure": structure},
               "fabrication": {"left_out_edges": list(left_out)}}
    return StageInputs(spec=spec, out=tmp_path, stage="annual", results=results, report={}), structure


def test_annual_stage_reports_bare_fins_and_devices(tmp_path):
    from torsal.pipeline.annual import run_annual

    spec = _toy_design()
    inp, structure = _stage_inputs(spec, tmp_path)
    out = run_annual(inp)
    r = out["report"]
    assert r["weather"]["source"] == "clear sky" and "Ineichen" in r["weather"]["description"]
    assert (r["ambient_bounces"], r["ambient_divisions"], r["sky"], r["sky_patches"]) == \
        (1, 128, "tregenza", 145)
    assert r["seasons"]["rule"] == "months"
    bare, fins = r["bare"], r["fins"]
    assert 0 < fins["annual_kwh_m2"] < bare["annual_kwh_m2"]
    f = fins["shading_factor"]
    assert 0 < f["f_sh_cooling"] < f["f_sh_heating"] < 1        # louvers: summer sun cut off
    assert f["cooling_gains_avoided_kwh_m2"] == pytest.approx(
        bare["cooling_kwh_m2"] - fins["cooling_kwh_m2"])
    assert sum(fins["monthly_kwh_m2"]) == pytest.approx(fins["annual_kwh_m2"])
    made = {n: d for n, d in r["devices"].items() if d.get("applicable", True)}
    assert "horizontal louvers" in made and "shading_factor" in made["horizontal louvers"]
    assert out["map"]["points"].shape == (24, 3) and out["map"]["fins"].shape == (24,)
    assert {k: (tmp_path / v).stat().st_size > 1000 for k, v in out["files"].items()} == \
        {"annual_map": True, "annual_months": True}
    # every fin left out by the fabrication: nothing shades, the glazing is bare
    inp, _ = _stage_inputs(_toy_design(devices=False), tmp_path,
                           left_out=range(len(structure.edges)))
    r = run_annual(inp)["report"]
    assert r["fins"]["shading_factor"]["f_sh_year"] == pytest.approx(1.0, rel=1e-6)
    assert r["devices"] == {}


def test_annual_stage_measures_the_rooms_daylight(tmp_path, monkeypatch):
    """With a [room]: each storey's sDA and ASE, bare and behind the louvers, which keep the
    direct sun off the work plane (a lower ASE). The room's closed blinds pass its
    ``shade_transmittance`` (here 20 %, not the default 5 %)."""
    import torsal.pipeline.annual as annual
    from torsal.pipeline.annual import run_annual
    from torsal.pipeline.report import _daylight_html

    passed, real = [], annual.daylight
    monkeypatch.setattr(annual, "daylight", lambda *a, **kw: passed.append(kw["blinds"])
                        or real(*a, **kw))
    spec = _toy_design(devices=False).model_copy(update={"room": RoomSpec(
        depth=3.0, height=2.0, storey_height=2.0, ambient_bounces=1, shade_transmittance=0.2)})
    inp, _ = _stage_inputs(spec, tmp_path)
    out = run_annual(inp)
    dl = out["report"]["daylight"]
    assert [b.transmittance for b in passed] == [0.2, 0.2]          # bare and the fins
    assert dl["shade_transmittance"] == 0.2 and "closed they pass 20%" in dl["standard"]
    assert (tmp_path / out["files"]["daylight_plans"]).stat().st_size > 1000
    assert dl["applicable"] and dl["storeys"] == [0.0]
    assert 0 < dl["fins"]["ase_all"] < dl["bare"]["ase_all"]
    assert dl["bare"]["points"] == 5 * 5 and len(dl["fins"]["sda"]) == 1
    # LM-83's blinds only take light away: its sDA is at most the room's without blinds,
    # and the blinds close in at most every occupied hour
    for name in ("bare", "fins"):
        d = dl[name]
        assert d["sda_all"] <= d["sda_unshaded_all"]
        assert d["sda_unshaded_all"] == pytest.approx(np.mean(d["sda_unshaded"]))
        h0, h1 = dl["occupied_hours"]
        assert all(0 <= h <= (h1 - h0) * 366 for h in d["blinds_hours"])
    assert "blinds" in dl["standard"] and "no blinds drawn (the fins" not in dl["standard"]
    # the figures a study's search may optimize are in the report under their names
    from torsal.study.study_file import ANNUAL_OBJECTIVE_KEYS
    from torsal.study.study_tasks import flatten

    flat = flatten({"light": {"annual": out["report"]}})
    assert all(isinstance(flat[k], float) for k in ANNUAL_OBJECTIVE_KEYS)
    assert "storey at 0.0" in _daylight_html(dl, ["torsal fins as built"])
    low = spec.model_copy(update={"room": RoomSpec(depth=3.0, height=2.8)})   # 3 m storeys
    inp, _ = _stage_inputs(low, tmp_path)
    assert "lower than a storey" in run_annual(inp)["report"]["daylight"]["reason"]


def test_annual_stage_reads_the_designs_epw(tmp_path):
    """With sun.epw the year is the file's and the seasons follow its temperatures."""
    from torsal.pipeline.annual import run_annual

    epw = tmp_path / "site.epw"
    write_synthetic_epw(epw, **VIENNA, tz_hours=1.0)
    spec = _toy_design(devices=False, points=8).model_copy(update={"sun": SunSpec(epw=epw)})
    inp, _ = _stage_inputs(spec, tmp_path)
    r = run_annual(inp)["report"]
    assert r["weather"] == {"source": "epw", "description": "EPW weather file site.epw",
                            "hours": 8760}
    assert r["seasons"]["rule"] == "temperature"
    assert 0 < r["fins"]["annual_kwh_m2"] < r["bare"]["annual_kwh_m2"]


def _greensboro_design(weather, **sun):
    """The toy design at Greensboro with ``sun.weather``."""
    spec = _toy_design(devices=False, points=8)
    return spec.model_copy(update={
        "site": spec.site.model_copy(update={**GREENSBORO, "timezone": "America/New_York"}),
        "sun": SunSpec(weather=weather, **sun)})


def test_annual_stage_reads_a_tmy3_year(tmp_path):
    """With sun.weather a TMY3 file: the year is the file's, its seasons its temperatures."""
    from torsal.pipeline.annual import run_annual

    inp, _ = _stage_inputs(_greensboro_design(GREENSBORO_TMY3), tmp_path)
    r = run_annual(inp)["report"]
    assert r["weather"] == {"source": "tmy3", "description": "TMY3 weather file 723170TYA.CSV",
                            "hours": 8760}
    assert r["seasons"]["rule"] == "temperature"
    assert 0 < r["fins"]["annual_kwh_m2"] < r["bare"]["annual_kwh_m2"]


def test_a_weather_file_far_from_the_site_is_refused(tmp_path):
    """Greensboro's year on a Vienna facade: the sun and the annual stages name both places;
    sun.allow_distant_weather lets it through."""
    from torsal.pipeline.annual import design_weather
    from torsal.pipeline.errors import DesignError
    from torsal.pipeline.stages import sun_directions

    far = _toy_design().model_copy(update={"sun": SunSpec(weather=GREENSBORO_TMY3)})
    for call, stage in ((sun_directions, "sun"), (design_weather, "annual")):
        with pytest.raises(DesignError) as err:
            call(far)
        text = str(err.value)
        assert err.value.stage == stage and err.value.key == "sun.weather"
        assert "GREENSBORO PIEDMONT TRIAD INT, NC at 36.10 N, 79.95 W" in text
        assert "[site] at 48.21 N, 16.37 E" in text and "sun.allow_distant_weather" in text
    allowed = far.model_copy(update={"sun": SunSpec(weather=GREENSBORO_TMY3,
                                                    allow_distant_weather=True)})
    assert len(sun_directions(allowed)[0]) > 100
    assert design_weather(allowed).latitude == 36.1          # the file's place, as asked
    # within a degree (a neighbouring town): the site's own weather
    near = _greensboro_design(GREENSBORO_TMY3)
    near = near.model_copy(update={"site": near.site.model_copy(update={"latitude": 35.3})})
    assert design_weather(near).place == "GREENSBORO PIEDMONT TRIAD INT, NC"
    # sun.epw is checked alike
    epw = tmp_path / "amsterdam.epw"
    write_synthetic_epw(epw, 52.30, 4.77, tz_hours=1.0)
    with pytest.raises(DesignError, match=r"sun\.epw = .*Synthetic, XXX at 52\.30 N, 4\.77 E"):
        design_weather(_toy_design().model_copy(update={"sun": SunSpec(epw=epw)}))


#: pvlib's other TMY3 sample: Sand Point, Alaska, a cloudy coast (DNI a quarter of its clear sky's)
SAND_POINT_TMY3 = GREENSBORO_TMY3.with_name("703165TY.csv")


@pytest.mark.parametrize("path", [SAND_POINT_TMY3, GREENSBORO_TMY3], ids=lambda p: p.name)
def test_a_measured_years_daylight_is_its_own(path):
    """The same south room (the examples' window: glazed from 0.9 to 2.7 m across its width, 6 m
    deep) under a measured typical year and under the clear-sky year of the same place. Direct
    sun: the measured year's clouds leave fewer hours of it on the work plane (ASE hours at most
    0.8 of the clear sky's), at both places. sDA without blinds: on Sand Point's cloudy coast
    less of the room reaches 300 lx for half the occupied hours than under its clear sky (93 %
    against 98 %); in sunnier Greensboro the clouded hours' brighter diffuse sky (DHI 78 against
    43 W/m^2 a year) makes up for the sun and sDA is level (99 % both): a measured year does not
    lower sDA by itself. LM-83's sDA, with its blinds: the clear sky's sun closes them in most
    occupied hours (Sand Point 3030 of 3650, Greensboro 2925), the measured year's in fewer
    (1421, 2099), so under the measured year more of the room is daylit (45 % against 21 %,
    37 % against 23 %)."""
    measured = weather_year(path)
    clear = clear_sky_year(measured.latitude, measured.longitude,
                           timezone=measured.utc_offset_hours, elevation=measured.elevation)
    settings = RadianceSettings(ambient_bounces=2, ambient_divisions=128)
    room = Room((-3.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), 6.0, 6.0, 3.0, 0.9, 2.7,
                transmittance=0.6, reflectance=(0.2, 0.5, 0.7))
    d = {name: daylight(room, sky_year(w, quantity=SkyQuantity.VISIBLE), settings=settings)
         for name, w in (("measured", measured), ("clear", clear))}
    assert d["measured"].hours_ase.mean() < 0.8 * d["clear"].hours_ase.mean()
    assert 0.5 < d["measured"].sda_unshaded
    assert d["measured"].blinds_hours < 0.8 * d["clear"].blinds_hours
    assert d["measured"].sda > d["clear"].sda + 0.1
    if path == SAND_POINT_TMY3:
        assert d["measured"].sda_unshaded < d["clear"].sda_unshaded
        assert d["measured"].hours_sda_unshaded.mean() < d["clear"].hours_sda_unshaded.mean()
    else:
        assert d["measured"].sda_unshaded == pytest.approx(d["clear"].sda_unshaded, abs=0.02)
        assert measured.dhi.mean() > 1.5 * clear.dhi.mean()


def test_a_search_on_annual_figures_needs_the_annual_stage(tmp_path):
    from torsal.study.study_file import StudyFileError, load_study_file

    design = ('surface = { generator = "flat_facade" }\n'
              'sun = { vectors = [[0, -1, 1]] }\nfins = { spacing = 0.5, depth = 0.3 }\n')
    study = ('base = "base.toml"\n[axes]\n"fins.depth" = { low = 0.2, high = 0.4 }\n'
             '[search]\ntrials = 4\nobjectives = { "light.annual.fins.cooling_kwh_m2" = "min", '
             '"light.view_out" = "max" }\n')
    (tmp_path / "base.toml").write_text(design)
    (tmp_path / "study.toml").write_text(study)
    with pytest.raises(StudyFileError, match=r"\[annual\] enabled"):
        load_study_file(tmp_path / "study.toml")
    (tmp_path / "base.toml").write_text(design + "[annual]\nenabled = true\n")
    spec = load_study_file(tmp_path / "study.toml")[0]
    assert "light.annual.fins.cooling_kwh_m2" in spec.search.objectives


def test_annual_stage_names_what_is_missing(tmp_path):
    from torsal.pipeline.annual import run_annual
    from torsal.pipeline.design_file import DesignSpec
    from torsal.pipeline.errors import DesignError

    no_site = DesignSpec.model_validate({
        "surface": {"generator": "flat_facade"}, "sun": {"vectors": [[0, -1, 1]]},
        "fins": {"spacing": 0.5, "depth": 0.3}, "annual": {"enabled": True}})
    inp, _ = _stage_inputs(no_site, tmp_path)
    with pytest.raises(DesignError, match="site"):
        run_annual(inp)
    inp, _ = _stage_inputs(_toy_design(season="temperature"), tmp_path)
    with pytest.raises(DesignError, match="annual.season"):
        run_annual(inp)


@pytest.fixture(scope="module")
def visible_sky(clear_weather):
    return sky_year(clear_weather, quantity=SkyQuantity.VISIBLE)


def _south_room(**kw):
    """6 m x 6 m x 3 m behind a south window wall (the plane y = 0, the room at y > 0),
    glazed across its width from 0.9 m to 2.4 m."""
    return Room((-3.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), 6.0, 6.0, 3.0, 0.9, 2.4, **kw)


def test_ase_of_a_box_room_counted_by_hand(visible_sky):
    """ASE through an open window, counted by hand: an occupied hour counts at a work-plane
    point when the ray to the sun leaves through the window's rectangle and the sun's direct
    illuminance on the horizontal work plane, 179 lm/W x its visible DNI x sin(elevation), is
    at least 1000 lx; a point is exposed past 250 such hours."""
    room = _south_room(transmittance=None)
    d = daylight(room, visible_sky, settings=RadianceSettings(ambient_bounces=1,
                                                              ambient_divisions=64))
    p, sun = d.points, visible_sky.sun_vectors
    t = -p[:, 1:2] / np.where(sun[:, 1] < 0, sun[:, 1], -1e-12)[None]       # to the plane y = 0
    x, z = p[:, :1] + t * sun[:, 0], p[:, 2:] + t * sun[:, 2]
    through = (sun[:, 1] < 0) & (np.abs(x) <= 3.0) & (z >= 0.9) & (z <= 2.4)
    lux = 179.0 * visible_sky.sun_dni * sun[:, 2]
    hours = occupied(visible_sky)[visible_sky.sun_hours]
    by_hand = (through & (lux >= 1000.0) & hours).sum(axis=1)
    assert np.abs(d.hours_ase - by_hand).max() <= 2
    assert d.ase == pytest.approx(np.mean(by_hand > 250))
    assert 0.2 < d.ase < 0.9 and d.occupied_hours == 3650            # 8:00-18:00, 365 days


def test_glazing_transmits_its_transmittance_at_normal_incidence(tmp_path):
    room = _south_room(transmittance=0.6, reflectance=(0.0, 0.0, 0.0))
    sensors = b"0 1 1.5 0 -1 0\n"
    coef = sun_coefficients(sensors, room.scene(), [[0.0, -1.0, 0.0]],
                            radiance=Radiance.bundled(), folder=tmp_path)
    assert coef[0, 0] == pytest.approx(0.6, abs=0.005)


def test_sda_grows_with_the_window(visible_sky):
    """A taller window lights more of the room to 300 lx for half the occupied hours."""
    settings = RadianceSettings(ambient_bounces=3, ambient_divisions=256)
    deep = dict(transmittance=0.6, reflectance=(0.2, 0.5, 0.7))
    small = daylight(Room((-3.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), 6.0, 9.0, 3.0,
                          1.8, 2.2, **deep), visible_sky, settings=settings)
    large = daylight(Room((-3.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), 6.0, 9.0, 3.0,
                          0.2, 2.9, **deep), visible_sky, settings=settings)
    assert small.sda < large.sda
    assert small.hours_sda.mean() < large.hours_sda.mean()
