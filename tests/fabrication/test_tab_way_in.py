"""A tab is proved along the way its whole part goes in, not along any way its tab alone is
clear (issue 44).

The local check of a tab (:mod:`torsal.fabrication.builder.tab_check`) sees only the parts
near the tab. Free to try both senses of the part's axis, it once cleared a tab of example 9
(F1-S028-P07, tabbed at both ends) going in the other way, which the rest of the part could
not take (7,350 mm^3 through F0-S028-P04): the builder kept a tab the whole design's check
then refused. Now every part of a local check goes in only along the ways its joint records
give it (``check_assembly(ways=...)``), the ways the builder proved for the whole part.

The grid is ``test_fab_tabs``' (flat, rows family 0, columns family 1, 0.3 m apart, node
lines 0.1 m along z): column 1 comes down onto row 1's slot along -z, a tab at each end.
"""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest
from build123d import Box, Pos
from fab_structures import flat_structure

from torsal.fabrication import FinSystem, check_assembly
from torsal.fabrication.assembly.records import joints_of
from torsal.fabrication.builder.tabs import TabJoints, TabReason
from torsal.fabrication.model import FIXING_FAMILY, JointKind, PartId, _miter, quad_normals
from torsal.fabrication.plates.part import part_solid

T, C = 3.0, 0.5


def _build(**kw) -> FinSystem:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return FinSystem(flat_structure(4, 3), thickness=T, clearance=C, **kw)


def test_a_part_goes_in_only_along_the_ways_it_is_given():
    # q butts against the wall p and slides down along it (joint axis -z, travel 1 + the 1
    # unit tolerance); o, set down first (no joint), stands right over q: coming down (the
    # joint's sense) q sweeps through all of it, from below (the other sense) it meets
    # nothing. Free, the check takes the way from below; given the joint's way only, q is
    # blocked by o, by o's whole 1 unit^3
    solids = {"p": Pos(-1, 0, 0.5) * Box(1, 4, 4), "q": Pos(0, 0, 0.5) * Box(1, 1, 1),
              "o": Pos(0, 0, 2.5) * Box(1, 1, 1)}
    rec = type("J", (), dict(kind="butt-bracket", node=0, parts=("p", "q"), connector=None,
                             insert_direction=np.array([0.0, 0.0, -1.0]), depth=3.0))()
    free = check_assembly(solids, joints=[rec], workers=1, min_volume=1e-3)
    assert free.buildable, free.problems()
    [step] = [s for s in free.order if s.part == "q"]
    assert step.insert_direction == pytest.approx((0.0, 0.0, 1.0))     # from below
    bound = check_assembly(solids, joints=[rec], workers=1, min_volume=1e-3,
                           ways={"q": [(0.0, 0.0, -1.0)]})
    assert [s.part for s in bound.blocked] == ["q"]
    [hit] = bound.blocked[0].collisions
    assert hit.parts == ("q", "o") and hit.volume == pytest.approx(1.0, rel=1e-6)


def _obstacles(fs: FinSystem) -> list:
    """Two small angles standing over column 1's end on row 0 (node 1), one each side of the
    column, in the slab of its tab there: clear of every part in place, and of the column's
    way down but for its tab (in either corner it may bend it in); not on the way up."""
    [tj] = [t for t in fs.tab_joints if t.node == 1]
    tab = fs.part(tj.part).panels[tj.panel(fs.part(tj.part))]
    y = float(tab[:, 1].mean())                           # the tab's mid-plane
    proto = next(p for p in fs.parts if p.family == FIXING_FAMILY)
    out = []
    for k, (x0, x1) in enumerate(((282.0, 294.0), (306.0, 318.0))):
        q = np.array([[[x0, y, 130.0], [x0, y, 110.0], [x1, y, 110.0], [x1, y, 130.0]],
                      [[x0, y, 110.0], [x0, y + 15.0, 110.0], [x1, y + 15.0, 110.0],
                       [x1, y, 110.0]]])
        n = quad_normals(q)
        out.append(dataclasses.replace(proto, id=PartId(FIXING_FAMILY, 999, k), panels=q,
                                       miters=np.array([n[0], _miter(n[0], n[1]), n[1]]),
                                       holes=()))
    return out


def _whole(fs: FinSystem, extra: list) -> "AssemblyCheck":
    solids = dict(fs.solids())
    solids.update((q.name, part_solid(q, T)) for q in extra)
    return check_assembly(solids, joints=joints_of(fs), workers=1)


def test_a_tab_clear_only_the_other_way_keeps_its_bracket(monkeypatch):
    # the grid as built: column 1 bent into a tab at each end, going in along -z
    base = _build()
    [j1] = [j for j in base.joints if j.node == 1 and j.kind == JointKind.BUTT_TAB]
    assert j1.parts[-1] == "F1-S001-P00" and tuple(j1.insert_direction) == (0.0, 0.0, -1.0)
    obstacles = _obstacles(base)
    # with the angles standing there, that design cannot be built: the tab at node 1 runs
    # into one on the column's way in, and the other way the column runs into row 1
    r = _whole(base, obstacles)
    assert [s.part for s in r.blocked] == ["F1-S001-P00"], r.problems()
    # the builder sees the angles when it bends the tabs: a tab at node 1, in either corner,
    # is clear of them only going up, the way the column cannot go: refused, its bracket
    # stays, named
    make = TabJoints.make
    names = {q.name for q in obstacles}

    def make_beside(self):
        self.fs.parts += obstacles
        try:
            make(self)
        finally:
            self.fs.parts = [p for p in self.fs.parts if p.name not in names]
    monkeypatch.setattr(TabJoints, "make", make_beside)
    fs = _build()
    assert sorted(t.node for t in fs.tab_joints) == [0, 2, 3, 4, 7, 8, 9, 10, 11]
    [fall] = [f for f in fs.joint_fallbacks if isinstance(f.reason, TabReason)]
    assert (fall.node, fall.reason) == (1, TabReason.ASSEMBLY)
    assert "C-N0001-0 stays" in fall.detail and "hits A-E0999-" in fall.detail
    assert [c.name for c in fs.connectors] == ["C-N0001-0"]
    # and the design built beside them goes together, the angles standing where they are
    r = _whole(fs, obstacles)
    assert r.buildable, r.problems()
