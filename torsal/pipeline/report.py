"""Figures and reports: PNG figures with matplotlib (Agg, no screen needed), JSON summaries."""
from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from ..core.atomic import atomic_path
from ..geometry.mesh import area_vector
from .report_3d import design_view_html

__all__ = ["plot_torsal_field", "principal_plane", "plot_fins", "plot_blocked_sun", "plot_sheets",
           "plot_annual_map", "plot_annual_months", "plot_daylight_plans", "best_device",
           "design_report_html", "write_design_report", "draw_design_pictures", "plot_assembly",
           "plot_ceiling_light"]


def principal_plane(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centroid and orthonormal axes (3, 3) of a point cloud, largest spread first (PCA).

    The first two axes span the plane a facade or canopy is best seen in.
    """
    p = np.asarray(points, float)
    c = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - c, full_matrices=False)
    return c, vt


def _view_frame(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`principal_plane` oriented so the surface's mean normal points at the viewer."""
    center, axes = principal_plane(v)
    if area_vector(v, f) @ axes[2] < 0:
        axes = axes * [[1], [-1], [-1]]
    return center, axes


def _torsal_field_panel(fig, ax, congruence, max_segments: int) -> None:
    """Left panel of :func:`plot_torsal_field`: mesh A in its principal plane, faces coloured
    by the torsal angle, short segments along both torsal directions."""
    from matplotlib.collections import LineCollection, PolyCollection

    v, f = congruence.vertices, congruence.faces
    center, axes = _view_frame(v, f)
    uv = (v - center) @ axes[:2].T
    t = congruence.torsal_directions()
    ang = congruence.torsal_angle()
    bc2 = (congruence.barycenters() - center) @ axes[:2].T
    valid = np.isfinite(t).all(axis=(1, 2))
    pc = PolyCollection(uv[f], array=np.where(valid, ang, np.nan), cmap="viridis",
                        edgecolors=(0.6, 0.6, 0.6, 0.35), linewidths=0.3)
    pc.set_clim(0, 90)
    ax.add_collection(pc)
    cb = fig.colorbar(pc, ax=ax, shrink=0.8)
    cb.set_label("angle between torsal directions (deg)")
    idx = np.flatnonzero(valid)
    if idx.size > max_segments:
        idx = idx[np.linspace(0, idx.size - 1, max_segments).astype(int)]
    half = 0.35 * congruence.delta * max(1.0, np.sqrt(len(f) / max(idx.size, 1)))
    d2 = t[idx] @ axes[:2].T  # (k, 2, 2)
    d2 /= np.maximum(np.linalg.norm(d2, axis=2, keepdims=True), 1e-300)
    # the index t of eq. (1)'s solutions follows the focal-parameter order, which can swap
    # between neighbours; for a readable picture colour by the direction nearer axis 1
    first = np.abs(d2[:, 0, 0]) >= np.abs(d2[:, 1, 0])
    along = np.where(first[:, None], d2[:, 0], d2[:, 1])
    across = np.where(first[:, None], d2[:, 1], d2[:, 0])
    for d, colour, label in ((along, "tab:red", "torsal direction nearer axis 1"),
                             (across, "tab:blue", "torsal direction nearer axis 2")):
        segs = np.stack([bc2[idx] - half * d, bc2[idx] + half * d], axis=1)
        ax.add_collection(LineCollection(segs, colors=colour, linewidths=1.0, label=label))
    bad = ~valid
    if bad.any():
        ax.plot(bc2[bad, 0], bc2[bad, 1], "x", color="0.3", ms=3,
                label=f"no torsal directions ({int(bad.sum())} faces)")
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_xlabel("principal axis 1 (model units)")
    ax.set_ylabel("principal axis 2 (model units)")
    ax.set_title("torsal direction fields (paper eq. 1)")
    ax.legend(loc="upper right", fontsize=8, framealpha=0.9)


def _congruence_lines_panel(ax3, congruence) -> None:
    """Right panel of :func:`plot_torsal_field`: mesh A in 3D and (at most ~600 of) its lines
    a_i -> a_i + 2 delta e_i / |e_i|."""
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    v, f = congruence.vertices, congruence.faces
    ax3.add_collection3d(Poly3DCollection(v[f], facecolor=(0.8, 0.82, 0.86, 0.6),
                                          edgecolor=(0.5, 0.5, 0.5, 0.2), linewidths=0.2))
    step = max(1, len(v) // 600)
    a = v[::step]
    e = congruence.directions[::step]
    e = e / np.linalg.norm(e, axis=1, keepdims=True) * 2 * congruence.delta
    ax3.add_collection3d(Line3DCollection(np.stack([a, a + e], axis=1), colors="tab:orange",
                                          linewidths=0.6, label="lines of the congruence"))
    _cube_limits(ax3, v)
    ax3.set_xlabel("x")
    ax3.set_ylabel("y")
    ax3.set_zlabel("z")
    ax3.set_title("mesh A and lines a_i + lambda e_i")
    ax3.legend(loc="upper right", fontsize=8)


def plot_torsal_field(congruence, path: str | Path, *, title: str | None = None,
                      max_segments: int = 900) -> Path:
    """Draw mesh A with its two torsal direction fields and write a PNG (atomically).

    Left: the mesh seen in its principal plane, faces coloured by the angle between the two
    torsal directions, two short segments per face along the torsal directions (red: the one
    nearer the view's first axis, blue: the other),
    grey crosses on faces that are not hyperbolic or are line bundles. Right: a 3D view with
    the line congruence (segments a_i -> b_i). Axes in model units.

    Parameters
    ----------
    congruence : torsal.geometry.Congruence
    path : str or Path
        Output PNG.
    max_segments : int
        At most this many faces get direction segments (evenly subsampled) to keep the
        figure readable for large meshes.

    Examples
    --------
    >>> plot_torsal_field(Congruence.from_normals(mesh), "out/torsal_field.png")  # doctest: +SKIP
    """
    fig = _figure((14, 6.5))
    _torsal_field_panel(fig, fig.add_subplot(1, 2, 1), congruence, max_segments)
    _congruence_lines_panel(fig.add_subplot(1, 2, 2, projection="3d"), congruence)
    if title:
        fig.suptitle(title)
    path = Path(path)
    _save(fig, path)
    return path


# ====================================================================== design report
def _figure(figsize):
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, dpi=110)


def _save(fig, path: Path) -> str:
    """Lay ``fig`` out tight and write it as a PNG at ``path``; returns the file name.

    Written by Agg's ``print_png`` directly: ``savefig`` would draw the whole figure once
    more without rendering it first (the layout engine ``tight_layout`` leaves behind makes it
    do so), for the same bytes (7a's five pictures: about a quarter of their time). Compressed
    at zlib level 3, not Pillow's 6: the same pixels, 6 % more bytes, in half the time (7a's
    four pictures 0.46 -> 0.22 CPU s, the most of any one step of drawing them)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig.tight_layout()
    with atomic_path(path) as tmp:
        FigureCanvasAgg(fig).print_png(tmp, pil_kwargs={"compress_level": _PNG_LEVEL})
    return path.name


#: zlib level of the PNG pictures (:func:`_save`)
_PNG_LEVEL = 3


def _cube_limits(ax, points: np.ndarray) -> None:
    """Equal axis ranges around the finite ones of ``points`` (n, 3): a degenerate fin or a
    solid's face with a non-finite corner must not leave the whole picture without limits."""
    p = np.asarray(points, float).reshape(-1, 3)
    p = p[np.isfinite(p).all(axis=1)]
    if not len(p):
        return
    lo, hi = p.min(axis=0), p.max(axis=0)
    mid, rad = (lo + hi) / 2, max(float((hi - lo).max()) / 2, 1e-9)
    ax.set_xlim(mid[0] - rad, mid[0] + rad)
    ax.set_ylim(mid[1] - rad, mid[1] + rad)
    ax.set_zlim(mid[2] - rad, mid[2] + rad)


_SUPERSCRIPT = str.maketrans("-0123456789", "\u207b\u2070\u00b9\u00b2\u00b3\u2074\u2075\u2076\u2077\u2078\u2079")


def _power_of_ten(value: float, _pos=None) -> str:
    """A log colour bar's label: ``10⁻⁶`` at a power of ten, nothing between. In plain
    (Unicode) text: matplotlib's own labels are TeX (``$10^{-6}$``), whose parser took a tenth
    of the pictures' time (built in their process and run for every label)."""
    e = np.log10(value) if value > 0 else np.nan
    if not np.isfinite(e) or abs(e - round(e)) > 1e-9:
        return ""
    return "10" + str(int(round(e))).translate(_SUPERSCRIPT)


def plot_fins(structure, surface, path: str | Path, *, title: str = "") -> Path:
    """3D view of the fins over the surface, each fin coloured by its planarity (Fig. 12's
    measure: distance of the diagonals / their mean length, log scale), seen from outside."""
    from matplotlib.colors import LogNorm
    from matplotlib.ticker import FuncFormatter, NullFormatter
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    v, f = surface
    quads = structure.fin_quads()
    pl = np.maximum(structure.planarity(), 1e-9)
    fig = _figure((11, 7.5))
    ax = fig.add_subplot(1, 1, 1, projection="3d")
    ax.add_collection3d(Poly3DCollection(v[f], facecolor=(0.75, 0.78, 0.82, 0.35),
                                         edgecolor=(0.6, 0.6, 0.6, 0.08), linewidths=0.2))
    norm = LogNorm(vmin=1e-6, vmax=max(1e-2, float(pl.max())))
    pc = Poly3DCollection(quads, array=pl, cmap="plasma", norm=norm, edgecolor=(0, 0, 0, 0.25),
                          linewidths=0.15)
    ax.add_collection3d(pc)
    cb = fig.colorbar(pc, ax=ax, shrink=0.7, pad=0.08, format=FuncFormatter(_power_of_ten))
    cb.ax.yaxis.set_minor_formatter(NullFormatter())
    cb.set_label("fin planarity: diagonal distance / mean diagonal (log)")
    _cube_limits(ax, np.concatenate([v, structure.vertices_b]))
    n = area_vector(v, f)
    n /= np.linalg.norm(n)
    ax.view_init(elev=float(np.clip(np.degrees(np.arcsin(n[2])), 15, 60)),
                 azim=float(np.degrees(np.arctan2(n[1], n[0]))) + 25)
    ax.set_xlabel("x (east)")
    ax.set_ylabel("y (north)")
    ax.set_zlabel("z (up)")
    ax.set_title(title or f"{len(quads)} fins, delta_pl = {structure.delta_pl:.2e}")
    return Path(path).parent / _save(fig, Path(path))


def _surface_map(points, values, surface, path: Path, *, cmap: str, limits, label: str,
                 title: str, missing: str = "") -> Path:
    """Values at sample points over mesh A, seen in its principal plane: points (p, 3), values
    (p,) (NaN: drawn as a grey cross, labelled ``missing``), limits (vmin, vmax) or None."""
    from matplotlib.collections import PolyCollection

    v, f = surface
    c, axes = _view_frame(v, f)
    uv = (v - c) @ axes[:2].T
    p2 = (np.asarray(points) - c) @ axes[:2].T
    fig = _figure((11, 5.5))
    ax = fig.add_subplot(1, 1, 1)
    ax.add_collection(PolyCollection(uv[f], facecolor=(0.92, 0.92, 0.92), edgecolor=(0.7, 0.7, 0.7, 0.3),
                                     linewidths=0.2))
    values = np.asarray(values, float)
    ok = np.isfinite(values)
    vmin, vmax = limits if limits is not None else (None, None)
    sc = ax.scatter(p2[ok, 0], p2[ok, 1], c=values[ok], cmap=cmap, vmin=vmin, vmax=vmax, s=9)
    if (~ok).any():
        ax.scatter(p2[~ok, 0], p2[~ok, 1], c="0.6", s=4, marker="x", label=missing)
        ax.legend(loc="upper right", fontsize=8)
    cb = fig.colorbar(sc, ax=ax)
    cb.set_label(label)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_xlabel("along the surface, principal axis 1 (model units)")
    ax.set_ylabel("principal axis 2 (model units)")
    ax.set_title(title)
    return Path(path).parent / _save(fig, Path(path))


def plot_blocked_sun(points, per_point, surface, path: str | Path, *, title: str = "") -> Path:
    """Map of the blocked share of direct sun at the sample points, seen in the surface's
    principal plane (0 = all sun gets through, 1 = fully shaded)."""
    return _surface_map(points, per_point, surface, path, cmap="RdYlGn", limits=(0, 1),
                        label="share of direct sun blocked by the fins",
                        title=title or "blocked direct sun at the design hours",
                        missing="no direct sun")


def plot_annual_map(points, kwh_m2, surface, path: str | Path, *, title: str = "") -> Path:
    """Map of the year's solar irradiation on the glazing behind the fins, kWh/m^2 at the
    sample points (points (p, 3), kwh_m2 (p,)), seen in the surface's principal plane."""
    return _surface_map(points, kwh_m2, surface, path, cmap="inferno", limits=None,
                        label="solar irradiation on the glazing over the year (kWh/m²)",
                        title=title or "annual irradiance on the glazing behind the fins")


def best_device(annual: dict) -> str | None:
    """The standard device of ``light.annual`` that avoids the most cooling-season gains
    (None when none was made)."""
    made = {n: d for n, d in annual.get("devices", {}).items() if d.get("applicable", True)}
    return min(made, key=lambda n: made[n]["cooling_kwh_m2"]) if made else None


def plot_daylight_plans(plans: dict, path: str | Path) -> Path:
    """False-colour plans of the rooms' work planes, one row per storey: the share of the
    occupied hours with 300 lx or more (sDA's measure) and the hours of direct sun of 1000 lx
    or more (ASE's), bare and behind the fins. ``plans``: ``rooms`` (list of Room), ``bare``
    and ``fins`` (lists of Daylight, one per room)."""
    rooms = plans["rooms"]
    fig = _figure((12, 2.6 * len(rooms) + 0.8))
    panels = [("bare", "sda"), ("fins", "sda"), ("bare", "ase"), ("fins", "ase")]
    for i, room in enumerate(rooms):
        for j, (which, measure) in enumerate(panels):
            ax = fig.add_subplot(len(rooms), 4, 4 * i + j + 1)
            d = plans[which][i]
            rel = d.points - np.asarray(room.origin, float)
            u, w = rel @ np.asarray(room.along, float), rel @ np.asarray(room.inward, float)
            top = max(500, *(int(plans[k][i].hours_ase.max()) for k in ("bare", "fins")))
            values, limits = ((d.hours_sda / d.occupied_hours, (0, 1)) if measure == "sda" else
                              (d.hours_ase, (0, top)))       # bare and fins on one scale
            sc = ax.scatter(u, w, c=values, cmap="viridis" if measure == "sda" else "magma",
                            vmin=limits[0], vmax=limits[1], marker="s", s=30)
            ax.axhline(0.0, color="tab:blue", lw=3)          # the window wall
            ax.set_aspect("equal")
            ax.set_title(f"storey at {room.origin[2]:.1f}, {which}\n" +
                         ("share of hours >= 300 lx (LM-83 blinds)" if measure == "sda" else
                          "hours of sun >= 1000 lx"), fontsize=8)
            ax.tick_params(labelsize=7)
            fig.colorbar(sc, ax=ax, shrink=0.8)
    fig.suptitle("daylight on the work plane (window wall at the bottom of each plan)")
    return Path(path).parent / _save(fig, Path(path))


def plot_annual_months(annual: dict, path: str | Path) -> Path:
    """Monthly bars of ``light.annual``: kWh/m^2 on the bare glazing, behind the fins and
    behind the best device (:func:`best_device`)."""
    rows = [("bare", annual["bare"]), ("torsal fins", annual["fins"])]
    best = best_device(annual)
    if best is not None:
        rows.append((best, annual["devices"][best]))
    fig = _figure((11, 4.5))
    ax = fig.add_subplot(1, 1, 1)
    x, width = np.arange(12), 0.8 / len(rows)
    for k, (name, m) in enumerate(rows):
        ax.bar(x + (k - (len(rows) - 1) / 2) * width, m["monthly_kwh_m2"], width, label=name)
    ax.set_xticks(x, _MONTHS)
    ax.set_ylabel("kWh/m² on the glazing")
    ax.set_title("solar irradiation on the glazing per month")
    ax.legend(fontsize=8)
    return Path(path).parent / _save(fig, Path(path))


def plot_sheets(layout, path: str | Path, *, max_sheets: int = 6) -> Path:
    """The nested cutting sheets: part outlines (cut), fold lines (dashed) and part ids."""
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.patches import Rectangle

    k = min(layout.n_sheets, max_sheets)
    cols = min(k, 2)
    rows = (k + cols - 1) // cols
    W, H = layout.sheet
    fig = _figure((7 * cols, 3.8 * rows + 0.4))
    for s in range(k):
        ax = fig.add_subplot(rows, cols, s + 1)
        ax.add_patch(Rectangle((0, 0), W, H, fill=False, edgecolor="k", linewidth=1.2))
        placed = list(layout.on_sheet(s))
        # one collection per sheet, not one artist per part: hundreds of parts draw at once
        ax.add_collection(PolyCollection(
            [np.column_stack(pl.polygon.exterior.xy) for pl in placed],
            facecolor=(0.55, 0.7, 0.9, 0.6), edgecolor="tab:blue", linewidth=0.6))
        folds = [np.column_stack(line.xy) for pl in placed for line, _angle in pl.folds]
        if folds:
            ax.add_collection(LineCollection(folds, colors="tab:red", linestyles="--",
                                             linewidths=0.5))
        for pl in placed:
            # inside the sheet: not in the tight layout, which would measure every label
            ax.text(pl.label[0], pl.label[1], pl.name, fontsize=4, ha="center", va="center",
                    in_layout=False)
        ax.set_xlim(-0.02 * W, 1.02 * W)
        ax.set_ylim(-0.02 * H, 1.02 * H)
        ax.set_aspect("equal")
        ax.set_title(f"sheet {s + 1} of {layout.n_sheets}: {100 * layout.sheet_utilization[s]:.0f}% used",
                     fontsize=9)
        ax.set_xlabel(f"{layout.unit}")
        ax.set_ylabel(f"{layout.unit}")
    return Path(path).parent / _save(fig, Path(path))


def plot_assembly(solids, check, path, *, title: str | None = None) -> Path:
    """3D view of every part (family 0 orange, family 1 blue, connectors green, grey
    otherwise) with interfering parts red and parts that cannot be inserted magenta."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from ..fabrication import face_polygons

    items = list(solids.items()) if hasattr(solids, "items") else list(solids)
    bad = set(check.interfering_parts)
    blocked = {s.part for s in check.blocked}
    fig = _figure((9, 7))
    ax = fig.add_subplot(projection="3d")
    polys, colors = [], []
    for name, solid in items:
        if name in bad:
            col = (0.85, 0.05, 0.05, 1.0)
        elif name in blocked:
            col = (0.8, 0.0, 0.8, 1.0)
        elif name.startswith("F0"):
            col = (0.93, 0.55, 0.14, 0.35)
        elif name.startswith("F1"):
            col = (0.16, 0.45, 0.78, 0.35)
        elif name.startswith("C"):
            col = (0.30, 0.65, 0.30, 0.6)
        else:
            col = (0.5, 0.5, 0.5, 0.35)
        for poly in face_polygons(solid):
            polys.append(poly)
            colors.append(col)
    keep = [k for k, q in enumerate(polys) if np.isfinite(q).all()]
    if keep:
        ax.add_collection3d(Poly3DCollection([polys[k] for k in keep],
                                             facecolors=[colors[k] for k in keep],
                                             edgecolors="none"), autolim=False)
        _cube_limits(ax, np.concatenate([polys[k] for k in keep]))
    ax.set_xlabel(f"x ({check.unit})")
    ax.set_ylabel(f"y ({check.unit})")
    ax.set_zlabel(f"z ({check.unit})")
    verdict = ("buildable" if check.buildable else
               f"NOT buildable: {check.interfering_pairs} interfering pairs (red, "
               f"{len(bad)} parts), {len(blocked)} parts blocked (magenta)")
    ax.set_title(title or f"{len(items)} parts, {check.pairs_checked} touching pairs checked; "
                 f"{verdict}", fontsize=9)
    return Path(path).parent / _save(fig, Path(path))


def _ceiling_grid(picture: dict, bins: int = 96):
    """Bin edges over the ceiling window: twice the target's size around its centre, square
    cells, about ``bins`` along the longer side."""
    c, size = np.asarray(picture["target"]["centre"], float), np.asarray(picture["target"]["size"], float)
    half = size.copy()
    cell = 2 * half.max() / bins
    nx, ny = (max(8, int(round(2 * h / cell))) for h in half)
    return (np.linspace(c[0] - half[0], c[0] + half[0], nx + 1),
            np.linspace(c[1] - half[1], c[1] + half[1], ny + 1))


def plot_ceiling_light(picture: dict, path: str | Path, *, title: str = "") -> Path:
    """The reflected sunlight on the ceiling plane (the paper's Fig. 13 shows it): where the
    light the fins reflect ends, per sun direction and averaged over the design hours, as
    irradiance in units of the direct normal irradiance (1 = as bright as a surface facing the
    sun), the target outlined, the surface's plan in grey.

    ``picture`` as returned by :func:`torsal.pipeline.reflection.measure_reflection`.
    """
    from matplotlib.patches import Rectangle

    ex, ey = _ceiling_grid(picture)
    cell = (ex[1] - ex[0]) * (ey[1] - ey[0])
    dirs = picture["directions"]
    maps = [np.histogram2d(d["xy"][:, 0], d["xy"][:, 1], bins=(ex, ey))[0] * d["area"] / cell
            if len(d["xy"]) else np.zeros((len(ex) - 1, len(ey) - 1)) for d in dirs]
    w = np.array([d["weight"] for d in dirs], float)
    total = sum(wi * m for wi, m in zip(w, maps)) / w.sum() if len(maps) and w.sum() > 0 else \
        np.zeros((len(ex) - 1, len(ey) - 1))
    shown = list(range(len(dirs)))
    if len(shown) > 3:  # the three directions that bring the most light
        shown = sorted(np.argsort([-wi * m.sum() for wi, m in zip(w, maps)])[:3].tolist())
    panels = [(maps[j], dirs[j]) for j in shown] + [(total, None)]
    vmax = max(float(np.percentile(m[m > 0], 99.5)) if (m > 0).any() else 0.0 for m, _ in panels)
    vmax = vmax if vmax > 0 else 1.0
    c, size = picture["target"]["centre"], picture["target"]["size"]
    plan = np.asarray(picture["plan"], float)
    inwin = ((plan[:, 0] >= ex[0]) & (plan[:, 0] <= ex[-1]) & (plan[:, 1] >= ey[0])
             & (plan[:, 1] <= ey[-1]))
    cols = min(len(panels), 2)
    rows = (len(panels) + cols - 1) // cols
    aspect = (ey[-1] - ey[0]) / (ex[-1] - ex[0])
    fig = _figure((6.2 * cols, 6.2 * rows * aspect + 1.0))
    for k, (m, d) in enumerate(panels):
        ax = fig.add_subplot(rows, cols, k + 1)
        ax.set_facecolor("black")
        im = ax.imshow(m.T, origin="lower", extent=(ex[0], ex[-1], ey[0], ey[-1]), cmap="inferno",
                       vmin=0.0, vmax=vmax, interpolation="nearest")
        ax.add_patch(Rectangle((c[0] - size[0] / 2, c[1] - size[1] / 2), size[0], size[1],
                               fill=False, edgecolor="cyan", linewidth=1.2, linestyle="--"))
        if inwin.any():
            ax.plot(plan[inwin, 0], plan[inwin, 1], ".", color="0.6", ms=1)
        if d is None:
            share = picture.get("on_target")
            head = "average over the design hours"
        else:
            v = np.asarray(d["vector"], float)
            share = d.get("on_target")
            head = (f"sun azimuth {np.degrees(np.arctan2(v[0], v[1])) % 360:.0f}\N{DEGREE SIGN}, "
                    f"elevation {np.degrees(np.arcsin(np.clip(v[2], -1, 1))):.0f}\N{DEGREE SIGN}")
        tail = "" if share is None else f": {100 * share:.0f}% of the struck light on target"
        ax.set_title(head + tail, fontsize=9)
        ax.set_xlabel("x (model units)")
        ax.set_ylabel("y (model units)")
        cb = fig.colorbar(im, ax=ax, shrink=0.85)
        cb.set_label("irradiance / DNI", fontsize=8)
    fig.suptitle(title or f"reflected sunlight on the ceiling plane z = {c[2]:g} (target dashed, "
                 "surface plan grey)", fontsize=10)
    return Path(path).parent / _save(fig, Path(path))


def _reflection_html(r: dict) -> str:
    """Section 3b: where the fins send the sunlight (light.reflection), per sun direction."""
    def pct(x):
        return "-" if x is None else f"{100 * x:.1f}%"

    rows = [(f"{d['azimuth_deg']:.0f}&deg; / {d['elevation_deg']:.0f}&deg;", f"{d['weight']:.3g}",
             f"{d['struck_m2']:.2f}", pct(d["on_target"]), pct(d["elsewhere"]), pct(d["trapped"]),
             f"{pct(d['reflecting_fins_share'])} / {pct(d['reflecting_fins_on_target'])}",
             pct(d["other_family_only"]), pct(d["bound_ideal_mirrors"]))
            for d in r["per_sun_direction"]]
    rf = r["reflecting_fins"]
    rows.append(("<b>design hours</b>", "", f"{r['struck_m2']:.2f}", f"<b>{pct(r['on_target'])}</b>",
                 pct(r["elsewhere"]), pct(r["trapped"]),
                 f"{pct(rf['share_of_struck'])} / {pct(rf['on_target'])}",
                 pct(r["other_family_only"]), pct(r["bound"]["ideal_mirrors"])))
    goal = r["goal"]
    verdict = (f'<span class="{"ok" if goal["met"] else "bad"}">'
               f'{"met" if goal["met"] else "missed"}</span>')
    t = r["target"]
    err = r["fin_plane_error_deg"].get(str(r["reflecting_family"]))
    planes = (f" The reflecting family is family {r['reflecting_family']}: its fins lie within "
              f"{err['median']:.1f}&deg; (median; 90% within {err['p90']:.1f}&deg;) of the best "
              "mirror planes at their centres." if err else "")
    limits = (f" What limits the share: {pct(r['other_family_only'])} of the struck light meets "
              "only the other family's fins (at the hours the sun stands beside their planes) and "
              "cannot be steered; of the light that meets a mirror fin "
              f"{pct(rf['on_target'])} lands. Ideal planar mirrors at the struck points would land "
              f"{pct(r['bound']['ideal_mirrors'])}: the rest is the spread of the sunlight over the "
              "design hours, which no single plane gathers into the target.")
    return ("<h2>3b. Reflection onto the ceiling (paper 4.3, Fig. 13)</h2>"
            f"<p>Target: {t['size'][0]:g} &times; {t['size'][1]:g} on the ceiling plane "
            f"z = {t['centre'][2]:g}, centred at ({t['centre'][0]:g}, {t['centre'][1]:g}), lit from "
            f"below. Goal: at least {100 * goal['on_target_at_least']:.0f}% of the struck light "
            f"on the target: {verdict}.{planes}{limits}</p>"
            + _table(rows, ("sun azimuth / elevation", "weight", "struck (m&sup2;)", "on target",
                            "elsewhere", "trapped", "meets the mirror family / of it on target",
                            "meets only the other family", "bound: ideal mirrors"))
            + f"<p><small>{html.escape(r['definition'])} {r['rays_per_direction']} rays per sun "
              "direction.</small></p>")


_HTML = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<style>
body {{ font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }}
table {{ border-collapse: collapse; margin: 0.5em 0 1.5em; }}
td, th {{ border: 1px solid #ccc; padding: 0.3em 0.8em; text-align: left; }}
th {{ background: #f2f2f2; }} td.num {{ text-align: right; font-variant-numeric: tabular-nums; }}
img {{ max-width: 100%; border: 1px solid #ddd; margin: 0.5em 0; }}
.bad {{ color: #b00; font-weight: bold; }} .ok {{ color: #070; font-weight: bold; }}
</style></head><body>
<h1>{title}</h1>
<p>torsal design report. Method: Wang et al. 2013, <i>Discrete Line Congruences for Shading and
Lighting</i>. Units: {units}. All numbers below are measured on this design.</p>
{sections}
</body></html>
"""


def _table(rows, header=("quantity", "value")) -> str:
    def cell(x):
        if isinstance(x, float):
            return f'<td class="num">{x:.4g}</td>'
        return f"<td>{x}</td>"

    body = "".join("<tr>" + "".join(cell(c) for c in r) + "</tr>" for r in rows)
    return "<table><tr>" + "".join(f"<th>{h}</th>" for h in header) + "</tr>" + body + "</table>"


def _constraints_state(c: dict) -> str:
    """How the congruence solve met its inequality constraints, in a few words."""
    ws = c.get("working_set")
    if c.get("constraints_active") and ws:
        n = ", ".join(f"{k} on {v}" for k, v in ws.items())
        return (f"active, imposed where needed ({html.escape(n)} of {c['faces']} faces); "
                "the rest hold with slack")
    return {True: "active (solved with them)", False: "inactive (met without them)"}.get(
        c.get("constraints_active"), "none")


#: what each torsal angle is, for the report's row labels
TORSAL_ANGLE_LABELS = {"planes": "angle at which the torsal planes (the fins) cross",
                       "directions": "angle between the torsal directions in the face"}


def _torsal_angle_rows(c: dict) -> list:
    """The two torsal angles, each labelled with what it is; the one
    ``constraints.min_torsal_angle`` bounds is marked (reports from before both were
    measured have the plane angle only, as ``min_torsal_angle_deg``)."""
    bounded = c.get("torsal_angle_between")
    rows = []
    for between, key in (("planes", "min_torsal_plane_angle_deg"),
                         ("directions", "min_torsal_direction_angle_deg")):
        if key not in c and not (between == "planes" and "min_torsal_angle_deg" in c):
            continue
        v = c.get(key, c.get("min_torsal_angle_deg"))
        mark = " (bounded by min_torsal_angle)" if bounded == between else ""
        rows.append((f"min {TORSAL_ANGLE_LABELS[between]} (deg){mark}",
                     "n/a" if v is None else f"{v:.4g}"))
    return rows


def _convergence_rows(conv: dict | None) -> list:
    """How close to converged the congruence is: why the solve ended (under which stopping
    rule), and the last relative Newton decrement and decrease of the objective where the
    augmented Lagrangian answered (reports from before the key have no row)."""
    if not conv:
        return []
    rows = [("solve ended by (stopping rule)", f"{html.escape(conv['reason'])} ({html.escape(conv['stop'])})")]
    for key, label in (("newton_decrement", "last Newton decrement (relative)"),
                       ("recent_decrease", "objective decrease over the last Newton steps (relative)")):
        if conv.get(key) is not None:
            rows.append((label, f"{conv[key]:.2g}"))
    return rows


def _measured_constraint_rows(c: dict) -> list:
    """One row per constraint as measured on the optimized congruence (issue 16): bound,
    measured worst value, and the faces that miss the bound beyond its tolerance; a torsal
    angle says which angle it is."""
    rows = []
    for name, m in (c.get("constraints") or {}).items():
        unit = " deg" if m["unit"] == "deg" else ""
        ok = m["n_missing"] == 0
        worst = "n/a" if m["measured"] is None else f"{m['measured']:.4g}{unit}"
        state = "holds" if ok else f"missed on {m['n_missing']} elements (e.g. {m['elements_missing'][:5]})"
        what = f"; {TORSAL_ANGLE_LABELS[m['angle']]}" if m.get("angle") in TORSAL_ANGLE_LABELS else ""
        rows.append((f"{html.escape(name)} (measured{what}; bound {m['bound']:g}{unit})",
                     f'<span class="{"ok" if ok else "bad"}">{html.escape(worst)}: {html.escape(state)}</span>'))
    return rows


def _family_rows(families: dict | None) -> list:
    """The two torsal families side by side: spacing, depth, strips, fins, fin area."""
    if not families:
        return []
    f = families
    return [("family 0 / family 1: spacing, depth (model units)",
             f"{f['spacing'][0]:g}, {f['depth'][0]:g} / {f['spacing'][1]:g}, {f['depth'][1]:g}"),
            ("family 0 / family 1: strips, fins, fin area (m&sup2;)",
             f"{f['strips'][0]}, {f['fins'][0]}, {f['fin_area_m2'][0]:.1f} / "
             f"{f['strips'][1]}, {f['fins'][1]}, {f['fin_area_m2'][1]:.1f}")]


def _gate_rows(gate: dict | None, what: str, count_key: str) -> list:
    """Table rows of a joinery quality gate (see :mod:`torsal.pipeline.assembly`)."""
    if not gate:
        return []
    label = what.format(**gate)
    if not gate[count_key]:
        return [(label, '<span class="ok">none</span>')]
    return [(label, f'<span class="bad">{gate[count_key]}</span>: {html.escape(gate["message"])}')]


def _left_out_cell(fa: dict) -> str:
    """The fin panels the fabrication left out, named (the light section measures without
    them)."""
    n = fa.get("panels_left_out", 0)
    if not n:
        return "0"
    named = "; ".join(html.escape(f"{d['strip']} edge {d['edge']}"
                                  + (f" at node {d['node']}" if d["node"] is not None else "")
                                  + f": {d['reason']}")
                      for d in fa.get("panels_left_out_list", [])[:12])
    more = " ..." if n > 12 else ""
    return (f'<span class="bad">{n}</span> (not built, not counted in the light measurement): '
            f"{named}{more}")


def _held_rows(fa: dict) -> list:
    """The row of the plates the builder bolted to the plate they hung on because the load
    path found them loose (``fabrication.held_by_builder``); none where it bolted none."""
    held = fa.get("held_by_builder") or {}
    if not held.get("crossings"):
        return []
    named = "; ".join(html.escape(f"{h['part']} to {h['holder']} at node {h['node']}"
                                  + f" ({h['dip_deg']:.0f} deg): " + ", ".join(
                                      [f"tab {n}" for n in h["tabs"]]
                                      + [f"bracket {c}" for c in h["brackets"]]))
                      for h in held.get("list", [])[:12])
    return [("plates bolted where their slot would let them slide out",
             f"{held['crossings']} crossings butted and bolted (no fixing fitted): {named}")]


def _fastener_rows(fa: dict) -> list:
    """Rows of the connectors, fixings and fasteners a workshop counts (see
    :func:`torsal.pipeline.fins.fabrication_summary`)."""
    if "connectors" not in fa:
        return []
    share = fa.get("panels_left_out_share")
    rows = [("plates / connectors / fixings",
             f"{fa['plates']} / {fa['connectors']} / {fa['fixings']}"),
            ("connector share (separate connectors of all parts)",
             f"{100 * fa['connector_share']:.0f}%"),
            ("fasteners", f"{fa['bolts']} bolts, {fa['anchors']} anchors into the building")]
    for kind, c in fa.get("fasteners_by_joint", {}).items():
        rows.append((f"&nbsp;&nbsp;{html.escape(kind)}",
                     f"{c['connectors']} parts, {c['bolts']} bolts, {c['anchors']} anchors"
                     + (f", {c['without_holes']} without room for a hole" if c["without_holes"] else "")
                     + (f" ({html.escape(c['fastener'])})" if c["fastener"] else "")))
    if share is not None:
        rows.append(("share of fin panels left out", f"{100 * share:.1f}%"))
    return rows


def _quantities_html(q: dict | None, costs: dict | None) -> str:
    """The bill of quantities (:mod:`torsal.fabrication.quantities`) and, with the design
    file's ``[costs]`` rates, the price line by line; without rates it says there is none."""
    if not q:
        return ""
    gross = "-" if q["gross_kg"] is None else (
        f"{q['gross_kg']:.4g} kg ({q['sheets']} sheet(s), {q['gross_m2']:.4g} m&sup2;)")
    fasteners = ", ".join(f"{n} {html.escape(size)} {html.escape(kind)}"
                          for kind, sizes in q["fasteners"].items() for size, n in sizes.items())
    a = q["assembly"]
    rows = [("net material", f"{q['net_kg']:.4g} kg ({q['net_m2']:.4g} m&sup2; of parts)"),
            ("gross material (the sheets used)", gross),
            (f"cut length ({html.escape(str(q['process']))})", f"{q['cut_m']:.4g} m"),
            ("pierces (closed contours cut)", f"{q['pierces']} ({q['holes_cut']} of them holes)"),
            ("holes drilled", q["holes_drilled"]),
            ("bends", f"{q['bends']} ({q['bend_m']:.4g} m)"),
            ("fasteners", fasteners or "none"),
            ("assembly steps", f"{a['parts_placed']} parts placed, {a['fasteners_set']} fasteners "
                               f"set, {a['holes_drilled']} holes drilled")]
    out = "<h3>Bill of quantities</h3>" + _table(rows)
    if costs is None:
        return out + "<p>No price: the design file has no <code>[costs]</code> rates.</p>"
    cur = html.escape(costs.get("currency") or "")
    lines = [(html.escape(name), f"{ln['quantity']:.4g} {html.escape(ln['unit'])}",
              f"{ln['rate']:.4g} {cur}/{html.escape(ln['unit'])}", f"{ln['amount']:.2f}")
             for name, ln in costs["lines"].items()]
    per_m2 = "" if costs["per_m2"] is None else (
        f" ({costs['per_m2']:.2f} {cur}/m&sup2; of {costs['surface_m2']:.4g} m&sup2; of surface)")
    lines.append(("<b>total</b>", "", "", f"<b>{costs['total']:.2f} {cur}</b>{per_m2}"))
    return out + "<h3>Price at the design file's rates</h3>" + _table(
        lines, header=("line", "quantity", "rate", "amount"))


def _assembly_html(a: dict, max_steps: int = 300) -> str:
    """Section 5: the assembly check (verdict, numbers, picture) and the assembly sequence."""
    verdict = ('<span class="ok">buildable</span>' if a["buildable"] else
               '<span class="bad">NOT BUILDABLE</span>')
    inter = "; ".join(f"{html.escape(x['parts'][0])} / {html.escape(x['parts'][1])} "
                      f"({x['volume_mm3']:.3g} mm&sup3;)" for x in a.get("interfering", [])[:30])
    rows = [("verdict", verdict), ("touching pairs checked (exact boolean)", a["pairs_checked"]),
            ("interfering pairs (common volume &gt; 1 mm&sup3;)", a["interfering_pairs"]),
            ("worst overlap (mm&sup3;)", float(a["worst_overlap_mm3"])),
            ("parts that cannot be inserted", ", ".join(map(html.escape, a.get("blocked_parts", [])))
             or "none"),
            ("joints", ", ".join(f"{k}: {v}" for k, v in a["joints"].items()) or "none"),
            ("connectors", ", ".join(f"{k}: {v}" for k, v in a["connectors"].items()) or "none")]
    if inter:
        rows.append(("interfering parts", inter + (" ..." if len(a["interfering"]) > 30 else "")))
    rows += _load_path_rows(a.get("load_path"))
    out = ["<h2>5. Assembly check</h2>", _table(rows)]
    if a.get("picture"):
        out.append(f'<img src="{a["picture"]}" alt="parts, interfering ones in red">')
    seq = a.get("sequence", [])
    if seq:
        def direction(d, part=""):
            if d is None:      # a fixing (A-E...) is fixed to the building first
                return "fixed to the building" if part.startswith("A-") else "set in place"
            return "(" + ", ".join(f"{x:+.2f}" for x in d) + ")"

        srows = [(st["step"], html.escape(st["part"]), direction(st["insert_direction"], st["part"]),
                  html.escape(" ".join(st["joints"])), html.escape(" ".join(st["partners"])),
                  '<span class="ok">clear</span>' if st["clear"] else '<span class="bad">collides</span>')
                 for st in seq[:max_steps]]
        csv = a.get("csv", "assembly.csv")
        out.append(f'<h3>Assembly sequence ({len(seq)} steps, <a href="{csv}">{csv}</a>)</h3>'
                   + _table(srows, ("step", "part", "insert along", "joints", "joins", "path")))
        if len(seq) > max_steps:
            out.append(f"<p>... {len(seq) - max_steps} more steps in {csv}</p>")
    return "\n".join(out)


def _load_path_rows(lp: dict | None) -> list[tuple]:
    """The assembly table's rows of the load path (:mod:`torsal.fabrication.assembly.load_path`):
    whether every part reaches the building through joints that hold it, and which do not."""
    if lp is None or not lp.get("checked"):
        return [("held to the building", "not checked")]
    verdict = ('<span class="ok">every part</span>' if lp["supported"] else
               f'<span class="bad">{lp["unsupported"]} of {lp["parts"]} parts not held</span>')
    edges = ", ".join(f"{k}: {v}" for k, v in lp["edges"].items()) or "none"
    loose = len(lp["groups"])
    rows = [("held to the building (load path)", f"{verdict}; {lp['components']} connected "
             f"groups ({loose} not reaching the building); holding joints {edges}")]
    if lp["unsupported_parts"]:
        names = lp["unsupported_parts"]
        rows.append(("parts not held to the building", ", ".join(map(html.escape, names[:60]))
                     + (" ..." if len(names) > 60 else "") + "<br>" + html.escape(lp["message"])))
    if lp["slot_held"]:
        rows.append(("held by slots only (no fastener of their own)",
                     f"{lp['slot_held']} parts: their weight keeps them in their slots; a bolt "
                     "or clip at one crossing keeps wind from drawing them out"))
    if lp.get("welded"):
        rows.append(("welded (no room for a bolt)", f"{len(lp['welded'])} legs of connectors "
                     "and fixings on their plates: " + ", ".join(
                         html.escape(f"{c} / {p}") for c, p in lp["welded"][:20])
                     + (" ..." if len(lp["welded"]) > 20 else "")))
    if lp.get("site_fastened"):
        rows.append(("fastened on site (no room for a bracket)", f"{len(lp['site_fastened'])}: "
                     + ", ".join(f"{html.escape(' / '.join(j['parts']))} at node {j['node']}"
                                 for j in lp["site_fastened"][:20])))
    if lp["unfastened_joints"]:
        rows.append(("joints without a fastener", f"{len(lp['unfastened_joints'])}: " + ", ".join(
            f"{html.escape(j['kind'])} at node {j['node']}" for j in lp["unfastened_joints"][:20])))
    return rows


def _area(a) -> str:
    """A fin area cell (m^2), a dash where a report (of an older run) has none."""
    return f"{a:.1f}" if a is not None else "&ndash;"


def _pct(x) -> str:
    return '<td class="num">-</td>' if x is None else f'<td class="num">{100 * x:.1f}%</td>'


def _device_note(d: dict) -> str:
    o = d.get("orientation")
    if o:
        return (f"planes optimized for the sun: rotation {o['rotation_deg']:.1f}&deg;, tilt "
                f"{o['tilt_deg']:.1f}&deg; ({o['evaluations']} orientations tried)")
    return ""


def _light_html(li: dict, view: dict | None = None) -> str:
    """Section 3's comparison: the fins as built and every standard device of the same depth
    and spacing, measured with the same rays; devices that cannot be made on the surface are
    named with the reason, never shown as 0 %."""
    built = (f"torsal fins as built ({li['fins_measured']} fins)" if "fins_measured" in li
             else "torsal fins")
    # the design lets the sun through somewhere, or blocks another sun in some regions
    asked = "let_through" in li or "sun_regions" in li
    head = ("<tr><th>design</th><th>direct sun blocked</th>"
            + ("<th>sun as asked (goals.let_through, goals.sun_regions)</th>" if asked else "")
            + "<th>view out (occupants)</th><th>view clear along normal</th>"
            "<th>over 60&deg; cone</th><th>fin area (m&sup2;)</th><th>note</th></tr>")

    def row(name, m, note=""):
        return (f"<tr><td>{html.escape(name)}</td>{_pct(m['blocked_share'])}"
                + (_pct(m.get("goal_share")) if asked else "")
                + f"{_pct(m.get('view_out'))}{_pct(m['transparency'])}{_pct(m['transparency_cone'])}"
                f'<td class="num">{_area(m.get("fin_area_m2"))}</td><td>{note}</td></tr>')

    rows = [row(built, li)]
    for name, d in li.get("devices", {}).items():
        if d["applicable"]:
            rows.append(row(f"{name}, same depth and spacing", d, _device_note(d)))
        else:
            rows.append(f"<tr><td>{html.escape(name)}</td><td colspan=\"{6 + asked}\">not applicable: "
                        f"{html.escape(d['reason'])}</td></tr>")
    detail = li.get("view_out_detail") or {}
    levels = detail.get("en17037") or {}
    measure = ("view out from occupant eye points" if li.get("view_measure", "occupant") ==
               "occupant" else "view along the normal")
    where = ""
    if view:
        where = (f" ({', '.join(f'{d:g}' for d in view['distances_m'])} m behind the surface, "
                 f"every {view['grid_m']:g} m across it, {view['eye_height_m']:g} m above each "
                 f"storey's floor on a facade; sight lines &plusmn;{view['azimuth_deg']:g}&deg; "
                 f"about the view axis, {view['elevation_deg'][0]:g} to "
                 f"{view['elevation_deg'][1]:g}&deg; elevation, {view['step_deg']:g}&deg; cells)")
    text = (f"<p>The design's view measure (<code>view.measure</code>) is the {measure}. View out: "
            f"the share of sight lines from {detail.get('eye_points', 0)} occupant eye points"
            f"{where} that pass through the surface and past the fins (after EN 17037's view "
            "out and LEED v4's quality views; definitions and sources in "
            "<code>torsal.light.view</code>)."
            + (f" Eye points reaching EN 17037's clear horizontal sight angle: "
               f"{100 * levels['minimum']:.0f}% at 14&deg;, {100 * levels['medium']:.0f}% at "
               f"28&deg;, {100 * levels['high']:.0f}% at 54&deg;." if levels.get("high")
               is not None else "") + "</p>")
    return f"<table>{head}{''.join(rows)}</table>" + text


def _kwh(x) -> str:
    return '<td class="num">-</td>' if x is None else f'<td class="num">{x:.0f}</td>'


def _factor(x) -> str:
    return '<td class="num">-</td>' if x is None else f'<td class="num">{x:.2f}</td>'


_MONTHS = ("Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct", "Nov", "Dec")


def _annual_html(an: dict) -> str:
    """The annual irradiance on the glazing (``light.annual``): kWh/m&sup2; of the bare
    glazing, the fins as built and each standard device per season, their shading factors,
    the months, and the engine's settings."""
    made = [("torsal fins as built", an["fins"])] + [
        (f"{name}, same depth and spacing", d) for name, d in an["devices"].items()
        if d.get("applicable", True)]
    head = ("<tr><th>glazing</th><th>year (kWh/m&sup2;)</th><th>heating season</th>"
            "<th>cooling season</th><th>cooling gains avoided</th><th>F<sub>sh</sub> cooling"
            "</th><th>F<sub>sh</sub> heating</th><th>F<sub>sh</sub> year</th>"
            "<th>direct sun</th><th>seconds</th></tr>")

    def row(name, m):
        f = m.get("shading_factor") or {}
        return (f"<tr><td>{html.escape(name)}</td>{_kwh(m['annual_kwh_m2'])}"
                f"{_kwh(m['heating_kwh_m2'])}{_kwh(m['cooling_kwh_m2'])}"
                f"{_kwh(f.get('cooling_gains_avoided_kwh_m2'))}{_factor(f.get('f_sh_cooling'))}"
                f"{_factor(f.get('f_sh_heating'))}{_factor(f.get('f_sh_year'))}"
                f"{_kwh(m['by_source_kwh_m2']['sun'])}{_kwh(m.get('seconds'))}</tr>")

    rows = [row("bare", an["bare"])] + [row(n, m) for n, m in made]
    rows += [f"<tr><td>{html.escape(n)}</td><td colspan=\"9\">not applicable: "
             f"{html.escape(d['reason'])}</td></tr>"
             for n, d in an["devices"].items() if not d.get("applicable", True)]
    months = ("<tr><th>kWh/m&sup2;</th>" + "".join(f"<th>{m}</th>" for m in _MONTHS) + "</tr>"
              + "".join(f"<tr><td>{html.escape(n)}</td>"
                        + "".join(_kwh(x) for x in m["monthly_kwh_m2"]) + "</tr>"
                        for n, m in [("bare", an["bare"])] + made))
    w, se = an["weather"], an["seasons"]
    text = (f"<p>Solar irradiation on the glazing over the year (sun, sky, ground and what the "
            f"fins reflect), the mean of {an['points']} points on the surface. Weather: "
            f"{html.escape(w['description'])} ({w['hours']} hours). Seasons: "
            f"{html.escape(se['description'])}. Engine: {html.escape(an['engine'])}, "
            f"{an['ambient_bounces']} ambient bounces (-ab), {an['ambient_divisions']} "
            f"divisions (-ad), sky {an['sky']} ({an['sky_patches']} patches) and "
            f"{html.escape(an['sun'])}; fin reflectance {an['fin_reflectance']:g}, ground "
            f"{an['ground_reflectance']:g}. F<sub>sh</sub>: "
            f"{html.escape(an['fins']['shading_factor']['standard'])}.</p>")
    figures = "".join(f'<img src="{name}" alt="{html.escape(what)}">' for what, name in
                      (an.get("figures") or {}).items())
    return (f"<h3>Annual irradiance on the glazing ({an['seconds']:.0f} s)</h3>"
            f"<table>{head}{''.join(rows)}</table><table>{months}</table>" + text + figures
            + _daylight_html(an.get("daylight"), [n for n, _ in made]))


def _daylight_html(dl: dict | None, names: list) -> str:
    """sDA and ASE of the rooms behind the facade (``light.annual.daylight``), per storey."""
    if not dl:
        return ""
    if not dl["applicable"]:
        return f"<h3>Daylight</h3><p>Not applicable: {html.escape(dl['reason'])}</p>"
    keys = ["bare", "fins", *(n.removesuffix(", same depth and spacing") for n in names[1:])]
    head = ("<tr><th>glazing</th><th>sDA<sub>300/50%</sub> (LM-83, its blinds)</th>"
            "<th>sDA without blinds</th><th>ASE<sub>1000/250</sub></th>"
            + "".join(f"<th>storey at {z:.1f}: sDA / ASE</th>" for z in dl["storeys"]) + "</tr>")

    def cells(d):
        return (f"{_pct(d['sda_all'])}{_pct(d.get('sda_unshaded_all'))}{_pct(d['ase_all'])}"
                + "".join(f'<td class="num">{100 * a:.0f}% / {100 * b:.0f}%</td>'
                          for a, b in zip(d["sda"], d["ase"])))

    rows = "".join(f"<tr><td>{html.escape(k)}</td>{cells(dl[k])}</tr>" for k in keys if k in dl)
    lo, hi = dl["occupied_hours"]
    return (f"<h3>Daylight in the rooms behind the facade</h3><table>{head}{rows}</table>"
            f"<p>{html.escape(dl['standard'])}; occupied {lo:g}:00 to {hi:g}:00, work plane "
            f"{dl['work_plane_m']:g} m, points every {dl['grid_m']:g} m at most, "
            f"{dl['ambient_bounces']} ambient bounces, {dl.get('ambient_divisions', '-')} "
            "divisions.</p>")


#: lines within this many degrees of their mean direction are called nearly parallel in the
#: report (examples 7a and 7b end within 0.2 degrees, 7d within 1.75, 11's fins within 7)
NEARLY_PARALLEL_DEG = 1.0


def _spread_rows(c: dict) -> list:
    """The lines' spread (``line_spread_deg``; the substructure's too), said plainly where the
    optimized lines are nearly parallel."""
    rows = []
    for key, what in (("line_spread_deg", "lines"), ("substructure_line_spread_deg", "substructure lines")):
        v = c.get(key)
        if v is None:
            continue
        note = (" (nearly parallel: every fin contains nearly the same direction, as the louvers and "
                "egg-crates of section 3 do)" if v < NEARLY_PARALLEL_DEG else "")
        rows.append((f"widest angle of the {what} from their mean direction (deg)", f"{v:.2f}{note}"))
    return rows


def design_report_html(report: dict, images: dict, title: str, *, view3d: str | None = None) -> str:
    """The HTML report: tables of every figure in ``report`` and the PNGs next to it, and the
    interactive 3D view ``view3d`` (an HTML fragment, see :mod:`torsal.pipeline.report_3d`) if given."""
    c, s, li, fa = (report.get(k, {}) for k in ("congruence", "support", "light", "fabrication"))
    secs = []
    if c:
        rows = [("vertices / faces", f"{c['vertices']} / {c['faces']}"),
                ("solver status", html.escape(str(c["status"]))),
                ("build / solve time (s)", f"{c['build_s']:.2f} / {c['solve_s']:.2f}"),
                ("min hyperbolicity c_hyp (>= 0 needed)", c["min_hyperbolicity"]),
                ("inequality constraints", _constraints_state(c)),
                *_convergence_rows(c.get("convergence")),
                *_torsal_angle_rows(c),
                *_spread_rows(c)]
        rows += _measured_constraint_rows(c)
        rows += [(f"energy {k} (before &rarr; after)",
                  f"{c['energies_before'].get(k, float('nan')):.4g} &rarr; {v:.4g}")
                 for k, v in c["energies"].items()]
        rows += _gate_rows(c.get("joinery"), "torsal planes crossing at less than "
                           "{min_crossing_angle_deg:g}&deg; (joinery limit)", "faces_below")
        secs.append("<h2>1. Optimized line congruence (paper 4.1)</h2>" + _table(rows))
        if "torsal_field" in images:
            secs.append(f'<img src="{images["torsal_field"]}" alt="torsal direction fields">')
    if s:
        ok = s["delta_pl_optimized"] <= 1e-4
        rows = [("faces of A~ (quads)", f"{s['faces']} ({s['quads']})"), ("fins (edges)", s["edges"]),
                ("delta_pl after extraction", s["delta_pl_extracted"]),
                ("delta_pl after optimization",
                 f'<span class="{"ok" if ok else "bad"}">{s["delta_pl_optimized"]:.2e}</span>'),
                ("support optimization (s)", s["solve_s"]), ("status", html.escape(s["status"]))]
        rows += _family_rows(s.get("families"))
        rows += _gate_rows(s.get("joinery"), "crossings where a strip folds more than "
                           "{max_fold_at_crossing_deg:g}&deg;", "nodes_above")
        secs.append("<h2>2. Torsion-free support structure (paper 4.2, eq. 8)</h2>" + _table(rows))
        if "fins" in images:
            secs.append(f'<img src="{images["fins"]}" alt="fins coloured by planarity">')
    if view3d:
        secs.append("<h2>The design in 3D</h2><p>Drag to rotate, scroll to zoom, click a legend "
                    "entry to hide or show it. Sun rays come in from the sky towards the surface; "
                    "the heavier directions are drawn thicker.</p>" + view3d)
    if li:
        secs.append(f"<h2>3. Light ({li['sun_directions']} sun directions)</h2>" + _light_html(li, report.get("design", {}).get("view")))
        if "blocked_sun" in images:
            secs.append(f'<img src="{images["blocked_sun"]}" alt="blocked sun map">')
        if li.get("annual"):
            secs.append(_annual_html(li["annual"]))
    if li.get("reflection"):
        secs.append(_reflection_html(li["reflection"]))
        if "ceiling_light" in images:
            secs.append(f'<img src="{images["ceiling_light"]}" alt="reflected light on the ceiling">')
    if fa:
        dxf = fa.get("dxf") or []
        rows = [("parts", fa["parts"]), ("panels", fa["panels"]), ("sheets", fa["sheets"]),
                ("sheet utilization", fa["utilization"]),
                *_nesting_rows(fa.get("nesting"), fa.get("cutting")),
                ("fin panels left out", _left_out_cell(fa)), *_held_rows(fa)] + _fastener_rows(fa) + [
                ("STEP", f'<a href="{fa["step"]}">{fa["step"]}</a>' if fa.get("step") else "-"),
                ("DXF", ", ".join(f'<a href="{p}">{p}</a>' for p in dxf) or "-")]
        secs.append("<h2>4. Fabrication</h2>" + _table(rows))
        secs.append(_quantities_html(fa.get("quantities"), fa.get("costs")))
        if "sheets" in images:
            secs.append(f'<img src="{images["sheets"]}" alt="nested cutting sheets">')
        if fa.get("assembly"):
            secs.append(_assembly_html(fa["assembly"]))
    return _HTML.format(title=html.escape(title), units=html.escape(str(report.get("units", ""))),
                        sections="\n".join(secs))


def _split_cell(sp: dict) -> str:
    """The final cut's plates split for yield (``fabrication.nesting.split``): which, where
    and what it saved, or why none."""
    if not sp.get("kept"):
        return "none: " + html.escape(sp.get("why") or "")
    d = sp.get("delta", {})
    price = (f", price {d['price']:+,.2f} {html.escape(sp.get('currency') or '')}".rstrip()
             if d.get("price") is not None else "")
    plates = "; ".join(f"{html.escape(p['plate'])} at node{'s' if len(p['nodes']) > 1 else ''} "
                       + ", ".join(str(v) for v in p["nodes"])
                       + f" -> {', '.join(html.escape(n) for n in p['pieces'])}"
                       for p in sp.get("plates", [])[:12])
    more = len(sp.get("plates", [])) - 12
    return (f"{sp['plates_split']} plates cut {sp['cuts']} times at crossing slots "
            f"({sp['seams_in_slot']} seams held in their slots, {len(sp.get('fallbacks', []))} "
            f"fell back to brackets): {sp['sheets_before']} &rarr; {sp['sheets_after']} sheets "
            f"({100 * sp['utilization_before']:.1f}% &rarr; {100 * sp['utilization_after']:.1f}%); "
            f"the bill: cut {d.get('cut_m', 0):+.1f} m, pierces {d.get('pierces', 0):+d}, "
            f"bends {d.get('bends', 0):+d}, parts {d.get('parts', 0):+d}, connectors "
            f"{d.get('connectors', 0):+d}, fixings {d.get('fixings', 0):+d}{price}. "
            + plates + (f"; and {more} more" if more > 0 else ""))


def _nesting_rows(nest: dict | None, cut: dict | None) -> list[tuple[str, str]]:
    """Report rows of the nesting (sheets against the area bound, utilization read back from
    the DXF, time) and the cutting process."""
    rows = []
    if nest:
        dxf = nest.get("utilization_dxf")
        rows += [("sheets / area bound (parts' area / sheet area)",
                  f"{nest['sheets']} / {nest['area_bound_sheets']:.1f}"),
                 ("utilization, in the DXF files", "-" if dxf is None else f"{100 * dxf:.1f}%"),
                 ("nesting", f"{nest['nester']}, {nest['seconds']:.0f} s"
                  + (f" of {nest['time_limit_s']:g} s, seed {nest['seed']}"
                     if nest.get("time_limit_s") else "")
                  + (f", {nest['tries']} tries" if nest.get("tries") else "")
                  + (f", {nest['fallback_parts']} parts by the fast nester"
                     if nest.get("fallback_parts") else "")),
                 ("the same sheets on every run",
                  "yes: deterministic, the result of its inputs alone"
                  if nest.get("deterministic", False) else
                  "NO: the time limit cut the search, so these sheets depend on the machine's "
                  "load" if nest.get("time_limited") else
                  "NO: sparrow stops on the clock; nest with the rows or the final cut's search "
                  "for sheets that repeat")]
    if nest and nest.get("split"):
        rows.append(("plates split for yield (final cut)", _split_cell(nest["split"])))
    if cut:
        rows.append(("cutting (DXF layer CUT)",
                     f"{cut['process']}, kerf {cut['kerf_mm']:g} mm, tool {cut['tool_diameter_mm']:g} mm, "
                     f"reliefs: {cut['relief']} ({cut['reliefs']})"))
    return rows


def draw_design_pictures(out: Path, spec, congruence, structure, light_map: dict, surface,
                         layout) -> dict:
    """Write the PNG renders of a design run into ``out``: the torsal field, the fins, the
    blocked sun, the sheets (with a ``layout``) and the ceiling light (a reflection goal);
    returns {kind: file name}. The pipeline's ``pictures`` stage draws them while the
    assembly is checked; :func:`write_design_report` draws them when not given."""
    out = Path(out)
    images = {
        "torsal_field": plot_torsal_field(congruence, out / "torsal_field.png",
                                          title=f"{spec.name}: optimized congruence").name,
        "fins": plot_fins(structure, surface, out / "fins.png").name,
        "blocked_sun": plot_blocked_sun(light_map["points"], light_map["per_point"], surface,
                                        out / "blocked_sun.png").name,
    }
    if layout is not None and layout.n_sheets:
        images["sheets"] = plot_sheets(layout, out / "sheets.png").name
    if light_map.get("reflection"):
        images["ceiling_light"] = plot_ceiling_light(light_map["reflection"],
                                                     out / "ceiling_light.png").name
    return images


def write_design_report(out: Path, spec, report: dict, congruence, structure, light_map: dict,
                        surface, layout, *, sun=None, images: dict | None = None) -> dict:
    """Write the PNG renders and ``report.html`` for a design run; returns {kind: file name}.

    ``sun`` (vectors (S, 3) site -> sun, weights (S,)): the design's sun directions, drawn in
    the report's interactive 3D view (without them the view shows the surface and fins only).
    ``images``: the renders :func:`draw_design_pictures` wrote already ({kind: file name} in
    ``out``); None: drawn here.
    """
    out = Path(out)
    if images is None:
        images = draw_design_pictures(out, spec, congruence, structure, light_map, surface,
                                      layout)
    with atomic_path(out / "report.html") as tmp:
        tmp.write_text(design_report_html(report, images, spec.name,
                                          view3d=design_view_html(surface, structure, sun,
                                                                  title=spec.name)))
    return {**images, "report_html": "report.html"}
