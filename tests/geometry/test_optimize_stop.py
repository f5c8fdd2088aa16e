"""The design tolerance (``solve(stop="design")``, the default) against full convergence
(issue 44: stop where further digits change nothing the user gets, and say how close to
converged the answer is)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from torsal.geometry import Congruence, CongruenceProblem
from torsal.geometry.optimize import alm
from torsal.geometry.optimize.result import Stop, StopReason
from torsal.geometry.surfaces import canopy, facade_patch

SUN = [0.3, -0.8, -0.5]


def _shading(c: Congruence, angle: float = 60.0) -> CongruenceProblem:
    """A miniature of Fig. 12 row 9: fair, fair_torsal 10, lines perpendicular to a noon sun,
    parallel to a low one on a few vertices, hyperbolic, torsal planes at 60 degrees or more.
    Its energies settle well above zero (as row 9's, 0.017)."""
    return (CongruenceProblem(c).fair().fair_torsal(weight=10).perpendicular([0, 0, -1.0])
            .parallel([0.3, 0.2, -1.0], vertices=np.arange(5), weight=0.1).hyperbolic().min_torsal_angle(angle))


#: the tests that read ``both`` run on one xdist worker (make test's --dist loadgroup), so its
#: two solves run once: split over the two workers they ran twice (11.9 and 11.8 s of setup
#: in a fresh clone's make test)
SHARED_SOLVES = pytest.mark.xdist_group("optimize-stop-both")


@pytest.fixture(scope="module")
def both():
    c = Congruence.from_normals(canopy(nu=11, nv=11))
    return {stop: _shading(c).solve(stop=stop) for stop in Stop}


@SHARED_SOLVES
def test_the_design_tolerance_ends_before_convergence_where_the_energy_has_settled(both):
    d, c = both[Stop.DESIGN], both[Stop.CONVERGED]
    assert d.convergence.reason is StopReason.DESIGN, d.status
    assert c.convergence.reason is StopReason.CONVERGED, c.status
    assert d.success and d.feasible and "design tolerance" in d.status
    assert d.iterations < c.iterations
    # what the user gets: the energy to a tenth of a percent, the bound as measured
    assert d.objective == pytest.approx(c.objective, rel=1e-3)
    assert d.min_torsal_angle_deg >= 60.0 - 0.1
    assert d.convergence.stop is Stop.DESIGN and c.convergence.stop is Stop.CONVERGED


@SHARED_SOLVES
def test_the_design_rule_holds_on_the_recorded_iterates(both):
    """The rule read back from the solve's own history, not from the solver's bookkeeping:
    the answer is measured feasible, and the objective moved by at most DESIGN_DECREASE over
    the last DESIGN_WINDOW Newton steps; the decrement reported is within its bound."""
    d = both[Stop.DESIGN]
    h = d.history
    assert h[-1].feasible and h[-1].objective == pytest.approx(d.objective, rel=1e-12)
    window = h[-1 - alm.DESIGN_WINDOW].objective - h[-1].objective
    assert abs(window) <= alm.DESIGN_DECREASE * abs(h[-1].objective)
    assert d.convergence.recent_decrease == pytest.approx(window / h[-1].objective, rel=1e-9)
    assert 0 < d.convergence.newton_decrement <= alm.DESIGN_DECREMENT


def test_a_design_whose_energies_reach_zero_is_solved_to_convergence():
    """The design tolerance is relative to the energy itself: on a facade whose energies go to
    zero (normal, fair, perpendicular at a 60 degree bound) the last 1e-3 of the start's energy
    is most of the answer's, and stopping there left the lines elsewhere (the smallest angle of
    the torsal directions 56 against 18 degrees), so both rules give the converged answer."""
    c = Congruence.from_normals(facade_patch(nu=7, nv=6))
    make = (lambda: CongruenceProblem(c).normal().fair().perpendicular(SUN).min_torsal_angle(60))
    d, full = make().solve(), make().solve(stop="converged")
    assert d.convergence.reason is StopReason.CONVERGED
    assert d.iterations == full.iterations and d.objective == full.objective


def test_the_convergence_record_says_why_a_solve_ended():
    c = Congruence.from_normals(canopy(nu=7, nv=7))
    r = _shading(c).solve(max_iter=3)
    assert r.convergence.reason is StopReason.ITERATION_LIMIT and not r.success
    d = json.loads(json.dumps(r.convergence.as_dict()))
    assert d == {"stop": "design", "reason": "iteration limit",
                 "newton_decrement": r.convergence.newton_decrement,
                 "recent_decrease": r.convergence.recent_decrease}
    assert d["recent_decrease"] is None          # fewer Newton steps than the window
    ip = CongruenceProblem(c).normal().fair().perpendicular(SUN).solve(solver="ipopt")
    assert ip.convergence.reason is StopReason.CONVERGED and ip.convergence.newton_decrement is None
    with pytest.raises(ValueError, match="stop"):
        _shading(c).solve(stop="soon")


def test_rows_still_out_when_the_energy_has_settled_get_their_penalties_raised(monkeypatch):
    """SETTLED_GAMMA: the miniature at a 50 degree bound, solved by the inner minimizations of
    before issue 44's model-guided passes (40 Newton steps each, the passes' last step taken
    whole), settles (decrement and recent decrease within the design tolerance) at Newton step
    56 with 8 rows still out of their bounds; their penalties grow there, and the answer is
    measured feasible at the design tolerance with the converged answer's energy (to a tenth of
    a percent) and the bound as measured. (Today's inner minimizations reach this miniature's
    bound before its energy settles, at 40-70 degrees: the rule is not needed there.)"""
    monkeypatch.setattr(alm, "INNER_MAX", 40)
    monkeypatch.setattr(alm, "PREDICT_MODEL", False)
    c = Congruence.from_normals(canopy(nu=11, nv=11))
    d, full = _shading(c, 50).solve(), _shading(c, 50).solve(stop="converged")
    assert d.counts["tightened"] > 0 and full.counts["tightened"] == 0     # the design tolerance's only
    assert d.convergence.reason is StopReason.DESIGN and d.success and d.feasible, d.status
    assert d.objective == pytest.approx(full.objective, rel=1e-3)
    assert d.min_torsal_angle_deg >= 50.0 - 0.1
    # the rule read back from the history: the answer is the last iterate, feasible, and the
    # objective moved by at most DESIGN_DECREASE over the last DESIGN_WINDOW Newton steps
    h = d.history
    assert h[-1].feasible and abs(h[-1 - alm.DESIGN_WINDOW].objective - h[-1].objective) <= (
        alm.DESIGN_DECREASE * abs(h[-1].objective))
