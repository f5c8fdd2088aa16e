"""constraints.torsal_angle_between: which angle min_torsal_angle bounds, and report.json /
report.html giving both torsal angles, each named (issue 44)."""
from __future__ import annotations

import tomllib

import pytest

from torsal.design import Design
from torsal.pipeline import DEFAULT_PIPELINE
from torsal.cli import main
from torsal.pipeline.design_file import DesignFileError, DesignSpec, load_design_file
from torsal.pipeline.report import design_report_html

DESIGN = """
[surface]
generator = "facade_patch"
params = {{ nu = 7, nv = 6 }}
[sun]
vectors = [[0.3, -0.8, 0.5]]
[constraints]
min_torsal_angle = 60.0
{between}
[fins]
spacing = 1.5
depth = 0.4
"""


def spec(between: str = "") -> DesignSpec:
    return DesignSpec.model_validate(tomllib.loads(DESIGN.format(between=between)))


@pytest.fixture(scope="module")
def reports(tmp_path_factory):
    out = {}
    for name, line in (("default", ""), ("directions", 'torsal_angle_between = "directions"')):
        res = Design(spec(line)).run(tmp_path_factory.mktemp(name),
                                     pipeline=DEFAULT_PIPELINE.until("congruence"))
        out[name] = res.report
    return out


def test_the_default_bounds_the_planes_and_reports_both_angles(reports):
    c = reports["default"]["congruence"]
    assert c["torsal_angle_between"] == "planes"
    assert c["constraints"]["min_torsal_angle"]["angle"] == "planes"
    assert c["constraints"]["min_torsal_angle"]["measured"] == pytest.approx(c["min_torsal_plane_angle_deg"])
    assert c["min_torsal_plane_angle_deg"] >= 60.0 - 0.1
    assert c["min_torsal_angle_deg"] == c["min_torsal_plane_angle_deg"]      # the earlier key
    # on this facade the lines lean: the directions in the face are far closer than the planes
    assert c["min_torsal_direction_angle_deg"] < 50.0


def test_directions_bound_the_paper_angle(reports):
    c = reports["directions"]["congruence"]
    assert c["torsal_angle_between"] == "directions"
    m = c["constraints"]["min_torsal_angle"]
    assert m["angle"] == "directions" and m["n_missing"] == 0
    assert m["measured"] == pytest.approx(c["min_torsal_direction_angle_deg"])
    assert c["min_torsal_direction_angle_deg"] >= 60.0 - 0.1


def test_report_html_says_which_angle_a_number_is(reports):
    page = design_report_html(reports["directions"], {}, "t")
    assert ("min angle between the torsal directions in the face (deg) (bounded by "
            "min_torsal_angle)") in page
    assert "min angle at which the torsal planes (the fins) cross (deg)<" in page
    assert "min_torsal_angle (measured; angle between the torsal directions in the face; bound 60" in page
    plain = design_report_html(reports["default"], {}, "t")
    assert "min angle at which the torsal planes (the fins) cross (deg) (bounded by min_torsal_angle)" in plain


def test_a_bad_value_is_named_exit_2(tmp_path, capsys):
    path = tmp_path / "d.toml"
    path.write_text(DESIGN.format(between='torsal_angle_between = "normals"'))
    with pytest.raises(DesignFileError, match="torsal_angle_between"):
        load_design_file(path)
    assert main(["design", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "torsal_angle_between" in err and "Traceback" not in err
