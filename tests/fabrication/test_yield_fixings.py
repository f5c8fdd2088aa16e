"""A plate the final cut splits at a crossing slot keeps its fixings; a piece gets one of its
own only where the load path needs it (issues 40, 42): constructed cases, counted by hand.

The facade of ``test_fab_held``: an egg-crate on a vertical wall, rows (family 0, 1.6 m,
four 0.4 m panels) fixed to the building, columns (family 1) sliding onto them along the
node lines. With the lines dipping 20 deg, a column's way out of its slots dips: it hangs,
with one fixing of its own, and a row's way off a column (the slide direction, up 20 deg)
does not dip: the column holds the row. With the lines rising 20 deg it is the other way
round: the rows' slots carry the columns, which hold no row.

A row (1.6 m, fixings at most 1.5 m apart: two, nearest 0.4 and 1.2 m along it, on its panels
0 and 2) cut at its node line 3 gives a piece of three panels, which keeps both fixings, and a
tail of one panel, which none falls on. The tail needs none where the column at its seam holds
it (dipping), and one where nothing else does (rising).
"""
from __future__ import annotations

import warnings

import pytest

from test_fab_held import _build, _fixed, facade
from torsal.fabrication import verify_assembly
from torsal.fabrication.assembly import load_path
from torsal.fabrication.builder.seams import yield_cut_positions
from torsal.fabrication.model import JointKind
from torsal.fabrication.nesting.cut_costs import fixings_added
from torsal.fabrication.nesting.mapped import rebuilt_with_cuts, strip_cuts


@pytest.fixture(scope="module", params=[20.0, -20.0], ids=["dipping", "rising"])
def walls(request):
    return request.param, _build(facade(request.param))


def _cut(fs, plate: str, j: int):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return rebuilt_with_cuts(fs, strip_cuts(fs, {plate: (j,)}))


def test_a_cut_row_keeps_its_fixings_and_its_tail_is_fixed_only_where_nothing_holds_it(walls):
    dip, fs = walls
    row = "F0-S001-P00"
    assert len(fs.part(row).panels) == 4 and 3 in yield_cut_positions(fs)[row]
    assert _fixed(fs)[row] == 2
    fs2 = _cut(fs, row, 3)
    head, tail = sorted((p for p in fs2.plates if fs2._strip_of[p.name] == fs._strip_of[row]),
                        key=lambda p: p.span[0])
    assert (len(head.panels), len(tail.panels)) == (3, 1)
    # the seam stays in the column's slot, no connector
    assert any({head.name, tail.name} <= set(s.parts) for s in fs2.seams_in_slot)
    fixed = _fixed(fs2)
    assert fixed[head.name] == 2                      # the row's two, on panels 0 and 2
    if dip > 0:
        assert tail.name not in fixed                 # held by the column at its seam
        assert len(fs2.fixings) == len(fs.fixings)
    else:
        assert fixed[tail.name] == 1                  # nothing else holds it
        assert len(fs2.fixings) == len(fs.fixings) + 1
    # the final cut's cost of that cut said so before the rebuild
    assert fixings_added(fs, {row: (3,)}) == {(row, 3): len(fs2.fixings) - len(fs.fixings)}
    lp = load_path(fs2)
    assert lp.supported and lp.unsupported_parts == []
    assert verify_assembly(fs2).buildable


def test_without_its_fixing_the_tail_of_the_rising_wall_would_fall():
    """Control: on the rising wall the tail's fixing is what holds it (the slots do not)."""
    from torsal.fabrication.assembly import check_load_path, fastenings_of, joints_of

    fs = _build(facade(-20.0))
    fs2 = _cut(fs, "F0-S001-P00", 3)
    tail = max((p for p in fs2.plates if fs2._strip_of[p.name] == fs._strip_of["F0-S001-P00"]),
               key=lambda p: p.span[0])
    theirs = {j.parts[0] for j in fs2.joints if j.kind == JointKind.FIXING
              and j.parts[1] == tail.name}
    assert len(theirs) == 1
    bare = check_load_path([p.name for p in fs2.parts if p.name not in theirs],
                           [j for j in joints_of(fs2) if not theirs & set(j.parts)],
                           [f for f in fastenings_of(fs2) if not theirs & set(f.parts)])
    assert bare.unsupported_parts == [tail.name]


def test_a_cut_hung_column_gives_each_piece_its_one_fixing(walls):
    dip, fs = walls
    col = "F1-S001-P00"
    js = yield_cut_positions(fs)[col]
    fs2 = _cut(fs, col, js[0])
    pieces = sorted(p.name for p in fs2.plates if fs2._strip_of[p.name] == fs._strip_of[col])
    assert len(pieces) == 2
    fixed = _fixed(fs2)
    if dip > 0:          # each piece still slides out of its slots: one each, one more
        assert [fixed.get(n, 0) for n in pieces] == [1, 1] and _fixed(fs)[col] == 1
        assert len(fs2.fixings) == len(fs.fixings) + 1
    else:                # the rows' slots carry both
        assert not any(n in fixed for n in pieces) and col not in _fixed(fs)
        assert len(fs2.fixings) == len(fs.fixings)
    assert fixings_added(fs, {col: (js[0],)}) == {(col, js[0]): len(fs2.fixings) - len(fs.fixings)}
    assert load_path(fs2).supported
