"""Kernels of the plates' B-reps: the B-rep of a closed polyhedron (``plates.brep._polyhedron_solid``):
its faces built directly on their planes where the loop runs counter-clockwise about the normal
are the faces ``BRepBuilderAPI_MakeFace(plane, wire, True)`` makes (the same binary BRep, byte
for byte), a loop turned the other way still goes through that call, which turns its wire
round; the plane axes of one normal are those of a stack of normals, bit for bit; the
plate's distinct corners are numpy's unique rows."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("OCP")
from torsal.fabrication.plates import brep  # noqa: E402
from torsal.fabrication.plates.occ import _is_valid, _volume  # noqa: E402
from torsal.fabrication.workers import _to_bytes  # noqa: E402

# a box 3 x 2 x 1, its faces' loops counter-clockwise seen from outside
_POINTS = np.array([[0, 0, 0], [3, 0, 0], [3, 2, 0], [0, 2, 0],
                    [0, 0, 1], [3, 0, 1], [3, 2, 1], [0, 2, 1]], float)
_LOOPS = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]]
_NORMALS = np.array([[0, 0, -1], [0, 0, 1], [0, -1, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0]], float)
_CENTRES = np.array([_POINTS[x].mean(axis=0) for x in _LOOPS])


def _box(monkeypatch=None, *, all_by_api=False):
    if all_by_api:          # every face by BRepBuilderAPI_MakeFace, as before
        monkeypatch.setattr(brep, "_counter_clockwise", lambda p, loops, n: [False] * len(loops))
    return brep._polyhedron_solid(_POINTS, _LOOPS, _NORMALS, _CENTRES)


def test_counter_clockwise_loops_by_their_newell_vector():
    sq = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    up, down = np.array([[0, 0, 1.0]]), np.array([[0, 0, -1.0]])
    assert brep._counter_clockwise(sq, [[0, 1, 2, 3]], up) == [True]
    assert brep._counter_clockwise(sq, [[0, 1, 2, 3]], down) == [False]
    assert brep._counter_clockwise(sq, [[0, 3, 2, 1]], up) == [False]
    # a loop across the normal (its plane square to it) is left to the API
    assert brep._counter_clockwise(sq, [[0, 1, 2, 3]], np.array([[1.0, 0, 0]])) == [False]
    assert brep._counter_clockwise(np.vstack([sq, sq + [0, 0, 1]]), [[0, 1, 2], [4, 6, 7]],
                                   np.vstack([up, up])) == [True, True]


def test_faces_built_directly_are_the_api_faces_byte_for_byte(monkeypatch):
    direct = _box()
    assert brep._counter_clockwise(_POINTS, _LOOPS, _NORMALS) == [True] * 6
    by_api = _box(monkeypatch, all_by_api=True)
    assert _to_bytes(direct) == _to_bytes(by_api)
    assert _is_valid(direct)
    assert _volume(direct) == pytest.approx(6.0, rel=1e-12)


def test_a_clockwise_loop_is_turned_round_by_the_api():
    # the top face's loop given clockwise about its normal: MakeFace's classifier turns the
    # wire round, so the solid is the same closed, valid box of volume 6
    loops = [list(x) for x in _LOOPS]
    loops[1] = loops[1][::-1]
    assert brep._counter_clockwise(_POINTS, loops, _NORMALS) == [True, False, True, True, True, True]
    solid = brep._polyhedron_solid(_POINTS, loops, _NORMALS, _CENTRES)
    assert _is_valid(solid)
    assert _volume(solid) == pytest.approx(6.0, rel=1e-12)


def test_plane_axes_of_one_normal_are_the_stacks_bit_for_bit():
    # the single-normal route of sections._plane_axes (Python floats) against the array
    # route of the same normals in a stack: the same bits, signed zeros included
    from torsal.fabrication.plates.sections import _plane_axes

    rng = np.random.default_rng(7)
    n = rng.normal(size=(500, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    n = np.vstack([np.eye(3), -np.eye(3), [[0.6, -0.8, 0.0], [-0.0, -0.0, -1.0]], n])
    stacked = _plane_axes(n)
    for k, x in enumerate(n):
        one = _plane_axes(x)
        assert one.shape == (2, 3)
        assert one.tobytes() == stacked[k].tobytes()
    e1, e2 = _plane_axes(np.array([0.0, 0.0, 1.0]))
    assert np.allclose(np.cross(e1, e2), [0, 0, 1]) and np.isclose(e1 @ e2, 0.0)


def test_distinct_rows_are_numpys_unique_rows():
    # plate._distinct_rows against np.unique(axis=0, return_index, return_inverse) on random
    # integer rows with many repeats (the plate's corners rounded to 1e-12)
    from torsal.fabrication.plates.plate import _distinct_rows

    rng = np.random.default_rng(3)
    for _ in range(300):
        n = int(rng.integers(1, 80))
        keys = rng.integers(-4, 4, size=(n, 3)).astype(np.int64) * int(rng.choice([1, -7, 10**12]))
        _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
        got_first, got_inverse = _distinct_rows(keys)
        assert np.array_equal(got_first, first)
        assert np.array_equal(got_inverse, inverse.reshape(-1))
        assert np.array_equal(keys[got_first][got_inverse], keys)
