"""A family-1 plate split where its slide direction turns, the split held in the crossing
slot without a connector (issue 42): constructed cases with known answers.

Columns (family 1) cross rows (family 0) whose node lines lean in the columns' planes, row
``r`` by ``tilts[r]`` degrees (``tilted_grid`` of test_fab_slide_search). Where no direction
is within ``MAX_SLOT_SKEW`` of every crossing's axis, the column is split at the inner
crossing that leaves its parts least skewed; the split is a seam inside that row's slot (a
crossing of both parts), each part sliding in along its own direction, and a ``slot-seam``
joint record says which goes in first: the second one's direction keeps the seam open. A seam
that both parts would close falls back to the butt joint with brackets, named
(``closes-seam``); so does one whose parts cannot slide onto it within ``MAX_SLOT_SKEW``
(``skew``).
"""
from __future__ import annotations

import warnings

import numpy as np

from test_fab_slide_search import _deg, tilted_grid
from torsal.fabrication import FinSystem, JointKind, verify_assembly
from torsal.fabrication.builder.seams import SeamReason
from torsal.fabrication.joints import MAX_SLOT_SKEW

T, C = 3.0, 0.5


def _build(tilts) -> FinSystem:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return FinSystem(tilted_grid(tilts), thickness=T, clearance=C)


def test_a_plate_split_where_its_slide_direction_turns_meets_on_a_seam_in_the_slot():
    # rows 1-3 lean 0, 3.6 and 3.6 deg: the mean is 2.4 deg off row 1 and no direction is
    # within 2 deg of all three; split at row 2 the parts are 1.8 and 0 deg off theirs
    fs = _build((0.0, 0.0, 3.6, 3.6, 0.0))
    col = [p for p in fs.parts if p.name.startswith("F1-S001")]
    assert len(col) == 2
    [seam] = fs.seams_in_slot
    assert seam.node == 7 and set(seam.parts) == {p.name for p in col}
    assert fs.joint_fallbacks == []
    assert not [c for c in fs.connectors if c.name.startswith(("C-N0004", "C-N0007", "C-N0010"))]
    [order] = [j for j in fs.joints if j.kind == JointKind.SLOT_SEAM]
    assert order.node == 7 and set(order.parts) == set(seam.parts) and order.connector is None
    # every part slides in along a direction within MAX_SLOT_SKEW of each of its crossings
    crate = [j for j in fs.joints if j.kind == JointKind.EGG_CRATE]
    for p in col:
        dirs = {tuple(j.insert_direction) for j in crate if p.name in j.parts}
        assert len(dirs) == 1
        for s in p.slots:
            ax = fs.structure.vertices_a[s.node] - fs.structure.vertices_b[s.node]
            assert _deg(next(iter(dirs)), ax / np.linalg.norm(ax)) <= MAX_SLOT_SKEW + 1e-9
    # the second part's direction does not run into the seam (its normal turned to that
    # part) by more than half the clearance over the fin's 100 mm depth
    n = fs._slot_seam_walls[7][order.parts[1]]
    assert order.insert_direction @ n <= 0.5 * C / 100.0
    r = verify_assembly(fs, workers=1)
    assert r.buildable, r.problems()


def test_a_seam_both_parts_would_close_falls_back_to_brackets_and_is_named():
    # rows 1 and 3 lean 3 deg the same way, row 2 not: split at row 2, where each part's
    # direction runs into the seam and the end rows' faces keep the other sense: butted
    # with brackets, and named
    fs = _build((0.0, 3.0, 0.0, 3.0, 0.0))
    fallbacks = {f.node: f for f in fs.joint_fallbacks}
    assert fallbacks[7].reason == SeamReason.CLOSES_SEAM and fallbacks[7].family == 1
    butts = [j for j in fs.joints if j.node == 7 and j.kind == JointKind.BUTT_BRACKET]
    assert len(butts) == 2 and all(j.connector for j in butts)
    assert 7 not in {s.node for s in fs.seams_in_slot}
    r = verify_assembly(fs, workers=1)
    assert r.buildable, r.problems()
