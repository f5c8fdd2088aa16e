"""The 3DM's Breps (torsal.fabrication.rhino): the records made without rhino3dm, read back
by rhino3dm as closed, valid solids with the solid's faces, vertices and volume (plane faces
with holes, curved hole walls as triangles, far from the origin), the mesh's Brep where they
make none, and the records put into a file rhino3dm wrote."""
from __future__ import annotations

import numpy as np
import pytest

rhino3dm = pytest.importorskip("rhino3dm")

from torsal.fabrication import rhino as R  # noqa: E402
from torsal.fabrication.rhino import brep_volume as _brep_volume  # noqa: E402


def _box(x0, y0, z0, dx, dy, dz):
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.gp import gp_Pnt

    return BRepPrimAPI_MakeBox(gp_Pnt(x0, y0, z0), dx, dy, dz).Shape()


def _cut(a, b):
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut

    from torsal.fabrication.plates import _downcast

    return _downcast(BRepAlgoAPI_Cut(a, b).Shape())


def _volume(shape) -> float:
    from torsal.fabrication.solids import _volume

    return _volume(shape)


def _faces(shape) -> int:
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer

    exp, n = TopExp_Explorer(shape, TopAbs_FACE), 0
    while exp.More():
        n += 1
        exp.Next()
    return n


def _brep(record):
    brep = rhino3dm.CommonObject.Decode(R._encoding(record))
    assert isinstance(brep, rhino3dm.Brep)
    return brep


@pytest.mark.parametrize("origin", [(0.0, 0.0, 0.0), (-61234.5, 48211.25, 15000.0)])
def test_a_plate_with_a_through_hole_is_a_brep_of_its_faces(origin):
    """A plate with a square hole: its top and bottom faces have a hole (an inner loop), the
    hole's walls are faces of their own: ten faces, 16 vertices, its volume; valid far from the
    origin too (facade coordinates)."""
    x, y, z = origin
    shape = _cut(_box(x, y, z, 200.0, 100.0, 3.0), _box(x + 50.0, y + 30.0, z - 1.0, 40.0, 20.0, 5.0))
    assert _faces(shape) == 10
    record = R.brep_record(shape, 0.15)
    assert record is not None
    brep = _brep(record)
    assert brep.IsValid and brep.IsSolid
    assert len(brep.Faces) == 10 and len(brep.Vertices) == 16 and len(brep.Edges) == 24
    assert sorted(len(f.Loops) for f in brep.Faces) == [1] * 8 + [2, 2]
    assert _brep_volume(brep) == pytest.approx(_volume(shape), rel=1e-9)
    # what brep_of gives, and rhino3dm's encoding of it
    assert R.brep_of(shape, 0.15).Encode()["data"] == brep.Encode()["data"]
    assert rhino3dm.CommonObject.Decode(R.encoded_brep(shape, 0.15)).IsValid


def test_a_curved_hole_wall_is_its_triangles():
    """A plate with a round hole: the plane faces are faces (with a polygonal hole), the
    cylinder's wall its mesh's triangles, a face each: a valid solid of the meshed solid's
    volume."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeCylinder
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt

    from torsal.fabrication.plates import _triangles

    hole = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(60.0, 40.0, -1.0), gp_Dir(0, 0, 1)), 8.0, 5.0).Shape()
    shape = _cut(_box(0.0, 0.0, 0.0, 120.0, 80.0, 3.0), hole)
    record = R.brep_record(shape, 0.15)
    assert record is not None
    brep = _brep(record)
    assert brep.IsValid and brep.IsSolid
    v, t = _triangles(shape, 0.15)
    meshed = np.einsum("ij,ij->", v[t[:, 0]], np.cross(v[t[:, 1]], v[t[:, 2]])) / 6.0
    assert _brep_volume(brep) == pytest.approx(meshed, rel=1e-9)
    assert _volume(shape) == pytest.approx(meshed, rel=5e-3)
    planar = [f for f in brep.Faces if len(f.Loops) == 2]
    assert len(planar) == 2                                      # top and bottom
    ring = len(planar[0].Loops[1].Trims)                         # the hole's polygon
    assert len(brep.Faces) == 6 + 2 * ring                       # + the wall's triangles


def test_faces_that_do_not_close_or_face_inwards_make_no_record():
    """A tetrahedron: its four faces make a record; without one face (open), or turned
    inside out, none."""
    pts = np.array([[0.0, 0.0, 0.0], [10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [0.0, 0.0, 10.0]])
    faces = [[[0, 2, 1]], [[0, 1, 3]], [[1, 2, 3]], [[0, 3, 2]]]
    brep = _brep(R._brep_bytes(pts, faces))
    assert brep.IsValid and brep.IsSolid and _brep_volume(brep) == pytest.approx(1000.0 / 6.0)
    assert R._brep_bytes(pts, faces[:3]) is None
    assert R._brep_bytes(pts, [[lp[::-1] for lp in f] for f in faces]) is None
    assert R._brep_bytes(pts, [[[0, 2, 1]], [[0, 1, 3]], [[1, 2, 3]], [[0, 2, 3]]]) is None


def test_brep_of_joins_the_mesh_where_there_is_no_record(monkeypatch):
    """Where the faces make no record, brep_of is the mesh's Brep (rhino3dm's
    CreateFromMesh, edge tolerances set): valid and closed, a face per quad."""
    shape = _box(0.0, 0.0, 0.0, 30.0, 20.0, 3.0)
    monkeypatch.setattr(R.brep, "brep_record", lambda *a, **k: None)     # where brep_of finds it
    brep = R.brep_of(shape, 0.15)
    assert brep.IsValid and brep.IsSolid and len(brep.Faces) == 6
    assert rhino3dm.CommonObject.Decode(R.encoded_brep(shape, 0.15)).IsValid


def test_splice_puts_the_records_in_the_place_of_their_placeholders(tmp_path):
    """A file rhino3dm wrote with placeholders: the records take their places, attributes
    kept, other objects as they were; a file of another kind or without a placeholder of a
    record is refused."""
    shape = _cut(_box(0.0, 0.0, 0.0, 200.0, 100.0, 3.0), _box(50.0, 30.0, -1.0, 40.0, 20.0, 5.0))
    record = R.brep_record(shape, 0.15)
    model = rhino3dm.File3dm()
    for k, name in enumerate(["a", "b", "c"]):
        attr = rhino3dm.ObjectAttributes()
        attr.Name = name
        if name == "b":
            model.Objects.AddLine(rhino3dm.Point3d(0, 0, 0), rhino3dm.Point3d(1, 1, 1), attr)
        else:
            model.Objects.AddPoint(R.placeholder(k), attr)
    assert model.Write(str(tmp_path / "skeleton.3dm"), 7)
    data = (tmp_path / "skeleton.3dm").read_bytes()
    (tmp_path / "out.3dm").write_bytes(R.splice_records(data, {0: record, 2: record}))
    back = rhino3dm.File3dm.Read(str(tmp_path / "out.3dm"))
    objects = [(o.Attributes.Name, type(o.Geometry).__name__) for o in back.Objects]
    assert objects == [("a", "Brep"), ("b", "LineCurve"), ("c", "Brep")]
    assert all(o.Geometry.IsValid for o in back.Objects)
    with pytest.raises(ValueError):
        R.splice_records(data, {0: record, 5: record})
    with pytest.raises(ValueError):
        R.splice_records(b"not a 3dm file" + bytes(40), {0: record})


def test_fixed_properties_leave_no_path_or_clock_in_the_file(tmp_path):
    """openNURBS writes the path written to and the time (created, last edited) into the
    properties: two writes of the same model, a second apart into folders of different
    lengths, differ; with the properties fixed they are the same bytes, the file's own name
    in the place of the path, rhino3dm reads them, and the revision history holds the fixed
    date where it held today's (its fields read here from openNURBS' layout)."""
    import struct
    import time
    import zlib

    from torsal.fabrication.rhino.properties import FIXED_TIME

    import uuid

    def written(folder):
        model = rhino3dm.File3dm()
        layer = rhino3dm.Layer()
        layer.Name, layer.Id = "family 0", uuid.uuid5(uuid.NAMESPACE_URL, "layer")   # as export_3dm
        attributes = rhino3dm.ObjectAttributes()
        attributes.Id, attributes.LayerIndex = uuid.uuid5(uuid.NAMESPACE_URL, "part"), model.Layers.Add(layer)
        model.Objects.AddPoint(rhino3dm.Point3d(1.0, 2.0, 3.0), attributes)
        path = tmp_path / folder / "fins.3dm"
        path.parent.mkdir()
        assert model.Write(str(path), 7)
        return path.read_bytes()

    a = written("a")
    time.sleep(1.05)
    b = written("a longer folder")
    assert a != b and len(a) != len(b)
    fa, fb = (R.fixed_properties(x, "fins.3dm") for x in (a, b))
    assert fa == fb
    assert str(tmp_path).encode("utf-16-le") not in fa and "fins.3dm".encode("utf-16-le") in fa
    (tmp_path / "fixed.3dm").write_bytes(fa)
    back = rhino3dm.File3dm.Read(str(tmp_path / "fixed.3dm"))
    assert back is not None and len(back.Objects) == 1 and back.Revision == 1
    # TCODE_PROPERTIES_REVISIONHISTORY: version byte, created-by (empty: count 0), created
    # (8 int32), last-edited-by, last edited, revision count, CRC-32 of what precedes it
    at = fa.index(struct.pack("<I", 0x20008021))
    (n,) = struct.unpack_from("<q", fa, at + 4)
    body = fa[at + 12:at + 12 + n]
    ints = struct.unpack_from("<19i", body, 1)
    today = time.gmtime()
    assert struct.unpack_from("<19i", a[a.index(struct.pack("<I", 0x20008021)) + 12:], 1)[6] \
        == today.tm_year - 1900
    assert ints[1:9] == ints[10:18] == struct.unpack("<8i", FIXED_TIME) == (0, 0, 0, 1, 0, 100, 6, 0)
    assert ints[18] == 1 and struct.unpack("<I", body[-4:])[0] == zlib.crc32(body[:-4])
    with pytest.raises(ValueError, match="3dm"):
        R.fixed_properties(b"not a 3dm file" + bytes(40), "fins.3dm")
