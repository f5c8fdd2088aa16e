"""Ray-cast light measurements against analytic truth: louver cut-off, full/empty blocking,
transparency, see-through, and the 45 degree mirror."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import trimesh

from torsal.geometry.surfaces import facade_patch, grid_faces
from torsal.light.baselines import (
    baselines,
    grid_normal_fins,
    horizontal_louvers,
    section_fins,
    vertical_fins,
)
from torsal.light.shading import (
    compare,
    direct_sun_blocked,
    mirror_normals,
    ray_hits,
    rays_blocked,
    reflect,
    reflected_hits,
    see_through,
    transparency,
)
from torsal.light.sun import SunDirections

D, S = 0.5, 0.6  # louver depth and spacing: full cut-off at tan(profile) = S / D = 1.2


def flat_wall(width=40.0, height=6.0, nu=21, nv=13):
    """The x-z plane y = 0, x in [-width/2, width/2], z in [0, height], normals -y (outside)."""
    x = np.linspace(-width / 2, width / 2, nu)
    z = np.linspace(0.0, height, nv)
    X, Z = np.meshgrid(x, z, indexing="ij")
    return np.c_[X.ravel(), np.zeros(X.size), Z.ravel()], grid_faces(nu, nv)


def rect(center, u, v):
    """Rectangle ``center +- u +- v`` as two triangles."""
    c, u, v = (np.asarray(a, float) for a in (center, u, v))
    return trimesh.Trimesh([c - u - v, c + u - v, c + u + v, c - u + v], [[0, 1, 2], [0, 2, 3]],
                           process=False)


def wall_points(n, *, z0=1.2, periods=3, axis="z", seed=1):
    """Stratified points on the flat wall over whole louver periods, normals -y."""
    rng = np.random.default_rng(seed)
    t = z0 + (np.arange(n) + 0.5) / n * periods * S
    other = rng.uniform(-2.0, 2.0, n) if axis == "z" else rng.uniform(2.0, 4.0, n)
    pts = np.c_[other, np.zeros(n), t] if axis == "z" else np.c_[t, np.zeros(n), other]
    return pts, np.tile([0.0, -1.0, 0.0], (n, 1))


def sun_with_profile(tan_profile, lateral):
    """Sun vector in front of the wall (-y side) with tan(vertical profile angle) given."""
    return np.array([lateral, -1.0, tan_profile])


def test_flat_wall_normals_point_outside():
    v, f = flat_wall()
    np.testing.assert_allclose(trimesh.Trimesh(v, f, process=False).face_normals,
                               np.tile([0.0, -1.0, 0.0], (len(f), 1)), atol=1e-12)


# ----------------------------------------------------------------------------- kernel
def test_rays_blocked_shape_and_simple_cases():
    wall = rect([0, 1, 0], [1, 0, 0], [0, 0, 1])      # square at y = 1
    pts = np.array([[0.0, 0, 0], [0.5, 0, 0.5], [5.0, 0, 0]])
    dirs = np.array([[0.0, 1, 0], [0.0, -1, 0], [0.0, 2, 0.5]])  # toward, away, oblique
    hit = rays_blocked(wall, pts, dirs)
    assert hit.shape == (3, 3) and hit.dtype == bool
    np.testing.assert_array_equal(hit, [[True, False, True], [True, False, True],
                                        [False, False, False]])
    # chunking does not change the answer
    rng = np.random.default_rng(0)
    many = rng.normal(size=(40, 3))
    np.testing.assert_array_equal(rays_blocked(wall, many, dirs, chunk_size=7),
                                  rays_blocked(wall, many, dirs))
    # the cached ray scene follows edits of the mesh: move the wall behind the points
    moved = rect([0, 1, 0], [1, 0, 0], [0, 0, 1])
    np.testing.assert_array_equal(rays_blocked(moved, pts[:1], dirs[:2]), [[True, False]])
    moved.vertices[:, 1] = -1.0  # in place: same object, new data
    np.testing.assert_array_equal(rays_blocked(moved, pts[:1], dirs[:2]), [[False, True]])
    # a segment that stops short of the wall does not hit it
    assert not ray_hits(wall, [[0.0, 0, 0]], [[0.0, 1, 0]], max_distance=0.9)[0]
    assert ray_hits(wall, [[0.0, 0, 0]], [[0.0, 1, 0]], max_distance=1.1)[0]


def test_kernel_rejects_bad_input():
    wall = rect([0, 1, 0], [1, 0, 0], [0, 0, 1])
    with pytest.raises(ValueError, match="NaN"):
        rays_blocked(wall, [[0.0, np.nan, 0]], [[0.0, 1, 0]])
    with pytest.raises(ValueError, match="zero length"):
        rays_blocked(wall, [[0.0, 0, 0]], [[0.0, 1, 0], [0.0, 0, 0]])
    with pytest.raises(TypeError, match="fin_mesh"):
        rays_blocked(np.zeros((3, 3)), [[0.0, 0, 0]], [[0.0, 1, 0]])


# ----------------------------------------------------------------------------- louvers
def test_horizontal_louvers_match_analytic_cutoff_within_1_percent():
    v, f = flat_wall()
    louvers = horizontal_louvers(v, f, depth=D, spacing=S)
    tans = np.array([0.1, 0.3, 0.6, 0.9, 1.1, 1.19, 1.25, 1.6, 3.0])
    laterals = np.array([0.0, 0.7, -0.4, 1.3, 0.2, -1.0, 0.5, 0.0, 0.9])
    sun = np.array([sun_with_profile(t, a) for t, a in zip(tans, laterals)])
    res = direct_sun_blocked(louvers, (v, f), sun, samples=wall_points(3000))
    expected = np.minimum(1.0, D * tans / S)
    assert res.incident.all()
    np.testing.assert_allclose(res.per_direction, expected, atol=0.01)
    assert abs(res.share - expected.mean()) < 0.01
    assert res.per_direction[-2:].min() == 1.0   # beyond the cut-off: full block
    # the profile angle governs, not the altitude: same profile, different altitude
    a = direct_sun_blocked(louvers, (v, f), [[0.0, -1.0, 0.5]], samples=wall_points(2000)).share
    b = direct_sun_blocked(louvers, (v, f), [[2.0, -1.0, 0.5]], samples=wall_points(2000)).share
    assert abs(a - b) < 0.01 and abs(a - D * 0.5 / S) < 0.01


def test_vertical_fins_match_analytic_cutoff_within_1_percent():
    v, f = flat_wall()
    fins = vertical_fins(v, f, depth=D, spacing=S)
    tans = np.array([0.2, 0.6, 1.0, 1.5])  # tan of the horizontal shadow angle
    sun = np.c_[tans, -np.ones(4), np.full(4, 0.4)]
    res = direct_sun_blocked(fins, (v, f), sun, samples=wall_points(3000, axis="x", z0=0.6))
    np.testing.assert_allclose(res.per_direction, np.minimum(1.0, D * tans / S), atol=0.01)


def test_weights_and_sun_directions_object():
    v, f = flat_wall()
    louvers = horizontal_louvers(v, f, depth=D, spacing=S)
    sun = np.array([sun_with_profile(3.0, 0.0), sun_with_profile(0.3, 0.0)])  # 1.0 and 0.25
    res = direct_sun_blocked(louvers, (v, f), sun, samples=wall_points(2000), weights=[3.0, 1.0])
    assert abs(res.share - (3 * 1.0 + 1 * 0.25) / 4) < 0.01
    # a SunDirections: its weights (DNI) are used and below-horizon times dropped
    times = pd.date_range("2024-06-21 12:00", periods=3, freq="1h", tz="UTC")
    vec = np.r_[sun / np.linalg.norm(sun, axis=1, keepdims=True), [[0.0, -1.0, -0.2]]]
    sd = SunDirections(vec, np.array([True, True, False]), times, np.zeros(3), np.zeros(3),
                       np.array([3.0, 1.0, 100.0]))
    res2 = direct_sun_blocked(louvers, (v, f), sd, samples=wall_points(2000))
    assert len(res2.sun) == 2 and abs(res2.share - res.share) < 1e-12


def test_all_blocked_is_100_percent_and_no_fins_is_0_percent():
    v, f = flat_wall()
    sun = np.array([sun_with_profile(t, a) for t, a in [(0.2, 0.0), (1.0, 1.5), (2.5, -2.0)]])
    screen = rect([0, -1, 3], [1000, 0, 0], [0, 0, 1000])  # in front of every sample ray
    full = direct_sun_blocked(screen, (v, f), sun, samples=500)
    assert full.share == 1.0 and np.all(full.per_point == 1.0) and full.blocked.all()
    empty = trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), process=False)
    none = direct_sun_blocked(empty, (v, f), sun, samples=500)
    assert none.share == 0.0 and np.all(none.per_point == 0.0) and not none.blocked.any()
    # the sun behind the facade is not incident: left out, not counted as blocked
    behind = direct_sun_blocked(screen, (v, f), [[0.0, 1.0, 0.5]], samples=50)
    assert not behind.incident.any() and np.isnan(behind.share)


def test_per_point_map_on_a_curved_facade():
    v, f = facade_patch(nu=17, nv=9)
    louvers = horizontal_louvers(v, f, depth=0.4, spacing=0.5)
    sun = np.array([[0.3, -1.0, 0.6], [-0.3, -1.0, 0.9]])
    res = direct_sun_blocked(louvers, (v, f), sun, samples=800)
    assert res.per_point.shape == (800,) and res.points.shape == (800, 3)
    assert np.nanmin(res.per_point) >= 0.0 and np.nanmax(res.per_point) <= 1.0
    assert 0.2 < res.share < 1.0
    # deeper louvers never block less, sample for sample
    deeper = direct_sun_blocked(horizontal_louvers(v, f, depth=0.8, spacing=0.5), (v, f), sun,
                                samples=800)
    assert deeper.share > res.share


# ----------------------------------------------------------------------------- transparency
def test_transparency_of_louvers():
    v, f = flat_wall()
    louvers = horizontal_louvers(v, f, depth=D, spacing=S)
    empty = trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), process=False)
    clear = transparency(empty, (v, f), samples=200)
    assert clear.along_normal == 1.0 and clear.cone == 1.0
    # straight out between horizontal louvers: free; a view ray with profile tan 0.3 is cut
    # exactly like a sun ray: transparency 1 - D * 0.3 / S
    res = transparency(louvers, (v, f), view_dirs=[[0.0, -1.0, 0.3], [0.0, -1.0, -0.3]],
                       samples=wall_points(2000))
    assert res.along_normal == 1.0
    assert abs(res.view_dirs - (1.0 - D * 0.3 / S)) < 0.01
    assert 0.0 < res.cone < 1.0
    deeper = transparency(horizontal_louvers(v, f, depth=2 * D, spacing=S), (v, f),
                          samples=wall_points(2000))
    assert deeper.cone < res.cone


# ----------------------------------------------------------------------------- see-through
def test_see_through_share_and_fisheye_png(tmp_path):
    eye = np.array([0.0, 1.0, 3.0])
    target = rect([0, -10, 3], [2, 0, 0], [0, 0, 1])
    empty = trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), process=False)
    free = see_through(empty, eye, target, 120.0, resolution=96, path=tmp_path / "free.png")
    assert free.share == 1.0 and free.image_share == 1.0
    assert free.path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(tmp_path.glob(".*tmp*"))  # written atomically, no leftovers
    # an opaque screen ending in the plane x = 0 hides exactly the target's x < 0 half
    half_screen = rect([-50, -5, 3], [50, 0, 0], [0, 0, 50])
    half = see_through(half_screen, eye, target, 120.0, resolution=128,
                       path=tmp_path / "half.png")
    assert abs(half.share - 0.5) < 0.03 and abs(half.image_share - 0.5) < 0.05
    assert {2, 3, 4} <= set(np.unique(half.image))
    full = see_through(rect([0, -5, 3], [50, 0, 0], [0, 0, 50]), eye, target, resolution=32)
    assert full.share == 0.0 and full.path is None


# ----------------------------------------------------------------------------- reflection
def test_mirror_normals_reflect_incoming_onto_outgoing():
    rng = np.random.default_rng(3)
    i = rng.normal(size=(50, 3))
    o = rng.normal(size=(50, 3))
    n = mirror_normals(i, o)
    i /= np.linalg.norm(i, axis=1, keepdims=True)
    o /= np.linalg.norm(o, axis=1, keepdims=True)
    np.testing.assert_allclose(reflect(i, n), o, atol=1e-12)
    assert (np.sum(n * -i, axis=1) >= 0).all()  # faces the arriving light
    with pytest.raises(ValueError, match="no mirror"):
        mirror_normals([0, 1, 0], [0, 2, 0])


def test_45_degree_mirror_sends_horizontal_ray_straight_up():
    n = mirror_normals([0, 1, 0], [0, 0, 1])[0]
    np.testing.assert_allclose(n, [0, -np.sqrt(0.5), np.sqrt(0.5)], atol=1e-12)
    np.testing.assert_allclose(reflect([0.0, 1.0, 0.0], n), [0, 0, 1], atol=1e-12)
    # a 1 m x 1 m mirror tilted 45 degrees, the sun due south on the horizon
    mirror = rect([0, 0, 0], [0.5, 0, 0], np.sqrt(0.5) * np.array([0, 0.5, 0.5]))
    np.testing.assert_allclose(np.abs(mirror.face_normals @ n), 1.0, atol=1e-12)
    sun = [[0.0, -1.0, 0.0]]
    above = rect([0, 0, 3], [2, 0, 0], [0, 2, 0])
    res = reflected_hits(mirror, sun, above, resolution=128)
    assert res.share == 1.0
    assert abs(res.struck_area[0] - np.sqrt(0.5)) < 0.02 * np.sqrt(0.5)  # projected mirror area
    # a target covering only x >= 0 receives half; one off to the side receives nothing
    assert abs(reflected_hits(mirror, sun, rect([2, 0, 3], [2, 0, 0], [0, 2, 0])).share - 0.5) < 0.02
    assert reflected_hits(mirror, sun, rect([7, 0, 3], [2, 0, 0], [0, 2, 0])).share == 0.0
    # a fin between mirror and target intercepts the reflected light
    shelf = trimesh.util.concatenate([mirror, rect([0, 0, 1.5], [3, 0, 0], [0, 3, 0])])
    assert reflected_hits(shelf, sun, above, resolution=64).share == 0.0


# ----------------------------------------------------------------------------- baselines
def test_baselines_have_the_requested_depth_and_spacing():
    v, f = flat_wall()
    lv = horizontal_louvers(v, f, depth=D, spacing=S)
    np.testing.assert_allclose(np.unique(np.round(lv.vertices[:, 1], 9)), [-D, 0.0], atol=1e-9)
    levels = np.unique(np.round(lv.vertices[:, 2], 9))
    np.testing.assert_allclose(levels, S * np.arange(1, 10), atol=1e-9)  # inside (0, 6)
    vf = vertical_fins(v, f, depth=D, spacing=S)
    xs = np.unique(np.round(vf.vertices[:, 0], 9))
    np.testing.assert_allclose(xs / S, np.round(xs / S), atol=1e-9)
    # on a curved facade every louver stays in its horizontal plane and is depth deep
    cv, cf = facade_patch(nu=17, nv=9)
    cl = horizontal_louvers(cv, cf, depth=0.4, spacing=0.5)
    z = cl.vertices[:, 2]
    np.testing.assert_allclose(z / 0.5, np.round(z / 0.5), atol=1e-9)
    # every vertex (root on A or tip) ends an edge of exactly the louver depth
    root_tip = cl.edges_unique[np.isclose(cl.edges_unique_length, 0.4, atol=1e-9)]
    assert len(np.unique(root_tip)) == len(cl.vertices)
    assert section_fins(v, f, [0, 0, 1], D, 100.0).faces.shape == (0, 3)
    with pytest.raises(ValueError, match="depth"):
        horizontal_louvers(v, f, depth=0.0, spacing=S)


def test_normal_congruence_fins_on_a_flat_wall_are_louvers_and_compare_agrees():
    v, f = flat_wall(nu=21, nv=13)  # grid step 2 m in x, 0.5 m in z
    grid = grid_normal_fins(v, f, (21, 13), depth=D, families=(1,))  # rows of constant z
    np.testing.assert_allclose(np.unique(np.round(grid.vertices[:, 1], 9)), [-D, 0.0])
    sets = baselines(v, f, D, 0.5, grid_shape=(21, 13))
    assert set(sets) == {"horizontal louvers", "vertical fins", "egg-crate",
                         "normal congruence (unoptimized)"}
    n = 3000
    z = 1.0 + (np.arange(n) + 0.5) / n * 1.5  # three whole periods of 0.5 m
    pts = np.c_[np.random.default_rng(5).uniform(-0.9, 0.9, n), np.zeros(n), z]
    nrm = np.tile([0.0, -1.0, 0.0], (n, 1))
    sun = [[0.3, -1.0, 0.4], [0.0, -1.0, 0.8]]  # blocked min(1, D tan / 0.5) = 0.4 and 0.8
    table = compare({"grid": grid, "louvers": sets["horizontal louvers"],
                     "egg-crate": sets["egg-crate"]}, (v, f), sun, samples=(pts, nrm))
    for name in ("grid", "louvers"):
        assert abs(table[name]["blocked"] - 0.6) < 0.01
        assert table[name]["transparent_normal"] == 1.0
    assert table["egg-crate"]["blocked"] > table["louvers"]["blocked"]
    assert table["egg-crate"]["transparent_cone"] < table["louvers"]["transparent_cone"]


@pytest.mark.parametrize("grazing_deg", [1.0, 10.0, 45.0])
def test_reflection_is_robust_at_grazing_sun(grazing_deg):
    """A tilted 1 m^2 mirror, the sun ``grazing_deg`` above its plane, a target placed where
    the mirror law sends the light: all struck light lands; the struck cross-section is the
    projected area sin(grazing)."""
    rng = np.random.default_rng(int(grazing_deg))
    n = rng.normal(size=3)
    n /= np.linalg.norm(n)
    t = np.cross(n, rng.normal(size=3))
    t /= np.linalg.norm(t)
    g = np.radians(grazing_deg)
    s = np.cos(g) * t + np.sin(g) * n
    u = np.cross(n, [0.0, 0.0, 1.0])
    u /= np.linalg.norm(u)
    mirror = rect([0, 0, 0], 0.5 * u, 0.5 * np.cross(n, u))
    out = reflect(-s, n)
    a = np.cross(out, [0.3, 0.1, 1.0])
    a /= np.linalg.norm(a)
    target = rect(5 * out, 3 * a, 3 * np.cross(out, a))
    res = reflected_hits(mirror, [s], target, resolution=128)
    assert res.share == 1.0
    assert abs(res.struck_area[0] - np.sin(g)) < 0.03 * np.sin(g) + 1e-3
