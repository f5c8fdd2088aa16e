"""fins.step gives back the solids the assembly check checks (issue 40).

The assembly stage checks the solids the design's files were written from (the solids'
workers make the check's copy of each, :func:`~torsal.fabrication.workers.check_solids`), not
``fins.step`` read again on every run. What the workshop gets is proved here instead: the
STEP file, read with OpenCascade's XCAF reader and with build123d's importer (two readers
apart from the writer), holds every part once, by name, each solid the right way out with
the volume, the vertex box and the faces of the solid it was written from; and the check's
copies of the solids are the same whether the workers or this process made them.
"""
from __future__ import annotations

import numpy as np
import pytest

from fab_structures import sphere_structure
from torsal.fabrication import FinSystem, joints_of
from torsal.fabrication import solids as S
from torsal.fabrication.assembly import TOUCHING_TOLERANCE, check_assembly
from torsal.fabrication.assembly.occ import _faces, _shape, _signed_volume, _vertices
from torsal.fabrication.workers import check_solids


pytest.importorskip("build123d")


@pytest.fixture(scope="module")
def structure():
    return sphere_structure(nu=4, nv=3, step=0.12)


def _fins(structure) -> FinSystem:
    """A fin system of its own (its solids not built yet): 3 mm plates, 0.5 mm clearance."""
    return FinSystem(structure, thickness=3.0, clearance=0.5)


def _box(shape) -> np.ndarray:
    """(2, 3) the extents of a polyhedral solid's vertices (exact, unlike a Bnd_Box, which
    adds the shape's tolerances)."""
    v = _vertices(shape)
    return np.array([v.min(axis=0), v.max(axis=0)])


def _same_solids(read: dict, built: dict) -> None:
    assert sorted(read) == sorted(built)
    for name, shape in read.items():
        v, v0 = _signed_volume(shape), _signed_volume(built[name])
        assert v0 > 0 and v > 0, name                         # neither is inside out
        assert v == pytest.approx(v0, rel=1e-9), name
        np.testing.assert_allclose(_box(shape), _box(built[name]), rtol=0, atol=1e-6,
                                   err_msg=name)
        assert len(_faces(shape)) == len(_faces(built[name])), name


def test_step_gives_back_every_solid_it_was_written_from(structure, tmp_path):
    import build123d as bd

    fs = _fins(structure)
    built = S.solid_shapes(fs, workers=1)
    path = fs.export_step(tmp_path / "fins.step")
    assert len(built) == len(fs.parts) >= 7
    # OpenCascade's XCAF reader (torsal's read_step): one solid per part, by name
    xcaf = S.read_step(path)
    assert len(xcaf) == len(built)
    _same_solids(dict(xcaf), built)
    # build123d's importer: the components' labels and their solids
    comp = bd.import_step(path)
    _same_solids({c.label: c.solids()[0].wrapped for c in comp.children}, built)


def test_a_solid_written_out_of_place_is_caught(structure, tmp_path):
    # the comparison fails where the file does not give a solid back: one part written
    # 0.01 mm off its place (its box), or not at all (the names)
    from OCP.gp import gp_Trsf, gp_Vec
    from OCP.TopLoc import TopLoc_Location

    fs = _fins(structure)
    built = S.solid_shapes(fs, workers=1)
    name = next(iter(built))
    shift = gp_Trsf()
    shift.SetTranslation(gp_Vec(0.0, 0.0, 0.01))
    path = tmp_path / "moved.step"
    S.write_step([(n, s.Moved(TopLoc_Location(shift)) if n == name else s, (0.5, 0.5, 0.5))
                  for n, s in built.items()], path, unit=fs.unit)
    with pytest.raises(AssertionError, match=name):
        _same_solids(dict(S.read_step(path)), built)
    S.write_step([(n, s, (0.5, 0.5, 0.5)) for n, s in built.items() if n != name], path,
                 unit=fs.unit)
    with pytest.raises(AssertionError):
        _same_solids(dict(S.read_step(path)), built)


def test_the_check_takes_the_same_solids_from_the_workers_as_made_here(structure):
    # prepare_workers(check=...): the workers make the check's solids with the solids; the
    # same bytes and records as check_solids makes in this process from a serial build
    here = check_solids(_fins(structure), TOUCHING_TOLERANCE)
    fs = _fins(structure)
    assert S.prepare_workers(len(fs.parts), workers=2, check=TOUCHING_TOLERANCE) == 2
    try:
        assert fs.start_solids(workers=2)
        S.solid_shapes(fs)
    finally:
        S.release_workers()
    assert fs._check_solids.key == S._parts_key(fs)
    assert sorted(fs._check_solids.rows) == sorted(p.name for p in fs.parts)
    there = check_solids(fs, TOUCHING_TOLERANCE, release=True)
    assert fs._check_solids is None                 # let go once taken
    again = check_solids(fs, TOUCHING_TOLERANCE)    # made here, of the workers' bytes
    assert [n for n, _ in there] == [n for n, _ in here] == [n for n, _ in again] == \
        [p.name for p in fs.parts]
    for (_, a), (_, b), (_, c) in zip(there, here, again):
        assert np.array_equal(a.records.triangles, c.records.triangles)
        for x, y in zip(a.records, b.records):
            if isinstance(x, tuple):
                assert len(x) == len(y) and all(np.array_equal(p, q) for p, q in zip(x, y))
            else:
                assert np.array_equal(x, y)
        assert _signed_volume(_shape(a)) == _signed_volume(_shape(b))
        # the records' vertices (its faces', in order) are those of the solid as it arrived
        assert np.array_equal(a.records.vertices, _vertices(_shape(a)))
    # at another tolerance the workers' copies are not taken: made here, meshed at that one
    other = check_solids(fs, 2 * TOUCHING_TOLERANCE)
    assert len(other) == len(there)
    # and the check finds the same on either
    joints = joints_of(fs)

    def verdict(solids):
        r = check_assembly(solids, joints=joints, workers=1)
        return r.buildable, r.report()["pairs_checked"], [s.part for s in r.order]

    assert verdict(there) == verdict(here)
    assert verdict(there)[0]
