"""Standard shading devices on any surface, generated relative to the surface and the sun.

- :mod:`~torsal.light.devices.sections`: fins along the sections of A by parallel planes;
- :mod:`~torsal.light.devices.frame`: is A a facade or a canopy, and its frame;
- :mod:`~torsal.light.devices.facade`: horizontal louvers, vertical fins, egg-crate, and the
  unoptimized normal-congruence fins;
- :mod:`~torsal.light.devices.oriented`: parallel fins whose plane orientation is optimized
  for the design's sun;
- :mod:`~torsal.light.devices.catalog`: every standard device of a depth and spacing, made
  or reported not applicable with the reason.

>>> from torsal.light.devices import DEVICE_NAMES
>>> DEVICE_NAMES[0]
'horizontal louvers'
"""
from torsal.core.lazy import lazy_exports
__getattr__, __dir__ = lazy_exports(__name__, {
    ".catalog": ("DEVICE_NAMES", "MIN_STAND_OUT_DEG", "Device", "DeviceKind", "baselines",
                 "standard_devices"),
    ".facade": ("egg_crate", "grid_normal_fins", "horizontal_louvers", "vertical_fin_normal",
                "vertical_fins"),
    ".frame": ("WALL_LIMIT_DEG", "SurfaceFrame", "surface_frame"),
    ".oriented": ("MAX_TILT_DEG", "FinOrientation", "optimize_fin_orientation"),
    ".sections": ("section_fins",),
})

__all__ = ["DEVICE_NAMES", "Device", "DeviceKind", "standard_devices", "baselines",
           "horizontal_louvers", "vertical_fins", "egg_crate", "grid_normal_fins",
           "vertical_fin_normal", "section_fins", "SurfaceFrame", "surface_frame",
           "FinOrientation", "optimize_fin_orientation", "MIN_STAND_OUT_DEG", "WALL_LIMIT_DEG",
           "MAX_TILT_DEG"]
