"""The report's 3D view, without a browser: what it draws, checked against the inputs."""
import numpy as np
import pytest

from torsal.geometry.support import SupportStructure
from torsal.pipeline.report import design_report_html
from torsal.pipeline.report_3d import (FAMILY_COLOURS, SunRays, design_view_figure, design_view_html,
                              representative_sun)


def _grid_structure(m=4):
    """An m x m quad grid in the plane z = 0 with fins of depth 0.5 standing up (+z)."""
    x, y = np.meshgrid(np.arange(m, dtype=float), np.arange(m, dtype=float), indexing="ij")
    a = np.c_[x.ravel(), y.ravel(), np.zeros(m * m)]
    idx = np.arange(m * m).reshape(m, m)
    e0 = np.c_[idx[:-1, :].ravel(), idx[1:, :].ravel()]   # along x: family 0
    e1 = np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()]   # along y: family 1
    faces = [[idx[i, j], idx[i + 1, j], idx[i + 1, j + 1], idx[i, j + 1]]
             for i in range(m - 1) for j in range(m - 1)]
    s = SupportStructure(a, a + [0, 0, 0.5], faces, np.r_[e0, e1],
                         np.r_[np.zeros(len(e0)), np.ones(len(e1))])
    tris = np.array([t for q in faces for t in ([q[0], q[1], q[2]], [q[0], q[2], q[3]])])
    return s, (a, tris)


def test_representative_sun_keeps_the_weight_and_means_each_cell():
    rng = np.random.default_rng(1)
    elev = np.radians(rng.uniform(5, 60, 400))
    az = np.radians(rng.uniform(150, 290, 400))
    v = np.c_[np.cos(elev) * np.sin(az), np.cos(elev) * np.cos(az), np.sin(elev)]
    w = rng.uniform(0, 800, 400)
    all_rays = representative_sun(v, w, max_rays=10_000)
    assert all_rays.coverage == pytest.approx(1.0) and all_rays.counts.sum() == 400
    assert np.allclose(np.linalg.norm(all_rays.directions, axis=1), 1)
    few = representative_sun(v, w, max_rays=5)
    assert len(few.weights) == 5 and np.all(np.diff(few.weights) <= 0)
    assert few.weights == pytest.approx(all_rays.weights[:5])
    assert few.coverage == pytest.approx(few.weights.sum()) and few.coverage < 1
    # the heaviest ray is the weighted mean direction of the directions in its 10 degree cell
    e, b = np.degrees(elev), np.degrees(az) % 360
    e0, b0 = few.elevation_deg[0], few.bearing_deg[0]
    cell = (np.floor(e / 10) == np.floor(e0 / 10)) & (np.floor(b / 10) == np.floor(b0 / 10))
    mean = (w[cell, None] * v[cell]).sum(0)
    assert np.allclose(few.directions[0], mean / np.linalg.norm(mean))
    assert few.weights[0] == pytest.approx(w[cell].sum() / w.sum())
    assert few.counts[0] == cell.sum()


def test_representative_sun_rejects_empty_or_weightless_input():
    with pytest.raises(ValueError, match="positive weight"):
        representative_sun(np.zeros((0, 3)))
    with pytest.raises(ValueError, match="positive weight"):
        representative_sun([[0, 0, 1]], [0.0])
    with pytest.raises(ValueError, match="shape"):
        representative_sun([[0, 0, 1]], [1.0, 2.0])


def test_the_figure_draws_every_fin_by_family_and_the_sun():
    s, surface = _grid_structure()
    # two directions in one 10 degree cell of the sky (bearing 180-190), one far away
    sun = (np.array([[0.0, -1, 1], [-0.05, -1, 1], [1, 0, 0.2]]), np.array([3.0, 1.0, 1.0]))
    fig = design_view_figure(surface, s, sun)
    by_name = {t.name: t for t in fig.data}
    fins = {fam: next(t for n, t in by_name.items() if n.startswith(f"fins, torsal family {fam}"))
            for fam in (0, 1)}
    n = len(s.vertices_a)
    nodes = np.r_[s.vertices_a, s.vertices_b]
    for fam, t in fins.items():
        assert t.color == FAMILY_COLOURS[fam]
        tri = np.c_[t.i, t.j, t.k]
        assert len(tri) == 2 * int((s.edge_family == fam).sum())
        # every fin a_i a_j b_j b_i is there: its edge on A and its edge on B
        drawn = {tuple(sorted(e)) for e in tri[0::2, :2]}
        assert drawn == {tuple(sorted(e)) for e in s.edges[s.edge_family == fam]}
        assert np.all(tri[0::2, 2] == tri[0::2, 1] + n)
        assert np.allclose(np.c_[t.x, t.y, t.z], nodes)
    assert np.asarray(by_name["design surface A"].i).size == len(surface[1])
    sun_lines = [t for t in fig.data if t.type == "scatter3d"]
    assert sum(np.isfinite(np.asarray(t.x, float)).sum() // 2 for t in sun_lines) == 2  # 2 cells
    heavy = next(t for t in sun_lines if t.name.startswith("sun: heaviest"))
    d = np.array([heavy.x[0] - heavy.x[1], heavy.y[0] - heavy.y[1], heavy.z[0] - heavy.z[1]], float)
    u = sun[0] / np.linalg.norm(sun[0], axis=1, keepdims=True)
    mean = 3 * u[0] + 1 * u[1]                   # weighted mean of the cell, drawn as one ray
    assert np.allclose(d / np.linalg.norm(d), mean / np.linalg.norm(mean))
    assert "5 sun directions" not in fig.layout.title.text and "3 sun directions as 2 rays" in \
        fig.layout.title.text


def test_many_fins_are_subsampled_and_the_view_says_so():
    s, surface = _grid_structure(8)
    fig = design_view_figure(surface, s, max_fins=20)
    names = [t.name for t in fig.data]
    assert sum(len(t.i) for t in fig.data if t.name.startswith("fins")) == 2 * 20
    assert any(f"of {len(s.edges)} shown" in n for n in names)
    assert "sun directions not given" in fig.layout.title.text


def test_the_page_is_offline_with_plotly_inlined_once():
    s, surface = _grid_structure()
    frag = design_view_html(surface, s, (np.array([[0, -1, 1.0]]), np.ones(1)), title="t")
    page = design_report_html({}, {}, "t", view3d=frag)
    assert page.count("<h2>The design in 3D</h2>") == 1 and 'id="torsal-3d"' in page
    assert "<script src=" not in page           # nothing to fetch
    assert page.count("Plotly=") + page.count("window.Plotly") >= 1
    assert len(page) > 1_000_000                 # plotly.js itself is in the page
    again = design_view_html(surface, s, include_plotlyjs=False, div_id="second")
    assert len(again) < 50_000
