"""Light as a measured part of torsal: sun directions (pvlib), ray-cast shading measurements,
the occupants' view out (:mod:`~torsal.light.view`) and the standard devices torsal's fins are
compared with (:mod:`~torsal.light.devices`).

Imports only :mod:`torsal.geometry` and :mod:`torsal.core` from torsal; never the optimizer or
fabrication.
"""
from torsal.core.lazy import lazy_exports
from .baselines import (baselines, egg_crate, grid_normal_fins, horizontal_louvers,
                        section_fins, vertical_fins)
__getattr__, __dir__ = lazy_exports(__name__, {
    ".devices": ("DEVICE_NAMES", "Device", "DeviceKind", "standard_devices"),
    ".shading": ("ReflectionResult", "SeeThroughResult", "ShadingResult", "TransparencyResult",
                 "compare", "direct_sun_blocked", "mirror_normals", "ray_hits", "rays_blocked",
                 "reflect", "reflected_hits", "see_through", "transparency"),
    ".reflection": ("CeilingTarget", "MirrorAim", "ReflectionBound", "ReflectionRays",
                    "TargetSide", "best_mirror_normals", "ideal_mirror_bound",
                    "incidence_plane_normals"),
    ".sun": ("SunDirections", "epw_hours", "hot_hours", "light_directions", "sun_directions",
             "sun_path", "write_synthetic_epw"),
    ".view": ("ViewField", "ViewOutResult", "view_out"),
})

__all__ = [
    "SunDirections", "sun_directions", "sun_path", "hot_hours", "light_directions",
    "write_synthetic_epw", "epw_hours",
    "rays_blocked", "ray_hits", "direct_sun_blocked", "transparency", "see_through",
    "mirror_normals", "reflect", "reflected_hits", "compare",
    "ShadingResult", "TransparencyResult", "SeeThroughResult", "ReflectionResult",
    "CeilingTarget", "TargetSide", "ReflectionRays", "MirrorAim", "ReflectionBound",
    "best_mirror_normals", "ideal_mirror_bound", "incidence_plane_normals",
    "horizontal_louvers", "vertical_fins", "egg_crate", "section_fins", "grid_normal_fins", "baselines",
    "standard_devices", "Device", "DeviceKind", "DEVICE_NAMES", "view_out", "ViewField",
    "ViewOutResult",
]
