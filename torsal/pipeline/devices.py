"""The standard shading devices a design and a study compare torsal's fins with, as a stage.

For a design's fin depth and spacing: horizontal louvers, vertical fins and their egg-crate
(on a facade), the sun-optimized parallel fins and their egg-crate (on any surface), made on
the same oriented mesh A by :func:`torsal.light.devices.standard_devices` and measured by
:func:`~torsal.pipeline.measure.measure_fins` exactly like the design's own fins (the same
seeded sample points, sun directions and weights, view rays and eye points). A device that
cannot be made on the surface is reported not applicable, with the reason.
"""
from __future__ import annotations

from dataclasses import replace

from ..light.devices import DEVICE_NAMES
from .measure import run_devices
from .stages import DEFAULT_PIPELINE

__all__ = ["DEVICES", "run_devices", "DEVICES_PIPELINE"]

#: the standard devices, in the order of the table and the plot
DEVICES = DEVICE_NAMES

#: surface, sun and orientation shared with the designs (one cache), then the devices: the
#: devices stage of every design run (the same keys), so a study's devices and its variants'
#: are one computation; run in order here (the design runs them beside its fins)
DEVICES_PIPELINE = DEFAULT_PIPELINE.until("orient").insert(
    replace(DEFAULT_PIPELINE["devices"], concurrent=False), after="orient")
