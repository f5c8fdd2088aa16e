"""Independent interference check for the fabrication tests: OpenCascade boolean common of
every pair of solids whose bounding boxes meet (shares no code with the joint builder).

Imported by name (pytest puts this folder on sys.path).
"""
from __future__ import annotations

import itertools


def common_volume(a, b) -> float:
    """Volume (unit^3) of the boolean common of two OCC shapes (TopoDS or build123d)."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Common
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    a = getattr(a, "wrapped", a)
    b = getattr(b, "wrapped", b)
    from OCP.collections import List_TopoDS_Shape as TopTools_ListOfShape

    # non-destructive: OpenCascade's default widens the arguments' vertex tolerances, and
    # later booleans on the same solids then disagree (the 7d egg-crate pair, see
    # torsal.fabrication.assembly.common_volume)
    op = BRepAlgoAPI_Common()
    la, lb = TopTools_ListOfShape(), TopTools_ListOfShape()
    la.Append(a)
    lb.Append(b)
    op.SetArguments(la)
    op.SetTools(lb)
    op.SetNonDestructive(True)
    op.Build()
    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(op.Shape(), props)
    return abs(props.Mass())


def interfering_pairs(solids: dict, limit: float = 1.0) -> list[tuple[str, str, float]]:
    """``[(name, name, common volume)]`` for every pair of ``{name: shape}`` whose common
    volume exceeds ``limit`` (1 mm^3: interference)."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib

    boxes = {}
    for n, s in solids.items():
        box = Bnd_Box()
        BRepBndLib.Add_s(getattr(s, "wrapped", s), box)
        boxes[n] = box
    out = []
    for m, n in itertools.combinations(solids, 2):
        if boxes[m].IsOut(boxes[n]):
            continue
        v = common_volume(solids[m], solids[n])
        if v > limit:
            out.append((m, n, v))
    return out
