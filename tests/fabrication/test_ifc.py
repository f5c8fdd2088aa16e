"""fins.ifc (issue 43): the fin system as IFC4 building elements, read back with ifcopenshell.

Two small structures: a flat grid (every fin plate flat: extruded profiles with their bolt
holes) and a sphere patch (folded strips and oblique ends: closed triangulated solids). Every
check reads the written file; volumes are compared with the solids of fins.step read back.
"""
from __future__ import annotations

import ast
import csv
import math
import types

import numpy as np
import pytest
from fab_structures import flat_structure, sphere_structure

ifcopenshell = pytest.importorskip("ifcopenshell")
import ifcopenshell.geom  # noqa: E402
import ifcopenshell.util.element  # noqa: E402
import ifcopenshell.util.shape  # noqa: E402
import ifcopenshell.validate  # noqa: E402
from ifcopenshell.express import rule_executor  # noqa: E402

from torsal.core.units import UNIT_TO_M  # noqa: E402
from torsal.fabrication import FinSystem, read_step  # noqa: E402
from torsal.fabrication import ifc as I  # noqa: E402
from torsal.fabrication.builder.fasteners import fastener_counts  # noqa: E402
from torsal.fabrication.plates import _volume  # noqa: E402
from torsal.fabrication.workers import solid_shapes  # noqa: E402

STRUCTURES = {"flat": flat_structure, "sphere": lambda: sphere_structure(nu=4, nv=3, step=0.12)}
PART_CLASSES = ("IfcPlate", "IfcMember")


#: the module's tests share each structure's solids and IFC (7 s of setup): on one xdist worker
#: (make test's --dist loadgroup) it is made once; tests split over the two workers
#: would make it twice
pytestmark = pytest.mark.xdist_group("ifc-export")


@pytest.fixture(scope="module", params=sorted(STRUCTURES))
def exported(request, tmp_path_factory):
    """(fin system, its fins.ifc opened, the folder with fins.ifc, fins.step, parts.csv)."""
    fs = FinSystem(STRUCTURES[request.param](), thickness=3.0, clearance=0.5)
    solid_shapes(fs, workers=1)                 # built once here, in this process
    out = tmp_path_factory.mktemp(f"ifc_{request.param}")
    fs.export_ifc(out / "fins.ifc", latitude=48.21, longitude=-16.37, elevation=170.0,
                  north_angle=30.0, material="aluminium", density=2700.0)
    fs.export_step(out / "fins.step")
    fs.bill_of_materials(out / "parts.csv")
    return fs, ifcopenshell.open(str(out / "fins.ifc")), out


#: a test whose subject is not the structure runs on the sphere in the quick set (make test):
#: its folded strips and flat plates write both kinds of body (extruded profiles and closed
#: triangles); the flat grid (bolt holes in its profiles) runs it in the slow set (make
#: test-slow, CI). Each takes 5-15 s: a second process importing torsal, or the EXPRESS
#: rules' validation (ifcopenshell compiles its rules again on every call)
SPHERE_QUICK = pytest.mark.parametrize(
    "exported", [pytest.param("flat", marks=pytest.mark.slow), "sphere"], indirect=True)


def _parts_csv(out) -> list[dict]:
    with open(out / "parts.csv", newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def _parts(f) -> list:
    return [e for cls in PART_CLASSES for e in f.by_type(cls)]


def _body(el):
    (rep,) = el.Representation.Representations
    (item,) = rep.Items
    return rep, item


class _RulesCompiledOnce:
    """ifcopenshell's check of the EXPRESS rules (``validate(..., express_rules=True)``) parses
    its rules module (578 kB for IFC4), rewrites its asserts with pytest's rewriter and
    compiles it on every call: 4.8 CPU s a call, of which the file's own check is a small part.
    Put in place of ``rule_executor``'s ``ast.parse`` and ``compile`` for a check, this
    compiles each schema's rules once per process and hands the same code object to every
    later check: the same rules run on each file, with the same line numbers in the messages
    (test_the_rules_compiled_once_still_find_a_broken_rule)."""

    def __init__(self):
        self.code: dict[str, types.CodeType] = {}
        self.source: str | None = None

    def parse(self, source, *args, **kw):
        self.source = source
        if source in self.code:          # compiled already: nothing for the rewriter to do
            return ast.Module(body=[], type_ignores=[])
        return ast.parse(source, *args, **kw)

    def compile(self, tree, filename, mode):
        if self.source not in self.code:
            self.code[self.source] = compile(tree, filename, mode)
        return self.code[self.source]


_RULES = _RulesCompiledOnce()


def _validation_statements(f) -> list:
    """What ``ifcopenshell.validate`` logs for the file ``f``, its EXPRESS rules checked."""
    log = ifcopenshell.validate.json_logger()
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(rule_executor, "ast", types.SimpleNamespace(parse=_RULES.parse))
        mp.setattr(rule_executor, "compile", _RULES.compile, raising=False)
        ifcopenshell.validate.validate(f, log, express_rules=True)
    return log.statements


def test_the_rules_compiled_once_still_find_a_broken_rule():
    """A direction of length 0 breaks IfcDirection's rule MagnitudeGreaterZero (which the
    schema check without the rules does not see): found by the first check and again by a
    later one that runs the rules compiled by the first."""
    f = ifcopenshell.file(schema="IFC4")
    f.createIfcDirection((0.0, 0.0, 0.0))
    for _ in range(2):
        (found,) = _validation_statements(f)
        assert found["type"] == "entity_rule" and "IfcDirection" in found["message"]
    assert len(_RULES.code) == 1
    log = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(f, log, express_rules=False)
    assert log.statements == []


def test_schema_validation_finds_nothing(exported):
    fs, f, out = exported
    assert f.schema == "IFC4"
    assert _validation_statements(f) == []
    # the project's length unit is the fin system's millimetre
    (length,) = [u for u in f.by_type("IfcProject")[0].UnitsInContext.Units
                 if u.is_a("IfcNamedUnit") and u.UnitType == "LENGTHUNIT"]
    assert (length.Prefix, length.Name) == ("MILLI", "METRE")
    assert not list(out.glob("*.tmp*"))


def test_one_element_per_parts_csv_row_with_its_name(exported):
    fs, f, out = exported
    rows = _parts_csv(out)
    elements = _parts(f)
    assert len(elements) == len(rows) == len(fs.parts)
    assert sorted(e.Name for e in elements) == sorted(r["part_id"] for r in rows)
    by_name = {r["part_id"]: r for r in rows}
    for el in elements:
        row = by_name[el.Name]
        ps = ifcopenshell.util.element.get_psets(el)
        tp = ps["Torsal_Part"]
        assert el.Tag == tp["PartName"] == ps["Pset_PlateCommon"]["Reference"] == el.Name
        assert (tp["Family"], tp["Strip"]) == (int(row["family"]), int(row["strip"]))
        assert tp["Panel"] == fs.part(el.Name).id.index
        assert tp["JointKind"] == row["kind"] and tp["Panels"] == int(row["panels"])
        assert tp["Holes"] == int(row["holes"])
        assert tp["Thickness"] == pytest.approx(fs.thickness)
        if row["kind"] == "plate":
            assert el.PredefinedType == "SHEET"
        else:
            assert (el.PredefinedType, el.ObjectType) == ("USERDEFINED", row["kind"])
    # every joint of the fin system is named on its parts
    # (a butt joint: with its bracket, or a tab bent from the butted plate instead)
    some = next(j for j in fs.joints if j.kind.value in ("butt-bracket", "butt-tab"))
    for name in some.parts:
        el = next(e for e in elements if e.Name == name)
        joints = ifcopenshell.util.element.get_psets(el)["Torsal_Part"]["Joints"]
        assert f"{some.kind.value} N{some.node:04d}" in joints


def test_volumes_are_those_of_the_step_solids(exported):
    """ifcopenshell.geom's volume of every element against OpenCascade's of the same part
    in fins.step: within 0.5 %, and that less the bolt holes drawn (flat plates)."""
    fs, f, out = exported
    step = {name: _volume(solid) for name, solid in read_step(out / "fins.step")}
    assert sorted(step) == sorted(p.name for p in fs.parts)
    settings = ifcopenshell.geom.settings()
    to_unit = 1.0 / UNIT_TO_M[fs.unit] ** 3          # geom gives m^3
    bodies = set()
    for el in _parts(f):
        shape = ifcopenshell.geom.create_shape(settings, el)
        volume = ifcopenshell.util.shape.get_volume(shape.geometry) * to_unit
        _, item = _body(el)
        bodies.add(item.is_a())
        holes = 0.0
        if item.is_a("IfcExtrudedAreaSolid"):
            holes = sum(math.pi * h.diameter ** 2 / 4 for h in fs.part(el.Name).holes) * fs.thickness
        assert volume == pytest.approx(step[el.Name], rel=5e-3), el.Name
        # less the holes, up to ifcopenshell's polygons for the circles (~1 % of a hole)
        assert abs(volume - (step[el.Name] - holes)) <= 0.02 * holes + 1e-6 * step[el.Name], el.Name
    assert "IfcTriangulatedFaceSet" in bodies


def test_flat_plates_are_extruded_profiles_and_bent_parts_closed_triangles(exported):
    fs, f, out = exported
    for el in _parts(f):
        part = fs.part(el.Name)
        rep, item = _body(el)
        flat = bool(np.allclose(part.fold_angles, 0.0, atol=1e-9))
        body = ifcopenshell.util.element.get_psets(el)["Torsal_Part"]["Body"]
        if item.is_a("IfcExtrudedAreaSolid"):
            assert flat and body == I.PlateBody.EXTRUSION.value
            assert rep.RepresentationType == "SweptSolid"
            assert item.Depth == pytest.approx(fs.thickness)
            area = item.SweptArea
            inner = area.InnerCurves if area.is_a("IfcArbitraryProfileDefWithVoids") else ()
            circles = [c for c in inner if c.is_a("IfcCircle")]
            assert len(circles) == len(part.holes)
            assert sorted(2 * c.Radius for c in circles) \
                == pytest.approx(sorted(h.diameter for h in part.holes))
        else:
            assert item.is_a("IfcTriangulatedFaceSet") and item.Closed is True
            assert rep.RepresentationType == "Tessellation" and body == I.PlateBody.TRIANGULATED.value
    names = {e.Name: _body(e)[1].is_a() for e in _parts(f)}
    # the bent connectors and fixings are never extruded; every plate on one plane with
    # square ends is, every folded plate is not
    assert all(v == "IfcTriangulatedFaceSet" for k, v in names.items() if k.startswith(("C-", "A-")))
    flat = [p.name for p in fs.plates if I._flat(p)]
    folded = [p.name for p in fs.plates if not np.allclose(p.fold_angles, 0.0)]
    assert all(names[n] == "IfcExtrudedAreaSolid" for n in flat)
    assert all(names[n] == "IfcTriangulatedFaceSet" for n in folded)
    # (a plate with a tab bent from an end is folded: on the flat grid rows 0 and 2 stay
    # flat, on the sphere none)
    assert (len(flat) >= 2 or fs.tab_joints) and (folded or len(flat) == len(fs.plates))


def test_materials_with_thickness(exported):
    fs, f, out = exported
    for el in _parts(f):
        mat = ifcopenshell.util.element.get_material(el, should_skip_usage=True)
        assert mat.is_a("IfcMaterialLayerSet")
        (layer,) = mat.MaterialLayers
        assert layer.LayerThickness == pytest.approx(fs.thickness) and layer.Material.Name == "aluminium"
        usage = ifcopenshell.util.element.get_material(el)
        assert usage.is_a("IfcMaterialLayerSetUsage") == _body(el)[1].is_a("IfcExtrudedAreaSolid")
    (alu,) = [m for m in f.by_type("IfcMaterial") if m.Name == "aluminium"]
    (props,) = alu.HasProperties
    assert props.Properties[0].NominalValue.wrappedValue == 2700.0
    for el in f.by_type("IfcMechanicalFastener"):
        assert ifcopenshell.util.element.get_material(el).Name == "stainless steel"


def test_bolts_and_anchors_are_mechanical_fasteners_through_their_plies(exported):
    fs, f, out = exported
    rows = _parts_csv(out)
    fasteners = f.by_type("IfcMechanicalFastener")
    assert len(fasteners) == sum(int(r["fasteners"]) for r in rows) > 0
    counts = fastener_counts(fs)
    kinds = [e.PredefinedType for e in fasteners]
    assert kinds.count("BOLT") == sum(c.bolts for c in counts.values())
    assert kinds.count("ANCHORBOLT") == sum(c.anchors for c in counts.values()) > 0
    plate_holes = {p.name: [h.center for h in p.holes] for p in fs.plates}
    for el in fasteners:
        ps = ifcopenshell.util.element.get_psets(el)["Torsal_Fastener"]
        place = el.ObjectPlacement.RelativePlacement
        start, axis = np.array(place.Location.Coordinates), np.array(place.Axis.DirectionRatios)
        part = fs.part(ps["Part"])
        hole = part.holes[ps["Hole"]]
        # the shank passes the part's hole, and a bolt's the matching hole of its plate
        along = (hole.center - start) @ axis
        assert np.linalg.norm(hole.center - start - along * axis) < 1e-6
        assert 0 < along < el.NominalLength
        assert el.NominalDiameter == pytest.approx({"BOLT": 6.0, "ANCHORBOLT": 8.0}[el.PredefinedType])
        if el.PredefinedType == "BOLT":
            def off_axis(c):
                return np.linalg.norm(c - start - ((c - start) @ axis) * axis)

            c = min(plate_holes[ps["Host"]], key=off_axis)
            assert off_axis(c) < 1e-6
            assert 0 < (c - start) @ axis < el.NominalLength
        else:
            assert ps["Host"] == "building"


def test_strips_are_assemblies_of_their_plates_in_the_storey(exported):
    fs, f, out = exported
    (storey,) = f.by_type("IfcBuildingStorey")
    assert [e.is_a() for e in (ifcopenshell.util.element.get_aggregate(storey),
                               ifcopenshell.util.element.get_aggregate(f.by_type("IfcBuilding")[0]))] \
        == ["IfcBuilding", "IfcSite"]
    assert ifcopenshell.util.element.get_aggregate(f.by_type("IfcSite")[0]).is_a("IfcProject")
    assemblies = f.by_type("IfcElementAssembly")
    assert sorted(a.Name for a in assemblies) == sorted({p.name[:-4] for p in fs.plates})
    seen = []
    for a in assemblies:
        parts = ifcopenshell.util.element.get_decomposition(a)
        assert parts and all(p.Name.startswith(a.Name + "-") for p in parts)
        assert ifcopenshell.util.element.get_container(a) == storey
        seen += [p.Name for p in parts]
    assert sorted(seen) == sorted(p.name for p in fs.plates)
    for el in [*f.by_type("IfcMechanicalFastener"), *(e for e in _parts(f) if e.Name[0] in "CA")]:
        assert ifcopenshell.util.element.get_container(el) == storey


def test_site_and_north(exported):
    fs, f, out = exported
    (site,) = f.by_type("IfcSite")
    lat, lon = site.RefLatitude, site.RefLongitude
    assert lat[0] + lat[1] / 60 + (lat[2] + lat[3] / 1e6) / 3600 == pytest.approx(48.21, abs=1e-9)
    assert lon[0] + lon[1] / 60 + (lon[2] + lon[3] / 1e6) / 3600 == pytest.approx(-16.37, abs=1e-9)
    assert all(v <= 0 for v in lon)
    assert site.RefElevation == pytest.approx(170_000.0)          # mm
    (model,) = [c for c in f.by_type("IfcGeometricRepresentationContext")
                if not c.is_a("IfcGeometricRepresentationSubContext")]
    north = np.array(model.TrueNorth.DirectionRatios)
    # true north 30 degrees counter-clockwise from +y, as the light's sun vectors take it
    assert north == pytest.approx([-0.5, math.sqrt(3) / 2])


def test_global_ids_stay_with_the_project(exported, tmp_path):
    fs, f, out = exported
    again = ifcopenshell.open(str(fs.export_ifc(tmp_path / "again.ifc", latitude=48.21,
                                                longitude=-16.37)))
    ids = {e.Name: e.GlobalId for e in _parts(f)}
    assert {e.Name: e.GlobalId for e in _parts(again)} == ids
    other = ifcopenshell.open(str(I.export_ifc(fs, tmp_path / "other.ifc", project="another")))
    assert not set(ids.values()) & {e.GlobalId for e in _parts(other)}
    assert len({e.GlobalId for e in other.by_type("IfcRoot")}) == len(other.by_type("IfcRoot"))


def test_global_ids_are_ifcopenshells_compressed_uuid5(exported):
    """_guid makes the GlobalId from the UUID's bytes: the same 22 characters as
    ifcopenshell.guid.compress of its hex text, which expands back to that UUID."""
    import uuid

    import ifcopenshell.guid

    fs, f, out = exported
    ns = uuid.uuid5(uuid.NAMESPACE_URL, "torsal:torsal fins")
    keys = [p.name for p in fs.parts] + ["project", "storey-contents", "k\u00e9y \u2713", ""]
    keys += [f"fastener:C-N{n:04d}-{i}.{h}" for n in range(0, 4000, 7) for i in range(3) for h in range(2)]
    for key in keys:
        u = uuid.uuid5(ns, key)
        g = I._guid(ns, key)
        assert g == ifcopenshell.guid.compress(u.hex)
        assert len(g) == 22 and uuid.UUID(ifcopenshell.guid.expand(g)) == u
    # the plates of the file carry them
    assert {e.GlobalId for e in _parts(f)} == {I._guid(ns, p.name) for p in fs.parts}


def test_the_same_fins_write_the_same_bytes_a_second_later(exported, tmp_path):
    import time

    fs = exported[0]
    first = fs.export_ifc(tmp_path / "first.ifc", latitude=48.21, longitude=-16.37).read_bytes()
    time.sleep(1.1)                       # the clock's second moves on: not in the file
    again = fs.export_ifc(tmp_path / "again.ifc", latitude=48.21, longitude=-16.37).read_bytes()
    assert first == again
    assert b"'2000-01-01T00:00:00'" in first      # the fixed stamp (no SOURCE_DATE_EPOCH)


@SPHERE_QUICK
def test_written_by_a_process_of_its_own_the_same_bytes(exported, tmp_path):
    from torsal.core.parallel import limit_workers

    fs = exported[0]
    here = fs.export_ifc(tmp_path / "here.ifc", latitude=48.21, longitude=-16.37).read_bytes()
    pending = fs.start_ifc(tmp_path / "there.ifc", latitude=48.21, longitude=-16.37)
    assert pending._process is not None                     # another process writes it
    assert pending.result() == tmp_path / "there.ifc"
    assert (tmp_path / "there.ifc").read_bytes() == here
    with limit_workers(1):                                   # no second process: written here
        alone = fs.start_ifc(tmp_path / "alone.ifc", latitude=48.21, longitude=-16.37)
        assert alone._process is None and alone.result().read_bytes() == here
    # the error of the other process is raised here, and no file is left
    bad = fs.start_ifc(tmp_path / "bad.ifc", density=0.0)
    with pytest.raises(ValueError, match="density"):
        bad.result()
    assert not (tmp_path / "bad.ifc").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["alone.ifc", "here.ifc", "there.ifc"]


def test_a_failed_write_leaves_no_file(exported, tmp_path, monkeypatch):
    fs, f, out = exported

    def broken(self, path):
        path.write_text("ISO-10303-21; half")
        raise OSError("disk full")

    monkeypatch.setattr(I._Writer, "write", broken)
    with pytest.raises(OSError, match="disk full"):
        fs.export_ifc(tmp_path / "fins.ifc")
    assert list(tmp_path.iterdir()) == []


@SPHERE_QUICK
def test_other_units_and_bad_options(exported, tmp_path):
    fs, f, out = exported
    with pytest.raises(ValueError, match="latitude and longitude"):
        I.export_ifc(fs, tmp_path / "x.ifc", latitude=48.0)
    with pytest.raises(ValueError, match="density"):
        I.export_ifc(fs, tmp_path / "x.ifc", density=0.0)
    assert not (tmp_path / "x.ifc").exists()
    inch = FinSystem.from_strips([fs.parts[0].panels / 25.4], thickness=0.125, unit="in",
                                 model_unit="in")
    g = ifcopenshell.open(str(inch.export_ifc(tmp_path / "inch.ifc", flat_profiles=False)))
    (length,) = [u for u in g.by_type("IfcProject")[0].UnitsInContext.Units
                 if u.is_a("IfcNamedUnit") and u.UnitType == "LENGTHUNIT"]
    assert length.is_a("IfcConversionBasedUnit") and length.Name == "inch"
    assert length.ConversionFactor.ValueComponent.wrappedValue == pytest.approx(0.0254)
    assert _validation_statements(g) == [] and not g.by_type("IfcMaterialLayerSetUsage")
    (plate,) = g.by_type("IfcPlate")
    assert _body(plate)[1].is_a("IfcTriangulatedFaceSet")
    assert ifcopenshell.util.element.get_psets(plate)["Torsal_Part"]["Family"] == -1
    volume = ifcopenshell.util.shape.get_volume(
        ifcopenshell.geom.create_shape(ifcopenshell.geom.settings(), plate).geometry) / 0.0254 ** 3
    assert volume == pytest.approx(_volume(solid_shapes(inch, workers=1)[plate.Name]), rel=1e-6)


def test_prism_profile_of_a_box_and_not_of_a_fold():
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox

    box = BRepPrimAPI_MakeBox(40.0, 20.0, 3.0).Shape()
    prof = I.prism_profile(box, 3.0)
    assert prof is not None and prof.depth == pytest.approx(3.0)
    assert abs(prof.z_dir @ [0, 0, 1]) == pytest.approx(1.0)
    x, y = prof.outer[:, 0], prof.outer[:, 1]
    assert 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) == pytest.approx(800.0)
    assert I.prism_profile(box, 5.0) is None               # a prism, but not 5 thick
    vertices, tri, closed = I.closed_triangles(box, 0.1)
    assert closed and len(vertices) == 8 and len(tri) == 12
    # a bent plate (an L of two legs 3 thick) is no extrusion of its outline
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Fuse
    from OCP.gp import gp_Pnt

    leg = BRepPrimAPI_MakeBox(gp_Pnt(0, 0, 0), gp_Pnt(3.0, 20.0, 30.0)).Shape()
    bent = BRepAlgoAPI_Fuse(box, leg).Shape()
    assert I.prism_profile(bent, 3.0) is None
    assert I.closed_triangles(bent, 0.1)[2]


DESIGN = """
name = "ifc pipeline"
units = "cm"
[surface]
generator = "facade_patch"
params = { nu = 4, nv = 4 }
[site]
latitude = 48.21
longitude = 16.37
north_angle = 15.0
[sun]
vectors = [[0.3, -0.8, 0.5]]
[fins]
spacing = 3.0
depth = 0.5
[constraints]
min_torsal_angle = 40
[outputs]
rhino_3dm = false
dxf = false
renders = false
"""


def test_the_fabrication_stage_writes_fins_ifc_and_nothing_half_written(tmp_path, monkeypatch):
    import tomllib
    import warnings

    from torsal.core.parallel import limit_workers
    from torsal.pipeline import DEFAULT_PIPELINE, Design, StageCache
    from torsal.pipeline.design_file import DesignSpec

    spec = DesignSpec.model_validate(tomllib.loads(DESIGN))
    assert spec.outputs.ifc is True                              # the default
    pipe, cache = DEFAULT_PIPELINE.until("fabrication"), StageCache(tmp_path / "cache")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = Design(spec).run(tmp_path / "out", pipeline=pipe, cache=cache)
    assert run.files["ifc"] == "fins.ifc"
    f = ifcopenshell.open(str(tmp_path / "out" / "fins.ifc"))
    assert f.by_type("IfcProject")[0].Name == "ifc pipeline"
    assert f.by_type("IfcSite")[0].RefLatitude[:2] == (48, 12)
    rows = _parts_csv(tmp_path / "out")
    assert sorted(e.Name for e in _parts(f)) == sorted(r["part_id"] for r in rows)
    # a remeshed structure (trimmed ends, dropped panels): valid, and the volumes of fins.step
    assert _validation_statements(f) == []
    step = {name: _volume(solid) for name, solid in read_step(tmp_path / "out" / "fins.step")}
    settings = ifcopenshell.geom.settings()
    for el in _parts(f):
        volume = ifcopenshell.util.shape.get_volume(
            ifcopenshell.geom.create_shape(settings, el).geometry) * 1e9     # m^3 -> mm^3
        assert volume == pytest.approx(step[el.Name], rel=5e-3), el.Name

    # the export fails half way (after writing some of the file): no fins.ifc, no results
    def broken(self, path):
        path.write_text("ISO-10303-21; half")
        raise OSError("disk full")

    monkeypatch.setattr(I._Writer, "write", broken)
    thicker = spec.model_copy(update={"material": spec.material.model_copy(update={"thickness_mm": 4.0})})
    # in this process (the patched writer; the IFC's own process is tested above)
    with warnings.catch_warnings(), pytest.raises(OSError, match="disk full"), limit_workers(1):
        warnings.simplefilter("ignore")
        Design(thicker).run(tmp_path / "failed", pipeline=pipe, cache=cache)
    left = list((tmp_path / "failed").rglob("*")) if (tmp_path / "failed").exists() else []
    assert not [p for p in left if p.name.startswith(("fins", ".fins"))], left
