"""Hit distances in double precision: Embree finds the triangle, the distance is the
triangle's plane intersected again in float64."""
from __future__ import annotations

import numpy as np
import trimesh

from torsal.light.rays import _scene, face_plane_distances


def tilted_plate(offset):
    """Two triangles on the plane x + 2y + 3z = 6, around ``offset`` (3,)."""
    o = np.asarray(offset, float)
    uv = np.array([[-20.0, -20.0], [20.0, -20.0], [20.0, 20.0], [-20.0, 20.0]])
    v = o + np.c_[6.0 - 2 * uv[:, 0] - 3 * uv[:, 1], uv[:, 0], uv[:, 1]]
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)


def test_first_hit_lies_on_the_plane_to_float64_far_from_the_origin():
    # 28 m of ray and a plate 10 km from the origin: single precision alone is ~1e-6 off
    plate = tilted_plate([1e4, 1e4, 0.0])
    rng = np.random.default_rng(3)
    d = rng.normal(size=(200, 3))
    d[:, 0] = -np.abs(d[:, 0]) - 1.0                         # towards the plate (normal ~ x)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    p_on = np.c_[np.full(200, 6.0), rng.uniform(-5, 5, (200, 2))] + [1e4, 1e4, 0.0]
    p_on[:, 0] -= 2 * (p_on[:, 1] - 1e4) + 3 * p_on[:, 2]
    o = p_on - 28.0 * d
    t, prim = _scene(plate).first_hit(o, d)
    assert (prim >= 0).all()
    np.testing.assert_allclose(t, 28.0, rtol=0, atol=1e-9)
    hit = o + t[:, None] * d
    plane = hit[:, 0] - 1e4 + 2 * (hit[:, 1] - 1e4) + 3 * hit[:, 2]
    np.testing.assert_allclose(plane, 6.0, rtol=0, atol=1e-9)


def test_misses_grazing_rays_and_degenerate_triangles_keep_the_fallback():
    v = np.array([[0, 0, 1.0], [1, 0, 1], [0, 1, 1], [2, 2, 2]])
    f = [[0, 1, 2], [3, 3, 3]]                                # the second has no area
    o = np.zeros((4, 3))
    d = np.array([[0, 0, 4.0], [1, 0, 0], [0, 0, 1], [0, 0, 1]])
    t = face_plane_distances(v, f, [0, 0, -1, 1], o, d, fallback=[7.0, 8.0, 9.0, 10.0])
    # distance in units of the direction's length; grazing, miss, degenerate: fallback
    np.testing.assert_array_equal(t, [0.25, 8.0, 9.0, 10.0])
    assert np.isinf(face_plane_distances(v, f, [-1], o[:1], d[:1])).all()


def test_a_query_split_over_threads_answers_each_ray_as_one_thread_does(monkeypatch):
    """rays_blocked casts a large query from several threads (Embree releases the
    interpreter); each ray's answer is its own, so the split changes nothing. Checked against
    the analytic answer too: a ray from outside a sphere is blocked iff its line meets it
    ahead of the origin."""
    from torsal.light import rays

    sphere = trimesh.creation.icosphere(subdivisions=3)
    rng = np.random.default_rng(5)
    points = rng.normal(size=(700, 3)) * 4.0
    points = points[np.linalg.norm(points, axis=1) > 1.5]
    dirs = rng.normal(size=(450, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    monkeypatch.setattr(rays, "_RAY_THREADS", 3)
    split = rays.rays_blocked(sphere, points, dirs)
    monkeypatch.setattr(rays, "_RAY_THREADS", 1)
    assert np.array_equal(split, rays.rays_blocked(sphere, points, dirs))
    # the mesh lies within 1 % of the unit sphere: rays clear of that band agree with it
    b = points @ dirs.T
    c = (points * points).sum(axis=1)[:, None]
    disc = b * b - c + 1.0                 # 1 - the line's distance^2 from the centre: > 0 meets it
    sure = np.abs(disc) > 0.05
    assert np.array_equal(split[sure], ((disc > 0) & (b < 0))[sure])
