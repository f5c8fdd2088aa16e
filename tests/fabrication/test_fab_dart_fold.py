"""A strip split at a sharp fold where the panel before the fold is a dart (sheared, its corner
``b`` on the fold line reflex; the case of test_fab_dart_plate.py, at a fold butt).

The fold butt took the direction from the fold line into the previous panel from that panel's
centre, which for such a dart lies across the line: the bracket's leg on the previous panel
pointed off it (a corner of 60 degrees instead of 120) and no bracket fitted ("the panels are
too small for a bracket"), leaving the joint unfastened. The direction is now the side the
panel lies on along the line (:func:`torsal.fabrication.joints.toward_panel`).
"""
from __future__ import annotations

import warnings

import numpy as np
from shapely.geometry import Point, Polygon

from torsal.fabrication import FinSystem, JointKind, verify_assembly
from torsal.fabrication.builder.ends import CONNECTOR_GAP
from torsal.fabrication.joints import toward_panel
from torsal.geometry.support import SupportStructure

T, C = 3.0, 0.5
C60, S60 = 0.5, np.sqrt(3) / 2


def dart_fold() -> SupportStructure:
    """Node 0 -> 1 -> 2 of one strip (metres): the panel 0-1 lies in z = 0 on the -y side of
    node line 1 (x axis, 0.4 m) but its far line 0 runs from (0.3, -0.3) to (0.8, 0.4), across
    the line's extension (its centre at y = +0.025); the panel 1-2 folds up by 60 degrees into
    +y."""
    a = np.array([[0.3, -0.3, 0], [0, 0, 0], [0, 0.3 * C60, 0.3 * S60]])
    b = np.array([[0.8, 0.4, 0], [0.4, 0, 0], [0.4, 0.3 * C60, 0.3 * S60]])
    return SupportStructure(a, b, [], np.array([[0, 1], [1, 2]]), np.array([0, 0]))


def test_the_panel_before_the_fold_is_a_dart_whose_centre_is_across_the_line():
    s = dart_fold()
    dart = np.array([s.vertices_a[0], s.vertices_a[1], s.vertices_b[1], s.vertices_b[0]]) * 1000
    assert Polygon(dart[:, :2]).is_valid
    assert dart.mean(axis=0)[1] > 0                              # the centre: +y
    assert Polygon(dart[:, :2]).contains(Point(200, -1))         # the panel along the line: -y
    v = toward_panel(np.array([0, 1.0, 0]), dart, False)
    assert v[1] == -1.0


def test_a_bracket_joins_the_fold_with_its_leg_on_the_dart():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fs = FinSystem(dart_fold(), thickness=T, clearance=C, max_fold_angle=30, tabs=False)
    prev, nxt = fs.plates
    assert prev.ends[1] == "fold" and nxt.ends[0] == "fold"
    [j] = [j for j in fs.joints if j.kind == JointKind.BUTT_BRACKET]
    assert set(j.parts[:2]) == {prev.name, nxt.name}
    assert j.connector is not None, fs.unconnected_joints
    assert abs(j.angle - 120.0) < 1e-6                          # between the two panels
    [c] = [p for p in fs.parts if p.name == j.connector]
    # its leg on the dart lies over the dart (on the -y side of the line, inside the outline);
    # its mid-plane half the bracket's thickness and the gap off the plate's face
    dart = Polygon(prev.panels[-1][:, :2])
    leg = min(c.panels, key=lambda q: np.ptp(q[:, 2]))
    assert all(dart.contains(Point(x, y)) for x, y in leg[:, :2])
    assert np.allclose(np.abs(leg[:, 2]), 0.5 * T + 0.5 * T + CONNECTOR_GAP * T)
    r = verify_assembly(fs, workers=1)
    assert r.buildable and r.interfering_pairs == 0 and not r.blocked, r.problems()
