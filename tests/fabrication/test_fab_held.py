"""Every fin plate is held (the load path, issue 42): constructed cases with known answers.

A family-1 plate of an egg-crate slides onto the family-0 plates towards the building, along
its node lines; its way back out is along them, away from the building. Where the lines dip
outwards (a facade's fins pointing down), its weight draws it out of its slots: it gets one
fixing of its own; where they rise, the slots carry it and it gets none. A plate that meets no
other part and has no room for a fixing is left out, named.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from fab_structures import blocked_slide_structure, grid_structure
from torsal.fabrication import FinSystem
from torsal.geometry.support import SupportStructure
from torsal.fabrication.assembly import check_load_path, fastenings_of, joints_of, load_path
from torsal.fabrication.assembly.load_path import SLIDE_DIP_DEG
from torsal.fabrication.model import FIXING_FAMILY, JointKind

T, C = 3.0, 0.5


def facade(dip_deg: float, n: int = 5, step: float = 0.4, depth: float = 0.15):
    """An egg-crate on a vertical facade in the plane y = 0 (x across, z up), node lines
    leaving it along +y and dipping ``dip_deg`` below the horizontal (negative: rising), on an
    ``n`` x ``n`` grid of nodes: family 0 the rows 1 to n-2 (horizontal fins), family 1 the
    columns 1 to n-2 (vertical fins), each running one node past the last it crosses, so
    every crossing is an egg-crate slot and no plate ends against another."""
    x, z = np.meshgrid(np.arange(n) * step, np.arange(n) * step)
    a = np.stack([x, 0 * x, z], axis=-1)
    t = np.radians(dip_deg)
    s = grid_structure(a, a + depth * np.array([0.0, np.cos(t), -np.sin(t)]), n, n)
    idx = np.arange(n * n).reshape(n, n)
    rows = [[idx[r, c], idx[r, c + 1]] for r in range(1, n - 1) for c in range(n - 1)]
    cols = [[idx[r, c], idx[r + 1, c]] for c in range(1, n - 1) for r in range(n - 1)]
    return SupportStructure(s.vertices_a, s.vertices_b, s.faces, np.array(rows + cols),
                            np.r_[np.zeros(len(rows), int), np.ones(len(cols), int)])


def _build(structure):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return FinSystem(structure, thickness=T, clearance=C)


def _fixed(fs) -> dict[str, int]:
    """``{fin plate: fixings on it}``, read from the fixing joints."""
    out: dict[str, int] = {}
    for j in fs.joints:
        if j.kind == JointKind.FIXING:
            out[j.parts[1]] = out.get(j.parts[1], 0) + 1
    return out


@pytest.mark.parametrize("dip", [20.0, -20.0])
def test_a_plate_whose_slots_it_would_slide_out_of_gets_one_fixing(dip):
    fs = _build(facade(dip))
    columns = sorted(p.name for p in fs.parts if p.family == 1)
    rows = sorted(p.name for p in fs.parts if p.family == 0)
    crossings = [j for j in fs.joints if j.kind == JointKind.EGG_CRATE]
    assert len(columns) == 3 and len(rows) == 3 and len(crossings) == 9
    # the columns slide in towards the building, along the lines: their way out dips by
    # ``dip`` (by hand: -d . z = -sin(dip) for d = a - b)
    for j in crossings:
        d = np.asarray(j.insert_direction, float)
        assert np.degrees(np.arcsin(-d[2] / np.linalg.norm(d))) == pytest.approx(-dip, abs=1e-6)
    fixed = _fixed(fs)
    assert all(fixed.get(r, 0) >= 2 for r in rows)              # the rows carry: fixed as before
    if dip > SLIDE_DIP_DEG:
        assert {c: fixed.get(c, 0) for c in columns} == {c: 1 for c in columns}
        # its fixing holds it against the way out: the fin comes down onto it along its slide
        for j in fs.joints:
            if j.kind == JointKind.FIXING and j.parts[1] in columns:
                crossing = next(x for x in crossings if j.parts[1] in x.parts)
                np.testing.assert_allclose(j.insert_direction, crossing.insert_direction,
                                           atol=1e-9)
        # control: without those fixings the slots alone would let the columns slide out
        theirs = {j.parts[0] for j in fs.joints
                  if j.kind == JointKind.FIXING and j.parts[1] in columns}
        bare = check_load_path([p.name for p in fs.parts if p.name not in theirs],
                               [j for j in joints_of(fs) if not theirs & set(j.parts)],
                               [f for f in fastenings_of(fs) if not theirs & set(f.parts)])
        assert bare.unsupported_parts == columns
    else:
        assert not any(c in fixed for c in columns)              # the slots carry them
    lp = load_path(fs)
    assert lp.supported and lp.components == 1 and lp.unsupported_parts == []
    assert len([p for p in fs.parts if p.family == FIXING_FAMILY]) == sum(fixed.values())


def test_a_plate_nothing_holds_is_left_out_and_named():
    # the T of blocked_slide_structure: the row 50 mm above the column (U, F0-S001) meets no
    # part and its fixing would overlap the column: nothing can hold it
    fs = _build(blocked_slide_structure())
    assert [(s, e, why) for s, e, _, why in fs.coplanar_panels] == [
        ("F0-S001", 2, "F0-S001-P00 is held by nothing: it meets no other part and has no "
                       "room for a fixing")]
    assert "F0-S001-P00" not in {p.name for p in fs.parts}
    assert load_path(fs).supported


def test_plates_a_build_left_held_by_nothing_are_fixed_in_the_next(monkeypatch):
    """Whatever leaves plates unheld (here: the rule for slot-hung plates switched off, so the
    columns of the dipping facade hang in slots they slide out of), the builder reads the
    load path of its result and builds once more with each unheld plate fixed."""
    from torsal.fabrication.builder.paths import AssemblyPlanner

    monkeypatch.setattr(AssemblyPlanner, "_slot_hung", lambda self, roots: {})
    fs = _build(facade(20.0))
    columns = sorted(p.name for p in fs.parts if p.family == 1)
    assert fs._fix_also == {(fs._strip_of[c], fs.part(c).span[0] + j) for c in columns
                            for j in range(len(fs.part(c).panels))}
    assert {c: _fixed(fs).get(c, 0) for c in columns} == {c: 1 for c in columns}
    assert load_path(fs).supported


def test_a_design_no_fixing_fits_keeps_its_fins_and_is_refused():
    """15 mm deep fins: no fixing has room for its legs anywhere, so nothing holds the plates.
    They are not left out (more than MAX_UNHOLDABLE_SHARE of the panels): the load path
    names them, and the design is not buildable until it is deeper."""
    from fab_structures import flat_structure

    from torsal.fabrication.builder.rebuild import MAX_UNHOLDABLE_SHARE

    fs = _build(flat_structure(3, 5, depth=0.015))
    plates = sorted(p.name for p in fs.parts if p.family in (0, 1))
    assert not [p for p in fs.parts if p.family == FIXING_FAMILY]
    assert fs.coplanar_panels == [] and len(fs._fix_also) > MAX_UNHOLDABLE_SHARE * fs.n_panels
    lp = load_path(fs)
    assert not lp.supported and set(plates) <= set(lp.unsupported_parts)
