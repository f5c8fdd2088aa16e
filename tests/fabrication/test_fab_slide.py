"""Every part slides in along one direction (issue 15): constructed cases with known answers.

A family-1 plate slotted onto two crossings whose node axes differ slides along their mean
axis, its slots (and its partners') widened by ``2 depth tan(skew)``; beyond
``MAX_SLOT_SKEW`` a crossing is butted instead. Parts never butt on each other in a cycle.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from fab_structures import blocked_slide_structure, grid_structure
from torsal.fabrication import FinSystem, JointKind, check_assembly, joints_of, slot_width, verify_assembly
from torsal.fabrication.assembly import AssemblyJoint, joint_groups
from torsal.fabrication.joints import MAX_SLOT_SKEW
from torsal.fabrication.builder.paths import _cycles

T, C = 3.0, 0.5


def fanned_grid(half_skew_deg: float, step: float = 0.3, depth: float = 0.1):
    """3 columns x 4 rows; the node lines of every column fan in its plane (x = const) about
    the middle of rows 1 and 2, so the middle column crosses rows 1 and 2 (nodes 4 and 7) on
    node axes ``2 * half_skew_deg`` apart; the lines of a row are parallel (flat rows)."""
    y_mid = 1.5 * step
    h = 0.5 * step / np.tan(np.radians(half_skew_deg))      # apex height of the fans
    a = np.array([[[c * step, r * step, 0.0] for c in range(3)] for r in range(4)])
    d = np.array([[[0.0, y_mid - r * step, h] for c in range(3)] for r in range(4)])
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return grid_structure(a, a + depth * d, 3, 4)


def _build(structure):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return FinSystem(structure, thickness=T, clearance=C, tabs=False)   # (butt joints' brackets)


def test_plate_slotted_on_skewed_axes_slides_along_their_mean_with_wider_slots():
    fs = _build(fanned_grid(0.5))
    col = fs.part("F1-S001-P00")
    assert sorted(s.node for s in col.slots) == [4, 7]
    # the plates cross at 90 degrees; each axis is 0.5 deg off the mean: 2 * 100 mm * tan(0.5)
    want = slot_width(90.0, thickness=T, clearance=C) + 2 * 100.0 * np.tan(np.radians(0.5))
    for p in fs.parts:
        for s in p.slots:
            assert s.width == pytest.approx(want, rel=1e-6), (p.name, s)
    crate = [j for j in fs.joints if j.kind == JointKind.EGG_CRATE]
    assert sorted(j.node for j in crate) == [4, 7]
    # one direction for the column at both crossings: the mean axis. Its ends butt against
    # rows 0 and 3, whose planes lean outwards (1.5 deg): sliding down (a - b) would close
    # both butt gaps, so it slides up (b - a), slotted from its b edge, the rows from their a
    for j in crate:
        np.testing.assert_allclose(j.insert_direction, [0, 0, 1], atol=1e-9)
    assert {s.side.value for s in col.slots} == {"b"}
    assert {s.side.value for p in fs.parts if p.family == 0 for s in p.slots} == {"a"}
    check = check_assembly(fs.solids(workers=1), joints=joints_of(fs), workers=1)
    assert check.interfering_pairs == 0 and not check.blocked, check.problems()


def test_crossing_too_far_off_the_slide_direction_is_butted():
    fs = _build(fanned_grid(MAX_SLOT_SKEW + 1.0))
    kinds = {j.node: j.kind for j in fs.joints if j.node in (4, 7)}
    # each axis is 3 deg off the mean: the first is butted (the column split there), the
    # other stays an egg-crate (one crossing left: no skew)
    assert kinds == {4: JointKind.BUTT_BRACKET, 7: JointKind.EGG_CRATE}
    [x] = [x for x in fs.joinery if x.node == 4]
    assert "off the slide direction" in x.why
    [s7] = [s for p in fs.parts for s in p.slots if s.node == 7 and p.family == 1]
    assert s7.width == pytest.approx(slot_width(90.0, thickness=T, clearance=C), rel=1e-6)


def test_cycles_are_found_and_sorted():
    after = {"a": {"b": 1}, "b": {"c": 2}, "c": {"a": 3, "d": 4}, "d": {"e": 5}, "e": {"d": 6}}
    assert _cycles(after) == [["d", "e"], ["a", "b", "c"]] or \
        sorted(_cycles(after)) == [["a", "b", "c"], ["d", "e"]]
    assert _cycles({"a": {"b": 1}, "b": {}}) == []


def test_butt_joint_groups_the_plate_it_butts_against():
    j = AssemblyJoint("butt-bracket", 3, ("F0-S001-P00", "F0-S001-P01", "F1-S002-P00", "C-N0003-0"),
                      np.array([0.0, 0, 1]), "C-N0003-0")
    # the two halves of the plate are not each other's partners by this joint
    assert joint_groups(j) == [("F0-S001-P00", "F0-S001-P01"), ("F1-S002-P00",), ("C-N0003-0",)]
    # nor by a tab bent from the butted part instead of the bracket: the second half does not
    # wait for the first and move in along the tabbed part's direction (7c at full size:
    # F0-S003-P08 went in after F0-S003-P07 along F1-S031-P04's way, into F0-S003-P09)
    tab = j._replace(kind="butt-tab", parts=j.parts[:3], connector=None)
    assert joint_groups(tab) == [("F0-S001-P00", "F0-S001-P01"), ("F1-S002-P00",)]


def test_quads_crossing_without_a_joint_are_found():
    from torsal.fabrication.builder.proximity import _quads_cross

    floor = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]], float)
    post = np.array([[[0.5, 0.5, -1], [0.6, 0.5, -1], [0.6, 0.5, 1], [0.5, 0.5, 1]]], float)
    assert _quads_cross(floor, post) and _quads_cross(post, floor)
    assert not _quads_cross(floor, post + [0, 0, 5])           # above it
    # sharing an edge (neighbours on a node line) is not crossing
    wall = np.array([[[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]]], float)
    assert not _quads_cross(floor, wall)


def test_fin_folded_back_onto_another_is_found():
    from torsal.fabrication.builder.proximity import _quads_on

    floor = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]], float)
    assert _quads_on(floor * 0.5 + [0.2, 0.2, 0.002], floor, 0.003)      # lies on it
    assert not _quads_on(floor * 0.5 + [0.2, 0.2, 0.01], floor, 0.003)   # 10 mm above
    assert not _quads_on(floor + [2, 0, 0], floor, 0.003)                 # beside it


@pytest.fixture
def obstacles_held(monkeypatch):
    """The rows in P's way below meet no part, and nothing would hold them (the builder
    leaves such a plate out: test_fab_held.py); here they stand for plates held elsewhere,
    so they stay in P's way."""
    from torsal.fabrication.builder.paths import AssemblyPlanner

    monkeypatch.setattr(AssemblyPlanner, "_loose_panels", lambda self: [])


def test_butted_part_whose_slide_is_blocked_goes_in_head_on(obstacles_held):
    # (issue 15, example 9) column P butts against row W and would slide along their common
    # line (z); a plate 50 mm above and one 50 mm below are in the way of both senses (nothing
    # joins them to P): the builder slides P in head on (along -y, towards W), which the
    # independent check finds clear; nothing is left out
    fs = _build(blocked_slide_structure())
    [butt] = [j for j in fs.joints if j.kind == JointKind.BUTT_BRACKET]
    assert butt.parts[:2] == ("F0-S000-P00", "F1-S000-P00")
    np.testing.assert_allclose(butt.insert_direction, [0, -1, 0], atol=1e-12)
    assert fs.coplanar_panels == [] and fs.n_panels == 6
    r = verify_assembly(fs, workers=1)
    assert r.buildable and r.interfering_pairs == 0 and not r.blocked, r.problems()
    [step] = [s for s in r.order if s.part == "F1-S000-P00"]
    np.testing.assert_allclose(step.insert_direction, [0, -1, 0], atol=1e-12)


def test_butted_part_blocked_every_way_leaves_out_the_cheaper_panel(obstacles_held, monkeypatch):
    # the same with a third plate 50 mm beyond P's free end, in the way of the head-on slide:
    # no direction P's joint allows is clear; of the pair on its first path (sliding down,
    # through the plate above) the cheaper panel is left out: the plate above, one panel of a
    # strip of one (P has two); then P slides down
    fs = _build(blocked_slide_structure(behind=True))
    assert [(x[0], x[1], x[2]) for x in fs.coplanar_panels] == [("F0-S001", 2, 5)]
    assert "path of F1-S000-P00" in fs.coplanar_panels[0][3]
    [butt] = [j for j in fs.joints if j.kind == JointKind.BUTT_BRACKET]
    np.testing.assert_allclose(butt.insert_direction, [0, 0, -1], atol=1e-12)
    r = verify_assembly(fs, workers=1)
    assert r.buildable and r.interfering_pairs == 0 and not r.blocked, r.problems()
    # control: without the path check P keeps its first slide (down) and is blocked both ways
    monkeypatch.setattr(FinSystem, "_check_paths", lambda self: None)
    for behind in (False, True):
        kept = _build(blocked_slide_structure(behind=behind))
        r = verify_assembly(kept, workers=1)
        assert [s.part for s in r.blocked] == ["F1-S000-P00"] and r.interfering_pairs == 0


def test_path_checks_remembered_across_rebuilds_give_the_same_hits():
    # the second check of the paths during a fin system's rebuilds looks its blocking pairs
    # and overlaps up in the rebuilds' memo: the same hits, panel for panel and distance for
    # distance, as measured afresh, and the second pass measures nothing again
    from torsal.fabrication.builder.memo import Memo
    from torsal.fabrication.builder.paths import _PathCheck

    fs = _build(blocked_slide_structure(behind=True))
    assert "_memo" not in fs.__dict__                   # built: no memo is kept

    def rows(paths):
        out = []
        for p in paths.bodies:
            for d in np.eye(3)[[0, 2]]:
                out += [(p.name, a, o.name, b, dist) for a, o, b, dist in paths.hits(p, d)]
            out += [(p.name, a, o.name, b, dist) for a, o, b, dist in paths.overlaps(p)]
        return out

    fresh = rows(_PathCheck(fs))
    assert any(r[0] == "F1-S000-P00" for r in fresh)    # the blocked slide is among them
    fs.__dict__["_memo"] = memo = Memo()
    first = rows(_PathCheck(fs))
    n = len(memo.table)
    assert first == fresh and n > 0
    assert rows(_PathCheck(fs)) == fresh and len(memo.table) == n


def test_point_segment_distances_are_the_bits_of_the_segment_kernel_and_exact():
    """A point's distance from a segment (the triangle distances' edges) is bit for bit the
    two-segment kernel's with a segment of length 0 there, and the hand value: from
    (1, 2, 0) to the segment (0, 0, 0) -> (4, 0, 0) it is 2 (its foot inside), from (6, 0, 3)
    sqrt(4 + 9) (past the end), from a point to a segment of length 0 the distance of the two
    points."""
    from torsal.fabrication.builder.proximity import _point_segment_distances, _segment_distances

    q0, q1 = np.zeros(3), np.array([4.0, 0.0, 0.0])
    assert _point_segment_distances(np.array([1.0, 2.0, 0.0]), q0, q1) == 2.0
    assert _point_segment_distances(np.array([6.0, 0.0, 3.0]), q0, q1) == np.sqrt(13.0)
    assert _point_segment_distances(np.array([0.0, 3.0, 4.0]), q0, q0) == 5.0
    rng = np.random.default_rng(3)
    for scale in (0.0, 1e-9, 1.0, 100.0):
        x = rng.normal(size=(40, 4, 1, 3)) * 50.0
        a = rng.normal(size=(40, 1, 2, 3))
        b = a + scale * rng.normal(size=(40, 1, 2, 3))
        x[:, 0] = a[:, :, 0]                                   # a point at a segment's end
        ours, kernel = _point_segment_distances(x, a, b), _segment_distances(x, x, a, b)
        assert ours.shape == kernel.shape == (40, 4, 2)
        assert np.array_equal(ours.view(np.int64), kernel.view(np.int64))
