"""Light as a measured part of torsal: sun directions (pvlib) and ray-cast shading measurements.

Imports only :mod:`torsal.geometry.mesh` from torsal (and the leaf helper
:mod:`torsal.geometry._atomic` for atomic file output); never the optimizer or fabrication.
"""
from torsal.light.baselines import (
    baselines,
    egg_crate,
    grid_normal_fins,
    horizontal_louvers,
    section_fins,
    vertical_fins,
)
from torsal.light.shading import (
    ReflectionResult,
    SeeThroughResult,
    ShadingResult,
    TransparencyResult,
    compare,
    direct_sun_blocked,
    mirror_normals,
    ray_hits,
    rays_blocked,
    reflect,
    reflected_hits,
    see_through,
    transparency,
)
from torsal.light.reflection import (
    CeilingTarget,
    MirrorAim,
    ReflectionBound,
    ReflectionRays,
    TargetSide,
    best_mirror_normals,
    ideal_mirror_bound,
    incidence_plane_normals,
)
from torsal.light.sun import (
    SunDirections,
    epw_hours,
    hot_hours,
    light_directions,
    sun_directions,
    sun_path,
    write_synthetic_epw,
)

__all__ = [
    "SunDirections", "sun_directions", "sun_path", "hot_hours", "light_directions",
    "write_synthetic_epw", "epw_hours",
    "rays_blocked", "ray_hits", "direct_sun_blocked", "transparency", "see_through",
    "mirror_normals", "reflect", "reflected_hits", "compare",
    "ShadingResult", "TransparencyResult", "SeeThroughResult", "ReflectionResult",
    "CeilingTarget", "TargetSide", "ReflectionRays", "MirrorAim", "ReflectionBound",
    "best_mirror_normals", "ideal_mirror_bound", "incidence_plane_normals",
    "horizontal_louvers", "vertical_fins", "egg_crate", "section_fins", "grid_normal_fins", "baselines",
]
