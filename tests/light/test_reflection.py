"""Where reflected sunlight lands, against analytic truth: a corner reflector (two
reflections, light sent back to the sun), a 45 degree mirror under a ceiling lit from below,
the planes of incidence, the best mirror plane for a spread of sun directions, and the
ideal-mirror bound."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from torsal.light import (
    CeilingTarget,
    TargetSide,
    best_mirror_normals,
    ideal_mirror_bound,
    incidence_plane_normals,
    mirror_normals,
    reflect,
    reflected_hits,
)
from torsal.light.shading import ReflectionResult as ShadingReflectionResult
from torsal.light.shading import reflected_hits as shading_reflected_hits


def rect(center, u, v):
    """Rectangle ``center +- u +- v`` as two triangles."""
    c, u, v = (np.asarray(a, float) for a in (center, u, v))
    return trimesh.Trimesh([c - u - v, c + u - v, c + u + v, c - u + v], [[0, 1, 2], [0, 2, 3]],
                           process=False)


def corner(length=2.0):
    """A dihedral right angle of two 1 m wide mirrors ``length`` long along y: the floor
    z = 0 (x in [0, 1]) and the wall x = 0 (z in [0, 1]); face groups 0 (floor), 1 (wall)."""
    floor = rect([0.5, 0, 0], [0.5, 0, 0], [0, length / 2, 0])
    wall = rect([0, 0, 0.5], [0, 0, 0.5], [0, length / 2, 0])
    return trimesh.util.concatenate([floor, wall]), np.array([0, 0, 1, 1])


#: the sun towards (1, 1, 1): light along -(1, 1, 1); floor and wall each flip one component,
#: so light meeting both leaves along (1, -1, 1), light meeting one along (-1, -1, 1) or (1, -1, -1)
SUN = np.array([[1.0, 1.0, 1.0]]) / np.sqrt(3)


def far_square(direction, distance=10.0, half=4.0):
    """A square ``distance`` out along ``direction`` from the corner, facing back to it."""
    d = np.asarray(direction, float) / np.linalg.norm(direction)
    u = np.cross(d, [0.0, 0.0, 1.0])
    u /= np.linalg.norm(u)
    sq = rect([0.5, 0, 0.5] + distance * np.sqrt(3) * d, half * u, half * np.cross(d, u))
    if (sq.face_normals @ d > 0).any():
        sq = trimesh.Trimesh(sq.vertices, sq.faces[:, ::-1], process=False)
    return sq


def test_the_reflection_names_stay_importable_from_shading():
    assert shading_reflected_hits is reflected_hits
    assert ShadingReflectionResult.__module__ == "torsal.light.reflection"


@pytest.mark.parametrize("length", [2.0, 4.0])
def test_a_right_angle_of_mirrors_reflects_twice_all_but_one_over_2_length_of_the_light(length):
    # light meeting the floor at (x, y, 0) reaches the wall at y - x, the wall at (0, y, z) the
    # floor at y - z: it misses the second mirror for y < x - L/2, a share 1 / (2 L)
    fins, groups = corner(length)
    back = far_square([1, -1, 1])
    r = reflected_hits(fins, SUN, back, resolution=200, face_groups=groups,
                       lit_side=TargetSide.FRONT)
    # the angle seen from the sun: each mirror 1 m x L at cos = 1/sqrt(3), side by side
    assert r.struck_area[0] == pytest.approx(2 * length / np.sqrt(3), rel=0.01)
    assert r.share == pytest.approx(1 - 1 / (2 * length), abs=0.01)
    np.testing.assert_allclose(r.landed_by_bounces[0, 1], r.landed_area[0])  # all after two
    assert r.landed_by_bounces[0, [0, 2]].sum() == 0
    assert r.elsewhere_share == pytest.approx(1 / (2 * length), abs=0.01)
    np.testing.assert_allclose(r.group_struck[0] / r.struck_area[0], [0.5, 0.5], atol=0.01)
    np.testing.assert_allclose(r.group_touched_landed[0], r.landed_area[0])  # landed: met both
    rays = r.rays[0]
    assert set(np.unique(rays.bounces)) == {1, 2}
    assert (rays.touched.all(axis=1) == (rays.bounces == 2)).all()
    # the light reaches the square's unlit side when it is turned round: counts only with BOTH
    turned = trimesh.Trimesh(back.vertices, back.faces[:, ::-1], process=False)
    rf = reflected_hits(fins, SUN, turned, resolution=64, lit_side=TargetSide.FRONT)
    assert rf.share == 0.0 and rf.elsewhere_share == pytest.approx(1.0)
    assert reflected_hits(fins, SUN, turned, resolution=64).share == pytest.approx(r.share, abs=0.02)
    # light that met only the floor goes to its own square
    assert reflected_hits(fins, SUN, far_square([-1, -1, 1]), resolution=64).share == \
        pytest.approx(1 / (4 * length), abs=0.01)


def test_rays_still_between_fins_after_max_bounces_are_trapped():
    fins, _ = corner(2.0)
    r = reflected_hits(fins, SUN, far_square([1, -1, 1]), resolution=64, max_bounces=1)
    assert r.share == 0.0
    np.testing.assert_allclose(r.trapped_area / r.struck_area, 0.75, atol=0.02)
    assert r.elsewhere_share == pytest.approx(0.25, abs=0.02)
    with pytest.raises(ValueError, match="max_bounces"):
        reflected_hits(fins, SUN, far_square([1, -1, 1]), max_bounces=0)
    with pytest.raises(ValueError, match="face_groups"):
        reflected_hits(fins, SUN, far_square([1, -1, 1]), face_groups=[0, 1])


def test_45_degree_mirror_lights_the_ceiling_from_below_and_records_where():
    mirror = rect([0, 0, 0], [0.5, 0, 0], np.sqrt(0.5) * np.array([0, 0.5, 0.5]))
    ceiling = CeilingTarget((0.0, 0.0, 3.0), (2.0, 2.0))
    sun = [[0.0, -1.0, 0.0]]                                      # due south, on the horizon
    r = reflected_hits(mirror, sun, ceiling.mesh(), resolution=64, lit_side=TargetSide.FRONT,
                       ceiling=3.0)
    assert r.share == 1.0
    xy = r.rays[0].ceiling_xy
    # straight up: the spot is the mirror's plan, 1 m x sqrt(0.5) m around the origin
    assert np.isfinite(xy).all()
    assert np.abs(xy[:, 0]).max() <= 0.5 + 1e-9 and np.abs(xy[:, 1]).max() <= 0.25 * np.sqrt(2) + 1e-6
    # a ceiling below the mirror is lit only from above: nothing lands, nothing crosses
    low = CeilingTarget((0.0, 0.0, -3.0), (2.0, 2.0))
    r2 = reflected_hits(mirror, sun, low.mesh(), resolution=32, lit_side=TargetSide.FRONT,
                        ceiling=-3.0)
    assert r2.share == 0.0 and np.isnan(r2.rays[0].ceiling_xy).all()


def test_ceiling_target_checks_its_input():
    t = CeilingTarget((0, 6, 5.5), (4, 2))
    np.testing.assert_allclose(t.mesh().face_normals, [[0, 0, -1], [0, 0, -1]])
    assert t.mesh().area == pytest.approx(8.0)
    np.testing.assert_allclose(t.offsets([[2, 6], [0, 7], [1, 6.5]]), [1.0, 1.0, 0.5])
    for bad in [dict(centre=(0, 0), size=(1, 1)), dict(centre=(0, 0, np.nan), size=(1, 1)),
                dict(centre=(0, 0, 0), size=(1, 0)), dict(centre=(0, 0, 0), size=(1, -2))]:
        with pytest.raises(ValueError, match="target"):
            CeilingTarget(**bad)


def test_plane_of_incidence_contains_the_light_and_its_reflection():
    rng = np.random.default_rng(4)
    i = rng.normal(size=(40, 3))
    i /= np.linalg.norm(i, axis=1, keepdims=True)
    n = rng.normal(size=(40, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    p = incidence_plane_normals(i, n)
    np.testing.assert_allclose(np.linalg.norm(p, axis=1), 1.0)
    np.testing.assert_allclose((p * i).sum(1), 0.0, atol=1e-12)
    np.testing.assert_allclose((p * reflect(i, n)).sum(1), 0.0, atol=1e-12)
    np.testing.assert_allclose((p * n).sum(1), 0.0, atol=1e-12)      # perpendicular to the mirror
    assert np.isnan(incidence_plane_normals([0, 0, -1], [0, 0, 1])).all()   # head-on


def test_best_mirror_for_one_sun_direction_aims_at_the_target_centre():
    t = CeilingTarget((1.0, 6.0, 6.0), (4.0, 2.0))
    p = np.array([[0.0, 0.0, 1.0], [-3.0, -0.5, 4.0]])
    sun = [[0.2, -0.7, 0.6]]
    aim = best_mirror_normals(p, sun, t)
    light = -np.asarray(sun[0]) / np.linalg.norm(sun[0])
    to_centre = np.asarray(t.centre) - p
    expect = mirror_normals(light, to_centre / np.linalg.norm(to_centre, axis=1, keepdims=True))
    np.testing.assert_allclose(aim.normals, expect, atol=1e-4)
    assert aim.lands.all() and aim.reachable.all()


def test_best_mirror_spreads_symmetric_sun_directions_symmetrically_about_the_target():
    # sun at +-20 degrees azimuth about south, the point on the target's meridian
    az = np.radians([-20.0, 0.0, 20.0])
    el = np.radians(40.0)
    sun = np.c_[np.sin(az) * np.cos(el), -np.cos(az) * np.cos(el), np.full(3, np.sin(el))]
    t = CeilingTarget((0.0, 5.0, 6.5), (6.0, 6.0))
    aim = best_mirror_normals([[0.0, -0.5, 2.0], [0.0, -0.5, 7.0]], sun, t)
    assert abs(aim.normals[0, 0]) < 1e-3                                 # no sideways tilt
    assert aim.lands[0].all() and aim.share[0] == 1.0
    # the landing spots of the +-20 degree suns are mirror images in x
    r = reflect(-sun, aim.normals[0])
    land = [0.0, -0.5, 2.0] + (6.5 - 2.0) / r[:, 2:3] * r
    assert land[0, 0] == pytest.approx(-land[2, 0], abs=1e-3)
    assert land[0, 1] == pytest.approx(land[2, 1], abs=1e-3)
    # a point above the ceiling cannot light its underside
    assert not aim.reachable[1] and not aim.lands[1].any() and aim.share[1] == 0.0
    # a target too small for the spread: one plane cannot land all three
    small = best_mirror_normals([[0.0, -0.5, 2.0]], sun, CeilingTarget((0.0, 5.0, 6.5), (1.0, 1.0)))
    assert small.share[0] < 1.0


def test_ideal_mirror_bound_of_a_best_oriented_mirror_is_its_measured_share():
    sun = np.array([[0.0, -0.75, 0.66]])
    t = CeilingTarget((0.0, 5.0, 6.5), (4.0, 4.0))
    n = best_mirror_normals([[0.0, 0.0, 2.0]], sun, t).normals[0]
    # a 0.4 m square mirror in that plane at (0, 0, 2)
    u = np.cross(n, [1.0, 0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    mirror = rect([0, 0, 2], 0.2 * u, 0.2 * v)
    r = reflected_hits(mirror, sun, t.mesh(), resolution=64, lit_side=TargetSide.FRONT)
    b = ideal_mirror_bound(r, t)
    assert r.share == 1.0 and b.share == 1.0 and b.points == 1500   # subsampled
    # nothing lands on a ceiling below the mirror: neither measured nor bound
    low = CeilingTarget((0.0, 5.0, 1.0), (4.0, 4.0))
    r2 = reflected_hits(mirror, sun, low.mesh(), resolution=32, lit_side=TargetSide.FRONT)
    assert r2.share == 0.0 and ideal_mirror_bound(r2, low).share == 0.0
    # no struck light: NaN share, no bound
    none = reflected_hits(rect([50, 50, 50], [0.1, 0, 0], [0, 0.1, 0]), [[0, -1, 0]], t.mesh())
    assert np.isnan(none.share) and np.isnan(ideal_mirror_bound(none, t).share)
