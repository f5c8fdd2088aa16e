"""Tabs at a T of one family (issue 42): a strip that ends against another strip of its own
family (or against its own other part, where it is split at a sharp fold) bends into a tab
like any other butted end. The tabbed part's own end panel is no fold of the plate it meets
(before, it counted as one and the tab was refused 3.27 mm off the plate); the plate's own
other panels and the other strips of its family at the node still count (a tab onto the bar
of a T whose other strip turns towards the stem would cut into that strip), and then the
end tries its next place.

Three fins of family 0 meet at node 1 (x = 300 mm, node line 100 mm along z; metres in the
structure, mm in the parts): ``F0-S000`` from node 0 (0, 0) to node 1, ``F0-S001`` from node 1
on to node 2, ``F0-S002`` from node 1 to node 3 (300, 300) along +y, butted against
``F0-S000`` (the plane y = 0).
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from torsal.fabrication import FinSystem, JointKind, verify_assembly
from torsal.fabrication.builder.tab_sites import TabSites
from torsal.fabrication.builder.tabs import TabReason
from torsal.geometry.support import SupportStructure

T, C = 3.0, 0.5


def _tee(node2_y: float) -> FinSystem:
    """The T of family 0, node 2 at (0.6, ``node2_y``) m (0: ``F0-S001`` in line with
    ``F0-S000``; > 0: it turns towards ``F0-S002``)."""
    xy = np.array([[0, 0], [0.3, 0], [0.6, node2_y], [0.3, 0.3]], float)
    a = np.c_[xy, np.zeros(4)]
    s = SupportStructure(a, a + [0, 0, 0.1], [], np.array([[0, 1], [1, 2], [1, 3]]),
                         np.array([0, 0, 0]))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return FinSystem(s, thickness=T, clearance=C)


def test_a_tee_of_one_family_bends_into_a_tab_that_assembles():
    fs = _tee(0.0)
    # the stem's start bends into a tab onto the bar (F0-S000), in place of its bracket:
    # before, the stem's own end panel counted as the bar folding towards the tab, and the
    # tab was refused 3.27 mm off the bar (tab-geometry)
    [tj] = fs.tab_joints
    assert (tj.node, tj.part, tj.host, tj.start) == (1, "F0-S002-P00", "F0-S000-P00", True)
    assert not [f for f in fs.joint_fallbacks if isinstance(f.reason, TabReason)]
    [j] = [j for j in fs.joints if j.kind == JointKind.BUTT_TAB]
    assert j.connector is None and j.parts[-1] == "F0-S002-P00"
    # only the splice plate of the bar's two parts is a connector
    assert [c.name for c in fs.connectors] == ["C-N0001-0"]
    p = fs.part("F0-S002-P00")
    tab, end = p.panels
    # by hand: the bar's mid-plane is y = 0, the tab's a thickness and half the clearance
    # off it (its face C/2 off the bar's face y = T/2), on the bar's side x < 300
    assert tab[:, 1] == pytest.approx([T + C / 2] * 4)
    assert tab[1] == pytest.approx([300, T + C / 2, 0]) and tab[2] == pytest.approx([300, T + C / 2, 100])
    assert np.all(tab[[0, 3], 0] < 300 - T)
    # the stem's end panel ends on the bend line and runs on to node 3 (y = 300)
    assert end[[0, 3], 1] == pytest.approx([T + C / 2] * 2) and end[[1, 2], 1] == pytest.approx([300] * 2)
    leg = 300.0 - tab[0, 0]
    # the flat pattern (mid-surface, as every bend of the fins is unrolled): the end panel's
    # 300 - 3.25 mm and the tab's leg beyond the bend, one bend
    u = fs.unrolled()[p.name]
    assert u.fold_count == 1
    ue, ut = (np.asarray(x) for x in (u.panels[1], u.panels[0]))
    assert np.linalg.norm(ue[1] - ue[0]) == pytest.approx(300.0 - (T + C / 2), abs=1e-6)
    bend = (ut[2] - ut[1]) / np.linalg.norm(ut[2] - ut[1])
    off = ut[0] - ut[1]
    assert np.linalg.norm(off - (off @ bend) * bend) == pytest.approx(leg, abs=1e-6)
    # the whole design assembles (the independent check on every solid)
    r = verify_assembly(fs, workers=1)
    assert r.buildable and r.interfering_pairs == 0 and not r.blocked, r.problems()


def test_a_tab_the_bars_other_strip_turns_towards_goes_onto_that_strip():
    # F0-S001 turns towards the stem (node 2 at y = 100 mm: 18.4 deg off the bar's line).
    # By hand: its face on the stem's side is y = (x - 300) / 3 + (T/2) sqrt(10) / 3; at the
    # outer corner of a tab's bend onto F0-S000 (x = 300 + T/2) that is 2.08 mm, above the
    # tab's underside y = C/2 + T/2 = 1.75: a tab onto F0-S000 would cut 0.33 mm into
    # F0-S001, so another strip of the plate's family at the node still counts as the plate
    # folding towards the tab there ...
    fs = _tee(0.1)
    x = 300 + T / 2
    face = (x - 300) / 3 + (T / 2) * np.sqrt(10) / 3
    assert face == pytest.approx(2.081, abs=1e-3) and face > C / 2 + T / 2
    # ... and the end tries its next place: F0-S001 itself, which the local check proves
    [tj] = fs.tab_joints
    assert (tj.node, tj.part, tj.host, tj.start) == (1, "F0-S002-P00", "F0-S001-P00", True)
    assert not [f for f in fs.joint_fallbacks if isinstance(f.reason, TabReason)]
    tab, _ = fs.part("F0-S002-P00").panels
    # the tab lies flat on F0-S001's face on the stem's side: parallel to its mid-plane, its
    # underside (the tab's mid-plane T/2 nearer) no nearer than half the clearance to that
    # face and no farther than the clearance (farther is refused: tab-geometry)
    n = np.array([-1.0, 3.0, 0.0]) / np.sqrt(10)           # F0-S001's normal, stem's side
    d = (tab - [300, 0, 0]) @ n                              # the tab's mid-plane off F0-S001's
    assert np.ptp(d) < 1e-9
    assert T + C / 2 - 1e-9 <= d[0] <= T + C
    r = verify_assembly(fs, workers=1)
    assert r.buildable and r.interfering_pairs == 0 and not r.blocked, r.problems()
