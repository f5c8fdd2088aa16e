"""Every design that fabrication builds is buildable (issue 27): constructed cases with known
answers, checked with the independent assembly check and by re-reading the files.

* a bracket whose path into place a plate blocks moves to the other corner of its joint (full
  size: its legs still take a bolt);
* the fins are fixed to the building: fixings (``A-E<edge>-<i>``) on surface A, in the STEP,
  the parts list (anchors) and first in the assembly sequence;
* the fasteners' holes are drilled in the DXF, where the parts' holes say.
"""
from __future__ import annotations

import csv
import warnings

import ezdxf
import numpy as np
import pytest

from torsal.fabrication import FinSystem, JointKind, verify_assembly
from torsal.fabrication.builder.ends import CONNECTOR_GAP
from torsal.fabrication.builder.fasteners import CLEARANCE_HOLES
from torsal.fabrication.builder.paths import AssemblyPlanner
from torsal.fabrication.model import CONNECTOR_FAMILY, FIXING_FAMILY
from torsal.fabrication.solids import read_step
from torsal.geometry.support import SupportStructure

T, C = 3.0, 0.5


def corner_blocked_structure() -> SupportStructure:
    """A T junction (metres; node lines vertical, ``a`` on A at z = 0, depth 0.1 m): row ``W``
    (family 0, nodes 0-1-2 along x at y = 0), column ``P`` (family 1, nodes 1-3-4 along y at
    x = 0) ends at node 1 and is butted against W with a bracket in a corner. A single-fin
    row ``O`` that nothing joins stands 30 mm off W in the corner x < 0 (y = 0.03, x from
    -0.15 to -0.01): the bracket put in that corner (legs 18 mm, on it diagonally) runs into O;
    the other corner (x > 0) is free."""
    x = [(-0.3, 0.0, 0.0), (0.0, 0.0, 0.0), (0.3, 0.0, 0.0), (0.0, 0.3, 0.0), (0.0, 0.6, 0.0),
         (-0.15, 0.03, 0.0), (-0.01, 0.03, 0.0)]
    a = np.array(x, float)
    return SupportStructure(a, a + [0.0, 0.0, 0.1], [], np.array([[0, 1], [1, 2], [5, 6], [1, 3], [3, 4]]),
                            np.array([0, 0, 0, 1, 1]))


def _build(structure=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # (brackets: their paths and holes are what this module checks; tabs instead of
        # brackets are test_fab_tabs')
        return FinSystem(structure if structure is not None else corner_blocked_structure(),
                         thickness=T, clearance=C, tabs=False)


@pytest.fixture(scope="module")
def fs():
    return _build()


def test_a_bracket_whose_path_a_plate_blocks_moves_to_the_free_corner(fs, monkeypatch):
    [butt] = [j for j in fs.joints if j.kind == JointKind.BUTT_BRACKET]
    assert butt.parts[:2] == ("F0-S000-P00", "F1-S000-P00")
    [c] = fs.connectors
    assert c.name == butt.connector and c.name in fs._moved_connectors
    # nothing left out, every part in
    assert fs.coplanar_panels == [] and fs.n_panels == 5
    # the bracket in the corner x > 0, y > 0: its legs' mid-planes a thickness and the gap off
    # W's (y = 0) and P's (x = 0), 18 mm (6 t) long, and it goes on diagonally into that corner
    legs, off = c.panels, T * (1 + CONNECTOR_GAP)
    assert np.allclose(legs[0][:, 1], off) and np.allclose(legs[1][:, 0], off)
    assert legs[:, :, 0].min() == pytest.approx(off) and legs[:, :, 0].max() == pytest.approx(off + 6 * T)
    assert legs[:, :, 1].max() == pytest.approx(off + 6 * T)
    np.testing.assert_allclose(butt.connector_direction, np.array([-1.0, -1.0, 0.0]) / np.sqrt(2), atol=1e-12)
    # it is fastened: two bolts a leg (M6 for 3 mm sheet), none shared
    assert len(c.holes) == 4 and all(h.fastener == "M6 bolt" for h in c.holes)
    # the independent check (exact booleans, its own sweep) finds every part's path clear
    r = verify_assembly(fs, workers=1)
    assert r.buildable and r.interfering_pairs == 0 and not r.blocked, r.problems()
    # control: without the builder's connector check the bracket stays in the blocked corner
    # and the independent check finds it blocked (by O)
    monkeypatch.setattr(AssemblyPlanner, "_check_connectors", lambda self, paths: None)
    kept = _build()
    [k] = kept.connectors
    assert k.panels[:, :, 0].max() == pytest.approx(-T * (1 + CONNECTOR_GAP))
    r = verify_assembly(kept, workers=1)
    assert [s.part for s in r.blocked] == [k.name] and r.interfering_pairs == 0


def _connector_path_checks(monkeypatch, structure) -> tuple[list[int], object]:
    """Build ``structure`` counting, per connector check of a build, how often a connector's
    path is looked at."""
    from torsal.fabrication.builder import paths as paths_mod

    counts: list[int] = []
    hits, check = paths_mod._PathCheck.hits, AssemblyPlanner._check_connectors

    def counted_hits(self, p, d, **kw):
        if p.family == CONNECTOR_FAMILY and counts:
            counts[-1] += 1
        return hits(self, p, d, **kw)

    def counted_check(self, paths):
        counts.append(0)
        check(self, paths)

    monkeypatch.setattr(paths_mod._PathCheck, "hits", counted_hits)
    monkeypatch.setattr(AssemblyPlanner, "_check_connectors", counted_check)
    return counts, _build(structure)


def test_connector_paths_are_checked_again_only_after_a_connector_moved(monkeypatch):
    # without the row O nothing blocks the bracket: its path is found clear once a build (the
    # second look, for connectors moved later, has nothing to look at)
    s = corner_blocked_structure()
    keep = np.array([0, 1, 3, 4])
    free = SupportStructure(s.vertices_a, s.vertices_b, [], s.edges[keep], s.edge_family[keep])
    counts, built = _connector_path_checks(monkeypatch, free)
    assert len(built.connectors) == 1 and built._moved_connectors == []
    assert counts and all(n == 1 for n in counts)
    assert verify_assembly(built, workers=1).buildable
    # with O the bracket moves to the free corner: every connector's path is looked at again
    counts, built = _connector_path_checks(monkeypatch, corner_blocked_structure())
    assert built._moved_connectors and counts[-1] >= 3


def test_fixings_on_surface_a_in_the_step_the_parts_list_and_first_in_the_sequence(fs, tmp_path):
    fixings = fs.fixings
    # W (the plate P butts against) carries the others; O stands on its own: both are fixed
    # (W near both its ends: 600 mm of foot, one each side of the crossing); P is not (it is
    # carried by W)
    assert sorted(f.name for f in fixings) == ["A-E0000-0", "A-E0001-0", "A-E0002-0"]
    fixed = {j.parts[1] for j in fs.joints if j.kind == JointKind.FIXING}
    assert fixed == {"F0-S000-P00", "F0-S001-P00"}
    for f in fixings:
        assert f.family == FIXING_FAMILY
        fin_leg, base_leg = f.panels
        # the leg on the building lies on A (z = 0): its mid-plane t/2 and the gap above it;
        # the leg on the fin on the fin's face (its mid-plane a thickness and the gap off the
        # fin's)
        gap = CONNECTOR_GAP * T
        assert np.allclose(base_leg[:, 2], T / 2 + gap)
        y_fin = 0.0 if f.name != "A-E0002-0" else 30.0
        assert np.allclose(np.abs(fin_leg[:, 1] - y_fin), T + gap)
        anchors = [h for h in f.holes if h.fastener.endswith("anchor")]
        bolts = [h for h in f.holes if h.fastener.endswith("bolt")]
        assert anchors and bolts
        assert all(h.diameter == pytest.approx(CLEARANCE_HOLES[8]) for h in anchors)   # M8
        assert all(abs(h.center[2] - T / 2 - gap) < 1e-9 for h in anchors)             # on A
    # STEP: a solid per fixing, read back by name with OCC's reader
    step = fs.export_step(tmp_path / "fins.step")
    names = {n for n, _ in read_step(step)}
    assert {f.name for f in fixings} <= names
    # parts list: kind "fixing", anchors counted
    fs.bill_of_materials(tmp_path / "parts.csv")
    with open(tmp_path / "parts.csv", newline="") as fh:
        rows = {r["part_id"]: r for r in csv.DictReader(fh)}
    for f in fixings:
        r = rows[f.name]
        assert r["kind"] == "fixing" and int(r["fasteners"]) == len(f.holes)
        assert "M8 anchor" in r["fastener"] and int(r["family"]) == FIXING_FAMILY
    # the assembly sequence starts from them: every fixing before every plate
    r = verify_assembly(fs, workers=1)
    order = [s.part for s in r.order]
    assert order[:len(fixings)] == sorted(f.name for f in fixings)
    assert all(s.insert_direction is None for s in r.order[:len(fixings)])


def test_holes_are_drilled_in_the_dxf_where_the_parts_say(fs, tmp_path):
    lay = fs.layout(sheet=(1250.0, 625.0))
    paths = lay.export_dxf(tmp_path / "cut.dxf", svg=False)
    circles = []
    for p in paths:
        doc = ezdxf.readfile(p)
        circles += [2 * e.dxf.radius for e in doc.modelspace().query("CIRCLE[layer=='NOMINAL']")]
    # every hole of every part (connectors, fixings and the plates they lie on), once
    want = sorted(round(h.diameter, 6) for p in fs.parts for h in p.holes)
    assert want and sorted(round(d, 6) for d in circles) == want
    # the plates carry the matching holes of the bracket and fixings on them
    holes = {p.name: len(p.holes) for p in fs.parts}
    c = fs.connectors[0]
    assert holes["F0-S000-P00"] + holes["F1-S000-P00"] >= len(c.holes)
    assert holes[c.name] == 4 and c.family == CONNECTOR_FAMILY


def parallel_lines_design() -> str:
    """The earlier good run of test_bad_input (``EARLIER_DESIGN``) without its
    min_torsal_angle: one sun on a nearly flat patch, whose optimum is a bundle of nearly
    parallel lines (torsal planes crossing at a few degrees); fins 5 mm deep in cm units; STEP
    written."""
    from pathlib import Path

    text = (Path(__file__).parents[1] / "test_bad_input.py").read_text()
    start = text.index('EARLIER_DESIGN = """') + len('EARLIER_DESIGN = """')
    design = text[start:text.index('"""', start)]
    assert "min_torsal_angle = 40\n" in design and "step = false" in design
    return design.replace("min_torsal_angle = 40\n", "").replace("step = false", "step = true")


def test_a_degenerate_one_sun_design_builds_or_names_what_to_do(tmp_path, capsys):
    # it once ended in a traceback-like 'invalid solid ... plate volume differs' at the
    # assembly stage: now it builds (its too narrow panels left out and named), or, where a
    # plate cannot be made, the run ends with exit 2 naming the parts and what to change
    import json

    from torsal.cli import main

    (tmp_path / "d.toml").write_text(parallel_lines_design())
    rc = main(["design", str(tmp_path / "d.toml"), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    if rc == 0:
        r = json.loads((tmp_path / "out" / "report.json").read_text())
        fa = r["fabrication"]
        assert fa["assembly"]["buildable"] and fa["assembly"]["interfering_pairs"] == 0
        # what was left out is named, and counted as a share of the fins
        assert fa["panels_left_out"] == len(fa["panels_left_out_list"])
        assert fa["panels_left_out_share"] == pytest.approx(fa["panels_left_out"] / r["support"]["edges"])
        assert (tmp_path / "out" / "fins.step").exists()
    elif rc == 3:
        # its fins are 5 mm deep: no room for a fixing, a bracket or a bolt; the plates go in
        # but nothing holds them (issue 42's load path): named, with what to do
        r = json.loads((tmp_path / "out" / "report.json").read_text())
        a = r["fabrication"]["assembly"]
        assert a["interfering_pairs"] == 0 and not a["blocked_parts"] and not a["buildable"]
        lp = a["load_path"]
        assert r["fabrication"]["fixings"] == 0 and lp["edges"].get("anchor", 0) == 0
        # every part
        assert a["unsupported_parts"] == lp["unsupported_parts"] == sorted(
            s["part"] for s in a["sequence"])
        # (the butt joints no bracket has room for hold as the site fastenings the builder
        # asks for: the plates form groups, none reaching the building)
        assert lp["components"] == len(lp["groups"]) >= 1
        assert sorted(sum(lp["groups"], [])) == lp["unsupported_parts"]
        flat = " ".join(err.split())
        assert "do not reach the building" in flat and "fixings" in flat
        assert all(n in flat for n in lp["unsupported_parts"][:8])
        # (the design writes no report.html: its assembly section as report.html shows it)
        from torsal.pipeline.report import _assembly_html

        html = _assembly_html(a)
        assert "parts not held to the building" in html and "NOT BUILDABLE" in html
        assert lp["unsupported_parts"][0] in html
    else:
        assert rc == 2 and "invalid solid for part" in err and "min_torsal_angle" in err
        assert not (tmp_path / "out" / "report.json").exists()
