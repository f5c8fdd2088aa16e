"""A strip split at a crossing meets on a mitred seam inside the crossing plate's slot, with
no connector, wherever the assembly check on the parts around that joint proves it; a seam it
refuses falls back to the butt joint with brackets, counted and named (issue 42).

Flat grids of nodes (rows family 0, columns family 1, 0.3 m apart, node lines 0.1 m along z,
see ``fab_structures``).
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from fab_structures import flat_structure, grid_structure

from torsal.fabrication import FinSystem, JointKind, verify_assembly
from torsal.fabrication.builder import seams as seams_module
from torsal.fabrication.builder.seams import SeamReason, local_part

T, C = 3.0, 0.5


def _build(structure, **kw) -> FinSystem:
    kw.setdefault("tabs", False)        # (the seams and their brackets; tabs: test_fab_tabs)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return FinSystem(structure, thickness=T, clearance=C, **kw)


def folded_row(theta: float, nu: int = 5, nv: int = 3, step: float = 0.3,
               depth: float = 0.1):
    """:func:`flat_structure` whose middle row (family 0) turns by ``theta`` degrees about the
    node line of node 7 (x 0.6, y 0.3): the joinery splits the row there (it folds more than
    an egg-crate allows) and column 2 passes through straight."""
    x, y = np.meshgrid(np.arange(nu) * step, np.arange(nv) * step)
    a = np.stack([x, y, 0 * x], axis=-1).astype(float)
    th = np.radians(theta)
    for c in range(3, nu):
        a[1, c] = a[1, 2] + (c - 2) * step * np.array([np.cos(th), np.sin(th), 0.0])
    return grid_structure(a, a + [0.0, 0.0, depth], nu, nv)


@pytest.fixture(scope="module")
def split_for_length():
    # 5 x 3 grid, max_panels=2: every row of four panels is split at its middle node; the
    # middle row's split (node 7) is an egg-crate crossing with column 2
    return _build(flat_structure(5, 3), max_panels=2)


def test_a_seam_in_the_slot_needs_no_connector_and_assembles(split_for_length):
    fs = split_for_length
    [x] = [j for j in fs.joints if j.node == 7]
    assert x.kind == JointKind.EGG_CRATE and x.connector is None
    assert x.parts == ("F0-S001-P00", "F0-S001-P01", "F1-S002-P00")
    assert not [c for c in fs.connectors if c.id.strip == 7]
    [seam] = [s for s in fs.seams_in_slot if s.node == 7]
    assert (seam.family, seam.parts, seam.holders) == (0, ("F0-S001-P00", "F0-S001-P01"),
                                                       ("F1-S002-P00",))
    assert fs.joint_fallbacks == []
    # both parts slotted at their ends (from the b edge, half the 100 mm depth and half the
    # clearance past it, where the column's slot ends clearance apart): the crossing
    # holds them; the two ends stand clearance/2 off the node line (x = 600 mm)
    left, right = fs.part("F0-S001-P00"), fs.part("F0-S001-P01")
    [sl] = [s for s in left.slots if s.node == 7]
    [sr] = [s for s in right.slots if s.node == 7]
    assert (sl.position, sr.position) == (2, 0)
    assert sl.side.value == sr.side.value == "b" and sl.depth == sr.depth == pytest.approx(50.0 + C / 2)
    assert left.panels[-1][[1, 2], 0] == pytest.approx([600 - C / 2] * 2)
    assert right.panels[0][[0, 3], 0] == pytest.approx([600 + C / 2] * 2)
    # and the whole design assembles, by the independent check on every solid
    r = verify_assembly(fs, workers=1)
    assert r.buildable and r.interfering_pairs == 0 and not r.blocked, r.problems()


def test_the_local_parts_are_the_panels_next_to_the_joint(split_for_length):
    fs = split_for_length
    column = fs.part("F1-S002-P00")          # nodes 2, 7, 12: one panel on either side of 7
    loc = local_part(column, 7)
    assert loc.name == column.name and len(loc.panels) == 2
    assert [s.node for s in loc.slots] == [7] and loc.slots[0].position == 1
    assert np.array_equal(loc.panels, column.panels) and loc.miters.shape == (3, 3)
    left = local_part(fs.part("F0-S001-P00"), 7)      # its end: the last panel only
    assert len(left.panels) == 1 and left.slots[0].position == 1
    assert local_part(column, 5) is None


def test_a_split_for_a_fold_is_held_in_the_slot_too():
    # the middle row turns by 30 degrees at node 7: split there by the joinery (it folds more
    # than 10 degrees), its two flat parts held in column 2's slot without brackets
    fs = _build(folded_row(30.0))
    assert [(s.node, s.family) for s in fs.seams_in_slot] == [(7, 0)]
    assert not [c for c in fs.connectors if c.id.strip == 7]
    r = verify_assembly(fs, workers=1)
    assert r.buildable, r.problems()


def test_a_seam_the_assembly_check_refuses_falls_back_to_a_bracket(monkeypatch):
    # the same grid with the crossing plate's slot cut to half the plate's thickness at the
    # seam's node: the parts around the joint interfere (each half by the plate's volume in
    # the slot), the check on them refuses the seam, and the split is butted with brackets
    # again, named among the fallbacks; nothing else changes
    from torsal.fabrication.builder import crossings

    monkeypatch.setattr(crossings, "slot_width", lambda alpha, **kw: 0.5 * T)
    checked = []
    local = seams_module._local_check

    def spy(parts, joints, thickness, unit):
        checked.append((joints[0].node, tuple(sorted(p.name for p in parts))))
        return local(parts, joints, thickness, unit)

    monkeypatch.setattr(seams_module, "_local_check", spy)
    fs = _build(flat_structure(5, 3), max_panels=2)
    [fb] = [f for f in fs.joint_fallbacks if f.node == 7]
    assert fb.family == 0 and fb.reason == SeamReason.ASSEMBLY
    assert "F0-S001-P00" in fb.parts and "F1-S002-P00" in fb.parts and fb.detail
    assert "interfer" in fb.detail
    assert (7, ("F0-S001-P00", "F0-S001-P01", "F1-S002-P00")) in checked
    assert not [s for s in fs.seams_in_slot if s.node == 7]
    # the fallback: the row's two parts butt against column 2 with brackets at node 7
    at7 = [j for j in fs.joints if j.node == 7 and j.kind == JointKind.BUTT_BRACKET]
    assert {j.parts[-2] for j in at7} == {"F0-S001-P00", "F0-S001-P01"}
    assert all(j.connector for j in at7) and len(at7) >= 2
    assert {c.name for c in fs.connectors if c.id.strip == 7} == {j.connector for j in at7}


def test_the_local_checks_give_the_same_verdicts_in_worker_processes(monkeypatch):
    # the fabrication stage runs the seams' local checks in the solids' prepared workers:
    # seams, fallbacks and joints are those of the checks in this process
    from torsal.fabrication.solids import prepare_workers, release_workers

    here = []
    local = seams_module._local_check
    monkeypatch.setattr(seams_module, "_local_check", lambda *a: here.append(1) or local(*a))
    serial = _build(flat_structure(5, 4), max_panels=2)
    n_checks = len(here)
    assert prepare_workers(1000, workers=2) == 2
    try:
        pooled = _build(flat_structure(5, 4), max_panels=2)
    finally:
        release_workers()
    assert len(serial.seams_in_slot) >= 2 and n_checks >= 2
    assert len(here) == n_checks          # none more in this process: the workers checked them
    assert pooled.seams_in_slot == serial.seams_in_slot
    assert pooled.joint_fallbacks == serial.joint_fallbacks
    assert [(j.kind, j.parts) for j in pooled.joints] == [(j.kind, j.parts) for j in serial.joints]


def _opposite(monkeypatch, name: str) -> None:
    """The slide plan turned round for the family-1 part ``name``: it slides onto its crossings
    along ``b - a`` while the other parts slide along ``a - b`` (as a part whose butted end
    would close its gap the other way does)."""
    from torsal.fabrication.builder import crossings

    sense = crossings.CrossingSlotter._sense
    monkeypatch.setattr(crossings.CrossingSlotter, "_sense",
                        lambda self, n, *a: -1.0 if n == name else sense(self, n, *a))


def test_a_seam_whose_parts_slide_in_from_opposite_edges_is_held_by_two_tongues(monkeypatch):
    # 3 x 5 grid, max_panels=2: each column of four panels is split at its middle node; column
    # 1's split (node 7) is an egg-crate crossing with row 2. Its second part slides in along
    # b - a, the first along a - b: row 2 is slotted a third of the 100 mm depth from each
    # edge, each part keeps a tongue of a third at its end, entering from its own side
    _opposite(monkeypatch, "F1-S001-P01")
    fs = _build(flat_structure(3, 5), max_panels=2)
    [seam] = [s for s in fs.seams_in_slot if s.node == 7]
    assert seam.parts == ("F1-S001-P00", "F1-S001-P01") and seam.holders == ("F0-S002-P00",)
    assert not [c for c in fs.connectors if c.id.strip == 7] and not fs.joint_fallbacks
    row = sorted((s.side.value, round(s.depth, 6)) for s in fs.part("F0-S002-P00").slots if s.node == 7)
    assert row == [("a", round(100 / 3 + C / 2, 6)), ("b", round(100 / 3 + C / 2, 6))]
    [first] = [s for s in fs.part("F1-S001-P00").slots if s.node == 7]
    [second] = [s for s in fs.part("F1-S001-P01").slots if s.node == 7]
    assert (first.side.value, second.side.value) == ("a", "b")
    assert first.depth == pytest.approx(200 / 3 + C / 2) and second.depth == pytest.approx(200 / 3 + C / 2)
    # one joint record per part, each with its own sense along the node axis (z)
    dirs = {j.parts[-1]: j.insert_direction for j in fs.joints if j.node == 7}
    assert dirs["F1-S001-P00"] @ dirs["F1-S001-P01"] == pytest.approx(-1.0)
    r = verify_assembly(fs, workers=1)
    assert r.buildable and r.interfering_pairs == 0 and not r.blocked, r.problems()


def test_opposite_slides_on_a_fin_too_shallow_for_tongues_fall_back_to_brackets(monkeypatch):
    # the same grid 15 mm deep: a third (5 mm) is less than two plate thicknesses, so the
    # seam is refused for the opposite slides and butted with brackets, named
    _opposite(monkeypatch, "F1-S001-P01")
    fs = _build(flat_structure(3, 5, depth=0.015), max_panels=2)
    [fb] = [f for f in fs.joint_fallbacks if f.node == 7]
    assert fb.family == 1 and fb.reason == SeamReason.OPPOSITE_SLIDES and "tongue" in fb.detail
    assert not [s for s in fs.seams_in_slot if s.node == 7]
    at7 = [j for j in fs.joints if j.node == 7 and j.kind == JointKind.BUTT_BRACKET]
    assert {j.parts[-2] for j in at7} == {"F1-S001-P00", "F1-S001-P01"} and all(j.connector for j in at7)


def folded_crossing(theta: float, phi: float):
    """:func:`folded_row` (the middle row turning by ``theta`` degrees at node 7) whose column
    2 turns by ``phi`` degrees there too: node 12 moved round node 7's line."""
    s = folded_row(theta)
    a, b = s.vertices_a.copy(), s.vertices_b.copy()
    ph = np.radians(phi)
    turn = 0.3 * np.array([np.sin(ph), np.cos(ph), 0.0]) - (a[12] - a[7])
    a[12] += turn
    b[12] += turn
    return grid_structure(a.reshape(3, 5, 3), b.reshape(3, 5, 3), 5, 3)


@pytest.mark.parametrize("holder_limit, held", [(None, True), (10.0, False)])
def test_a_split_for_a_fold_is_held_by_a_plate_folding_up_to_the_holder_limit(monkeypatch,
                                                                               holder_limit, held):
    # the row turns by 40 degrees at node 7 (split there), column 2 by 15: more than an
    # egg-crate of two folding plates allows (10), within MAX_HOLDER_FOLD (20, where a slot on
    # a fold is still one box on its bisector plane). The column is bent through its slot and
    # holds the row's two flat parts; with the holder's limit at 10 degrees the split is
    # butted against the column with brackets as before
    from torsal.fabrication.builder import seams
    from torsal.fabrication.joints import MAX_HOLDER_FOLD
    from torsal.fabrication.plates import SINGLE_BOX_FOLD

    assert MAX_HOLDER_FOLD <= SINGLE_BOX_FOLD
    if holder_limit is not None:
        monkeypatch.setattr(seams, "MAX_HOLDER_FOLD", holder_limit)
    fs = _build(folded_crossing(40.0, 15.0))
    [x] = [x for x in fs.joinery if x.node == 7]
    assert x.split == 0 and x.folds == pytest.approx((40.0, 15.0), abs=1e-6)
    at7 = [c for c in fs.connectors if c.id.strip == 7]
    if held:
        assert [(s.node, s.family) for s in fs.seams_in_slot] == [(7, 0)] and not at7
        assert [s.node for s in fs.part("F1-S002-P00").slots] == [7]
        r = verify_assembly(fs, workers=1)
        assert r.buildable, r.problems()
    else:
        assert not fs.seams_in_slot and len(at7) >= 2
