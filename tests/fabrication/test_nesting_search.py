"""The final cut's deterministic search and the skyline nester (issue 40): valid sheets, the
same sheets every time, curved strips stacked into each other, a cut search that says so."""
import numpy as np
import pytest
from shapely import affinity
from shapely.geometry import Polygon, box

from torsal.fabrication.cutting import Cutting
from torsal.fabrication.layout import spacing
from torsal.fabrication.nesting import Nester, nest_parts, nest_rows, nest_search
from torsal.fabrication.nesting.skyline import SkylinePacker, column_profiles
from torsal.fabrication.nesting.sparrow import sheet_ok


def arc(length=1000.0, sag=150.0, thick=100.0, n=21):
    """A strip bent in its plane: its lower edge a parabola rising ``sag`` to the middle, its
    upper edge the same ``thick`` higher (a curved fin's unrolled outline)."""
    x = np.linspace(0.0, length, n)
    y = sag * (1.0 - (2.0 * x / length - 1.0) ** 2)
    return Polygon(np.r_[np.c_[x, y], np.c_[x[::-1], y[::-1] + thick]])


def valid(lay, gap, margin, cutting=None):
    sep, edge = spacing(gap, margin, cutting)
    return all(sheet_ok([p.polygon for p in lay.on_sheet(s)], lay.sheet[0], lay.sheet[1], edge, sep)
               for s in range(lay.n_sheets))


def test_column_profiles_of_an_arc_are_its_edges():
    p = column_profiles([arc()], [0.0], res=10.0, sep=5.0)[0]
    x = (np.arange(len(p.bottom)) + 0.5) * 10.0
    lower = 150.0 * (1.0 - (2.0 * x / 1000.0 - 1.0) ** 2)
    # a column's lowest point lies at one of its sides: within the parabola's rise over 10 mm
    assert np.all(p.bottom <= lower + 1e-9) and np.all(p.bottom >= lower - 10.0 * 0.6 - 1e-9)
    g = (len(p.top) - len(p.bottom)) // 2
    # the grown top reaches the spacing above the upper edge at the column's middle...
    assert np.all(p.top[g:-g] >= lower + 100.0 + 5.0 - 1e-9)
    # ... and no higher than the spacing above the highest upper edge within the spacing
    # and a column around it (the conservative rule: a column's extremes over its width)
    xs = np.linspace(-20.0, 1020.0, 10401)
    up = 150.0 * (1.0 - (2.0 * np.clip(xs, 0, 1000) / 1000.0 - 1.0) ** 2) + 100.0
    reach = np.array([up[np.abs(xs - c) <= 5.0 + 15.0].max() for c in x])
    assert np.all(p.top[g:-g] <= reach + 5.0 + 1e-9)


def test_the_skyline_stacks_arcs_into_each_other():
    """Five arcs 150 mm sag, 100 mm thick: laid flat in rows each takes its 250 mm band; dropped
    into the one below, each adds its thickness and the spacing (about 105 mm)."""
    sep, res = 5.0, 2500.0 / 400
    opts = column_profiles([arc()] * 2, [0.0, 180.0], res=res, sep=sep)
    packer = SkylinePacker(2480.0, 1230.0, sep, res)
    for k in range(5):
        assert packer.add(f"a{k}", [opts[0]], new_sheet=k == 0)
    top = max(y + o.height for _, o, _, y in packer.placed.values())
    assert top <= 250.0 + 4 * (100.0 + sep + 2 * 0.6 * res) + 1e-6
    rows = nest_rows([arc()] * 5, sheet=(1100.0, 1250.0), gap=sep, margin=0.0)
    assert rows.n_sheets == 2          # 4 bands of 250 mm a sheet: the rows cannot stack them


def test_the_search_is_valid_deterministic_and_no_worse_than_its_starts():
    rng = np.random.default_rng(7)
    parts = {}
    for i in range(40):
        w, h = rng.uniform(300, 1400), rng.uniform(80, 300)
        shear = rng.uniform(-150, 150)
        p = Polygon([(0, 0), (w, 0), (w + shear, h), (shear, h)])
        parts[f"p{i:02d}"] = arc(w, rng.uniform(0, 200), h) if i % 3 == 0 else p
    cut = Cutting.for_process("laser")
    a = nest_search(parts, sheet=(2500, 1250), gap=5, margin=10, cutting=cut)
    b = nest_search(dict(reversed(list(parts.items()))), sheet=(2500, 1250), gap=5, margin=10,
                    cutting=cut)
    assert valid(a, 5, 10, cut)
    assert a.n_sheets <= min(a.stats.starts.values())
    key = [(p.name, p.sheet, p.rotation, p.offset) for p in a.placements]
    assert key == [(p.name, p.sheet, p.rotation, p.offset) for p in b.placements]
    assert {p.name for p in a.placements} == set(parts)
    assert not a.stats.time_limited and a.stats.tries <= 600
    assert a.n_sheets >= np.ceil(a.area_bound - 1e-9)


def test_a_search_the_time_limit_cuts_says_so():
    # shorter than half the sheet: the crossing bound does not stop the search at its start
    parts = {f"p{i}": affinity.rotate(box(0, 0, 1000 + i, 180), 7 * i) for i in range(60)}
    lay = nest_parts(parts, nester=Nester.SEARCH, sheet=(2500, 1250), gap=5, margin=10,
                     time_limit=1e-6)
    assert lay.stats.time_limited and valid(lay, 5, 10)
    assert "time limit" in lay.stats.method


def test_tries_must_be_a_count():
    with pytest.raises(ValueError, match="tries"):
        nest_search([box(0, 0, 10, 10)], sheet=(100, 100), tries=-1)


@pytest.mark.parametrize("sheet", [(1000.0, 500.0), (500.0, 1000.0)], ids=["landscape", "portrait"])
def test_the_search_fills_a_hole_inside_a_part(sheet):
    """A C-shaped plate 800 x 400 mm open on its short side holds a 700 x 300 mm hole; on a
    1000 x 500 mm sheet two 280 x 200 mm plates fit nowhere else (not above it: 95 mm left; not
    beside it: 195 mm). The starts put them on a second sheet, and no part dropped from above
    reaches the hole (the skyline); the hole filler empties that sheet into it, on a portrait
    sheet too (the search's frame turned a quarter)."""
    c = Polygon([(0, 0), (800, 0), (800, 400), (0, 400), (0, 350), (700, 350), (700, 50), (0, 50)])
    parts = {"c": c, "plate1": box(0, 0, 280, 200), "plate2": box(0, 0, 280, 200)}
    lay = nest_search(parts, sheet=sheet, gap=5.0, margin=0.0)
    assert min(lay.stats.starts.values()) == 2
    assert lay.n_sheets == 1
    assert valid(lay, 5.0, 0.0)
    placed = {p.name: p.polygon for p in lay.placements}
    hole = placed["c"].convex_hull.difference(placed["c"])
    for n in ("plate1", "plate2"):
        assert hole.buffer(1e-6).contains(placed[n])
