"""The standard devices on any surface: facade devices only on a facade, the sun-optimized
parallel fins against the analytic optimum, not-applicable devices with their reason, and the
plane sections (no divide warning on a canopy cut by horizontal planes)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from torsal.geometry.surfaces import canopy, flat_facade, grid_faces
from torsal.light.devices import (
    DEVICE_NAMES,
    baselines,
    optimize_fin_orientation,
    section_fins,
    standard_devices,
    surface_frame,
)
from torsal.light.shading import direct_sun_blocked


def hypar(n=9, size=4.0, k=0.15):
    """A small hyperbolic paraboloid z = k x y over a size x size square, normals up."""
    x = np.linspace(-size / 2, size / 2, n)
    X, Y = np.meshgrid(x, x, indexing="ij")
    return np.c_[X.ravel(), Y.ravel(), 3.0 + k * (X * Y).ravel()], grid_faces(n, n)


def test_horizontal_sections_of_a_canopy_give_no_warning_and_share_their_cut_points():
    v, f = hypar()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fins = section_fins(v, f, [0, 0, 1], 0.3, 0.1)
    assert len(fins.faces) > 0
    # fins lying in the surface: the canopy's slope is at most atan(k size / 2 sqrt 2) ~ 23 deg
    assert fins.metadata["stand_out_deg"] < 25
    # neighbouring quads share their root and tip points: no gaps for light to leak through
    n = len(fins.vertices) // 2
    roots = fins.vertices[:n]
    assert len(np.unique(np.round(roots, 9), axis=0)) == n
    np.testing.assert_allclose(np.linalg.norm(fins.vertices[n:] - roots, axis=1), 0.3)


def test_on_a_canopy_the_facade_devices_are_not_applicable_and_say_why():
    v, f = hypar()
    sun = [[0.3, -0.4, 0.85], [0.1, -0.5, 0.8]]
    d = standard_devices(v, f, 0.3, 0.5, sun=sun)
    assert list(d) == list(DEVICE_NAMES)
    assert surface_frame(v, f).kind == "canopy"
    for name in ("horizontal louvers", "vertical fins", "egg-crate"):
        assert not d[name].applicable and d[name].fins is None
        assert "canopy" in d[name].reason and "optimized parallel fins" in d[name].reason
    for name in ("optimized parallel fins", "optimized egg-crate"):
        assert d[name].applicable and d[name].reason is None
        assert direct_sun_blocked(d[name].fins, (v, f), sun, samples=400).share > 0.2
        assert d[name].stand_out_deg >= 45 - 1e-9             # tilt within 45 degrees
    # the egg-crate's second family stands square to the first
    p, q = d["optimized egg-crate"].plane_normals
    assert abs(p @ q) < 1e-9
    assert d["optimized egg-crate"].as_dict()["orientation"]["evaluations"] > 80


@pytest.mark.parametrize("sun", [[0.6, -1.0, 0.35], [-0.9, -1.0, 0.5], [0.2, -1.0, 0.45]])
def test_upright_optimized_fins_face_the_sun_and_block_the_analytic_share(sun):
    """Upright parallel fins (planes containing the wall's normal) with normal p in the wall:
    a sun s in front blocks min(1, D |<s, p>| / (S <s, n>)), largest for p along s's
    in-plane part."""
    v, f = flat_facade(width=40.0, height=20.0, nu=21, nv=11)
    D, S = 0.4, 0.6
    s = np.asarray(sun) / np.linalg.norm(sun)
    n = np.array([0.0, -1.0, 0.0])
    st = s - (s @ n) * n
    best = optimize_fin_orientation(v, f, [sun], D, S, max_tilt=0.0, samples=2000)
    assert best.tilt_deg == 0.0
    expected_p = st / np.linalg.norm(st)
    angle = np.degrees(np.arccos(min(1.0, abs(best.plane_normal @ expected_p))))
    # the optimum is flat at full blocking: any orientation blocking everything is as good
    analytic = min(1.0, D * np.linalg.norm(st) / (S * (s @ n)))
    assert best.blocked_share == pytest.approx(analytic, abs=0.02)
    if analytic < 0.95:    # near the optimum the share falls as cos(angle): a flat top
        assert angle < 12.0
    # better than or equal to louvers and vertical fins of the same depth and spacing
    made = standard_devices(v, f, D, S, sun=[sun])
    shares = {k: direct_sun_blocked(x.fins, (v, f), [sun], samples=2000).share
              for k, x in made.items()}
    assert shares["optimized parallel fins"] >= max(shares["horizontal louvers"],
                                                    shares["vertical fins"]) - 0.01


def test_tilting_the_planes_blocks_more_of_a_low_sun_than_upright_louvers():
    v, f = flat_facade(width=40.0, height=20.0, nu=21, nv=11)
    sun = [[0.0, -1.0, 0.4]]                 # low sun straight ahead: louvers block D 0.4 / S
    upright = optimize_fin_orientation(v, f, sun, 0.4, 0.6, max_tilt=0.0)
    tilted = optimize_fin_orientation(v, f, sun, 0.4, 0.6)
    assert upright.blocked_share == pytest.approx(0.4 * 0.4 / 0.6, abs=0.02)
    assert tilted.blocked_share > upright.blocked_share + 0.05 and tilted.tilt_deg != 0.0


def test_a_surface_narrower_than_the_spacing_has_no_device_and_the_reason_says_so():
    v, f = flat_facade(width=1.0, height=0.8, nu=5, nv=5)
    v = v + [1.0, 0.0, 0.5]                  # x in [0.5, 1.5], z in [0.5, 1.3]: no plane k 2
    d = standard_devices(v, f, 0.3, 2.0, sun=[[0.2, -1.0, 0.5]])
    assert "no plane of the horizontal louvers cuts A: A spans 0.8" in d["horizontal louvers"].reason
    assert "no plane of the vertical fins cuts A: A spans 1" in d["vertical fins"].reason
    assert d["egg-crate"].reason.startswith("its first family") and d["egg-crate"].fins is None
    for x in d.values():                     # made, with fins, or not made, with a reason
        assert (x.fins is not None and len(x.fins.faces) > 0) == x.applicable == (x.reason is None)
    no_sun = standard_devices(v, f, 0.3, 0.2)
    assert no_sun["optimized parallel fins"].reason == "no sun directions to orient the fins for"


def test_the_legacy_names_still_work():
    from torsal.light import baselines as from_light
    from torsal.light.baselines import horizontal_louvers

    v, f = flat_facade()
    assert from_light is baselines
    sets = baselines(v, f, 0.4, 0.5)
    assert set(sets) == {"horizontal louvers", "vertical fins", "egg-crate"}
    assert len(horizontal_louvers(v, f, 0.4, 0.5).faces) == len(sets["horizontal louvers"].faces)
    assert surface_frame(*canopy(nu=5, nv=5)).kind == "canopy"


def test_a_depth_and_spacing_per_family_make_the_egg_crates_crossing_family_sparser():
    """fins.depth = [d0, d1], fins.spacing = [s0, s1]: the single-family devices take family
    0's, an egg-crate's crossing family family 1's; on a flat 12 x 6 facade its vertical fins
    are 6 m x d1 plates about 12 / s1 of them (the section count, independently of torsal)."""
    v, f = flat_facade(width=12.0, height=6.0, nu=13, nv=7)
    sun = [[0.3, -0.8, 0.5]]
    mixed = standard_devices(v, f, (0.3, 0.15), (0.6, 1.2), sun=sun)
    first = standard_devices(v, f, 0.3, 0.6, sun=sun)
    second = standard_devices(v, f, 0.15, 1.2, sun=sun)
    for name in ("horizontal louvers", "vertical fins", "optimized parallel fins"):
        assert mixed[name].fins.area == pytest.approx(first[name].fins.area, rel=1e-12)
    crossing = second["vertical fins"].fins.area
    assert mixed["egg-crate"].fins.area == pytest.approx(
        first["horizontal louvers"].fins.area + crossing, rel=1e-12)
    planes = np.unique(np.round(second["vertical fins"].fins.vertices @ [1.0, 0, 0], 6)).size
    assert crossing == pytest.approx(planes * 6.0 * 0.15, rel=0.02)
    assert abs(planes - 12.0 / 1.2) <= 1
    assert mixed["optimized egg-crate"].fins.area < first["optimized egg-crate"].fins.area
