"""Butted ends whose edges meet the plate at a few degrees are trimmed back along it and kept
(issue 27: until 2026-11 every end under 11.5 degrees was left out, 103 of example 9's 867
panels), where their bracket still fits; else they are left out and named, never kept unfastened.

The constructed T junction (metres, ``a`` at z = 0 ... the node lines run along z): row W
(family 0, nodes 0-1-2 along x at y = 0) passes node 1; column P (family 1, nodes 1-3-4) ends
at node 1 and is butted against W. P's plane holds the z axis and ``w`` = (cos 20, sin 20, 0)
deg: it crosses W's at 20 degrees, but its end panel is sheared (node 3 stands ``rise`` up the
z axis), so its ``a`` and ``b`` edges meet W at ``asin(sin 20 sin phi)``, phi the edge's angle
to the node line.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from torsal.fabrication import FinSystem, JointKind, verify_assembly
from torsal.fabrication.joints import BRACKET_TRIM_SINE, MIN_TRIM_SINE, _Untrimmable, butt_trim
from torsal.geometry.support import SupportStructure

T, C = 3.0, 0.5
THETA = np.radians(20.0)


def sheared_t(*, run: float, rise: float, depth: float) -> SupportStructure:
    """The T junction of the module text: P's end panel runs ``run`` along ``w`` and ``rise``
    along z from node 1 to node 3, then 0.2 m on along ``w`` to node 4; node lines ``depth``
    long along z."""
    w = np.array([np.cos(THETA), np.sin(THETA), 0.0])
    z = np.array([0.0, 0.0, 1.0])
    a = np.array([(-0.3, 0.0, 0.0), (0.0, 0.0, 0.0), (0.3, 0.0, 0.0),
                  tuple(run * w + rise * z), tuple((run + 0.2) * w + rise * z)])
    return SupportStructure(a, a + depth * z, [], np.array([[0, 1], [1, 2], [1, 3], [3, 4]]),
                            np.array([0, 0, 1, 1]))


def edge_sine(run: float, rise: float) -> float:
    """Sine of the angle P's end-panel edges meet W's plane at."""
    return run * np.sin(THETA) / np.hypot(run, rise)


def _build(s):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return FinSystem(s, thickness=T, clearance=C, tabs=False)   # (the ends' brackets)


def test_a_sheared_end_at_9_degrees_is_trimmed_along_the_plate_and_kept():
    run, rise, depth = 0.1, 0.2, 0.3
    sine = edge_sine(run, rise)
    assert MIN_TRIM_SINE < sine < BRACKET_TRIM_SINE            # 8.8 deg: the case of this test
    s = sheared_t(run=run, rise=rise, depth=depth)
    # the earlier limit could not trim it (the panel was left out)
    quad = np.array([s.vertices_a[1], s.vertices_a[3], s.vertices_b[3], s.vertices_b[1]]) * 1000
    walls = [(np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0])),
             (np.array([0.0, 1.0, 0.0]), np.array([-1.0, 0.0, 0.0]))]
    gap, h = 0.5 * (T + C), 0.5 * T
    with pytest.raises(_Untrimmable, match="meets the plate at 8.8 deg"):
        butt_trim(quad, True, walls, np.zeros(3), gap, h, min_sine=BRACKET_TRIM_SINE)
    fs = _build(s)
    assert fs.coplanar_panels == [] and fs.n_panels == 4
    [p] = [q for q in fs.plates if q.name.startswith("F1")]
    # its end face is clear of W's mid-plane (y = 0) by the gap: the a corner moved along the
    # edge by (gap + the end face's reach) / sine, far more than a square crossing would
    end = p.panels[0][[0, 3]]
    assert end[:, 1].min() >= gap - 1e-6
    moved = np.linalg.norm(p.panels[0][0])
    assert moved > gap / sine and moved < 0.5 * np.hypot(run, rise) * 1000
    # fastened: a bracket with its bolts, no joint without a connector
    [butt] = [j for j in fs.joints if j.kind == JointKind.BUTT_BRACKET]
    assert butt.connector is not None and fs.unconnected_joints == []
    assert len(fs.part(butt.connector).holes) >= 2
    r = verify_assembly(fs, workers=1)
    assert r.buildable and r.interfering_pairs == 0 and not r.blocked, r.problems()


def test_a_sheared_end_with_no_room_for_its_bracket_is_left_out_and_named():
    # the same T, sheared so far (phi 9.5 deg, edges at 3.2 deg) on a node line so short that
    # the trim takes the panel where the bracket's leg would lie: not kept unfastened
    run, rise, depth = 0.05, 0.3, 0.1
    assert MIN_TRIM_SINE < edge_sine(run, rise) < BRACKET_TRIM_SINE
    fs = _build(sheared_t(run=run, rise=rise, depth=depth))
    assert fs.unconnected_joints == []
    assert [(s_, e, v) for s_, e, v, _ in fs.coplanar_panels] == [("F1-S000", 2, 1)]
    assert "no bracket fits" in fs.coplanar_panels[0][3]
