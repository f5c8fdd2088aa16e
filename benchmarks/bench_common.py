"""Helpers the benchmarks share: a design's support structure from its stages (cached), and
the volume of a rhino3dm Brep of planar faces (the 3DM's check; a name for
:func:`torsal.fabrication.rhino.brep_volume`, which the tests use too)."""
from __future__ import annotations

import warnings
from pathlib import Path

from torsal.fabrication.rhino import brep_volume  # noqa: F401


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
