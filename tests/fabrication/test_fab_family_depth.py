"""Each fin family its own depth (``fins.depth = [d0, d1]``, issue 41): the parts of each
family are as deep as its fins, and the egg-crate slots of two plates of unequal depth meet
inside the stretch of the node line both plates cover, without the solids interfering."""
from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from fab_structures import grid_structure
from torsal.fabrication import FinSystem
from occ_overlap import interfering_pairs  # noqa: E402

T, C = 3.0, 0.5


def square_grid(depth: float = 0.1, step: float = 0.3):
    """3 x 3 grid of vertical node lines ``depth`` deep: flat plates crossing square at node 4."""
    a = np.array([[[c * step, r * step, 0.0] for c in range(3)] for r in range(3)])
    return grid_structure(a, a + [0, 0, depth], 3, 3)


@pytest.mark.parametrize("ratio", [(1.0, 0.4), (0.4, 1.0)])
def test_unequal_families_are_slotted_where_both_plates_are(ratio):
    s = dataclasses.replace(square_grid(), family_depth_ratio=ratio)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")            # no room for brackets on so small a grid
        fs = FinSystem(s, thickness=T, clearance=C)
    depth = {f: 100.0 * ratio[f] for f in (0, 1)}          # mm
    for p in fs.plates:                      # each plate as deep as its family's fins
        np.testing.assert_allclose(np.linalg.norm(p.panels[:, 3] - p.panels[:, 0], axis=1),
                                   depth[p.family], rtol=1e-9)
    [x] = fs.crossings
    both = min(depth.values())
    # family 0 slotted from its b edge, family 1 from a: they meet half-way up the shared
    # part, each running half the clearance past it (the slot ends stand C apart)
    assert x.depth1 == pytest.approx(0.5 * both + 0.5 * C)
    assert x.depth0 == pytest.approx(depth[0] - 0.5 * both + 0.5 * C)
    slots = {p.family: s for p in fs.parts for s in p.slots}
    assert slots[0].depth == pytest.approx(x.depth0) and slots[1].depth == pytest.approx(x.depth1)
    assert not interfering_pairs(fs.solids(workers=1))
