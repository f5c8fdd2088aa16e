"""A butted part end bent into a tab bolted to the plate it meets, instead of a bracket,
wherever the assembly check on the parts around that joint proves it; a tab it refuses leaves
the bracket, counted and named (issue 42).

Flat grids of nodes (rows family 0, columns family 1, 0.3 m apart, node lines 0.1 m along z,
see ``fab_structures``): every row and column ends against the plate across it at the
boundary (T and L junctions).
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from fab_structures import flat_structure

from torsal.fabrication import FinSystem, JointKind, verify_assembly
from torsal.fabrication.builder import tab_check, tab_sites
from torsal.fabrication.builder.fasteners import fastener_counts, part_fastening
from torsal.fabrication.builder.tabs import TabReason, with_tabs
from torsal.fabrication.joints import _Untrimmable, tab_panel
from torsal.fabrication.model import quad_normals

T, C = 3.0, 0.5


def _build(structure, **kw) -> FinSystem:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return FinSystem(structure, thickness=T, clearance=C, **kw)


@pytest.fixture(scope="module")
def grid():
    # 4 x 3 grid: rows 0 and 2 carry the columns' ends, the columns carry row 1's ends; the
    # two inner crossings are egg-crates
    return _build(flat_structure(4, 3))


def test_the_ends_of_a_grid_bend_into_tabs_and_need_no_connector(grid):
    fs = grid
    butts = [j for j in fs.joints if j.kind in (JointKind.BUTT_BRACKET, JointKind.BUTT_TAB)]
    assert len(butts) == 10 and all(j.kind == JointKind.BUTT_TAB for j in butts)
    assert not fs.connectors and all(j.connector is None for j in butts)
    assert len(fs.tab_joints) == 10
    assert not [f for f in fs.joint_fallbacks if isinstance(f.reason, TabReason)]
    # every column ends with a tab at both ends (one panel more at each), row 1 too
    for name in ("F1-S000-P00", "F1-S001-P00", "F1-S002-P00", "F1-S003-P00"):
        assert len(fs.part(name).panels) == 2 + 2
    assert len(fs.part("F0-S001-P00").panels) == 3 + 2
    # a joint record names the plate it lies on, then the tabbed part (placed after it)
    [j] = [j for j in butts if j.node == 4]
    assert j.parts == ("F1-S000-P00", "F0-S001-P00")
    # and the whole design assembles, by the independent check on every solid
    r = verify_assembly(fs, workers=1)
    assert r.buildable and r.interfering_pairs == 0 and not r.blocked, r.problems()


def test_a_tab_lies_on_the_plate_it_meets_half_the_clearance_off_its_face(grid):
    fs = grid
    [tj] = [t for t in fs.tab_joints if t.node == 4]           # row 1's start on column 0
    assert (tj.part, tj.host, tj.start) == ("F0-S001-P00", "F1-S000-P00", True)
    p, host = fs.part(tj.part), fs.part(tj.host)
    tab, end = p.panels[tj.panel(p)], p.panels[tj.panel(p) + 1]
    hq = host.panels[tj.host_panel]
    n = quad_normals(hq[None])[0]
    n = n if (end.mean(axis=0) - hq.mean(axis=0)) @ n > 0 else -n
    # the tab's mid-plane: a thickness and half the clearance off the column's (its face
    # half the clearance off the column's face), parallel to it
    assert (tab - hq[0]) @ n == pytest.approx([T + C / 2] * 4)
    # the row's end panel ends on the bend line, which the tab shares: folded 90 degrees
    assert np.allclose(tab[[1, 2]], end[[0, 3]])
    assert np.degrees(abs(p.fold_angles[0])) == pytest.approx(90.0)
    # the miters: a square cap at the tab's free edge, the fold's mitre at the bend
    nt, ne = quad_normals(np.array([tab, end]))
    assert p.miters[0] == pytest.approx(nt)
    assert p.miters[1] @ nt == pytest.approx(1.0) and p.miters[1] @ ne == pytest.approx(1.0)
    # the tab narrows to the free edge of the bracket it replaces (the node line's middle half)
    free = np.linalg.norm(tab[3] - tab[0])
    bend = np.linalg.norm(tab[2] - tab[1])
    assert free == pytest.approx(0.5 * 100.0) and bend == pytest.approx(100.0)


def test_the_flat_pattern_the_holes_and_the_counts_take_the_tab(grid):
    fs = grid
    # the tab is part of the outline, its bend line a bend of the part
    p = fs.part("F1-S001-P00")
    u = fs.unrolled()[p.name]
    assert len(u.panels) == 4 and u.fold_count == 2
    tabs = [t for t in fs.tab_joints if t.part == p.name]
    assert len(tabs) == 2
    # each tab is drilled like the bracket leg it replaces, the bolts counted at the tab
    # (own holes) and the matching holes in the plate it lies on
    for tj in tabs:
        own = [h for h in p.holes if h.own and h.panel == tj.panel(p)]
        assert len(own) == 2 and all(h.fastener == "M6 bolt" for h in own)
        host = fs.part(tj.host)
        for h in own:
            assert min(np.linalg.norm(m.center - h.center) for m in host.holes
                       if m.panel == tj.host_panel) == pytest.approx(T + C / 2)
    counts = fastener_counts(fs)
    rows = part_fastening(fs)
    assert counts["butt-tab"].connectors == 0 and counts["butt-tab"].bolts == 2 * 10
    assert rows[p.name]["fasteners"] == 4 and rows[p.name]["fastener"] == "M6 bolt"
    # the parts list counts every bolt and anchor once
    assert sum(r["fasteners"] for r in rows.values()) == sum(c.bolts + c.anchors
                                                           for c in counts.values())


def test_step_dxf_and_parts_list_agree_on_the_tabs(grid, tmp_path):
    # the solids (STEP), the flat pattern (DXF) and the parts list say the same of every
    # tabbed part: one solid and one row per part, the tab in its outline, its bend a fold
    # line of the sheet and a bend of the row, its holes cut, its bolts counted on its row
    import csv

    import ezdxf

    from torsal.fabrication import read_step

    fs = grid
    step = read_step(fs.export_step(tmp_path / "fins.step"))
    lay = fs.layout(sheet=(1250.0, 625.0))
    fs.bill_of_materials(tmp_path / "parts.csv", layout=lay)
    with open(tmp_path / "parts.csv", newline="") as f:
        rows = {r["part_id"]: r for r in csv.DictReader(f)}
    assert sorted(n for n, _ in step) == sorted(rows) == sorted(p.name for p in fs.parts)
    unrolled = fs.unrolled()
    for tj in fs.tab_joints:
        p, row = fs.part(tj.part), rows[tj.part]
        assert row["kind"] == "plate" and int(row["panels"]) == len(p.panels)
        n_tabs = sum(1 for t in fs.tab_joints if t.part == p.name)
        assert int(row["fold_count"]) == unrolled[p.name].fold_count >= n_tabs
        assert int(row["fasteners"]) == sum(1 for h in p.holes if h.own and not h.shared)
    # the flat tab is the part's outline beyond its bend: the outline (without the slots) is
    # as large as the panels, tabs with them
    from torsal.fabrication.unroll import unroll

    p = fs.part("F0-S001-P00")
    assert unroll(p, slots=[]).outline.area == pytest.approx(p.panel_areas.sum(), rel=1e-9)
    # every hole, the tabs' with them, drawn once in the sheets; every bend a fold line
    circles, folds = [], 0
    for path in lay.export_dxf(tmp_path / "cut.dxf", svg=False):
        msp = ezdxf.readfile(path).modelspace()
        circles += [2 * e.dxf.radius for e in msp.query("CIRCLE[layer=='NOMINAL']")]
        folds += len(msp.query("LINE[layer=='FOLD']"))
    assert sorted(round(d, 6) for d in circles) == sorted(round(h.diameter, 6)
                                                          for q in fs.parts for h in q.holes)
    assert folds == sum(x.fold_count for x in unrolled.values())
    # the flat holes of a tab lie inside the flat tab
    from shapely.geometry import Point, Polygon

    for tj in fs.tab_joints:
        q = fs.part(tj.part)
        u = unrolled[q.name]
        flat_tab = Polygon(u.panels[tj.panel(q)])
        mine = [i for i, h in enumerate(q.holes) if h.own and h.panel == tj.panel(q)]
        assert mine and all(flat_tab.contains(Point(*u.holes[i][0])) for i in mine), q.name


def test_a_tab_the_assembly_check_refuses_leaves_its_bracket(monkeypatch):
    # tabs sunk 1 mm into the plate they lie on (a gap of -1 mm): the parts around each joint
    # interfere, the check on them refuses every tab, and every bracket stays, each named
    # among the fallbacks with what the check found
    monkeypatch.setattr(tab_sites, "TAB_GAP", -2.0)
    checked = []
    local = tab_check._local_check
    monkeypatch.setattr(tab_check, "_local_check",
                        lambda ask: checked.append(sorted(p.name for p in ask[0])) or local(ask))
    fs = _build(flat_structure(4, 3))
    assert not fs.tab_joints
    butts = [j for j in fs.joints if j.kind in (JointKind.BUTT_BRACKET, JointKind.BUTT_TAB)]
    assert len(butts) == 10 and all(j.kind == JointKind.BUTT_BRACKET and j.connector for j in butts)
    assert len(fs.connectors) == 10
    falls = [f for f in fs.joint_fallbacks if isinstance(f.reason, TabReason)]
    assert len(falls) == 10 and {f.reason for f in falls} == {TabReason.ASSEMBLY}
    [f4] = [f for f in falls if f.node == 4]
    assert f4.family == 0 and f4.parts == ("F1-S000-P00", "F0-S001-P00")
    assert "C-N0004-0 stays" in f4.detail and "interfere" in f4.detail
    assert any("F0-S001-P00" in names and "F1-S000-P00" in names for names in checked)
    # the parts are those of the design with brackets: no tab panel
    assert len(fs.part("F0-S001-P00").panels) == 3
    r = verify_assembly(fs, workers=1)
    assert r.buildable, r.problems()


def test_an_end_bracketed_in_both_corners_bends_into_one_tab():
    # 5 x 5 grid, max_panels=2: row 2 and column 2 are both split at the middle node 12; the
    # column's halves were bracketed to both halves of the row (a bridge across its seam):
    # each half bends into a tab in one corner; of the two brackets left in the other
    # corners one still bridges the row's seam, the other joins parts the rest joins already
    # and goes (a spare bracket, named)
    fs = _build(flat_structure(5, 5), max_panels=2)
    at12 = [j for j in fs.joints if j.node == 12 and j.kind in (JointKind.BUTT_BRACKET,
                                                                JointKind.BUTT_TAB)]
    tabbed = sorted(j.parts[-1] for j in at12 if j.kind == JointKind.BUTT_TAB)
    assert tabbed == ["F1-S002-P00", "F1-S002-P01"]
    [bracket] = [j for j in at12 if j.kind == JointKind.BUTT_BRACKET]
    assert bracket.connector and bracket.parts[-2] in tabbed
    [second] = [f for f in fs.joint_fallbacks if f.node == 12 and f.reason == TabReason.SECOND_CORNER]
    assert "other corner" in second.detail and bracket.connector in second.detail
    [(node, spare, parts, why)] = [s for s in fs.spare_brackets if s[0] == 12]
    assert spare not in {c.name for c in fs.connectors} and "joined at node 12" in why
    # the four parts at the node are joined: each half of the column to the row by its tab,
    # one of them to the other half of the row by the bracket
    pairs = {(t.host, t.part) for t in fs.tab_joints if t.node == 12}
    (h, _), (q, _) = fs._sites[bracket.connector][2][0][6]
    pairs.add((h, q))
    assert {x for pq in pairs for x in pq} == {"F0-S002-P00", "F0-S002-P01", "F1-S002-P00",
                                               "F1-S002-P01"} and len(pairs) == 3
    r = verify_assembly(fs, workers=1)
    assert r.buildable, r.problems()


def test_the_tab_kernel():
    # a fin along y ending against a plate in the plane y = 0, the end trimmed back as a butt
    # end (clearance/2 off the plate's face); the free edge as a bracket leg's
    q = np.array([[0, 1.75, 0], [0, 50, 0], [0, 50, 40], [0, 1.75, 40.0]])
    host = np.array([[-60, 0, -5], [60, 0, -5], [60, 0, 45], [-60, 0, 45.0]])
    free = np.array([[20, 0, 10], [20, 0, 30.0]])
    g = tab_panel(q, True, host, np.array([0, 1.0, 0]), free, thickness=T, gap=C / 2)
    assert g.moved[0] == pytest.approx([0, T + C / 2, 0]) and g.moved[3] == pytest.approx([0, T + C / 2, 40])
    assert g.tab[:, 1] == pytest.approx([T + C / 2] * 4) and g.fold == pytest.approx(90.0)
    # the end as a part: the tab before the end panel, one bend
    from torsal.fabrication.model import Part, PartId
    n = quad_normals(q[None])[0]
    p = Part(PartId(0, 0, 0), q[None].copy(), np.array([3, 4]), np.array([7]),
             miters=np.array([n, n]))
    t = with_tabs(p, {True: g})
    assert len(t.panels) == 2 and list(t.nodes) == [-1, 3, 4] and list(t.edges) == [-1, 7]
    assert np.allclose(t.panels[0], g.tab) and np.allclose(t.panels[1][[0, 3]], g.tab[[1, 2]])
    # an oblique corner: the fin at 60 degrees to the plate, the tab in the open corner
    # (120 degrees) bends by 60
    d = np.array([np.cos(np.radians(60)), np.sin(np.radians(60)), 0.0])
    q2 = np.array([1.75 / d[1] * d, 50 * d, 50 * d + [0, 0, 40], 1.75 / d[1] * d + [0, 0, 40]])
    g2 = tab_panel(q2, True, host, np.array([0, 1.0, 0]), np.array([[-20, 0, 10], [-20, 0, 30.0]]),
                   thickness=T, gap=C / 2)
    assert g2.fold == pytest.approx(60.0) and g2.moved[0][1] == pytest.approx(T + C / 2)
    # an end trimmed back farther than the bend (it clears another part there): no tab
    q3 = q.copy()
    q3[[0, 3], 1] = 5.0
    with pytest.raises(_Untrimmable, match="off the plate"):
        tab_panel(q3, True, host, np.array([0, 1.0, 0]), free, thickness=T, gap=C / 2)
