"""A family-1 plate that cannot slide onto all its crossings along their mean axis (issue 42):
constructed cases with known answers.

Columns (family 1) cross rows (family 0) whose node lines all lean in the column's plane, row
``r`` by ``TILTS[r]`` degrees. A crossing more than ``MAX_SLOT_SKEW`` off the mean axis was
butted (the column split there, two brackets), and a plate whose butted ends closed a gap in
both senses had every crossing butted. Now a direction within ``MAX_SLOT_SKEW`` of every axis
that keeps the butted ends' gaps is searched for first
(:func:`~torsal.fabrication.builder.crossings.slide_direction`); the crossing is butted only
where there is none (test_fab_slide: the fanned column).
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from fab_structures import grid_structure
from torsal.fabrication import FinSystem, JointKind, verify_assembly
from torsal.fabrication.builder.crossings import slide_direction
from torsal.fabrication.joints import MAX_SLOT_SKEW

T, C = 3.0, 0.5


def tilted_grid(tilts, step: float = 0.3, depth: float = 0.1):
    """3 columns x ``len(tilts)`` rows (metres); the node lines of row ``r`` lean ``tilts[r]``
    degrees from vertical towards +y (in the columns' planes, x = const): the middle column
    crosses rows 1 .. n-2 and butts against rows 0 and n-1."""
    a = np.array([[[c * step, r * step, 0.0] for c in range(3)] for r in range(len(tilts))])
    d = np.array([[[0.0, np.sin(np.radians(t)), np.cos(np.radians(t))]] * 3 for t in tilts])
    return grid_structure(a, a + depth * d, 3, len(tilts))


def _build(tilts) -> FinSystem:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return FinSystem(tilted_grid(tilts), thickness=T, clearance=C)


def _column(fs):
    return [p for p in fs.parts if p.name.startswith("F1-S001")]


def _deg(u, v) -> float:
    return float(np.degrees(np.arccos(np.clip(abs(np.dot(u, v)), -1.0, 1.0))))


def test_the_search_finds_the_direction_nearest_all_axes_and_none_beyond_the_limit():
    tilt = lambda t: np.array([0.0, np.sin(np.radians(t)), np.cos(np.radians(t))])  # noqa: E731
    axes = np.array([tilt(0.0), tilt(0.0), tilt(3.6)])
    # the mean is 1.2 deg from the first two and 2.4 from the third; 1.8 deg from all is best
    d, sense = slide_direction(axes, np.zeros((0, 3)), max_skew=MAX_SLOT_SKEW, tol=1e-3)
    assert sense == 1.0 and max(_deg(d, a) for a in axes) == pytest.approx(1.8, abs=0.1)
    # a wall it may not run into: along +d it would (d . n > 0), so it slides the other way
    d2, s2 = slide_direction(axes, np.array([tilt(90.0 + 1.8)]) * -1, max_skew=MAX_SLOT_SKEW,
                             tol=1e-3)
    assert s2 == -1.0 and max(_deg(d2, a) for a in axes) <= MAX_SLOT_SKEW
    # axes 4.4 deg apart: no direction is within 2 deg of both
    assert slide_direction(np.array([tilt(0.0), tilt(4.4)]), np.zeros((0, 3)),
                           max_skew=MAX_SLOT_SKEW, tol=1e-3) is None


def test_a_plate_whose_mean_axis_is_too_far_off_one_crossing_slides_along_another_direction():
    # rows 1-3 lean 0, 0 and 3.6 deg: 2.4 deg off their mean (the crossing was butted), 1.8
    # off the best direction; the end rows lean outwards so that its ends keep their gaps
    fs = _build((-3.0, 0.0, 0.0, 3.6, 3.0))
    [col] = _column(fs)
    assert sorted(s.node for s in col.slots) == [4, 7, 10]
    crate = [j for j in fs.joints if j.kind == JointKind.EGG_CRATE]
    assert sorted(j.node for j in crate) == [4, 7, 10]
    axes = {v: fs.structure.vertices_a[v] - fs.structure.vertices_b[v] for v in (4, 7, 10)}
    for j in crate:
        assert _deg(j.insert_direction, axes[j.node] / np.linalg.norm(axes[j.node])) <= MAX_SLOT_SKEW
    assert not [c for c in fs.connectors if c.name.startswith(("C-N0004", "C-N0007", "C-N0010"))]
    r = verify_assembly(fs, workers=1)
    assert r.buildable, r.problems()
