"""report.json's congruence.convergence: the stopping rule, why the solve ended and how close to
converged the design is (issue 44), and report.html's rows for it."""
from __future__ import annotations

import json
import tomllib

import pytest

from torsal.design import Design
from torsal.geometry.optimize import STOPS, Stop, StopReason
from torsal.pipeline import DEFAULT_PIPELINE
from torsal.pipeline.design_file import DesignSpec
from torsal.pipeline.report import design_report_html

DESIGN = """
[surface]
generator = "canopy"
params = { nu = 11, nv = 11 }
[sun]
vectors = [[0.2, -0.3, 0.9]]
[weights]
norm = 0
fair = 1
fair_torsal = 10
perp = 1
[constraints]
hyperbolic = true
min_torsal_angle = 60
[fins]
spacing = 1.5
depth = 0.4
"""


#: the module's tests share its design run (8 s of setup): on one xdist worker
#: (make test's --dist loadgroup) it is made once; tests split over the two workers
#: would make it twice
pytestmark = pytest.mark.xdist_group("congruence-convergence-report")


@pytest.fixture(scope="module")
def congruence(tmp_path_factory):
    spec = DesignSpec.model_validate(tomllib.loads(DESIGN))
    res = Design(spec).run(tmp_path_factory.mktemp("conv"), pipeline=DEFAULT_PIPELINE.until("congruence"))
    return res.report["congruence"]


def test_the_report_says_how_close_to_converged_the_design_is(congruence):
    conv = json.loads(json.dumps(congruence["convergence"]))     # JSON as written
    assert conv["stop"] == Stop.DESIGN.value and conv["stop"] in STOPS
    assert conv["reason"] in {r.value for r in StopReason}
    # the augmented Lagrangian answered (a torsal-angle bound): its last decrement is there
    assert congruence["solver"].endswith("alm")
    assert conv["newton_decrement"] is not None and conv["newton_decrement"] >= 0
    # what ended the solve is the status's, in the report's words
    ended = {StopReason.DESIGN.value: "design tolerance", StopReason.CONVERGED.value: "converged"}
    assert ended[conv["reason"]] in congruence["status"]
    assert congruence["converged"] is True


def test_report_html_shows_the_stopping_rule(congruence):
    html = design_report_html({"congruence": congruence}, {}, "t")
    assert "solve ended by (stopping rule)" in html
    assert f"{congruence['convergence']['reason']} (design)" in html
    assert "last Newton decrement (relative)" in html
