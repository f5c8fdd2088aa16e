"""A part's solid (:func:`part_solid`): the plate built and checked, its slots cut directly where
that is sure, else by the boolean, the plate kept without them where neither can
(:class:`~.errors.SlotCutError`); :func:`_build_one` is what a worker process runs per part."""
from __future__ import annotations

import numpy as np

from ..model import Part
from .boolean import _slotted
from .direct import _slotted_direct
from .errors import InvalidSolidError, SlotCutError
from .occ import _valid, _volume
from .plate import _plate


def _labelled(shape, part: Part):
    """build123d ``Solid`` of an OCC solid, labelled with the part id and coloured by family."""
    from build123d import Color, Solid

    solid = Solid(shape)
    solid.label = part.name
    solid.color = Color(*part.color)
    return solid


def part_solid(part: Part, thickness: float, *, repair: bool = True, planar_tol: float = 1e-9):
    """The thickened, slotted solid of one part (build123d ``Solid``), labelled and coloured.

    Raises
    ------
    InvalidSolidError
        If the solid is invalid and cannot be repaired.
    SlotCutError
        If the plate is sound but its slots could not be cut (``plate``: the labelled plate).
    """
    try:
        shape = _part_shape(part, thickness, repair=repair, planar_tol=planar_tol)
    except SlotCutError as e:
        e.plate = _labelled(e.plate, part)
        raise
    return _labelled(shape, part)


def _part_shape(part: Part, thickness: float, *, repair: bool = True, planar_tol: float = 1e-9):
    """:func:`part_solid` as a bare OCC shape (what worker processes send back); a
    :class:`SlotCutError` carries the plate as an OCC shape too."""
    from OCP.TopoDS import TopoDS

    q, m = part.panels, part.miters
    if not (np.isfinite(q).all() and np.isfinite(m).all()):
        raise InvalidSolidError([part.name], "non-finite panel or mitre coordinates")
    if part.slots:
        direct = _slotted_direct(part, thickness, planar_tol)
        if direct is not None:
            return direct
    solid, poly_volume = _plate(part, thickness, planar_tol)
    volume = _volume(solid)
    if volume < 0:                   # sewn inside out: turn it round
        solid = TopoDS.Solid(solid.Reversed())
        volume = -volume
    # a closed, valid shell can still be garbage (e.g. a bow-tie panel): the solid must have the
    # volume of the polyhedron it was built from, and that the volume sum(panel area) *
    # thickness up to the twist of its side faces (which grows on narrow panels that meet the
    # node lines obliquely, mitred: a few percent at most)
    expected = float(part.panel_areas.sum()) * thickness
    if not abs(volume - abs(poly_volume)) <= 1e-3 * abs(poly_volume):
        raise InvalidSolidError([part.name], f"plate volume {volume:.6g} differs from that of "
                                f"its faces {abs(poly_volume):.6g}: the faces do not sew into a sound solid")
    if not abs(volume - expected) <= 0.05 * expected:
        raise InvalidSolidError([part.name], f"plate volume {volume:.6g} differs from panel "
                                f"area x thickness {expected:.6g}: broken or self-intersecting panels")
    if not part.slots:
        plate = _valid(solid, repair)
        if plate is None:
            raise InvalidSolidError([part.name], "BRepCheck failed after ShapeFix")
        return plate
    # the slots are cut into the plate as built and the result is checked (BRepCheck, volume,
    # probes); the plate itself is checked only when that fails: a sound cut of a broken
    # plate does not pass those checks, and checking both cost 15 % of a slotted part
    try:
        return _slotted(solid, part, thickness, volume, repair)
    except SlotCutError as e:
        failure = e
    plate = _valid(solid, repair)
    if plate is None:
        raise InvalidSolidError([part.name], "BRepCheck failed after ShapeFix")
    if plate is not solid:           # repaired: cut the repaired plate (as it always was)
        try:
            return _slotted(plate, part, thickness, volume, repair)
        except SlotCutError as e:
            failure = e
    failure.plate = plate
    raise failure


def _build_one(part: Part, thickness: float, repair: bool):
    """``(status, OCC shape or None, detail)`` for one part; status ``ok``, ``unslotted`` (the
    valid plate without slots) or ``bad``."""
    try:
        return "ok", _part_shape(part, thickness, repair=repair), ""
    except SlotCutError as e:
        return "unslotted", e.plate, (e.nodes, str(e))
    except InvalidSolidError as e:       # the detail only: the caller names the parts and advises
        return "bad", None, f"{part.name}: {e.detail}" if e.detail else part.name
    except Exception as e:  # OpenCascade errors: report by part id
        return "bad", None, f"{part.name}: {type(e).__name__}: {e}"
