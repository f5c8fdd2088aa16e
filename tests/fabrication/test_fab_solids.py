"""Solids: STEP re-read with OCP (count, names, validity, volume), slots in 3D, no two parts
interfering, preview exports re-read, invalid solids reported by part id."""
from __future__ import annotations

import itertools
import re
import struct
import warnings

import numpy as np
import pytest

from fab_structures import cylinder_structure, developable_strip, sphere_structure
from torsal.fabrication import FinSystem, InvalidSolidError, read_step

pytest.importorskip("build123d")


def _ocp_check(shape):
    from OCP.BRepCheck import BRepCheck_Analyzer
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(shape, props)
    return BRepCheck_Analyzer(shape).IsValid(), props.Mass()


def _expected_volume(fs):
    """sum(panel area x thickness) minus the slots (w x depth inside the plate, half of it at
    a part end), from the 3D panels (triangle areas) and the slot records."""
    total = 0.0
    for p in fs.parts:
        q = p.panels
        area = 0.5 * (np.linalg.norm(np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0]), axis=1)
                      + np.linalg.norm(np.cross(q[:, 2] - q[:, 0], q[:, 3] - q[:, 0]), axis=1)).sum()
        for s in p.slots:
            inner = 0 < s.position < len(q)
            area -= s.width * s.depth * (1.0 if inner else 0.5)
        total += area * fs.thickness
    return total


@pytest.fixture(scope="module")
def sphere_fs():
    return FinSystem(sphere_structure(nu=4, nv=3, step=0.12), thickness=3.0, clearance=0.5)


def test_step_reread_with_ocp_has_valid_named_solids_and_volume(sphere_fs, tmp_path):
    import build123d as bd

    fs = sphere_fs
    path = fs.export_step(tmp_path / "fins.step")
    names = sorted(p.name for p in fs.parts)
    # 1. OCP XCAF reader: one valid solid per part, with the part's name
    solids = read_step(path)
    assert sorted(n for n, _ in solids) == names
    vol = 0.0
    for n, s in solids:
        ok, v = _ocp_check(s)
        assert ok, n
        assert v > 0
        vol += v
    expected = _expected_volume(fs)
    assert abs(vol - expected) <= 0.005 * expected
    # 2. build123d's own STEP importer agrees, colours included
    comp = bd.import_step(path)
    assert sorted(c.label for c in comp.children) == names
    assert len(comp.solids()) == len(fs.parts)
    fam = {p.name: p.family for p in fs.parts}
    for c in comp.children:
        rgb = tuple(c.color)[:3]
        assert rgb == pytest.approx(fs.part(c.label).color, abs=1e-3)
    # 3. the raw file names every part in a PRODUCT entity
    text = path.read_text(errors="ignore")
    assert sorted(set(re.findall(r"PRODUCT\('((?:F\d-S\d+-P\d+)|(?:C-N\d+-\d+)|(?:A-E\d+-\d+))'",
                                 text))) == names
    # plates of both families, fixings, and the connectors where a bracket stayed (tabs
    # instead elsewhere: parts of their plates)
    assert {0, 1, -3} <= set(fam.values()) <= {0, 1, -2, -3}
    assert (-2 in fam.values()) == bool(fs.connectors) and (fs.connectors or fs.tab_joints)


def test_volume_equals_unrolled_area_times_thickness(sphere_fs):
    for p in sphere_fs.parts:
        s = sphere_fs.solids()[p.name]
        flat = sphere_fs.unrolled()[p.name].outline.area * sphere_fs.thickness
        assert s.volume == pytest.approx(flat, rel=1e-3), p.name


def test_slots_are_cut_where_the_crossing_plate_passes(sphere_fs):
    from build123d import Vector

    fs = sphere_fs
    sol = fs.solids()
    s = fs.structure
    assert len(fs.crossings) == 2
    for x in fs.crossings:
        a = s.vertices_a[x.node] * 1000
        b = s.vertices_b[x.node] * 1000
        u = (b - a) / np.linalg.norm(b - a)
        p0, p1 = sol[x.parts0[0]], sol[x.parts1[0]]
        in_slot0 = b - 0.5 * x.depth0 * u       # inside family 0's slot (open on the b side)
        in_slot1 = a + 0.5 * x.depth1 * u       # inside family 1's slot (open on the a side)
        assert not p0.is_inside(Vector(*in_slot0)) and p1.is_inside(Vector(*in_slot0))
        assert p0.is_inside(Vector(*in_slot1)) and not p1.is_inside(Vector(*in_slot1))
        # the slots run past each other by the clearance (0.5 mm): their ends stand that far
        # apart on the node line, and between them neither plate is
        assert x.depth0 + x.depth1 == pytest.approx(np.linalg.norm(b - a) + 0.5, rel=1e-12)
        end1, end0 = a + x.depth1 * u, b - x.depth0 * u
        assert np.linalg.norm(end1 - end0) == pytest.approx(0.5, rel=1e-9)
        for at, plate in ((end1, p1), (end0, p0)):
            # just beyond its slot's end a plate is solid, just inside it it is not
            past = 0.1 if plate is p1 else -0.1
            assert plate.is_inside(Vector(*(at + past * u)))
            assert not plate.is_inside(Vector(*(at - past * u)))
        gap = Vector(*(0.5 * (end0 + end1)))
        assert not p0.is_inside(gap) and not p1.is_inside(gap)
        # width: half the slot width either side of the node line, in family 0's panel
        part0 = fs.part(x.parts0[0])
        j = [sl.position for sl in part0.slots if sl.node == x.node][0]
        n = part0.normals[j]
        v = np.cross(n, u)
        for off, inside in ((0.5 * x.width - 0.05, False), (0.5 * x.width + 0.05, True)):
            for sgn in (-1, 1):
                assert p0.is_inside(Vector(*(in_slot0 + sgn * off * v))) == inside
        assert x.width == pytest.approx(fs.thickness + fs.clearance)


def _overlap(a, b) -> float:
    c = a.intersect(b)
    if c is None:
        return 0.0
    return float(getattr(c, "volume", None) if hasattr(c, "volume") else sum(s.volume for s in c))


def test_parts_do_not_interfere_egg_crate_assembles(sphere_fs):
    sol = sphere_fs.solids()
    worst = max(_overlap(sol[m], sol[n]) for m, n in itertools.combinations(sol, 2))
    assert worst < 1e-6
    # the check can fail: the same plate without its slots collides with its crossing strip
    import dataclasses

    from torsal.fabrication import part_solid

    x = sphere_fs.crossings[0]
    plain = part_solid(dataclasses.replace(sphere_fs.part(x.parts0[0]), slots=[]), sphere_fs.thickness)
    assert _overlap(plain, sol[x.parts1[0]]) > 0.25 * sphere_fs.thickness ** 2 * x.depth1


def test_folded_closed_strips_valid_and_interference_free():
    # the rows fold at every crossing: split there, the two parts meet on a seam in the
    # crossing plate's slot (issue 42) or are butted with brackets; no slot across a fold
    s = cylinder_structure(nu=6, nv=3, closed=True)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fs = FinSystem(s, thickness=3.0, clearance=0.5)
    seams = {sm.node for sm in fs.seams_in_slot}
    assert not [c for c in fs.crossings if c.fold > 10.0 and c.node not in seams]
    assert seams or fs.connectors
    sol = fs.solids()
    assert len(sol) == len(fs.parts) and all(v.is_valid for v in sol.values())
    worst = max(_overlap(sol[m], sol[n]) for m, n in itertools.combinations(sol, 2))
    assert worst < 1e-6
    total = sum(v.volume for v in sol.values())
    assert total == pytest.approx(_expected_volume(fs), rel=5e-3)


def test_developable_strips_are_thickened_the_same_way():
    quads, _ = developable_strip(k=5, seed=3, max_fold_deg=35.0)
    fs = FinSystem.from_strips([quads, quads + [0, 1.0, 0]], thickness=2.0)
    sol = fs.solids()
    assert len(sol) == 2
    for p in fs.parts:
        assert sol[p.name].is_valid
        assert sol[p.name].volume == pytest.approx(p.panel_areas.sum() * 2.0, rel=1e-3)


def test_invalid_solid_is_reported_by_part_id():
    fs = FinSystem(sphere_structure(), thickness=3.0)
    bad = fs.parts[2]
    q = bad.panels.copy()
    q[1, [1, 2]] = q[1, [2, 1]]            # a bow-tie panel
    bad.panels = q
    with pytest.raises(InvalidSolidError) as e:
        fs.solids()
    assert e.value.parts == [bad.name]
    assert bad.name in str(e.value)


def test_preview_exports_reread(sphere_fs, tmp_path):
    import rhino3dm
    import trimesh

    fs = sphere_fs
    names = sorted(p.name for p in fs.parts)
    vol = sum(s.volume for s in fs.solids().values())
    glb = fs.export_gltf(tmp_path / "fins.glb")
    scene = trimesh.load(glb)
    assert sorted(scene.geometry) == names
    stl = fs.export_stl(tmp_path / "fins.stl")
    mesh = trimesh.load(stl)
    assert mesh.volume == pytest.approx(vol, rel=1e-3)
    f3dm = fs.export_3dm(tmp_path / "fins.3dm")
    model = rhino3dm.File3dm.Read(str(f3dm))
    assert sorted(o.Attributes.Name for o in model.Objects) == names
    assert model.Settings.ModelUnitSystem == rhino3dm.UnitSystem.Millimeters


def _brep_volume(brep) -> float:
    """Volume of a rhino3dm Brep of planar faces (rhino3dm has no mass properties): the sum
    over its faces' loops, each a polygon of its trims' start vertices (the divergence
    theorem: (1/6) sum (p_i x p_i+1) . c, c a point of the face's plane)."""
    pts = np.array([(v.Location.X, v.Location.Y, v.Location.Z) for v in brep.Vertices])
    total = 0.0
    for face in brep.Faces:
        outer = pts[[t.StartVertexIndex for t in face.Loops[0].Trims]]
        c = outer.mean(axis=0)
        for loop in face.Loops:
            p = pts[[t.StartVertexIndex for t in loop.Trims]]
            total += np.cross(p - c, np.roll(p, -1, axis=0) - c).sum(axis=0) @ c / 6.0
    return total


def _ocp_faces_and_vertices(shape):
    """The number of faces of an OCC shape and its vertices (k, 3), each once."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FACE, TopAbs_VERTEX
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    def each(kind):
        exp, found = TopExp_Explorer(shape, kind), {}
        while exp.More():
            found.setdefault(hash(exp.Current()), exp.Current())
            exp.Next()
        return list(found.values())

    pts = [BRep_Tool.Pnt_s(TopoDS.Vertex(v)) for v in each(TopAbs_VERTEX)]
    return len(each(TopAbs_FACE)), np.array([(p.X(), p.Y(), p.Z()) for p in pts])


def test_3dm_holds_one_closed_valid_brep_per_part_on_layers_by_family_and_kind(sphere_fs, tmp_path):
    """fins.3dm re-read with rhino3dm: a solid, valid Brep per part, named as in parts.csv, on
    the layer of its family or of its connector kind, with the faces (one per face: all are
    planes), the vertices and the volume of the part's OpenCascade solid."""
    import rhino3dm

    from torsal.fabrication.solids import _volume, solid_shapes

    fs = sphere_fs
    model = rhino3dm.File3dm.Read(str(fs.export_3dm(tmp_path / "fins.3dm")))
    bom = {r["part_id"]: r for r in fs.bill_of_materials(tmp_path / "parts.csv")}
    layers = {i: model.Layers.FindIndex(i).FullPath for i in range(len(model.Layers))}
    kinds = {r["kind"] for r in bom.values()} - {"plate"}
    assert "fixing" in kinds and set(layers.values()) == {"family 0", "family 1", "fixings"} | (
        {"connectors"} | {f"connectors::{k}" for k in kinds - {"fixing"}} if fs.connectors else set())
    shapes = solid_shapes(fs)
    seen = set()
    for o in model.Objects:
        g, name = o.Geometry, o.Attributes.Name
        assert isinstance(g, rhino3dm.Brep) and g.IsSolid and g.IsValid, name
        assert name in bom and name not in seen
        seen.add(name)
        row = bom[name]
        want = ("fixings" if row["kind"] == "fixing" else f"connectors::{row['kind']}"
                if row["kind"] != "plate" else f"family {row['family']}")
        assert layers[o.Attributes.LayerIndex] == want
        # the Brep's vertices are the solid's corners, its faces the solid's faces, its
        # volume the solid's
        n_faces, pts = _ocp_faces_and_vertices(shapes[name])
        brep = np.array([(v.Location.X, v.Location.Y, v.Location.Z) for v in g.Vertices])
        assert len(brep) == len(pts) and len(g.Faces) == n_faces >= 6
        assert np.abs(np.sort(brep, axis=0) - np.sort(pts, axis=0)).max() < 1e-9
        assert _brep_volume(g) == pytest.approx(_volume(shapes[name]), rel=1e-9)
    assert seen == set(bom)
    # a part and a layer keep their ids in the next file of the same parts
    again = rhino3dm.File3dm.Read(str(fs.export_3dm(tmp_path / "again.3dm")))
    ids = {o.Attributes.Name: str(o.Attributes.Id) for o in model.Objects}
    assert {o.Attributes.Name: str(o.Attributes.Id) for o in again.Objects} == ids
    assert len(set(ids.values())) == len(ids)
    assert [str(x.Id) for x in again.Layers] == [str(x.Id) for x in model.Layers]


def test_slightly_nonplanar_structure_still_gives_valid_solids_and_reports_unroll_error():
    """Optimized structures are planar only to delta_pl ~ 1e-3: warped panels are split into
    triangles with the same diagonal on both faces, unrolled by least squares, error reported."""
    from torsal.geometry.support import SupportStructure

    s = sphere_structure(nu=4, nv=3)
    rng = np.random.default_rng(0)
    warped = SupportStructure(s.vertices_a + rng.normal(scale=3e-4, size=s.vertices_a.shape),
                              s.vertices_b + rng.normal(scale=3e-4, size=s.vertices_b.shape),
                              s.faces, s.edges, s.edge_family)
    assert warped.delta_pl > 1e-3
    fs = FinSystem(warped, thickness=3.0, clearance=0.5)
    sol = fs.solids()
    assert all(v.is_valid for v in sol.values())
    total = sum(v.volume for v in sol.values())
    flat = sum(u.area for u in fs.unrolled().values()) * fs.thickness
    assert total == pytest.approx(flat, rel=5e-3)
    errs = [u.max_edge_error for u in fs.unrolled().values()]
    # the warped plates are developed by least squares (connectors are built flat)
    assert not any(fs.unrolled()[p.name].planar for p in fs.parts if p.family >= 0)
    assert 1e-8 < max(errs) < 1e-3


def test_worker_processes_build_the_same_solids(sphere_fs):
    """Solids built by two worker processes (sent back as BReps) equal the serial ones: same
    names, labels, colours, valid, and the volume of the mid-surface area x thickness."""
    from torsal.fabrication.solids import build_solids

    serial = build_solids(sphere_fs, workers=1)
    parallel = build_solids(sphere_fs, workers=2)
    assert list(parallel) == list(serial) == [p.name for p in sphere_fs.parts]
    for name, s in parallel.items():
        assert s.label == name and s.is_valid
        assert tuple(s.color)[:3] == pytest.approx(tuple(serial[name].color)[:3])
        assert s.volume == pytest.approx(serial[name].volume, rel=1e-12)
        assert len(s.faces()) == len(serial[name].faces())
    assert sum(s.volume for s in parallel.values()) == pytest.approx(_expected_volume(sphere_fs), rel=0.005)


def test_solids_started_in_the_background_are_the_same(sphere_fs):
    """start_solids returns at once; solids() collects the same solids as a serial build, and
    a started build can be cancelled (a later step of the stage failed)."""
    from torsal.fabrication import FinSystem
    from torsal.fabrication.solids import build_solids

    serial = build_solids(sphere_fs, workers=1)
    fs = FinSystem(sphere_fs.structure, thickness=sphere_fs.thickness, clearance=sphere_fs.clearance)
    assert fs.start_solids(workers=2)
    assert not fs.start_solids(workers=2)          # one build at a time
    flat = fs.unrolled()                           # this process goes on meanwhile
    assert sorted(flat) == sorted(serial)
    background = fs.solids()
    assert list(background) == list(serial)
    for name, s in background.items():
        assert s.is_valid and s.volume == pytest.approx(serial[name].volume, rel=1e-12)
    assert not fs.start_solids(workers=2)          # built already
    other = FinSystem(sphere_fs.structure, thickness=sphere_fs.thickness, clearance=sphere_fs.clearance)
    assert other.start_solids(workers=2)
    other.cancel_solids()
    assert list(other.solids(workers=1)) == list(serial)


def test_prepared_workers_mesh_the_solids_the_exports_read(sphere_fs, tmp_path):
    """Workers started ahead (prepare_workers, mesh=True) build the solids and mesh them: the
    STEP written from those shapes re-reads as the serial build's solids, and the preview
    triangles are the ones this process makes from a serial build (same vertices and
    triangles), so the 3DM holds the same meshes."""
    from torsal.fabrication import FinSystem
    from torsal.fabrication import solids as S

    serial = S.solid_shapes(FinSystem(sphere_fs.structure, thickness=sphere_fs.thickness,
                                      clearance=sphere_fs.clearance), workers=1)
    fs = FinSystem(sphere_fs.structure, thickness=sphere_fs.thickness, clearance=sphere_fs.clearance)
    assert S.prepare_workers(len(fs.parts), workers=2, mesh=True) == 2
    assert fs.start_solids(workers=2)
    step = fs.export_step(tmp_path / "fins.step")
    assert fs._solids is None                      # no build123d solids were needed
    reread = dict(S.read_step(step))
    assert sorted(reread) == sorted(serial)
    from OCP.BRepTools import BRepTools

    tol = S.MESH_TOLERANCE * fs.thickness
    for name, shape in S.solid_shapes(fs).items():
        assert BRepTools.Triangulation_s(shape, tol)        # meshed by the worker
        assert S._volume(reread[name]) == pytest.approx(S._volume(serial[name]), rel=1e-9)
        v, f = S._triangles(shape, tol)
        v0, f0 = S._triangles(serial[name], tol)
        np.testing.assert_array_equal(f, f0)
        np.testing.assert_allclose(v, v0, rtol=0, atol=1e-9)
    S.release_workers()
    # the workers made the 3DM's Breps too: the file holds the same solids as one whose Breps
    # this process makes (read back with rhino3dm: names, closed valid Breps, vertices, faces)
    import rhino3dm

    assert fs._breps.key == S._parts_key(fs) and set(fs._breps.breps) == set(serial)
    assert all(b is not None for b in fs._breps.breps.values())
    here = FinSystem(sphere_fs.structure, thickness=sphere_fs.thickness, clearance=sphere_fs.clearance)

    def breps(path):
        out = {}
        for o in rhino3dm.File3dm.Read(str(path)).Objects:
            g = o.Geometry
            assert isinstance(g, rhino3dm.Brep) and g.IsSolid and g.IsValid
            out[o.Attributes.Name] = (len(g.Vertices), len(g.Faces), len(g.Edges),
                                      round(g.GetBoundingBox().Min.Z, 9), round(g.GetBoundingBox().Max.X, 9))
        return out

    assert breps(fs.export_3dm(tmp_path / "workers.3dm")) == \
        breps(here.export_3dm(tmp_path / "here.3dm")) and len(breps(tmp_path / "here.3dm")) == len(serial)
    assert getattr(here, "_breps", None) is None


def test_slot_area_from_the_records_is_the_unrolled_one(sphere_fs):
    """The slots' area from their records (width x depth, half at a part end), which the cut
    is checked against, is what the unrolled outline loses (panels' area - outline area)."""
    from torsal.fabrication import solids as S

    slotted = [p for p in sphere_fs.parts if p.slots]
    assert slotted
    for p in slotted:
        assert S._slot_record_area(p) == pytest.approx(S._slot_area(p), rel=1e-3)


def test_workers_make_the_3dm_records_with_the_solids(sphere_fs, tmp_path):
    """With mesh=True the workers hand each solid over with its 3DM record, made from the
    shape they built (not read again from its bytes): the same bytes as this process makes
    from the solid it got, their CPU seconds counted (``breps_cpu_seconds``, part of
    ``solids_cpu_seconds``); forgotten (cancel_solids), the 3DM makes them here: the same
    file's objects."""
    import rhino3dm

    from torsal.fabrication import FinSystem
    from torsal.fabrication import solids as S
    from torsal.fabrication.rhino import brep_record

    fs = FinSystem(sphere_fs.structure, thickness=sphere_fs.thickness, clearance=sphere_fs.clearance)
    assert S.prepare_workers(len(fs.parts), workers=2, mesh=True) == 2
    assert fs.start_solids(workers=2)
    shapes = S.solid_shapes(fs)
    made = fs._breps.breps
    assert set(made) == {p.name for p in fs.parts}
    tol = S.MESH_TOLERANCE * fs.thickness
    assert made == {name: brep_record(shape, tol) for name, shape in shapes.items()}
    assert 0 < fs.breps_cpu_seconds < fs.solids_cpu_seconds

    def objects(path):
        return {o.Attributes.Name: (len(o.Geometry.Vertices), len(o.Geometry.Faces), o.Geometry.IsValid,
                                    o.Geometry.IsSolid, str(o.Attributes.Id))
                for o in rhino3dm.File3dm.Read(str(path)).Objects}

    workers = objects(fs.export_3dm(tmp_path / "workers.3dm"))
    fs.cancel_solids()
    assert fs._breps is None
    assert objects(fs.export_3dm(tmp_path / "here.3dm")) == workers
    assert len(workers) == len(fs.parts) and all(v[2] and v[3] for v in workers.values())


def _chunks(data: bytes, a: int, b: int) -> dict:
    """{type code: [chunk bytes]} of the chunks of a .3dm file between ``a`` and ``b``."""
    out: dict = {}
    while a < b:
        tc, n = struct.unpack_from("<Iq", data, a)
        end = a + 12 + (0 if tc & 0x80000000 else n)
        out.setdefault(tc, []).append(data[a:end])
        a = end
    return out


def test_3dm_is_the_file_rhino3dm_writes_with_the_breps_added(sphere_fs, tmp_path, monkeypatch):
    """The records put in the place of their placeholders make the file rhino3dm writes when
    it is given the Breps (decoded from the same records, added with the same attributes):
    every table the same bytes (the object table too) but the properties (rhino3dm stamps
    the time and the file's name). Should rhino3dm write a file the splice does not expect, the Breps are added
    so: the same objects."""
    import rhino3dm

    from torsal.fabrication import exports
    from torsal.fabrication.rhino import _encoding, brep_record
    from torsal.fabrication.solids import solid_shapes

    fs = sphere_fs
    spliced = fs.export_3dm(tmp_path / "fins.3dm").read_bytes()
    # the same model with the Breps decoded and added by rhino3dm (IsSolid not asked: it
    # would be written with the Brep)
    shapes = solid_shapes(fs)
    tol = exports.MESH_TOLERANCE * fs.thickness
    records = {p.name: brep_record(shapes[p.name], tol) for p in fs.parts}
    model, placed, meshed = exports._rhino_model(fs, shapes, records, tol, splice=True)
    assert not meshed and len(placed) == len(fs.parts)
    ref = rhino3dm.File3dm()
    ref.Settings.ModelUnitSystem = model.Settings.ModelUnitSystem
    ref.Settings.ModelAbsoluteTolerance = model.Settings.ModelAbsoluteTolerance
    for lay in model.Layers:
        ref.Layers.Add(lay)
    for k, o in enumerate(model.Objects):
        ref.Objects.AddBrep(rhino3dm.CommonObject.Decode(_encoding(placed[k])), o.Attributes)
    assert ref.Write(str(tmp_path / "ref.3dm"), 7)
    expected = (tmp_path / "ref.3dm").read_bytes()
    got, want = _chunks(spliced, 32, len(spliced)), _chunks(expected, 32, len(expected))
    assert spliced[:32] == expected[:32]
    assert set(got) == set(want) and 0x10000013 in got            # the object table
    # but the properties (the time, the file's name) and the end mark (the file's length)
    assert {tc for tc in got if got[tc] != want[tc]} <= {0x10000014, 0x00007FFF}
    # rhino3dm adds the Breps itself where the splice fails
    def refuse(data, records):
        raise ValueError("unexpected")

    monkeypatch.setattr("torsal.fabrication.exports.splice_records", refuse)
    added = rhino3dm.File3dm.Read(str(fs.export_3dm(tmp_path / "added.3dm")))
    again = rhino3dm.File3dm.Read(str(tmp_path / "fins.3dm"))
    assert [(o.Attributes.Name, str(o.Attributes.Id), o.Attributes.LayerIndex, len(o.Geometry.Faces),
             o.Geometry.IsValid, o.Geometry.IsSolid) for o in added.Objects] == \
        [(o.Attributes.Name, str(o.Attributes.Id), o.Attributes.LayerIndex, len(o.Geometry.Faces),
          o.Geometry.IsValid, True) for o in again.Objects]
