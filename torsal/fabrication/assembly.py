"""Assembly verification: do the solids of a fin system interfere, and in which order can they
be put together? (issue 15)

The check reads only the finished solids (``FinSystem.solids()`` or the solids of ``fins.step``
re-read with :func:`~torsal.fabrication.solids.read_step`) and the joint records (part names and
insertion axes); it shares no code with the joint builder, so a mistake there shows up here.

1. **Touching pairs.** Axis-aligned bounding boxes grown by ``tolerance`` select candidate
   pairs; a proximity test on the solids' triangulations (``BRepExtrema_ShapeProximity``, a
   BVH of triangles; the triangulation of a planar face is exact) keeps the pairs whose
   boundaries come within ``tolerance``, and a point classification those where one solid
   lies inside the other: these are ``pairs_checked`` (:func:`solid_distance` gives the exact
   distance of a pair, ten times slower).
2. **Interference.** For every touching pair the common volume is computed with an exact
   OpenCascade boolean (``BRepAlgoAPI_Common``); a common volume above ``min_volume``
   (1 mm^3) is an interference. The booleans leave the solids unchanged (non-destructive:
   OpenCascade's default may change their tolerances, and then erred, and later booleans
   depended on what ran before in the process), and a common above 1 mm^3 is measured again
   in the other order and with a fuzzy tolerance, the median of the three counting
   (:func:`common_volume`; the swept paths of 3. alike). A
   boolean that fails is listed in ``failed_pairs`` and the
   design is not called buildable (nothing is assumed). Most touching plates only touch: a
   cheap exact test proves them apart first and skips the boolean (:func:`solid_clear`): one
   solid is covered by convex prisms (its exit faces swept back over its extent along its
   thinnest face normal, :func:`solid_cover`; a flat plate: its panels), and a prism is
   apart from the other solid when no triangle of the other's boundary reaches into it
   (separating axes, :func:`hull_clear_of_triangles`) and it is not wholly inside it (ray
   parity). Triangles may touch a prism or reach ``CLEAR_TOLERANCE`` (1e-7, OpenCascade's
   own confusion tolerance) into it; an undecided pair gets the boolean.
3. **Assembly order.** Parts are placed one by one in an order that follows the joints (the
   parts a joint lists first are placed first: for an egg-crate crossing the family-0
   plate(s), then the family-1 plate(s); for a butt joint the parts of the plate butted
   against, in any order among themselves, then the butted part; the two parts of a mitre in
   either order; connectors go on after the plates around them). Each part is inserted along a
   straight line: the axis of its joints with parts already placed (the joint's
   ``insert_direction``: for egg-crate pairs along the node axis ``L_i``, or the slide
   direction the builder cut the slots for; the mean axis of its slots first, then the mean of all its joints' axes,
   then each axis on its own, then the lines where two plates it butts against meet; both
   senses). The path starts one depth of the part back (``travel``: the part's extent
   along the direction, but no more than the largest ``depth`` of the joints it makes with
   parts placed before, the fin depth at their nodes, over which the parts engage: a slot is
   never longer; so it is disengaged from its slots) and ends in place; every placed part near the path is checked, joined or not. A
   path is clear when the volume swept by the part meets no placed part by more than
   ``min_volume``: the swept volume is the union of the prisms that every face of the solid
   sweeps (``BRepPrimAPI_MakePrism``), each intersected exactly with the placed parts near the
   path; the sum of those common volumes (an upper bound of the swept overlap) is the
   collision volume (a prism that :func:`prism_clear` proves apart from a part adds 0
   without the boolean). A part with no clear path is *blocked*.

A design is ``buildable`` when no pair interferes, no boolean failed and no part is blocked.

Pairs and paths are independent of one another; with ``workers > 1`` they are computed in
forked processes (each inherits the solids, nothing is pickled).

Units: those of the solids (``unit`` of the fin system, mm by default): volumes in unit^3.

Example
-------
>>> from torsal.fabrication import FinSystem, verify_assembly
>>> fs = FinSystem(structure, thickness=3.0, clearance=0.5)              # doctest: +SKIP
>>> check = verify_assembly(fs)                                          # doctest: +SKIP
>>> check.buildable, check.pairs_checked, check.worst_overlap_mm3        # doctest: +SKIP
(True, 12, 0.0)
>>> check.write_csv("out/assembly.csv")                                  # doctest: +SKIP
"""
from __future__ import annotations

import csv
import itertools
import multiprocessing
import os
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Mapping, NamedTuple, Sequence

import numpy as np

from torsal.core.atomic import atomic_path
from torsal.core.parallel import usable_workers

# the fin model's vector helper (np.cross bit for bit, cheaper on small arrays): a data-model
# kernel, not the joint builder's code, so the check stays independent of the builder
from .model import _cross

__all__ = ["Interference", "AssemblyStep", "AssemblyCheck", "AssemblyJoint", "check_assembly",
           "verify_assembly", "joints_of", "face_polygons", "common_volume", "solid_distance",
           "swept_overlap", "joint_groups", "MIN_INTERFERENCE_VOLUME", "CLEAR_TOLERANCE",
           "hull_clear_of_triangles", "prism_clear", "prisms_clear", "solid_cover", "solid_clear"]

#: unit^3 (mm^3): a common volume above this is an interference (below it: round-off of the
#: booleans on plates that touch)
MIN_INTERFERENCE_VOLUME = 1.0


class AssemblyJoint(NamedTuple):
    """What the check needs of a joint (``torsal.fabrication`` ``Joint`` records have these
    fields too): ``kind`` (e.g. ``"egg-crate"``), structure ``node``, the ``parts`` it joins
    (names; earlier names are placed first), ``insert_direction`` ((3,) unit vector, model
    coordinates, the sense the later parts move in; the other sense is tried too) and the
    ``connector`` part, if any."""

    kind: str
    node: int
    parts: tuple
    insert_direction: np.ndarray
    connector: str | None = None
    #: (3,) direction the connector is put on along (None: ``insert_direction``)
    connector_direction: np.ndarray | None = None
    #: length (unit) over which the joint's parts engage along its axis, e.g. the fin depth at
    #: the node (a slot is never longer); None: unknown (the part's own extent is used)
    depth: float | None = None


@dataclass(frozen=True)
class Interference:
    """Two parts whose solids overlap by ``volume`` (unit^3)."""

    parts: tuple[str, str]
    volume: float


@dataclass(frozen=True)
class AssemblyStep:
    """One step of the assembly order.

    ``insert_direction`` is the unit direction the part moves in (None: it has no joint to a
    part placed before it and is set down in place); ``travel`` the length of its path
    (unit); ``partners`` the parts placed before it that it joins; ``collisions`` what the
    swept part meets on the best path tried (empty: the path is clear; volumes of a blocked
    path are lower bounds: the sum stops once it exceeds ``min_volume``).
    """

    step: int
    part: str
    insert_direction: tuple | None
    travel: float
    partners: tuple[str, ...]
    joint_kinds: tuple[str, ...]
    collisions: tuple[Interference, ...] = ()

    @property
    def clear(self) -> bool:
        return not self.collisions


@dataclass
class AssemblyCheck:
    """Result of :func:`check_assembly`.

    ``interfering`` lists the pairs whose common volume exceeds ``min_volume``, worst first;
    ``order`` the assembly steps; ``failed_pairs`` the pairs whose boolean failed
    ``(part, part, reason)``; ``joints`` the number of joints by kind and ``connectors`` the
    number of connector parts by the kind of joint they fasten.
    """

    parts: list[str]
    pairs_checked: int
    interfering: list[Interference]
    order: list[AssemblyStep]
    failed_pairs: list[tuple[str, str, str]] = field(default_factory=list)
    joints: dict = field(default_factory=dict)
    connectors: dict = field(default_factory=dict)
    min_volume: float = MIN_INTERFERENCE_VOLUME
    unit: str = "mm"
    seconds: float = 0.0

    @property
    def interfering_pairs(self) -> int:
        return len(self.interfering)

    @property
    def worst_overlap_mm3(self) -> float:
        """Largest common volume of two parts (unit^3; 0 when none interfere)."""
        return max((x.volume for x in self.interfering), default=0.0)

    @property
    def interfering_parts(self) -> list[str]:
        return sorted({n for x in self.interfering for n in x.parts})

    @property
    def blocked(self) -> list[AssemblyStep]:
        """Steps whose part cannot be inserted along any direction tried without collision."""
        return [s for s in self.order if not s.clear]

    @property
    def buildable(self) -> bool:
        return not self.interfering and not self.failed_pairs and not self.blocked

    def problems(self, limit: int = 8) -> str:
        """One sentence naming what makes the design unbuildable ('' when it is buildable)."""
        out = []
        if self.interfering:
            out.append(f"{len(self.interfering)} pairs of parts interfere (worst "
                       f"{self.worst_overlap_mm3:.4g} {self.unit}^3): " + ", ".join(
                           f"{a} / {b} ({v:.3g})" for (a, b), v in
                           ((x.parts, x.volume) for x in self.interfering[:limit]))
                       + (" ..." if len(self.interfering) > limit else ""))
        if self.failed_pairs:
            out.append(f"{len(self.failed_pairs)} pairs could not be checked: " + ", ".join(
                f"{a} / {b}" for a, b, _ in self.failed_pairs[:limit]))
        if self.blocked:
            out.append(f"{len(self.blocked)} parts cannot be inserted without collision: " + ", ".join(
                f"{s.part} (hits {', '.join(c.parts[1] for c in s.collisions[:3])})"
                for s in self.blocked[:limit]) + (" ..." if len(self.blocked) > limit else ""))
        return "; ".join(out)

    def report(self) -> dict:
        """The ``fabrication.assembly`` section of report.json."""
        return {
            "pairs_checked": int(self.pairs_checked),
            "interfering_pairs": int(self.interfering_pairs),
            "worst_overlap_mm3": float(self.worst_overlap_mm3),
            "buildable": bool(self.buildable),
            "joints": {str(k): int(v) for k, v in self.joints.items()},
            "connectors": {str(k): int(v) for k, v in self.connectors.items()},
            "parts": len(self.parts),
            "interfering": [{"parts": list(x.parts), "volume_mm3": float(x.volume)}
                            for x in self.interfering],
            "interfering_parts": self.interfering_parts,
            "failed_pairs": [list(x) for x in self.failed_pairs],
            "blocked_parts": [s.part for s in self.blocked],
            "steps": len(self.order),
            "sequence": [{"step": st.step, "part": st.part,
                          "insert_direction": None if st.insert_direction is None
                          else [round(float(x), 6) for x in st.insert_direction],
                          "partners": list(st.partners), "joints": list(st.joint_kinds),
                          "clear": st.clear} for st in self.order],
            "min_volume_mm3": float(self.min_volume),
            "seconds": float(self.seconds),
        }

    def write_csv(self, path) -> Path:
        """``assembly.csv``: one row per step (step, part, insert direction, travel, joint kinds,
        partners placed before, clear, collision volume and parts hit)."""
        path = Path(path)
        with atomic_path(path) as tmp:
            with open(tmp, "w", newline="") as fh:
                w = csv.writer(fh)
                w.writerow(["step", "part", "insert_dx", "insert_dy", "insert_dz",
                            f"travel_{self.unit}", "joint_kinds", "joint_partners", "clear",
                            f"collision_{self.unit}3", "collides_with"])
                for s in self.order:
                    d = s.insert_direction
                    w.writerow([s.step, s.part, *(("", "", "") if d is None else
                                                   (f"{x:.6f}" for x in d)),
                                f"{s.travel:.3f}", " ".join(s.joint_kinds), " ".join(s.partners),
                                "yes" if s.clear else "no",
                                f"{sum(c.volume for c in s.collisions):.3f}",
                                " ".join(c.parts[1] for c in s.collisions)])
        return path


# ---------------------------------------------------------------------------- OCC kernels
def _shape(x):
    """TopoDS_Shape of a build123d shape or an OCP shape."""
    return getattr(x, "wrapped", x)


def _mesh(shapes, tolerance: float) -> None:
    """Triangulate the shapes (in place, once, before any fork) for the proximity prefilter."""
    from OCP.BRepMesh import BRepMesh_IncrementalMesh

    for s in shapes:
        # serial: worker threads left behind would deadlock the forked processes
        BRepMesh_IncrementalMesh(s, 0.1 * tolerance, False, 0.5, False)


def _signed_volume(shape) -> float:
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(shape, props)
    return float(props.Mass())


def _volume(shape) -> float:
    return abs(_signed_volume(shape))


def _vertices(shape) -> np.ndarray:
    """(k, 3) coordinates of the vertices of a shape (exact extents of a polyhedral solid)."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_VERTEX
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    out = []
    ex = TopExp_Explorer(shape, TopAbs_VERTEX)
    while ex.More():
        p = BRep_Tool.Pnt_s(TopoDS.Vertex(ex.Current()))
        out.append((p.X(), p.Y(), p.Z()))
        ex.Next()
    return np.asarray(out, float).reshape(-1, 3)


def _bbox(shape) -> np.ndarray:
    """(2, 3) axis-aligned bounding box (min, max) of a shape."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib

    box = Bnd_Box()
    BRepBndLib.Add_s(shape, box, False)
    lo, hi = box.CornerMin(), box.CornerMax()
    return np.array([[lo.X(), lo.Y(), lo.Z()], [hi.X(), hi.Y(), hi.Z()]])


def _faces(shape) -> list:
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    out = []
    ex = TopExp_Explorer(shape, TopAbs_FACE)
    while ex.More():
        out.append(TopoDS.Face(ex.Current()))
        ex.Next()
    return out


def face_polygons(solid) -> list[np.ndarray]:
    """Outer loops of the faces of a polyhedral solid, each (k, 3) in order (for pictures)."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepTools import BRepTools, BRepTools_WireExplorer

    out = []
    for f in _faces(_shape(solid)):
        ex = BRepTools_WireExplorer(BRepTools.OuterWire_s(f))
        pts = []
        while ex.More():
            p = BRep_Tool.Pnt_s(ex.CurrentVertex())
            pts.append((p.X(), p.Y(), p.Z()))
            ex.Next()
        pts = np.asarray(pts, float).reshape(-1, 3)
        if len(pts) >= 3 and np.isfinite(pts).all():     # degenerate loops are left out
            out.append(pts)
    return out


def common_volume(s1, s2) -> float:
    """Volume of the intersection of two solids (exact OpenCascade boolean), unit^3.

    The boolean runs non-destructively: by default OpenCascade may widen the tolerances of
    its arguments' vertices while it works (to about 1 mm, seen on a slotted plate crossing
    another at an egg-crate), and then got this very common wrong (``a & b`` reported all of
    ``b``, more than ``b``'s own volume, where ``b & a`` gave 0 and no point of ``b`` lies
    inside ``a``),
    and later booleans on the changed solids came out differently in one process than in
    another (a path blocked or clear by the worker count). An overlap above
    :data:`MIN_INTERFERENCE_VOLUME` is confirmed too: measured again in the other order and
    with a fuzzy tolerance, the median of the three is returned, so that one wrong boolean in
    the first order cannot make an interference (a wrong 0 there is not looked at again: that
    would triple the cost of every boolean).

    Raises RuntimeError when the boolean fails even with a fuzzy tolerance.

    >>> from build123d import Box, Pos
    >>> round(common_volume(Box(2, 2, 2), Pos(1, 0, 0) * Box(2, 2, 2)), 6)
    4.0
    """
    a, b = _shape(s1), _shape(s2)
    first = _common(a, b)
    if not first > MIN_INTERFERENCE_VOLUME:
        return first
    return float(np.median([first, _common(b, a), _common(a, b, fuzzy=_FUZZY)]))


#: unit: fuzzy tolerance of the boolean that confirms an overlap or retries a failed one
_FUZZY = 1e-6


def _common(a, b, *, fuzzy: float = 0.0) -> float:
    """Volume of ``a & b`` (TopoDS shapes, left unchanged); a failed exact boolean is tried
    again with the fuzzy tolerance :data:`_FUZZY` (RuntimeError if that fails too)."""
    for f in ((0.0, _FUZZY) if fuzzy == 0.0 else (fuzzy,)):
        op = _boolean_common(a, b, f)
        if op.IsDone():
            return _volume(op.Shape())
    raise RuntimeError("BRepAlgoAPI_Common failed")


def _boolean_common(a, b, fuzzy: float):
    """The built ``BRepAlgoAPI_Common`` of ``a`` and ``b``: non-destructive (the arguments
    keep their tolerances), with ``fuzzy`` (unit; 0: exact)."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Common
    try:
        from OCP.TopTools import TopTools_ListOfShape
    except ImportError:           # OCP >= 7.8 has the list type in OCP.collections only
        from OCP.collections import List_TopoDS_Shape as TopTools_ListOfShape

    op = BRepAlgoAPI_Common()
    la, lb = TopTools_ListOfShape(), TopTools_ListOfShape()
    la.Append(a)
    lb.Append(b)
    op.SetArguments(la)
    op.SetTools(lb)
    op.SetNonDestructive(True)
    if fuzzy > 0.0:
        op.SetFuzzyValue(fuzzy)
    op.Build()
    return op


def _inside(shape, solid) -> bool:
    """A vertex of ``shape`` lies strictly inside ``solid``."""
    from OCP.BRepClass3d import BRepClass3d_SolidClassifier
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_IN

    v = _vertices(shape)
    if not len(v):
        return False
    cls = BRepClass3d_SolidClassifier(solid, gp_Pnt(*map(float, v[0])), 1e-7)
    return cls.State() == TopAbs_IN


def solid_distance(s1, s2) -> float:
    """Exact distance between two solids (0 when they touch, overlap or one holds the other).

    >>> from build123d import Box, Pos
    >>> solid_distance(Box(1, 1, 1), Pos(3, 0, 0) * Box(1, 1, 1)), solid_distance(Box(3, 3, 3), Box(1, 1, 1))
    (2.0, 0.0)
    """
    from OCP.BRepExtrema import BRepExtrema_DistShapeShape

    a, b = _shape(s1), _shape(s2)
    d = BRepExtrema_DistShapeShape(a, b)
    if not d.IsDone():
        raise RuntimeError("BRepExtrema_DistShapeShape failed")
    dist = float(d.Value())
    # the distance of the boundaries: a solid wholly inside the other is at distance 0
    if dist > 0 and (_inside(a, b) or _inside(b, a)):
        return 0.0
    return dist


#: unit: how far a triangle may reach into a convex prism and the prism still count as clear of
#: it (OpenCascade's confusion tolerance, the precision of its booleans themselves)
CLEAR_TOLERANCE = 1e-7


def hull_clear_of_triangles(points, triangles, *, eps: float = CLEAR_TOLERANCE) -> bool:
    """Whether no triangle reaches into the convex hull of ``points`` by more than ``eps``.

    A separating-axis test: a triangle is apart from the hull when their projections on one
    axis overlap by at most ``eps`` (times the axis length). The axes are the triangle's normal,
    the normal of the points' best plane, and the cross products of the points' difference
    vectors along the hull's edges with the triangle's edges. Any axis that separates proves
    the pair apart, so the answer ``True`` is exact (up to ``eps``); ``False`` means
    *undecided* (the exact boolean decides). For the prism of a planar face swept along ``v``
    the hull's edge directions are the face's edges and ``v`` (give them as ``edges``, see
    :func:`prism_clear`); here every pair of points gives one (small point sets only).

    Parameters
    ----------
    points : (m, 3) array
    triangles : (t, 3, 3) array
        Corners of each triangle.
    eps : float

    >>> import numpy as np
    >>> cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    >>> tri = np.array([[[0.5, 0.5, 1.0], [3, 0.5, 1.0], [0.5, 3, 1.0]]])   # on the top face
    >>> hull_clear_of_triangles(cube, tri), hull_clear_of_triangles(cube, tri - [0, 0, 0.01])
    (True, False)
    """
    p = np.asarray(points, float)
    tri = np.asarray(triangles, float).reshape(-1, 3, 3)
    if not len(tri):
        return True
    i, j = np.triu_indices(len(p), 1)
    return bool(_sat_clear(p[None], (p[j] - p[i])[None], _plane_normal(p)[None], tri,
                           np.ones((1, len(tri)), bool), eps)[0])


def _plane_normal(points: np.ndarray) -> np.ndarray:
    """Unit normal of the best-fit plane of (m, 3) points."""
    return np.linalg.svd(points - points.mean(axis=0), full_matrices=False)[2][-1]


def _inside_by_ray(point, triangles) -> bool | None:
    """Whether ``point`` lies inside the closed triangulated surface ``triangles`` (t, 3, 3):
    the parity of the crossings of one ray (Moller-Trumbore); None when that is not certain
    (the point on the surface, the ray grazing an edge or running in a triangle's plane)."""
    d = np.array([0.5773, 0.5871, 0.5675])          # a direction no face of a model shares
    a = triangles[:, 0] - point
    e1, e2 = triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    h = _cross(d, e2)
    det = (e1 * h).sum(axis=1)
    n = _cross(e1, e2)
    nn = np.sqrt((n * n).sum(axis=1))
    good = np.abs(det) > 1e-9 * nn
    tol = 1e-9
    if (~good & (np.abs((n * a).sum(axis=1)) <= tol * nn)).any():
        return None                                  # the ray runs in a triangle's plane
    inv = np.where(good, 1.0 / np.where(good, det, 1.0), 0.0)
    u = -(a * h).sum(axis=1) * inv
    q = _cross(-a, e1)
    v = (q @ d) * inv
    w = (e2 * q).sum(axis=1) * inv                   # distance along the ray
    within = good & (u > -tol) & (v > -tol) & (u + v < 1 + tol)
    edge = (np.abs(u) < tol) | (np.abs(v) < tol) | (np.abs(u + v - 1) < tol)
    if (within & ((np.abs(w) < tol) | (edge & (w > -tol)))).any():
        return None              # on the surface, or the ray grazes an edge or a corner
    return bool((within & (w > 0)).sum() % 2)


class _Face(NamedTuple):
    """A face of a moving solid: its OCC face, vertices (k, 3), edge directions (k, 3)."""

    face: object
    points: np.ndarray
    edges: np.ndarray
    normal: np.ndarray


def _face_records(shape) -> list[_Face]:
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp, TopExp_Explorer
    from OCP.TopoDS import TopoDS

    out = []
    for f in _faces(shape):
        edges = []
        ex = TopExp_Explorer(f, TopAbs_EDGE)
        while ex.More():
            e = TopoDS.Edge(ex.Current())
            a, b = BRep_Tool.Pnt_s(TopExp.FirstVertex_s(e)), BRep_Tool.Pnt_s(TopExp.LastVertex_s(e))
            edges.append((b.X() - a.X(), b.Y() - a.Y(), b.Z() - a.Z()))
            ex.Next()
        pts = _vertices(f)
        out.append(_Face(f, pts, np.asarray(edges, float).reshape(-1, 3), _plane_normal(pts)))
    return out


_TRIANGLES: dict = {}


def _boundary_triangles(shape) -> np.ndarray:
    """(t, 3, 3) corners of the triangles of a meshed shape's boundary (exact for planar
    faces), kept per shape while a check runs (:func:`check_assembly` empties the store)."""
    key = id(shape)
    got = _TRIANGLES.get(key)
    if got is None or got[0] is not shape:
        from OCP.BRepTools import BRepTools

        from .solids import _triangles

        if not BRepTools.Triangulation_s(shape, 0.1):
            _mesh([shape], 1.0)           # serially (check_assembly meshes before any fork)
        v, f = _triangles(shape, 0.1)
        got = (shape, v[f].reshape(-1, 3, 3))
        if _SHAPES:                       # during a check only: nothing is kept after it
            _TRIANGLES[key] = got
    return got[1]


def prisms_clear(faces: Sequence[_Face], vectors, other_triangles: np.ndarray,
                 other_box: np.ndarray, *, eps: float = CLEAR_TOLERANCE,
                 triangle_boxes=None) -> np.ndarray:
    """:func:`prism_clear` of many face prisms against one other solid at once: ``vectors``
    (p, 3) or (3,), one per face or shared. Returns (p,) bool (True: proved apart)."""
    nf = len(faces)
    if not nf:
        return np.zeros(0, bool)
    v = np.broadcast_to(np.asarray(vectors, float), (nf, 3))
    m = max(len(f.points) for f in faces)
    k = max(len(f.edges) for f in faces) + 1
    pts = np.empty((nf, 2 * m, 3))
    edges = np.zeros((nf, k, 3))                 # zero rows give no axis (masked below)
    for n, f in enumerate(faces):
        fp = np.concatenate([f.points, f.points[:1].repeat(m - len(f.points), axis=0)])
        pts[n, :m], pts[n, m:] = fp, fp - v[n]   # repeated corners leave the hull as it is
        edges[n, :len(f.edges)] = f.edges
        edges[n, len(f.edges)] = v[n]
    normals = np.array([f.normal for f in faces])
    lo, hi = pts.min(axis=1) - eps, pts.max(axis=1) + eps
    tri = other_triangles
    tmin, tmax = triangle_boxes if triangle_boxes is not None else (tri.min(axis=1), tri.max(axis=1))
    near = ((tmin[None] <= hi[:, None]).all(axis=2) & (tmax[None] >= lo[:, None]).all(axis=2))
    clear = np.ones(nf, bool)
    used = near.any(axis=0)
    if used.any():
        clear = _sat_clear(pts, edges, normals, tri[used], near[:, used], eps)
    # clear of the boundary: apart unless wholly inside (a hull sticking out of the box is not)
    inside_box = (lo >= other_box[0]).all(axis=1) & (hi <= other_box[1]).all(axis=1)
    for n in np.flatnonzero(clear & inside_box):
        clear[n] = _inside_by_ray(pts[n].mean(axis=0), tri) is False
    return clear


def _sat_clear(pts, edges, normals, tri, near, eps) -> np.ndarray:
    """(p,) whether no near triangle reaches ``eps`` into the hull of each point set ``pts``
    (p, m, 3) with edge directions ``edges`` (p, k, 3), axis ``normals`` (p, 3); ``near``
    (p, t) selects the triangles (t, 3, 3) each is tested against (only those pairs are)."""
    pi, ti = np.nonzero(near)
    c = pts.mean(axis=1)                               # (p, 3): centred, smaller round-off
    q = (pts - c[:, None])[pi]                         # (n, m, 3)
    t = tri[ti] - c[pi][:, None]                       # (n, 3, 3)
    te = t[:, [1, 2, 0]] - t                           # (n, 3, 3) triangle edges
    tn = _cross(te[:, 0], te[:, 1])                    # (n, 3)
    cross = _cross(edges[pi][:, :, None, :], te[:, None, :, :]).reshape(len(pi), -1, 3)
    axes = np.concatenate([tn[:, None], normals[pi][:, None], cross], axis=1)   # (n, a, 3)
    norm = np.sqrt((axes * axes).sum(axis=2))          # (n, a)
    scale = max(float(np.abs(q).max(initial=0.0)), float(np.abs(t).max(initial=0.0)), 1.0)
    ok = norm > 1e-9 * scale * scale                   # parallel edges give no axis
    pp = axes @ q.transpose(0, 2, 1)                   # (n, a, m)
    tp = axes @ t.transpose(0, 2, 1)                   # (n, a, 3)
    gap = np.maximum(tp.min(axis=2) - pp.max(axis=2), pp.min(axis=2) - tp.max(axis=2))
    sep = (ok & (gap >= -eps * norm)).any(axis=1)      # (n,)
    clear = np.ones(len(pts), bool)
    clear[pi[~sep]] = False
    return clear


def prism_clear(face: _Face, vector, other_triangles: np.ndarray, other_box: np.ndarray,
                *, eps: float = CLEAR_TOLERANCE, triangle_boxes=None) -> bool:
    """Whether the prism that ``face`` sweeps from ``-vector`` to its place provably has no
    volume in common with the solid bounded by ``other_triangles`` (t, 3, 3) whose box is
    ``other_box`` (2, 3) (True: exact, within ``eps``; False: undecided). The prism lies in the
    convex hull of the face's corners and their translates, whose edges run along the face's
    edges and ``vector``: no boundary triangle of the other reaching into that hull
    (:func:`hull_clear_of_triangles`), and the hull not inside the other (one point, ray
    parity), leave them apart. ``triangle_boxes``: the triangles' (min, max) corners, if known."""
    return bool(prisms_clear([face], vector, other_triangles, other_box, eps=eps,
                             triangle_boxes=triangle_boxes)[0])


def _outward_normals(shape, faces: list[_Face]) -> np.ndarray | None:
    """(f, 3) outward unit normals of the planar faces of a closed solid (None: a face is not
    planar)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.GeomAbs import GeomAbs_Plane
    from OCP.TopAbs import TopAbs_REVERSED

    out = []
    for f in faces:
        surf = BRepAdaptor_Surface(f.face)
        if surf.GetType() != GeomAbs_Plane:
            return None
        d = surf.Plane().Axis().Direction()
        n = np.array([d.X(), d.Y(), d.Z()])
        out.append(-n if f.face.Orientation() == TopAbs_REVERSED else n)
    # a shell oriented inside out has a negative volume: its faces point in
    return np.asarray(out).reshape(-1, 3) * (1.0 if _signed_volume(shape) >= 0 else -1.0)


def solid_cover(shape, faces: list[_Face] | None = None) -> list[tuple[_Face, np.ndarray]]:
    """Prisms that cover a closed planar-faced solid: ``(face, vector)``, each face with
    ``n . w > 0`` swept back along ``vector = L w`` (a point of the solid leaves it along
    ``w`` through such a face within the solid's extent ``L`` along ``w``); ``w`` is the
    outward face normal along which the solid is thinnest (a flat plate: its thickness, one
    prism per face). Empty when a face is not planar (no cover)."""
    faces = _face_records(shape) if faces is None else faces
    normals = _outward_normals(shape, faces)
    if normals is None or not len(faces):
        return []
    verts = np.concatenate([f.points for f in faces])
    proj = verts @ normals.T
    ext = proj.max(axis=0) - proj.min(axis=0)
    k = int(np.argmin(ext))
    w = normals[k] * float(ext[k])
    return [(f, w) for f, n in zip(faces, normals) if n @ normals[k] > 0]


def solid_clear(cover: list[tuple[_Face, np.ndarray]], other_triangles: np.ndarray,
                other_box: np.ndarray, *, eps: float = CLEAR_TOLERANCE,
                triangle_boxes=None) -> bool:
    """Whether the solid covered by the prisms ``cover`` (:func:`solid_cover`) provably has no
    volume in common with the solid bounded by ``other_triangles`` (t, 3, 3), box
    ``other_box`` (True: exact within ``eps``; False: undecided): every prism is clear of it
    (:func:`prism_clear`)."""
    if not cover:
        return False
    return bool(prisms_clear([f for f, _ in cover], np.array([w for _, w in cover]),
                             other_triangles, other_box, eps=eps,
                             triangle_boxes=triangle_boxes).all())


def swept_overlap(moving, vector, others: Sequence, *, stop_above: float = np.inf,
                  faces: list[_Face] | None = None) -> list[float]:
    """Volume that ``moving`` sweeps on its way from ``position - vector`` to its place and that
    lies inside each of ``others`` (unit^3, one per other; an upper bound: the sum over the
    prisms every face of ``moving`` sweeps along ``vector``, each intersected exactly). With
    ``stop_above`` the sum for one other stops once it exceeds that (a collision is known).

    A prism that :func:`prism_clear` proves apart from an other adds 0 without a boolean.
    ``faces``: the face records of ``moving`` (``_face_records``), if made already.

    >>> from build123d import Box, Pos
    >>> [round(v, 6) for v in swept_overlap(Box(1, 1, 1), (0, 0, 3), [Pos(0, 0, -2) * Box(1, 1, 1)])]
    [2.0]
    """
    v = np.asarray(vector, float)
    faces = _face_records(_shape(moving)) if faces is None else faces
    fboxes = [(np.minimum(f.points.min(axis=0), (f.points - v).min(axis=0)),
               np.maximum(f.points.max(axis=0), (f.points - v).max(axis=0))) for f in faces]
    prisms: dict[int, object] = {}           # face index -> oriented prism (None: no volume)
    out = []
    for o in others:
        oshape = _shape(o)
        ob = _bbox(oshape)
        total = 0.0
        meets = [n for n, (plo, phi) in enumerate(fboxes)
                 if not ((plo > ob[1]).any() or (ob[0] > phi).any())]     # else apart
        if meets:
            clear = prisms_clear([faces[n] for n in meets], v, _boundary_triangles(oshape), ob)
            meets = [n for n, c in zip(meets, clear) if not c]            # else proved apart
        for n in meets:
            face = faces[n]
            if n not in prisms:
                prisms[n] = _face_prism(face.face, v)
            pr = prisms[n]
            if pr is None or (_bbox(pr)[0] > ob[1]).any() or (ob[0] > _bbox(pr)[1]).any() \
                    or not _near(pr, oshape, 1e-3):
                continue
            try:
                total += common_volume(pr, o)
            except RuntimeError:
                total = float("inf")
            if total > stop_above:
                break
        out.append(total)
    return out


def _face_prism(face, v: np.ndarray):
    """The oriented, meshed solid ``face`` sweeps along ``-v`` (None: the face runs along
    ``v`` and sweeps no volume)."""
    from OCP.BRepGProp import BRepGProp
    from OCP.BRepLib import BRepLib
    from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism
    from OCP.GProp import GProp_GProps
    from OCP.TopoDS import TopoDS
    from OCP.gp import gp_Vec

    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, props)
    pr = TopoDS.Solid(BRepPrimAPI_MakePrism(face, gp_Vec(*map(float, -v)), True).Shape())
    # faces along the path sweep no volume (numerically a sliver of either sign: skip it)
    if abs(_signed_volume(pr)) <= 1e-9 * props.Mass() * float(np.linalg.norm(v)):
        return None
    # a face swept against its normal gives an inside-out solid; the boolean would take its
    # complement: orient it
    BRepLib.OrientClosedSolid_s(pr)
    _mesh([pr], 1.0)
    return pr


# ---------------------------------------------------------------------------- parallel map
_SHAPES: list = []


def _near(s1, s2, tol: float) -> bool:
    """Whether two meshed shapes come within about ``tol`` (BVH on their triangulations, fast;
    exact triangles for planar faces, a conservative test of the gap): a prefilter only."""
    from OCP.BRepExtrema import BRepExtrema_ShapeProximity

    p = BRepExtrema_ShapeProximity(s1, s2, tol)
    p.Perform()
    return not p.IsDone() or p.OverlapSubShapes1().Size() > 0


_COVERS: dict = {}


def _faces_of(k: int) -> list[_Face]:
    """Face records of ``_SHAPES[k]``, made once per process."""
    key = ("f", k)
    if key not in _COVERS or _COVERS[key][0] is not _SHAPES[k]:
        _COVERS[key] = (_SHAPES[k], _face_records(_SHAPES[k]))
    return _COVERS[key][1]


def _cover_of(k: int) -> list:
    """:func:`solid_cover` of ``_SHAPES[k]``, made once per process."""
    if k not in _COVERS or _COVERS[k][0] is not _SHAPES[k]:
        _COVERS[k] = (_SHAPES[k], solid_cover(_SHAPES[k], _faces_of(k)))
    return _COVERS[k][1]


def _triangles_of(k: int) -> tuple:
    """``(triangles, box, triangle_boxes)`` of ``_SHAPES[k]`` for :func:`solid_clear`."""
    key = ("t", k)
    if key not in _COVERS or _COVERS[key][0] is not _SHAPES[k]:
        tri = _boundary_triangles(_SHAPES[k])
        _COVERS[key] = (_SHAPES[k], (tri, _bbox(_SHAPES[k]), (tri.min(axis=1), tri.max(axis=1))))
    return _COVERS[key][1]


def _pair_job(job):
    i, j, tol = job
    try:
        a, b = _SHAPES[i], _SHAPES[j]
        if not _near(a, b, tol) and not (_inside(a, b) or _inside(b, a)):
            return i, j, float("inf"), 0.0, ""     # boundaries apart, neither inside the other
        # within the tolerance on the triangulations (exact for planar faces): touching;
        # the exact distance (solid_distance) would cost ten booleans a pair. A pair that
        # the cheap exact test proves apart has nothing in common; the others get the boolean
        (ta, ba, tba), (tb, bb, tbb) = _triangles_of(i), _triangles_of(j)
        if solid_clear(_cover_of(i), tb, bb, triangle_boxes=tbb) or \
                solid_clear(_cover_of(j), ta, ba, triangle_boxes=tba):
            return i, j, 0.0, 0.0, ""
        return i, j, 0.0, common_volume(a, b), ""
    except Exception as e:       # OpenCascade failures: reported per pair, never assumed clear
        return i, j, float("nan"), float("nan"), f"{type(e).__name__}: {e}"


def _sweep_job(job):
    k, vector, others, stop_above = job
    return k, swept_overlap(_SHAPES[k], vector, [_SHAPES[o] for o in others],
                            stop_above=stop_above, faces=_faces_of(k))


def _map(fn, jobs: list, workers: int, progress: Callable | None, what: str) -> list:
    """``[fn(job)]`` in order, over forked processes when ``workers > 1`` (the solids in
    ``_SHAPES`` are inherited, not pickled)."""
    out = []
    workers = usable_workers(workers)
    if workers <= 1 or len(jobs) < 8 or "fork" not in multiprocessing.get_all_start_methods():
        for n, job in enumerate(jobs):
            out.append(fn(job))
            if progress:
                progress(what, n + 1, len(jobs))
        return out
    with multiprocessing.get_context("fork").Pool(workers) as pool:
        for n, r in enumerate(pool.imap(fn, jobs, chunksize=max(1, len(jobs) // (8 * workers)))):
            out.append(r)
            if progress:
                progress(what, n + 1, len(jobs))
    return out


# ---------------------------------------------------------------------------- joints
def joints_of(fin_system) -> list[AssemblyJoint]:
    """Joint records of a fin system: ``fin_system.joints`` when it has them, else its egg-crate
    crossings (family-0 parts first; the family-1 plate, slotted from its ``a`` edge, moves
    along the node axis ``a_i - b_i`` onto them) and the mitred splits inside a strip (the
    later part slides along the node line of the split)."""
    joints = getattr(fin_system, "joints", None)
    if joints is not None:
        return [_as_joint(j) for j in joints]
    st = fin_system.structure
    out = []

    def axis(node):
        d = np.asarray(st.vertices_a[node] - st.vertices_b[node], float)
        return d / np.linalg.norm(d)

    for x in fin_system.crossings:
        out.append(AssemblyJoint("egg-crate", int(x.node), tuple(x.parts0) + tuple(x.parts1),
                                 axis(x.node), None))
    # parts of one strip split inside it meet mitred on the bisector plane of the fold, which
    # holds the node line: the later part slides along it
    parts = list(fin_system.parts)
    for prev, nxt in zip(parts[:-1], parts[1:]):
        if (prev.id.family, prev.id.strip) == (nxt.id.family, nxt.id.strip) and \
                nxt.ends[0] == "miter" and int(nxt.nodes[0]) >= 0:
            out.append(AssemblyJoint("mitre", int(nxt.nodes[0]), (prev.name, nxt.name),
                                     axis(int(nxt.nodes[0])), None))
    return out


def _as_joint(j) -> AssemblyJoint:
    """An :class:`AssemblyJoint` from any record with the same fields."""
    if isinstance(j, AssemblyJoint):
        return j
    cd = getattr(j, "connector_direction", None)
    depth = getattr(j, "depth", None)
    return AssemblyJoint(str(getattr(j.kind, "value", j.kind)), int(j.node), tuple(j.parts),
                         np.asarray(j.insert_direction, float), getattr(j, "connector", None),
                         None if cd is None else np.asarray(cd, float),
                         None if depth is None else float(depth))


def joint_groups(joint: AssemblyJoint) -> list[tuple[str, ...]]:
    """The parts of a joint in the groups that go in one after the other: for an egg-crate the
    plates of one family, then those of the other (named ``F<family>-...``: two parts of one
    strip split at the crossing are not each other's partners); for a butt joint the parts of
    the plate it butts against (one group: they are not joined to each other by it), the butted
    part, the connector; for a mitre the two parts (either may go in first: they meet on the
    fold's bisector plane), then the splice plate; otherwise one part at a time."""
    if joint.kind == "egg-crate":
        groups: dict[str, list] = {}
        for p in joint.parts:
            groups.setdefault(p.split("-", 1)[0], []).append(p)
        return [tuple(g) for g in groups.values()]
    if joint.kind == "butt-bracket":
        plates = [p for p in joint.parts if p != joint.connector]
        return ([tuple(plates[:-1])] if len(plates) > 1 else []) + [(plates[-1],)] + (
            [(joint.connector,)] if joint.connector else [])
    if joint.kind == "mitre-splice":
        return [tuple(p for p in joint.parts if p != joint.connector)] + (
            [(joint.connector,)] if joint.connector else [])
    return [(p,) for p in joint.parts]


def _placement_order(names: list[str], joints: list[AssemblyJoint]) -> list[str]:
    """Parts in an order where, for every joint, the groups it lists first come first (as far
    as the joints agree; a conflicting precedence is dropped), ties by name."""
    index = {n: i for i, n in enumerate(names)}
    before: dict[str, set] = {n: set() for n in names}
    for j in joints:
        groups = [[p for p in g if p in index] for g in joint_groups(j)]
        for ga, gb in zip(groups[:-1], groups[1:]):
            for b in gb:
                before[b].update(a for a in ga if a != b)
    connectors = {j.connector for j in joints if j.connector}
    order, placed = [], set()
    remaining = sorted(names)
    while remaining:
        ready = [n for n in remaining if before[n] <= placed]
        if not any(n not in connectors for n in ready):
            # plates wait only for connectors, or for each other (a cycle): take the plate with
            # the fewest plates missing before it
            plates = [n for n in remaining if n not in connectors]
            if plates:
                ready = [min(plates, key=lambda n: (len(before[n] - placed - connectors), n))]
            elif not ready:
                ready = [min(remaining, key=lambda n: (len(before[n] - placed), n))]
        # connectors (brackets, splice plates) go on once the plates around them are in
        nxt = next((n for n in ready if n not in connectors), ready[0])
        order.append(nxt)
        placed.add(nxt)
        remaining.remove(nxt)
    return order


def _candidate_directions(axes: list[np.ndarray], slotted: list[bool] | None = None) -> list[np.ndarray]:
    """Directions to try: the mean axis of the slotted joints (a slot allows one direction; a
    butt end slides along the plate it meets), the mean of all axes (signed alike), then each
    distinct axis; both senses."""
    if not axes:
        return []
    ref = axes[0]
    signed = [a if a @ ref >= 0 else -a for a in axes]
    cands = []
    slotted = slotted or [False] * len(axes)
    for group in ([a for a, sl in zip(signed, slotted) if sl], signed):
        mean = np.sum(group, axis=0) if group else np.zeros(3)
        if np.linalg.norm(mean) > 1e-9 and all(abs(mean @ c) < (1.0 - 1e-12) * np.linalg.norm(mean)
                                              for c in cands):
            cands.append(mean / np.linalg.norm(mean))
    for a in signed:           # each joint's own axis, exactly: the path a slot allows
        if all(abs(a @ c) < 1.0 - 1e-12 for c in cands):
            cands.append(a)
    # a part held between plates it butts against slides along the line where their faces
    # meet: the cross product of two butt directions (plate normals)
    for a, b in itertools.combinations([a for a, sl in zip(signed, slotted) if not sl][:4], 2):
        c = np.cross(a, b)
        if np.linalg.norm(c) > 1e-6:
            cands.append(c / np.linalg.norm(c))
    # at most ten directions, both senses: a part that none of these lets in is blocked (only
    # blocked parts pay for the further tries)
    return [s * c for c in cands[:10] for s in (1.0, -1.0)]


# ---------------------------------------------------------------------------- the check
def check_assembly(solids: Mapping | Iterable, *, joints: Iterable = (),
                   tolerance: float = 1.0, min_volume: float = MIN_INTERFERENCE_VOLUME,
                   workers: int | None = None, unit: str = "mm",
                   progress: Callable[[str, int, int], None] | None = None) -> AssemblyCheck:
    """Check named solids for interference and find an assembly order (see the module text).

    Parameters
    ----------
    solids : mapping name -> solid, or iterable of (name, solid)
        build123d or OCP solids, e.g. ``FinSystem.solids()`` or ``read_step("fins.step")``.
        Names must be unique.
    joints : iterable of joint records
        Objects with ``kind, node, parts, insert_direction, connector`` (see
        :class:`AssemblyJoint` and :func:`joints_of`). Parts without joints are set down in
        place (no path is checked).
    tolerance : float
        Pairs closer than this (unit) are touching and get the exact boolean.
    min_volume : float
        Common volume (unit^3) above which two parts interfere or a path collides.
    workers : int, optional
        Processes for the pair and path checks; default ``min(2, cpu count)``.
    progress : callable(phase, done, total), optional

    Returns
    -------
    AssemblyCheck
    """
    t0 = time.perf_counter()
    items = list(solids.items()) if isinstance(solids, Mapping) else list(solids)
    names = [str(n) for n, _ in items]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"solids with the same name {dup[:8]}: every part needs one solid of its own")
    shapes = [_shape(s) for _, s in items]
    joints = [_as_joint(j) for j in joints]
    if workers is None:
        workers = min(2, os.cpu_count() or 1)
    global _SHAPES
    _SHAPES = shapes
    _mesh(shapes, tolerance)
    try:
        boxes = np.array([_bbox(s) for s in shapes]).reshape(-1, 2, 3)
        touching, interfering, failed = _touching_pairs(names, boxes, tolerance, min_volume,
                                                        workers, progress)
        order = _assembly_order(names, boxes, joints, tolerance, min_volume, workers, progress)
    finally:
        _SHAPES = []
        _TRIANGLES.clear()
        _COVERS.clear()
    kinds = Counter(j.kind for j in joints)
    # connector parts (brackets, splice plates) by the kind of joint they fasten
    connectors = Counter(j.kind for j in {j.connector: j for j in joints if j.connector}.values())
    return AssemblyCheck(parts=names, pairs_checked=len(touching), interfering=interfering,
                         order=order, failed_pairs=failed, joints=dict(sorted(kinds.items())),
                         connectors=dict(sorted(connectors.items())), min_volume=min_volume,
                         unit=unit, seconds=time.perf_counter() - t0)


def _box_pairs(boxes: np.ndarray, grow: float) -> list[tuple[int, int]]:
    """Index pairs (i < j) whose boxes, grown by ``grow``, overlap (sort and sweep on x)."""
    lo, hi = boxes[:, 0] - grow, boxes[:, 1] + grow
    order = np.argsort(lo[:, 0])
    pairs = []
    for n, i in enumerate(order):
        for j in order[n + 1:]:
            if lo[j, 0] > hi[i, 0]:
                break
            if (lo[i] <= hi[j]).all() and (lo[j] <= hi[i]).all():
                pairs.append((int(min(i, j)), int(max(i, j))))
    return sorted(pairs)


def _touching_pairs(names, boxes, tolerance, min_volume, workers, progress):
    jobs = [(i, j, tolerance) for i, j in _box_pairs(boxes, 0.5 * tolerance)]
    touching, interfering, failed = set(), [], []
    for i, j, dist, vol, err in _map(_pair_job, jobs, workers, progress, "pairs"):
        if err:
            failed.append((names[i], names[j], err))
            touching.add((i, j))
        elif dist <= tolerance:
            touching.add((i, j))
            if vol > min_volume:
                interfering.append(Interference((names[i], names[j]), float(vol)))
    interfering.sort(key=lambda x: -x.volume)
    return touching, interfering, failed


def _assembly_order(names, boxes, joints, tolerance, min_volume, workers, progress):
    """Steps with the first clear insertion direction of every part (see the module text)."""
    index = {n: i for i, n in enumerate(names)}
    order = [index[n] for n in _placement_order(names, joints)]
    rank = {k: r for r, k in enumerate(order)}
    joint_of: dict[int, list[AssemblyJoint]] = {k: [] for k in range(len(names))}
    for jt in joints:
        for p in jt.parts:
            if p in index:
                joint_of[index[p]].append(jt)
    verts = {k: _vertices(_SHAPES[k]) for k in range(len(names))}
    plans = []                       # per step: (part, partners, kinds, [(direction, travel, others)])
    for k in order:
        partners, kinds, axes, slotted, depths = set(), [], [], [], []
        for jt in joint_of[k]:
            groups = joint_groups(jt)
            mine = next(g for g, ps in enumerate(groups) if names[k] in ps)
            placed = [index[p] for g in groups[:mine] for p in g
                      if p in index and rank[index[p]] < rank[k]]
            if placed:
                partners.update(placed)
                kinds.append(jt.kind)
                own = (jt.connector_direction if names[k] == jt.connector
                       and jt.connector_direction is not None else jt.insert_direction)
                axes.append(np.asarray(own, float))
                slotted.append(jt.kind == "egg-crate")
                depths.append(jt.depth if jt.connector != names[k] else None)
        cands = []
        for d in _candidate_directions(axes, slotted):
            # start one depth of the part (its extent along d) back: disengaged from its
            # joints (a slot is at most as long as the part is deep along its axis)
            ext = verts[k] @ d
            travel = float(ext.max() - ext.min())
            if depths and all(x is not None and x > 0 for x in depths):
                # disengaged from its joints once slid back by their depth (a long, skewed
                # plate need not come from beyond its own far end)
                travel = min(travel, max(depths))
            travel += tolerance
            lo = np.minimum(boxes[k, 0], boxes[k, 0] - travel * d) - tolerance
            hi = np.maximum(boxes[k, 1], boxes[k, 1] - travel * d) + tolerance
            others = [o for o in order[:rank[k]]
                      if (boxes[o, 0] <= hi).all() and (lo <= boxes[o, 1]).all()]
            cands.append((d, travel, others))
        plans.append((k, sorted(partners, key=rank.get), tuple(sorted(set(kinds))), cands))
    # try the first direction of every part at once, then the next for those still blocked
    best: dict[int, tuple] = {}
    pending = [n for n, p in enumerate(plans) if p[3]]
    for n, p in enumerate(plans):
        if not p[3]:
            best[n] = (None, 0.0, ())
    attempt = 0
    while pending:
        jobs = [(plans[n][0], plans[n][3][attempt][1] * plans[n][3][attempt][0],
                 plans[n][3][attempt][2], min_volume) for n in pending]
        results = _map(_sweep_job, jobs, workers, progress, f"paths (try {attempt + 1})")
        still = []
        for n, (_, vols) in zip(pending, results):
            d, travel, others = plans[n][3][attempt]
            hits = tuple(sorted((Interference((names[plans[n][0]], names[o]), float(v))
                                 for o, v in zip(others, vols) if not v <= min_volume),
                                key=lambda x: -x.volume))
            total = sum(h.volume for h in hits)
            if n not in best or total < sum(h.volume for h in best[n][2]):
                best[n] = (d, travel, hits)
            if hits and attempt + 1 < len(plans[n][3]):
                still.append(n)
        pending, attempt = still, attempt + 1
    steps = []
    for n, (k, partners, kinds, _) in enumerate(plans):
        d, travel, hits = best[n]
        steps.append(AssemblyStep(step=n + 1, part=names[k],
                                  insert_direction=None if d is None else tuple(float(x) for x in d),
                                  travel=float(travel), partners=tuple(names[o] for o in partners),
                                  joint_kinds=kinds, collisions=hits))
    return steps


def verify_assembly(fin_system, *, step_file=None, tolerance: float = 1.0,
                    min_volume: float = MIN_INTERFERENCE_VOLUME, workers: int | None = None,
                    progress: Callable[[str, int, int], None] | None = None) -> AssemblyCheck:
    """:func:`check_assembly` of a :class:`~torsal.fabrication.FinSystem`: its solids (or, with
    ``step_file``, the solids re-read from that STEP file, as a fabricator would get them) and
    its joints (:func:`joints_of`)."""
    if step_file is not None:
        from .solids import read_step

        solids = read_step(step_file)
    else:
        solids = fin_system.solids()
    return check_assembly(solids, joints=joints_of(fin_system), tolerance=tolerance,
                          min_volume=min_volume, workers=workers, unit=fin_system.unit,
                          progress=progress)
