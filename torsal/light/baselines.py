"""What a designer would otherwise use: the standard shading devices.

Kept for the names it has always exported; the devices live in :mod:`torsal.light.devices`
(horizontal louvers, vertical fins, egg-crate, and the sun-optimized parallel fins and
egg-crate on any surface).

>>> from torsal.light.baselines import horizontal_louvers
>>> horizontal_louvers.__module__
'torsal.light.devices.facade'
"""
from torsal.light.devices import (
    baselines,
    egg_crate,
    grid_normal_fins,
    horizontal_louvers,
    section_fins,
    standard_devices,
    vertical_fins,
)

__all__ = ["horizontal_louvers", "vertical_fins", "egg_crate", "section_fins", "grid_normal_fins",
           "baselines", "standard_devices"]
