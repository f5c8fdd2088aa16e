"""The bill of quantities and the price (issue 42): a constructed part counted by hand, the
price as the sum of its lines (none without rates), parts.csv columns that add up to the
design's totals, and the design file's [costs] table."""
from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from fab_structures import cylinder_structure, flat_structure
from torsal.fabrication import FinSystem, nest, unroll
from torsal.fabrication.builder.fasteners import fastener_counts
from torsal.fabrication.cutting import Cutting, Process
from torsal.fabrication.model import CONNECTOR_FAMILY, FIXING_FAMILY, Hole, Part, PartId, Slot, SlotSide
from torsal.fabrication.quantities import CostLine, Rates, bill_of_quantities, price
from torsal.cli import main
from torsal.pipeline.design_file import DesignFileError, load_design_file
from torsal.pipeline.quantities import quantities_report, surface_area
from torsal.pipeline.report import design_report_html
from torsal.study.study_tasks import flatten

# ------------------------------------------------------------------ the constructed part
# a 350 x 100 mm plate bent by 30 degrees on the node line 200 mm from its start, a slot
# 3.5 mm wide and 40 mm deep from its b edge on that bend line, an M6 bolt hole (6.6 mm) in
# the first panel and an M8 anchor hole (9 mm) in the second; 3 mm thick
L0, L1, H, W, D, T = 200.0, 150.0, 100.0, 3.5, 40.0, 3.0
HOLES = (6.6, 9.0)
FOLD = np.radians(30.0)


def _plate(family: int = FIXING_FAMILY) -> Part:
    c, s = np.cos(FOLD), np.sin(FOLD)
    far = np.array([L0 + L1 * c, L1 * s, 0.0])
    a = np.array([[0, 0, 0], [L0, 0, 0], far])
    b = a + [0, 0, H]
    panels = np.stack([a[:-1], a[1:], b[1:], b[:-1]], axis=1)
    mid1 = np.array([L0 + 0.5 * L1 * c, 0.5 * L1 * s, 0.5 * H])
    holes = (Hole(np.array([50.0, 0, 50.0]), HOLES[0], 0, "M6 bolt"),
             Hole(mid1, HOLES[1], 1, "M8 anchor"))
    return Part(PartId(family, 7, 0), panels, np.full(3, -1), np.full(2, -1),
                slots=[Slot(-1, 1, SlotSide.B, D, W)], holes=holes)


class _OnePart:
    """The fin system's face the bill of quantities reads, around constructed parts."""

    unit, thickness = "mm", T

    def __init__(self, *parts):
        self.parts = list(parts)
        self._unrolled = {p.name: unroll(p) for p in parts}

    def unrolled(self):
        return self._unrolled


# by hand, in mm: the outline (the rectangle and the slot's two flanks), the net area
PERIMETER = 2 * (L0 + L1 + H) + 2 * D
NET_MM2 = (L0 + L1) * H - W * D - sum(np.pi * d ** 2 / 4 for d in HOLES)
KG_PER_MM2 = 1e-6 * T * 1e-3 * 2700.0


def test_constructed_part_by_hand_laser():
    """A laser cuts both holes: the outline and the two circles, three pierces."""
    fs = _OnePart(_plate())
    q = bill_of_quantities(fs, density=2700.0, cutting=Cutting.for_process("laser"))
    p = q.part(fs.parts[0].name)
    assert p.cut_m == pytest.approx((PERIMETER + np.pi * sum(HOLES)) / 1000, rel=1e-9)
    assert (p.pierces, p.holes_cut, p.holes_drilled) == (3, 2, 0)
    assert p.bends == 1
    assert p.bend_m == pytest.approx((H - D) / 1000, rel=1e-9)   # the slot is on the bend
    assert p.net_m2 == pytest.approx(NET_MM2 * 1e-6, rel=1e-9)
    assert p.net_kg == pytest.approx(NET_MM2 * KG_PER_MM2, rel=1e-9)
    assert p.fasteners == {"M6 bolt": 1, "M8 anchor": 1}
    assert p.gross_kg is None and q.gross_kg is None and q.sheets is None
    assert (q.cut_m, q.pierces, q.bends, q.net_kg) == (p.cut_m, p.pierces, p.bends, p.net_kg)
    a = q.assembly
    assert (a.parts_placed, a.fasteners_set, a.holes_drilled) == (1, 2, 0)


def test_constructed_part_by_hand_router_drills_the_small_hole():
    """An 8 mm router bit cannot cut the 6.6 mm hole: drilled, no pierce, not in the cut."""
    fs = _OnePart(_plate())
    q = bill_of_quantities(fs, density=2700.0,
                           cutting=Cutting.for_process("router", tool_diameter_mm=8.0))
    p = q.parts[0]
    assert p.cut_m == pytest.approx((PERIMETER + np.pi * HOLES[1]) / 1000, rel=1e-9)
    assert (p.pierces, p.holes_cut, p.holes_drilled) == (2, 1, 1)
    assert q.process is Process.ROUTER and q.assembly.holes_drilled == 1


def test_a_plate_sets_no_fasteners_and_a_shared_bolt_counts_once():
    """A fin plate's holes take the connector's bolts (counted there); a bolt shared with
    the connector on the plate's other face is counted at that one."""
    plate = _plate(family=0)
    c = _plate(family=CONNECTOR_FAMILY)
    c.holes = (c.holes[0], Hole(c.holes[1].center, HOLES[1], 1, "M8 anchor", shared=True))
    q = bill_of_quantities(_OnePart(plate, c), density=2700.0)
    assert q.part(plate.name).fasteners == {}
    assert q.part(c.name).fasteners == {"M6 bolt": 1}
    assert q.fasteners == {"M6 bolt": 1}
    # no process: every hole cut, as the DXF draws them
    assert q.pierces == 6 and q.holes_drilled == 0


def test_gross_material_is_the_sheets_shared_by_area():
    fs = _OnePart(_plate(), _plate(family=0))
    u = list(fs.unrolled().values())
    layout = nest(u, sheet=(500.0, 300.0), gap=5.0, margin=10.0, cutting=Cutting.for_process("laser"))
    assert layout.n_sheets == 1
    q = bill_of_quantities(fs, density=2700.0, layout=layout)
    sheet_mm2 = 500.0 * 300.0
    assert q.gross_m2 == pytest.approx(sheet_mm2 * 1e-6)
    assert q.gross_kg == pytest.approx(sheet_mm2 * KG_PER_MM2)
    # two equal outlines: half the sheet each
    for p in q.parts:
        assert p.gross_kg == pytest.approx(0.5 * sheet_mm2 * KG_PER_MM2)
    with pytest.raises(ValueError, match="once"):
        bill_of_quantities(fs, density=2700.0, layout=layout, cutting=Cutting())
    with pytest.raises(ValueError, match="density"):
        bill_of_quantities(fs, density=0.0)


# ------------------------------------------------------------------ price
RATES = dict(cut_per_m={"laser": 1.5, "waterjet": 4.0}, per_pierce=0.05, per_bend=0.8,
             fasteners={"bolt": 0.3, "anchor": 2.0, "M8 anchor": 2.6}, per_minute=1.2,
             minutes_per_part=3.0, minutes_per_fastener=1.5, minutes_per_hole_drilled=0.5,
             currency="EUR")


def _priced(**rates):
    fs = _OnePart(_plate())
    layout = nest(list(fs.unrolled().values()), sheet=(500.0, 300.0),
                  cutting=Cutting.for_process("laser"))
    return bill_of_quantities(fs, density=2700.0, layout=layout), Rates(**{**RATES, **rates})


def test_no_rates_no_price():
    q, _ = _priced(material_per_kg=6.0)
    assert price(q, None) is None


def test_price_is_the_sum_of_its_lines_by_hand():
    q, rates = _priced(material_per_kg=6.0)
    p = price(q, rates, surface_m2=2.0)
    gross_kg = 500.0 * 300.0 * KG_PER_MM2
    cut_m = (PERIMETER + np.pi * sum(HOLES)) / 1000
    by_hand = {"material": 6.0 * gross_kg, "cutting laser": 1.5 * cut_m, "pierces": 3 * 0.05,
               "bends": 0.8, "fasteners M6 bolt": 0.3, "fasteners M8 anchor": 2.6,
               "placing parts": 3.0 * 1.2, "setting fasteners": 2 * 1.5 * 1.2,
               "drilling holes": 0.0}
    assert {ln.name: ln.amount for ln in p.lines} == pytest.approx(by_hand, rel=1e-9)
    assert p.total == pytest.approx(sum(by_hand.values()), rel=1e-12)
    assert p.total == pytest.approx(math.fsum(ln.amount for ln in p.lines), rel=1e-15)
    assert p.per_m2 == pytest.approx(p.total / 2.0)
    rep = p.as_report()
    assert rep["total"] == p.total and rep["currency"] == "EUR"
    assert rep["lines"]["cutting laser"]["unit"] == "m"
    assert [ln.line for ln in p.lines][:4] == [CostLine.MATERIAL, CostLine.CUTTING,
                                               CostLine.PIERCES, CostLine.BENDS]


def test_price_per_sheet_and_what_cannot_be_priced():
    q, rates = _priced(material_per_sheet=40.0)
    material = price(q, rates).lines[0]
    assert (material.quantity, material.unit, material.amount) == (1, "sheet", 40.0)
    q, rates = _priced(material_per_kg=6.0, cut_per_m={"waterjet": 4.0})
    with pytest.raises(ValueError, match="cut_per_m has no rate for process 'laser'"):
        price(q, rates)
    no_layout = bill_of_quantities(_OnePart(_plate()), density=2700.0, cutting=Cutting())
    with pytest.raises(ValueError, match="material_per_kg prices the sheets used .* need the layout"):
        price(no_layout, Rates(**RATES, material_per_kg=6.0))


@pytest.mark.parametrize("change, words", [
    (dict(material_per_kg=None), "exactly one of material_per_kg"),
    (dict(material_per_kg=6.0, material_per_sheet=40.0), "exactly one of material_per_kg"),
    (dict(material_per_kg=6.0, per_bend=-1.0), "per_bend = -1.0 must be a number >= 0"),
    (dict(material_per_kg=6.0, fasteners={"bolt": 0.3}), r"no fastener rate for the kinds \['anchor'\]"),
    (dict(material_per_kg=6.0, fasteners={"bolt": 0.3, "anchor": 2, "M8 rivet": 1}), "M8 rivet"),
    (dict(material_per_kg=6.0, cut_per_m={"plasma": 1.0}), "plasma"),
])
def test_bad_rates_say_which(change, words):
    with pytest.raises(ValueError, match=words):
        Rates(**{**RATES, **change})


# ------------------------------------------------------------------ a fin system, parts.csv
@pytest.fixture(scope="module")
def cylinder():
    fs = FinSystem(cylinder_structure(), thickness=3.0, clearance=0.5)
    layout = fs.layout(sheet=(1250.0, 625.0), cutting=Cutting.for_process("router", tool_diameter_mm=3.175))
    return fs, layout


COLUMN_OF = {"mass_kg": "net_kg", "gross_kg": "gross_kg", "cut_length_m": "cut_m",
             "pierces": "pierces", "holes_drilled": "holes_drilled", "fold_count": "bends",
             "bend_length_m": "bend_m"}


def test_parts_csv_columns_add_up_to_the_design(cylinder, tmp_path):
    fs, layout = cylinder
    fs.bill_of_materials(tmp_path / "parts.csv", density=2700.0, layout=layout)
    with open(tmp_path / "parts.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert set(COLUMN_OF) | {"fasteners"} <= set(rows[0])
    q = bill_of_quantities(fs, density=2700.0, layout=layout).as_report()
    for column, total in COLUMN_OF.items():
        assert sum(float(r[column]) for r in rows) == pytest.approx(q[total], rel=1e-6, abs=1e-5), column
    # and against what is counted elsewhere: the sheets bought, the bolts and anchors
    assert q["gross_kg"] == pytest.approx(layout.n_sheets * 1.25 * 0.625 * 3e-3 * 2700.0)
    counts = fastener_counts(fs)
    n = sum(c.bolts + c.anchors for c in counts.values())
    assert sum(int(r["fasteners"]) for r in rows) == n == q["assembly"]["fasteners_set"] > 0
    assert sum(q["fasteners"]["bolt"].values()) == sum(c.bolts for c in counts.values())
    # every connector and fixing is one bent plate: one bend each at least
    assert q["bends"] >= len(fs.connectors) + len(fs.fixings) > 0


# ------------------------------------------------------------------ the design file, the report
GOOD = """
name = "test"
[surface]
generator = "facade_patch"
params = { nu = 9, nv = 5 }
[sun]
vectors = [[0, -1, 1]]
[fins]
spacing = 1.5
depth = 0.4
[cutting]
process = "router"
"""
COSTS = """
[costs]
currency = "EUR"
material_per_sheet = 60.0
cut_per_m = { router = 2.0 }
per_pierce = 0.1
per_bend = 0.8
fasteners = { bolt = 0.35, anchor = 2.5 }
per_minute = 1.0
minutes_per_part = 3.0
minutes_per_fastener = 1.0
minutes_per_hole_drilled = 0.5
"""


def _spec(tmp_path, text):
    p = tmp_path / "d.toml"
    p.write_text(text)
    return load_design_file(p)


def test_report_sections_and_study_columns(cylinder, tmp_path):
    fs, layout = cylinder
    structure = cylinder_structure()
    plain = quantities_report(_spec(tmp_path, GOOD), fs, layout, structure)
    assert plain["costs"] is None
    priced = quantities_report(_spec(tmp_path, GOOD + COSTS), fs, layout, structure)
    q, c = priced["quantities"], priced["costs"]
    assert q == {**plain["quantities"]}
    assert c["total"] == pytest.approx(sum(ln["amount"] for ln in c["lines"].values()), rel=1e-12)
    assert c["lines"]["material"]["amount"] == 60.0 * layout.n_sheets
    assert c["lines"]["cutting router"]["amount"] == pytest.approx(2.0 * q["cut_m"])
    # the surface: A~ of the cylinder grid, 3 x 2 faces of 0.3 m x 2 sin(0.075) 2 m
    chord = 2 * 2.0 * np.sin(0.075)
    assert surface_area(structure) == pytest.approx(3 * 2 * 0.3 * chord, rel=1e-9)
    assert c["per_m2"] == pytest.approx(c["total"] / q["surface_m2"])
    flat = flatten({"fabrication": priced})
    assert flat["fabrication.costs.total"] == c["total"]
    assert flat["fabrication.quantities.cut_m"] == q["cut_m"]
    html = design_report_html({"fabrication": {"parts": 1, "panels": 1, "sheets": 1,
                                               "utilization": 0.5, **priced}}, {}, "t")
    assert "Bill of quantities" in html and f"{c['total']:.2f} EUR" in html
    html = design_report_html({"fabrication": {"parts": 1, "panels": 1, "sheets": 1,
                                               "utilization": 0.5, **plain}}, {}, "t")
    assert "No price" in html


@pytest.mark.parametrize("edit, key, words", [
    (("per_pierce = 0.1", "per_pierce = -0.1"), "costs.per_pierce", "greater than or equal to 0"),
    (("per_bend = 0.8", 'per_bend = "cheap"'), "costs.per_bend", "valid number"),
    (("router = 2.0", "plasma = 2.0"), "costs.cut_per_m", "'laser', 'waterjet' or 'router'"),
    (("router = 2.0", "laser = 2.0"), "costs.cut_per_m", "no rate for the design's cutting.process 'router'"),
    (("anchor = 2.5", '"M8 anchor" = 2.5'), "costs.fasteners", "no fastener rate for the kinds"),
    (("material_per_sheet = 60.0", ""), "costs", "exactly one of material_per_kg"),
    (("minutes_per_part = 3.0\n", ""), "costs.minutes_per_part", "missing"),
])
def test_bad_costs_name_the_key(tmp_path, edit, key, words):
    with pytest.raises(DesignFileError) as exc:
        _spec(tmp_path, GOOD + COSTS.replace(*edit))
    msg = str(exc.value)
    assert key in msg and words in msg, msg


def test_bad_costs_exit_2_without_traceback(tmp_path, capsys):
    p = tmp_path / "d.toml"
    p.write_text(GOOD + COSTS.replace("per_pierce = 0.1", "per_pierce = -0.1"))
    assert main(["design", str(p), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "costs.per_pierce" in err and "Traceback" not in err
    assert not (tmp_path / "out" / "report.json").exists()


def test_developable_strips_keep_the_surface_they_price_by():
    """Fig. 10's strips have no faces; the price per m^2 and bolts per m^2 divide by the
    area of the faces they were refined from: 3 x 2 faces of 0.3 m x 2 sin(0.075) 2 m, as the
    grid's own area (a flat grid: 3 x 2 squares of 0.3 m)."""
    from torsal.geometry.developable import refine_developable

    chord = 2 * 2.0 * np.sin(0.075)
    for s, area in ((cylinder_structure(), 3 * 2 * 0.3 * chord), (flat_structure(), 6 * 0.09)):
        strips = refine_developable(s, 1)
        assert len(strips.faces) == 0
        assert surface_area(strips) == pytest.approx(area, rel=1e-9)
        assert surface_area(refine_developable(strips, 1)) == pytest.approx(area, rel=1e-9)
