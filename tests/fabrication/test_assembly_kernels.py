"""The exact cheap tests of the assembly check (separating axes, ray parity, clear prisms)
against values computed by hand or by OpenCascade's booleans."""
from __future__ import annotations

import numpy as np
import pytest

from torsal.fabrication.assembly import (_boundary_triangles, _face_prism, _face_records,
                                         _inside_by_ray, common_volume, hull_clear_of_triangles,
                                         prism_clear, swept_overlap)

pytest.importorskip("build123d")

CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)


def _box(x, y, z, *, at=(0.0, 0.0, 0.0), rotate_z=0.0):
    from build123d import Align, Box, Pos, Rot

    return Rot(0, 0, rotate_z) * (Pos(*at) * Box(x, y, z, align=(Align.MIN,) * 3))


def _triangle_in_plane(normal, offset, centre, size=5.0):
    """A large triangle in the plane normal . x = offset around the foot of ``centre``."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    c = np.asarray(centre, float) + (offset / np.linalg.norm(normal) - n @ centre) * n
    u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    w = np.cross(n, u)
    return np.array([[c + size * u, c - size * (u + w), c + size * w]])


def test_separating_plane_through_a_corner_of_the_cube():
    # the plane x + y + z = 3 touches the unit cube at (1, 1, 1) only; at 2.9 it cuts off a
    # corner tetrahedron (legs 0.1), so a triangle there reaches into the cube
    touch = _triangle_in_plane([1, 1, 1], 3.0, [1, 1, 1])
    cut = _triangle_in_plane([1, 1, 1], 2.9, [1, 1, 1])
    assert hull_clear_of_triangles(CUBE, touch)
    assert not hull_clear_of_triangles(CUBE, cut)
    # a tilted plane apart by 1e-3 and one reaching 1e-6 in (beyond the 1e-7 tolerance)
    assert hull_clear_of_triangles(CUBE, _triangle_in_plane([1, 2, 0], 3.0 + 1e-3, [1, 1, 0.5]))
    assert not hull_clear_of_triangles(CUBE, _triangle_in_plane([1, 2, 0], 3.0 - 1e-6 * np.sqrt(5),
                                                                [1, 1, 0.5]))


def test_edge_against_edge_needs_the_cross_axis():
    # a triangle in the plane x = 0.5 (it cuts the cube) whose lower edge z = 1.01 + 0.02 y
    # passes 0.01 above the cube's top edge (y = 0, z = 1), the rest of it above: no face
    # normal of either separates them, the cross product of the two edges does
    skew = np.array([[[0.5, -1.0, 0.99], [0.5, 1.0, 1.03], [0.5, 0.0, 5.0]]])
    assert hull_clear_of_triangles(CUBE, skew)
    assert not hull_clear_of_triangles(CUBE, skew - [0.0, 0.0, 0.02])     # 0.01 into the cube


def test_ray_parity_inside_outside_and_on_the_surface():
    from torsal.fabrication.assembly import _mesh

    box = _box(2, 3, 4, at=(1, 1, 1)).wrapped
    _mesh([box], 1.0)
    tri = _boundary_triangles(box)
    assert _inside_by_ray(np.array([2.0, 2.0, 2.0]), tri) is True
    assert _inside_by_ray(np.array([2.0, 2.0, 5.5]), tri) is False
    assert _inside_by_ray(np.array([0.0, 0.0, 0.0]), tri) is False
    assert _inside_by_ray(np.array([2.0, 2.0, 5.0]), tri) is None        # on the top face


@pytest.mark.parametrize("angle", [0.0, 30.0, 45.0])
def test_clear_prisms_agree_with_the_exact_boolean(angle):
    """Every face prism of a box slid past, into or through a neighbour: where prism_clear
    says clear, the exact boolean gives 0 (within its round-off)."""
    from torsal.fabrication.assembly import _mesh

    rng = np.random.default_rng(int(angle))
    moving = _box(4, 1, 2, rotate_z=angle).wrapped
    faces = _face_records(moving)
    decided = undecided = 0
    for _ in range(12):
        at = rng.uniform(-3, 5, 3)
        other = _box(*rng.uniform(0.5, 3, 3), at=at, rotate_z=rng.uniform(0, 90)).wrapped
        _mesh([other], 1.0)
        tri = _boundary_triangles(other)
        from torsal.fabrication.assembly import _bbox

        ob = _bbox(other)
        v = rng.normal(size=3)
        v *= rng.uniform(1, 6) / np.linalg.norm(v)
        for f in faces:
            pr = _face_prism(f.face, v)
            if pr is None:
                continue
            if prism_clear(f, v, tri, ob):
                decided += 1
                assert common_volume(pr, other) == pytest.approx(0.0, abs=1e-9)
            else:
                undecided += 1
    assert decided > 0 and undecided > 0


def test_prisms_of_a_part_against_many_solids_at_once_as_one_by_one():
    """prisms_clear_of_each (one pass over a part's path and a dozen solids) gives, pair for
    pair, what prisms_clear of each solid gives, and proves apart where the exact boolean
    finds nothing in common."""
    from torsal.fabrication.assembly import _bbox, _mesh, prisms_clear
    from torsal.fabrication.assembly.separation import prisms_clear_of_each

    rng = np.random.default_rng(7)
    moving = _box(4, 1, 2, rotate_z=30.0).wrapped
    faces = _face_records(moving)
    others = []
    for _ in range(12):
        other = _box(*rng.uniform(0.5, 3, 3), at=rng.uniform(-3, 5, 3),
                     rotate_z=rng.uniform(0, 90)).wrapped
        _mesh([other], 1.0)
        tri = _boundary_triangles(other)
        others.append((other, tri, _bbox(other)))
    v = np.array([1.0, -2.0, 0.5])
    candidates = rng.random((len(faces), len(others))) < 0.8
    each = prisms_clear_of_each(faces, v, [(t, b, (t.min(axis=1), t.max(axis=1)))
                                           for _, t, b in others], candidates)
    for i, (other, tri, box) in enumerate(others):
        rows = np.flatnonzero(candidates[:, i])
        one = prisms_clear([faces[n] for n in rows], v, tri, box)
        assert each[rows, i].tolist() == one.tolist()
        assert not each[~candidates[:, i], i].any()
        for n in rows[one]:
            pr = _face_prism(faces[n].face, v)
            assert pr is None or common_volume(pr, other) == pytest.approx(0.0, abs=1e-9)
    assert 0 < each.sum() < candidates.sum()          # some proved apart, some not


def test_swept_overlap_of_a_tilted_plate_known_by_hand():
    # a 10 x 1 x 2 plate turned 45 degrees about z slides 10 along its long axis into place;
    # a cube 0.5 beside it (apart by a plane parallel to the plate's side) is never met
    plate = _box(10, 1, 2, rotate_z=45.0)
    d = np.array([np.cos(np.pi / 4), np.sin(np.pi / 4), 0.0])
    side = np.array([-d[1], d[0], 0.0])
    from build123d import Pos

    # the plate's side face is side . x = 1: the cube starts at 1.5
    beside = Pos(*(1.5 * side - 5 * d)) * _box(1, 1, 1, at=(0, 0, 0), rotate_z=45.0)
    assert swept_overlap(plate, 10 * d, [beside]) == [0.0]
    # a block on the path behind the plate, x' in [-4, -3] along d, across its section: of
    # the face prisms only the rear end cap's (x' in [-10, 0]) meets it, in 1 x 1 x 2; the
    # side faces run along the path and sweep nothing
    block = Pos(*(-4.0 * d)) * _box(1, 1, 2, rotate_z=45.0)
    assert swept_overlap(plate, 10 * d, [block])[0] == pytest.approx(2.0, rel=1e-9)
    # the block sits in the plate's section, so a ray-parity or separating-axis slip would
    # show: moved 1 aside (beyond the side face) it is clear again
    assert swept_overlap(plate, 10 * d, [Pos(*side) * block]) == [0.0]


def _clear(a, b):
    """solid_clear of build123d solids a (covered) against b (its triangles)."""
    from torsal.fabrication.assembly import _bbox, _mesh, solid_clear, solid_cover

    a, b = getattr(a, "wrapped", a), getattr(b, "wrapped", b)
    _mesh([a, b], 1.0)
    return solid_clear(solid_cover(a), _boundary_triangles(b), _bbox(b))


def test_solid_cover_is_a_cover_of_the_solid():
    from torsal.fabrication.assembly import _face_prism, solid_cover

    # a bent (L-shaped) plate: the prisms of its exit faces over its extent hold all of it,
    # so the sum of their common volumes with the solid is at least its volume
    ell = (_box(10, 1, 4) + _box(1, 8, 4)).wrapped
    cover = solid_cover(ell)
    got = sum(common_volume(_face_prism(f.face, w), ell) for f, w in cover
              if _face_prism(f.face, w) is not None)
    assert got >= (10 * 1 * 4 + 1 * 7 * 4) * (1 - 1e-9)


def test_solid_clear_against_known_overlaps_and_contacts():
    from build123d import Pos

    a = _box(10, 10, 10)
    assert not _clear(a, _box(10, 10, 10, at=(8, 0, 0)))          # 200 in common
    assert not _clear(_box(2, 2, 2, at=(4, 4, 4)), a)                # wholly inside
    assert _clear(a, _box(5, 5, 5, at=(10, 0, 0)))                   # face to face
    assert _clear(a, _box(5, 5, 5, at=(10, 10, 10)))                 # corner to corner
    # tilted: a plate turned 30 degrees about z and a block beyond the plane of its side face
    plate = _box(10, 1, 4, rotate_z=30.0)
    side = np.array([-np.sin(np.pi / 6), np.cos(np.pi / 6), 0.0])    # the face at y' = 1
    assert _clear(plate, Pos(*side) * _box(3, 1, 4, at=(2, 0, 0), rotate_z=30.0))
    assert _clear(Pos(*side) * _box(3, 1, 4, at=(2, 0, 0), rotate_z=30.0), plate)
    assert not _clear(plate, Pos(*(0.999 * side)) * _box(3, 1, 4, at=(2, 0, 0), rotate_z=30.0))
    # a bent plate and a block in its inner corner, touching both legs: apart (the block's
    # cover is itself); pushed 0.01 into one leg: not. The bent plate's own cover (its L-shaped
    # top face swept down, the hull of the L) holds the corner: undecided, the boolean decides
    ell = _box(10, 1, 4) + _box(1, 8, 4)
    assert _clear(_box(3, 3, 4, at=(1, 1, 0)), ell)
    assert not _clear(_box(3, 3, 4, at=(0.99, 1, 0)), ell)
    assert not _clear(ell, _box(3, 3, 4, at=(1, 1, 0)))


def test_surfaces_clear_agrees_with_the_exact_boolean():
    """Bent plates (L-shaped, like a bracket) and blocks placed at random near, into and in
    the inner corner of each other: where surfaces_clear says apart the exact boolean gives 0;
    it proves apart a block in the bend's corner 0.05 off both legs, which the convex cover
    (solid_clear) cannot, and never a block touching a face."""
    from torsal.fabrication.assembly import _bbox, _mesh, solid_clear, solid_cover
    from torsal.fabrication.assembly.separation import surfaces_clear

    def parts(a, b):
        a, b = getattr(a, "wrapped", a), getattr(b, "wrapped", b)
        _mesh([a, b], 1.0)
        return a, b, _boundary_triangles(a), _boundary_triangles(b), _bbox(a), _bbox(b)

    ell = _box(10, 1, 4) + _box(1, 8, 4)
    a, b, ta, tb, ba, bb = parts(ell, _box(3, 3, 4, at=(1.05, 1.05, 0)))
    assert surfaces_clear(ta, tb, ba, bb) and surfaces_clear(tb, ta, bb, ba)
    assert not solid_clear(solid_cover(a), tb, bb)
    # touching one leg (a face in contact), or 0.01 into it: undecided
    for at in ((1.0, 1.05, 0), (0.99, 1.05, 0)):
        assert not surfaces_clear(*parts(ell, _box(3, 3, 4, at=at))[2:])
    # wholly inside a block: boundaries apart, but not apart
    assert not surfaces_clear(*parts(_box(20, 20, 20, at=(-5, -5, -5)), ell)[2:])
    rng = np.random.default_rng(7)
    decided = undecided = 0
    for _ in range(24):
        other = _box(*rng.uniform(0.5, 3, 3), at=rng.uniform(-2, 9, 3), rotate_z=rng.uniform(0, 90))
        a, b, ta, tb, ba, bb = parts(ell, other)
        clear = surfaces_clear(ta, tb, ba, bb)
        assert surfaces_clear(tb, ta, bb, ba) == clear           # either way round
        if clear:
            decided += 1
            assert common_volume(a, b) == pytest.approx(0.0, abs=1e-9)
        else:
            undecided += 1
    assert decided > 0 and undecided > 0


class _PerProcess:
    """Jobs that answer with their process id and what this process made before."""

    def __init__(self):
        self.made = 0

    def make(self, x):
        import os

        self.made += 1
        return os.getpid(), 10 * x

    def made_here(self, x):
        import os

        return os.getpid(), self.made, x


def test_job_pool_keeps_its_workers_for_every_map():
    # the assembly check maps its pairs and then its paths over one pool: the same worker
    # processes (not forked afresh, not this one) answer both maps, in order, and what a
    # worker made in the first map it still has in the second
    import os
    from collections import Counter

    from torsal.fabrication.assembly.workers import JobPool

    with JobPool(_PerProcess(), workers=2) as pool:
        first = pool.map("make", list(range(40)))
        second = pool.map("made_here", list(range(40)))
        few = pool.map("made_here", [1, 2])          # too few to send out: run here
    assert [v for _, v in first] == [10 * x for x in range(40)]
    assert [x for _, _, x in second] == list(range(40))
    made_by = Counter(pid for pid, _ in first)
    assert os.getpid() not in made_by
    assert all(made == made_by[pid] for pid, made, _ in second)
    assert [(pid, made) for pid, made, _ in few] == [(os.getpid(), 0)] * 2


def test_inside_answers_outside_the_box_without_classifying():
    # the checker's inside test: False at once where the first vertex lies outside the other
    # solid's box (by more than the classifier's tolerance), else OpenCascade's classifier;
    # the same answers as the classifier alone for a box inside another, one touching its
    # face from outside (its first vertex on the face), one beside it and one far away
    from torsal.fabrication.assembly import AssemblyChecker
    from torsal.fabrication.assembly.occ import _bbox, _inside

    big = _box(4, 4, 4)
    solids = [big, _box(1, 1, 1, at=(1, 1, 1)), _box(1, 1, 1, at=(4, 1, 1)),
              _box(1, 1, 1, at=(4.5, 1, 1)), _box(1, 1, 1, at=(40, 1, 1))]
    chk = AssemblyChecker([f"s{k}" for k in range(len(solids))], solids, workers=1)
    chk.boxes = np.array([_bbox(s) for s in chk.shapes]).reshape(-1, 2, 3)
    got = [[chk._inside(k, o) for o in range(len(solids))] for k in range(len(solids))]
    occ = [[_inside(chk.shapes[k], chk.shapes[o]) for o in range(len(solids))] for k in range(len(solids))]
    assert got == occ
    assert got[1][0] and not any(got[k][0] for k in (2, 3, 4))


def test_a_boolean_of_upright_solids_skips_the_inside_out_check_with_the_same_volume():
    # two crossing boxes (1 x 1 x 0.5 in common, by hand) and a tilted one: the
    # common volume is the same whether OpenCascade checks the arguments for inside-out
    # solids or is told they face outwards; an inside-out solid is recognised as such
    from torsal.fabrication.assembly.occ import is_upright

    a = _box(4, 1, 1)
    b = _box(1, 3, 0.5, at=(1, -1, 0))
    c = _box(2, 2, 2, at=(0.5, 0.2, 0.1), rotate_z=17)
    assert common_volume(a, b, upright=True) == pytest.approx(0.5, rel=1e-9)
    for s, t in ((a, b), (a, c), (b, c)):
        assert common_volume(s, t, upright=True) == pytest.approx(common_volume(s, t), rel=1e-9)
    assert is_upright(a) and is_upright(c)
    assert not is_upright(a.wrapped.Reversed())


def _edge_uses(tri: np.ndarray) -> np.ndarray:
    """How many triangles of ``tri`` (t, 3, 3) use each of their edges (vertices matched by
    coordinates)."""
    pts, index = np.unique(tri.reshape(-1, 3), axis=0, return_inverse=True)
    t = index.reshape(-1, 3)
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    return np.unique(edges, axis=0, return_counts=True)[1]


def test_a_prism_surface_is_the_closed_surface_of_the_swept_face():
    """The prism of a face of an L-shaped plate swept 2 along its normal: a closed surface
    (every edge on two triangles) of the area a hand count gives (two L faces of area 3 and
    six walls, perimeter 8 x height 2), proved clear of a box 1e-3 beyond it and not of one
    reaching 1e-3 into it; OpenCascade's prism of the same face has the same area."""
    from build123d import Align, Box, Pos

    from torsal.fabrication.assembly.separation import surfaces_clear
    from torsal.fabrication.assembly.sweep import _prism_surface

    plate = (Box(2, 2, 0.5, align=(Align.MIN,) * 3)
             - Pos(1, 1, -1) * Box(1, 1, 3, align=(Align.MIN,) * 3))
    face = next(f for f in _face_records(plate.wrapped) if abs(f.normal[2]) > 0.99
                and f.points[:, 2].max() < 0.25)                   # the bottom face, z = 0
    tri, box = _prism_surface(face, np.array([0.0, 0.0, -2.0]))    # swept to z = 2
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    area = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1).sum()
    assert (_edge_uses(tri) == 2).all()
    assert area == pytest.approx(2 * 3 + 8 * 2, abs=1e-9)
    np.testing.assert_allclose(box, [[0, 0, 0], [2, 2, 2]], atol=1e-12)
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(_face_prism(face.face, np.array([0.0, 0.0, -2.0])), props)
    assert props.Mass() == pytest.approx(area, abs=1e-9)
    for gap, apart in ((1e-3, True), (-1e-3, False)):
        other = _box(1, 1, 1, at=(2 + gap, 0.5, 0.5))
        otri = _boundary_triangles(other.wrapped)
        obox = np.array([otri.min(axis=(0, 1)), otri.max(axis=(0, 1))])
        assert surfaces_clear(tri, otri, box, obox) is apart
    # a small box in the prism's notch-free part, wholly inside it: not clear (ray parity)
    inner = _box(0.2, 0.2, 0.2, at=(0.4, 0.4, 0.9))
    itri = _boundary_triangles(inner.wrapped)
    assert surfaces_clear(tri, itri, box, np.array([itri.min(axis=(0, 1)), itri.max(axis=(0, 1))])) is False
