"""Where a session's warm re-solve starts after a goal region moved
(:func:`torsal.session.warm.restarted`): each line near the region's edge is the last design's
line at the same distance from the old edge, on the same side."""
import numpy as np

from torsal.geometry import Congruence, CongruenceProblem
from torsal.geometry.optimize.strategy import Optimum
from torsal.geometry.surfaces import grid_faces
from torsal.session.warm import _energy_vertices, restarted

NX, NY = 12, 6


def _lines(s):
    """A line for each signed distance ``s`` (its own direction per distance)."""
    t = np.arctan(np.asarray(s, float))
    return np.c_[np.cos(t), np.zeros_like(t), np.sin(t)]


def _signed(x, edge):
    """Signed distance from the edge of {x <= edge} on the unit grid's columns (by hand):
    inside to the first column outside, outside to the last column inside."""
    return np.where(x <= edge, edge + 1 - x, edge - x)


def test_a_moved_regions_lines_move_with_its_edge():
    x, y = np.meshgrid(np.arange(NX, dtype=float), np.arange(NY, dtype=float), indexing="ij")
    v = np.c_[x.ravel(), y.ravel(), np.zeros(x.size)]
    c = Congruence.from_normals((v, grid_faces(NX, NY)))
    old_edge, new_edge = 4, 6                      # the region {x <= 4} moved 2 columns
    before = _energy_vertices(CongruenceProblem(c).perpendicular(
        [0, 1, 0], vertices=np.flatnonzero(v[:, 0] <= old_edge)))
    p = CongruenceProblem(c).perpendicular([0, 1, 0], vertices=np.flatnonzero(v[:, 0] <= new_edge))
    last = _lines(_signed(v[:, 0], old_edge))      # the old design: a line per distance from its edge
    e = restarted(Optimum(directions=last), before, p).directions
    s_new = _signed(v[:, 0], new_edge)
    s_old = _signed(v[:, 0], old_edge)
    # every vertex within 4 columns of either edge (RESTART_BAND mean edge lengths, 4.55 here)
    # whose distance the old design had on its side (inside up to 5 columns deep, outside up
    # to 7) has the line of its new distance: columns 2-9
    matchable = ((np.abs(s_new) < 4) | (np.abs(s_old) < 4)) & (s_new <= old_edge + 1)
    assert matchable.sum() == 8 * NY
    np.testing.assert_allclose(e[matchable], _lines(s_new[matchable]), atol=1e-15)
    # beyond the band of both edges (columns 0 and 11) the lines stay the old design's
    far = np.minimum(np.abs(s_new), np.abs(s_old)) >= 5
    assert far.sum() == 2 * NY
    np.testing.assert_array_equal(e[far], last[far])


def test_a_region_added_takes_the_nearest_line_that_had_its_goal():
    """No old edge to match (the energy was over every vertex): a vertex a region takes from
    the energy restarts where a cold solve starts it; a vertex the energy keeps keeps its line."""
    x, y = np.meshgrid(np.arange(NX, dtype=float), np.arange(NY, dtype=float), indexing="ij")
    v = np.c_[x.ravel(), y.ravel(), np.zeros(x.size)]
    c = Congruence.from_normals((v, grid_faces(NX, NY)))
    before = _energy_vertices(CongruenceProblem(c).perpendicular([0, 1, 0]))
    p = CongruenceProblem(c).perpendicular([0, 1, 0], vertices=np.flatnonzero(v[:, 0] >= 3))
    last = _lines(v[:, 0])
    e = restarted(Optimum(directions=last), before, p).directions
    left = v[:, 0] < 3
    np.testing.assert_array_equal(e[~left], last[~left])
    np.testing.assert_allclose(e[left], c.directions[left], atol=1e-15)
