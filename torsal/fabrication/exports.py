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
from .plates import MESH_TOLERANCE, _triangles
from .step_order import canonical_styles_file
from .rhino import (_encoding, _membrane, _mesh_brep, _quad, _rhino_mesh,  # noqa: F401
                    _with_edge_tolerances, brep_of, brep_record, fixed_properties, placeholder,
                    splice_records)
from .workers import _parts_key, cancel_breps, solid_shapes

__all__ = ["export_step", "write_step", "read_step", "start_read_step", "PendingStepRead",
           "binary_round_trip", "read_step_for_check",
           "export_mesh", "export_3dm", "brep_of"]


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
    # a file stamped with the clock differs from the last run's for no change of the design:
    # the time stamp of reproducible builds (SOURCE_DATE_EPOCH), else a fixed one (and the
    # colours, which OpenCascade orders by memory address, in canonical order below)
    header.SetTimeStamp(TCollection_HAsciiString(_time_stamp()))
    STEPCAFControl_Controller.Init_s()
    STEPControl_Controller.Init_s()
    Interface_Static.SetIVal_s("write.surfacecurve.mode", 0)        # no pcurves
    Interface_Static.SetIVal_s("write.precision.mode", 0)           # average
    writer.Transfer(doc, STEPControl_StepModelType.STEPControl_AsIs)
    if writer.Write(str(path)) != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise OSError(f"the STEP writer failed for {path}")
    canonical_styles_file(path)


def _time_stamp() -> str:
    """ISO 8601 time stamp of the files torsal writes: ``SOURCE_DATE_EPOCH`` (seconds since
    1970, UTC) where set, else 2000-01-01T00:00:00 (ezdxf's fixed date for DXF)."""
    import os
    from datetime import datetime, timezone

    epoch = os.environ.get("SOURCE_DATE_EPOCH", "")
    when = (datetime.fromtimestamp(int(epoch), tz=timezone.utc) if epoch.isdigit()
            else datetime(2000, 1, 1, tzinfo=timezone.utc))
    return when.strftime("%Y-%m-%dT%H:%M:%S")


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


def _read_in_child(path: str, mesh_tolerance: float | None, conn) -> None:
    """Reading process: ``("done", [(name, BRep bytes, records)])`` of :func:`_read_meshed`
    (shapes do not pickle: OpenCascade's binary form, see :func:`binary_round_trip`; the
    records are arrays) or ``("error", exception)``. The file is parsed once; its components
    are transferred, meshed and recorded by this process and a fork of it, half each
    (:func:`_split_rows`)."""
    try:
        message = ("done", _split_rows(path, mesh_tolerance))
    except BaseException as exc:            # raised again in the parent
        message = ("error", exc if isinstance(exc, OSError) else RuntimeError(f"{type(exc).__name__}: {exc}"))
    try:
        conn.send(message)
        conn.close()
    except OSError:       # the caller stopped waiting (a cancelled build, a closed session)
        pass


def _rows(solids: list, mesh_tolerance: float | None) -> list[tuple[str, bytes, object]]:
    """``[(name, BRep bytes, records)]`` of ``[(name, solid)]``: each solid meshed and
    recorded as :func:`_read_meshed` does (one at a time: nothing depends on the others)."""
    from .workers import _to_bytes

    if mesh_tolerance is None:
        return [(name, _to_bytes(s), None) for name, s in solids]
    from .assembly.occ import _mesh
    from .assembly.prepared import solid_records

    _mesh([s for _, s in solids], mesh_tolerance)
    return [(name, _to_bytes(s), solid_records(s)) for name, s in solids]


def _split_rows(path, mesh_tolerance: float | None) -> list[tuple[str, bytes, object]]:
    """:func:`_rows` of the solids of the STEP file ``path`` as :func:`_read_meshed` reads
    them, in a reading process (which runs no thread): the file is parsed once, then the odd
    components are transferred, meshed and recorded in a fork of this process while this one
    does the even ones (OpenCascade's transfer is most of the read: on 7a 3.5 of 4.5 s, then
    the meshing another 4 s). A file that is not one flat assembly is read whole here, the
    meshing split. The same rows, in the same order, either way."""
    reader = _step_reader(path)
    components = _flat_components(reader)
    if components is None:
        return _forked(read_step(path), lambda half: _rows(half, mesh_tolerance))
    return _forked(components, lambda half: _rows(_transfer(reader, half, path), mesh_tolerance))


def _forked(items: list, rows_of) -> list:
    """``rows_of(items)``, its items one by one in order, with ``rows_of(items[1::2])`` in a
    fork of this process (which must run no thread) while this one does ``items[0::2]``:
    the second core does half. In this process where there is no fork or fewer than two
    items."""
    import os
    import pickle
    import signal

    if len(items) < 2 or not hasattr(os, "fork"):
        return rows_of(items)
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:                            # the fork: the odd items, sent back pickled
        try:
            os.close(read)
            try:
                message = ("done", rows_of(items[1::2]))
            except BaseException as exc:
                message = ("error", f"{type(exc).__name__}: {exc}")
            with os.fdopen(write, "wb") as f:
                pickle.dump(message, f, protocol=pickle.HIGHEST_PROTOCOL)
        finally:
            os._exit(0)
    os.close(write)
    with os.fdopen(read, "rb") as f:
        try:
            even = rows_of(items[0::2])
            kind, odd = pickle.load(f)
        except BaseException:
            os.kill(pid, signal.SIGKILL)        # it may be blocked writing to the pipe
            raise
        finally:
            os.waitpid(pid, 0)
    if kind == "error":
        raise RuntimeError(f"reading the solids of the STEP file failed: {odd}")
    rows = [None] * len(items)
    rows[0::2], rows[1::2] = even, odd
    return rows


def _step_reader(path):
    """OpenCascade's STEP reader (``STEPControl_Reader``) with the file ``path`` parsed
    (OSError if it cannot be read)."""
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader

    reader = STEPControl_Reader()
    if reader.ReadFile(str(path)) != IFSelect_RetDone:
        raise OSError(f"cannot read STEP file {path}")
    return reader


def _flat_components(reader) -> list[tuple[int, str]] | None:
    """``[(entity number, name)]`` of the assembly's components in the reader's model (each
    a ``NEXT_ASSEMBLY_USAGE_OCCURRENCE``, in the file's order, which is the order of
    :func:`read_step`; named as it names them: the occurrence's name, else its product's),
    or None when the file is not one assembly of parts (a part alone, or an assembly of
    assemblies): then only :func:`read_step` names its solids."""
    model = reader.StepModel()
    out, parents, children = [], set(), set()
    for i in range(1, model.NbEntities() + 1):
        e = model.Value(i)
        if e.DynamicType().Name() != "StepRepr_NextAssemblyUsageOccurrence":
            continue
        # (the handles come back as copies: products are told apart by their ids)
        part = e.RelatedProductDefinition().Formation().OfProduct()
        parents.add(e.RelatingProductDefinition().Formation().OfProduct().Id().ToCString())
        children.add(part.Id().ToCString())
        out.append((i, e.Name().ToCString() or part.Name().ToCString()))
    return out if out and len(parents) == 1 and not parents & children else None


def _transfer(reader, components: list[tuple[int, str]], path) -> list[tuple[str, object]]:
    """``[(name, TopoDS_Solid)]`` of ``components`` (:func:`_flat_components`): each
    occurrence transferred on its own (the part's shape at its placement in the assembly),
    bit for bit the solids of :func:`read_step` (the same transfer, placement included)."""
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    out = []
    for number, name in components:
        reader.ClearShapes()
        if not reader.TransferList(reader.GiveList(str(number))) or reader.NbShapes() != 1:
            raise OSError(f"cannot transfer component {name} of STEP file {path}")
        exp = TopExp_Explorer(reader.Shape(1), TopAbs_SOLID)
        while exp.More():
            out.append((name, TopoDS.Solid(exp.Current())))
            exp.Next()
    return out


def _read_solids(path) -> list[tuple[str, object]]:
    """:func:`read_step` of ``path``, its components transferred one by one where the file is
    one assembly of parts (:func:`_transfer`: the solids :func:`_split_rows` reads)."""
    reader = _step_reader(path)
    components = _flat_components(reader)
    return read_step(path) if components is None else _transfer(reader, components, path)


def _read_meshed(path, mesh_tolerance: float | None) -> list[tuple[str, object, object]]:
    """``[(name, solid, records)]``: :func:`read_step`, meshed for the assembly check at
    ``mesh_tolerance`` (its touching tolerance, unit; None: not meshed, no records), with
    the records of the check's cheap tests (:func:`~.assembly.prepared.solid_records`) made
    here, once. The triangles travel with OpenCascade's binary form: the process that reads
    the file meshes it, and the check's own meshing of the same shapes, with the same
    parameters, finds it done."""
    solids = _read_solids(path)
    if mesh_tolerance is None:
        return [(name, s, None) for name, s in solids]
    from .assembly.occ import _mesh
    from .assembly.prepared import solid_records

    _mesh([s for _, s in solids], mesh_tolerance)
    return [(name, s, solid_records(s)) for name, s in solids]


def _prepared(name: str, solid, records) -> tuple[str, object]:
    """``(name, solid)``, the solid a :class:`~.assembly.prepared.PreparedSolid` when it has
    records."""
    from .assembly.prepared import PreparedSolid

    return name, solid if records is None else PreparedSolid(solid, records)


def read_step_for_check(path, *, mesh_tolerance: float | None = None
                        ) -> list[tuple[str, object]]:
    """:func:`read_step` of ``path`` in OpenCascade's binary form (:func:`binary_round_trip`),
    meshed at ``mesh_tolerance`` (unit; None: not meshed): what :func:`start_read_step`'s
    process sends, read in this one, so that the assembly check gets the same solids wherever
    the file was read.

    >>> solids = read_step_for_check("fins.step", mesh_tolerance=0.1)   # doctest: +SKIP
    """
    from .workers import _from_bytes, _to_bytes

    return [_prepared(name, _from_bytes(_to_bytes(solid)), records)
            for name, solid, records in _read_meshed(path, mesh_tolerance)]


def binary_round_trip(solids: list[tuple[str, object]]) -> list[tuple[str, object]]:
    """``[(name, solid)]`` written to OpenCascade's binary form and read back: the form in
    which solids read in another process arrive (:class:`PendingStepRead`), so that a check of
    them does not depend on where they were read (vertices keep every bit; a plane's direction
    is normalized again on reading)."""
    from .workers import _from_bytes, _to_bytes

    return [(name, _from_bytes(_to_bytes(solid))) for name, solid in solids]


class PendingStepRead:
    """:func:`read_step` of one file running in a process of its own (:func:`start_read_step`):
    :meth:`result` waits for its solids, :meth:`cancel` stops it. Where no second process
    may be started (a daemonic worker, :func:`~torsal.core.parallel.limit_workers` ``(1)``),
    :meth:`result` reads the file in this process."""

    def __init__(self, path, mesh_tolerance: float | None = None):
        import multiprocessing as mp

        from torsal.core.parallel import usable_workers

        self.path, self.mesh_tolerance = Path(path), mesh_tolerance
        self._process = self._conn = None
        if usable_workers(2) < 2:
            return
        # forked from the clean server the solids' workers come from (OpenCascade imported)
        ctx = mp.get_context("forkserver" if "forkserver" in mp.get_all_start_methods() else "spawn")
        self._conn, child = ctx.Pipe(duplex=False)
        self._process = ctx.Process(target=_read_in_child, args=(str(self.path), mesh_tolerance, child),
                                    name="torsal-read-step", daemon=True)
        self._process.start()
        child.close()

    def result(self) -> list[tuple[str, object]]:
        """``[(name, TopoDS_Solid)]`` of :func:`read_step`, in OpenCascade's binary form
        (:func:`binary_round_trip`) wherever they were read (waits)."""
        if self._process is None:
            return read_step_for_check(self.path, mesh_tolerance=self.mesh_tolerance)
        from .workers import _from_bytes, child_answer

        kind, value = child_answer(self._conn, self._process, f"the process reading {self.path}")
        if kind == "error":
            raise value
        return [_prepared(name, _from_bytes(data), records) for name, data, records in value]

    def cancel(self) -> None:
        """Stop the reading process."""
        if self._process is not None and self._process.is_alive():
            self._process.terminate()
            self._process.join()


def start_read_step(path, *, mesh_tolerance: float | None = None) -> PendingStepRead:
    """Start :func:`read_step` of ``path`` in a process of its own and return at once: the
    caller goes on (writes other files, measures light) while OpenCascade's reader parses
    and heals the file; ``.result()`` gives its ``[(name, solid)]`` in OpenCascade's binary
    form (vertices bit for bit; each plane's direction normalized again on reading, which
    moves a volume by round-off, about 1e-15 of it). With ``mesh_tolerance`` (the assembly
    check's touching tolerance, unit) that process meshes them for the check too.

    >>> pending = start_read_step("fins.step")          # doctest: +SKIP
    >>> solids = pending.result()                        # doctest: +SKIP
    """
    return PendingStepRead(path, mesh_tolerance)


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


def _rhino_id(key: str):
    """A 3DM object's or layer's id from its name, not random: a part keeps its id from one
    run of a design to the next (rhino3dm still stamps the file with the time it was written)."""
    import uuid

    return uuid.uuid5(uuid.NAMESPACE_URL, f"torsal:3dm:{key}")


def export_3dm(fin_system, path, *, tolerance: float | None = None) -> Path:
    """Rhino 3DM (through rhino3dm): one closed, valid Brep per part, a planar face per plane
    face of its solid (:func:`~.rhino.brep_record`; where the solid's faces make none, its
    mesh's faces joined by rhino3dm, :func:`~.rhino.brep_of`), named with the part id (as in
    parts.csv), on a layer per family (``family 0``, ``family 1``, ``developable``) and, for
    connectors, a sublayer of ``connectors`` per joint kind (``connectors::butt-bracket``,
    ...), the fixings to the building on ``fixings``, coloured by family; model units set
    to ``unit``; parts and layers keep their ids from one file to the next (:func:`_rhino_id`).
    ``tolerance``: the deflection of the curved faces (fastener holes), default
    :data:`~.plates.MESH_TOLERANCE` x thickness; plane faces are exact.

    The Breps' records are those the solids' worker processes made with the solids (they
    need no rhino3dm) or are made here; rhino3dm writes the file with a placeholder in the
    place of each (attributes and all) and the records are put in their place
    (:func:`~.rhino.splice_records`): the file is the one rhino3dm writes with the Breps
    decoded and added (the tests check it byte for byte), without the cost of decoding
    them and encoding them again. Should rhino3dm write a file that is not so made, the
    Breps are decoded and added. The properties' file name is ``path``'s name and their
    times a fixed date (:func:`~.rhino.fixed_properties`): the same parts give the same bytes."""
    shapes = solid_shapes(fin_system)
    tol = tolerance if tolerance is not None else MESH_TOLERANCE * fin_system.thickness
    # the records the solids' workers made for this file (the same brep_record, in parallel)
    made = getattr(fin_system, "_breps", None)
    if made is not None and made.key == _parts_key(fin_system) and made.tolerance == tol:
        made = made.breps
    else:
        cancel_breps(fin_system)      # records made for other parts or at another tolerance
        made = {}
    records = {p.name: made[p.name] if p.name in made else brep_record(shapes[p.name], tol)
               for p in fin_system.parts}
    model, placed, meshed = _rhino_model(fin_system, shapes, records, tol, splice=True)
    with atomic_path(path) as tmp:
        if not model.Write(str(tmp), 7):
            raise RuntimeError(f"rhino3dm could not write {path}")
        data = tmp.read_bytes()
        if placed:
            try:
                data = splice_records(data, placed)
            except ValueError:       # not the file it expects: rhino3dm adds the Breps
                model, _, meshed = _rhino_model(fin_system, shapes, records, tol, splice=False)
                if not model.Write(str(tmp), 7):
                    raise RuntimeError(f"rhino3dm could not write {path}") from None
                data = tmp.read_bytes()
        # the staging path and the clock out of the file: the same parts, the same bytes
        tmp.write_bytes(fixed_properties(data, Path(path).name))
    if meshed:
        warnings.warn(f"fins.3dm: {len(meshed)} parts are closed meshes, not Breps (rhino3dm made "
                      f"no valid solid of them): {', '.join(meshed[:8])}"
                      + (" ..." if len(meshed) > 8 else "") + "; the STEP has their solids",
                      stacklevel=2)
    return Path(path)


def _rhino_model(fin_system, shapes: dict, records: dict, tol: float, *, splice: bool):
    """``(File3dm, {key: record}, [names of meshed parts])`` of :func:`export_3dm`: its
    settings, layers and one object per part, a placeholder (:func:`~.rhino.placeholder`)
    for each record of ``records`` {part name: record or None} with ``splice``, else the
    record's Brep; a part without a record joined from its mesh (:func:`~.rhino._mesh_brep`)
    or, where that is not a valid solid, its closed mesh."""
    import rhino3dm

    model = rhino3dm.File3dm()
    us = {"mm": rhino3dm.UnitSystem.Millimeters, "cm": rhino3dm.UnitSystem.Centimeters,
          "m": rhino3dm.UnitSystem.Meters, "in": rhino3dm.UnitSystem.Inches,
          "ft": rhino3dm.UnitSystem.Feet}[fin_system.unit]
    model.Settings.ModelUnitSystem = us
    model.Settings.ModelAbsoluteTolerance = float(min(0.01, tol))
    kind_of = {j.connector: j.kind.value for j in getattr(fin_system, "joints", []) if j.connector}
    layers: dict = {}

    def layer(name: str, colour, parent: str | None = None) -> int:
        key = (parent, name)
        if key not in layers:
            lay = rhino3dm.Layer()
            lay.Name = name
            lay.Id = _rhino_id(f"layer:{parent}::{name}")
            lay.Color = tuple(int(255 * c) for c in colour) + (255,)
            if parent is not None:
                lay.ParentLayerId = model.Layers.FindIndex(layers[(None, parent)]).Id
            layers[key] = model.Layers.Add(lay)
        return layers[key]

    placed: dict = {}
    meshed: list[str] = []
    for k, p in enumerate(fin_system.parts):
        if p.family == CONNECTOR_FAMILY:
            layer("connectors", p.color)
            index = layer(kind_of.get(p.name, "connector"), p.color, parent="connectors")
        elif p.family == FIXING_FAMILY:
            index = layer("fixings", p.color)
        else:
            index = layer(f"family {p.family}" if p.family >= 0 else "developable", p.color)
        attr = rhino3dm.ObjectAttributes()
        attr.Name = p.name
        attr.Id = _rhino_id(f"part:{p.name}")
        attr.LayerIndex = index
        attr.ColorSource = rhino3dm.ObjectColorSource.ColorFromLayer
        record = records.get(p.name)
        if record is not None and splice:
            placed[k] = record
            model.Objects.AddPoint(placeholder(k), attr)
            continue
        brep = rhino3dm.CommonObject.Decode(_encoding(record)) if record is not None else None
        if brep is None or not (brep.IsSolid and brep.IsValid):
            brep = _mesh_brep(shapes[p.name], tol)
        if brep is not None and brep.IsSolid and brep.IsValid:
            model.Objects.AddBrep(brep, attr)
        else:
            # rhino3dm could not join the faces into a valid solid (a sliver face of a small
            # connector): the part as its closed mesh, named, rather than no file at all
            meshed.append(p.name)
            model.Objects.AddMesh(_rhino_mesh(shapes[p.name], tol, quads=False), attr)
    return model, placed, meshed
