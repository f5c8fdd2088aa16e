"""Figures and reports: PNG figures with matplotlib (Agg, no screen needed), JSON summaries."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ._io import atomic_path

__all__ = ["plot_torsal_field", "principal_plane"]


def principal_plane(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centroid and orthonormal axes (3, 3) of a point cloud, largest spread first (PCA).

    The first two axes span the plane a facade or canopy is best seen in.
    """
    p = np.asarray(points, float)
    c = p.mean(axis=0)
    _, _, vt = np.linalg.svd(p - c, full_matrices=False)
    return c, vt


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
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.collections import LineCollection, PolyCollection
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    v, f = congruence.vertices, congruence.faces
    center, axes = principal_plane(v)
    # orient the view so the surface normal points at the viewer
    n_mean = np.nanmean(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=0)
    if n_mean @ axes[2] < 0:
        axes = axes * [[1], [-1], [-1]]
    uv = (v - center) @ axes[:2].T
    tris = uv[f]
    t = congruence.torsal_directions()
    ang = congruence.torsal_angle()
    bc = congruence.barycenters()
    bc2 = (bc - center) @ axes[:2].T
    valid = np.isfinite(t).all(axis=(1, 2))
    delta = congruence.delta

    fig = Figure(figsize=(14, 6.5), dpi=110)
    ax = fig.add_subplot(1, 2, 1)
    pc = PolyCollection(tris, array=np.where(valid, ang, np.nan), cmap="viridis",
                        edgecolors=(0.6, 0.6, 0.6, 0.35), linewidths=0.3)
    pc.set_clim(0, 90)
    ax.add_collection(pc)
    cb = fig.colorbar(pc, ax=ax, shrink=0.8)
    cb.set_label("angle between torsal directions (deg)")
    idx = np.flatnonzero(valid)
    if idx.size > max_segments:
        idx = idx[np.linspace(0, idx.size - 1, max_segments).astype(int)]
    half = 0.35 * delta * max(1.0, np.sqrt(len(f) / max(idx.size, 1)))
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

    ax3 = fig.add_subplot(1, 2, 2, projection="3d")
    ax3.add_collection3d(Poly3DCollection(v[f], facecolor=(0.8, 0.82, 0.86, 0.6),
                                          edgecolor=(0.5, 0.5, 0.5, 0.2), linewidths=0.2))
    step = max(1, len(v) // 600)
    a = v[::step]
    e = congruence.directions[::step]
    e = e / np.linalg.norm(e, axis=1, keepdims=True) * 2 * delta
    ax3.add_collection3d(Line3DCollection(np.stack([a, a + e], axis=1), colors="tab:orange",
                                          linewidths=0.6, label="lines of the congruence"))
    lo, hi = v.min(axis=0), v.max(axis=0)
    mid, rad = (lo + hi) / 2, (hi - lo).max() / 2
    ax3.set_xlim(mid[0] - rad, mid[0] + rad)
    ax3.set_ylim(mid[1] - rad, mid[1] + rad)
    ax3.set_zlim(mid[2] - rad, mid[2] + rad)
    ax3.set_xlabel("x")
    ax3.set_ylabel("y")
    ax3.set_zlabel("z")
    ax3.set_title("mesh A and lines a_i + lambda e_i")
    ax3.legend(loc="upper right", fontsize=8)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    return path
