"""The fabrication and assembly stages of one run share one fin system (issue 15: it was
built twice per run); a changed structure or design builds a new one."""
from __future__ import annotations

import tomllib

import numpy as np
from fab_structures import sphere_structure
from torsal.pipeline.design_file import DesignSpec
from torsal.pipeline.fins import fin_system

SPEC = DesignSpec.model_validate(tomllib.loads("""
units = "m"
[surface]
generator = "facade_patch"
[sun]
vectors = [[0.0, -1.0, 0.5]]
[fins]
spacing = 0.6
depth = 0.15
"""))


def _thicker(spec, t):
    return spec.model_copy(update={"material": spec.material.model_copy(update={"thickness_mm": t})})


def test_one_fin_system_per_structure_and_design():
    s = sphere_structure()
    fs = fin_system(SPEC, s)
    assert fs.thickness == SPEC.material.thickness_mm and len(fs.parts) > 0
    # the second stage of the run: the same object, its solids built once
    assert fin_system(SPEC, s) is fs
    # an equal structure (a cached stage re-read) is the same content: reused too
    assert fin_system(SPEC, sphere_structure()) is fs
    # another thickness, another structure: built afresh, never a stale fin system
    other = fin_system(_thicker(SPEC, 5.0), s)
    assert other is not fs and other.thickness == 5.0
    deeper = fin_system(SPEC, sphere_structure(depth=0.2))
    assert deeper is not fs
    assert deeper.parts[0].panels.shape == fs.parts[0].panels.shape
    assert not np.allclose(deeper.parts[0].panels, fs.parts[0].panels)
