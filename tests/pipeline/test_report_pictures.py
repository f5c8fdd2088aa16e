"""The report's pictures (torsal.pipeline.report): the fins' log colour bar labelled in plain
text at the powers of ten (no TeX to parse), the sheets' part labels inside the sheets they
are left out of the tight layout for, the PNG the figure's size at its dpi."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from shapely.geometry import box

from torsal.fabrication.layout import Layout, Placement
from torsal.pipeline import report

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "fabrication"))
from fab_structures import sphere_structure  # noqa: E402


@pytest.mark.parametrize("value, label", [(1e-6, "10⁻⁶"), (1e-2, "10⁻²"), (1.0, "10⁰"),
                                          (1e3, "10³"), (3e-4, ""), (0.0, ""), (-1.0, "")])
def test_power_of_ten_labels(value, label):
    assert report._power_of_ten(value) == label


@pytest.fixture
def figures(monkeypatch):
    """The figures the plot functions save, kept after their PNG is written."""
    kept = []
    save = report._save

    def keep(fig, path):
        kept.append(fig)
        return save(fig, path)

    monkeypatch.setattr(report, "_save", keep)
    return kept


def test_fins_colour_bar_is_labelled_at_the_powers_of_ten_without_tex(tmp_path, figures):
    s = sphere_structure(nu=5, nv=4)
    v = s.vertices_a
    f = np.array([q for q in s.faces])
    path = report.plot_fins(s, (v, f), tmp_path / "fins.png")
    fig = figures[0]
    bar = fig.axes[-1]                                  # the colour bar's axes
    lo, hi = bar.get_ylim()
    shown = [(loc, t.get_text()) for loc, t in zip(bar.yaxis.get_majorticklocs(),
                                                   bar.yaxis.get_ticklabels())
             if lo * (1 - 1e-9) <= loc <= hi * (1 + 1e-9)]
    assert (lo, hi) == pytest.approx((1e-6, 1e-2))     # planarity below 1e-2: the bar's floor
    assert [text for _, text in shown] == ["10⁻⁶", "10⁻⁵", "10⁻⁴", "10⁻³", "10⁻²"]
    assert all("$" not in text for _, text in shown)
    assert not any(t.get_text() for t in bar.yaxis.get_ticklabels(minor=True))
    w, h = fig.get_size_inches() * fig.dpi
    assert Image.open(path).size == (round(w), round(h))


def test_sheet_labels_stay_inside_their_sheets_out_of_the_layout(tmp_path, figures):
    placements = [Placement(f"P{i}", i % 2, 0.0, (0.0, 0.0), box(20 + 300 * (i // 2), 20,
                                                                   260 + 300 * (i // 2), 120),
                            label=(140.0 + 300 * (i // 2), 70.0)) for i in range(6)]
    lay = Layout((1000.0, 500.0), placements, 2)
    path = report.plot_sheets(lay, tmp_path / "sheets.png")
    fig = figures[0]
    renderer = fig.canvas.get_renderer()
    for ax, sheet in zip(fig.axes, range(2)):
        labels = [t for t in ax.texts]
        assert sorted(t.get_text() for t in labels) == sorted(
            p.name for p in placements if p.sheet == sheet)
        frame = ax.get_window_extent(renderer)
        for t in labels:
            assert not t.get_in_layout()
            e = t.get_window_extent(renderer)
            assert frame.x0 <= e.x0 and e.x1 <= frame.x1 and frame.y0 <= e.y0 and e.y1 <= frame.y1
    w, h = fig.get_size_inches() * fig.dpi
    image = np.asarray(Image.open(path))
    assert image.shape[:2] == (round(h), round(w)) and image[..., :3].min() < 100   # drawn
