"""A plate re-read from STEP stays the right way out (example 7c's F0-S001-P00 at 3db0016).

The STEP reader heals what it reads (ShapeFix_Solid), and orients a solid by classifying a
point at infinity; on this long (978 mm), thin (at most 127 mm across), non-convex plate that
classification comes out IN and the plate came back inside out: the assembly check's common of
it and the bracket at node 197 beside it was all of the bracket (4,314 mm^3), while the solids
as built are 0.05 mm apart. Rebuilt here from the two parts of that build (mm, moved near the
origin); seconds. The same plate, and panels warped with a reflex corner at 1 or 3, built by
the sewn fallback (faces one by one) are split on the same inner diagonal.
"""
import dataclasses

import numpy as np
import pytest

from torsal.fabrication.assembly.occ import _signed_volume, common_volume
from torsal.fabrication.exports import read_step, write_step
from torsal.fabrication.model import CONNECTOR_FAMILY, Part, PartId, quad_normals
from torsal.fabrication.plates import (_coplanar, _fan_volume, _part_shape, _plate_outlines,
                                       _plate_sewn)

T = 3.0   # mm, the plates' and the connector's thickness in example 7c

PLATE = Part(
    id=PartId(0, 1, 0), nodes=np.array([197, 203]), edges=np.array([3]), span=(1, 2),
    panels=np.array([[[0.0, 0.0, 0.0], [511.746034, -94.268702, 274.933945],
                      [855.375307, -195.929554, 449.840339], [347.23544, -29.573109, 195.27731]]]),
    miters=np.array([[-0.492636386, -0.214172607, 0.843468723]] * 2))
BRACKET = Part(
    id=PartId(CONNECTOR_FAMILY, 197, 0), nodes=np.full(3, 197), edges=np.full(2, -1), span=(0, 2),
    panels=np.array([[[123.508808, -20.498352, 63.294383], [123.256096, -14.654087, 64.628812],
                      [227.426728, -23.526019, 123.212005], [227.67944, -29.370284, 121.877576]],
                     [[123.256096, -14.654087, 64.628812], [125.986204, -16.255817, 59.531659],
                      [230.156836, -25.127749, 118.114852], [227.426728, -23.526019, 123.212005]]]),
    miters=np.array([[0.49261143, 0.213909917, -0.843549955],
                     [0.562588201, -1.40438551, -1.213057513],
                     [-0.19338727, -0.960861371, 0.198360249]]))


def test_sliver_plate_reread_from_step_is_not_inside_out(tmp_path):
    built = {p.name: _part_shape(p, T) for p in (PLATE, BRACKET)}
    # as built: a sound plate, and the bracket clear of it
    assert _signed_volume(built[PLATE.name]) > 0
    assert common_volume(built[BRACKET.name], built[PLATE.name]) == 0.0
    path = tmp_path / "joint.step"
    write_step([(n, s, (0.5, 0.5, 0.5)) for n, s in built.items()], path, unit="mm")
    reread = dict(read_step(path))
    assert set(reread) == set(built)
    for name, solid in reread.items():
        v = _signed_volume(solid)
        # the volume of the plate as built (41,092 mm^3), and positive: not turned inside out
        assert v > 0 and abs(v - _signed_volume(built[name])) < 1e-6 * v, name
    # the bracket does not cut the plate re-read (was 4,314 mm^3: all of the bracket)
    assert common_volume(reread[BRACKET.name], reread[PLATE.name]) == 0.0


def _prism_volume(part: Part, thickness: float, tri) -> float:
    """Volume of a one-panel plate computed apart from the solid builder: its top and bottom
    faces (corners +- t/2 x mitre) tiled by the triangles ``tri`` of the panel, each
    triangle with the one under it a prism of three tetrahedra (side faces planar)."""
    q, m = part.panels[0], part.miters[[0, 1, 1, 0]]
    top, bot = q + 0.5 * thickness * m, q - 0.5 * thickness * m

    def tet(a, b, c, d):
        return np.linalg.det(np.array([b - a, c - a, d - a])) / 6.0

    v = 0.0
    for i, j, k in tri:
        a, b, c, a2, b2, c2 = top[i], top[j], top[k], bot[i], bot[j], bot[k]
        v += tet(a, b, c, a2) + tet(b, c, a2, b2) + tet(c, a2, b2, c2)
    return abs(v)


def _warped(reflex: int) -> Part:
    """A 100 mm panel warped by 4 mm whose corner ``reflex`` (1 or 3) is reflex."""
    q = np.array([[0.0, 0, 0], [100, 0, 0], [100, 100, 0], [0, 100, 0]])
    q[reflex] = [62.0, 38.0, 4.0] if reflex == 3 else [38.0, 62.0, 4.0]
    n = quad_normals(q[None])[0]
    return Part(id=PartId(0, 9, reflex), nodes=np.array([1, 2]), edges=np.array([0]), span=(0, 1),
                panels=q[None], miters=np.array([n, n]))


@pytest.mark.parametrize("part", [PLATE, _warped(1), _warped(3)],
                         ids=["7c-F0-S001", "reflex-1", "reflex-3"])
def test_sewn_fallback_splits_a_reflex_quad_inside(part):
    # the fallback that sews faces made one by one (taken where the direct B-rep is not
    # closed) splits a warped quad on the diagonal inside it (1-3), as the direct one does:
    # with the fan from corner 0 it gave 7c's plate inside out (-41,092 mm^3)
    assert not _coplanar(_plate_outlines(part, T)[0][:1], 1e-9)[0]        # the top is warped
    solid, poly_volume = _plate_sewn(part, T, 1e-9)
    expected = _prism_volume(part, T, [[1, 2, 3], [1, 3, 0]])
    assert _signed_volume(solid) > 0
    assert _signed_volume(solid) == pytest.approx(expected, rel=1e-9)
    assert poly_volume == pytest.approx(expected, rel=1e-9)
    # and so is the volume of its faces as the fallback sums it for outlines with repeats
    faces = zip(*_plate_outlines(part, T))
    assert sum(s * _fan_volume(f) for f, s in faces) == pytest.approx(expected, rel=1e-9)
    # (the outside diagonal on the top and the bottom bounds the same volume, up to its sign:
    # the sewn shell overlapped itself and OpenCascade gave it -41,092 mm^3 on 7c's plate)


def test_step_read_in_the_background_gives_the_same_solids(tmp_path):
    # start_read_step: OpenCascade's reader in a process of its own, the solids sent back in
    # binary BRep form: the same names and vertices (bit for bit) as read_step in this
    # process, the volumes to round-off (the binary form normalizes each plane's direction
    # again when it reads it: 41091.96628623667 -> ...6806 mm^3), the sliver plate healed the
    # right way out; bit for bit what this process gets in the same form (where no second
    # process may start, or the assembly stage reads the file itself); a changed file is not
    # taken from a read of the file before (the pipeline's hand-over to the assembly stage)
    from torsal.core.parallel import limit_workers
    from torsal.fabrication.assembly.occ import _shape, _vertices
    from torsal.fabrication.exports import binary_round_trip, start_read_step
    from torsal.pipeline import assembly as stage

    built = {p.name: _part_shape(p, T) for p in (PLATE, BRACKET)}
    path = tmp_path / "joint.step"
    write_step([(n, s, (0.5, 0.5, 0.5)) for n, s in built.items()], path, unit="mm")
    here = read_step(path)
    pending = start_read_step(path)
    assert pending._process is not None
    there = pending.result()
    with limit_workers(1):
        alone = start_read_step(path)
        assert alone._process is None
        alone = alone.result()
    assert [n for n, _ in there] == [n for n, _ in here] == [PLATE.name, BRACKET.name]
    for (_, a), (_, b), (_, c), (_, d) in zip(here, there, alone, binary_round_trip(here)):
        assert np.array_equal(_vertices(a), _vertices(b))
        assert _signed_volume(a) > 0 and abs(_signed_volume(b) / _signed_volume(a) - 1) < 1e-13
        assert _signed_volume(b) == _signed_volume(c) == _signed_volume(d)
    stage.prefetch_step_solids(path)
    taken = stage._step_solids(path)
    assert [n for n, _ in taken] == [PLATE.name, BRACKET.name]
    assert stage._PREFETCHED.get() is None                  # taken once
    assert [_signed_volume(_shape(s)) for _, s in stage._step_solids(path)] == \
        [_signed_volume(_shape(s)) for _, s in taken]       # read here: the same solids
    stage.prefetch_step_solids(path)
    write_step([(PLATE.name, built[PLATE.name], (0.5, 0.5, 0.5))], path, unit="mm")
    assert [n for n, _ in stage._step_solids(path)] == [PLATE.name]   # the new file
    stage.drop_prefetched_solids()
    assert stage._PREFETCHED.get() is None


def test_the_background_read_meshes_the_solids_as_the_check_would(tmp_path):
    # the reading process meshes the solids for the assembly check and makes the records of
    # its cheap tests: the triangles it sends are those the check makes of the same file
    # read here, bit for bit, and its face records are those of the solid that arrives
    # (the same faces in the same explorer order: the same vertices, edges and normals)
    from torsal.fabrication.assembly import TOUCHING_TOLERANCE
    from torsal.fabrication.assembly.occ import _boundary_triangles, _face_records, _mesh, _shape
    from torsal.fabrication.assembly.prepared import PreparedSolid, face_records_of, solid_records
    from torsal.fabrication.assembly.separation import solid_cover
    from torsal.fabrication.exports import binary_round_trip, read_step_for_check, start_read_step

    path = tmp_path / "joint.step"
    write_step([(p.name, _part_shape(p, T), (0.5, 0.5, 0.5)) for p in (PLATE, BRACKET)], path,
               unit="mm")
    pending = start_read_step(path, mesh_tolerance=TOUCHING_TOLERANCE)
    assert pending._process is not None
    there = pending.result()
    here = binary_round_trip(read_step(path))
    _mesh([s for _, s in here], TOUCHING_TOLERANCE)
    alone = read_step_for_check(path, mesh_tolerance=TOUCHING_TOLERANCE)
    for (_, a), (_, b), (_, c) in zip(there, here, alone):
        assert isinstance(a, PreparedSolid) and isinstance(c, PreparedSolid)
        ta, tb = _boundary_triangles(_shape(a)), _boundary_triangles(b)
        assert len(ta) >= 12 and np.array_equal(ta, tb)
        assert np.array_equal(a.records.triangles, tb)
        mine, sent = _face_records(b), face_records_of(_shape(a), a.records)
        assert len(mine) == len(sent) >= 6
        for f, g in zip(mine, sent):
            assert np.array_equal(f.points, g.points) and np.array_equal(f.edges, g.edges)
            assert np.array_equal(f.normal, g.normal)
        cover = solid_cover(b, mine)
        assert [mine.index(f) for f, _ in cover] == list(a.records.cover_faces)
        assert np.allclose(cover[0][1], a.records.cover_vector, rtol=1e-12, atol=0)
        for x, y in zip(solid_records(_shape(c)), a.records):     # in this process alike
            assert all(np.array_equal(u, v) for u, v in zip(x, y)) if isinstance(x, tuple) \
                else np.allclose(x, y, rtol=1e-12, atol=0)


def test_the_reading_process_reads_half_the_solids_in_a_fork(tmp_path):
    # the reading process transfers, meshes and records the odd components in a fork of
    # itself: the same rows (names, binary BReps with their triangles, records), in the same
    # order, as reading the file whole (read_step) and meshing every solid in one process,
    # for an odd count too
    from torsal.fabrication.assembly import TOUCHING_TOLERANCE
    from torsal.fabrication.exports import _rows, _split_rows

    path = tmp_path / "three.step"
    write_step([(n, _part_shape(p, T), (0.5, 0.5, 0.5)) for n, p in
                (("a", PLATE), ("b", BRACKET), ("c", PLATE))], path, unit="mm")
    forked = _split_rows(path, TOUCHING_TOLERANCE)
    here = _rows(read_step(path), TOUCHING_TOLERANCE)
    assert [n for n, _, _ in forked] == [n for n, _, _ in here] == ["a", "b", "c"]
    for (_, a, ra), (_, b, rb) in zip(forked, here):
        assert a == b and len(a) > 1000
        assert len(ra.triangles) >= 12 and np.array_equal(ra.triangles, rb.triangles)
        assert all(np.array_equal(u, v) for u, v in zip(ra.face_points, rb.face_points))


def test_components_read_one_by_one_are_the_solids_of_the_whole_read(tmp_path):
    # the reading process transfers the assembly's components one by one, half in a fork
    # (exports._split_rows): each is bit for bit (OpenCascade's binary form: vertices,
    # tolerances, the placement the assembly gives it) the solid read_step's XCAF reader
    # gives, under the same name, in the same order; a file that is not an assembly of
    # parts (a bare solid) is left to read_step
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    from torsal.fabrication.exports import (_flat_components, _read_solids, _rows, _split_rows,
                                            _step_reader)
    from torsal.fabrication.workers import _to_bytes

    parts = (PLATE, BRACKET, dataclasses.replace(PLATE, id=PartId(0, 2, 0)))
    path = tmp_path / "joint.step"
    write_step([(p.name, _part_shape(p, T), (0.5, 0.5, 0.5)) for p in parts], path, unit="mm")
    whole = read_step(path)
    components = _flat_components(_step_reader(path))
    assert [n for _, n in components] == [n for n, _ in whole] == [p.name for p in parts]
    one_by_one = _read_solids(path)
    assert [n for n, _ in one_by_one] == [n for n, _ in whole]
    assert [_to_bytes(s) for _, s in one_by_one] == [_to_bytes(s) for _, s in whole]
    assert _split_rows(path, None) == _rows(whole, None)          # forked: the same rows
    bare = tmp_path / "bare.step"
    writer = STEPControl_Writer()
    writer.Transfer(_part_shape(PLATE, T), STEPControl_AsIs)
    writer.Write(str(bare))
    assert _flat_components(_step_reader(bare)) is None
    assert [_to_bytes(s) for _, s in _read_solids(bare)] == [_to_bytes(s) for _, s in read_step(bare)]
