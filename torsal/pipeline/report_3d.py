"""The design seen in 3D: an interactive, offline view of the fins over the surface and the sun.

One plotly figure for ``report.html``: mesh A (the design surface), the fins of the support
structure (one quad ``a_i a_j b_j b_i`` per edge of A~, paper eq. 8) as one merged mesh per
torsal family, and the sun directions the design was optimized for (paper 4.1, 4.3) as rays
coming in towards the surface, the heavier ones drawn thicker. plotly.js is inlined once, so
the page needs no network; the user can rotate, zoom, hover and switch layers on and off.

Size: plotly.js is about 4.8 MB; the geometry is sent as float32 binary arrays (12 bytes a
node and a corner, 12 bytes a triangle), so a full-size design with ~2000 fins adds well
under 1 MB. Past ``max_fins`` fins are subsampled evenly and the view says so.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.mesh import area_vector

__all__ = ["SunRays", "representative_sun", "design_view_figure", "design_view_html",
           "FAMILY_COLOURS", "SUN_COLOUR"]

#: Fin colours of torsal family 0 and 1 (colour-blind safe pair).
FAMILY_COLOURS = ("#d95f02", "#1b9e77")
_SURFACE_COLOUR = "#b8bec8"
#: Colour of the sun rays.
SUN_COLOUR = "#e6a700"


@dataclass(frozen=True)
class SunRays:
    """A few representative sun directions standing for many (what the 3D view draws).

    Attributes
    ----------
    directions : (k, 3) float
        Unit vectors site -> sun, model frame, heaviest first.
    weights : (k,) float
        Share of the total sun weight each ray stands for; sums to ``coverage``.
    counts : (k,) int
        How many of the input directions each ray stands for.
    total : int
        Number of input directions.
    coverage : float
        Share of the total weight the k rays stand for (1.0 unless rays were dropped).
    """

    directions: np.ndarray
    weights: np.ndarray
    counts: np.ndarray
    total: int
    coverage: float

    @property
    def elevation_deg(self) -> np.ndarray:
        """Elevation above the model's xy plane, (k,) degrees."""
        return np.degrees(np.arcsin(np.clip(self.directions[:, 2], -1, 1)))

    @property
    def bearing_deg(self) -> np.ndarray:
        """Angle from +y towards +x in the xy plane (the azimuth when north is +y), (k,) degrees."""
        d = self.directions
        return np.degrees(np.arctan2(d[:, 0], d[:, 1])) % 360.0


def representative_sun(vectors, weights=None, *, max_rays: int = 24,
                       cell_deg: float = 10.0) -> SunRays:
    """Group sun directions into sky cells of ``cell_deg`` (elevation x bearing) and keep the
    ``max_rays`` heaviest cells, each as its weighted mean direction.

    Parameters
    ----------
    vectors : (S, 3) float
        Site -> sun directions (need not be unit length).
    weights : (S,) float, optional
        Non-negative weights (e.g. direct normal irradiance); 1 each by default.
    max_rays : int
        At most this many rays.
    cell_deg : float
        Size of a sky cell in degrees. Directions within one cell are drawn as one ray.

    Examples
    --------
    >>> r = representative_sun([[1, 0, 0], [0, 1, 0.5], [0.01, 1, 0.5]], [3, 1, 1])
    >>> r.counts.tolist(), r.weights.round(2).tolist()
    ([1, 2], [0.6, 0.4])
    """
    v = np.asarray(vectors, float).reshape(-1, 3)
    v = v / np.linalg.norm(v, axis=1, keepdims=True)
    w = np.ones(len(v)) if weights is None else np.asarray(weights, float).ravel()
    if w.shape != (len(v),):
        raise ValueError(f"weights must have shape ({len(v)},), got {w.shape}")
    if len(v) == 0 or not np.isfinite(v).all() or w.sum() <= 0:
        raise ValueError("need at least one finite sun direction with a positive weight")
    elev = np.minimum(np.degrees(np.arcsin(np.clip(v[:, 2], -1, 1))), 90 - 1e-9)  # zenith: top cell
    bearing = np.degrees(np.arctan2(v[:, 0], v[:, 1])) % 360.0
    cell = np.floor(elev / cell_deg).astype(int) * 1000 + np.floor(bearing / cell_deg).astype(int)
    keys, inv = np.unique(cell, return_inverse=True)
    wsum = np.bincount(inv, weights=w, minlength=len(keys))
    mean = np.stack([np.bincount(inv, weights=w * v[:, k], minlength=len(keys)) for k in range(3)], 1)
    count = np.bincount(inv, minlength=len(keys))
    keep = np.argsort(-wsum, kind="stable")[:max_rays]
    keep = keep[wsum[keep] > 0]
    mean = mean[keep] / np.linalg.norm(mean[keep], axis=1, keepdims=True)
    share = wsum[keep] / w.sum()
    return SunRays(mean, share, count[keep], len(v), float(share.sum()))


def _plural(n: int, word: str) -> str:
    return f"{n} {word}{'' if n == 1 else 's'}"


def _fin_triangles(structure, max_fins: int):
    """Nodes (a, then the b ends: (2n, 3), or (3n, 3) where the families end at their own
    depths) and per family the triangles (2 per fin) of the fins to draw."""
    edges, fam = structure.edges, structure.edge_family
    shown = np.arange(len(edges))
    if len(edges) > max_fins:  # evenly subsample: keeps the spread of the structure visible
        shown = np.unique(np.linspace(0, len(edges) - 1, max_fins).astype(int))
    n = len(structure.vertices_a)
    # each family's fins end at its own depth (family_depth_ratio): nodes a, then b of each
    two = structure.family_depth_ratio[0] != structure.family_depth_ratio[1]
    nodes = np.concatenate([structure.vertices_a, structure.family_vertices_b(0)]
                           + ([structure.family_vertices_b(1)] if two else []))
    out = {}
    for family in (0, 1):
        i, j = edges[shown[fam[shown] == family]].T
        k = n * (1 + family) if two else n
        tri = np.empty((2 * len(i), 3), np.int64)
        tri[0::2] = np.c_[i, j, j + k]
        tri[1::2] = np.c_[i, j + k, i + k]
        out[family] = tri
    return nodes, out, len(shown)


def _mesh_trace(vertices, triangles, *, name: str, colour: str, **kw):
    import plotly.graph_objects as go

    v = np.asarray(vertices, np.float32)
    t = np.asarray(triangles, np.int32)
    return go.Mesh3d(x=v[:, 0], y=v[:, 1], z=v[:, 2], i=t[:, 0], j=t[:, 1], k=t[:, 2], name=name,
                     color=colour, flatshading=True, showlegend=True, hoverinfo="name", **kw)


def _sun_traces(rays: SunRays, anchor: np.ndarray, length: float) -> list:
    """Rays from the sky towards ``anchor`` (stopping short of it, so that the fins stay
    visible): thick for the directions that make up the first half of the weight, thin for the
    rest, each with an arrowhead (cone) along the light, scaled by its weight."""
    import plotly.graph_objects as go

    order_w = np.cumsum(rays.weights) - rays.weights  # weight of the heavier rays before each
    heavy = order_w < 0.5 * rays.coverage
    text = [f"sun: elevation {e:.0f}&deg;, bearing from +y {b:.0f}&deg;<br>"
            f"{100 * s:.1f}% of the sun weight ({c} of {rays.total} directions)"
            for e, b, s, c in zip(rays.elevation_deg, rays.bearing_deg, rays.weights, rays.counts)]
    traces = []
    for sel, width, opacity, label in ((heavy, 7, 1.0, "sun: heaviest directions (half the weight)"),
                                       (~heavy, 2.5, 0.6, "sun: other directions")):
        if not sel.any():
            continue
        far = anchor + length * rays.directions[sel]
        near = anchor + 0.25 * length * rays.directions[sel]
        pts = np.full((3 * sel.sum(), 3), np.nan)
        pts[0::3], pts[1::3] = far, near
        hover = np.repeat(np.array(text, dtype=object)[sel], 3)
        traces.append(go.Scatter3d(x=pts[:, 0], y=pts[:, 1], z=pts[:, 2], mode="lines", name=label,
                                   line=dict(color=SUN_COLOUR, width=width), opacity=opacity,
                                   text=hover, hovertemplate="%{text}<extra></extra>",
                                   connectgaps=False))
    heads = anchor + 0.6 * length * rays.directions
    size = rays.weights / rays.weights.max()
    light = -rays.directions * size[:, None]
    traces.append(go.Cone(x=heads[:, 0], y=heads[:, 1], z=heads[:, 2], u=light[:, 0], v=light[:, 1],
                          w=light[:, 2], anchor="center", sizemode="absolute", sizeref=0.15 * length,
                          colorscale=[[0, SUN_COLOUR], [1, SUN_COLOUR]], showscale=False,
                          name="sun: light direction (size = weight)", showlegend=True,
                          text=text, hovertemplate="%{text}<extra></extra>"))
    return traces


def _camera_eye(look, *, distance: float = 1.9, turn_deg: float = 25.0,
                elevation_deg: tuple[float, float] = (15.0, 50.0)) -> np.ndarray:
    """Camera position (plotly scene units, (3,)) on the side ``look`` (3,) points to, turned
    about z by ``turn_deg`` and with its elevation kept in ``elevation_deg``: a facade seen
    exactly head-on or a roof seen from straight above would hide the depth of the fins."""
    look = np.asarray(look, float)
    horizontal = float(np.hypot(look[0], look[1]))
    bearing = np.arctan2(look[1], look[0]) if horizontal > 1e-9 else -np.pi / 2  # else from -y
    elev = np.radians(np.clip(np.degrees(np.arctan2(look[2], horizontal)), *elevation_deg))
    bearing += np.radians(turn_deg)
    return distance * np.array([np.cos(elev) * np.cos(bearing), np.cos(elev) * np.sin(bearing),
                                np.sin(elev)])


def design_view_figure(surface, structure, sun=None, *, title: str = "", max_fins: int = 20000,
                       max_rays: int = 24):
    """The plotly figure of a design: mesh A, the fins by torsal family, the sun rays.

    Parameters
    ----------
    surface : (vertices (V, 3), faces (F, 3))
        Mesh A, model units.
    structure : torsal.geometry.SupportStructure
        Its ``vertices_a``, ``vertices_b``, ``edges`` and ``edge_family`` give the fins.
    sun : (vectors (S, 3), weights (S,)) or SunRays, optional
        Site -> sun directions of the design; drawn as up to ``max_rays`` representative rays
        (see :func:`representative_sun`). Without it the view has no sun.
    max_fins : int
        Fins beyond this many are subsampled evenly (the legend says how many are shown).

    Returns
    -------
    plotly.graph_objects.Figure

    Examples
    --------
    >>> fig = design_view_figure((v, f), structure, (sun_vectors, sun_weights))  # doctest: +SKIP
    >>> fig.show()  # doctest: +SKIP
    """
    import plotly.graph_objects as go

    v, f = (np.asarray(x) for x in surface)
    nodes, tris, n_shown = _fin_triangles(structure, max_fins)
    n_fins = len(structure.edges)
    shown = "" if n_shown == n_fins else f", {n_shown} of {n_fins} shown"
    traces = [_mesh_trace(v, f, name="design surface A", colour=_SURFACE_COLOUR, opacity=1.0,
                          lighting=dict(ambient=0.75, diffuse=0.35, specular=0.0))]
    for family in (0, 1):
        k = int((structure.edge_family == family).sum())
        if len(tris[family]):
            traces.append(_mesh_trace(nodes, tris[family], colour=FAMILY_COLOURS[family],
                                      name=f"fins, torsal family {family} ({k}{shown})",
                                      lighting=dict(ambient=0.7, diffuse=0.45, specular=0.1)))
    pts = np.concatenate([v, structure.vertices_b])
    extent = float(np.ptp(pts, axis=0).max())
    normal = area_vector(v, f)
    normal = normal / max(np.linalg.norm(normal), 1e-300)
    rays = None
    if sun is not None:
        rays = sun if isinstance(sun, SunRays) else representative_sun(*sun, max_rays=max_rays)
        depth = float(np.linalg.norm(structure.directions, axis=1).max(initial=0.0))
        traces += _sun_traces(rays, v.mean(axis=0) + depth * normal, 0.6 * extent)
    # seen from the sun side (where the fins stand); lit from the heaviest sun direction
    look = normal if rays is None else normal + rays.directions.T @ rays.weights
    eye = _camera_eye(look)
    lamp = rays.directions[0] if rays is not None else eye
    lamp = 1e5 * lamp / np.linalg.norm(lamp)  # plotly wants |x|, |y|, |z| <= 1e5
    for t in traces:
        if isinstance(t, go.Mesh3d):
            t.lightposition = dict(x=lamp[0], y=lamp[1], z=lamp[2])
    fig = go.Figure(traces)
    sub = (f"{_plural(rays.total, 'sun direction')} as {_plural(len(rays.weights), 'ray')}"
           f" ({100 * rays.coverage:.0f}% of the weight)" if rays is not None else "sun directions not given")
    fig.update_layout(
        title=dict(text=f"{title + ': ' if title else ''}{_plural(n_fins, 'fin')} over the surface; {sub}",
                   font=dict(size=14)),
        scene=dict(aspectmode="data", xaxis_title="x (east)", yaxis_title="y (north)",
                   zaxis_title="z (up)", camera=dict(eye=dict(x=eye[0], y=eye[1], z=eye[2]),
                                                     up=dict(x=0, y=0, z=1))),
        legend=dict(orientation="h", x=0.0, y=0.0, yanchor="top", bgcolor="rgba(255,255,255,0.8)"),
        margin=dict(l=0, r=0, t=40, b=60), height=700, paper_bgcolor="white")
    return fig


def design_view_html(surface, structure, sun=None, *, title: str = "", div_id: str = "torsal-3d",
                     include_plotlyjs: bool = True, **kw) -> str:
    """The 3D view as an HTML fragment (a ``<div>`` and its scripts) to put into a page.

    With ``include_plotlyjs`` (default) plotly.js is inlined in the fragment, so the page works
    with no network; put it into a page once and pass False for further views on that page.
    Keywords go to :func:`design_view_figure`.
    """
    fig = design_view_figure(surface, structure, sun, title=title, **kw)
    return fig.to_html(full_html=False, include_plotlyjs=bool(include_plotlyjs), div_id=div_id,
                       config={"displaylogo": False, "responsive": True,
                               "toImageButtonOptions": {"filename": "torsal-design-3d"}})
