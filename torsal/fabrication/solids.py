"""Solid parts (OpenCascade) and their export: STEP, STL/glTF, 3DM (issue 6).

Every part is thickened about its mid-plane by ``thickness``: the plate is a closed
polyhedral shell (top face ``p + t/2 m``, bottom ``p - t/2 m`` with the mitre vectors ``m``
of :class:`~.parts.Part`, side faces along the ``a`` and ``b`` edges, end caps) built as one
B-rep (shared vertices and edges, each face on the plane of its corners; the faces are sewn
only where corners nearly coincide): folds are mitred on the bisector plane, so no boolean
fuse is needed and the plate volume equals ``sum(panel area) * thickness`` up to the twist of
side faces. Egg-crate slots are then cut with one boolean per part (a box per panel touching
the slot, centred on the node line, ``thickness + clearance`` wide, through the plate).

Every solid is checked with BRepCheck (build123d's ``is_valid``); an invalid one is repaired
with ``ShapeFix`` and if it stays invalid an :class:`InvalidSolidError` names the part:
nothing is written silently. The slots are checked too (the cut must remove the slot area of
the unrolled part times the thickness); where OpenCascade cannot cut them (thin, oblique
plates of real structures) the sound plate is kept without them, listed in
``FinSystem.unslotted_solids`` and warned about (the unrolled cutting outlines always have
the slots).

Everything here is OpenCascade through OCP directly (the calls build123d makes, without its
wrappers): worker processes (:func:`start_solids`, :func:`prepare_workers`) build the solids
and send them back as binary BReps, with their preview meshes if asked; the STEP, 3DM and
mesh exports work on those shapes (:func:`solid_shapes`). build123d (2 s to import) is used
only for the labelled ``Solid`` objects of :func:`build_solids` / ``FinSystem.solids()``.

Units: the ``unit`` of the fin system (mm by default); STEP files are written in mm.
"""
from __future__ import annotations

import threading
from pathlib import Path

import numpy as np

from torsal.core.atomic import atomic_path
from torsal.core.parallel import usable_workers

from .model import CONNECTOR_FAMILY, FIXING_FAMILY, Part, SlotSide, quad_normals
from .unroll import unroll
from torsal.core.errors import TorsalError

__all__ = ["InvalidSolidError", "SlotCutError", "part_solid", "build_solids", "start_solids",
           "solid_shapes", "write_step", "prepare_workers", "release_workers",
           "PendingSolids", "default_workers",
           "export_step", "export_mesh", "export_3dm", "read_step"]


class InvalidSolidError(TorsalError, RuntimeError):
    """A part's solid is not valid OpenCascade geometry even after repair."""

    def __init__(self, parts: list[str], detail: str = ""):
        self.parts = parts
        super().__init__(f"invalid solid for part(s) {', '.join(parts)}" + (f": {detail}" if detail else ""))


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
    """OCC faces through the points: one planar face, or a fan of triangles if they are not
    coplanar (to ``min(planar_tol * size, 1e-9)`` in absolute units, below OpenCascade's
    1e-7). ``planar``: that test, done already (by :func:`_coplanar`) for points without
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
    return [_polygon_face(pts[[0, i, i + 1]]) for i in range(1, len(pts) - 1)]


def _coplanar(pts: np.ndarray, planar_tol: float) -> np.ndarray:
    """Whether each polygon of ``pts`` (F, n, 3) is within ``min(planar_tol * size, 1e-9)`` of
    its best-fit plane (size: its bounding-box diagonal)."""
    c = pts.mean(axis=1, keepdims=True)
    normal = np.linalg.svd(pts - c)[2][:, 2]                                  # (F, 3)
    size = np.linalg.norm(pts.max(axis=1) - pts.min(axis=1), axis=1)
    off = np.abs(np.einsum("fni,fi->fn", pts - c, normal)).max(axis=1)
    return off <= np.minimum(planar_tol * size, 1e-9)


def _fan_volume(points) -> float:
    """Signed volume contribution (divergence theorem) of a face as :func:`_face` builds it:
    repeated points dropped, a fan of triangles from the first point."""
    pts = _dedup(points)
    if len(pts) < 3:
        return 0.0
    return float(np.einsum("j,ij->", pts[0], np.cross(pts[1:-1], pts[2:])) / 6.0)


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


def slot_boxes(part: Part, thickness: float) -> list:
    """Cutting boxes of the slots of a part: per panel adjacent to the slotted node line, a box
    in the panel plane centred on the node line, ``width`` wide, from ``2 width`` outside the
    open edge to ``depth`` inside, ``2 thickness`` through the plate. On a fold flatter than
    :data:`SINGLE_BOX_FOLD` one box on the bisector plane, ``width cos(fold/2)`` wide (so the
    slot is ``width`` wide in both panels)."""
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
                boxes.append(_box(corner, uu, n, over + s.depth, w, 2.0 * thickness))
                continue
        for j in (pos - 1, pos):
            if not 0 <= j < k:
                continue
            n = normals[j]
            v = np.cross(n, u)
            corner = start - over * u - 0.5 * s.width * v - thickness * n
            boxes.append(_box(corner, u, n, over + s.depth, s.width, 2.0 * thickness))
    return boxes


def _plate_outlines(part: Part, thickness: float):
    """Every face outline of a part's plate (F, 4, 3) and its orientation sign (F,): per panel
    top (``p + t/2 m``), bottom (same diagonal as the top if warped; sign -1: it is oriented
    inwards), the a side and the b side; then the start and end caps."""
    q, m = part.panels, part.miters
    k = len(q)
    # node index of each quad corner: 0, 3 -> j; 1, 2 -> j + 1
    node = np.arange(k)[:, None] + np.array([0, 1, 1, 0])
    top = q + 0.5 * thickness * m[node]
    bot = q - 0.5 * thickness * m[node]
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
    (F, n, 3): the whole polygon if its corners are coplanar (:func:`_coplanar`), else a fan of
    triangles from its first corner (as :func:`_face`)."""
    n = pts.shape[1]
    planar = np.ones(len(pts), bool) if n == 3 else _coplanar(pts, planar_tol)
    fan = [[0, i, i + 1] for i in range(1, n - 1)]
    return [[list(range(n))] if ok else fan for ok in planar]


def _plate_direct(part: Part, thickness: float, planar_tol: float):
    """The plate of a part built as a B-rep directly: one vertex per distinct corner, one edge
    per pair of corners that bound a face (shared by its two faces), one planar face per
    outline on the plane through its corners (a fan of triangles where the corners are not
    coplanar, as :func:`_face`), all in one shell: no sewing and no shape healing, which find
    nothing to do on these faces and took two thirds of a part's solid. Returns the OCC solid
    (not yet validated) and the volume of the polyhedron (divergence theorem over its faces).
    ValueError where this construction does not give a closed shell (:func:`_plate` then
    sews the faces)."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.BRepBuilderAPI import (BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeFace,
                                    BRepBuilderAPI_MakeVertex)
    from OCP.gp import gp_Dir, gp_Pln, gp_Pnt
    from OCP.TopoDS import TopoDS, TopoDS_Shell, TopoDS_Solid, TopoDS_Wire

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
        area = 0.5 * np.cross(pts, np.roll(pts, -1, axis=1)).sum(axis=1)   # Newell
        normals.append(area)
        centres.append(pts.mean(axis=1))
        # divergence theorem: fan of triangles from the first corner
        volume += float(np.einsum("fi,fki->", pts[:, 0], np.cross(pts[:, 1:-1], pts[:, 2:])) / 6.0)
    order = np.concatenate([np.flatnonzero(sizes == n) for n in np.unique(sizes)])
    normals, centres = np.concatenate(normals), np.concatenate(centres)
    length = np.linalg.norm(normals, axis=1)
    if not (length > 0).all():
        raise ValueError("a degenerate face")
    normals = normals / length[:, None]

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
    for f, n, c in zip(order, normals.tolist(), centres.tolist()):
        loop = loops[f].tolist()
        wire = TopoDS_Wire()
        builder.MakeWire(wire)
        for i, j in zip(loop, loop[1:] + loop[:1]):
            builder.Add(wire, edge(i, j))
        wire.Closed(True)
        mk = BRepBuilderAPI_MakeFace(gp_Pln(gp_Pnt(*c), gp_Dir(*n)), wire, True)
        if not mk.IsDone():
            raise ValueError(f"a face is not made: {mk.Error()}")
        builder.Add(shell, mk.Face())
    if not BRep_Tool.IsClosed_s(shell):
        raise ValueError("the faces do not close")
    shell.Closed(True)
    solid = TopoDS_Solid()
    builder.MakeSolid(solid)
    builder.Add(solid, shell)
    return solid, volume


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
    p0, p1, p2, p3 = (outlines[clean, i] for i in range(4))
    poly_volume = float(sign[clean] @ (np.einsum("fi,fi->f", p0, np.cross(p1, p2) + np.cross(p2, p3))
                                       / 6.0))
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
    """:func:`part_solid` as a bare OCC shape (what worker processes send back), its holes
    drilled (:func:`_drilled`); a :class:`SlotCutError` carries the plate as an OCC shape too."""
    try:
        shape = _plate_shape(part, thickness, repair=repair, planar_tol=planar_tol)
    except SlotCutError as e:
        e.plate = _drilled(e.plate, part, thickness)
        raise
    return _drilled(shape, part, thickness)


#: sides of the polygon a hole is drilled as in the solids (every face stays planar, which the
#: assembly check's cheap tests need; the DXF and the parts list have the true circles)
HOLE_SIDES = 16


def _drilled(shape, part: Part, thickness: float):
    """``shape`` with the part's holes (``part.holes``) cut through it: a prism of a regular
    :data:`HOLE_SIDES`-gon inscribed in the hole, along the normal of its panel, 1.5 thicknesses
    long. The undrilled shape where OpenCascade cannot cut them (the holes are still in the
    cutting files)."""
    holes = getattr(part, "holes", ())
    if not holes:
        return shape
    from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism
    from OCP.gp import gp_Vec

    normals = quad_normals(part.panels)
    tools = []
    for h in holes:
        k = h.panel if 0 <= h.panel < len(part.panels) else int(np.argmin(
            np.abs(np.einsum("kj,kj->k", h.center - part.panels[:, 0], normals))))
        n = normals[k]
        e1 = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(n, e1)
        ang = np.linspace(0.0, 2 * np.pi, HOLE_SIDES, endpoint=False)
        ring = (h.center - 0.75 * thickness * n + 0.5 * h.diameter
                * (np.cos(ang)[:, None] * e1 + np.sin(ang)[:, None] * e2))
        tools.append(BRepPrimAPI_MakePrism(_polygon_face(ring), gp_Vec(*map(float, 1.5 * thickness * n)),
                                           True).Shape())
    try:
        pieces = _solids_of(_cut(shape, tools))
        volume = _volume(shape)
        best = max(pieces, key=_volume) if pieces else None
        if best is None or not 0.5 * volume < _volume(best) < volume or not _is_valid(best):
            return shape
        return best
    except Exception:       # OpenCascade failures: the plate as it was
        return shape


def _plate_shape(part: Part, thickness: float, *, repair: bool = True, planar_tol: float = 1e-9):
    """The plate of :func:`_part_shape` with its slots, before the holes are drilled."""
    from OCP.TopoDS import TopoDS

    q, m = part.panels, part.miters
    if not (np.isfinite(q).all() and np.isfinite(m).all()):
        raise InvalidSolidError([part.name], "non-finite panel or mitre coordinates")
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
    beyond it kept. SlotCutError (``plate`` not set) otherwise."""
    nodes = sorted({s.node for s in part.slots})
    try:
        solid = _cut(plate, slot_boxes(part, thickness))
        pieces = _solids_of(solid)
        if not pieces:
            raise ValueError("the boolean cut returned nothing")
        solid = pieces[0] if len(pieces) == 1 else _main_piece(part, thickness, plate_volume, pieces)
        solid = _valid(solid, repair)
        if solid is None:
            raise ValueError("BRepCheck failed after ShapeFix")
        volume = _volume(solid)
        if not 0.5 * plate_volume < volume <= plate_volume * (1 + 1e-9):
            raise ValueError(f"volume {volume:.6g} after cutting slots is implausible for a "
                             f"plate of {plate_volume:.6g}")
        # every slot is open where it should be and the web beyond it is kept (on folds the
        # boxes in both panel planes take a little more than slot area x thickness)
        removed = _slot_record_area(part) * thickness
        if not 0.3 * removed <= plate_volume - volume <= 3.0 * removed + 1e-6 * plate_volume:
            raise ValueError(f"the slots removed {plate_volume - volume:.6g} instead of about "
                             f"{removed:.6g} (slot area x thickness)")
        _check_slots(solid, part)
    except InvalidSolidError as e:
        raise SlotCutError([part.name], str(e), nodes=nodes) from None
    except Exception as e:     # OpenCascade failures
        raise SlotCutError([part.name], f"cutting the slots at nodes {nodes} failed: "
                           f"{type(e).__name__}: {e}", nodes=nodes) from None
    return solid


def _cut(shape, tools: list):
    """``shape`` minus the ``tools`` (OCC boolean cut, then coplanar faces merged), as
    build123d's ``Shape.cut`` does it."""
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
    down) is outside the OCC solid and a point of the web beyond it is inside."""
    from OCP.BRepClass3d import BRepClass3d_SolidClassifier
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_IN, TopAbs_OUT

    q = part.panels
    k = len(q)
    cls = BRepClass3d_SolidClassifier(solid)      # one classifier for every probe of the solid
    for s in part.slots:
        pos = s.position
        a, b = (q[0, 0], q[0, 3]) if pos == 0 else (q[pos - 1, 1], q[pos - 1, 2])
        start, other = (b, a) if SlotSide(s.side) == SlotSide.B else (a, b)
        u = other - start
        length = np.linalg.norm(u)
        u = u / length
        j = pos if pos < k else pos - 1
        into = q[j].mean(axis=0) - start
        into -= (into @ u) * u
        into /= np.linalg.norm(into)
        off = 0.25 * s.width * into
        probes = [(start + 0.5 * s.depth * u + off, TopAbs_OUT, "is not cut")]
        if s.depth < 0.99 * length:       # a web is left (not a full-depth end slot)
            probes.append((start + (s.depth + 0.5 * (length - s.depth)) * u + off, TopAbs_IN,
                           "cut through the web"))
        for x, want, what in probes:
            cls.Perform(gp_Pnt(*map(float, x)), 1e-6)
            if cls.State() != want:
                raise ValueError(f"the slot at node {s.node} {what}")


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


def _build_one(part: Part, thickness: float, repair: bool):
    """``(status, OCC shape or None, detail)`` for one part; status ``ok``, ``unslotted`` (the
    valid plate without slots) or ``bad``."""
    try:
        return "ok", _part_shape(part, thickness, repair=repair), ""
    except SlotCutError as e:
        return "unslotted", e.plate, (e.nodes, str(e))
    except InvalidSolidError as e:
        return "bad", None, str(e)
    except Exception as e:  # OpenCascade errors: report by part id
        return "bad", None, f"{part.name}: {type(e).__name__}: {e}"


def _to_bytes(shape) -> bytes:
    """OpenCascade binary BRep of a shape (OCC shapes do not pickle; bytes do)."""
    import io

    from OCP.BinTools import BinTools

    buf = io.BytesIO()
    BinTools.Write_s(shape, buf)
    return buf.getvalue()


def _from_bytes(data: bytes):
    """The OCC shape of :func:`_to_bytes`."""
    import io

    from OCP.BinTools import BinTools
    from OCP.TopoDS import TopoDS_Shape

    shape = TopoDS_Shape()
    BinTools.Read_s(shape, io.BytesIO(data))
    return _downcast(shape)


def _build_chunk(args):
    """Worker: build the solids of some parts and return them as binary BReps (OCP only: a
    worker never imports build123d), and the CPU seconds that took."""
    import time

    parts, thickness, repair, mesh = args
    cpu = time.process_time()
    out = []
    for p in parts:
        status, shape, detail = _build_one(p, thickness, repair)
        if shape is not None and mesh:       # the triangles travel with the BRep
            _mesh(shape, MESH_TOLERANCE * thickness, threads=False)
        out.append((p.name, status, None if shape is None else _to_bytes(shape), detail))
    return out, time.process_time() - cpu


def default_workers(n_parts: int) -> int:
    """Processes for building ``n_parts`` solids: one per available core, 1 for small jobs
    (starting the workers, which import OpenCascade, costs about as much as building 200
    parts)."""
    import os

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, min(cores, n_parts // 200))


class _Workers:
    """A pool of worker processes being started (from a thread: the first start waits seconds
    for the fork server to import OpenCascade), to build solids with later."""

    def __init__(self, workers: int, mesh: bool = False):
        import multiprocessing as mp
        from concurrent.futures import ProcessPoolExecutor

        self.workers, self.mesh = workers, mesh
        # a fork of a process that runs threads (OpenCascade, BLAS, a test runner) can
        # deadlock in the child: workers are forked from a clean server that has imported
        # this module
        if "forkserver" in mp.get_all_start_methods():
            ctx = mp.get_context("forkserver")
            ctx.set_forkserver_preload(["torsal.fabrication.solids", "OCP.BRepAlgoAPI"])
        else:
            ctx = mp.get_context("spawn")
        self.pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx)
        self.error: BaseException | None = None
        self._starter = threading.Thread(target=self._start, daemon=True)
        self._starter.start()

    def _start(self) -> None:
        try:              # each submission starts one more process, up to ``workers``
            for _ in range(self.workers):
                self.pool.submit(_ready)
        except BaseException as e:        # re-raised by PendingSolids.result()
            self.error = e

    def started(self) -> None:
        """Wait until the processes are started (or failed to)."""
        self._starter.join()

    def shutdown(self, cancel: bool = False) -> None:
        """Stop the pool: wait for its work, or (``cancel``) drop it and return at once: a
        process still being started holds the pool's lock for seconds, so a thread waits for
        it and shuts the pool down."""
        if not cancel:
            self._starter.join()
            self.pool.shutdown(wait=True)
            return
        threading.Thread(target=self.pool.shutdown, kwargs={"wait": False, "cancel_futures": True},
                         daemon=True).start()


def _ready() -> None:
    """Worker: nothing (a submission that makes the pool start a process)."""


#: worker processes started ahead by :func:`prepare_workers`, taken by the next build
_prepared: _Workers | None = None


def prepare_workers(n_parts: int, *, workers: int | None = None, mesh: bool = False) -> int:
    """Start the worker processes for about ``n_parts`` solids now (in the background), so
    that :func:`start_solids` finds them ready: the caller builds its parts meanwhile (the
    fabrication stage: its FinSystem takes as long as the workers take to start). With
    ``mesh`` they also mesh every solid for the previews (3DM, glTF, STL at the default
    tolerance), which then only read the triangles. Returns the number of processes started
    (0: the solids will be built in this process). :func:`release_workers` stops them if no
    build comes."""
    global _prepared
    release_workers()
    n = _workers_for(n_parts, workers)
    if n > 1:
        _prepared = _Workers(n, mesh)
    return n if n > 1 else 0


def release_workers() -> None:
    """Stop worker processes started by :func:`prepare_workers` and not used."""
    global _prepared
    if _prepared is not None:
        w, _prepared = _prepared, None
        w.shutdown(cancel=True)


def _take_workers(workers: int) -> _Workers:
    """The prepared workers if there are ``workers`` of them, else new ones."""
    global _prepared
    if _prepared is not None and _prepared.workers == workers:
        w, _prepared = _prepared, None
        return w
    release_workers()
    return _Workers(workers)


class PendingSolids:
    """Solids being built by worker processes (:func:`start_solids`): the caller goes on with
    other work (unrolling, nesting, DXF) and :meth:`result` collects them. Holds the pool
    until then; :meth:`cancel` drops work not yet started."""

    def __init__(self, parts: list, thickness: float, repair: bool, workers: int):
        self.parts, self.thickness, self.repair, self.workers = parts, thickness, repair, workers
        # interleaved chunks of about equal work; a few per worker so that none waits long
        n_chunks = min(len(parts), 4 * workers)
        chunks = [parts[i::n_chunks] for i in range(n_chunks)]
        self._workers = _take_workers(workers)
        self._pool = self._workers.pool
        self._futures: list = []
        self._error: BaseException | None = None
        # submitting waits for the processes to start: a thread does that, so the caller
        # goes on at once
        self._starter = threading.Thread(target=self._submit, args=(chunks,), daemon=True)
        self._starter.start()

    def _submit(self, chunks) -> None:
        try:
            self._workers.started()
            if self._workers.error is not None:
                raise self._workers.error
            for c in chunks:
                self._futures.append(self._pool.submit(
                    _build_chunk, (c, self.thickness, self.repair, self._workers.mesh)))
        except BaseException as e:        # re-raised by result()
            self._error = e

    def result(self) -> list:
        """``[(name, status, OCC shape, detail)]`` in the order of the parts (waits)."""
        self._starter.join()
        try:
            if self._error is not None:
                raise self._error
            done = [f.result() for f in self._futures]
        finally:
            self._pool.shutdown(wait=True)
        res = {}
        #: CPU seconds the workers spent building (what the caller's clock does not see)
        self.cpu_seconds = sum(cpu for _, cpu in done)
        for rows, _ in done:
            for name, status, data, detail in rows:
                res[name] = (status, None if data is None else _from_bytes(data), detail)
        return [(p.name,) + res[p.name] for p in self.parts]

    def cancel(self) -> None:
        """Stop: chunks not yet started are dropped, the workers end after their current one."""
        self._starter.join()
        self._pool.shutdown(wait=False, cancel_futures=True)


def _workers_for(n_parts: int, workers: int | None) -> int:
    """Worker processes for ``n_parts`` solids: ``workers`` or :func:`default_workers`, no more
    than this process may use (:func:`~torsal.core.parallel.usable_workers`)."""
    return usable_workers(default_workers(n_parts) if workers is None else workers)


def start_solids(fin_system, *, repair: bool = True, workers: int | None = None) -> PendingSolids | None:
    """Start building the solids of a :class:`~.parts.FinSystem` in worker processes and return
    at once (:class:`PendingSolids`), or None if they would be built in this process (one
    worker: small jobs, one core) or are built already. :func:`build_solids` with ``pending``
    collects them; meanwhile this process can unroll, nest and write the sheets."""
    memo = getattr(fin_system, "_solid_shapes", None)
    if getattr(fin_system, "_solids", None) is not None or (
            memo is not None and memo[0] == _parts_key(fin_system)):
        return None
    parts = list(fin_system.parts)
    workers = _workers_for(len(parts), workers)
    if workers <= 1:
        return None
    return PendingSolids(parts, fin_system.thickness, repair, workers)


def build_solids(fin_system, *, repair: bool = True, workers: int | None = None,
                 pending: PendingSolids | None = None) -> dict:
    """``{part name: Solid}`` for every part of a :class:`~.parts.FinSystem` (plates and
    connectors), build123d solids labelled with the part id and coloured by family.

    Solids are independent per part: with ``workers > 1`` (default :func:`default_workers`)
    they are built in worker processes (forked from a clean server process) and sent back as
    OpenCascade binary BReps; ``pending`` (:func:`start_solids`) collects such a build
    started earlier. All parts are attempted; if any is invalid an
    :class:`InvalidSolidError` listing every invalid part id is raised. Shapes built already
    for the exports (:func:`solid_shapes`) are labelled, not built again.
    """
    memo = getattr(fin_system, "_solid_shapes", None)
    if pending is None and memo is not None and memo[0] == _parts_key(fin_system):
        shapes = memo[1]
    else:
        shapes = _collect(fin_system, repair, workers, pending)
    by_name = {p.name: p for p in fin_system.parts}
    return {name: _labelled(shape, by_name[name]) for name, shape in shapes.items()}


def solid_shapes(fin_system, *, repair: bool = True, workers: int | None = None) -> dict:
    """``{part name: OCC solid}`` of a :class:`~.parts.FinSystem`: the shapes of its build123d
    solids if it has them, else built (or collected from :meth:`~.parts.FinSystem.start_solids`)
    as :func:`build_solids` does and kept on the fin system, without build123d (what the
    exports need)."""
    built = getattr(fin_system, "_solids", None)
    if built is not None:
        return {name: s.wrapped for name, s in built.items()}
    key = _parts_key(fin_system)
    memo = getattr(fin_system, "_solid_shapes", None)
    if memo is not None and memo[0] == key:
        return memo[1]
    pending, fin_system._pending = getattr(fin_system, "_pending", None), None
    shapes = _collect(fin_system, repair, workers, pending)
    fin_system._solid_shapes = (key, shapes)
    return shapes


def _parts_key(fin_system) -> tuple:
    """Which parts (objects) the fin system has: shapes kept for other parts are stale."""
    return tuple(id(p) for p in fin_system.parts)


def _collect(fin_system, repair: bool, workers: int | None, pending: PendingSolids | None) -> dict:
    """``{part name: OCC solid}``: built here or by worker processes, or collected from
    ``pending``; sets ``fin_system.unslotted_solids`` (and warns); InvalidSolidError naming
    every invalid part."""
    import time

    parts = list(fin_system.parts)
    t = fin_system.thickness
    workers = _workers_for(len(parts), workers)
    if pending is None and workers > 1:
        pending = PendingSolids(parts, t, repair, workers)
    if pending is not None:
        rows = pending.result()
        cpu = pending.cpu_seconds
    else:
        cpu = time.process_time()
        rows = [(p.name,) + _build_one(p, t, repair) for p in parts]
        cpu = time.process_time() - cpu
    # CPU seconds of the last build, in whichever process it ran (for benchmarks)
    fin_system.solids_cpu_seconds = cpu
    out, bad, detail, unslotted = {}, [], [], []
    for name, status, shape, info in rows:
        if status == "bad":
            bad.append(name)
            detail.append(info)
            continue
        out[name] = shape
        if status == "unslotted":
            unslotted.append((name, info[0], info[1]))
    fin_system.unslotted_solids = unslotted
    if unslotted:
        import warnings

        warnings.warn(
            f"{len(unslotted)} parts are modelled without their slots (OpenCascade could not cut "
            f"them into the thin, oblique plate; the unrolled cutting outlines do have them): "
            + "; ".join(f"{n} (slots at nodes {v})" for n, v, _ in unslotted[:8])
            + (" ..." if len(unslotted) > 8 else "") + "; see FinSystem.unslotted_solids",
            stacklevel=4)
    if bad:
        raise InvalidSolidError(bad, "; ".join(detail))
    return out


def export_step(fin_system, path) -> Path:
    """Write one STEP assembly (AP214, mm) with a named, coloured solid per part.

    The assembly ``torsal_fins`` has one component per part: the part solid, named with the
    part id (on the component and on the solid it refers to) and coloured by family, as
    build123d's ``export_step`` of a labelled ``Compound`` writes it; written here with
    OpenCascade's XCAF writer directly from the solids' OCC shapes, so that a run that only
    writes files never imports build123d (2 s). Every face of a part is planar, so no
    parametric curves (pcurves) are written: readers compute them from the plane (the file
    is 2.4 times smaller, written 40 % and re-read 15 % faster, with the same solids).
    """
    shapes = solid_shapes(fin_system)
    colors = {p.name: p.color for p in fin_system.parts}
    with atomic_path(path) as tmp:
        write_step([(name, shape, colors[name]) for name, shape in shapes.items()], tmp,
                   unit=fin_system.unit, label="torsal_fins")
    return Path(path)


def write_step(solids, path, *, unit: str = "mm", label: str = "torsal_fins") -> None:
    """Write ``[(name, OCC shape, (r, g, b))]`` as one STEP (AP214) assembly ``label``, lengths
    in ``unit``: one named, coloured component per solid; no pcurves. OSError if the writer
    fails."""
    from OCP.APIHeaderSection import APIHeaderSection_MakeHeader
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.Interface import Interface_Static
    from OCP.Message import Message, Message_Gravity
    from OCP.Quantity import Quantity_Color, Quantity_ColorRGBA, Quantity_TOC_sRGB
    from OCP.STEPCAFControl import STEPCAFControl_Controller, STEPCAFControl_Writer
    from OCP.STEPControl import STEPControl_Controller, STEPControl_StepModelType
    from OCP.TCollection import TCollection_ExtendedString, TCollection_HAsciiString
    from OCP.TDataStd import TDataStd_Name
    from OCP.TDF import TDF_Label
    from OCP.TDocStd import TDocStd_Document
    from OCP.XCAFApp import XCAFApp_Application
    from OCP.XCAFDoc import XCAFDoc_ColorType, XCAFDoc_DocumentTool, XCAFDoc_ShapeTool
    from OCP.XSControl import XSControl_WorkSession

    from torsal.core.units import UNIT_TO_M

    doc = TDocStd_Document(TCollection_ExtendedString("XmlOcaf"))
    app = XCAFApp_Application.GetApplication_s()
    app.NewDocument(TCollection_ExtendedString("MDTV-XCAF"), doc)
    app.InitDocument(doc)
    XCAFDoc_DocumentTool.SetLengthUnit_s(doc, UNIT_TO_M[unit])
    shape_tool = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    color_tool = XCAFDoc_DocumentTool.ColorTool_s(doc.Main())
    shape_tool.SetAutoNaming_s(True)
    gen = XCAFDoc_ColorType.XCAFDoc_ColorGen

    def name_and_colour(node, name, colour) -> None:
        TDataStd_Name.Set_s(node, TCollection_ExtendedString(name))
        if colour is not None:
            color_tool.SetColor(node, colour, gen)

    assembly = shape_tool.NewShape()
    name_and_colour(assembly, label, None)
    for name, shape, rgb in solids:
        # sRGB, opaque: as build123d's Color
        colour = Quantity_ColorRGBA(Quantity_Color(*map(float, rgb), Quantity_TOC_sRGB), 1.0)
        component = shape_tool.AddComponent(assembly, shape)
        name_and_colour(component, name, colour)
        referred = TDF_Label()
        if XCAFDoc_ShapeTool.GetReferredShape_s(component, referred) and not referred.IsNull():
            name_and_colour(referred, name, colour)     # the STEP product's name
    shape_tool.UpdateAssemblies()

    for printer in Message.DefaultMessenger_s().Printers():
        printer.SetTraceLevel(Message_Gravity.Message_Fail)
    writer = STEPCAFControl_Writer(XSControl_WorkSession(), False)
    writer.SetColorMode(True)
    writer.SetLayerMode(True)
    writer.SetNameMode(True)
    header = APIHeaderSection_MakeHeader(writer.Writer().Model())
    if not header.IsDone():
        header = APIHeaderSection_MakeHeader(0)
        header.Apply(writer.Writer().Model())
    header.SetName(TCollection_HAsciiString(label))
    header.SetOriginatingSystem(TCollection_HAsciiString("torsal"))
    STEPCAFControl_Controller.Init_s()
    STEPControl_Controller.Init_s()
    Interface_Static.SetIVal_s("write.surfacecurve.mode", 0)        # no pcurves
    Interface_Static.SetIVal_s("write.precision.mode", 0)           # average
    writer.Transfer(doc, STEPControl_StepModelType.STEPControl_AsIs)
    if writer.Write(str(path)) != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise OSError(f"the STEP writer failed for {path}")


def read_step(path) -> list[tuple[str, object]]:
    """Read a STEP file with OCP's XCAF reader: ``[(name, TopoDS_Solid)]`` for every solid,
    name from the label of the solid or of the nearest labelled parent (independent of
    build123d's importer)."""
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPCAFControl import STEPCAFControl_Reader
    from OCP.TCollection import TCollection_AsciiString, TCollection_ExtendedString
    from OCP.TDataStd import TDataStd_Name
    from OCP.collections import Sequence_TDF_Label as TDF_LabelSequence
    from OCP.TDF import TDF_Label
    from OCP.TDocStd import TDocStd_Document
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS
    from OCP.XCAFDoc import XCAFDoc_DocumentTool

    doc = TDocStd_Document(TCollection_ExtendedString("torsal"))
    reader = STEPCAFControl_Reader()
    reader.SetNameMode(True)
    reader.SetColorMode(True)
    if reader.ReadFile(str(path)) != IFSelect_RetDone:
        raise OSError(f"cannot read STEP file {path}")
    if not reader.Transfer(doc):
        raise OSError(f"cannot transfer STEP file {path}")
    tool = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())

    def name_of(label) -> str:
        attr = TDataStd_Name()
        if label.IsAttribute(TDataStd_Name.GetID_s()) and label.FindAttribute(TDataStd_Name.GetID_s(), attr):
            return TCollection_AsciiString(attr.Get()).ToCString()
        return ""

    out = []

    def walk(label, loc, inherited):
        nm = name_of(label) or inherited
        if tool.IsReference_s(label):
            ref = TDF_Label()
            tool.GetReferredShape_s(label, ref)
            walk(ref, loc * tool.GetLocation_s(label), nm)
            return
        if tool.IsAssembly_s(label):
            comps = TDF_LabelSequence()
            tool.GetComponents_s(label, comps)
            for i in range(1, comps.Length() + 1):
                walk(comps.Value(i), loc, "")
            return
        shape = tool.GetShape_s(label).Moved(loc)
        exp = TopExp_Explorer(shape, TopAbs_SOLID)
        while exp.More():
            out.append((nm, TopoDS.Solid(exp.Current())))
            exp.Next()

    roots = TDF_LabelSequence()
    tool.GetFreeShapes(roots)
    for i in range(1, roots.Length() + 1):
        walk(roots.Value(i), TopLoc_Location(), "")
    return out


def _triangles(shape, tolerance: float, angular_tolerance: float = 0.1):
    """Vertices (n, 3) and triangles (m, 3) of an OCC shape, meshed as build123d's
    ``Shape.tessellate`` does (BRepMesh to ``tolerance``, faces in explorer order, reversed
    faces' triangles turned round), without its per-vertex wrappers."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    _mesh(shape, tolerance, angular_tolerance)
    faces, exp = {}, TopExp_Explorer(shape, TopAbs_FACE)
    while exp.More():                        # each face once, in the order first met
        faces[hash(exp.Current())] = exp.Current()
        exp.Next()
    verts, tris, offset = [], [], 0
    for f in faces.values():
        face = TopoDS.Face(f)
        loc = TopLoc_Location()
        poly = BRep_Tool.Triangulation_s(face, loc)
        pts = [poly.Node(j) for j in range(1, poly.NbNodes() + 1)]
        if not loc.IsIdentity():
            trsf = loc.Transformation()
            pts = [p.Transformed(trsf) for p in pts]
        verts.append(np.array([(p.X(), p.Y(), p.Z()) for p in pts], float).reshape(-1, 3))
        # one triangle at a time: poly.Triangles() copies the whole array on every call
        t = np.array([poly.Triangle(i).Get() for i in range(1, poly.NbTriangles() + 1)],
                     dtype=np.int64).reshape(-1, 3) + (offset - 1)
        tris.append(t[:, [0, 2, 1]] if face.Orientation() == TopAbs_REVERSED else t)
        offset += len(verts[-1])
    if not verts:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    return np.concatenate(verts), np.concatenate(tris)


#: preview meshes (3DM, glTF, STL): deflection as a fraction of the plate thickness
MESH_TOLERANCE = 0.05


def _mesh(shape, tolerance: float, angular_tolerance: float = 0.1, *, threads: bool = True) -> None:
    """Mesh an OCC shape (BRepMesh, deflection relative to the edge size; ``threads``: one per
    face in parallel, the same triangles) unless it has a triangulation that fine."""
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.BRepTools import BRepTools

    if not BRepTools.Triangulation_s(shape, tolerance):
        BRepMesh_IncrementalMesh(shape, tolerance, True, angular_tolerance, threads)


def _tessellate(fin_system, tolerance: float | None):
    tol = tolerance if tolerance is not None else MESH_TOLERANCE * fin_system.thickness
    return {name: _triangles(shape, tol) for name, shape in solid_shapes(fin_system).items()}


def export_mesh(fin_system, path, *, file_type: str = "glb", tolerance: float | None = None) -> Path:
    """Preview meshes through trimesh: ``stl`` (one mesh) or ``glb``/``gltf`` (a scene with a
    named, coloured node per part)."""
    import trimesh

    meshes = _tessellate(fin_system, tolerance)
    colors = {p.name: p.color for p in fin_system.parts}
    scene = trimesh.Scene()
    for name, (v, f) in meshes.items():
        m = trimesh.Trimesh(v, f, process=False)
        rgba = (np.r_[colors[name], 1.0] * 255).astype(np.uint8)
        m.visual.face_colors = np.tile(rgba, (len(f), 1))
        scene.add_geometry(m, node_name=name, geom_name=name)

    with atomic_path(path) as tmp:
        if file_type == "stl":
            data = trimesh.util.concatenate(list(scene.geometry.values())).export(file_type="stl")
        else:
            data = scene.export(file_type=file_type)
        tmp.write_bytes(data if isinstance(data, bytes) else data.encode())
    return Path(path)


def export_3dm(fin_system, path, *, tolerance: float | None = None) -> Path:
    """Rhino 3DM (through rhino3dm): one named mesh object per part on a layer per family
    (``family 0``, ``family 1``, ``connectors``), coloured by family, model units set to ``unit``."""
    import rhino3dm

    model = rhino3dm.File3dm()
    us = {"mm": rhino3dm.UnitSystem.Millimeters, "cm": rhino3dm.UnitSystem.Centimeters,
          "m": rhino3dm.UnitSystem.Meters, "in": rhino3dm.UnitSystem.Inches,
          "ft": rhino3dm.UnitSystem.Feet}[fin_system.unit]
    model.Settings.ModelUnitSystem = us
    layers = {}
    for p in fin_system.parts:
        if p.family not in layers:
            lay = rhino3dm.Layer()
            lay.Name = (f"family {p.family}" if p.family >= 0 else
                        "connectors" if p.family == CONNECTOR_FAMILY else
                        "fixings" if p.family == FIXING_FAMILY else "developable")
            lay.Color = tuple(int(255 * c) for c in p.color) + (255,)
            layers[p.family] = model.Layers.Add(lay)
    meshes = _tessellate(fin_system, tolerance)
    for p in fin_system.parts:
        v, f = meshes[p.name]
        mesh = rhino3dm.Mesh()
        for x in v:
            mesh.Vertices.Add(float(x[0]), float(x[1]), float(x[2]))
        for t in f:
            mesh.Faces.AddFace(int(t[0]), int(t[1]), int(t[2]))
        mesh.Normals.ComputeNormals()
        attr = rhino3dm.ObjectAttributes()
        attr.Name = p.name
        attr.LayerIndex = layers[p.family]
        attr.ColorSource = rhino3dm.ObjectColorSource.ColorFromLayer
        model.Objects.AddMesh(mesh, attr)

    with atomic_path(path) as tmp:
        if not model.Write(str(tmp), 7):
            raise RuntimeError(f"rhino3dm could not write {path}")
    return Path(path)
