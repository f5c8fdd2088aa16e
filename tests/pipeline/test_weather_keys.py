"""The design file's weather keys: sun.weather (EPW, TMY3, TMY2) beside sun.epw, paths relative
to the design file, and the example that runs on a measured year."""
from __future__ import annotations

import shutil
from pathlib import Path

import pvlib
import pytest

from torsal.pipeline.design_file import DesignFileError, load_design_file, validate_design

DATA = Path(pvlib.__file__).parent / "data"
EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "weather" / "greensboro_facade.toml"
BASE = ('surface = { generator = "flat_facade" }\nfins = { spacing = 0.5, depth = 0.3 }\n'
        '[site]\nlatitude = 25.8\nlongitude = -80.27\ntimezone = "America/New_York"\n')


def test_sun_weather_is_a_sun_source_of_its_own():
    base = {"surface": {"generator": "flat_facade"}, "fins": {"spacing": 0.5, "depth": 0.3}}
    spec = validate_design({**base, "sun": {"weather": "w.tm2"}})
    assert spec.sun.weather_file == Path("w.tm2") and spec.sun.weather_key == "sun.weather"
    spec = validate_design({**base, "sun": {"epw": "w.epw"}})
    assert spec.sun.weather_file == Path("w.epw") and spec.sun.weather_key == "sun.epw"
    assert not spec.sun.allow_distant_weather
    with pytest.raises(DesignFileError, match="sun.weather or sun.epw, not both"):
        validate_design({**base, "sun": {"weather": "w.csv", "epw": "w.epw"}})
    with pytest.raises(DesignFileError, match="exactly one of"):
        validate_design({**base, "sun": {"weather": "w.csv", "vectors": [[0, -1, 1]]}})


def test_sun_weather_is_read_relative_to_the_design_file(tmp_path):
    shutil.copyfile(DATA / "12839.tm2", tmp_path / "miami.tm2")
    (tmp_path / "d.toml").write_text(BASE + '[sun]\nweather = "miami.tm2"\n')
    spec = load_design_file(tmp_path / "d.toml")
    assert spec.sun.weather == tmp_path / "miami.tm2"
    (tmp_path / "e.toml").write_text(BASE + '[sun]\nweather = "nowhere.csv"\n')
    with pytest.raises(DesignFileError, match=r"sun\.weather: file not found: .*nowhere\.csv"):
        load_design_file(tmp_path / "e.toml")


def test_a_variant_and_a_freecad_job_find_the_weather_file(tmp_path):
    """A study's variant and a FreeCAD job write the design file elsewhere: sun.weather goes
    with them as an absolute path, as sun.epw and surface.mesh do."""
    from torsal.pipeline.design_file import absolute_file_paths    # what both call

    data = {"sun": {"weather": "w.csv"}}
    absolute_file_paths(data, tmp_path)
    assert data["sun"]["weather"] == str((tmp_path / "w.csv").resolve())


def test_the_measured_year_example_loads_and_takes_its_sun_from_the_file():
    """examples/weather/greensboro_facade.toml: the TMY3 file beside it, [site] at its station
    (the distance check passes), its hot, sunny afternoons the design sun."""
    from torsal.pipeline.annual import design_weather
    from torsal.pipeline.stages import sun_directions

    spec = load_design_file(EXAMPLE)
    assert spec.sun.weather == EXAMPLE.parent / "723170TYA.CSV"
    assert spec.annual.enabled and spec.room is not None
    vectors, weights = sun_directions(spec)
    assert 250 < len(vectors) < 350 and (weights >= 300).all()
    weather = design_weather(spec)
    assert weather.source.value == "tmy3" and weather.place.startswith("GREENSBORO")
