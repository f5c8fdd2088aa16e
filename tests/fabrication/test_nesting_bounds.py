"""The sheets no nesting can go below (issues 40, 42): the crossing bound of the parts longer
than half the sheet, its bin packing, and the final cut's search on instances whose optimum is
known: it reaches it, stops there without searching, and gives the same sheets twice."""
import numpy as np
import pytest
from shapely import affinity
from shapely.geometry import Polygon, box

from torsal.fabrication.cutting import Cutting
from torsal.fabrication.layout import spacing
from torsal.fabrication.nesting import crossing_bound, nest_rows, nest_search
from torsal.fabrication.nesting.bounds import bin_packing_bound, crossing_chords
from torsal.fabrication.nesting.sparrow import sheet_ok

SHEET = (2500.0, 1250.0)


def valid(lay, gap, margin, cutting=None):
    sep, edge = spacing(gap, margin, cutting)
    return all(sheet_ok([p.polygon for p in lay.on_sheet(s)], lay.sheet[0], lay.sheet[1], edge, sep)
               for s in range(lay.n_sheets))


def placements(lay):
    return [(p.name, p.sheet, p.rotation, p.offset) for p in lay.placements]


def parallelogram(base=1100.0, slant=200.0, height=380.0):
    return Polygon([(0, 0), (base, 0), (base + slant, height), (slant, height)])


def test_bin_packing_bound_counts_what_does_not_pair():
    # 0.4 + 0.4 fits, three do not: the continuous bound (3) is one short
    assert bin_packing_bound([0.4] * 7, 1.0) == 4
    assert bin_packing_bound([0.5] * 4, 1.0) == 2
    assert bin_packing_bound([], 1.0) == 0
    with pytest.raises(ValueError):
        bin_packing_bound([1.5], 1.0)


def test_chords_are_the_width_where_the_middle_crosses():
    sep, edge = 5.0, 10.0
    # a 2000 mm strip crosses the middle on its 400 mm width, a 1000 mm one need not cross
    ch = crossing_chords([box(0, 0, 2000, 400), box(0, 0, 1000, 400)], sheet=SHEET, sep=sep,
                         edge=edge)
    assert ch == pytest.approx([400.0])
    # a trapezoid 1500 long narrowing from 400 to 100: the middle crosses it between 260 and
    # 1240 mm along, where it is at least 400 - 300 * 1240 / 1500 wide
    trap = Polygon([(0, 0), (1500, 150), (1500, 250), (0, 400)])
    (c,) = crossing_chords([trap], sheet=SHEET, sep=sep, edge=edge)
    assert c == pytest.approx(400.0 - 300.0 * 1240.0 / 1500.0, rel=1e-3)
    # a slot (10 mm wide, half the depth) does not make the chord smaller: nothing goes in it
    slotted = box(0, 0, 2000, 400).difference(box(995, 200, 1005, 401))
    assert crossing_chords([slotted], sheet=SHEET, sep=sep, edge=edge) == pytest.approx([400.0])


def test_three_strips_a_sheet_however_small_the_rest():
    """Ten 2000 x 390 strips: three cross each sheet's middle (4 x 390 > 1230), so four sheets
    however the area (2.5 sheets) says; the search gets there and does not search on."""
    parts = {f"s{i}": box(0, 0, 2000, 390) for i in range(10)}
    parts |= {f"c{i}": box(0, 0, 150, 100) for i in range(30)}
    cut = Cutting.for_process("laser")
    sep, edge = spacing(5, 10, cut)
    assert crossing_bound(list(parts.values()), sheet=SHEET, sep=sep, edge=edge) == 4
    lay = nest_search(parts, sheet=SHEET, gap=5, margin=10, cutting=cut)
    assert lay.n_sheets == 4 and valid(lay, 5, 10, cut)
    assert lay.stats.crossing_bound == 4 and lay.stats.tries == 0
    assert "at the crossing bound" in lay.stats.method
    assert np.ceil(lay.area_bound) < 4


def test_two_parallelograms_share_a_row():
    """Parallelograms 1300 mm long over their slant: two bounding boxes (2600 mm) overrun a
    2480 mm row, but one end fits the slant of the next, so two share a row and six a sheet."""
    parts = {f"p{i}": parallelogram() for i in range(6)}
    for nester in (nest_rows, nest_search):
        lay = nester(parts, sheet=SHEET, gap=5, margin=10)
        assert lay.n_sheets == 1 and valid(lay, 5, 10)


def test_the_search_reaches_a_known_optimum_and_repeats_it():
    """Sixteen 1230 x 300 plates, shuffled: they tile two sheets (two a row, four rows) and
    their area needs more than one, so two sheets are the optimum, 94 % of them filled."""
    rng = np.random.default_rng(3)
    parts = {f"b{i:02d}": box(0, 0, 1230, 300) for i in range(16)}
    names = list(parts)
    rng.shuffle(names)
    parts = {n: parts[n] for n in names}
    a = nest_search(parts, sheet=SHEET, gap=5, margin=10)
    b = nest_search(parts, sheet=SHEET, gap=5, margin=10)
    assert a.n_sheets == 2 and valid(a, 5, 10)
    assert a.utilization == pytest.approx(16 * 1230 * 300 / (2 * SHEET[0] * SHEET[1]))
    assert a.utilization > 0.94
    assert placements(a) == placements(b)


def test_a_part_dropped_onto_a_sheet_as_it_is():
    """Two strips on a sheet: a third, dropped from above, lands on them (the two stay where
    they are) and keeps the spacing; a fourth finds no room above the third."""
    from torsal.fabrication.nesting.rows import prepare
    from torsal.fabrication.nesting.search import _Dropper, _Frame, _Skyline

    parts = {f"s{i}": box(0, 0, 2000, 380) for i in range(4)}
    w, h, items, sep, edge = prepare(parts, SHEET, 5.0, 10.0, None, "mm")
    drop = _Dropper(_Skyline(items, _Frame.of(w, h, sep, edge), None),
                    {it.name: it.outline for it in items})
    sheet = {"s0": (0.0, (edge, edge)), "s1": (0.0, (edge, edge + 380 + sep))}
    at = drop(sheet, "s2")
    assert at is not None
    sheet["s2"] = at
    placed = [affinity.translate(affinity.rotate(parts[n], rot, origin=(0, 0)), *off)
              for n, (rot, off) in sheet.items()]
    assert sheet_ok(placed, w, h, edge, sep)
    assert placed[2].bounds[1] >= edge + 2 * (380 + sep) - 1e-6
    assert drop(sheet, "s3") is None


@pytest.mark.parametrize("sheet", [(2500.0, 1250.0), (1250.0, 2500.0)])
def test_the_search_on_either_sheet_way_is_valid_and_repeats(sheet):
    rng = np.random.default_rng(11)
    parts = {}
    for i in range(45):
        w, h = rng.uniform(250, 1500), rng.uniform(80, 320)
        shear = rng.uniform(-200, 200)
        parts[f"q{i:02d}"] = Polygon([(0, 0), (w, 0), (w + shear, h), (shear, h)])
    cut = Cutting.for_process("laser")
    a = nest_search(parts, sheet=sheet, gap=5, margin=10, cutting=cut, tries=150)
    b = nest_search(parts, sheet=sheet, gap=5, margin=10, cutting=cut, tries=150)
    assert valid(a, 5, 10, cut) and placements(a) == placements(b)
    assert {p.name for p in a.placements} == set(parts)
    assert a.n_sheets <= min(a.stats.starts.values())


def test_a_chord_counts_the_part_not_its_concavity():
    """A C 2000 x 400 mm whose two arms 100 mm wide run along it around a 200 mm notch takes
    200 mm of the middle line, not 400: another part may lie in the notch, between the arms.
    Turned a quarter, it is measured the same (each part is laid along the rows)."""
    c = Polygon([(0, 0), (2000, 0), (2000, 400), (0, 400), (0, 300), (1800, 300), (1800, 100),
                 (0, 100)])
    chords = crossing_chords([box(0, 0, 2000, 100), c, affinity.rotate(c, 90, origin=(0, 0))],
                             sheet=SHEET, sep=5.0, edge=10.0)
    assert np.allclose(chords, [100.0, 200.0, 200.0], atol=1e-6)
