"""The solids' files: STEP (the assembly, nominal solids), Rhino 3DM (one closed Brep per part),
glTF / STL previews, and the STEP reader the checks use.

Units: the ``unit`` of the fin system (mm by default); STEP files are written in that unit.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from torsal.core.atomic import atomic_path

from .model import CONNECTOR_FAMILY, FIXING_FAMILY
from .plates import MESH_TOLERANCE, _face_triangles, _triangles
from .workers import solid_shapes

__all__ = ["export_step", "write_step", "read_step", "export_mesh", "export_3dm", "brep_of"]


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
    """Rhino 3DM (through rhino3dm): one closed, valid Brep per part (:func:`brep_of`), named
    with the part id (as in parts.csv), on a layer per family (``family 0``, ``family 1``,
    ``developable``) and, for connectors, a sublayer of ``connectors`` per joint kind
    (``connectors::butt-bracket``, ...), the fixings to the building on ``fixings``, coloured
    by family; model units set to ``unit``.
    ``tolerance``: the deflection of the curved faces (fastener holes), default
    :data:`~.plates.MESH_TOLERANCE` x thickness; plane faces are exact."""
    import rhino3dm

    model = rhino3dm.File3dm()
    us = {"mm": rhino3dm.UnitSystem.Millimeters, "cm": rhino3dm.UnitSystem.Centimeters,
          "m": rhino3dm.UnitSystem.Meters, "in": rhino3dm.UnitSystem.Inches,
          "ft": rhino3dm.UnitSystem.Feet}[fin_system.unit]
    model.Settings.ModelUnitSystem = us
    tol = tolerance if tolerance is not None else MESH_TOLERANCE * fin_system.thickness
    model.Settings.ModelAbsoluteTolerance = float(min(0.01, tol))
    kind_of = {j.connector: j.kind.value for j in getattr(fin_system, "joints", []) if j.connector}
    layers: dict = {}

    def layer(name: str, colour, parent: str | None = None) -> int:
        key = (parent, name)
        if key not in layers:
            lay = rhino3dm.Layer()
            lay.Name = name
            lay.Color = tuple(int(255 * c) for c in colour) + (255,)
            if parent is not None:
                lay.ParentLayerId = model.Layers.FindIndex(layers[(None, parent)]).Id
            layers[key] = model.Layers.Add(lay)
        return layers[key]

    shapes = solid_shapes(fin_system)
    meshed: list[str] = []
    for p in fin_system.parts:
        if p.family == CONNECTOR_FAMILY:
            layer("connectors", p.color)
            index = layer(kind_of.get(p.name, "connector"), p.color, parent="connectors")
        elif p.family == FIXING_FAMILY:
            index = layer("fixings", p.color)
        else:
            index = layer(f"family {p.family}" if p.family >= 0 else "developable", p.color)
        brep = brep_of(shapes[p.name], tol)
        attr = rhino3dm.ObjectAttributes()
        attr.Name = p.name
        attr.LayerIndex = index
        attr.ColorSource = rhino3dm.ObjectColorSource.ColorFromLayer
        if brep is not None and brep.IsSolid and brep.IsValid:
            model.Objects.AddBrep(brep, attr)
        else:
            # rhino3dm could not join the faces into a valid solid (a sliver face of a small
            # connector): the part as its closed mesh, named, rather than no file at all
            meshed.append(p.name)
            model.Objects.AddMesh(_rhino_mesh(shapes[p.name], tol, quads=False), attr)
    if meshed:
        warnings.warn(f"fins.3dm: {len(meshed)} parts are closed meshes, not Breps (rhino3dm made "
                      f"no valid solid of them): {', '.join(meshed[:8])}"
                      + (" ..." if len(meshed) > 8 else "") + "; the STEP has their solids",
                      stacklevel=2)

    with atomic_path(path) as tmp:
        if not model.Write(str(tmp), 7):
            raise RuntimeError(f"rhino3dm could not write {path}")
    return Path(path)


def brep_of(shape, tolerance: float):
    """A closed rhino3dm ``Brep`` of an OCC solid: one Brep face per plane face of the solid
    with four corners (a planar quad, exact), the others (faces with slot notches, curved
    hole walls) as the planar triangles of their mesh (curved faces within ``tolerance``),
    joined along shared edges (rhino3dm's ``Brep.CreateFromMesh`` on the welded faces).

    rhino3dm leaves the edges' tolerance unset (openNURBS's ON_UNSET_VALUE), which makes
    ``IsValid`` false although each edge lies exactly on both of its faces (they are built
    from the same vertices): the tolerance is set to 0 in the Brep's openNURBS record (the only
    doubles with that value, one per edge) when that makes the Brep valid."""
    import rhino3dm

    brep = rhino3dm.Brep.CreateFromMesh(_rhino_mesh(shape, tolerance), True)
    if brep is None or brep.IsValid:
        return brep
    return _with_edge_tolerances(brep)


def _rhino_mesh(shape, tolerance: float, *, quads: bool = True):
    """The rhino3dm ``Mesh`` of an OCC solid's faces (:func:`brep_of`), welded: planar quads
    as quads (with ``quads``), the rest as triangles. Pairs of coincident triangles of
    opposite orientation (a membrane of zero thickness inside the solid, which a fuzzy slot
    cut can leave: :data:`~.plates.SLOT_CUT_FUZZY`) are dropped: they enclose no volume and
    make the mesh non-manifold."""
    import rhino3dm

    faces = _face_triangles(shape, tolerance)
    pts = np.concatenate([v for v, _ in faces]) if faces else np.zeros((0, 3))
    scale = max(1.0, float(np.abs(pts).max(initial=0.0)))
    _, first, ids = np.unique(np.round(pts / (1e-9 * scale)).astype(np.int64), axis=0,
                              return_index=True, return_inverse=True)
    ids = ids.ravel()
    offsets = np.cumsum([0] + [len(v) for v, _ in faces])
    welded = [ids[o:o + len(v)][t] for o, (v, t) in zip(offsets, faces)]
    membrane = _membrane(np.concatenate(welded) if welded else np.zeros((0, 3), int))
    mesh = rhino3dm.Mesh()
    for x in pts[first]:             # double precision (Add keeps single precision)
        mesh.Vertices.AddPoint3d(float(x[0]), float(x[1]), float(x[2]))
    for (v, t), g in zip(faces, welded):
        keep = [tuple(sorted(map(int, tri))) not in membrane for tri in g]
        quad = _quad(g) if quads and len(v) == 4 and len(t) == 2 and all(keep) else None
        if quad is not None:
            mesh.Faces.AddFace(*map(int, quad))
        else:
            for (a, b, c), k in zip(g, keep):
                if k:
                    mesh.Faces.AddFace(int(a), int(b), int(c))
    return mesh


def _membrane(tris: np.ndarray) -> set:
    """The vertex sets (sorted tuples) of triangles ``tris`` (n, 3) that occur twice with
    opposite orientations."""
    key = np.sort(tris, axis=1)
    # the orientation: the parity of the vertices' inversions (a cyclic turn keeps it)
    a, b, c = np.asarray(tris).T
    parity = ((a > b).astype(int) + (a > c) + (b > c)) % 2
    seen: dict = {}
    out = set()
    for k, par in zip(map(tuple, key.tolist()), parity.tolist()):
        if k in seen and seen[k] != par:
            out.add(k)
        seen.setdefault(k, par)
    return out


def _quad(tris: np.ndarray):
    """The quad (4,) of two triangles (2, 3) that share an edge (in opposite directions), in
    their order, or None."""
    a, b = [list(map(int, t)) for t in tris]
    for i in range(3):
        u, v, w = a[i], a[(i + 1) % 3], a[(i + 2) % 3]
        for j in range(3):
            if b[j] == v and b[(j + 1) % 3] == u:
                x = b[(j + 2) % 3]
                return (u, x, v, w)
    return None


def _with_edge_tolerances(brep):
    """The Brep with its unset edge tolerances set to 0 (see :func:`brep_of`), if that makes it
    valid; else the Brep as it was."""
    import base64
    import struct

    import rhino3dm

    unset = struct.pack("<d", -1.23432101234321e+308)       # openNURBS's ON_UNSET_VALUE
    enc = brep.Encode()
    data = base64.b64decode(enc["data"])
    if data.count(unset) != len(brep.Edges):
        return brep
    enc = dict(enc, data=base64.b64encode(data.replace(unset, struct.pack("<d", 0.0))).decode())
    fixed = rhino3dm.CommonObject.Decode(enc)
    return fixed if fixed is not None and fixed.IsValid and fixed.IsSolid else brep
