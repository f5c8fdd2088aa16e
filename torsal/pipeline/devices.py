"""The standard shading devices a study compares torsal's fins with, as a stage.

For a design's fin depth and spacing: horizontal louvers, vertical fins and the orthogonal
egg-crate of both (:mod:`torsal.light.baselines`) on the same oriented mesh A, measured by
:func:`~torsal.pipeline.stages.measure_fins` exactly like the design's own fins (the same
seeded sample points, sun directions and weights, view rays).
"""
from __future__ import annotations

from .design_file import DesignSpec
from .stage import Stage, StageInputs
from .stages import DEFAULT_PIPELINE, measure_fins

__all__ = ["DEVICES", "run_devices", "DEVICES_PIPELINE"]

#: the standard devices, in the order of the table and the plot
DEVICES = ("horizontal louvers", "vertical fins", "egg-crate")


def run_devices(inp: StageInputs) -> dict:
    """Returns ``report``: {device name: :func:`measure_fins` report}."""
    from ..light.baselines import baselines

    spec = inp.spec
    o = inp["orient"]
    v, f = o["vertices"], o["faces"]
    meshes = baselines(v, f, spec.fins.depth, spec.fins.spacing)
    return {"report": {name: measure_fins(meshes[name], (v, f), inp["sun"],
                                          spec.outputs.light_samples, spec.metres_per_unit)[0]
                       for name in DEVICES}}


def _devices_key(spec: DesignSpec) -> tuple:
    return (spec.fins.depth, spec.fins.spacing, spec.outputs.light_samples, spec.units)


#: surface, sun and orientation shared with the designs (one cache), then the devices
DEVICES_PIPELINE = DEFAULT_PIPELINE.until("orient").insert(
    Stage("devices", run_devices, inputs=("orient", "sun"), key=_devices_key), after="orient")
