"""Independent interference check for the fabrication tests: OpenCascade boolean common of
every pair of solids whose bounding boxes meet (shares no code with the joint builder).

Imported by name (pytest puts this folder on sys.path).
"""
from __future__ import annotations

import itertools


def common_volume(a, b) -> float:
    """Volume (unit^3) of the boolean common of two OCC shapes (TopoDS or build123d): one
    exact, non-destructive boolean (the assembly check's, which shares no code with the
    joint builder either; without its confirmation of overlaps, so a test sees the raw
    boolean)."""
    from torsal.fabrication.assembly import _boolean_common, _volume

    op = _boolean_common(getattr(a, "wrapped", a), getattr(b, "wrapped", b), 0.0)
    return _volume(op.Shape())


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
