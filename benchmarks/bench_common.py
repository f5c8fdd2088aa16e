"""Helpers the benchmarks share: a design's support structure from its stages (cached), and
the volume of a rhino3dm Brep of planar faces (the 3DM's check; tests/fabrication/test_rhino.py
uses it too)."""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np


def design_structure(toml: Path, out: Path):
    """The design spec and its support structure (stages up to ``support``, cached in
    ``out``/cache; a last stage in the place of fabrication only hands the structure over)."""
    from torsal.design import Design
    from torsal.pipeline import DEFAULT_PIPELINE, Stage, StageCache

    got = {}

    def take(inp):
        got["structure"] = inp["support"]["structure"]
        return {"report": {}}

    fabrication = DEFAULT_PIPELINE["fabrication"]
    pipe = DEFAULT_PIPELINE.until("fabrication").replace(
        Stage("fabrication", take, inputs=fabrication.inputs, key=fabrication.key, cache=False))
    design = Design.from_toml(toml)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        design.run(out / "run", cache=StageCache(out / "cache", prune=False), pipeline=pipe)
    return design.spec, got["structure"]


def brep_volume(brep) -> float:
    """Volume of a rhino3dm Brep of planar faces (cubed units of its points): (1/6) sum over
    its loops of (p_i x p_i+1) . c, c the centroid of its face's outer loop's points."""
    pts = np.array([(v.Location.X, v.Location.Y, v.Location.Z) for v in brep.Vertices])
    total = 0.0
    for face in brep.Faces:
        c = pts[[t.StartVertexIndex for t in face.Loops[0].Trims]].mean(axis=0)
        for loop in face.Loops:
            p = pts[[t.StartVertexIndex for t in loop.Trims]]
            total += np.cross(p - c, np.roll(p, -1, axis=0) - c).sum(axis=0) @ c / 6.0
    return total
