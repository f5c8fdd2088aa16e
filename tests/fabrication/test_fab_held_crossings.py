"""The builder's safety net (issues 40, 42): a 4 x 3 m facade patch whose fins point 57 deg
down from the wall has three plates hung in slots they would slide out of, where no fixing
fits; the builder bolts each to the plate it hangs on (that crossing butted, bracket or tab)
and the load path, which reads the bolts from the holes, then reaches every part.

The design is the command-line tests' tiny facade at 4 x 3 m (``facade_patch`` nu 7, nv 5,
fin spacing 1 m, depth 0.5 m): its support structure in half a second, its fin system in
about ten (the net's two rounds of builds add about as much again).
"""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from torsal.fabrication.assembly import check_load_path, fastenings_of, joints_of, load_path
from torsal.fabrication.builder.held import MAX_HOLD_ROUNDS, held_report
from torsal.fabrication.model import JointKind
from torsal.pipeline.cache import StageCache
from torsal.pipeline.design_file import load_design_file
from torsal.pipeline.fins import fabrication_summary, fin_system, forget_fin_system
from torsal.pipeline.report import _held_rows
from torsal.pipeline.stage import StageRun, run_stages
from torsal.pipeline.stages import DEFAULT_PIPELINE

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from test_cli import tiny_design  # noqa: E402

#: the command-line tests' tiny design at 4 x 3 m (its 6 x 3 m builds as it is)
PATCH = tiny_design(spacing=1.0, width=4.0)

#: the plates the load path finds loose without the net (measured: refused by ``torsal
#: design``, exit status 3, before the net)
LOOSE = ["F0-S002-P03", "F1-S001-P00", "F1-S005-P00"]


@pytest.fixture(scope="module")
def patch(tmp_path_factory):
    """``(spec, structure)`` of the patch: the design run's stages up to the support."""
    folder = tmp_path_factory.mktemp("patch")
    (folder / "patch.toml").write_text(PATCH)
    spec = load_design_file(folder / "patch.toml")
    run = run_stages(DEFAULT_PIPELINE.until("support"), spec, folder,
                     StageCache(folder / "cache", enabled=False), run=StageRun())
    return spec, run.values["support"]["structure"]


def _build(spec, structure):
    forget_fin_system()                 # never the one another test built
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            fs = fin_system(spec, structure)
    finally:
        forget_fin_system()
    return fs, [str(w.message) for w in caught]


def _way_out_dip(structure, node: int) -> float:
    """Degrees below the horizontal of the way out of a slot at ``node``: away from the
    building along the node line, ``b - a`` (by hand from the structure)."""
    a, b = (np.asarray(x[node], float) for x in (structure.vertices_a, structure.vertices_b))
    return float(np.degrees(np.arcsin(-((b - a) / np.linalg.norm(b - a))[2])))


def test_without_the_net_three_plates_slide_out_of_their_slots(patch, monkeypatch):
    monkeypatch.setattr("torsal.fabrication.builder.rebuild.MAX_HOLD_ROUNDS", 0)
    spec, structure = patch
    fs, _ = _build(spec, structure)
    lp = load_path(fs)
    assert lp.unsupported_parts == LOOSE and not fs.held_crossings
    # each hangs in slots whose way out dips as the fins do, 57 deg (by hand: the node line)
    for name, dip in lp.sliding_out.items():
        nodes = [j.node for j in fs.joints if j.kind == JointKind.EGG_CRATE and name in j.parts]
        assert dip == pytest.approx(max(_way_out_dip(structure, v) for v in nodes), abs=0.1)
        assert 56 < dip < 57
    assert "3 parts do not reach the building" in lp.problems()


def test_the_net_bolts_them_to_the_plates_they_hang_on(patch):
    assert MAX_HOLD_ROUNDS >= 2          # the patch takes two: one plate hangs on another
    spec, structure = patch
    fs, said = _build(spec, structure)
    # the load path (it reads the bolts from the holes, not the builder's plans) reaches all
    lp = load_path(fs)
    assert lp.supported and lp.components == 1 and lp.unsupported_parts == []
    held = fs.held_crossings
    assert sorted(h.part for h in held) == LOOSE and len({h.node for h in held}) == 3
    bolts = fastenings_of(fs)
    pairs = {frozenset(f.parts) for f in bolts}
    for h in held:
        assert h.dip_deg == pytest.approx(_way_out_dip(structure, h.node), abs=0.1)
        # the crossing is a butt joint now: the loose plate's family split there, every
        # part butted against the holder bolted to it, by its tab or through a bracket
        joints = [j for j in fs.joints if j.node == h.node]
        assert joints and not any(j.kind == JointKind.EGG_CRATE for j in joints)
        assert h.part in h.parts and h.parts
        for name in h.parts:
            brackets = {c for c in h.brackets if frozenset((c, name)) in pairs}
            assert (name in h.tabs and frozenset((name, h.holder)) in pairs) or any(
                frozenset((c, h.holder)) in pairs for c in brackets), (name, h)
        assert h.holder not in lp.unsupported_parts
    # control: without the bolts at those crossings the loose plates are loose again
    holder_of = {n: h.holder for h in held for n in h.parts}
    added = {c for h in held for c in h.brackets}

    def the_nets(f):
        a, b = f.parts
        return bool(added & {a, b}) or holder_of.get(a) == b or holder_of.get(b) == a

    without = check_load_path([p.name for p in fs.parts], joints_of(fs),
                              [f for f in bolts if not the_nets(f)])
    assert set(LOOSE) <= set(without.unsupported_parts)
    # named for the fabricator: the report and a warning
    report = fabrication_summary(fs)["held_by_builder"]
    assert report["crossings"] == 3 and report["parts"] == LOOSE
    assert all("no fixing held it" in h["why"] and h["holder"] in h["why"] for h in report["list"])
    assert held_report(fs) == report
    (label, cell), = _held_rows({"held_by_builder": report})
    assert cell.startswith("3 crossings") and all(name in cell for name in LOOSE)
    assert _held_rows({"held_by_builder": {"crossings": 0, "parts": [], "list": []}}) == []
    warned = [m for m in said if "hung loose in slots" in m]
    assert len(warned) == 1 and all(name in warned[0] for name in LOOSE)
