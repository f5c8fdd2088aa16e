"""A generated family of constrained shading designs: the optimizer's reliability, not one case.

:func:`design_family` makes doubly curved facades and canopies (:mod:`torsal.geometry.surfaces`)
of varied curvature under varied suns, each with the shading term set of the paper's Fig. 12
(``normal 2``, ``fair 1``, ``perpendicular 10`` to one sun, ``hyperbolic``) and a
``min_torsal_angle``. The test suite solves it at small size, ``benchmarks/optimize_bench.py``
at full size; a member that fails names its faces (``OptimizationResult.violated``).
"""
from __future__ import annotations

import math
from typing import Callable, NamedTuple

import numpy as np

from ..congruence import Congruence
from ..surfaces import canopy, facade_patch


class FamilyMember(NamedTuple):
    """One design of the family: a name, its surface (vertices (n, 3), faces (m, 3)), its sun
    (unit vector, light travels along it) and how to make its problem at a bound."""

    name: str
    surface: tuple
    sun: np.ndarray
    make: Callable[..., object]      # make(alpha_deg, **CongruenceProblem options) -> problem


def _sun(azimuth_deg: float, elevation_deg: float, facing: np.ndarray) -> np.ndarray:
    """A light direction (site -> ground) from the sun's azimuth and elevation, turned so that
    it falls on the side the surface faces (``facing``: the mean normal)."""
    a, el = math.radians(azimuth_deg), math.radians(elevation_deg)
    to_sun = np.array([math.sin(a) * math.cos(el), math.cos(a) * math.cos(el), math.sin(el)])
    if to_sun @ facing < 0:            # the sun behind the surface: mirror it in front
        to_sun = to_sun - 2 * (to_sun @ facing) * facing / (facing @ facing)
    return -to_sun / np.linalg.norm(to_sun)


def design_family(n: int = 20, *, size: int = 33) -> list[FamilyMember]:
    """``n`` doubly curved designs (half facades, half canopies) of ``size x size`` vertices.

    Curvatures (bulge, sag, twist; rise, sag) and suns (azimuth 0 to 300 degrees, elevation
    20 to 65 degrees) vary deterministically over the family, so every run solves the same
    designs.

    Examples
    --------
    >>> fam = design_family(4, size=6)
    >>> [m.name for m in fam]
    ['facade-0', 'canopy-1', 'facade-2', 'canopy-3']
    >>> fam[0].make(40).terms["min_torsal_angle"][0]
    'constraint'
    """
    from .problem import CongruenceProblem

    out = []
    for k in range(n):
        t = k / max(n - 1, 1)
        if k % 2 == 0:
            surf = facade_patch(nu=size, nv=size, width=12.0 * size / 33, height=6.0 * size / 33,
                                bulge=0.5 + 0.8 * t, sag=0.2 + 0.4 * ((3 * t) % 1), twist=0.3 + 0.6 * ((7 * t) % 1))
            name = f"facade-{k}"
        else:
            surf = canopy(nu=size, nv=size, span=10.0 * size / 25, rise=1.5 + 2.0 * t, sag=0.4 + 0.8 * ((5 * t) % 1))
            name = f"canopy-{k}"
        c = Congruence.from_normals(surf)
        facing = c.directions.mean(axis=0)
        sun = _sun(300.0 * ((11 * t) % 1), 20.0 + 45.0 * ((3 * t + 0.5) % 1), facing)

        def make(alpha_deg: float, *, _c=c, _sun=sun, **options):
            return (CongruenceProblem(_c, **options).normal(weight=2).fair(weight=1)
                    .perpendicular(_sun, weight=10).hyperbolic().min_torsal_angle(alpha_deg))

        out.append(FamilyMember(name, surf, sun, make))
    return out
