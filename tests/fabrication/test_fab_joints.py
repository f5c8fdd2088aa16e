"""Joinery per node on constructed cases with known answers (issue 15).

Plates crossing at 90, 45 and 20 degrees; a strip folding 60 degrees at a crossing. "No
interference" is checked with OpenCascade boolean common volumes (``occ_overlap``, which
shares no code with the joint builder): > 1 mm^3 is interference.
"""
from __future__ import annotations

import csv
import dataclasses
import warnings

import numpy as np
import pytest

from fab_structures import grid_structure
from torsal.fabrication import FinSystem, Joint, JointKind, read_dxf_parts, read_step, slot_width

pytest.importorskip("build123d")
from occ_overlap import common_volume, interfering_pairs  # noqa: E402

T, C = 3.0, 0.5


def sheared_grid(alpha_deg: float, step: float = 0.3, depth: float = 0.1):
    """3 x 3 grid whose rows (family 0) run along x and columns (family 1) at ``alpha`` to
    them; vertical node lines, so all fins are flat plates crossing at ``alpha`` at node 4."""
    al = np.radians(alpha_deg)
    e0, e1 = np.array([1.0, 0, 0]), np.array([np.cos(al), np.sin(al), 0])
    a = np.array([[c * step * e0 + r * step * e1 for c in range(3)] for r in range(3)])
    return grid_structure(a, a + [0, 0, depth], 3, 3)


def folded_rows(fold_deg: float = 60.0, step: float = 0.3, depth: float = 0.1):
    """3 x 3 grid whose rows fold ``fold_deg`` (in plan, about the vertical node lines) at the
    middle column; columns straight."""
    f = np.radians(fold_deg)
    xs = [np.array([-step, 0, 0]), np.zeros(3), step * np.array([np.cos(f), np.sin(f), 0])]
    a = np.array([[x + [0, r * step, 0] for x in xs] for r in range(3)])
    return grid_structure(a, a + [0, 0, depth], 3, 3)


def _build(structure, **kw):
    # (the joinery's joints as chosen: brackets; tabs instead of brackets are test_fab_tabs')
    kw.setdefault("tabs", False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")             # constructed cases: nothing to warn about
        return FinSystem(structure, thickness=T, clearance=C, **kw)


@pytest.mark.parametrize("alpha", [90.0, 45.0])
def test_crossing_plates_are_slotted_with_the_width_the_angle_needs(alpha):
    fs = _build(sheared_grid(alpha))
    [x] = fs.crossings
    assert x.node == 4 and x.angle == pytest.approx(alpha, abs=1e-9)
    a = np.radians(alpha)
    # the crossing plate's cross-section is a parallelogram t (1 + cos a) / sin a wide
    want = T * (1 + np.cos(a)) / np.sin(a) + C
    slots = [s for p in fs.parts for s in p.slots]
    assert len(slots) == 2 and all(s.width == pytest.approx(want, rel=1e-12) for s in slots)
    if alpha == 90.0:
        assert want == pytest.approx(T + C)
    [j] = [j for j in fs.joints if j.kind == JointKind.EGG_CRATE]
    assert j.node == 4 and j.connector is None
    assert set(j.parts) == {"F0-S001-P00", "F1-S001-P00"}
    # the later (family-1) plate slides along the node axis, from b towards a
    np.testing.assert_allclose(j.insert_direction, [0, 0, -1], atol=1e-12)
    assert not interfering_pairs(fs.solids(workers=1))


def test_slot_of_only_t_over_sin_alpha_would_interfere_at_45_degrees():
    # why the slot is t (1 + cos a) / sin a + c wide and not t / sin a + c: a square cut of the
    # narrower width leaves material of the slotted plate inside the crossing plate
    fs = _build(sheared_grid(45.0))
    sol = fs.solids(workers=1)
    p0 = fs.part("F0-S001-P00")
    narrow = [dataclasses.replace(s, width=T / np.sin(np.radians(45.0)) + C) for s in p0.slots]
    from torsal.fabrication import part_solid

    thin = part_solid(dataclasses.replace(p0, slots=narrow), T)
    assert common_volume(thin, sol["F1-S001-P00"]) > 1.0
    assert common_volume(sol["F0-S001-P00"], sol["F1-S001-P00"]) <= 1.0


def test_too_oblique_crossing_is_butted_with_brackets():
    with pytest.warns(UserWarning, match="2 joints have no connector"):
        fs = FinSystem(sheared_grid(20.0), thickness=T, clearance=C, tabs=False)
    # the two L corners of 20 deg have no room for a bracket: named, not silent
    assert sorted((n, v) for n, v, _ in fs.unconnected_joints) == [("F1-S000-P00", 0),
                                                                    ("F1-S002-P00", 8)]
    assert not fs.crossings                      # 20 deg < MIN_CROSSING_ANGLE: no slots
    [x] = fs.joinery
    assert x.kind == JointKind.BUTT_BRACKET and x.angle == pytest.approx(20.0)
    assert "cross at 20 deg" in x.why
    # the column (family 1, the tie-break) is split at the crossing; both halves are butted
    # against the continuous row, each with a bracket bent to the open (160 deg) corner
    at4 = [j for j in fs.joints if j.node == 4]
    assert len(at4) == 2 and all(j.kind == JointKind.BUTT_BRACKET for j in at4)
    assert {j.parts[1] for j in at4} == {"F1-S001-P00", "F1-S001-P01"}
    assert all(j.parts[0] == "F0-S001-P00" and j.connector == j.parts[-1] for j in at4)
    assert all(j.angle == pytest.approx(160.0, abs=1e-6) for j in at4)
    conn = [fs.part(j.connector) for j in at4]
    for c in conn:
        assert c.name.startswith("C-N0004-")
        assert np.degrees(abs(c.fold_angles[0])) == pytest.approx(20.0, abs=1e-6)
    sol = fs.solids(workers=1)
    assert not interfering_pairs(sol)
    # a user may allow slots down to 10 deg: then the slot is t cot(10 deg) + c wide
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        slotted = FinSystem(sheared_grid(20.0), thickness=T, clearance=C, min_crossing_angle=10.0,
                            tabs=False)
    [x] = slotted.crossings
    assert x.width == pytest.approx(T / np.tan(np.radians(10.0)) + C)
    assert not interfering_pairs(slotted.solids(workers=1))


def test_strip_folding_60_degrees_at_a_crossing_is_split_never_overlapping():
    fs = _build(folded_rows(60.0))
    [x] = fs.joinery
    assert x.split == 0 and x.folds[0] == pytest.approx(60.0, abs=1e-9)
    row = [p for p in fs.parts if p.family == 0 and p.id.strip == 1]
    assert [len(p.panels) for p in row] == [1, 1]           # split at the fold
    for p in row:
        assert np.all(p.fold_angles == 0)
    # the two parts meet on their mitred seam inside the straight column's slot (issue 42),
    # proved by the assembly check on the three; with that seam refused, they butt against
    # the column with a bracket each
    at4 = [j for j in fs.joints if j.node == 4]
    assert [(j.kind, j.connector) for j in at4] == [(JointKind.EGG_CRATE, None)]
    assert at4[0].parts == tuple(sorted(p.name for p in row)) + ("F1-S001-P00",)
    assert [(s.node, s.family) for s in fs.seams_in_slot] == [(4, 0)]
    assert not fs.untrimmed_joints and not fs.unconnected_joints
    sol = fs.solids(workers=1)
    assert not interfering_pairs(sol)


def test_a_strip_folding_at_a_crossing_butts_where_its_seam_cannot_stay(monkeypatch):
    from torsal.fabrication.builder.seams import SlotSeams

    monkeypatch.setattr(SlotSeams, "candidates", lambda self, *a, **kw: set())
    fs = _build(folded_rows(60.0))
    row = [p for p in fs.parts if p.family == 0 and p.id.strip == 1]
    at4 = [j for j in fs.joints if j.node == 4]
    assert len(at4) == 2 and {j.parts[1] for j in at4} == {p.name for p in row}
    assert all(j.parts[0] == "F1-S001-P00" and j.connector for j in at4)
    assert not fs.untrimmed_joints and not fs.unconnected_joints
    # the butted ends stop t/2 + c/2 short of the column's mid-plane x = 0 (end cap along it)
    for p in row:
        q = p.panels[0]
        corners = q[[0, 3]] if int(p.nodes[0]) == 4 else q[[1, 2]]
        np.testing.assert_allclose(np.abs(corners[:, 0]), T / 2 + C / 2, rtol=1e-9)
    sol = fs.solids(workers=1)
    assert not interfering_pairs(sol)


def test_joints_name_parts_and_connectors_of_the_files(tmp_path):
    fs = _build(folded_rows(60.0))
    names = [p.name for p in fs.parts]
    for j in fs.joints:
        assert isinstance(j, Joint) and isinstance(j.kind, JointKind)
        assert set(j.parts) <= set(names)
        assert j.insert_direction.shape == (3,)
        assert np.linalg.norm(j.insert_direction) == pytest.approx(1.0)
        if j.connector is not None:
            assert j.connector in j.parts and fs.part(j.connector).family == -2
    with pytest.raises(dataclasses.FrozenInstanceError):
        fs.joints[0].node = 7
    # STEP: one valid solid per part and connector, named as in parts.csv
    from OCP.BRepCheck import BRepCheck_Analyzer

    step = read_step(fs.export_step(tmp_path / "fins.step"))
    lay = fs.layout(sheet=(1250.0, 625.0))
    fs.bill_of_materials(tmp_path / "parts.csv", layout=lay)
    with open(tmp_path / "parts.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert sorted(n for n, _ in step) == sorted(r["part_id"] for r in rows) == sorted(names)
    assert all(BRepCheck_Analyzer(s).IsValid() for _, s in step)
    kinds = {r["part_id"]: r["kind"] for r in rows}
    assert {kinds[c.name] for c in fs.connectors} == {"butt-bracket"}
    assert all(kinds[p.name] == "plate" for p in fs.parts if p.family >= 0)
    # DXF: audit clean, every part and connector cut, no two outlines overlapping on a sheet
    texts = []
    for path in lay.export_dxf(tmp_path / "cut.dxf", svg=False):
        polys, t, auditor = read_dxf_parts(path)
        assert not auditor.has_errors
        texts += t
        for i in range(len(polys)):
            for k in range(i + 1, len(polys)):
                assert polys[i].intersection(polys[k]).area < 1e-6
    assert sorted(texts) == sorted(names)
