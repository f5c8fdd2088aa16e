"""A part butted against a plate whose panel at the node is a dart (issue 25: example 7c at
700dfc6, F1-S009-P01 overlapping F0-S000-P00 by 10.7 mm3 at node 84, and blocked).

The T junction is that of example 7c, nodes 1, 84, 91 and 187 of its support structure (mm off
node 84's ``a``, rounded to 0.1 mm): row W (family 0, nodes 1-84-91) folds 21 degrees at node
84; column P (family 1, 84-187) ends there and is butted against W. W's panel 84-91 is sheared
along the node line so far that its far node line (91) runs across the extension of node line
84: its corner ``b_84`` is reflex (a dart), and the panel's centre lies on the other side of
node line 84 than the panel does along it. The butt trim took each panel's side from its centre
and so treated P's end corners there as standing off the plate's convex corner, clear of both
panels, while they stood 0.1 mm inside that panel's half thickness.
"""
from __future__ import annotations

import warnings

import numpy as np
from shapely.geometry import Point, Polygon

from torsal.fabrication import FinSystem, JointKind, verify_assembly
from torsal.fabrication.model import _miter, quad_normals
from torsal.geometry.support import SupportStructure

T, C = 3.0, 0.5
#: node: (a, b) in mm off example 7c's a_84
NODES = {1: ((-310.2, 46.3, -127.3), (44.6, -64.0, 20.3)),
         84: ((0.0, 0.0, 0.0), (361.4, -68.3, 148.8)),
         91: ((635.8, -84.1, 275.4), (983.5, -249.0, 381.1)),
         187: ((-23.2, 167.4, 638.4), (334.4, 103.9, 801.2))}


def dart_t() -> SupportStructure:
    """The T junction of the module text (metres; nodes 0-3 are 7c's 1, 84, 91, 187)."""
    a = np.array([NODES[v][0] for v in (1, 84, 91, 187)]) / 1000
    b = np.array([NODES[v][1] for v in (1, 84, 91, 187)]) / 1000
    return SupportStructure(a, b, [], np.array([[1, 0], [2, 1], [3, 1]]), np.array([0, 0, 1]))


def _in_plane(quad: np.ndarray):
    """2D coordinates in the plane of ``quad`` (4, 3): a function of (k, 3) points."""
    n = quad_normals(quad[None])[0]
    e1 = quad[3] - quad[0]
    e1 = e1 / np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    return lambda x: np.c_[(x - quad[0]) @ e1, (x - quad[0]) @ e2]


def test_the_panel_is_a_dart_whose_centre_is_across_the_node_line():
    s = dart_t()
    a, b = s.vertices_a * 1000, s.vertices_b * 1000
    dart = np.array([a[1], a[2], b[2], b[1]])
    flat = _in_plane(dart)
    poly = Polygon(flat(dart))
    assert poly.is_valid                                    # a simple quad, not a bow-tie
    mid, line = 0.5 * (a[1] + b[1]), (b[1] - a[1]) / np.linalg.norm(b[1] - a[1])
    centre = dart.mean(axis=0) - mid
    side = centre - (centre @ line) * line
    side = side / np.linalg.norm(side)
    # 1 mm off the node line's middle towards the centre is outside the panel, the other way in
    towards, away = flat(np.array([mid + side, mid - side]))
    assert not poly.contains(Point(towards)) and poly.contains(Point(away))


def test_an_end_butted_against_a_dart_panel_clears_it_and_goes_in():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fs = FinSystem(dart_t(), thickness=T, clearance=C)
    [w] = [p for p in fs.plates if p.name.startswith("F0")]
    [p] = [q for q in fs.plates if q.name.startswith("F1")]
    assert fs.coplanar_panels == [] and fs.untrimmed_joints == []
    [butt] = [j for j in fs.joints if j.kind == JointKind.BUTT_BRACKET]
    assert set(butt.parts[:2]) == {w.name, p.name} and butt.connector is not None

    # P's end face (its corners t/2 along the end mitre either way) against W's two panels at
    # node 84: a corner on a panel's side of W's mitre plane (the bisector of the fold, where
    # W's solid changes from one panel to the other) clears that panel's mid-plane by t/2 + c/2
    h, gap = 0.5 * T, 0.5 * (T + C)
    q, m_end = p.panels[0], p.miters[0]
    face = np.r_[q[[0, 3]] + h * m_end, q[[0, 3]] - h * m_end]
    n = quad_normals(w.panels[:2])
    pa, line = w.panels[0][1], w.panels[0][2] - w.panels[0][1]
    mitre = np.cross(line, _miter(n[0], n[1]))
    # the dart (panel 1) lies on its side of the mitre plane: a point inside it near the line
    inside = w.panels[1][[0, 3]].mean(axis=0) + 0.05 * (w.panels[1][1] - w.panels[1][0])
    mitre = mitre if (inside - pa) @ mitre > 0 else -mitre
    on_dart = (face - pa) @ mitre > 0
    assert on_dart.any()                    # the case of this test: the end runs past the fold
    for k, sel in ((1, on_dart), (0, ~on_dart)):
        off = np.abs((face[sel] - pa) @ n[k])
        assert (off >= gap - 1e-6).all(), (k, off)

    r = verify_assembly(fs, workers=1)
    assert r.buildable and r.interfering_pairs == 0 and not r.blocked, r.problems()
