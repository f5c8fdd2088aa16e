"""Plate and slot solids (OpenCascade through OCP): the construction kernel of :mod:`.solids`.

Every part is thickened about its mid-plane by ``thickness``: the plate is a closed
polyhedral shell (top face ``p + t/2 m``, bottom ``p - t/2 m`` with the mitre vectors ``m``
of :class:`~.parts.Part`, side faces along the ``a`` and ``b`` edges, end caps) built as one
B-rep (shared vertices and edges, each face on the plane of its corners; the faces are sewn
only where corners nearly coincide): folds are mitred on the bisector plane, so no boolean
fuse is needed and the plate volume equals ``sum(panel area) * thickness`` up to the twist of
side faces. Egg-crate slots are cut as boxes (a box per panel touching the slot, or one on
the bisector of a flat fold, centred on the node line, ``thickness + clearance`` wide, through
the plate): without a boolean, in the planes of the plate's faces (each face less the boxes'
sections, each box face within the plate's section: :func:`_cut_polyhedron`, then one B-rep
as the plate's), the solid OpenCascade's boolean cut and face unification give, in less than
half their time; the boolean (one per part) cuts the parts where that declines (faces on one
plane, corners on a cutting plane, anything it cannot close into one shell).

Every solid is checked with BRepCheck (build123d's ``is_valid``); an invalid one is repaired
with ``ShapeFix`` and if it stays invalid an :class:`InvalidSolidError` names the part:
nothing is written silently. The slots are checked too (the cut must remove the slot area of
the unrolled part times the thickness, every slot open and the web beyond it kept); where
neither route can cut them (thin, oblique plates of real structures) the sound plate is kept
without them (:class:`SlotCutError`).
The STEP solids are nominal: the cutting process (kerf, reliefs) lives in the DXF only.

Also the meshing of OCC shapes for previews (:func:`_mesh`, :func:`_triangles`).

Units: the ``unit`` of the fin system (mm by default).
"""
from __future__ import annotations

import numpy as np

from torsal.core.errors import TorsalError

from .model import Part, SlotSide, _cross, panel_widths, slab_faces
from .unroll import unroll

__all__ = ["InvalidSolidError", "SlotCutError", "part_solid", "slot_boxes", "SINGLE_BOX_FOLD",
           "SLOT_CUT_FUZZY", "MESH_TOLERANCE"]


class InvalidSolidError(TorsalError, RuntimeError):
    """A part's solid is not valid OpenCascade geometry even after repair."""

    #: what a designer can do about it (said after the detail)
    ADVICE = ("; its fin panels are twisted or folded back too far to make a plate: keep the fins' "
              "torsal planes apart ([constraints] min_torsal_angle, e.g. 30) or smooth the "
              "congruence (weights.fair), or remesh the surface more finely")

    def __init__(self, parts: list[str], detail: str = ""):
        self.parts = parts
        self.detail = detail
        super().__init__(f"invalid solid for part(s) {', '.join(parts)}" + (f": {detail}" if detail else "")
                         + (self.ADVICE if type(self) is InvalidSolidError else ""))


class SlotCutError(InvalidSolidError):
    """The plate of a part is sound but OpenCascade could not cut its slots (a boolean failure
    on a thin, oblique plate). ``plate`` is the valid solid without slots (a build123d ``Solid``
    from :func:`part_solid`, an OCC shape inside the module)."""

    def __init__(self, parts: list[str], detail: str = "", plate=None, nodes=()):
        super().__init__(parts, detail)
        self.plate = plate
        self.nodes = list(nodes)


#: build123d's point tolerance: a polygon whose last point is farther than this from its first
#: is closed by repeating the first (as ``Wire.make_polygon(close=True)``)
_CLOSE_TOL = 1e-6


def _dedup(points) -> np.ndarray:
    """Points (n, 3) without consecutive repeats (degenerate twisted sides) and without a last
    point repeating the first."""
    pts = np.asarray(points, float)
    keep = np.r_[True, np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-12]
    pts = pts[keep]
    if len(pts) > 3 and np.linalg.norm(pts[-1] - pts[0]) <= 1e-12:
        pts = pts[:-1]
    return pts


def _polygon_face(pts: np.ndarray):
    """Planar OCC face bounded by the closed polygon ``pts`` (n, 3), built as build123d's
    ``Face(Wire.make_polygon(pts, close=True))`` does (same OCC calls: the wire is fixed,
    the face made on its plane and its orientation fixed). ValueError if OpenCascade finds
    the points not coplanar."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakePolygon
    from OCP.BRepLib import BRepLib_FindSurface
    from OCP.gp import gp_Pnt
    from OCP.ShapeFix import ShapeFix_Face, ShapeFix_Shape
    from OCP.TopoDS import TopoDS

    poly = BRepBuilderAPI_MakePolygon()
    for p in pts:
        poly.Add(gp_Pnt(float(p[0]), float(p[1]), float(p[2])))
    if np.linalg.norm(pts[0] - pts[-1]) > _CLOSE_TOL:
        poly.Add(gp_Pnt(float(pts[0, 0]), float(pts[0, 1]), float(pts[0, 2])))
    wire = poly.Wire()
    if not BRep_Tool.IsClosed_s(wire):
        raise ValueError("Face can only be created with closed wires")
    if not BRepLib_FindSurface(wire, OnlyPlane=True).Found():
        raise ValueError("Cannot build face(s): wires not planar")
    fix = ShapeFix_Shape(wire)
    fix.Perform()
    maker = BRepBuilderAPI_MakeFace(TopoDS.Wire(fix.Shape()), True)
    maker.Build()
    if not maker.IsDone():
        raise ValueError(f"Cannot build face(s): {maker.Error()}")
    face_fix = ShapeFix_Face(maker.Face())
    face_fix.FixOrientation()
    face_fix.Perform()
    return TopoDS.Face(face_fix.Result())


def _face(points, planar_tol: float, planar: bool | None = None) -> list:
    """OCC faces through the points: one planar face, or triangles (:func:`_triangles_inside`)
    if they are not coplanar (to ``min(planar_tol * size, 1e-9)`` in absolute units, below
    OpenCascade's 1e-7). ``planar``: that test, done already (by :func:`_coplanar`) for points without
    repeats."""
    pts = _dedup(points) if planar is None else np.asarray(points, float)
    if len(pts) < 3:
        return []
    if planar is None:
        planar = len(pts) == 3 or bool(_coplanar(pts[None], planar_tol)[0])
    if planar:
        try:
            return [_polygon_face(pts)]
        except ValueError:       # OpenCascade finds it not planar enough: use triangles
            if len(pts) == 3:
                raise
    return [_polygon_face(pts[t]) for t in _triangles_inside(pts[None])[0]]


def _coplanar(pts: np.ndarray, planar_tol: float) -> np.ndarray:
    """Whether each polygon of ``pts`` (F, n, 3) is within ``min(planar_tol * size, 1e-9)`` of
    its best-fit plane (size: its bounding-box diagonal)."""
    c = pts.mean(axis=1, keepdims=True)
    normal = np.linalg.svd(pts - c)[2][:, 2]                                  # (F, 3)
    size = np.linalg.norm(pts.max(axis=1) - pts.min(axis=1), axis=1)
    off = np.abs(np.einsum("fni,fi->fn", pts - c, normal)).max(axis=1)
    return off <= np.minimum(planar_tol * size, 1e-9)


def _triangles_inside(pts: np.ndarray) -> np.ndarray:
    """Corner indices (F, n - 2, 3) of triangles that tile each polygon of ``pts`` (F, n, 3),
    as :func:`_face` and :func:`_plate_direct` build a face whose corners are not coplanar:
    a fan from corner 0, but a quad is split on its diagonal that lies inside it, 1-3 where
    corner 1 or 3 is reflex (seen along its Newell normal): on the diagonal 0-2 outside it the
    two triangles would overlap, one turned against the other, and a solid of such faces is a
    self-overlapping shell that OpenCascade classifies, and so heals and intersects, as inside
    out (example 7c's F0-S001-P00 at 3db0016).

    >>> _triangles_inside(np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.1]]]))[0].tolist()
    [[0, 1, 2], [0, 2, 3]]
    >>> _triangles_inside(np.array([[[0, 0, 0], [2, 0, 0], [2, 2, 0], [1.5, 0.5, 0.1]]]))[0].tolist()
    [[1, 2, 3], [1, 3, 0]]
    """
    pts = np.asarray(pts, float)
    f, n = pts.shape[:2]
    fan = np.array([[0, i, i + 1] for i in range(1, n - 1)]).reshape(-1, 3)
    out = np.broadcast_to(fan, (f, n - 2, 3)).copy()
    if n == 4:
        area = _cross(pts, np.roll(pts, -1, axis=1)).sum(axis=1)             # Newell, (F, 3)
        d = pts[:, 2] - pts[:, 0]
        inside = ((np.einsum("fi,fi->f", _cross(pts[:, 1] - pts[:, 0], d), area) > 0)
                  & (np.einsum("fi,fi->f", _cross(d, pts[:, 3] - pts[:, 0]), area) > 0))
        out[~inside] = [[1, 2, 3], [1, 3, 0]]
    return out


def _polygon_volumes(pts: np.ndarray) -> np.ndarray:
    """Signed volume contributions (F,) of polygons (F, n, 3) as faces of a closed surface
    (divergence theorem: the sum over the faces is the volume it bounds), each tiled as
    :func:`_triangles_inside` tiles it."""
    pts = np.asarray(pts, float)
    t = pts[np.arange(len(pts))[:, None, None], _triangles_inside(pts)]        # (F, n-2, 3, 3)
    return np.einsum("fki,fki->f", t[:, :, 0], _cross(t[:, :, 1], t[:, :, 2])) / 6.0


def _fan_volume(points) -> float:
    """Signed volume contribution (divergence theorem) of a face as :func:`_face` builds it:
    repeated points dropped, triangles as :func:`_triangles_inside`."""
    pts = _dedup(points)
    if len(pts) < 3:
        return 0.0
    return float(_polygon_volumes(pts[None])[0])


def _box(origin, x_dir, z_dir, length, width, height):
    """OCC box ``length x width x height`` from ``origin`` along ``x_dir``, ``z_dir x x_dir``,
    ``z_dir`` (as build123d's ``Solid.make_box`` on that plane)."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt

    def unit(v):
        v = np.asarray(v, float)
        return gp_Dir(*map(float, v / np.linalg.norm(v)))

    ax = gp_Ax2(gp_Pnt(*map(float, origin)), unit(z_dir), unit(x_dir))
    return BRepPrimAPI_MakeBox(ax, float(length), float(width), float(height)).Shape()


def _volume(shape) -> float:
    """Volume of an OCC shape (signed: negative for a solid turned inside out)."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(shape, props)
    return props.Mass()


def _is_valid(shape) -> bool:
    """BRepCheck of an OCC shape (as build123d's ``is_valid``)."""
    from OCP.BRepCheck import BRepCheck_Analyzer

    chk = BRepCheck_Analyzer(shape)
    chk.SetParallel(True)
    return chk.IsValid()


def _valid(shape, repair: bool):
    """The shape if BRepCheck finds it valid, else (with ``repair``) what ShapeFix makes of it
    if that is valid, else None."""
    if _is_valid(shape):
        return shape
    if not repair:
        return None
    from OCP.ShapeFix import ShapeFix_Shape

    fix = ShapeFix_Shape(shape)
    fix.Perform()
    fixed = _downcast(fix.Shape())
    return fixed if _is_valid(fixed) else None


def _downcast(shape):
    """The OCC shape as its own type (TopoDS_Solid, TopoDS_Compound, ...)."""
    from OCP.TopAbs import TopAbs_COMPOUND, TopAbs_SHELL, TopAbs_SOLID
    from OCP.TopoDS import TopoDS

    cast = {TopAbs_SOLID: TopoDS.Solid, TopAbs_COMPOUND: TopoDS.Compound,
            TopAbs_SHELL: TopoDS.Shell}.get(shape.ShapeType())
    return cast(shape) if cast is not None else shape


def _solids_of(shape) -> list:
    """The OCC solids in a shape."""
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    out, exp = [], TopExp_Explorer(shape, TopAbs_SOLID)
    while exp.More():
        out.append(TopoDS.Solid(exp.Current()))
        exp.Next()
    return out


#: degrees: a slot on a fold flatter than this is cut with one box on the fold's bisector plane
#: (two nearly coplanar boxes make OpenCascade's boolean leave slivers or split the plate)
SINGLE_BOX_FOLD = 20.0

#: fraction of the plate thickness: OpenCascade's fuzzy tolerance for the second try of a slot
#: cut whose exact boolean failed (see :func:`_slotted`)
SLOT_CUT_FUZZY = 0.005


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


def _plate_outlines(part: Part, thickness: float):
    """Every face outline of a part's plate (F, 4, 3) and its orientation sign (F,): per panel
    top (``p + t/2 m``), bottom (same diagonal as the top if warped; sign -1: it is oriented
    inwards), the a side and the b side; then the start and end caps."""
    k = len(part.panels)
    top, bot = slab_faces(part.panels, part.miters, thickness)
    sides = np.stack([top, bot, np.stack([top[:, 1], top[:, 0], bot[:, 0], bot[:, 1]], 1),
                      np.stack([top[:, 3], top[:, 2], bot[:, 2], bot[:, 3]], 1)], axis=1)
    caps = np.array([[top[0, 0], top[0, 3], bot[0, 3], bot[0, 0]],
                     [top[-1, 2], top[-1, 1], bot[-1, 1], bot[-1, 2]]])
    return (np.concatenate([sides.reshape(-1, 4, 3), caps]),
            np.r_[np.tile([1.0, -1.0, 1.0, 1.0], k), 1.0, 1.0])


#: BRepBuilderAPI_Sewing's default tolerance: corners closer than this are one point when sewn
_SEW_TOL = 1e-6


def _fans(pts: np.ndarray, planar_tol: float) -> list:
    """Index lists of the planar pieces of polygons with the same number of corners
    (F, n, 3): the whole polygon if its corners are coplanar (:func:`_coplanar`), else
    triangles inside it (:func:`_triangles_inside`, as :func:`_face`)."""
    n = pts.shape[1]
    planar = np.ones(len(pts), bool) if n == 3 else _coplanar(pts, planar_tol)
    tri = _triangles_inside(pts)
    return [[list(range(n))] if ok else t.tolist() for ok, t in zip(planar, tri)]


def _plate_direct(part: Part, thickness: float, planar_tol: float):
    """The plate of a part built as a B-rep directly: one vertex per distinct corner, one edge
    per pair of corners that bound a face (shared by its two faces), one planar face per
    outline on the plane through its corners (a fan of triangles where the corners are not
    coplanar, as :func:`_face`), all in one shell: no sewing and no shape healing, which find
    nothing to do on these faces and took two thirds of a part's solid. Returns the OCC solid
    (not yet validated) and the volume of the polyhedron (divergence theorem over its faces).
    ValueError where this construction does not give a closed shell (:func:`_plate` then
    sews the faces)."""
    points, loops, normals, centres, volume = _plate_polyhedron(part, thickness, planar_tol)
    return _polyhedron_solid(points, loops, normals, centres), volume


def _plate_polyhedron(part: Part, thickness: float, planar_tol: float):
    """The faces of a part's plate as :func:`_plate_direct` builds them: ``(points (V, 3),
    loops, normals (F, 3), centres (F, 3), volume)``, each loop the corner ids of one planar
    face (sewn order, oriented as the plate's outlines), its unit Newell normal and the mean of
    its corners (the face's plane), and the volume of the polyhedron (divergence theorem;
    negative where the outlines are turned inwards). ValueError where the faces would not
    make a closed shell of distinct corners."""
    outlines, sign = _plate_outlines(part, thickness)
    # the bottom turned round from its first corner (the fan's diagonal stays that of the top)
    outlines[sign < 0] = outlines[sign < 0][:, [0, 3, 2, 1]]
    # distinct corners: coincident points (collapsed corners of degenerate panels) are one vertex
    flat = outlines.reshape(-1, 3)
    if not np.abs(flat).max() < 1e6:
        raise ValueError("coordinates too large for the vertex table")
    _, first, ids = np.unique(np.round(flat / 1e-12).astype(np.int64), axis=0,
                              return_index=True, return_inverse=True)
    ids = ids.reshape(outlines.shape[:2])
    points = flat[first]
    gaps = np.linalg.norm(points[:, None] - points[None], axis=2)
    np.fill_diagonal(gaps, np.inf)
    if gaps.min() <= _SEW_TOL:       # nearly coincident corners: sewing merges them
        raise ValueError("corners closer than the sewing tolerance")
    # the faces as vertex loops: quads with four distinct corners in one go, the others alone
    clean = (ids != np.roll(ids, -1, axis=1)).all(axis=1)
    loops = [ids[f][piece] for f, pieces in zip(np.flatnonzero(clean),
                                                _fans(outlines[clean], planar_tol))
             for piece in pieces]
    for f in np.flatnonzero(~clean):
        loop = np.array([x for i, x in enumerate(ids[f]) if x != ids[f][i - 1]])
        if len(loop) >= 3:
            loops += [loop[piece] for piece in _fans(points[loop][None], planar_tol)[0]]
    sizes = np.array([len(x) for x in loops])
    normals, centres, volume = [], [], 0.0
    for n in np.unique(sizes):                       # polygons of n corners (3 or 4)
        pts = points[np.array([x for x in loops if len(x) == n])]          # (F, n, 3)
        area = 0.5 * _cross(pts, np.roll(pts, -1, axis=1)).sum(axis=1)   # Newell
        normals.append(area)
        centres.append(pts.mean(axis=1))
        volume += float(_polygon_volumes(pts).sum())        # divergence theorem
    order = np.concatenate([np.flatnonzero(sizes == n) for n in np.unique(sizes)])
    normals, centres = np.concatenate(normals), np.concatenate(centres)
    length = np.linalg.norm(normals, axis=1)
    if not (length > 0).all():
        raise ValueError("a degenerate face")
    return points, [loops[f] for f in order], normals / length[:, None], centres, volume


def _polyhedron_solid(points: np.ndarray, loops: list, normals, centres, *, pcurves: bool = True):
    """OCC solid of a closed polyhedron: one vertex per point, one edge per pair of points
    that bound a face (built once, shared by its two faces), one face per loop of point ids
    on the plane through its centre with its normal (the loop runs counter-clockwise about
    it), all in one shell. ValueError where the faces do not close.

    With ``pcurves`` each edge's curve on each of its faces' planes is stored with the edge:
    the curve OpenCascade otherwise projects again every time it is asked for (BRepCheck,
    the volume, the point classifier, the mesher: half of their time), computed by the same
    call, so meshes are the same triangle for triangle; the STEP files are written without
    them (the same bytes)."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.BRepBuilderAPI import (BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeFace,
                                    BRepBuilderAPI_MakeVertex)
    from OCP.BRepLib import BRepLib
    from OCP.gp import gp_Dir, gp_Pln, gp_Pnt
    from OCP.TopoDS import TopoDS, TopoDS_Shell, TopoDS_Solid, TopoDS_Wire

    builder = BRep_Builder()
    vertices = [BRepBuilderAPI_MakeVertex(gp_Pnt(*map(float, x))).Vertex() for x in points]
    edges: dict = {}

    def edge(i: int, j: int):
        """The edge i -> j (shared: built once, from the lower vertex id)."""
        a, b = (i, j) if i < j else (j, i)
        e = edges.get((a, b))
        if e is None:
            e = edges[(a, b)] = BRepBuilderAPI_MakeEdge(vertices[a], vertices[b]).Edge()
        return e if i < j else TopoDS.Edge(e.Reversed())

    shell = TopoDS_Shell()
    builder.MakeShell(shell)
    for loop, n, c in zip(loops, np.asarray(normals).tolist(), np.asarray(centres).tolist()):
        loop = [int(x) for x in loop]
        wire = TopoDS_Wire()
        builder.MakeWire(wire)
        sides = [edge(i, j) for i, j in zip(loop, loop[1:] + loop[:1])]
        for e in sides:
            builder.Add(wire, e)
        wire.Closed(True)
        mk = BRepBuilderAPI_MakeFace(gp_Pln(gp_Pnt(*c), gp_Dir(*n)), wire, True)
        if not mk.IsDone():
            raise ValueError(f"a face is not made: {mk.Error()}")
        face = mk.Face()
        for e in sides if pcurves else ():
            BRepLib.BuildPCurveForEdgeOnPlane_s(e, face)
        builder.Add(shell, face)
    if not BRep_Tool.IsClosed_s(shell):
        raise ValueError("the faces do not close")
    shell.Closed(True)
    solid = TopoDS_Solid()
    builder.MakeSolid(solid)
    builder.Add(solid, shell)
    return solid


def _plate(part: Part, thickness: float, planar_tol: float):
    """The plate of a part as a closed OCC solid (not yet validated) and the volume of the
    polyhedron it is built from (divergence theorem over its faces): built directly
    (:func:`_plate_direct`), else its faces sewn."""
    try:
        return _plate_direct(part, thickness, planar_tol)
    except ValueError:
        return _plate_sewn(part, thickness, planar_tol)


def _plate_sewn(part: Part, thickness: float, planar_tol: float):
    """:func:`_plate` by sewing faces made one by one (:func:`_face`)."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Sewing
    from OCP.ShapeFix import ShapeFix_Solid
    from OCP.TopoDS import TopoDS

    outlines, sign = _plate_outlines(part, thickness)
    # outlines without repeated corners (all but degenerate twisted sides) in one go
    clean = (np.linalg.norm(outlines - np.roll(outlines, -1, axis=1), axis=2) > 1e-12).all(axis=1)
    planar = np.zeros(len(outlines), bool)
    planar[clean] = _coplanar(outlines[clean], planar_tol)
    poly_volume = float(sign[clean] @ _polygon_volumes(outlines[clean]))
    sewing = BRepBuilderAPI_Sewing()
    for pts, sgn, ok, flat in zip(outlines, sign, clean, planar):
        for f in _face(pts, planar_tol, planar=bool(flat) if ok else None):
            sewing.Add(f)
        if not ok:
            poly_volume += sgn * _fan_volume(pts)
    sewing.Perform()
    try:
        shell = TopoDS.Shell(sewing.SewedShape())
    except Exception as e:           # a compound of pieces: OCC's Standard_TypeMismatch
        raise InvalidSolidError([part.name], f"the plate's faces do not sew into one shell "
                                f"({type(e).__name__})") from None
    if not BRep_Tool.IsClosed_s(shell):
        raise InvalidSolidError([part.name], "the plate's faces do not sew into a closed shell")
    return ShapeFix_Solid().SolidFromShell(shell), poly_volume


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
    n_tri = np.array([len(x) for x in loops]) - 2
    first = np.repeat([x[0] for x in loops], n_tri)
    mid = np.concatenate([x[1:-1] for x in loops])
    last = np.concatenate([x[2:] for x in loops])
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


#: model units (``unit``): the direct slot cut (:func:`_cut_polyhedron`) declines, leaving the
#: part to OpenCascade's boolean (whose tolerance is 1e-7), where a corner lies this near a
#: plane it is cut by, or two corners of the result lie this near each other
_DIRECT_GAP = 1e-6

#: model units: the copies of one corner computed in the planes of its faces are one vertex
#: within this distance
_DIRECT_MERGE = 1e-8

#: radians: faces of two boxes this near one plane make the direct cut decline unless they are
#: on one plane to 1e-12 (the bottoms of a slot's two boxes: one face)
_DIRECT_PARALLEL = 1e-6

#: radians: adjacent faces of the result this near parallel make the direct cut decline:
#: OpenCascade's face unification merges faces parallel to 1e-12 (and 1e-7 apart), and the
#: faces in between are left to it (the two triangles of a warped panel are 2e-9 apart on
#: example 7a, and stay two faces either way)
_DIRECT_SAME_PLANE = 1e-10


class _Decline(ValueError):
    """The direct slot cut does not apply to a part (a degenerate or unexpected configuration):
    the boolean cuts it."""


def _plane_axes(n: np.ndarray) -> np.ndarray:
    """Unit axes (..., 2, 3) ``e1, e2`` of planes with the unit normals ``n`` (..., 3),
    ``e1 x e2 = n``: ``e1`` is ``n`` crossed with the coordinate axis it is least along."""
    n = np.asarray(n, float)
    least = np.argmin(np.abs(n), axis=-1)
    e1 = _cross(n, np.eye(3)[least])
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    return np.stack([e1, _cross(n, e1)], axis=-2)


_BITS = (np.arange(8)[:, None] >> np.arange(3)) & 1               # corner i: bit k along axis k
_BOX_EDGES = np.array([(i, i | 1 << k) for k in range(3) for i in range(8) if not i >> k & 1])
# each face (axis k, side) as a cycle of corner ids
_BOX_FACES = np.array([[int(np.flatnonzero((_BITS[:, k] == side) & (_BITS[:, p] == bp)
                                           & (_BITS[:, q] == bq))[0])
                        for bp, bq in ((0, 0), (1, 0), (1, 1), (0, 1))]
                       for k, p, q in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) for side in (0, 1)])


def _box_geometry(frames: list):
    """Corners (B, 8, 3) and unit axes (B, 3, 3) of the boxes that :func:`_box` makes of
    ``frames`` (OpenCascade's axes: z along ``z_dir``, x the part of ``x_dir`` square to it,
    y = z x x; corner i at ``origin + bit0 length x + bit1 width y + bit2 height z``)."""
    origin, x_dir, z_dir = (np.array([f[i] for f in frames], float) for i in range(3))
    size = np.array([f[3:6] for f in frames], float)
    z = z_dir / np.linalg.norm(z_dir, axis=1, keepdims=True)
    x = x_dir - np.einsum("bi,bi->b", x_dir, z)[:, None] * z
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    axes = np.stack([x, _cross(z, x), z], axis=1)
    return origin[:, None] + np.einsum("ck,bk,bki->bci", _BITS, size, axes), axes


def _rings(xy: np.ndarray, sizes) -> np.ndarray:
    """Shapely polygons of consecutive rings of ``xy`` (N, 2) with ``sizes`` corners each."""
    import shapely

    sizes = np.asarray(sizes)
    return shapely.polygons(shapely.linearrings(xy, indices=np.repeat(np.arange(len(sizes)), sizes)))


def _box_sections(corners: np.ndarray, normals: np.ndarray, offsets: np.ndarray,
                  origins: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """The sections of boxes (corners (P, 8, 3)) by planes ``x.n = d`` (``normals`` (P, 3),
    ``offsets`` (P,)), pair by pair, as shapely polygons (P,) in the planes' frames
    (``origins`` (P, 3), ``axes`` (P, 2, 3)); None where a plane misses its box."""
    s = np.einsum("pci,pi->pc", corners, normals) - offsets[:, None]
    if (np.abs(s) <= _DIRECT_GAP).any():
        raise _Decline("a box corner on a plane it is cut by")
    i, j = _BOX_EDGES.T
    si, sj = s[:, i], s[:, j]
    hit = si * sj < 0                                                      # (P, 12)
    t = np.where(hit, si / np.where(hit, si - sj, 1.0), 0.0)
    p = corners[:, i] + t[..., None] * (corners[:, j] - corners[:, i])
    xy = np.einsum("pei,pki->pek", p - origins[:, None], axes)              # (P, 12, 2)
    count = hit.sum(axis=1)
    centre = (xy * hit[..., None]).sum(axis=1) / np.maximum(count, 1)[:, None]
    angle = np.where(hit, np.arctan2(xy[..., 1] - centre[:, None, 1], xy[..., 0] - centre[:, None, 0]),
                     np.inf)
    xy = np.take_along_axis(xy, np.argsort(angle, axis=1)[..., None], axis=1)
    out = np.full(len(s), None, object)
    ok = count > 0
    if ok.any():
        out[ok] = _rings(xy[ok][np.arange(12)[None] < count[ok][:, None]], count[ok])
    return out


class _Edges:
    """The edges of a closed polyhedron's faces (``loops`` of point ids): per directed edge
    its corners ``a -> b``, its face and the id of the undirected edge."""

    def __init__(self, loops: list):
        self.sizes = np.array([len(x) for x in loops])
        self.starts = np.r_[0, np.cumsum(self.sizes)[:-1]]
        self.face = np.repeat(np.arange(len(loops)), self.sizes)
        self.a = np.concatenate(loops)
        nxt = np.arange(1, len(self.a) + 1)
        nxt[self.starts + self.sizes - 1] = self.starts          # each loop's last corner -> first
        self.b = self.a[nxt]
        lo, hi = np.minimum(self.a, self.b), np.maximum(self.a, self.b)
        _, self.uid = np.unique(lo * (hi.max() + 1) + hi, return_inverse=True)


def _polyhedron_section(points: np.ndarray, edges: _Edges, normals: np.ndarray, n, s,
                        origin, axes) -> list:
    """The section of a closed polyhedron (``points``, the ``edges`` of its outward faces, their
    unit ``normals``) by a plane of normal ``n`` (``s``: the signed distances of the points
    from it) as shapely polygons in the plane's frame (``origin``, ``axes`` (2, 3)): the
    segments the faces cut from the plane, chained by the edges they cross."""
    hit = np.flatnonzero(s[edges.a] * s[edges.b] < 0)          # in face order
    if not len(hit):
        return []
    lo, hi = np.minimum(edges.a[hit], edges.b[hit]), np.maximum(edges.a[hit], edges.b[hit])
    t = s[lo] / (s[lo] - s[hi])          # from the lower id: one point per undirected edge
    xyz = points[lo] + t[:, None] * (points[hi] - points[lo])
    uid, face = edges.uid[hit], edges.face[hit]
    counts = np.bincount(face)
    if (counts % 2).any():
        raise _Decline("a face crosses a plane an odd number of times")
    if (counts > 2).any():           # a face that is not convex: pair the points along the line
        order = []
        for f in np.flatnonzero(counts):
            idx = np.flatnonzero(face == f)
            if len(idx) > 2:
                idx = idx[np.argsort(xyz[idx] @ np.cross(n, normals[f]))]
            order += idx.tolist()
        pairs = np.array(order).reshape(-1, 2)
    else:
        pairs = np.arange(len(hit)).reshape(-1, 2)
    links: dict = {}
    point: dict = {}
    for i, j in pairs.tolist():
        a, b = int(uid[i]), int(uid[j])
        links.setdefault(a, []).append(b)
        links.setdefault(b, []).append(a)
        point[a], point[b] = i, j
    if any(len(v) != 2 for v in links.values()):
        raise _Decline("the section of the plate does not chain into loops")
    xy = (xyz - origin) @ axes.T
    rings, seen = [], set()
    for start in links:
        if start in seen:
            continue
        ring, prev, cur = [], None, start
        while cur not in seen:
            seen.add(cur)
            ring.append(point[cur])
            a, b = links[cur]
            prev, cur = cur, (b if a == prev else a)
        rings.append(ring)
    polys = list(_rings(xy[np.concatenate(rings)], [len(r) for r in rings]))
    for i, a in enumerate(polys):
        if not a.is_valid or any(a.intersects(b) for b in polys[i + 1:]):
            raise _Decline("the section of the plate is not a set of disjoint polygons")
    return polys


def _box_planes(normals: np.ndarray, corners: np.ndarray) -> list:
    """The faces of boxes (unit ``normals`` (B, 3, 3) of their axes, ``corners`` (B, 8, 3)) by
    plane: ``(outward normal, offset, [(box, face)])``; faces of several boxes that meet on
    one plane to 1e-12 (the bottoms of a slot's two boxes) share one. :class:`_Decline` where
    faces of two boxes that meet are nearly on one plane, or on one plane facing each other."""
    n = np.concatenate([[(2 * side - 1) * a[k] for k in range(3) for side in (0, 1)] for a in normals])
    face = corners[np.arange(len(n)) // 6][np.arange(len(n))[:, None], _BOX_FACES[np.arange(len(n)) % 6]]
    d = np.einsum("fi,fi->f", n, face[:, 0])
    sin = np.linalg.norm(_cross(n[:, None], n[None]), axis=2)
    cos = n @ n.T
    apart = np.abs(d[:, None] - np.where(cos > 0, 1.0, -1.0) * d[None]) >= _DIRECT_GAP
    lo, hi = face.min(axis=1) - _DIRECT_GAP, face.max(axis=1) + _DIRECT_GAP
    meet = ((lo[:, None] <= hi[None]) & (hi[:, None] >= lo[None])).all(axis=2)    # bounding boxes
    near = (sin < _DIRECT_PARALLEL) & ~apart & meet
    np.fill_diagonal(near, False)
    groups, member = [], {}
    for i in range(len(n)):
        j = next((j for j in np.flatnonzero(near[i]) if j < i), None)
        if j is None:
            member[i] = len(groups)
            groups.append((n[i], d[i], [divmod(i, 6)]))
            continue
        if not (cos[i, j] > 0 and sin[i, j] <= 1e-12):
            raise _Decline("box faces nearly on one plane")
        member[i] = member[j]
        groups[member[j]][2].append(divmod(i, 6))
    return groups


def _cut_polyhedron(points: np.ndarray, loops: list, normals: np.ndarray, centres: np.ndarray,
                    frames: list):
    """A closed polyhedron (``points`` (V, 3), ``loops`` of point ids oriented outwards, unit
    ``normals`` and ``centres`` of their planes) less the boxes of ``frames`` (arguments of
    :func:`_box`), computed face by face in the faces' planes: each face less the boxes'
    sections by its plane, and each box face (coplanar box faces together) within the
    polyhedron's section by its plane, less the other boxes'. Faces no box reaches are kept as
    they are; the result's faces are whole (no two adjacent faces on one plane, no vertex
    between two collinear edges of the same two faces), as OpenCascade's boolean cut followed
    by face unification leaves them. Returns ``(points, loops, normals, centres, volume)``;
    :class:`_Decline` where a corner lies on a plane it is cut by, faces are nearly coplanar
    or the result is not one closed shell."""
    import shapely

    corners, box_axes = _box_geometry(frames)
    edges = _Edges(loops)
    # the faces a box reaches: its corners on both sides of the face's plane, and the face
    # within the box's extent along each of its axes (separating axes); the others are kept
    offsets = np.einsum("fi,fi->f", normals, centres)
    s = np.einsum("fi,bci->fbc", normals, corners) - offsets[:, None, None]          # (F, B, 8)
    extent = np.einsum("bki,bi->bk", box_axes, corners[:, 7] - corners[:, 0])
    local = np.einsum("bki,bvi->bvk", box_axes, points - corners[:, None, 0])         # (B, V, 3)
    f_lo = np.minimum.reduceat(local[:, edges.a], edges.starts, axis=1)              # (B, F, 3)
    f_hi = np.maximum.reduceat(local[:, edges.a], edges.starts, axis=1)
    within = ((f_lo < extent[:, None] + _DIRECT_GAP) & (f_hi > -_DIRECT_GAP)).all(axis=2).T  # (F, B)
    if (within & (np.abs(s) <= _DIRECT_GAP).any(axis=2)).any():
        raise _Decline("a box corner on a plane it cuts")
    reach = within & (s.min(axis=2) < 0) & (s.max(axis=2) > 0)
    face_axes = _plane_axes(normals)                                                 # (F, 2, 3)
    # the new faces: shapely regions, each with the face it replaces (plate faces: their
    # index; box planes: len(loops) + their number) and its plane (normal, origin, axes)
    regions, owners, planes = [], [], {}
    f_cut, b_cut = np.nonzero(reach)                # by face
    if len(f_cut):
        cuts = _box_sections(corners[b_cut], normals[f_cut], offsets[f_cut], centres[f_cut],
                             face_axes[f_cut])
        hit, first, count = np.unique(f_cut, return_index=True, return_counts=True)
        cut = cuts[first]
        for k in np.flatnonzero(count > 1):
            cut[k] = shapely.union_all(cuts[first[k]:first[k] + count[k]])
        uv = np.einsum("ei,eki->ek", points[edges.a] - centres[edges.face], face_axes[edges.face])
        faces = _rings(uv[np.isin(edges.face, hit)], edges.sizes[hit])
        touch = shapely.intersects(faces, cut)
        regions += list(shapely.difference(faces[touch], cut[touch]))
        owners += hit[touch].tolist()
        planes.update((int(f), (normals[f], centres[f], face_axes[f])) for f in hit[touch])
    # the box faces by plane, within the plate's section by it and outside the other boxes
    box_lo, box_hi = corners.min(axis=1), corners.max(axis=1)
    for g, (gn, gd, members) in enumerate(_box_planes(box_axes, corners)):
        s = points @ gn - gd
        crossing = np.unique(edges.face[s[edges.a] * s[edges.b] < 0])
        mine = np.zeros(len(corners), bool)
        mine[[bi for bi, _ in members]] = True
        if not within[crossing][:, mine].any():
            continue                # no face crosses the plane within the box
        if (np.abs(s) <= _DIRECT_GAP).any():
            raise _Decline("a corner of the plate on a box face's plane")
        n = -gn                                     # the result's face looks into the box
        c = gd * gn
        axes = _plane_axes(n)
        rect = corners[[bi for bi, _ in members]][np.arange(len(members))[:, None],
                                                  _BOX_FACES[[fi for _, fi in members]]]
        rect = _rings(((rect - c) @ axes.T).reshape(-1, 2), [4] * len(members))
        section = _polyhedron_section(points, edges, normals, n, s, c, axes)
        if not section:
            continue
        region = shapely.intersection(rect[0] if len(rect) == 1 else shapely.union_all(rect),
                                      section[0] if len(section) == 1 else shapely.union_all(section))
        if region.is_empty:
            continue
        others = np.flatnonzero(~mine & (box_lo <= box_hi[mine].max(axis=0)).all(axis=1)
                                & (box_hi >= box_lo[mine].min(axis=0)).all(axis=1))
        if len(others):
            k = len(others)
            x = _box_sections(corners[others], np.tile(n, (k, 1)), np.full(k, float(n @ c)),
                              np.tile(c, (k, 1)), np.tile(axes, (k, 1, 1)))
            x = [y for y in x if y is not None]
            if x:
                region = shapely.difference(region, x[0] if len(x) == 1 else shapely.union_all(x))
        regions.append(region)
        owners.append(len(loops) + g)
        planes[len(loops) + g] = (n, c, axes)
    return _whole_faces(points, loops, normals, centres, regions, owners, planes)


def _pieces(regions: list, owners: list, planes: dict):
    """The polygons of shapely ``regions`` (in their planes' frames) as 3D corner loops:
    ``(corners (M, 3), sizes, owner of each loop)``, each loop counter-clockwise about its
    plane's normal, without the closing repeat. :class:`_Decline` where a region has a hole."""
    import shapely

    parts, which = shapely.get_parts(np.array(regions, object), return_index=True)
    keep = (shapely.get_type_id(parts) == 3) & (shapely.area(parts) > 0)
    parts, which = parts[keep], which[keep]
    if (shapely.get_num_interior_rings(parts) > 0).any():
        raise _Decline("a face with a hole")
    xy, ring = shapely.get_coordinates(shapely.get_exterior_ring(parts), return_index=True)
    sizes = np.bincount(ring, minlength=len(parts))
    starts = np.r_[0, np.cumsum(sizes)[:-1]]
    # the shoelace sum of each ring (closed by its repeated first point): clockwise ones turn
    step = xy[:-1, 0] * xy[1:, 1] - xy[1:, 0] * xy[:-1, 1]
    area = np.add.reduceat(np.r_[step, 0.0] * (np.r_[ring[1:] == ring[:-1], False]), starts)
    last = np.ones(len(xy), bool)
    last[starts + sizes - 1] = False              # drop each ring's closing repeat
    order = np.arange(len(xy))
    for k in np.flatnonzero(area < 0):
        order[starts[k]:starts[k] + sizes[k] - 1] = order[starts[k]:starts[k] + sizes[k] - 1][::-1]
    xy, ring = xy[order][last], ring[last]
    owner = np.asarray(owners)[which]
    origin, axes = (np.array([planes[o][i] for o in owner]) for i in (1, 2))
    xyz = origin[ring] + np.einsum("mk,mki->mi", xy, axes[ring])
    return xyz, sizes - 1, owner


def _whole_faces(points: np.ndarray, loops: list, normals: np.ndarray, centres: np.ndarray,
                 regions: list, owners: list, planes: dict):
    """The polyhedron of :func:`_cut_polyhedron`: the faces of ``loops`` not in ``owners``
    as they are, the others replaced by the polygons of their ``regions``, then the box faces'
    (:func:`_pieces`). Corners within :data:`_DIRECT_MERGE` are one vertex, a vertex of fewer
    than three faces is dropped (it lies on a straight edge: :func:`_straightened`), and the
    result is checked to be one closed, oriented shell of distinct corners whose adjacent faces
    are not on one plane. Returns ``(points, loops, normals, centres, volume)``, the volume by
    the divergence theorem."""
    xyz, sizes, owner = (_pieces(regions, owners, planes) if regions
                         else (np.zeros((0, 3)), np.zeros(0, int), np.zeros(0, int)))
    extra = np.zeros((0, 3))
    ids = np.zeros(0, int)
    if len(xyz):                    # the new faces' corners: a corner of the plate, or new
        diff = xyz[:, None] - points[None]
        d2 = np.einsum("mvi,mvi->mv", diff, diff)
        ids = np.argmin(d2, axis=1)
        fresh = np.flatnonzero(d2[np.arange(len(xyz)), ids] > _DIRECT_MERGE ** 2)
        if len(fresh):
            diff = xyz[fresh][:, None] - xyz[fresh][None]
            same = np.einsum("mni,mni->mn", diff, diff) <= _DIRECT_MERGE ** 2
            first = np.argmax(same, axis=1)           # the first copy of each new corner
            kept, which = np.unique(first, return_inverse=True)
            ids[fresh] = len(points) + which.ravel()
            extra = xyz[fresh][kept]
    new = np.split(ids, np.cumsum(sizes)[:-1]) if len(sizes) else []
    out, out_n, out_c = [], [], []
    pieces = iter(zip(new, owner.tolist()))
    piece = next(pieces, None)
    for f in range(len(loops) + max(planes, default=0) + 1):
        if f < len(loops) and f not in planes:
            out.append(list(map(int, loops[f])))
            out_n.append(normals[f])
            out_c.append(centres[f])
        while piece is not None and piece[1] == f:
            out.append(piece[0].tolist())
            out_n.append(planes[f][0])
            out_c.append(planes[f][1])
            piece = next(pieces, None)
    loops = out
    pts = np.concatenate([points, extra])
    if any(len(set(x)) != len(x) for x in loops):
        raise _Decline("two corners of a face are one vertex")
    # a vertex of fewer than three faces lies on a straight edge: not a vertex (one where two
    # boxes' notches meet on a face, one between two faces' collinear edges)
    count = np.bincount(np.concatenate(loops), minlength=len(pts))
    if (count < 3).any():
        loops = [_straightened(loop, count >= 3, pts) for loop in loops]
    # every edge once in each sense, between faces not on one plane; one shell
    e = _Edges(loops)
    key = e.a * len(pts) + e.b
    order = np.argsort(key)
    if (np.diff(key[order]) == 0).any():
        raise _Decline("an edge used twice in one sense")
    at = np.searchsorted(key[order], e.b * len(pts) + e.a)
    at = np.minimum(at, len(key) - 1)
    if not (key[order][at] == e.b * len(pts) + e.a).all():
        raise _Decline("the faces do not close")
    other = e.face[order][at]
    normals, centres = np.array(out_n), np.array(out_c)
    if (np.linalg.norm(_cross(normals[e.face], normals[other]), axis=1) < _DIRECT_SAME_PLANE).any():
        raise _Decline("adjacent faces (nearly) on one plane")
    # one shell: every face reached from the first across its edges
    label = np.arange(len(loops))
    while True:
        low = np.minimum(label[e.face], label[other])
        nxt = label.copy()
        np.minimum.at(nxt, e.face, low)
        nxt = nxt[nxt]                              # jump along the chains of labels
        if (nxt == label).all():
            break
        label = nxt
    if (label != 0).any():
        raise _Decline("the result is in pieces")
    used = np.unique(e.a)
    diff = pts[used][:, None] - pts[used][None]
    gaps = np.einsum("mni,mni->mn", diff, diff)
    np.fill_diagonal(gaps, np.inf)
    if gaps.min() <= _DIRECT_GAP ** 2:
        raise _Decline("corners of the result too near each other")
    new_id = np.full(len(pts), -1)
    new_id[used] = np.arange(len(used))
    loops = [new_id[loop] for loop in loops]
    pts = pts[used]
    # the volume (divergence theorem: a fan from each face's first corner)
    ref = pts.mean(axis=0)
    n_tri = np.array([len(x) for x in loops]) - 2
    first = np.repeat([x[0] for x in loops], n_tri)
    mid = np.concatenate([x[1:-1] for x in loops])
    last = np.concatenate([x[2:] for x in loops])
    q0, q1, q2 = pts[first] - ref, pts[mid] - ref, pts[last] - ref
    volume = float(np.einsum("ki,ki->", q0, _cross(q1, q2))) / 6.0
    return pts, loops, normals, centres, volume


def _straightened(loop: list, keep: np.ndarray, pts: np.ndarray) -> list:
    """The corners of a face's ``loop`` that ``keep`` keeps; :class:`_Decline` unless every
    corner dropped lies on the straight edge between the corners kept before and after it
    (within :data:`_DIRECT_MERGE`), and three corners are left."""
    kept = [i for i, x in enumerate(loop) if keep[x]]
    if len(kept) < 3:
        raise _Decline("a face of fewer than three corners")
    if len(kept) == len(loop):
        return loop
    for k, i in enumerate(kept):                   # the corners between kept i and the next
        j = kept[(k + 1) % len(kept)]
        between = [loop[m % len(loop)] for m in range(i + 1, j if j > i else j + len(loop))]
        if between:
            a, b = pts[loop[i]], pts[loop[j]]
            d = (b - a) / np.linalg.norm(b - a)
            off = pts[between] - a
            along = off @ d
            if (np.linalg.norm(off - along[:, None] * d, axis=1) > _DIRECT_MERGE).any() or \
                    (along <= 0).any() or (along >= np.linalg.norm(b - a)).any():
                raise _Decline("a corner of fewer than three faces off its face's edge")
    return [loop[i] for i in kept]


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


def _face_triangles(shape, tolerance: float, angular_tolerance: float = 0.1, *,
                    threads: bool = True) -> list:
    """``[(vertices (k, 3), triangles (m, 3) into them)]`` per face of an OCC shape, meshed as
    build123d's ``Shape.tessellate`` does (BRepMesh to ``tolerance``, faces in explorer
    order, reversed faces' triangles turned round, so every triangle faces out).
    ``threads=False`` in forked processes (see :func:`_mesh`)."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    _mesh(shape, tolerance, angular_tolerance, threads=threads)
    faces, exp = {}, TopExp_Explorer(shape, TopAbs_FACE)
    while exp.More():                        # each face once, in the order first met
        faces[hash(exp.Current())] = exp.Current()
        exp.Next()
    out = []
    for f in faces.values():
        face = TopoDS.Face(f)
        loc = TopLoc_Location()
        poly = BRep_Tool.Triangulation_s(face, loc)
        pts = [poly.Node(j) for j in range(1, poly.NbNodes() + 1)]
        if not loc.IsIdentity():
            trsf = loc.Transformation()
            pts = [p.Transformed(trsf) for p in pts]
        v = np.array([(p.X(), p.Y(), p.Z()) for p in pts], float).reshape(-1, 3)
        # one triangle at a time: poly.Triangles() copies the whole array on every call
        t = np.array([poly.Triangle(i).Get() for i in range(1, poly.NbTriangles() + 1)],
                     dtype=np.int64).reshape(-1, 3) - 1
        out.append((v, t[:, [0, 2, 1]] if face.Orientation() == TopAbs_REVERSED else t))
    return out


def _triangles(shape, tolerance: float, angular_tolerance: float = 0.1, *, threads: bool = True):
    """Vertices (n, 3) and triangles (m, 3) of an OCC shape: its faces' triangles
    (:func:`_face_triangles`) in one array, vertices not shared between faces."""
    faces = _face_triangles(shape, tolerance, angular_tolerance, threads=threads)
    if not faces:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    offsets = np.cumsum([0] + [len(v) for v, _ in faces[:-1]])
    return (np.concatenate([v for v, _ in faces]),
            np.concatenate([t + o for (_, t), o in zip(faces, offsets)]))


#: preview meshes (3DM, glTF, STL): deflection as a fraction of the plate thickness
MESH_TOLERANCE = 0.05


def _mesh(shape, tolerance: float, angular_tolerance: float = 0.1, *, threads: bool = True) -> None:
    """Mesh an OCC shape (BRepMesh, deflection relative to the edge size; ``threads``: one per
    face in parallel, the same triangles) unless it has a triangulation that fine.

    A forked process must pass ``threads=False``: OpenCascade's thread pool, once started
    in the parent (e.g. by the 3DM export), has no threads in the child, and a parallel mesh
    there waits for them for ever (7c's assembly check hung so, 2026-11-26)."""
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.BRepTools import BRepTools

    if not BRepTools.Triangulation_s(shape, tolerance):
        BRepMesh_IncrementalMesh(shape, tolerance, True, angular_tolerance, threads)
