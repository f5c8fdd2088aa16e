"""The light figures a preview shows: which face of mesh A each sun sample point is on comes
from the draw itself (no closest-point query), the same faces as measured geometrically."""
import numpy as np
import trimesh

from torsal.geometry.surfaces import facade_patch
from torsal.light import direct_sun_blocked
from torsal.pipeline.measure import SAMPLE_SEED, sample_faces


def _inside(v, f, tri, points):
    """Each point lies in the plane of its face and inside it (barycentric coordinates >= 0)."""
    a, b, c = (v[f[tri, k]] for k in range(3))
    n = np.cross(b - a, c - a)
    area2 = (n * n).sum(1)
    bary = np.stack([(np.cross(c - b, points - b) * n).sum(1), (np.cross(a - c, points - c) * n).sum(1),
                     (np.cross(b - a, points - a) * n).sum(1)], axis=1) / area2[:, None]
    off_plane = np.abs(((points - a) * n).sum(1)) / np.sqrt(area2)
    return bary.min(axis=1) >= -1e-9, off_plane


def test_the_sample_points_faces_are_those_they_lie_on():
    v, f = facade_patch(nu=9, nv=7)
    shading = direct_sun_blocked(trimesh.Trimesh(), (v, f), [[0.3, -0.8, 0.5]], samples=700,
                                 seed=SAMPLE_SEED)
    tri = sample_faces((v, f), shading.points, 700)
    ok, off_plane = _inside(v, f, tri, shading.points)
    assert tri.shape == (700,) and ok.all() and off_plane.max() < 1e-12
    # the faces a closest-point query gives (points on a shared edge could take either)
    closest = trimesh.proximity.closest_point(trimesh.Trimesh(v, f, process=False), shading.points)[2]
    assert np.array_equal(tri, closest)


def test_points_drawn_otherwise_are_given_their_nearest_face():
    v, f = facade_patch(nu=9, nv=7)
    mesh = trimesh.Trimesh(v, f, process=False)
    other = trimesh.sample.sample_surface(mesh, 300, seed=SAMPLE_SEED + 1)[0]
    for samples in (300, other, "vertices"):          # not the seeded draw of that many points
        tri = sample_faces((v, f), other, samples)
        ok, off_plane = _inside(v, f, tri, other)
        assert ok.all() and off_plane.max() < 1e-12
