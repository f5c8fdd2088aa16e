"""FinSystem: grouping of fins into parts, ids, slots of crossing strips, trimming, errors."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from fab_structures import (crossing_strips_structure, cylinder_structure, developable_strip, flat_structure,
                            sphere_structure)
from torsal.fabrication import FamilySplit, FinSystem, JointKind, PartId, SlotSide, slot_width
from torsal.fabrication.builder.proximity import _near_panel_pairs
from torsal.geometry.support import SupportStructure


def test_egg_crate_one_part_per_strip_with_stable_ids_and_colours():
    s = sphere_structure(nu=4, nv=3)
    fs = FinSystem(s, thickness=3.0, tabs=False)         # (brackets, not tabs: their names)
    plates = [p for p in fs.parts if p.family >= 0]
    assert len(plates) == len(s.fins()) == 3 + 4
    # the 10 boundary T/L junctions are butted with a bracket each, named after their node
    assert sorted(p.name for p in fs.parts if p.family == -2) == [
        f"C-N{v:04d}-0" for v in (0, 1, 2, 3, 4, 7, 8, 9, 10, 11)]
    assert fs.n_panels == len(s.edges)
    assert [p.name for p in fs.parts[:2]] == ["F0-S000-P00", "F0-S001-P00"]
    assert fs.parts[3].id == PartId(1, 0, 0)
    # ids are stable: rebuilding gives the same names for the same panels
    again = FinSystem(s, thickness=3.0, tabs=False)
    assert [p.name for p in again.parts] == [p.name for p in fs.parts]
    assert all(np.array_equal(p.edges, q.edges) for p, q in zip(fs.parts, again.parts))
    cols = {p.family: p.color for p in fs.parts}
    assert cols[0] != cols[1] and all(p.color == cols[p.family] for p in fs.parts)
    # every fin is used exactly once
    assert sorted(np.concatenate([p.edges for p in plates]).tolist()) == list(range(len(s.edges)))


@pytest.mark.parametrize("make", [sphere_structure, cylinder_structure, flat_structure])
@pytest.mark.parametrize("ratio", [0.5, 0.3])
def test_slot_depths_add_up_to_fin_depth_and_clearance_and_widths_match(make, ratio):
    s = make()
    t, c = 3.0, 0.4
    fs = FinSystem(s, thickness=t, clearance=c, slot_ratio=ratio)
    # interior nodes of a 4x3 grid are the X crossings
    assert sorted(x.node for x in fs.crossings) == [5, 6]
    depth = np.linalg.norm(s.vertices_b - s.vertices_a, axis=1) * 1000.0
    for x in fs.crossings:
        s0 = [sl for p in fs.parts if p.family == 0 for sl in p.slots if sl.node == x.node]
        s1 = [sl for p in fs.parts if p.family == 1 for sl in p.slots if sl.node == x.node]
        assert len(s0) == len(s1) == 1
        assert s0[0].side == SlotSide.B and s1[0].side == SlotSide.A
        # each runs half the clearance past where they meet: the slot ends stand c apart
        assert s0[0].depth + s1[0].depth == pytest.approx(depth[x.node] + c, rel=1e-12)
        assert s0[0].depth == pytest.approx(ratio * depth[x.node] + 0.5 * c, rel=1e-12)
        # widths from the crossing angle and folds there: t + c only for flat plates at 90 deg
        assert s0[0].width == pytest.approx(slot_width(x.angle, thickness=t, clearance=c,
                                                       fold_self=x.fold if make is cylinder_structure else 0.0,
                                                       fold_other=0.0), rel=0.05)
        assert min(s0[0].width, s1[0].width) >= t + c - 1e-9
        if make is flat_structure:
            assert s0[0].width == s1[0].width == pytest.approx(t + c, rel=1e-12)


def test_boundary_ends_are_trimmed_against_the_crossing_plate():
    t, c = 3.0, 0.5
    s = flat_structure()
    fs = FinSystem(s, thickness=t, clearance=c, tabs=False)      # (the butt trim, no tab)
    # flat grid, step 300 mm: a column (family 1) ends on rows 0 and 2 (T junctions) and is
    # shortened by t/2 + c/2 at both ends; row 1 ends on the boundary columns
    col = fs.part("F1-S001-P00")
    assert col.trimmed == (True, True)
    length = np.linalg.norm(col.panels[-1, 1] - col.panels[0, 0])
    assert length == pytest.approx(600.0 - 2 * (t / 2 + c / 2), rel=1e-12)
    assert fs.part("F0-S001-P00").trimmed == (True, True)
    # corners (L junctions): family 0 continues, family 1 butts
    assert fs.part("F0-S000-P00").trimmed == (False, False)
    assert fs.part("F1-S000-P00").trimmed == (True, True)


def test_family0_continuous_cuts_family1_into_single_panels():
    fs = FinSystem(sphere_structure(), thickness=3.0, family_split="family0-continuous", tabs=False)
    assert fs.family_split is FamilySplit.FAMILY0_CONTINUOUS
    f0 = [p for p in fs.parts if p.family == 0]
    f1 = [p for p in fs.parts if p.family == 1]
    assert len(f0) == 3 and all(len(p.panels) == 3 for p in f0)
    assert len(f1) == 8 and all(len(p.panels) == 1 for p in f1)
    assert not fs.crossings and not any(p.slots for p in fs.parts)
    assert all(p.trimmed == (True, True) for p in f1)


def test_sharp_folds_and_long_strips_are_split():
    quads, folds = developable_strip(k=6, seed=0, max_fold_deg=50.0)
    deg = np.degrees(np.abs(folds))
    fs = FinSystem.from_strips([quads], thickness=2.0, max_fold_angle=30.0)
    assert len(fs.parts) == 1 + np.count_nonzero(deg > 30.0)
    for p in fs.parts:
        assert np.all(np.degrees(np.abs(p.fold_angles)) <= 30.0)
    fs2 = FinSystem.from_strips([quads], thickness=2.0, max_panels=4)
    assert [len(p.panels) for p in fs2.parts] == [3, 3]
    assert fs2.parts[0].name == "D-S000-P00"


def test_closed_strips_become_two_parts():
    s = cylinder_structure(nu=8, closed=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fs = FinSystem(s, thickness=3.0, fit_sheet=None)
    rows = [p for p in fs.parts if p.family == 0]
    # the boundary rows (no crossings) are cut in two halves, mitred with a splice plate
    for strip in (0, 2):
        assert [len(p.panels) for p in rows if p.id.strip == strip] == [4, 4]
    splices = [j for j in fs.joints if j.kind == JointKind.MITRE_SPLICE]
    assert len(splices) == 4 and all(j.connector for j in splices)
    # the middle row folds 24 deg at every crossing: split there, one panel per part
    assert [len(p.panels) for p in rows if p.id.strip == 1] == [1] * 8


def test_parts_are_halved_until_they_fit_the_sheet():
    s = cylinder_structure(nu=8, closed=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = FinSystem(s, thickness=3.0, fit_sheet=None)
        fs = FinSystem(s, thickness=3.0, fit_sheet=(2500.0, 1250.0))
    assert len(fs.parts) > len(whole.parts)
    from shapely.geometry import box

    for u in fs.unrolled().values():
        rect = u.outline.minimum_rotated_rectangle
        c = np.asarray(rect.exterior.coords)
        sides = sorted([np.linalg.norm(c[1] - c[0]), np.linalg.norm(c[2] - c[1])])
        assert sides[1] <= 2480 and sides[0] <= 1230
    lay = fs.layout(sheet=(2500.0, 1250.0))
    assert all(box(0, 0, 2500, 1250).contains(p.polygon) for p in lay.placements)
    with pytest.raises(ValueError, match="fit_sheet"):
        FinSystem(s, thickness=3.0, fit_sheet=(10.0, 10.0))


def test_folded_crossings_are_split_and_held_in_the_slot():
    s = cylinder_structure(nu=8, closed=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # a sound design: nothing to warn about
        fs = FinSystem(s, thickness=3.0, clearance=0.5, fit_sheet=None, tabs=False)
    # the 8 crossings of the middle row: it folds there, the columns are flat
    assert len(fs.joinery) == 8
    # the dihedral angle of consecutive panels of the middle row, from their normals
    q = s.fins()[1].quads
    n = np.cross(q[:, 2] - q[:, 0], q[:, 3] - q[:, 1])
    n /= np.linalg.norm(n, axis=1)[:, None]
    fold = np.degrees(np.arccos(n[0] @ n[1]))
    assert fold > 20.0
    for x in fs.joinery:
        # split for the fold (never slotted across it) ...
        assert x.split == 0 and f"folds {fold:.0f} deg" in x.why
        assert x.folds[0] == pytest.approx(fold, abs=1e-6) and x.folds[1] == pytest.approx(0, abs=1e-6)
    row = sorted(p.name for p in fs.plates if p.family == 0 and p.id.strip == 1)
    assert len(row) == 8 and all(len(fs.part(n).panels) == 1 for n in row)
    # ... and the row's parts meet in the flat columns' slots, no bracket at those nodes (issue
    # 42: they were 16 brackets), each seam proved by the assembly check on its parts
    nodes = {x.node for x in fs.joinery}
    assert {s.node for s in fs.seams_in_slot} == nodes and not fs.joint_fallbacks
    assert not [j for j in fs.joints if j.kind == JointKind.BUTT_BRACKET and j.node in nodes]
    assert {x.node for x in fs.crossings} == nodes
    assert all(len(x.parts0) == 2 and len(x.parts1) == 1 for x in fs.crossings)


def test_units_scale_the_structure():
    s = flat_structure()
    mm = FinSystem(s, thickness=3.0)
    cm = FinSystem(s, thickness=0.3, clearance=0.05, unit="cm")
    np.testing.assert_allclose(mm.parts[0].panels, 10 * cm.parts[0].panels, rtol=1e-12)


@pytest.mark.parametrize("kw, msg", [
    ({"thickness": 0.0}, "thickness"),
    ({"thickness": -1.0}, "thickness"),
    ({"thickness": 3.0, "clearance": -0.1}, "clearance"),
    ({"thickness": 3.0, "family_split": "welded"}, "welded"),
    ({"thickness": 3.0, "unit": "furlong"}, "unit"),
    ({"thickness": 3.0, "slot_ratio": 1.0}, "slot_ratio"),
])
def test_bad_options_raise_clear_errors(kw, msg):
    with pytest.raises(ValueError, match=msg):
        FinSystem(flat_structure(), **kw)


def test_empty_structure_raises():
    s = SupportStructure(np.zeros((0, 3)), np.zeros((0, 3)), [], np.zeros((0, 2), int), np.zeros(0, int))
    with pytest.raises(ValueError, match="no edges"):
        FinSystem(s, thickness=3.0)


def test_zero_depth_node_raises():
    s = flat_structure()
    b = s.vertices_b.copy()
    b[4] = s.vertices_a[4]
    bad = SupportStructure(s.vertices_a, b, s.faces, s.edges, s.edge_family)
    with pytest.raises(ValueError, match="zero fin depth"):
        FinSystem(bad, thickness=3.0)


def test_max_part_length_splits_strips_to_fit_sheets():
    s = sphere_structure(nu=9, nv=3, step=0.1)              # rows of 8 panels of ~300 mm
    fs = FinSystem(s, thickness=3.0, max_part_length=1000.0, tabs=False)
    for p in fs.parts:
        la = np.linalg.norm(p.panels[:, 1] - p.panels[:, 0], axis=1).sum()
        lb = np.linalg.norm(p.panels[:, 2] - p.panels[:, 3], axis=1).sum()
        assert max(la, lb) <= 1000.0
    rows = [p for p in fs.parts if p.family == 0 and p.id.strip == 1]
    assert [len(p.panels) for p in rows] == [3, 3, 2]
    plates = [p for p in fs.parts if p.family >= 0]
    assert sorted(np.concatenate([p.edges for p in plates]).tolist()) == list(range(len(s.edges)))
    with pytest.raises(ValueError, match="max_part_length"):
        FinSystem(s, thickness=3.0, max_part_length=0.0)


@pytest.mark.filterwarnings("ignore:.*egg-crate crossings")
def test_end_that_lies_along_the_plate_is_left_out_and_named():
    # a column ends against row 0 almost tangentially: move its second node along the row
    s = flat_structure()
    a, b = s.vertices_a.copy(), s.vertices_b.copy()
    a[5] = a[1] + [0.3, 0.005, 0.0]          # column 1: node 1 -> node 5 runs nearly along row 0
    b[5] = a[5] + [0, 0, 0.1]
    bad = SupportStructure(a, b, s.faces, s.edges, s.edge_family)
    with pytest.warns(UserWarning, match="left out because they meet the plate"):
        fs = FinSystem(bad, thickness=3.0)
    # the panel 1 -> 5 meets row 0 at 1 degree, lying along row 0's panel 1 -> 2 (node 5 is
    # 5 mm from node 2): one of the two cannot be trimmed clear of the other, so one of them
    # is left out (named) and the other kept whole, and every remaining part end is trimmed
    edges = np.asarray(bad.edges).tolist()
    edge = next(e for e, (i, j) in enumerate(edges) if {i, j} == {1, 5})
    row = next(e for e, (i, j) in enumerate(edges) if {i, j} == {1, 2})
    left = {e for _, e, _, _ in fs.coplanar_panels}
    kept = set(np.concatenate([p.edges for p in fs.parts]).tolist())
    assert len(left & {edge, row}) == 1 and len(kept & {edge, row}) == 1
    assert fs.untrimmed_joints == []


def test_panel_crossing_a_strip_of_its_family_is_left_out_and_named():
    s = crossing_strips_structure()
    extra_edge = len(s.edges) - 1
    assert s.edges[1].tolist() == [1, 2]
    with pytest.warns(UserWarning, match="cross another plate where no joint joins them"):
        fs = FinSystem(s, thickness=3.0, clearance=0.5)
    # the one-panel strip F0-S004 (cheaper than the inner panel of row 0) is left out, named
    # with the panel it crosses; row 0 keeps all its panels
    assert fs.coplanar_panels == [("F0-S004", extra_edge, 12, "it crosses panel 1 of F0-S000 "
                                   "without a joint (the structure runs through itself)")]
    kept = np.concatenate([p.edges for p in fs.parts if p.family in (0, 1)]).tolist()
    assert extra_edge not in kept and 1 in kept
    assert not any(p.name.startswith("F0-S004") for p in fs.parts)


def test_near_panel_pairs_known_distances():
    def wall(x0, x1, y, z1=100.0):      # vertical quad a_i a_j b_j b_i in the plane y (mm)
        return [[x0, y, 0], [x1, y, 0], [x1, y, z1], [x0, y, z1]]

    quads = np.array([wall(0, 300, 0.0),                              # 0
                      wall(100, 200, 2.0),                            # 1: parallel, 2 mm off 0
                      wall(100, 200, 5.0),                            # 2: 5 mm off 0, 3 mm off 1
                      [[150, -50, 20], [150, 50, 20], [150, 50, 80], [150, -50, 80]],  # 3: through 0, 1, 2
                      [[300, 0, 0], [300, 9, 0], [300, 9, 100], [300, 0, 100]]],       # 4: shares node 1 of 0
                     float)
    nodes = np.array([[0, 1], [2, 3], [4, 5], [6, 7], [1, 8]])
    pairs, dist = _near_panel_pairs(quads, nodes, 3.5)
    got = {tuple(p): d for p, d in zip(pairs.tolist(), dist.tolist())}
    # 0-2 are 5 mm apart (> 3.5); 0-4 touch but share node 1 (joined there)
    assert set(got) == {(0, 1), (1, 2), (0, 3), (1, 3), (2, 3)}
    assert got[(0, 1)] == pytest.approx(2.0) and got[(1, 2)] == pytest.approx(3.0)
    assert got[(0, 3)] == got[(1, 3)] == got[(2, 3)] == 0.0


def test_swept_distances_known_values():
    from torsal.fabrication.builder.proximity import _swept_distances

    floor = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]], float)
    wall = np.array([[[3, -1, -1], [3, 2, -1], [3, 2, 1], [3, -1, 1]]], float)
    # the floor swept towards the wall: through it, to 0.5 short of it, away from it
    assert _swept_distances(floor, [5.0, 0, 0], wall)[0, 0] == 0.0
    assert _swept_distances(floor, [1.5, 0, 0], wall)[0, 0] == pytest.approx(0.5)
    assert _swept_distances(floor, [-5.0, 0, 0], wall)[0, 0] == pytest.approx(2.0)
    # a small tilted square wholly inside the prism the floor sweeps upwards (no face meets
    # it): 0; a sweep that stops 1 below it: 1
    sq = np.array([[[0.4, 0.4, 2], [0.6, 0.4, 2], [0.6, 0.6, 2.1], [0.4, 0.6, 2.1]]], float)
    assert _swept_distances(floor, [0, 0, 5.0], sq)[0, 0] == 0.0
    assert _swept_distances(floor, [0, 0, 1.0], sq)[0, 0] == pytest.approx(1.0)
    # a sweep in the floor's own plane (flat): past a post standing 0.2 beside its path
    post = np.array([[[0.5, 1.2, -1], [0.6, 1.2, -1], [0.6, 1.2, 1], [0.5, 1.2, 1]]], float)
    assert _swept_distances(floor, [3.0, 0, 0], post)[0, 0] == pytest.approx(0.2)
    assert _swept_distances(floor, [0, 3.0, 0], post)[0, 0] == 0.0


def test_swept_and_in_place_distances_come_from_one_pass():
    from torsal.fabrication.builder.proximity import (_quad_distances, _swept_and_still_distances,
                                                      _swept_distances)

    floor = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]],
                      [[1, 0, 0], [2, 0, 0.5], [2, 1, 0.5], [1, 1, 0]]], float)
    wall = np.array([[[3, -1, -1], [3, 2, -1], [3, 2, 1], [3, -1, 1]],
                     [[0.5, 1.2, -1], [0.6, 1.2, -1], [0.6, 1.2, 1], [0.5, 1.2, 1]]], float)
    swept, still = _swept_and_still_distances(floor, [1.5, 0, 0], wall)
    np.testing.assert_array_equal(swept, _swept_distances(floor, [1.5, 0, 0], wall))
    i, j = np.divmod(np.arange(4), 2)
    np.testing.assert_array_equal(still, _quad_distances(floor[i], wall[j]).reshape(2, 2))
    # in place: the floor 2 from the wall, its second panel 1 (its far edge at x = 2), the post
    # 0.2 beside the floor
    assert still[0, 0] == pytest.approx(2.0) and still[1, 0] == pytest.approx(1.0)
    assert still[0, 1] == pytest.approx(0.2)


def test_slab_depths_known_values():
    from torsal.fabrication.builder.proximity import _slab_depths

    # 1 x 1 plates 0.2 thick: a floor at z = 0 and one 0.5 above it, swept from 0.9 (apart by
    # 0.3: faces at 0.1 and 0.4) or from 0.1 (down to the floor's face: overlap 0.1)
    floor = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]], float)
    assert _slab_depths(floor + [0, 0, 0.5], [0, 0, 0.4], floor, 0.2)[0] == pytest.approx(-0.3)
    assert _slab_depths(floor + [0, 0, 0.5], [0, 0, -0.4], floor, 0.2)[0] == pytest.approx(0.1)
    # a wall square to the floor, its square edge at z = 0.4, swept sideways over the floor
    # (face at 0.1): apart by 0.3; tilted 45 deg about that edge line, its corner dips 0.1 lower
    wall = np.array([[[0.5, 0.5, 0.4], [0.5, 0.6, 0.4], [0.5, 0.6, 1.4], [0.5, 0.5, 1.4]]], float)
    assert _slab_depths(wall, [0, 3.0, 0], floor, 0.2)[0] == pytest.approx(-0.3)
    tilt = wall.copy()
    tilt[0, 2:, 0] += 1.0                                   # top edge moved 1 along x: 45 deg
    assert _slab_depths(tilt, [0, 3.0, 0], floor, 0.2)[0] == pytest.approx(-(0.3 - 0.1 / np.sqrt(2)))


def test_the_build_leaves_the_collector_as_it_found_it():
    """FinSystem's build runs with the objects that existed before it frozen (gc.freeze): the
    objects it makes are still collected, and afterwards nothing is frozen; a caller's own
    frozen objects are left frozen (nothing frozen or unfrozen by the build), and so is a
    disabled collector."""
    import gc
    import weakref

    from torsal.fabrication import parts as P

    class Node:
        pass

    assert gc.get_freeze_count() == 0
    before = Node()
    with P._old_objects_frozen():
        assert gc.get_freeze_count() > 0
        cycle = Node()
        cycle.me = cycle                              # garbage only the cyclic collector frees
        gone = weakref.ref(cycle)
        del cycle
        gc.collect()
        assert gone() is None                         # made in the block: collected there
    assert gc.get_freeze_count() == 0 and gc.is_tracked(before)
    fs = FinSystem(flat_structure(), thickness=3.0)
    assert len(fs.parts) > 0 and gc.get_freeze_count() == 0
    gc.freeze()
    try:
        frozen = gc.get_freeze_count()
        with P._old_objects_frozen():
            assert gc.get_freeze_count() == frozen
        assert gc.get_freeze_count() == frozen
    finally:
        gc.unfreeze()
    gc.disable()
    try:
        with P._old_objects_frozen():
            assert gc.get_freeze_count() == 0
        assert not gc.isenabled()
    finally:
        gc.enable()
