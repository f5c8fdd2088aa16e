"""Solid parts (OpenCascade through build123d) and their export: STEP, STL/glTF, 3DM (issue 6).

Every part is thickened about its mid-plane by ``thickness``: the plate is built directly as
a closed polyhedral shell (top face ``p + t/2 m``, bottom ``p - t/2 m`` with the mitre
vectors ``m`` of :class:`~.parts.Part`, side faces along the ``a`` and ``b`` edges, end caps)
sewn into one solid: folds are mitred on the bisector plane, so no boolean fuse is needed and
the plate volume equals ``sum(panel area) * thickness`` up to the twist of side faces.
Egg-crate slots are then cut with one boolean per part (a box per panel touching the slot,
centred on the node line, ``thickness + clearance`` wide, through the plate).

Every solid is checked with ``is_valid``; an invalid one is repaired with ``ShapeFix`` and if it
stays invalid an :class:`InvalidSolidError` names the part: nothing is written silently.
The slots are checked too (the cut must remove the slot area of the unrolled part times the
thickness); where OpenCascade cannot cut them (thin, oblique plates of real structures) the
sound plate is kept without them, listed in ``FinSystem.unslotted_solids`` and warned about
(the unrolled cutting outlines always have the slots).

Units: the ``unit`` of the fin system (mm by default); STEP files are written in mm.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from torsal.core.atomic import atomic_path
from torsal.core.parallel import usable_workers

from .model import CONNECTOR_FAMILY, Part, SlotSide
from .unroll import unroll
from torsal.core.errors import TorsalError

__all__ = ["InvalidSolidError", "SlotCutError", "part_solid", "build_solids", "default_workers",
           "export_step", "export_mesh", "export_3dm", "read_step"]


class InvalidSolidError(TorsalError, RuntimeError):
    """A part's solid is not valid OpenCascade geometry even after repair."""

    def __init__(self, parts: list[str], detail: str = ""):
        self.parts = parts
        super().__init__(f"invalid solid for part(s) {', '.join(parts)}" + (f": {detail}" if detail else ""))


class SlotCutError(InvalidSolidError):
    """The plate of a part is sound but OpenCascade could not cut its slots (a boolean failure
    on a thin, oblique plate). ``plate`` is the valid solid without slots."""

    def __init__(self, parts: list[str], detail: str = "", plate=None, nodes=()):
        super().__init__(parts, detail)
        self.plate = plate
        self.nodes = list(nodes)


def _face(points, planar_tol: float):
    """Planar face through the points, or a fan of triangles if they are not coplanar (to
    ``min(planar_tol * size, 1e-9)`` in absolute units, below OpenCascade's 1e-7)."""
    from build123d import Face, Vector, Wire

    pts = np.asarray(points, float)
    # drop repeated points (degenerate twisted sides)
    keep = [0] + [i for i in range(1, len(pts)) if np.linalg.norm(pts[i] - pts[i - 1]) > 1e-12]
    pts = pts[keep]
    if len(pts) > 3 and np.linalg.norm(pts[-1] - pts[0]) <= 1e-12:
        pts = pts[:-1]
    if len(pts) < 3:
        return []
    c = pts.mean(0)
    _, sv, vt = np.linalg.svd(pts - c)
    size = np.linalg.norm(pts.max(0) - pts.min(0))
    if len(pts) == 3 or np.abs((pts - c) @ vt[2]).max() <= min(planar_tol * size, 1e-9):
        try:
            return [Face(Wire.make_polygon([Vector(*p) for p in pts], close=True))]
        except ValueError:       # OpenCascade finds it not planar enough: use triangles
            if len(pts) == 3:
                raise
    return [Face(Wire.make_polygon([Vector(*pts[0]), Vector(*pts[i]), Vector(*pts[i + 1])], close=True))
            for i in range(1, len(pts) - 1)]


def _fan_volume(points) -> float:
    """Signed volume contribution (divergence theorem) of a face as :func:`_face` builds it:
    repeated points dropped, a fan of triangles from the first point."""
    pts = np.asarray(points, float)
    keep = [0] + [i for i in range(1, len(pts)) if np.linalg.norm(pts[i] - pts[i - 1]) > 1e-12]
    pts = pts[keep]
    if len(pts) < 3:
        return 0.0
    return float(sum(pts[0] @ np.cross(pts[i], pts[i + 1]) for i in range(1, len(pts) - 1)) / 6.0)


def _box(origin, x_dir, z_dir, length, width, height):
    from build123d import Plane, Solid, Vector

    return Solid.make_box(length, width, height,
                          Plane(origin=Vector(*origin), x_dir=Vector(*x_dir), z_dir=Vector(*z_dir)))


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


def part_solid(part: Part, thickness: float, *, repair: bool = True, planar_tol: float = 1e-9):
    """The thickened, slotted solid of one part (build123d ``Solid``), labelled and coloured.

    Raises
    ------
    InvalidSolidError
        If the solid is invalid and cannot be repaired.
    """
    from build123d import Color, Shell, Solid

    q = part.panels
    m = part.miters
    h = 0.5 * thickness
    k = len(q)
    # node index of each quad corner: 0, 3 -> j; 1, 2 -> j + 1
    top = np.empty_like(q)
    bot = np.empty_like(q)
    for j in range(k):
        for c, node in ((0, j), (3, j), (1, j + 1), (2, j + 1)):
            top[j, c] = q[j, c] + h * m[node]
            bot[j, c] = q[j, c] - h * m[node]
    if not (np.isfinite(q).all() and np.isfinite(m).all()):
        raise InvalidSolidError([part.name], "non-finite panel or mitre coordinates")
    faces, poly_volume = [], 0.0
    outlines = []                                   # (points, orientation) of every face
    for j in range(k):
        outlines += [(top[j], 1.0), (bot[j], -1.0),   # bottom: same diagonal as the top if warped
                     ([top[j, 1], top[j, 0], bot[j, 0], bot[j, 1]], 1.0),   # a side
                     ([top[j, 3], top[j, 2], bot[j, 2], bot[j, 3]], 1.0)]   # b side
    outlines += [([top[0, 0], top[0, 3], bot[0, 3], bot[0, 0]], 1.0),       # start cap
                 ([top[-1, 2], top[-1, 1], bot[-1, 1], bot[-1, 2]], 1.0)]   # end cap
    for pts, sign in outlines:
        faces += _face(pts, planar_tol)
        poly_volume += sign * _fan_volume(pts)
    shell = Shell(faces)
    from OCP.BRep import BRep_Tool

    if not BRep_Tool.IsClosed_s(shell.wrapped):
        raise InvalidSolidError([part.name], "the plate's faces do not sew into a closed shell")
    solid = Solid(shell)
    if solid.volume < 0:             # sewn inside out: turn it round
        solid = Solid(solid.wrapped.Reversed())
    # a closed, valid shell can still be garbage (e.g. a bow-tie panel): the solid must have the
    # volume of the polyhedron it was built from, and that the volume sum(panel area) *
    # thickness up to the twist of its side faces (which grows on narrow panels that meet the
    # node lines obliquely, mitred: a few percent at most)
    expected = float(part.panel_areas.sum()) * thickness
    if not abs(solid.volume - abs(poly_volume)) <= 1e-3 * abs(poly_volume):
        raise InvalidSolidError([part.name], f"plate volume {solid.volume:.6g} differs from that of "
                                f"its faces {abs(poly_volume):.6g}: the faces do not sew into a sound solid")
    if not abs(solid.volume - expected) <= 0.05 * expected:
        raise InvalidSolidError([part.name], f"plate volume {solid.volume:.6g} differs from panel "
                                f"area x thickness {expected:.6g}: broken or self-intersecting panels")
    plate_volume = abs(solid.volume)
    plate = solid
    if not plate.is_valid:
        if repair:
            plate = plate.fix()
        if not plate.is_valid:
            raise InvalidSolidError([part.name], "BRepCheck failed after ShapeFix")
    plate.label = part.name
    plate.color = Color(*part.color)
    if not part.slots:
        return plate
    nodes = sorted({s.node for s in part.slots})
    try:
        boxes = slot_boxes(part, thickness)
        solid = plate.cut(*boxes)
        if solid is None:
            raise ValueError("the boolean cut returned nothing")
        if not isinstance(solid, Solid):
            sols = solid.solids()
            if len(sols) != 1:
                solid = _main_piece(part, thickness, plate_volume, sols)
            else:
                solid = sols[0]
        if not solid.is_valid and repair:
            solid = solid.fix()
        if not solid.is_valid:
            raise ValueError("BRepCheck failed after ShapeFix")
        if not 0.5 * plate_volume < solid.volume <= plate_volume * (1 + 1e-9):
            raise ValueError(f"volume {solid.volume:.6g} after cutting slots is implausible for a "
                             f"plate of {plate_volume:.6g}")
        # every slot is open where it should be and the web beyond it is kept (on folds the
        # boxes in both panel planes take a little more than slot area x thickness)
        removed = _slot_area(part) * thickness
        if not 0.3 * removed <= plate_volume - solid.volume <= 3.0 * removed + 1e-6 * plate_volume:
            raise ValueError(f"the slots removed {plate_volume - solid.volume:.6g} instead of about "
                             f"{removed:.6g} (slot area x thickness)")
        _check_slots(solid, part)
    except InvalidSolidError as e:
        raise SlotCutError([part.name], str(e), plate=plate, nodes=nodes) from None
    except Exception as e:     # OpenCascade failures
        raise SlotCutError([part.name], f"cutting the slots at nodes {nodes} failed: "
                           f"{type(e).__name__}: {e}", plate=plate, nodes=nodes) from None
    solid.label = part.name
    solid.color = Color(*part.color)
    return solid


def _check_slots(solid, part: Part) -> None:
    """Raise ValueError unless, for every slot, a point in the slot (on the mid-plane, halfway
    down) is outside the solid and a point of the web beyond it is inside."""
    from OCP.BRepClass3d import BRepClass3d_SolidClassifier
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_IN, TopAbs_OUT

    q = part.panels
    k = len(q)
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
            cls = BRepClass3d_SolidClassifier(solid.wrapped, gp_Pnt(*map(float, x)), 1e-6)
            if cls.State() != want:
                raise ValueError(f"the slot at node {s.node} {what}")


def _slot_area(part: Part) -> float:
    """Area the slots take out of the unrolled part (``unit``^2)."""
    from shapely.geometry import Polygon

    u = unroll(part)
    return float(sum(Polygon(f).area for f in u.panels) - u.outline.area)


def _main_piece(part: Part, thickness: float, plate_volume: float, pieces: list):
    """The plate left after cutting the slots when OpenCascade's boolean returned several
    pieces: on thin, oblique plates it sometimes splits the cut-out off instead of removing it,
    or leaves slivers. The unrolled outline says what must be left (``plate - slot area x
    thickness``); the piece of that volume is kept, else the part is reported."""
    nodes = sorted({s.node for s in part.slots})
    try:
        removed = _slot_area(part) * thickness
    except ValueError as e:
        raise InvalidSolidError([part.name], f"the slots at nodes {nodes} cut the plate apart ({e})")
    expected = plate_volume - removed
    best = min(pieces, key=lambda x: abs(x.volume - expected))
    if not abs(best.volume - expected) <= 0.05 * removed + 1e-6 * plate_volume:
        raise InvalidSolidError([part.name], f"the slots at nodes {nodes} split the plate into "
                                f"{len(pieces)} pieces (volumes {sorted(round(x.volume, 1) for x in pieces)}, "
                                f"expected one of {expected:.6g})")
    return best


def _build_one(part: Part, thickness: float, repair: bool):
    """``(status, solid or None, detail)`` for one part; status ``ok``, ``unslotted`` (the valid
    plate without slots) or ``bad``."""
    try:
        return "ok", part_solid(part, thickness, repair=repair), ""
    except SlotCutError as e:
        return "unslotted", e.plate, (e.nodes, str(e))
    except InvalidSolidError as e:
        return "bad", None, str(e)
    except Exception as e:  # OpenCascade errors: report by part id
        return "bad", None, f"{part.name}: {type(e).__name__}: {e}"


def _build_chunk(args):
    """Worker: build the solids of some parts and return them as OpenCascade binary BReps
    (OCC shapes do not pickle; bytes do)."""
    from build123d.persistence import serialize_shape

    parts, thickness, repair = args
    out = []
    for p in parts:
        status, solid, detail = _build_one(p, thickness, repair)
        out.append((p.name, status, None if solid is None else serialize_shape(solid.wrapped), detail))
    return out


def default_workers(n_parts: int) -> int:
    """Processes for building ``n_parts`` solids: one per available core, 1 for small jobs
    (starting the workers, which import OpenCascade, costs about as much as building 200
    parts)."""
    import os

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, min(cores, n_parts // 200))


def _build_parallel(parts: list, thickness: float, repair: bool, workers: int):
    """``[(name, status, solid, detail)]`` built by ``workers`` forked processes, in order."""
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    from build123d import Color, Solid
    from build123d.persistence import deserialize_shape

    # interleaved chunks of about equal work; a few per worker so that none waits long
    n_chunks = min(len(parts), 4 * workers)
    chunks = [parts[i::n_chunks] for i in range(n_chunks)]
    # a fork of a process that runs threads (OpenCascade, BLAS, a test runner) can deadlock
    # in the child: workers are forked from a clean server that has imported this module
    if "forkserver" in mp.get_all_start_methods():
        ctx = mp.get_context("forkserver")
        ctx.set_forkserver_preload(["torsal.fabrication.solids", "build123d"])
    else:
        ctx = mp.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        done = list(pool.map(_build_chunk, [(c, thickness, repair) for c in chunks]))
    by_name = {p.name: p for p in parts}
    res = {}
    for rows in done:
        for name, status, data, detail in rows:
            solid = None
            if data is not None:
                solid = Solid(deserialize_shape(data))
                solid.label = name
                solid.color = Color(*by_name[name].color)
            res[name] = (status, solid, detail)
    return [(p.name,) + res[p.name] for p in parts]


def build_solids(fin_system, *, repair: bool = True, workers: int | None = None) -> dict:
    """``{part name: Solid}`` for every part of a :class:`~.parts.FinSystem` (plates and
    connectors).

    Solids are independent per part: with ``workers > 1`` (default :func:`default_workers`)
    they are built in worker processes (forked from a clean server process) and sent back as
    OpenCascade binary BReps. All parts
    are attempted; if any is invalid an :class:`InvalidSolidError` listing every invalid part
    id is raised.
    """
    parts = list(fin_system.parts)
    t = fin_system.thickness
    workers = usable_workers(default_workers(len(parts)) if workers is None else workers)
    if workers > 1:
        rows = _build_parallel(parts, t, repair, workers)
    else:
        rows = [(p.name,) + _build_one(p, t, repair) for p in parts]
    out, bad, detail, unslotted = {}, [], [], []
    for name, status, solid, info in rows:
        if status == "bad":
            bad.append(name)
            detail.append(info)
            continue
        out[name] = solid
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
            stacklevel=3)
    if bad:
        raise InvalidSolidError(bad, "; ".join(detail))
    return out


def export_step(fin_system, path) -> Path:
    """Write one STEP assembly (AP214, mm) with a named, coloured solid per part.

    The assembly is a build123d ``Compound`` labelled ``torsal_fins`` whose children are the
    part solids (``label`` = part id, ``color`` by family).
    """
    from build123d import Compound, Unit
    from build123d import export_step as _bd_export_step

    sol = fin_system.solids()
    assembly = Compound(label="torsal_fins", children=list(sol.values()))
    unit = {"mm": Unit.MM, "cm": Unit.CM, "m": Unit.M, "in": Unit.IN, "ft": Unit.FT}[fin_system.unit]

    with atomic_path(path) as tmp:
        if not _bd_export_step(assembly, str(tmp), unit=unit):
            raise RuntimeError(f"STEP writer failed for {path}")
    return Path(path)


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


def _tessellate(fin_system, tolerance: float | None):
    tol = tolerance if tolerance is not None else 0.05 * fin_system.thickness
    res = {}
    for name, s in fin_system.solids().items():
        v, f = s.tessellate(tol)
        res[name] = (np.array([[p.X, p.Y, p.Z] for p in v]), np.asarray(f, dtype=np.int64))
    return res


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
                        "connectors" if p.family == CONNECTOR_FAMILY else "developable")
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
