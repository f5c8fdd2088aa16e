"""The load path (issue 42): every part must reach the building through joints that hold it.

Constructed cases checked by hand: a chain of parts fixed to the building, the same chain with
one joint's bolt taken away (the far parts are named), a tab bolted to the other part of a
split plate than the one fixed, slots that hold a plate against its weight or let it slide
out, and a real fin system of a 3 x 3 grid (fixings, brackets, two corners without one).
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from torsal.fabrication.assembly import (BUILDING, AssemblyJoint, Fastening, check_load_path,
                                         fastenings_of, load_path)
from torsal.fabrication.model import CONNECTOR_FAMILY, FIXING_FAMILY, Hole, Part, PartId

Z = np.array([0.0, 0.0, 1.0])


def _chain():
    """Fixing A (anchored) - bolt - plate P1 - bracket C (bolted to P1 and P2) - P2 - bolt
    (a tab of P3 on P2) - P3: a chain of five parts out from the building."""
    names = ["A-E0000-0", "F0-S000-P00", "C-N0001-0", "F1-S000-P00", "F1-S001-P00"]
    bolts = [Fastening(("A-E0000-0", BUILDING), "M8 anchor"),
             Fastening(("A-E0000-0", "F0-S000-P00"), "M6 bolt"),
             Fastening(("C-N0001-0", "F0-S000-P00"), "M6 bolt"),
             Fastening(("C-N0001-0", "F1-S000-P00"), "M6 bolt"),
             Fastening(("F1-S000-P00", "F1-S001-P00"), "M6 bolt")]
    joints = [AssemblyJoint("fixing", 0, ("A-E0000-0", "F0-S000-P00"), -Z),
              AssemblyJoint("butt-bracket", 1, ("F0-S000-P00", "F1-S000-P00", "C-N0001-0"), -Z,
                            "C-N0001-0"),
              AssemblyJoint("butt-tab", 2, ("F1-S000-P00", "F1-S001-P00"), -Z)]
    return names, joints, bolts


def test_a_chain_fixed_to_the_building_is_one_component():
    names, joints, bolts = _chain()
    lp = check_load_path(names, joints, bolts)
    assert lp.supported and lp.unsupported_parts == [] and lp.components == 1
    assert lp.edges == {"anchor": 1, "bolt": 4} and lp.unfastened_joints == []
    assert lp.problems() == ""
    r = lp.report()
    assert r["supported"] and r["components"] == 1 and r["unsupported_parts"] == []


def test_a_bracket_without_its_bolt_leaves_the_far_parts_named():
    names, joints, bolts = _chain()
    # the bracket's leg on F1-S000-P00 has no bolt: F1-S000-P00 and the part on its tab hang
    # on nothing; the bracket itself is still bolted to F0-S000-P00
    cut = [b for b in bolts if b.parts != ("C-N0001-0", "F1-S000-P00")]
    lp = check_load_path(names, joints, cut)
    assert lp.unsupported_parts == ["F1-S000-P00", "F1-S001-P00"]
    assert lp.groups == [["F1-S000-P00", "F1-S001-P00"]] and lp.components == 2
    assert lp.unfastened_joints == [
        ("butt-bracket", 1, ("F0-S000-P00", "F1-S000-P00", "C-N0001-0"))]
    msg = lp.problems()
    assert "2 parts do not reach the building" in msg and "F1-S000-P00, F1-S001-P00" in msg
    assert "butt-bracket at node 1" in msg and "fixings" in msg
    # without the anchor nothing reaches the building: every part named, one loose group
    lp = check_load_path(names, joints, bolts[1:])
    assert lp.unsupported_parts == sorted(names) and lp.components == 1 and len(lp.groups) == 1
    assert lp.bare_connectors == []
    # a bracket without a single bolt (no room for a hole) is loose, and named as such
    bare = [b for b in bolts if "C-N0001-0" not in b.parts]
    lp = check_load_path(names, joints, bare)
    assert lp.unsupported_parts == ["C-N0001-0", "F1-S000-P00", "F1-S001-P00"]
    assert lp.bare_connectors == ["C-N0001-0"]
    assert "1 of them are connectors without" in lp.problems()


def test_nothing_is_judged_without_fastenings():
    names, joints, _ = _chain()
    lp = check_load_path(names, joints, None)
    assert not lp.checked and lp.supported and lp.report()["checked"] is False


def _flat(fid: PartId, x0: float, x1: float, z: float, holes=()) -> Part:
    """A flat rectangular plate ``x0..x1`` by 0..100 in the plane ``z`` (normal +z)."""
    q = np.array([[[x0, 0, z], [x1, 0, z], [x1, 100, z], [x0, 100, z]]], float)
    return Part(id=fid, panels=q, nodes=np.array([-1, -1]), edges=np.array([-1]),
                holes=tuple(holes))


class _System:
    def __init__(self, parts, thickness=3.0):
        self.parts, self.thickness = parts, thickness


def test_a_tab_holds_to_the_part_of_a_split_plate_its_bolt_goes_through():
    # the plate F0-S000 is split at x = 100 into P00 and P01; the tab of F1-S000-P00 lies on
    # P01 (mid-surface 3.5 mm above it: t + gap), its hole at (150, 50); P01 has the matching
    # hole right below. The fixing's bolt goes through P00 only (hole at (50, 50)), its anchor
    # into the building.
    m6, m8 = 6.6, 9.0
    pa = _flat(PartId(0, 0, 0), 0, 100, 0.0, [Hole(np.array([50, 50, 0.0]), m6, 0, "M6 bolt")])
    pb = _flat(PartId(0, 0, 1), 100, 200, 0.0, [Hole(np.array([150, 50, 0.0]), m6, 0, "M6 bolt")])
    tab = _flat(PartId(1, 0, 0), 120, 180, 3.5,
                [Hole(np.array([150, 50, 3.5]), m6, 0, "M6 bolt", own=True)])
    fixing = _flat(PartId(FIXING_FAMILY, 0, 0), 20, 80, -3.5,
                   [Hole(np.array([50, 50, -3.5]), m6, 0, "M6 bolt"),
                    Hole(np.array([30, 10, -3.5]), m8, 0, "M8 anchor")])
    # two brackets whose holes miss P00's: 10 mm above it on its hole's axis (more than 3 t),
    # and 3.5 mm above it but 0.7 mm across the axis (more than a tenth of 6.6 mm)
    far = _flat(PartId(CONNECTOR_FAMILY, 1, 0), 40, 60, 10.0,
                [Hole(np.array([50, 50, 10.0]), m6, 0, "M6 bolt")])
    aside = _flat(PartId(CONNECTOR_FAMILY, 1, 1), 40, 60, 3.5,
                  [Hole(np.array([50.7, 50, 3.5]), m6, 0, "M6 bolt")])
    fs = _System([pa, pb, tab, fixing, far, aside])
    got = fastenings_of(fs)
    # a part listed twice is one part: its holes do not bolt it to itself
    assert fastenings_of(_System(fs.parts + [fixing])) == got
    assert got == [Fastening(("A-E0000-0", "F0-S000-P00"), "M6 bolt"),
                   Fastening(("A-E0000-0", BUILDING), "M8 anchor"),
                   Fastening(("F0-S000-P01", "F1-S000-P00"), "M6 bolt")]
    names = [p.name for p in fs.parts]
    tab_joint = AssemblyJoint("butt-tab", 3, ("F0-S000-P00", "F0-S000-P01", "F1-S000-P00"), -Z)
    lp = check_load_path(names, [tab_joint], got)
    # the tab is bolted to P01, which nothing holds to the building: the tab's part and P01
    # hang together; the two brackets are loose, each on its own
    assert lp.unsupported_parts == ["C-N0001-0", "C-N0001-1", "F0-S000-P01", "F1-S000-P00"]
    assert lp.groups == [["F0-S000-P01", "F1-S000-P00"], ["C-N0001-0"], ["C-N0001-1"]]
    assert lp.components == 4
    assert lp.unfastened_joints == []           # the tab is bolted to a part of its plate
    # a splice bolt between the two halves of the plate: everything but the far bracket holds
    spliced = got + [Fastening(("F0-S000-P00", "F0-S000-P01"), "M6 bolt")]
    lp = check_load_path(names, [tab_joint], spliced)
    assert lp.unsupported_parts == ["C-N0001-0", "C-N0001-1"]


@pytest.mark.parametrize("d, holds_later, holds_earlier", [
    ((0, 0, -1), True, False),      # slid down onto the fixed plate: its weight keeps it there
    ((0, 0, 1), False, True),       # slid up into place: it falls out the way it came
    ((1, 0, 0), True, True),        # horizontal: the slots bear its weight either way
    # the later plate's way out dips 4 deg below the horizontal: held (5 deg allowed); 6 deg:
    # not (the earlier plate's way off rises: held either way)
    ((np.cos(np.radians(4)), 0, np.sin(np.radians(4))), True, True),
    ((np.cos(np.radians(6)), 0, np.sin(np.radians(6))), False, True),
])
def test_a_slot_holds_a_plate_unless_its_weight_draws_it_out(d, holds_later, holds_earlier):
    names = ["A-E0000-0", "F0-S000-P00", "F1-S000-P00"]
    slot = AssemblyJoint("egg-crate", 4, ("F0-S000-P00", "F1-S000-P00"), np.array(d, float))
    fixed0 = [Fastening(("A-E0000-0", BUILDING), "M8 anchor"),
              Fastening(("A-E0000-0", "F0-S000-P00"), "M6 bolt")]
    lp = check_load_path(names, [slot], fixed0)
    assert (lp.unsupported_parts == []) == holds_later
    if holds_later:                 # held by its slot only: named as such
        assert lp.slot_held_parts == ["F1-S000-P00"] and lp.edges["slot"] == 1
    else:                           # named with the dip of its way out: 90 or 6 deg
        dip = 90.0 if d[2] > 0.5 else 6.0
        assert lp.sliding_out == {"F1-S000-P00": pytest.approx(dip, abs=1e-9)}
    # the same crossing with the later plate fixed and the earlier one hanging on it
    fixed1 = [Fastening(("A-E0000-0", BUILDING), "M8 anchor"),
              Fastening(("A-E0000-0", "F1-S000-P00"), "M6 bolt")]
    lp = check_load_path(names, [slot], fixed1)
    assert (lp.unsupported_parts == []) == holds_earlier
    if not holds_earlier:
        assert lp.unsupported_parts == ["F0-S000-P00"] and lp.components == 2
        # its way off the later plate is +d: straight down here
        assert lp.sliding_out == {"F0-S000-P00": 90.0} and "dips up to 90 deg" in lp.problems()


def test_a_real_grid_with_two_corners_without_a_bracket_still_reaches_the_building():
    pytest.importorskip("build123d")
    from test_fab_joints import sheared_grid

    from torsal.fabrication import FinSystem

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # the two corners without a bracket are named
        fs = FinSystem(sheared_grid(20.0), thickness=3.0, clearance=0.5, tabs=False)
    lp = load_path(fs)
    # 4 fixings on the outer rows, each anchored and bolted; 8 brackets, two bolts each; the
    # two L corners the builder named in unconnected_joints ("fasten them on site") hold
    assert lp.edges == {"anchor": 4, "bolt": 4 + 2 * 8, "site": 2} and lp.supported
    assert lp.components == 1
    assert sorted((n, p[-1]) for _, n, p in lp.unfastened_joints) == [
        (0, "F1-S000-P00"), (8, "F1-S002-P00")]
    assert sorted((n, p[-1]) for _, n, p in lp.site_fastened) == [
        (0, "F1-S000-P00"), (8, "F1-S002-P00")]
    assert sorted(v for _, v, _ in fs.unconnected_joints) == [0, 8]
    # the third column hangs on the brackets at nodes 2 and 5 and on the site fastening at
    # 8: without their bolts into it, only node 8 holds it; without that joint too, it is
    # named, and only it
    bolts = [f for f in fastenings_of(fs) if "F1-S002-P00" not in f.parts]
    lp = check_load_path([p.name for p in fs.parts], fs.joints, bolts)
    assert lp.supported and sorted(n for _, n, _ in lp.unfastened_joints) == [0, 2, 5, 8]
    joints = [j for j in fs.joints if not (j.node == 8 and "F1-S002-P00" in j.parts)]
    lp = check_load_path([p.name for p in fs.parts], joints, bolts)
    assert lp.unsupported_parts == ["F1-S002-P00"] and lp.components == 2


def test_a_connector_leg_without_a_hole_is_welded_to_its_plate():
    """The builder drills no hole in a leg too small for one (the parts list counts such a
    connector ``without_holes``: welded or bonded): read from the holes, that leg is a weld
    to the plate it lies on, which holds; a leg that lies on no plate of its joint welds to
    nothing."""
    pytest.importorskip("build123d")
    import dataclasses

    from test_fab_joints import sheared_grid

    from torsal.fabrication import FinSystem
    from torsal.fabrication.assembly.load_path import WELD

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fs = FinSystem(sheared_grid(20.0), thickness=3.0, clearance=0.5, tabs=False)
    bracket = next(p for p in fs.parts if p.name.startswith("C-"))
    joint = next(j for j in fs.joints if j.connector == bracket.name)
    before = fastenings_of(fs)
    bolted = sorted(f.parts for f in before if bracket.name in f.parts)
    assert len(bolted) == 2 and not any(f.fastener == WELD for f in before)
    # take the holes out of the bracket's first leg (and its plate's matching hole stays:
    # only the bracket's own holes make a bolt)
    legs = {h.panel for h in bracket.holes}
    assert legs == {0, 1}
    stripped = dataclasses.replace(bracket, holes=tuple(h for h in bracket.holes if h.panel != 0))
    fs.parts = [stripped if p.name == bracket.name else p for p in fs.parts]
    after = fastenings_of(fs)
    welds = [f.parts for f in after if f.fastener == WELD]
    assert len(welds) == 1 and welds[0] in bolted                 # the same pair, now a weld
    assert set(welds[0]) - {bracket.name} <= set(joint.parts)
    lp = check_load_path([p.name for p in fs.parts], fs.joints, after)
    assert lp.supported and lp.welded == welds and lp.edges["weld"] == 1
    assert lp.report()["welded"] == [list(welds[0])]
