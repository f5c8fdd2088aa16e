"""Refinement of fin strips towards smooth developables (Wang et al. 2013, Fig. 10).

A strip of fins (the edges of one torsal family chained into a polyline, with the node lines
``a~_i b~_i``) is a discrete developable made of planar quads. Following Liu et al. 2006
(subdivision of conical/planar-quad strips), :func:`refine_developable` splits every fin
of every strip, smooths the two boundary polylines ``a~`` and ``b~`` with the interpolatory
4-point scheme, puts ``a~`` back on the reference surface and re-planarizes, ``levels``
times: the strip becomes a smooth developable made of many planar quads.
"""
from __future__ import annotations

import numpy as np

from .mesh import polygon_areas
from .support import SupportStructure, closest_points, optimize_support

__all__ = ["refine_developable", "four_point"]


def four_point(p: np.ndarray, closed: bool = False, w: float = 1.0 / 16.0) -> np.ndarray:
    """One step of the interpolatory 4-point scheme (Dyn, Levin, Gregory 1987) on a polyline.

    Parameters
    ----------
    p : (m, 3) float
        Polyline points (for ``closed``, without repeating the first at the end).
    closed : bool
    w : float, default 1/16
        Tension; 0 gives midpoints.

    Returns
    -------
    (2m - 1, 3) float for open, (2m, 3) for closed polylines: old points at even indices.

    Examples
    --------
    >>> four_point(np.array([[0., 0, 0], [1, 0, 0], [2, 0, 0]]))[:, 0]
    array([0. , 0.5, 1. , 1.5, 2. ])
    """
    p = np.asarray(p, float)
    m = len(p)
    if m < 2:
        return p.copy()
    if closed:
        ext = np.concatenate([p[-1:], p, p[:2]])
    else:
        ext = np.concatenate([2 * p[:1] - p[1:2], p, 2 * p[-1:] - p[-2:-1]])
    k = m if closed else m - 1
    mid = (0.5 + w) * (ext[1:k + 1] + ext[2:k + 2]) - w * (ext[0:k] + ext[3:k + 3])
    out = np.empty((m + k, 3))
    out[0::2][:m] = p
    out[1::2][:k] = mid
    return out


def refine_developable(structure: SupportStructure, levels: int = 1, *, reference=None,
                       hard_tol: float = 1e-4) -> SupportStructure:
    """Split, smooth and re-planarize every strip of fins, ``levels`` times (Fig. 10).

    Parameters
    ----------
    structure : SupportStructure
    levels : int, default 1
        Each level doubles the fins of every strip.
    reference : (vertices, faces), optional
        Surface A; new nodes ``a~`` are projected onto it before re-planarization, which keeps
        them on the tangent planes of A (:func:`optimize_support`, method "projection").
    hard_tol : float, default 1e-4
        delta_pl reached by re-planarization.

    Returns
    -------
    SupportStructure
        The strips as disjoint polylines (a node shared by two strips of different families
        is duplicated, one copy per strip); ``faces`` is empty; ``metadata['strip']`` gives the
        strip index of every edge, ``metadata['surface_area']`` the area of the faces of A~ the
        strips were refined from (model units squared: what a price per m^2 divides by).

    Examples
    --------
    >>> a = np.array([[0., 0, 0], [1, 0, 0], [2, 0, 0.2]])
    >>> s = SupportStructure(a, a + [0, 0.1, 1], [], np.array([[0, 1], [1, 2]]), np.array([0, 0]))
    >>> r = refine_developable(s, 1)
    >>> len(r.edges), r.delta_pl <= 1e-4
    (4, True)
    """
    levels = int(levels)
    if levels < 0:
        raise ValueError(f"levels must be >= 0, got {levels}")
    a0, b0 = structure.vertices_a, structure.vertices_b
    A, B, Ed, fam, sid = [], [], [], [], []
    off = 0
    mesh = None
    if reference is not None:
        v, f = (reference.vertices, reference.faces) if hasattr(reference, "vertices") else reference
        mesh = (np.asarray(v, float), np.asarray(f, np.int64))
    for k, (fm, verts, _) in enumerate(structure.strips()):
        closed = len(verts) > 2 and verts[0] == verts[-1]
        vv = verts[:-1] if closed else verts
        pa, pb = a0[vv], b0[vv]
        for _ in range(levels):
            pa, pb = four_point(pa, closed), four_point(pb, closed)
        if mesh is not None and levels:
            new = np.ones(len(pa), bool)
            new[0::2 ** levels] = False
            if new.any():
                cp, _, _ = closest_points(mesh[0], mesh[1], pa[new])
                shift = cp - pa[new]
                pa[new] = cp
                pb[new] = pb[new] + shift
        m = len(pa)
        idx = np.arange(m) + off
        e = np.stack([idx[:-1], idx[1:]], 1)
        if closed:
            e = np.concatenate([e, [[idx[-1], idx[0]]]])
        A.append(pa)
        B.append(pb)
        Ed.append(e)
        fam.append(np.full(len(e), fm))
        sid.append(np.full(len(e), k))
        off += m
    # each family keeps its depth: the duplicated nodes of two crossing strips stay one
    # node line (merged again where the fins are built)
    meta = {"strip": np.concatenate(sid), "levels": levels,
            "surface_area": float(polygon_areas(a0, structure.faces).sum())
            if len(structure.faces) else structure.metadata.get("surface_area", 0.0)}
    s = SupportStructure(np.concatenate(A), np.concatenate(B), [], np.concatenate(Ed),
                         np.concatenate(fam), metadata=dict(meta),
                         family_depth_ratio=structure.family_depth_ratio)
    if s.delta_pl > hard_tol:
        r = optimize_support(s, reference, hard_tol=hard_tol, method="projection", rounds=2)
        s = r.structure
        s.metadata.update({**meta, "planarize_status": r.status})
    return s
