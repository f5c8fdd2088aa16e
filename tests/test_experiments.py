"""examples/experiments/: a user's own terms and constraints, run at small size; every
effect is checked on the geometry (angles between vectors), not on the solver's report."""
import importlib.util
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent.parent / "examples" / "experiments"


def _load(name):
    spec = importlib.util.spec_from_file_location(name, HERE / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_twist_limit(capsys):
    r = _load("twist_limit").main(["--nu", "13", "--nv", "9"])
    assert "twist limit" in capsys.readouterr().out
    assert r["success"] and r["worst_excess_free_deg"] > 1.0 and r["worst_excess_deg"] <= 1e-3
    assert r["vertical_with_term"] < r["vertical_without_term"] - 0.5     # the user's term acts


def test_sun_path_cone(capsys):
    r = _load("sun_path_cone").main(["--nu", "13", "--nv", "9", "--theta", "4"])
    assert "sun path" in capsys.readouterr().out
    assert r["success"] and r["worst_free_deg"] > 4.1 and r["worst_deg"] <= 4.0 + 1e-3


@pytest.mark.parametrize("theta", [40.0])
def test_viewer_cone(capsys, theta):
    r = _load("viewer_cone").main(["--nu", "13", "--nv", "9", "--theta", str(theta)])
    assert "viewer" in capsys.readouterr().out
    assert r["success"] and r["worst_free_deg"] > theta + 5 and r["worst_deg"] <= theta + 1e-3
    assert r["shade"] >= r["shade_free"]          # opening to the viewer costs shade
