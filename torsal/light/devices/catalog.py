"""The standard devices torsal's fins are compared with, generated relative to the surface
and the sun, each either made or reported not applicable with the reason.

=========================  ==========================================================
device                     planes
=========================  ==========================================================
horizontal louvers         horizontal (facades only)
vertical fins              vertical, across the facade (facades only)
egg-crate                  both of the above
optimized parallel fins    one family, orientation optimized for the design's sun
                           (:mod:`~torsal.light.devices.oriented`); any surface
optimized egg-crate        the optimized family and the family square to it and to A
=========================  ==========================================================

All have the design's fin depth and spacing. Where the design gives each torsal family its
own (``fins.depth = [d0, d1]``, ``fins.spacing = [s0, s1]``), a device's first family (the
louvers, the vertical fins, the optimized parallel fins) has family 0's and the crossing
family of an egg-crate (its vertical fins, the optimized egg-crate's square family) family
1's: an egg-crate then spends its material as the two torsal families do, and a single
family stands for torsal's first. A device is **not applicable** when it cannot
be made on the surface: a facade device on a canopy (:mod:`~torsal.light.devices.frame`), a
family no plane of which cuts A (A narrower than the spacing), or fins that would leave A at
less than :data:`MIN_STAND_OUT_DEG` (they would lie in the surface). Such a device has no
fins and a reason, never a measured 0 %.

Examples
--------
>>> from torsal.geometry.surfaces import canopy
>>> v, f = canopy(nu=9, nv=9)
>>> devices = standard_devices(v, f, 0.3, 1.0, sun=[[0.2, -0.3, 0.9]])
>>> devices["horizontal louvers"].applicable, devices["optimized parallel fins"].applicable
(False, True)
"""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np
import trimesh

from ...geometry.support import per_family
from .facade import grid_normal_fins, horizontal_louvers, vertical_fin_normal, vertical_fins
from .frame import WALL_LIMIT_DEG, SurfaceFrame, surface_frame
from .oriented import FinOrientation, optimize_fin_orientation
from .sections import section_fins, unit_vector

__all__ = ["DeviceKind", "Device", "DEVICE_NAMES", "standard_devices", "baselines",
           "MIN_STAND_OUT_DEG"]

#: fins leaving A at a smaller (length-weighted median) angle are not a device (degrees)
MIN_STAND_OUT_DEG = 30.0


class DeviceKind(str, Enum):
    """The standard devices, in the order of every table and plot."""

    HORIZONTAL_LOUVERS = "horizontal louvers"
    VERTICAL_FINS = "vertical fins"
    EGG_CRATE = "egg-crate"
    OPTIMIZED_FINS = "optimized parallel fins"
    OPTIMIZED_EGG_CRATE = "optimized egg-crate"


#: device names in order (the values of :class:`DeviceKind`)
DEVICE_NAMES = tuple(k.value for k in DeviceKind)


@dataclass(frozen=True)
class Device:
    """One standard device on a surface: its fins, or why it cannot be made.

    Attributes
    ----------
    kind : DeviceKind
    fins : trimesh.Trimesh or None
        Thin-surface fins; None when not applicable.
    reason : str or None
        Why the device is not applicable (None when it is).
    plane_normals : list of (3,) float
        Unit normals of its plane families.
    stand_out_deg : float or None
        Length-weighted median angle at which its fins leave A (the smaller family's).
    orientation : FinOrientation or None
        For the optimized devices: the searched plane orientation.
    """

    kind: DeviceKind
    fins: trimesh.Trimesh | None
    reason: str | None = None
    plane_normals: list = field(default_factory=list)
    stand_out_deg: float | None = None
    orientation: FinOrientation | None = None

    @property
    def name(self) -> str:
        return self.kind.value

    @property
    def applicable(self) -> bool:
        return self.reason is None

    def as_dict(self) -> dict:
        """JSON-ready description (no geometry): ``applicable``, ``reason``,
        ``plane_normals``, ``stand_out_deg`` and, if optimized, ``orientation``."""
        out = {"applicable": self.applicable, "reason": self.reason,
               "plane_normals": [[round(float(x), 6) for x in p] for p in self.plane_normals],
               "stand_out_deg": None if self.stand_out_deg is None else float(self.stand_out_deg)}
        if self.orientation is not None:
            out["orientation"] = self.orientation.as_dict()
        return out


def _family(v, f, p, depth, spacing, what: str) -> tuple[trimesh.Trimesh | None, str | None]:
    """One plane family's fins, or the reason it cannot be made."""
    fins = section_fins(v, f, p, depth, spacing)
    if len(fins.faces) == 0:
        extent = float(np.ptp(v @ p))
        return None, (f"no plane of the {what} cuts A: A spans {extent:.3g} along the planes' "
                      f"normal, no more than the spacing {spacing:g}")
    so = fins.metadata["stand_out_deg"]
    if so < MIN_STAND_OUT_DEG:
        return None, (f"the {what} would leave A at a median {so:.0f} deg (less than "
                      f"{MIN_STAND_OUT_DEG:g}): they would lie almost in the surface")
    return fins, None


def _not_a_facade(frame: SurfaceFrame, what: str) -> str:
    return (f"{what} are a facade device and A is a canopy: {100 * (1 - frame.wall_share):.0f}% "
            f"of its area faces more than {WALL_LIMIT_DEG:g} deg up or down (mean normal "
            f"{frame.normal_elevation_deg:.0f} deg above the horizon); the optimized parallel "
            "fins are the device for it")


def _pair(kind, a: Device, b: Device) -> Device:
    """The egg-crate of two single families: both fins, applicable when both are."""
    reason = a.reason or b.reason
    if reason is not None:
        return Device(kind, None, f"its {'first' if a.reason else 'second'} family: {reason}")
    return Device(kind, trimesh.util.concatenate([a.fins, b.fins]),
                  plane_normals=a.plane_normals + b.plane_normals,
                  stand_out_deg=min(a.stand_out_deg, b.stand_out_deg),
                  orientation=a.orientation or b.orientation)


def _single(kind, v, f, p, depth, spacing, what, orientation=None) -> Device:
    fins, reason = _family(v, f, p, depth, spacing, what)
    return Device(kind, fins, reason, [p], None if fins is None else fins.metadata["stand_out_deg"],
                  orientation)


def standard_devices(surface_vertices, surface_faces, depth, spacing, *,
                     sun=None, weights=None, up=(0.0, 0.0, 1.0), samples: int = 300,
                     seed: int | None = 0) -> dict[str, Device]:
    """Every standard device of ``depth`` and ``spacing`` on A, by name (:data:`DEVICE_NAMES`
    order).

    Parameters
    ----------
    surface_vertices : (n, 3) float
    surface_faces : (F, 3) int
        Design surface A, normals outside (towards the sun).
    depth, spacing : float or (2,) sequence of float
        Model units; one for both families or ``(family 0, family 1)``: the single-family
        devices and an egg-crate's first family take family 0's, an egg-crate's crossing
        family family 1's.
    sun : (k, 3) float, optional
        Sun vectors (site -> sun) the optimized devices are oriented for; without them those
        two are not applicable.
    weights : (k,) float, optional
    up : (3,) float
    samples, seed
        Sample points of the orientation search (see
        :func:`~torsal.light.devices.oriented.optimize_fin_orientation`).

    Returns
    -------
    dict of str -> Device
    """
    v = np.asarray(surface_vertices, float)
    f = np.asarray(surface_faces, np.int64)
    up = unit_vector(up, "up")
    (d0, d1), (s0, s1) = per_family(depth, "depth"), per_family(spacing, "spacing")
    frame = surface_frame(v, f, up=up)
    K = DeviceKind
    out: dict[str, Device] = {}
    if frame.is_facade:
        louvers = _single(K.HORIZONTAL_LOUVERS, v, f, up, d0, s0, "horizontal louvers")
        try:
            along = vertical_fin_normal(v, f, up=up)
            fins = _single(K.VERTICAL_FINS, v, f, along, d0, s0, "vertical fins")
            # the egg-crate's vertical fins: the crossing family's depth and spacing
            crossing = fins if (d1, s1) == (d0, s0) else _single(
                K.VERTICAL_FINS, v, f, along, d1, s1, "vertical fins")
        except ValueError as exc:
            fins = crossing = Device(K.VERTICAL_FINS, None, str(exc))
    else:
        louvers = Device(K.HORIZONTAL_LOUVERS, None, _not_a_facade(frame, "horizontal louvers"))
        fins = Device(K.VERTICAL_FINS, None, _not_a_facade(frame, "vertical fins"))
    out[louvers.name], out[fins.name] = louvers, fins
    out[K.EGG_CRATE.value] = (_pair(K.EGG_CRATE, louvers, crossing) if frame.is_facade else
                              Device(K.EGG_CRATE, None, _not_a_facade(frame, "egg-crates")))
    if sun is None or len(np.asarray(sun).reshape(-1, 3)) == 0:
        why = "no sun directions to orient the fins for"
        out[K.OPTIMIZED_FINS.value] = Device(K.OPTIMIZED_FINS, None, why)
        out[K.OPTIMIZED_EGG_CRATE.value] = Device(K.OPTIMIZED_EGG_CRATE, None, why)
        return out
    best = optimize_fin_orientation(v, f, sun, d0, s0, weights=weights, samples=samples,
                                    seed=seed, up=up)
    p = best.plane_normal
    one = _single(K.OPTIMIZED_FINS, v, f, p, d0, s0, "optimized fins", best)
    # the crossing family: square to the optimized planes and standing on A's mean plane
    q = np.cross(p, frame.normal)
    if np.linalg.norm(q) < 1e-9:                  # cannot happen within the search's tilt
        q = frame.u
    q = q / np.linalg.norm(q)
    other = _single(K.OPTIMIZED_EGG_CRATE, v, f, q, d1, s1, "crossing fins")
    out[one.name] = one
    out[K.OPTIMIZED_EGG_CRATE.value] = _pair(K.OPTIMIZED_EGG_CRATE, one, other)
    return out


def baselines(surface_vertices, surface_faces, depth: float, spacing: float, *,
              grid_shape: tuple[int, int] | None = None, every: int | None = None,
              up=(0.0, 0.0, 1.0)) -> dict[str, trimesh.Trimesh]:
    """The conventional facade shades of equal depth and spacing, by name, ready for
    :func:`torsal.light.shading.compare`: horizontal louvers, vertical fins, the egg-crate
    of both, and (given ``grid_shape``) the unoptimized normal-congruence fins with lines
    ``every`` grid steps apart (default: the step closest to ``spacing``). For any surface
    and the optimized devices see :func:`standard_devices`."""
    out = {
        "horizontal louvers": horizontal_louvers(surface_vertices, surface_faces, depth, spacing, up=up),
        "vertical fins": vertical_fins(surface_vertices, surface_faces, depth, spacing, up=up),
    }
    # the egg-crate of both (what :func:`egg_crate` builds), without cutting A twice
    out["egg-crate"] = trimesh.util.concatenate([out["horizontal louvers"], out["vertical fins"]])
    if grid_shape is not None:
        if every is None:
            v = np.asarray(surface_vertices, float).reshape(*grid_shape, 3)
            step = np.mean([np.linalg.norm(np.diff(v, axis=0), axis=2).mean(),
                            np.linalg.norm(np.diff(v, axis=1), axis=2).mean()])
            every = max(1, int(round(spacing / step)))
        out["normal congruence (unoptimized)"] = grid_normal_fins(
            surface_vertices, surface_faces, grid_shape, depth, every=every)
    return out
