"""The final cut splits a long plate at a crossing slot where that empties a sheet: the seam
stays in the slot (no connector), the sheets' yield rises, the parts stay buildable, and the
same design gives the same split, parts and sheets every time (issues 40, 42).

A flat grid (``fab_structures.flat_structure``: rows family 0, 900 mm, columns family 1,
600 mm, 100 mm deep) on a 1000 x 330 mm sheet: three 100 mm rows a sheet. Each 900 mm row
and each 600 mm column takes a row of its own (two columns do not fit one), and all seven
cross the sheet's middle: three sheets, whatever the nesting (the crossing bound). One column
cut at its middle node, where it crosses the middle row, gives two 300 mm pieces that fill
the ends of two column rows: two sheets.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from fab_structures import flat_structure

from torsal.fabrication import FinSystem, verify_assembly
from torsal.fabrication.builder.seams import yield_cut_positions
from torsal.fabrication.nesting import crossing_bound, nest_search
from torsal.fabrication.nesting import final_cut as fc
from torsal.fabrication.nesting.split import CutCost, nest_split
from torsal.fabrication.quantities import Rates, bill_of_quantities
from torsal.fabrication.cutting import Process

T, C = 3.0, 0.5
SHEET = (1000.0, 330.0)
OPTIONS = dict(sheet=SHEET, gap=5.0, margin=10.0, cutting=None, rotation_step=None, tries=600,
               time_limit=None)


def _build(structure, **kw) -> FinSystem:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return FinSystem(structure, thickness=T, clearance=C, **kw)


def _lead(fs, name: str) -> int:
    """1 where the part starts with a tab bent from its end (a panel of no fin), else 0."""
    return int(fs.part(name).edges[0] < 0)


@pytest.fixture(scope="module")
def grid():
    return _build(flat_structure(4, 3))


@pytest.fixture(scope="module")
def cut(grid):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fc.final_cut(grid, OPTIONS)


def test_the_long_plates_cannot_fill_the_sheets(grid):
    outlines = [u.outline for u in grid.unrolled().values()]
    assert crossing_bound(outlines, sheet=SHEET, sep=5.0, edge=10.0) == 3
    lay = nest_search(list(grid.unrolled().values()), **OPTIONS)
    assert lay.n_sheets == 3 and lay.utilization < 0.6


def test_a_plate_may_be_cut_where_it_is_slotted(grid):
    sites = yield_cut_positions(grid)
    # the middle row at both its inner nodes, columns at the middle row (node line 1 of their
    # fin panels, 2 of the part: every end bends into a tab, the part's panel 0 at its start):
    # each where the plate is slotted at an egg-crate crossing
    assert all(_lead(grid, n) == 1 for n in sites)
    assert sites["F0-S001-P00"] == (1 + 1, 2 + 1)
    assert all(js == (1 + 1,) for n, js in sites.items() if n.startswith("F1-"))
    assert all(all(grid.part(n).nodes[j] in {s.node for s in grid.part(n).slots} for j in js)
               for n, js in sites.items())


def test_the_split_empties_a_sheet_with_a_seam_in_the_slot(grid, cut):
    fs2, lay, split = cut
    assert fs2 is not grid and split.kept, split.why
    assert (split.sheets_before, split.sheets_after, lay.n_sheets) == (3, 2, 2)
    assert split.utilization_after > split.utilization_before + 0.25
    [p] = split.plates
    assert p["plate"].startswith("F1-") and len(p["pieces"]) == 2
    assert p["node_lines"] == [1 + _lead(grid, p["plate"])]
    # the cut is a seam held in the crossing slot: no connector, no fastener, no fixing more
    assert split.seams == 1 and split.fallbacks == []
    d = split.delta
    assert d["parts"] == 1 and d["pierces"] == 1 and d["connectors"] == 0 and d["bolts"] == 0
    assert d["anchors"] == 0 and d["fixings"] == 0 and d["panels_left_out"] == 0
    assert 0 < d["cut_m"] < 0.25           # the seam's two edges, less the slot they cut through
    assert len(fs2.connectors) == len(grid.connectors)
    [seam] = [s for s in fs2.seams_in_slot if s.node == p["nodes"][0]]
    assert seam.family == 1 and set(seam.parts) == set(p["pieces"])
    # the layout holds every part of the new fin system, each once, the pieces where their
    # stand-ins lay (nothing was placed again)
    assert sorted(pl.name for pl in lay.placements) == sorted(q.name for q in fs2.parts)
    assert "parts_placed_again" not in d
    report = lay.stats.split
    assert report["kept"] and report["sheets_saved"] == 1 and report["plates"][0] == p


def test_the_split_parts_are_laid_out_apart(cut):
    fs2, lay, _ = cut
    import shapely

    for s in range(lay.n_sheets):
        polys = [pl.polygon for pl in lay.placements if pl.sheet == s]
        for i, a in enumerate(polys):
            assert min(shapely.distance(a, polys[i + 1:]), default=np.inf) >= 5.0 - 1e-6


def test_the_split_design_is_buildable(cut):
    fs2, _, _ = cut
    r = verify_assembly(fs2, workers=1)
    assert r.buildable and r.interfering_pairs == 0 and not r.blocked, r.problems()


def test_the_split_is_the_same_every_time(grid, cut):
    fs2, lay, split = cut
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        again = fc.final_cut(grid, OPTIONS)
    assert again[2].as_report() | {"seconds": None} == split.as_report() | {"seconds": None}
    assert [(p.name, p.sheet, p.rotation, p.offset) for p in again[1].placements] == \
        [(p.name, p.sheet, p.rotation, p.offset) for p in lay.placements]
    assert [(p.name, p.panels.tobytes()) for p in again[0].parts] == \
        [(p.name, p.panels.tobytes()) for p in fs2.parts]


def test_a_rebuild_without_cuts_builds_the_same_parts(grid):
    # the rebuild copies the fin system's options (final_cut._OPTIONS): none is missed
    same = fc.rebuilt_with_cuts(grid, {})
    assert [(p.name, p.panels.tobytes(), len(p.slots)) for p in same.parts] == \
        [(p.name, p.panels.tobytes(), len(p.slots)) for p in grid.parts]


def test_the_rates_decide_whether_a_sheet_pays():
    cost = [CutCost("F1-S000-P00", 1, 100.0, 1)]

    def rates(per_sheet):
        return Rates(material_per_sheet=per_sheet, cut_per_m={Process.LASER: 2.0}, per_pierce=0.1,
                     per_bend=1.0, fasteners={"bolt": 0.3, "anchor": 2.0}, per_minute=1.0,
                     minutes_per_part=3.0, minutes_per_fastener=1.0, minutes_per_hole_drilled=0.5)

    kw = dict(sheet=SHEET, thickness=T, density=2700.0, unit="mm", process=Process.LASER)
    # a cut costs 0.2 (0.1 m at 2.0) + 0.1 + 3.0 - 1.0 (the bend it removes) = 2.3
    assert fc.cuts_pay(rates(2.4), **kw)(cost, 1)
    assert not fc.cuts_pay(rates(2.2), **kw)(cost, 1)
    assert not fc.cuts_pay(rates(100.0), **kw)(cost, 0)
    # without rates: a sheet saved pays for its seams and at most one fixing more
    free = fc.cuts_pay(None, **kw)
    assert free(cost, 1) and not free(cost, 0)
    fixed = cost[0]._replace(fixings=1)
    assert free([fixed], 1) and free([fixed, fixed], 2) and free([fixed, cost[0]], 1)
    assert not free([fixed, fixed], 1) and not free([fixed._replace(fixings=2)], 1)
    assert not free([fixed], 0)


def test_without_rates_a_cut_may_add_one_fixing(grid, monkeypatch):
    from torsal.fabrication.builder import seams
    from torsal.fabrication.nesting import cut_costs

    sites = {"F0-S001-P00": (2, 3), "F1-S001-P00": (2,)}
    monkeypatch.setattr(seams, "yield_cut_positions", lambda fs: dict(sites))
    # the row fixed to the building: its pieces take one fixing more at node line 2, two at 3
    monkeypatch.setattr(cut_costs, "fixings_added",
                        lambda fs, cuts: {("F0-S001-P00", 2): 1, ("F0-S001-P00", 3): 2})
    cuts, fixings = fc.yield_cut_sites(grid)
    assert cuts == {"F0-S001-P00": (2,), "F1-S001-P00": (2,)}
    assert fixings[("F0-S001-P00", 3)] == 2
    # with rates every site is offered: the price decides
    assert fc.yield_cut_sites(grid, rates=object())[0] == sites


def test_of_equal_sheets_the_cuts_that_add_no_fixing_win():
    from torsal.fabrication.nesting.split import _Candidate

    seam = CutCost("F1-S000-P00", 1, 100.0, 1)
    fixed = CutCost("F0-S000-P00", 2, 100.0, 1, fixings=1)
    three = _Candidate(38, 3, None, (), [seam, seam, fixed], [])
    four = _Candidate(38, 4, None, (), [seam] * 4, [])
    fewer = _Candidate(37, 5, None, (), [seam] * 4 + [fixed], [])
    assert min([three, four], key=lambda c: c.rank) is four
    assert min([three, four, fewer], key=lambda c: c.rank) is fewer
    assert four.rank == (38, 0, 4) and three.rank == (38, 1, 3)


def test_no_sheet_to_save_no_split(grid):
    big = dict(OPTIONS, sheet=(2500.0, 1250.0))
    fs2, lay, split = fc.final_cut(grid, big)
    assert fs2 is grid and not split.kept and "area bound" in split.why
    assert lay.n_sheets == 1 and lay.stats.split["kept"] is False


def test_the_split_search_alone(grid):
    un = list(grid.unrolled().values())
    res = nest_split(un, cuts=yield_cut_positions(grid), **OPTIONS)
    assert res.base.n_sheets == 3 and res.layout.n_sheets == 2 and res.n_cuts == 1
    [(part, js)] = res.cuts.items()
    # (each piece with the tab at its end of the column: 2 fin panels and 2 tabs)
    assert set(res.pieces.values()) == {(part, 0, js[0]), (part, js[0], 2 + 2)}
    q = bill_of_quantities(grid, density=2700.0, layout=res.base)
    assert q.sheets == 3


def test_the_bill_decides():
    class Sheets:
        def __init__(self, n):
            self.n_sheets = n

    class Price:
        def __init__(self, total):
            self.total = total

    d = dict(sheets=-1, panels_left_out=0, blocked=0, connectors=0, fixings=0, bolts=0, anchors=0,
             connector_bolts=0, connector_anchors=0)
    base, fewer = Sheets(3), Sheets(2)
    assert fc._verdict(d, None, None, base, fewer, "") == ""
    assert "connectors" in fc._verdict(d | {"connectors": 2}, None, None, base, fewer, "")
    assert "connector bolts" in fc._verdict(d | {"connector_bolts": 1}, None, None, base, fewer, "")
    # without rates a sheet saved may add one fixing, with its own bolts and anchors
    one = d | {"fixings": 1, "bolts": 2, "anchors": 2}
    assert fc._verdict(one, None, None, base, fewer, "") == ""
    assert "2 fixings more for 1 sheets" in fc._verdict(one | {"fixings": 2}, None, None, base,
                                                          fewer, "")
    assert fc._verdict(one | {"fixings": 2, "sheets": -2}, None, None, base, Sheets(1), "") == ""
    assert "not fewer" in fc._verdict(d | {"sheets": 0}, None, None, base, Sheets(3), "")
    assert "panels" in fc._verdict(d | {"panels_left_out": 1}, Price(2), Price(1), base, fewer, "")
    # with rates the price decides, brackets and all
    assert fc._verdict(d | {"connectors": 2}, Price(10.0), Price(9.0), base, fewer, "EUR") == ""
    assert "price went up by 1.00 EUR" in fc._verdict(d, Price(9.0), Price(10.0), base, fewer, "EUR")


def test_rows_as_planned():
    from shapely.geometry import box

    from torsal.fabrication.nesting.items import _as_items
    from torsal.fabrication.nesting.rows import planned_layout, row_layout

    parts = {"a": box(0, 0, 600, 100), "b": box(0, 0, 300, 100), "c": box(0, 0, 600, 100),
             "d": box(0, 0, 300, 100)}
    items = _as_items(parts)
    # best fit decreasing pairs the long ones: two rows of 600 + 300 are what a plan asks
    plan = [["a", "b"], ["c", "d"]]
    got = planned_layout(items, plan, 1000.0, 330.0, 5.0, 10.0)
    rows = {n: (si, round(off[1])) for n, (si, _, off) in got.items()}
    assert rows["a"][0] == rows["b"][0] == rows["c"][0] == rows["d"][0] == 0
    assert rows["a"][1] == rows["b"][1] != rows["c"][1] == rows["d"][1]
    # a plate that does not fit its planned row goes where the rows' best fit puts it
    over = planned_layout(items, [["a", "c", "b", "d"]], 1000.0, 330.0, 5.0, 10.0)
    assert set(over) == set(parts) and max(si for si, _, _ in over.values()) == 0
    assert set(row_layout(items, 1000.0, 330.0, 5.0, 10.0)) == set(parts)


def test_the_row_plans_take_the_parts_not_the_pieces(grid, monkeypatch):
    # step B plans the rows of the parts as they are; step A's pieces (stand-ins it added to
    # the search) are not parts of their own
    from torsal.fabrication.nesting import split as sp

    seen = []

    class Recorder(sp.RowPlan):
        def __init__(self, pieces, names, frame):
            seen.append(sorted(names))
            super().__init__(pieces, names, frame)

    monkeypatch.setattr(sp, "RowPlan", Recorder)
    res = nest_split(list(grid.unrolled().values()), cuts=yield_cut_positions(grid), **OPTIONS)
    assert res.n_cuts == 1 and res.pieces           # step A cut a plate into two stand-ins
    assert seen == [sorted(grid.unrolled())]


def test_with_rates_a_cut_that_adds_fixings_empties_a_sheet_where_they_cost_less(grid):
    """Every cut site made to add two fixings: without rates no sheet pays for them (at most
    one fixing a sheet saved), so the search keeps its three sheets; with rates the price
    decides: a sheet of 100 against a cut's contour, pierce and placing (0.1 + 0.2 + 3.0
    less a bend of 1.0 at most: 2.3-3.3) and two fixings. At 45 a fixing the cut pays (93.3
    at most) and empties a sheet, as without fixings; at 52 it does not (106.3 at least)."""
    un = list(grid.unrolled().values())
    sites = yield_cut_positions(grid)
    two = {(n, j): 2 for n, js in sites.items() for j in js}
    rates = Rates(material_per_sheet=100.0, cut_per_m={Process.LASER: 2.0}, per_pierce=0.1,
                  per_bend=1.0, fasteners={"bolt": 0.3, "anchor": 2.0}, per_minute=1.0,
                  minutes_per_part=3.0, minutes_per_fastener=1.0, minutes_per_hole_drilled=0.5)
    kw = dict(sheet=SHEET, thickness=T, density=2700.0, unit="mm", process=Process.LASER)

    def split(rates, per_fixing=0.0):
        pays = fc.cuts_pay(rates, per_fixing=per_fixing, **kw)
        return nest_split(un, cuts=sites, pays=pays, fixings=two, **OPTIONS)

    free = split(None)
    assert free.n_cuts == 0 and free.layout.n_sheets == free.base.n_sheets == 3
    cheap = split(rates, 45.0)
    assert cheap.layout.n_sheets == 2 and cheap.n_cuts == 1
    assert [c.fixings for c in cheap.costs] == [2] and 0 < cheap.costs[0].cut <= 100.0
    dear = split(rates, 52.0)
    assert dear.n_cuts == 0 and dear.layout.n_sheets == 3
