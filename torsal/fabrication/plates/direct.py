"""The slotted solid of a part built without a boolean (:func:`_slotted_direct`): the plate's faces
less the slot boxes in the faces' planes, one B-rep, checked as the boolean's result is; None
where that does not apply."""
from __future__ import annotations

from ..model import Part
from .brep import _polyhedron_solid
from .occ import _is_valid, _volume
from .plate import _plate_polyhedron
from .polygon_cut import _cut_polyhedron
from .slots import _check_cut, _slot_box_frames


def _slotted_direct(part: Part, thickness: float, planar_tol: float):
    """The slotted solid of a part built without a boolean, or None where that does not apply
    (:func:`_part_shape` then builds the plate and cuts it with OpenCascade, as before). The
    plate's faces (:func:`_plate_polyhedron`) less the slots' boxes (:func:`_slot_box_frames`)
    are computed in the faces' planes (:func:`_cut_polyhedron`) and built as one B-rep
    (:func:`_polyhedron_solid`): the solid of OpenCascade's cut and face unification (the same
    volume to 1e-10 and the same faces, edges and vertices on example 7a's 135 slotted parts
    and on the test structures') in less than half its time. It is checked as the boolean's result
    is: the plate's volume panel area x thickness to 5 %, BRepCheck, a plausible volume and
    slot area taken out, every slot open and the web beyond it kept (:func:`_check_cut`, the
    probes on the polyhedron the solid is built from), and besides the solid's volume that of
    its faces to 1e-9. Any failure returns None: the boolean route decides, and reports."""
    try:
        points, loops, normals, centres, plate_volume = _plate_polyhedron(part, thickness, planar_tol)
    except ValueError:
        return None
    if plate_volume < 0:             # outlines turned inwards: turn every face round
        loops = [x[::-1] for x in loops]
        normals, plate_volume = -normals, -plate_volume
    expected = float(part.panel_areas.sum()) * thickness
    if not abs(plate_volume - expected) <= 0.05 * expected:
        return None
    try:
        pts, loops, normals, centres, volume = _cut_polyhedron(
            points, loops, normals, centres, _slot_box_frames(part, thickness))
        solid = _polyhedron_solid(pts, loops, normals, centres)
        if not _is_valid(solid):
            return None
        occ = _volume(solid)
        if not abs(occ - volume) <= 1e-9 * abs(volume):
            return None
        _check_cut(solid, occ, part, thickness, plate_volume, polyhedron=(pts, loops))
    except Exception:       # _Decline, a failed check, shapely's or OpenCascade's errors
        return None
    return solid
