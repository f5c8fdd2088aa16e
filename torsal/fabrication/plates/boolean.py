"""The boolean route of the slot cut: OpenCascade's cut of the plate and its slot boxes, then face
unification (:func:`_cut`), tried exactly and then fuzzily (:data:`SLOT_CUT_FUZZY`), the piece
to keep where it splits the plate, and the checks of :mod:`.slots`. The route of every part the
direct cut (:mod:`.direct`) declines."""
from __future__ import annotations

import numpy as np

from ..model import Part
from .errors import InvalidSolidError, SlotCutError
from .occ import _downcast, _solids_of, _valid, _volume
from .slots import _check_cut, _slot_area, slot_boxes


#: fraction of the plate thickness: OpenCascade's fuzzy tolerance for the second try of a slot
#: cut whose exact boolean failed (see :func:`_slotted`)
SLOT_CUT_FUZZY = 0.005


def _slotted(plate, part: Part, thickness: float, plate_volume: float, repair: bool):
    """The plate (OCC solid of ``plate_volume``) with the part's slots cut, checked: valid,
    a plausible volume, about slot area x thickness removed, every slot open and the web
    beyond it kept. SlotCutError (``plate`` not set) otherwise.

    The cut is tried exactly first, then with OpenCascade's fuzzy tolerance of
    :data:`SLOT_CUT_FUZZY` x thickness: on thin plates met obliquely the exact boolean can
    return an empty shape (example 7c's F1-S014-P00, 3 mm, volume 0) where the fuzzy one
    cuts the slot (0.015 mm, far below any cutting process's kerf)."""
    nodes = sorted({s.node for s in part.slots})
    for fuzzy in (0.0, SLOT_CUT_FUZZY * thickness):
        try:
            return _slotted_once(plate, part, thickness, plate_volume, repair, fuzzy)
        except InvalidSolidError as e:
            failure = SlotCutError([part.name], str(e), nodes=nodes)
        except Exception as e:     # OpenCascade failures
            failure = SlotCutError([part.name], f"cutting the slots at nodes {nodes} failed: "
                                   f"{type(e).__name__}: {e}", nodes=nodes)
    raise failure


def _slotted_once(plate, part: Part, thickness: float, plate_volume: float, repair: bool,
                  fuzzy: float):
    """One try of :func:`_slotted` with the boolean's ``fuzzy`` tolerance (``unit``); raises
    on a failed or implausible cut."""
    solid = _cut(plate, slot_boxes(part, thickness), fuzzy=fuzzy)
    pieces = _solids_of(solid)
    if not pieces:
        raise ValueError("the boolean cut returned nothing")
    solid = pieces[0] if len(pieces) == 1 else _main_piece(part, thickness, plate_volume, pieces)
    solid = _valid(solid, repair)
    if solid is None:
        raise ValueError("BRepCheck failed after ShapeFix")
    _check_cut(solid, _volume(solid), part, thickness, plate_volume)
    return solid


def _cut(shape, tools: list, *, fuzzy: float = 0.0):
    """``shape`` minus the ``tools`` (OCC boolean cut, then coplanar faces merged), as
    build123d's ``Shape.cut`` does it; ``fuzzy``: OpenCascade's fuzzy tolerance (``unit``,
    0: exact)."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
    from OCP.ShapeUpgrade import ShapeUpgrade_UnifySameDomain
    from OCP.collections import List_TopoDS_Shape

    args, tls = List_TopoDS_Shape(), List_TopoDS_Shape()
    args.Append(shape)
    for t in tools:
        tls.Append(t)
    op = BRepAlgoAPI_Cut()
    op.SetArguments(args)
    op.SetTools(tls)
    # one thread: the solids are built one process per core already (OCC's threads cost
    # 10 % more CPU on 7a's parts for the same shapes)
    op.SetRunParallel(False)
    op.SetUseOBB(True)          # oriented boxes: fewer face pairs intersected, same result
    op.SetToFillHistory(False)  # which face came from which is never asked
    if fuzzy > 0:
        op.SetFuzzyValue(fuzzy)
    op.Build()
    if not op.IsDone():
        raise ValueError("the boolean cut failed")
    result = _downcast(op.Shape())
    unify = ShapeUpgrade_UnifySameDomain(result, True, True, True)
    unify.AllowInternalEdges(False)
    try:
        unify.Build()
        result = _downcast(unify.Shape())
    except Exception:        # merging faces is cosmetic: keep the uncleaned result
        pass
    return result


def _main_piece(part: Part, thickness: float, plate_volume: float, pieces: list):
    """The plate left after cutting the slots when OpenCascade's boolean returned several
    pieces (OCC solids): on thin, oblique plates it sometimes splits the cut-out off instead of
    removing it, or leaves slivers. The unrolled outline says what must be left (``plate - slot
    area x thickness``); the piece of that volume is kept, else the part is reported."""
    nodes = sorted({s.node for s in part.slots})
    try:
        removed = _slot_area(part) * thickness
    except ValueError as e:
        raise InvalidSolidError([part.name], f"the slots at nodes {nodes} cut the plate apart ({e})")
    expected = plate_volume - removed
    volumes = [_volume(x) for x in pieces]
    best = int(np.argmin([abs(v - expected) for v in volumes]))
    if not abs(volumes[best] - expected) <= 0.05 * removed + 1e-6 * plate_volume:
        raise InvalidSolidError([part.name], f"the slots at nodes {nodes} split the plate into "
                                f"{len(pieces)} pieces (volumes {sorted(round(v, 1) for v in volumes)}, "
                                f"expected one of {expected:.6g})")
    return pieces[best]
