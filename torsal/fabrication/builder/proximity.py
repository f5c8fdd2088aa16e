"""How near fin panels come: mid-surface distances, crossings and swept paths (issue 15).

Small vectorized kernels over quads ``(m, 4, 3)`` (corners ``a_i a_j b_j b_i``, planar and
convex) for the builder's checks: which panels of two plates cross or come within a gap
where no joint joins them (:func:`_near_panel_pairs`), and how near a panel comes to another
on its way into place (:func:`_swept_distances` on mid-surfaces, :func:`_slab_depths` on the
thickened panels). Lengths in the fin system's ``unit``.

Example
-------
>>> import numpy as np
>>> floor = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]], float)
>>> wall = np.array([[[3, -1, -1], [3, 2, -1], [3, 2, 1], [3, -1, 1]]], float)
>>> float(_swept_distances(floor, [1.5, 0, 0], wall)[0, 0])
0.5
"""
from __future__ import annotations

import numpy as np

from ..model import _cross, _safe_normals


def _quads_cross(p: np.ndarray, q: np.ndarray) -> bool:
    """Whether an edge of a quad of ``p`` (k, 4, 3) passes through a quad of ``q`` (m, 4, 3)
    or the other way round (mid-surfaces, two triangles per quad; Moller-Trumbore): every
    pair of :func:`_edges_pierce`."""
    i, j = np.divmod(np.arange(len(p) * len(q)), len(q))
    return bool((_edges_pierce(p[i], q[j], eps=1e-6) | _edges_pierce(q[j], p[i], eps=1e-6)).any())


def _quads_on(p: np.ndarray, q: np.ndarray, gap: float) -> bool:
    """Whether the centre of a quad of ``p`` (k, 4, 3) lies within ``gap`` of a quad of ``q``
    (m, 4, 3), over it (a fin folded back onto another: coplanar overlap, no edge crossing)."""
    c = p.mean(axis=1)                                                  # (k, 3)
    tris = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])           # (T, 3, 3)
    v0, e1, e2 = tris[:, 0], tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    n = _cross(e1, e2)
    area2 = np.linalg.norm(n, axis=1)
    ok = area2 > 0
    n = n / np.where(ok, area2, 1.0)[:, None]
    w = c[:, None] - v0[None]                                           # (k, T, 3)
    dist = np.abs(np.einsum("ktj,tj->kt", w, n))
    # barycentric coordinates of the projection
    d00, d01, d11 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    d20, d21 = np.einsum("ktj,tj->kt", w, e1), np.einsum("ktj,tj->kt", w, e2)
    den = np.where(ok, d00 * d11 - d01 * d01, 1.0)
    v = (d11 * d20 - d01 * d21) / den
    u = (d00 * d21 - d01 * d20) / den
    inside = ok & (v > 0) & (u > 0) & (u + v < 1)
    return bool((inside & (dist <= gap)).any())


def _segment_distances(p0, p1, q0, q1) -> np.ndarray:
    """Distances of segments ``p0 p1`` and ``q0 q1`` (broadcast arrays (..., 3)): the closest
    points of the two lines, clamped to the segments (Ericson, Real-Time Collision Detection
    5.1.9)."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a, e = (d1 * d1).sum(-1), (d2 * d2).sum(-1)
    f, c, b = (d2 * r).sum(-1), (d1 * r).sum(-1), (d1 * d2).sum(-1)
    den = a * e - b * b
    safe = lambda x: np.where(x > 0, x, 1.0)  # noqa: E731
    s = np.where(den > 1e-12 * a * e, np.clip((b * f - c * e) / safe(den), 0.0, 1.0), 0.0)
    t = (b * s + f) / safe(e)
    # t outside [0, 1]: clamp it and recompute s for that end of q
    t_lo, t_hi = t < 0, t > 1
    s = np.where(t_lo, np.clip(-c / safe(a), 0.0, 1.0), s)
    s = np.where(t_hi, np.clip((b - c) / safe(a), 0.0, 1.0), s)
    t = np.clip(t, 0.0, 1.0)
    return np.linalg.norm(p0 + s[..., None] * d1 - q0 - t[..., None] * d2, axis=-1)


def _point_segment_distances(x, q0, q1) -> np.ndarray:
    """Distances of points ``x`` from segments ``q0 q1`` (broadcast arrays (..., 3)): bit for
    bit :func:`_segment_distances` ``(x, x, q0, q1)`` (a segment of length 0 there: its
    parameter is 0, the products with its zero direction add zeros), without the work of the
    second segment (the triangle distances ask this three times a corner, thousands of times
    in a fin system's build)."""
    d2 = q1 - q0
    e, f = (d2 * d2).sum(-1), (d2 * (x - q0)).sum(-1)
    t = np.clip(f / np.where(e > 0, e, 1.0), 0.0, 1.0)
    return np.linalg.norm(x - q0 - t[..., None] * d2, axis=-1)


def _point_triangle_distances(x, tri) -> np.ndarray:
    """Distances of points ``x`` (..., 3) from triangles ``tri`` (..., 3, 3) (broadcast): to
    the plane where the projection falls inside, else to the nearest edge."""
    v0, e1, e2 = tri[..., 0, :], tri[..., 1, :] - tri[..., 0, :], tri[..., 2, :] - tri[..., 0, :]
    w = x - v0
    d00, d01, d11 = (e1 * e1).sum(-1), (e1 * e2).sum(-1), (e2 * e2).sum(-1)
    d20, d21 = (w * e1).sum(-1), (w * e2).sum(-1)
    den = d00 * d11 - d01 * d01
    ok = den > 1e-12 * d00 * d11
    den = np.where(ok, den, 1.0)
    v, u = (d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den
    n = _cross(e1, e2)
    plane = np.abs((w * n).sum(-1)) / np.where(ok, np.linalg.norm(n, axis=-1), 1.0)
    edges = np.minimum.reduce([_point_segment_distances(x, tri[..., i, :], tri[..., (i + 1) % 3, :])
                               for i in range(3)])
    return np.where(ok & (u >= 0) & (v >= 0) & (u + v <= 1), plane, edges)


def _edges_pierce(p: np.ndarray, q: np.ndarray, *, eps: float = 1e-9) -> np.ndarray:
    """(m,) whether an edge of quad ``p[k]`` (m, 4, 3) passes through the inside of quad
    ``q[k]`` (two triangles; Moller-Trumbore), pair by pair; ``eps``: how far inside (in
    barycentric and edge parameters) a hit must be."""
    e0 = p[:, :, None]                                                  # (m, 4, 1, 3)
    d = np.roll(p, -1, axis=1)[:, :, None] - e0
    tris = np.stack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]], axis=1)[:, None]  # (m, 1, 2, 3, 3)
    v0, v1, v2 = tris[..., 0, :], tris[..., 1, :] - tris[..., 0, :], tris[..., 2, :] - tris[..., 0, :]
    pv = _cross(d, v2)
    det = (pv * v1).sum(-1)
    ok = np.abs(det) > 1e-12 * np.linalg.norm(v1, axis=-1) * np.linalg.norm(v2, axis=-1) * \
        np.linalg.norm(d, axis=-1)
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    tv = e0 - v0
    u = (tv * pv).sum(-1) * inv
    qv = _cross(tv, v1)
    v = (d * qv).sum(-1) * inv
    t = (v2 * qv).sum(-1) * inv
    hit = ok & (u > eps) & (v > eps) & (u + v < 1 - eps) & (t > eps) & (t < 1 - eps)
    return hit.any(axis=(1, 2))


def _quad_distances(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(m,) distances of the mid-surfaces of quads ``p[k]`` and ``q[k]`` (m, 4, 3), pair by
    pair: 0 where one passes through the other, else the least of corner-to-quad (two
    triangles each) and edge-to-edge distances (two quads apart come nearest there)."""
    tri = lambda x: np.stack([x[:, [0, 1, 2]], x[:, [0, 2, 3]]], axis=1)  # noqa: E731
    tp, tq = tri(p)[:, None], tri(q)[:, None]                           # (m, 1, 2, 3, 3)
    corner = np.minimum(_point_triangle_distances(p[:, :, None], tq).min(axis=(1, 2)),
                        _point_triangle_distances(q[:, :, None], tp).min(axis=(1, 2)))
    pe0, pe1 = p[:, :, None], np.roll(p, -1, axis=1)[:, :, None]        # (m, 4, 1, 3)
    qe0, qe1 = q[:, None], np.roll(q, -1, axis=1)[:, None]              # (m, 1, 4, 3)
    edge = _segment_distances(pe0, pe1, qe0, qe1).min(axis=(1, 2))
    crossing = _edges_pierce(p, q) | _edges_pierce(q, p)
    return np.where(crossing, 0.0, np.minimum(corner, edge))


def _near_panel_pairs(quads: np.ndarray, nodes: np.ndarray, gap: float) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``(i, j)``, i < j, of panels ``quads`` (n, 4, 3) with no node in common
    (``nodes`` (n, 2): a joint joins panels only at a shared node line) whose mid-surfaces
    cross or come within ``gap`` of each other, and their distances (0: crossing)."""
    lo, hi = quads.min(axis=1) - gap, quads.max(axis=1) + gap
    order = np.argsort(lo[:, 0], kind="stable")
    ii, jj = [], []
    # sweep along x: only panels whose boxes overlap in x are compared in full
    stop = np.searchsorted(lo[order, 0], hi[order, 0], side="right")
    for k, i in enumerate(order):
        js = order[k + 1:stop[k]]
        js = js[((lo[js] <= hi[i]) & (hi[js] >= lo[i])).all(axis=1)]
        ii.append(np.full(len(js), i))
        jj.append(js)
    i, j = np.concatenate(ii).astype(int), np.concatenate(jj).astype(int)
    share = (nodes[i][:, :, None] == nodes[j][:, None, :]).any(axis=(1, 2))
    i, j = np.minimum(i[~share], j[~share]), np.maximum(i[~share], j[~share])
    dist = _quad_distances(quads[i], quads[j])
    near = dist < gap
    return np.c_[i[near], j[near]], dist[near]


def _swept_faces(quads: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """(k, 6, 4, 3) the boundary of the region each quad of ``quads`` (k, 4, 3) sweeps when
    moved by ``vector`` (3,): the quad, its translate and the four parallelograms its edges
    sweep (a convex prism; flat when ``vector`` lies in the quad's plane)."""
    q = np.asarray(quads, float)
    e = q + np.asarray(vector, float)
    sides = np.stack([q, np.roll(q, -1, axis=1), np.roll(e, -1, axis=1), e], axis=2)
    return np.concatenate([q[:, None], e[:, None], sides], axis=1)


def _inside_sweeps(x: np.ndarray, quads: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """(m, k) whether point ``x[i]`` (m, 3) lies strictly inside the prism quad ``k`` (k, 4, 3,
    convex) sweeps along ``vector`` (False for a flat sweep: its faces cover it)."""
    v = np.asarray(vector, float)
    n = _safe_normals(quads)                                             # (k, 3)
    sn = n @ v
    ok = np.abs(sn) > 1e-9 * np.linalg.norm(v)
    mu = ((x[:, None] - quads[None, :, 0]) * n).sum(-1) / np.where(ok, sn, 1.0)   # (m, k)
    p = x[:, None] - mu[..., None] * v                                   # on the quad's plane
    edge = np.roll(quads, -1, axis=1) - quads                            # (k, 4, 3)
    turn = (_cross(edge[None], p[:, :, None] - quads[None]) * n[None, :, None]).sum(-1)
    return ok & (mu > 0) & (mu < 1) & (turn > 0).all(axis=-1)


def _swept_distances(moving: np.ndarray, vector: np.ndarray, others: np.ndarray) -> np.ndarray:
    """(k, m) least distance of the mid-surface of panel ``moving[i]`` (k, 4, 3), anywhere on
    its way from ``moving + vector`` to its place, from panel ``others[j]`` (m, 4, 3): the
    distance of the region it sweeps (:func:`_swept_faces`; 0 where a panel lies inside it)."""
    return _swept_and_still_distances(moving, vector, others)[0]


def _swept_and_still_distances(moving: np.ndarray, vector: np.ndarray, others: np.ndarray, *,
                               within: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(:func:`_swept_distances`, the (k, m) distances in place, ``_quad_distances`` of every
    pair): the first face of each swept region is the panel in place, so both come from one
    pass of :func:`_quad_distances`. With ``within``, only the pairs whose boxes (the region
    a panel sweeps, and the other panel) come within that distance are measured; the others
    are farther apart than that and get ``inf`` (the same values otherwise: pair by pair)."""
    k, m = len(moving), len(others)
    if not (k and m):
        return np.zeros((k, m)), np.zeros((k, m))
    faces = _swept_faces(moving, vector).reshape(-1, 4, 3)               # (6k, 4, 3)
    if within is None:
        f, o = np.divmod(np.arange(len(faces) * m), m)
        d = _quad_distances(faces[f], others[o]).reshape(k, 6, m)
    else:
        region = faces.reshape(k, -1, 3)
        lo, hi = region.min(axis=1) - within, region.max(axis=1) + within
        near = (((others.min(axis=1)[None] <= hi[:, None]) & (others.max(axis=1)[None] >= lo[:, None]))
                .all(axis=2))                                            # (k, m)
        i, o = np.nonzero(near)
        f = (6 * i[:, None] + np.arange(6)).ravel()                      # the 6 faces of panel i
        o6 = np.repeat(o, 6)
        d = np.full((k, 6, m), np.inf)
        d[np.repeat(i, 6), np.tile(np.arange(6), len(i)), o6] = _quad_distances(faces[f], others[o6])
    inside = _inside_sweeps(others.reshape(-1, 3), moving, vector).reshape(m, 4, k).any(axis=1)
    return np.where(inside.T, 0.0, d.min(axis=1)), d[:, 0]


def _slab_depths(moving: np.ndarray, vector: np.ndarray, others: np.ndarray,
                 thickness: float) -> np.ndarray:
    """(m,) how deep the plate panel ``moving[i]`` (m, 4, 3), thickened to ``thickness``
    about its mid-surface and swept from ``moving + vector`` to its place, and panel
    ``others[i]`` (m, 4, 3), thickened alike, overlap, pair by pair (< 0: apart, by about
    that much). Both are convex; the depth is the least overlap of their projections on the
    separating axes (the products of two of their edge directions, the sweep's among them:
    they hold every face normal and every edge-edge axis)."""
    def slab(q):
        h = 0.5 * thickness * _safe_normals(q)[:, None]
        return np.concatenate([q - h, q + h], axis=1), np.roll(q, -1, axis=1) - q, 2 * h

    pa, ea, na = slab(np.asarray(moving, float))
    pb, eb, nb = slab(np.asarray(others, float))
    v = np.broadcast_to(np.asarray(vector, float), (len(pa), 1, 3))
    pa = np.concatenate([pa, pa + v], axis=1)                            # (m, 16, 3)
    dirs = np.concatenate([ea, na, v, eb, nb], axis=1)                   # (m, 11, 3)
    i, j = np.triu_indices(dirs.shape[1], 1)
    ax = _cross(dirs[:, i], dirs[:, j])                                  # (m, 55, 3)
    norm = np.linalg.norm(ax, axis=-1, keepdims=True)
    ok = norm[..., 0] > 1e-9 * np.maximum(1.0, norm.max(axis=1))
    ax = ax / np.where(norm > 0, norm, 1.0)
    sa = np.einsum("mpk,mak->mpa", pa, ax)
    sb = np.einsum("mpk,mak->mpa", pb, ax)
    overlap = np.minimum(sa.max(axis=1) - sb.min(axis=1), sb.max(axis=1) - sa.min(axis=1))
    return np.where(ok, overlap, np.inf).min(axis=1)
