"""A strip split at an egg-crate crossing meets on a mitred seam inside the crossing plate's
slot (issue 27): both parts are slotted at their ends, the crossing plate holds them, and the
joint needs no separate connector (it needed two brackets, and more where the parts then
butted on each other in a cycle).

Flat grid of 5 x 3 nodes (rows family 0, columns family 1, 0.3 m apart, node lines 0.1 m
along z), ``max_panels=2``: every row of four panels is split at its middle node; the middle
row's split (node 7) is an egg-crate crossing with column 2, the outer rows' (nodes 2, 12)
T junctions on the boundary.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from fab_structures import flat_structure
from shapely.geometry import Polygon

from torsal.fabrication import FinSystem, JointKind, verify_assembly

T, C = 3.0, 0.5


def _build():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return FinSystem(flat_structure(5, 3), thickness=T, clearance=C, max_panels=2)


@pytest.fixture(scope="module")
def fs():
    return _build()


def test_the_split_at_a_crossing_is_held_by_the_slot_without_a_connector(fs):
    [x] = [j for j in fs.joints if j.node == 7]
    assert x.kind == JointKind.EGG_CRATE and x.connector is None
    assert x.parts == ("F0-S001-P00", "F0-S001-P01", "F1-S002-P00")
    assert not [c for c in fs.connectors if c.id.strip == 7]
    # each part of the row slotted at its end (from the b edge, half the 100 mm depth), the
    # column from its a edge: one crossing with both halves in its slot
    left, right = fs.part("F0-S001-P00"), fs.part("F0-S001-P01")
    [sl] = [s for s in left.slots if s.node == 7]
    [sr] = [s for s in right.slots if s.node == 7]
    assert (sl.position, sr.position) == (2, 0)
    assert sl.side.value == sr.side.value == "b" and sl.depth == sr.depth == pytest.approx(50.0)
    [c7] = [c for c in fs.crossings if c.node == 7]
    assert c7.parts0 == ("F0-S001-P00", "F0-S001-P01") and c7.parts1 == ("F1-S002-P00",)
    # the two ends stand clearance/2 off the node line (x = 600 mm): the seam is open
    assert left.panels[-1][[1, 2], 0] == pytest.approx([600 - C / 2] * 2)
    assert right.panels[0][[0, 3], 0] == pytest.approx([600 + C / 2] * 2)
    # unrolled, the slot at its end is half a slot, centred on the trimmed end: the end stands
    # clearance/2 + width/2 off the node line over the slot's depth, the column's face t/2
    u = fs.unrolled()["F0-S001-P00"]
    [s6] = [s for s in left.slots if s.node == 6]
    full = sum(Polygon(f).area for f in u.panels)
    assert full - u.outline.area == pytest.approx((s6.width + sl.width / 2) * sl.depth, rel=1e-9)
    # from the end butted against column 0 (trimmed T/2 + C/2 off x = 0) to the seam
    assert u.outline.bounds[2] - u.outline.bounds[0] == pytest.approx(600 - C / 2 - (T + C) / 2)


def test_the_seam_in_the_slot_is_buildable(fs):
    r = verify_assembly(fs, workers=1)
    assert r.buildable and r.interfering_pairs == 0 and not r.blocked, r.problems()
    assert fs.unslotted_solids == []


def test_the_connectors_it_saves_on_the_parts_list(fs, monkeypatch):
    # control: the same grid with the split butted against the column, as before: brackets
    monkeypatch.setattr(FinSystem, "_seams_in_slots", lambda self, *a: set())
    before = _build()
    at7 = [c.name for c in before.connectors if c.id.strip == 7]
    assert len(at7) >= 2
    assert len(before.connectors) - len(fs.connectors) >= len(at7)
    assert before.n_panels == fs.n_panels == 22
