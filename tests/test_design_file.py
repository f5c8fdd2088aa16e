"""Design files: every broken file gets a message naming the key or stage, exit status 2,
and nothing half-written."""
from pathlib import Path

import numpy as np
import pytest

from torsal.cli import main
from torsal.design import Design, dominant_light_direction, select_faces, select_vertices
from torsal.pipeline.design_file import DesignFileError, Region, load_design_file

GOOD = """
name = "test"
[surface]
generator = "facade_patch"
params = { nu = 9, nv = 5 }
[site]
latitude = 48.2
longitude = 16.4
timezone = "Europe/Vienna"
[sun]
start = "2026-07-01"
end = "2026-07-03"
hours = [13, 16]
[fins]
spacing = 1.5
depth = 0.4
"""


def _write(tmp_path, text, name="d.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_good_file_loads_with_defaults(tmp_path):
    spec = load_design_file(_write(tmp_path, GOOD))
    assert spec.fins.spacing == 1.5
    assert spec.material.thickness_mm == 3.0
    assert spec.goals.block is True
    assert spec.constraints.hyperbolic is True
    assert spec.metres_per_unit == 1.0


@pytest.mark.parametrize("edit, key, words", [
    (("[fins]", "[fins]\nspaceing = 2"), "fins.spaceing", "unknown key"),
    (("spacing = 1.5", 'spacing = "wide"'), "fins.spacing", "valid number"),
    (("spacing = 1.5", "spacing = -1"), "fins.spacing", "greater than 0"),
    (('generator = "facade_patch"', 'generator = "blob"'), "surface.generator", "facade_patch"),
    (("latitude = 48.2", "latitude = 148.2"), "site.latitude", "less than or equal to 90"),
    (('timezone = "Europe/Vienna"', 'timezone = "Mars/Base"'), "site.timezone", "unknown time zone"),
    (('hours = [13, 16]', 'hours = [16, 13]'), "sun", "h0 <= h1"),
    (("depth = 0.4", ""), "fins.depth", "missing"),
    (("spacing = 1.5", "spacing = [1.5, 3, 4.5]"), "fins.spacing", "a list of 3"),
    (("spacing = 1.5", "spacing = [1.5]"), "fins.spacing", "a list of 1"),
    (("depth = 0.4", "depth = [0.4, 0]"), "fins.depth", "greater than 0, not 0"),
    (("depth = 0.4", 'depth = [0.4, "deep"]'), "fins.depth", "valid number"),
])
def test_bad_values_name_the_key(tmp_path, edit, key, words):
    p = _write(tmp_path, GOOD.replace(*edit))
    with pytest.raises(DesignFileError) as exc:
        load_design_file(p)
    msg = str(exc.value)
    assert key in msg and words in msg, msg


def test_missing_mesh_and_bad_toml(tmp_path):
    p = _write(tmp_path, GOOD.replace('generator = "facade_patch"\nparams = { nu = 9, nv = 5 }',
                                      'mesh = "nowhere.obj"'))
    with pytest.raises(DesignFileError, match=r"surface.mesh: file not found: .*nowhere.obj"):
        load_design_file(p)
    with pytest.raises(DesignFileError, match="not valid TOML"):
        load_design_file(_write(tmp_path, "[fins\nspacing=1", "bad.toml"))
    with pytest.raises(FileNotFoundError):
        load_design_file(tmp_path / "absent.toml")
    both = GOOD.replace("[surface]", '[surface]\nmesh = "x.obj"')
    with pytest.raises(DesignFileError, match="exactly one of surface.mesh"):
        load_design_file(_write(tmp_path, both, "both.toml"))


def test_a_spacing_and_depth_per_family(tmp_path):
    """fins.spacing = [s0, s1] and fins.depth = [d0, d1] per torsal family; a number still
    means both."""
    spec = load_design_file(_write(tmp_path, GOOD.replace("spacing = 1.5", "spacing = [1.5, 3]")
                                   .replace("depth = 0.4", "depth = [0.4, 0.2]")))
    assert spec.fins.spacings == (1.5, 3.0) and spec.fins.depths == (0.4, 0.2)
    assert spec.fins.spacing == (1.5, 3.0)                  # as written, for the report
    same = load_design_file(_write(tmp_path, GOOD, "same.toml")).fins
    assert same.spacings == (1.5, 1.5) and same.depths == (0.4, 0.4)


@pytest.mark.parametrize("edit, words", [
    (("[fins]", "[fins]\nspaceing = 2"), "fins.spaceing"),
    (('generator = "facade_patch"\nparams = { nu = 9, nv = 5 }', 'mesh = "gone.obj"'), "surface.mesh"),
    (("spacing = 1.5", "spacing = [1.5, 3, 4.5]"), "fins.spacing is a list of 3"),
    (("depth = 0.4", "depth = [-0.4, 0.4]"), "fins.depth: Input should be greater than 0"),
])
def test_cli_exit_2_and_nothing_written(tmp_path, capsys, edit, words):
    p = _write(tmp_path, GOOD.replace(*edit))
    out = tmp_path / "out"
    assert main(["design", str(p), "--out", str(out)]) == 2
    assert words in capsys.readouterr().err
    assert not out.exists() or not any(out.iterdir())


def test_infeasible_constraint_names_the_stage(tmp_path, capsys):
    text = GOOD + "[constraints]\nhyperbolic_margin = 1e9\nmax_iter = 30\n"
    out = tmp_path / "out"
    assert main(["design", str(_write(tmp_path, text)), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "stage 'congruence' failed" in err
    # earlier stages' results are kept, no output files of later stages exist
    assert not (out / "report.json").exists() and not (out / "fins.step").exists()


def test_regions_and_light_reduction():
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 2, 2.0]])
    f = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 2]])
    assert select_vertices(Region(x=(0.5, 1.5)), v).tolist() == [1, 2]
    assert select_vertices(Region(x=(0.5, 1.5), vertices=[0]), v).tolist() == [0, 1, 2]
    assert select_faces(Region(z=(-1, 0.1)), v, f).tolist() == [0, 1]
    assert select_faces(Region(faces=[2]), v, f).tolist() == [2]
    with pytest.raises(ValueError, match="outside"):
        select_vertices(Region(vertices=[9]), v)
    with pytest.raises(ValueError):
        Region()
    # the dominant direction of a sun arc is its middle, signed like the light
    az = np.radians(np.linspace(-40, 40, 9))
    d = np.c_[np.sin(az), -np.cos(az), np.full(9, -0.5)]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    q = dominant_light_direction(d, np.ones(9))
    assert np.allclose(q, [0, -1 / np.sqrt(1.25), -0.5 / np.sqrt(1.25)], atol=0.05)
    assert np.allclose(dominant_light_direction(-d, np.ones(9)), -q)
    # weights pull it towards the heavier directions
    w = np.r_[np.full(4, 10.0), np.ones(5)]
    assert dominant_light_direction(d, w)[0] < q[0] - 0.05


def test_design_api_from_toml(tmp_path):
    d = Design.from_toml(_write(tmp_path, GOOD))
    assert d.spec.name == "test"
    assert Path(d.source).name == "d.toml"


@pytest.mark.parametrize("form, lifted", [(None, False), ("split", False), ("lift", True)])
def test_torsal_angle_form_reaches_the_optimizer(tmp_path, form, lifted):
    from torsal.geometry.surfaces import facade_patch
    from torsal.pipeline import congruence_problem

    extra = "" if form is None else f'\ntorsal_angle_form = "{form}"'
    spec = load_design_file(_write(tmp_path, GOOD + f"[constraints]\nmin_torsal_angle = 40{extra}\n"))
    v, f = facade_patch(nu=9, nv=5)
    p = congruence_problem(spec, v, f, np.array([[0.0, -0.8, 0.6]]), np.ones(1))
    term = p.registry.terms["min_torsal_angle"]
    # lift: 3 rows per face tied to lifted variables; split: 2 inequality rows per face
    assert term.lift is lifted
    assert len(term.elements) == (3 if lifted else 2) * len(f)


def test_unknown_torsal_angle_form_names_the_choices(tmp_path):
    p = _write(tmp_path, GOOD + '[constraints]\nmin_torsal_angle = 40\ntorsal_angle_form = "cones"\n')
    with pytest.raises(DesignFileError) as exc:
        load_design_file(p)
    assert "constraints.torsal_angle_form" in str(exc.value) and "lift" in str(exc.value)
