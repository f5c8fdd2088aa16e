"""The slots of a part: the boxes that cut them (:func:`slot_boxes`, their frames), the area they
take out, and the checks of a slotted solid: a plausible volume, about slot area x thickness
removed, every slot open and the web beyond it kept (probed with OpenCascade's classifier on
the solid, or by winding numbers on the polyhedron it was built from)."""
from __future__ import annotations

import numpy as np

from ..model import Part, SlotSide, _cross, panel_widths
from ..unroll import unroll
from .faces import _fan_corners
from .occ import _box


#: degrees: a slot on a fold flatter than this is cut with one box on the fold's bisector plane
#: (two nearly coplanar boxes make OpenCascade's boolean leave slivers or split the plate)
SINGLE_BOX_FOLD = 20.0


def slot_boxes(part: Part, thickness: float) -> list:
    """Cutting boxes of the slots of a part: per panel adjacent to the slotted node line, a box
    in the panel plane centred on the node line, ``width`` wide, from ``2 width`` outside the
    open edge to ``depth`` inside, ``2 thickness`` through the plate. On a fold flatter than
    :data:`SINGLE_BOX_FOLD` one box on the bisector plane, ``width cos(fold/2)`` wide (so the
    slot is ``width`` wide in both panels)."""
    return [_box(*frame) for frame in _slot_box_frames(part, thickness)]


def _slot_box_frames(part: Part, thickness: float) -> list:
    """The boxes of :func:`slot_boxes` as ``(origin, x_dir, z_dir, length, width, height)``
    (the arguments of :func:`_box`)."""
    boxes = []
    k = len(part.panels)
    normals = part.normals
    for s in part.slots:
        pos = s.position
        if pos == 0:
            a, b = part.panels[0, 0], part.panels[0, 3]
        else:
            a, b = part.panels[pos - 1, 1], part.panels[pos - 1, 2]
        start, other = (b, a) if SlotSide(s.side) == SlotSide.B else (a, b)
        u = other - start
        u = u / np.linalg.norm(u)
        # beyond the open edge by 2 widths and the node line's length: an edge slanted
        # along the line leaves no web across the slot's mouth
        over = 2.0 * s.width + float(np.linalg.norm(b - a))
        if 0 < pos < k:
            n1, n2 = normals[pos - 1], normals[pos]
            c = float(np.clip(n1 @ n2, -1.0, 1.0))
            if np.degrees(np.arccos(c)) < SINGLE_BOX_FOLD:
                n = (n1 + n2) / np.linalg.norm(n1 + n2)
                uu = u - (u @ n) * n
                uu /= np.linalg.norm(uu)
                v = np.cross(n, uu)
                w = s.width * np.sqrt(0.5 * (1.0 + c))          # width * cos(fold / 2)
                corner = start - over * uu - 0.5 * w * v - thickness * n
                boxes.append((corner, uu, n, over + s.depth, w, 2.0 * thickness))
                continue
        for j in (pos - 1, pos):
            if not 0 <= j < k:
                continue
            n = normals[j]
            v = np.cross(n, u)
            corner = start - over * u - 0.5 * s.width * v - thickness * n
            boxes.append((corner, u, n, over + s.depth, s.width, 2.0 * thickness))
    return boxes


def _check_cut(solid, volume: float, part: Part, thickness: float, plate_volume: float,
               polyhedron=None) -> None:
    """Raise ValueError unless the slotted solid (OCC, of ``volume``) of a plate of
    ``plate_volume`` is plausible: less than the plate and more than half of it, about slot
    area x thickness taken out, every slot open and the web beyond it kept
    (:func:`_check_slots`; on the ``(points, loops)`` of the ``polyhedron`` the solid was
    built from, where given: :func:`_check_slots_polyhedron`)."""
    if not 0.5 * plate_volume < volume <= plate_volume * (1 + 1e-9):
        raise ValueError(f"volume {volume:.6g} after cutting slots is implausible for a "
                         f"plate of {plate_volume:.6g}")
    # every slot is open where it should be and the web beyond it is kept (on folds the
    # boxes in both panel planes take a little more than slot area x thickness)
    removed = _slot_record_area(part) * thickness
    if not 0.3 * removed <= plate_volume - volume <= 3.0 * removed + 1e-6 * plate_volume:
        raise ValueError(f"the slots removed {plate_volume - volume:.6g} instead of about "
                         f"{removed:.6g} (slot area x thickness)")
    if polyhedron is None:
        _check_slots(solid, part)
    else:
        _check_slots_polyhedron(*polyhedron, part)


def _check_slots(solid, part: Part) -> None:
    """Raise ValueError unless, for every slot, a point in the slot (on the mid-plane, halfway
    down) is outside the OCC solid and a point of the web beyond it is inside
    (:func:`_slot_probes`)."""
    from OCP.BRepClass3d import BRepClass3d_SolidClassifier
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_IN, TopAbs_OUT

    cls = BRepClass3d_SolidClassifier(solid)      # one classifier for every probe of the solid
    for x, inside, message in _slot_probes(part):
        cls.Perform(gp_Pnt(*map(float, x)), 1e-6)
        if cls.State() != (TopAbs_IN if inside else TopAbs_OUT):
            raise ValueError(message)


def _check_slots_polyhedron(points: np.ndarray, loops: list, part: Part) -> None:
    """:func:`_check_slots` on a closed polyhedron (``points``, ``loops`` oriented outwards)
    instead of its OCC solid: each probe's winding number (the solid angles of the faces' fan
    triangles seen from it, over 4 pi) is 1 inside and 0 outside. The direct slot cut builds
    its solid from this polyhedron face for face and checks their volumes equal, so this is
    the classifier's answer for a tenth of its time."""
    probes = _slot_probes(part)
    first, mid, last = _fan_corners(loops)
    x = np.array([p for p, _, _ in probes])
    a, b, c = (points[i][None] - x[:, None] for i in (first, mid, last))             # (P, T, 3)
    la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, c))
    num = np.einsum("pti,pti->pt", a, _cross(b, c))
    den = (la * lb * lc + np.einsum("pti,pti->pt", a, b) * lc + np.einsum("pti,pti->pt", a, c) * lb
           + np.einsum("pti,pti->pt", b, c) * la)
    winding = 2.0 * np.arctan2(num, den).sum(axis=1) / (4.0 * np.pi)
    for w, (_, inside, message) in zip(winding, probes):
        if not abs(w - (1.0 if inside else 0.0)) < 1e-6:
            raise ValueError(message)


def _slot_probes(part: Part) -> list:
    """``(point, inside, message)`` per probe of the part's slots: a point in each slot (on the
    node line halfway down, a little into the wider panel) that must be outside the solid, and
    one in the web beyond it that must be inside; the message says what failed."""
    q = part.panels
    k = len(q)
    widths = panel_widths(q)
    out = []
    for s in part.slots:
        pos = s.position
        a, b = (q[0, 0], q[0, 3]) if pos == 0 else (q[pos - 1, 1], q[pos - 1, 2])
        start, other = (b, a) if SlotSide(s.side) == SlotSide.B else (a, b)
        u = other - start
        length = np.linalg.norm(u)
        u = u / length
        # probed in the wider panel next to the node line, no farther into it than a quarter
        # of its width: a slot wider than a narrow end panel takes all of that panel down to
        # its depth, and a probe a quarter of the slot into it fell outside the plate (example
        # 9, F0-S001-P00 at node 335: a 23 mm slot by a 5.6 mm panel, "cut through the web")
        j = max((i for i in (pos - 1, pos) if 0 <= i < k), key=lambda i: widths[i])
        into = q[j].mean(axis=0) - start
        into -= (into @ u) * u
        into /= np.linalg.norm(into)
        off = min(0.25 * s.width, 0.25 * float(widths[j])) * into
        out.append((start + 0.5 * s.depth * u + off, False, f"the slot at node {s.node} is not cut"))
        # the web ends where a slot from the other edge on the same node line begins (a plate
        # holding a seam whose parts slide in from opposite edges, :mod:`.builder.crossings`)
        end = length - max([o.depth for o in part.slots if o.position == pos
                            and SlotSide(o.side) != SlotSide(s.side)], default=0.0)
        if s.depth < 0.99 * end:          # a web is left (not a full-depth end slot)
            out.append((start + (s.depth + 0.5 * (end - s.depth)) * u + off, True,
                        f"the slot at node {s.node} cut through the web"))
    return out


def _slot_record_area(part: Part) -> float:
    """Area the slots take out of the part from their records (``unit``^2): ``width x depth``
    each, half of it at a part end (the slot is centred on the end edge). Equal to the
    unrolled outline's (:func:`_slot_area`) to 1e-4 on example 7a's 152 slotted parts, without
    unrolling the part (a tenth of a worker's time)."""
    k = len(part.panels)
    return float(sum(s.width * s.depth * (1.0 if 0 < s.position < k else 0.5) for s in part.slots))


def _slot_area(part: Part) -> float:
    """Area the slots take out of the unrolled part (``unit``^2)."""
    from shapely.geometry import Polygon

    u = unroll(part)
    return float(sum(Polygon(f).area for f in u.panels) - u.outline.area)
