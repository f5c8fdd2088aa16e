"""A strip that folds back onto itself at a node, and a bracket on a panel whose centre lies
near the node line (issue 42: the two faults that left example 7c unbuildable at full size).

* 7c's F1-S000 starts with an 18.7 mm panel folded back 169.5 degrees onto the next one (under
  ``MITER_LIMIT``, so it was kept and split off as a part of its own); a plate of the other
  family carries both parts on flat, so both ends were trimmed against that plate only and the
  two parts overlapped by 7,773 mm^3. Of such a panel only ``width - t / sin(180 - fold)``
  lies outside the other plate; where that is narrower than ``min_panel_width`` it is dropped.
* Bracket C-N0200-1 lay on a dart panel whose centre is 2 mm off the node line: the direction
  into it, taken towards that centre, tilted 0.45 degrees out of the panel's plane, and the
  leg's free edge stood 0.06 mm inside the plate (6 mm^3). A leg now lies flat on its plate.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from torsal.fabrication import FinSystem, verify_assembly
from torsal.fabrication.builder.strips import folded_back_reach
from torsal.fabrication.joints import bracket_panels
from torsal.fabrication.model import quad_normals
from torsal.geometry.support import SupportStructure

T, C = 3.0, 0.5
FOLD = 169.5           # degrees, as at 7c's node 86
DEPTH = 0.4            # m


def folded_strip(width_mm: float) -> SupportStructure:
    """One family-1 strip of two panels on vertical node lines: node 1 at the origin, node 2
    400 mm along x, node 0 ``width_mm`` from node 1 at ``180 - FOLD`` degrees to x, so that
    panel 0-1 is folded back ``FOLD`` degrees onto panel 1-2 (metres)."""
    back = np.radians(180.0 - FOLD)
    a = np.array([[np.cos(back), np.sin(back), 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    a[0] *= width_mm / 1000
    a[2] = [0.4, 0.0, 0.0]
    return SupportStructure(a, a + [0, 0, DEPTH], [], np.array([[0, 1], [1, 2]]), np.array([1, 1]))


def test_the_reach_of_a_fold_back_is_the_thickness_over_the_sine_of_the_angle_between():
    # a point r from the node line in one mid-plane is r sin(180 - fold) off the other's
    assert folded_back_reach(150.0, 3.0) == pytest.approx(6.0, rel=1e-12)
    assert folded_back_reach(FOLD, T) == pytest.approx(T / np.sin(np.radians(10.5)), rel=1e-12)
    assert folded_back_reach(90.0, T) == 0.0 and folded_back_reach(30.0, T) == 0.0


def _build(width_mm: float) -> FinSystem:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return FinSystem(folded_strip(width_mm), thickness=T, clearance=C)


def test_a_narrow_panel_folded_back_onto_its_neighbour_is_dropped_and_the_rest_builds():
    # 7c's case: 18.7 mm wide, 16.5 mm of it inside the next plate, 2.2 mm (< 3 mm) outside
    reach = folded_back_reach(FOLD, T)
    assert reach < 18.7 < reach + 3.0
    fs = _build(18.7)
    assert [(e, round(w, 1)) for _, e, w in fs.dropped_panels] == [(0, 18.7)]
    [p] = fs.plates
    assert len(p.panels) == 1 and sorted(p.nodes.tolist()) == [1, 2]
    r = verify_assembly(fs, workers=1)
    assert r.buildable, r.problems()


def test_a_panel_folded_back_with_a_fin_outside_the_other_plate_is_kept():
    # 40 mm wide: 23.5 mm of it stands outside the next plate, a fin worth making
    fs = _build(40.0)
    assert fs.dropped_panels == []
    assert sum(len(p.panels) for p in fs.plates) == 2


def test_a_bracket_leg_lies_flat_on_its_plate_when_the_direction_into_it_tilts():
    # plate 1 is z = 0 (normal +z towards the bracket), plate 2 is x = 0 (normal +x); the
    # node line is the y axis. The direction into plate 1 tilts 0.45 deg out of its plane, as
    # the direction to a dart's centre 2 mm off the node line did on 7c
    tilt = np.radians(0.45)
    v1 = np.array([np.cos(tilt), 0.0, np.sin(tilt)])
    n1, n2, v2 = np.array([0, 0, 1.0]), np.array([1.0, 0, 0]), np.array([0, 0, 1.0])
    q = bracket_panels(np.zeros(3), np.array([0, 200.0, 0]), (n1, v1), (n2, v2), T, 12.0)
    # leg 1's mid-surface is T off plate 1's mid-plane at the bend and at the free edge alike
    assert q[0][:, 2] == pytest.approx(np.full(4, T), abs=1e-12)
    assert q[1][:, 0] == pytest.approx(np.full(4, T), abs=1e-12)
    assert abs(quad_normals(q[:1])[0] @ n1) == pytest.approx(1.0, abs=1e-12)
    # the legs keep their length, square to the bend
    assert np.linalg.norm(q[0][0] - q[0][1]) == pytest.approx(12.0, rel=1e-12)
