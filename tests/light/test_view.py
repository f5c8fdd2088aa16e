"""The occupant view-out measure against hand-computed cases: no fins, one horizontal louver,
one vertical fin, and the documented grid of eye points."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.integrate import quad

from torsal.geometry.surfaces import canopy, flat_facade, grid_faces
from torsal.light.view import ViewField, eye_points, sight_lines, view_out


def wall(width=40.0, height=10.0, nu=21, nv=11):
    """The plane y = 0, x in [-width/2, width/2], z in [0, height], outside towards -y."""
    x = np.linspace(-width / 2, width / 2, nu)
    z = np.linspace(0.0, height, nv)
    X, Z = np.meshgrid(x, z, indexing="ij")
    return np.c_[X.ravel(), np.zeros(X.size), Z.ravel()], grid_faces(nu, nv)


def plate(corner, a, b):
    """The parallelogram ``corner + s a + t b``, s, t in [0, 1], as two triangles."""
    c, a, b = (np.asarray(x, float) for x in (corner, a, b))
    return trimesh.Trimesh([c, c + a, c + a + b, c + b], [[0, 1, 2], [0, 2, 3]], process=False)


#: one eye point 1 m behind the middle of the wall, 1.2 m up (one storey, one column)
ONE_EYE = ViewField(eye_height=1.2, storey_height=100.0, distances=(1.0,), grid=100.0,
                    azimuth=60.0, elevation=(-30.0, 30.0), step=5.0)
E, DIST = 1.2, 1.0


def test_the_eye_points_are_the_documented_grid():
    v, f = flat_facade()                           # 12 m wide, 6 m high, outside -y
    eyes = eye_points(v, f, ViewField())
    # 12 columns half a metre in from the ends, storeys at 1.2 and 4.2 m, 1, 2, 3 m inside
    # every point on the grid to 1e-9 m: placed in double precision (the hit face's plane
    # intersected again), not from Embree's single-precision distance (~28 m x 6e-8 off)
    grid = np.array(np.meshgrid(np.arange(-5.5, 6.0, 1.0), [1.0, 2.0, 3.0], [1.2, 4.2],
                                indexing="ij")).reshape(3, -1).T
    assert len(eyes.points) == len(grid) == 12 * 2 * 3
    gap = np.linalg.norm(eyes.points[:, None, :] - grid[None], axis=2)
    assert gap.min(axis=1).max() <= 1e-9                      # each point on a grid node
    assert sorted(gap.argmin(axis=1)) == list(range(len(grid)))  # and every node taken once
    np.testing.assert_allclose(eyes.distance, eyes.points[:, 1], rtol=0, atol=1e-9)
    # a canopy: the grid is under it, along its mean normal (up); trimesh's own ray test is
    # float64 throughout, so the two agree to rounding
    cv, cf = canopy(nu=9, nv=9)
    ce = eye_points(cv, cf, ViewField(distances=(2.0,), grid=2.5))
    assert ce.frame.kind == "canopy" and len(ce.points) == 4 * 4
    up = np.tile(ce.frame.axis, (16, 1))
    top, ray, _ = trimesh.Trimesh(cv, cf).ray.intersects_location(ce.points, up)
    assert sorted(ray) == list(range(16))
    np.testing.assert_allclose(top[np.argsort(ray)] - 2.0 * up, ce.points, rtol=0, atol=1e-9)


def test_no_fins_every_sight_line_is_clear():
    v, f = wall()
    res = view_out(trimesh.Trimesh(), (v, f), ONE_EYE)
    assert res.share == 1.0 and res.per_point.tolist() == [1.0]
    assert res.through.all()                       # the 40 m x 10 m wall fills the field
    assert res.sight_angle_deg.tolist() == [120.0]
    assert res.levels == {"minimum": 1.0, "medium": 1.0, "high": 1.0}
    lines = sight_lines(res.eyes.frame, ONE_EYE)
    assert len(lines.directions) == 24 * 12 and len(lines.level) == 24
    np.testing.assert_allclose(np.linalg.norm(lines.directions, axis=1), 1.0)


@pytest.mark.parametrize("h, depth", [(2.0, 0.5), (1.8, 1.2), (2.2, 1.5)])
def test_a_single_louver_hides_the_sight_lines_that_climb_through_it(h, depth):
    """A louver at height h reaching ``depth`` out of the wall: the sight line at azimuth az
    and elevation el is hidden when it reaches height h between the wall (horizontal travel
    d / cos az) and the louver's edge ((d + depth) / cos az)."""
    v, f = wall()
    louver = plate([-20.0, 0.0, h], [40.0, 0.0, 0.0], [0.0, -depth, 0.0])
    res = view_out(louver, (v, f), ONE_EYE)
    lines = sight_lines(res.eyes.frame, ONE_EYE)
    az, el = np.radians(lines.azimuth), np.radians(lines.elevation)
    with np.errstate(divide="ignore"):
        travel = (h - E) / np.tan(el)              # horizontal distance to reach the louver
    hidden = (el > 0) & (travel >= DIST / np.cos(az)) & (travel <= (DIST + depth) / np.cos(az))
    w = np.cos(el)
    expected = 1.0 - (w * hidden).sum() / w.sum()
    assert hidden.any() and res.blocked[0].tolist() == hidden.tolist()
    assert res.share == pytest.approx(expected, abs=1e-12)
    # and the cells converge on the solid-angle integral over the field (5 degree cells)
    a = np.radians(60.0)

    def band(phi):           # sin(el2) - sin(el1) of the hidden elevations at azimuth phi
        lo = np.arctan((h - E) * np.cos(phi) / (DIST + depth))
        hi = min(np.arctan((h - E) * np.cos(phi) / DIST), np.radians(30.0))
        return max(np.sin(hi) - np.sin(lo), 0.0)

    exact = 1.0 - quad(band, -a, a)[0] / (2 * a * (np.sin(np.radians(30)) * 2))
    assert res.share == pytest.approx(exact, abs=0.01)
    assert res.sight_angle_deg.tolist() == [120.0]     # at eye level the louver is overhead


def test_a_single_vertical_fin_narrows_the_horizontal_sight_angle():
    """A vertical fin in the plane x = x0 reaching 1 m out: the eye-level line at azimuth az
    (towards +x) is hidden when x0 lies between d tan az (the wall) and (d + 1) tan az."""
    v, f = wall()
    x0 = 1.0
    fin = plate([x0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 10.0])
    res = view_out(fin, (v, f), ONE_EYE)
    az = np.radians(np.arange(-57.5, 60.0, 5.0))
    hidden = (np.tan(az) * DIST <= x0) & (x0 <= np.tan(az) * (DIST + 1.0))
    assert hidden.sum() == 4                  # azimuths 27.5, 32.5, 37.5 and 42.5 degrees
    assert res.sight_angle_deg.tolist() == [120.0 - 5.0 * hidden.sum()]
    assert res.levels["high"] == 1.0                  # 105 degrees clear >= 54


def test_sight_lines_that_miss_the_surface_do_not_count():
    """A 2 m wide window: the eye sees most of its field through the wall beside it, which
    is not a view through this surface; the share is over the lines through the window."""
    v, f = wall(width=2.0, nu=3)
    louver = plate([-1.0, 0.0, 2.0], [2.0, 0.0, 0.0], [0.0, -0.5, 0.0])
    res = view_out(louver, (v, f), ONE_EYE)
    through = res.through[0]
    assert 0 < through.sum() < len(through)
    w = res.lines.weights
    expected = (w * (through & ~res.blocked[0])).sum() / (w * through).sum()
    assert res.share == pytest.approx(expected, abs=1e-12) and res.share < 1.0


def test_bad_fields_are_named():
    with pytest.raises(ValueError, match="distances"):
        ViewField(distances=(0.0,))
    with pytest.raises(ValueError, match="azimuth"):
        ViewField(azimuth=120.0)
    with pytest.raises(ValueError, match="elevation"):
        ViewField(elevation=(10.0, -10.0))
