"""Torsal remeshing: field-aligned parametrization and quad extraction (Wang et al. 2013, 4.2).

The paper remeshes mesh A along the torsal frame field with mixed-integer quadrangulation
([BZK09], [LXW*11]) and maps the new vertices to B through the piecewise-linear
correspondence A <-> B (Fig. 8a, 8b). No Python package ships MIQ, so this module does it:

* :func:`parametrize` -- a seamless global parametrization ``(u, v)`` per face corner: sparse
  least squares of the derivatives of ``u, v`` along the two field directions against
  ``(1, 0)`` and ``(0, 1)`` per spacing (the gradients against the dual frame, measured so that
  near-parabolic faces stay bounded), on the mesh
  cut open along a cut graph that joins the singularities to the boundary; across the cut the
  two sides are related by the field's matching (a signed permutation) plus an integer
  translation, the translations rounded to integers at once (as MIQ does greedily) and the
  system solved again. A singularity-free disk needs no cut: one sparse solve.
* :func:`extract_quads` -- traces the integer iso-lines per triangle, joins them across
  triangles (and across cuts, through the transition functions) into the polylines of the
  two families, and takes their intersections (lattice points) and their hits with the
  boundary of A as vertices of A~. Faces are the cycles of the embedded graph; along the
  boundary of A they are polygons clipped by straight segments between consecutive hits.
  Every vertex keeps its triangle of A and barycentric coordinates, and b~ is the same
  combination of B's vertices (Fig. 8b).
* :func:`remesh_torsal` -- the three steps, returning a :class:`SupportStructure`; the frame
  field is smoothed below half the fin spacing first (``torsal_frame_field(smoothing=...)``).

Conventions: family 0 edges follow the combed direction ``t0`` and lie on iso-lines of ``v``;
family 1 edges follow ``t1`` and lie on iso-lines of ``u``. Only iso-line pieces are fins
(``SupportStructure.edges``); boundary segments appear only as sides of boundary polygons.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
import scipy.sparse.csgraph as csg
import scipy.sparse.linalg as spla

from .frame_field import GROUP, TorsalFrameField, face_bases, torsal_frame_field
from .mesh import unique_edges
from .support import per_family
from torsal.core.errors import TorsalError

__all__ = ["TorsalParametrization", "ParametrizationError", "parametrize", "extract_quads",
           "remesh_torsal", "cut_graph"]


class ParametrizationError(TorsalError, RuntimeError):
    """The field-aligned parametrization failed; the message says where and why."""


@dataclass
class TorsalParametrization:
    """A seamless field-aligned parametrization in lattice units (fins at integer values).

    Attributes
    ----------
    field : TorsalFrameField
    spacing : float or (2,) tuple of float
        Fin spacing in model units, as given: one for both families or ``(s0, s1)``
        (:attr:`spacings`).
    uv : (F, 3, 2) float
        ``(u, v)`` per face corner in lattice units: iso-lines ``u = k`` carry family-1 fins,
        ``s1`` apart, ``v = l`` family-0 fins, ``s0`` apart.
    cut : (E,) bool
        Mesh edges (indexed like ``field.edges``) along which the mesh is cut open.
    transition : (E, 2) int
        Integer translation ``t`` on cut edges: ``uv[f0] = M uv[f1] + t`` with ``M`` =
        ``GROUP[field.matching[e]]`` and ``f0, f1 = field.edge_faces[e]``.
    residual : float
        Area-weighted root mean square of the error of the derivatives of ``(u, v)`` along the
        field directions ``t0, t1`` (targets ``(1, 0)`` and ``(0, 1)`` per spacing),
        dimensionless; 0 for an exactly integrable field.
    flipped : (k,) int
        Faces where the map ``(u, v)`` reverses orientation (fold-overs); empty when valid.
    """

    field: TorsalFrameField
    spacing: float | tuple[float, float]
    uv: np.ndarray
    cut: np.ndarray
    transition: np.ndarray
    residual: float
    flipped: np.ndarray
    metadata: dict = field(default_factory=dict)

    @property
    def spacings(self) -> tuple[float, float]:
        """``(s0, s1)``: the spacing of the family-0 fins (iso-lines of ``v``) and of the
        family-1 fins (iso-lines of ``u``), model units."""
        return per_family(self.spacing, "spacing")


def _spacing_text(spacing) -> str:
    s0, s1 = per_family(spacing, "spacing")
    return f"{s0:g}" if s0 == s1 else f"[{s0:g}, {s1:g}]"


def _gradient_basis(V, F):
    """Gradients of the three hat functions per face, (F, 3, 3), and the face areas (F,)."""
    p = V[F]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    dbl = np.linalg.norm(n, axis=1)
    nu = n / dbl[:, None]
    g = np.stack([np.cross(nu, p[:, (k + 2) % 3] - p[:, (k + 1) % 3]) for k in range(3)], axis=1)
    return g / dbl[:, None, None], 0.5 * dbl


def cut_graph(field: TorsalFrameField) -> np.ndarray:
    """Edges to cut along so that the mesh becomes a disk on which the field combs without
    mismatch: the edges not crossed by the combing's dual spanning tree, with dangling
    branches pruned (all boundary vertices count as one node; singular vertices are kept).

    Returns (E,) bool indexed like ``field.edges``. Empty for a singularity-free disk.
    """
    edges, ef = field.edges, field.edge_faces
    nV = len(field.vertices)
    cut = (ef[:, 1] >= 0) & ~field.tree_edge
    boundary = np.zeros(nV, bool)
    boundary[edges[ef[:, 1] < 0].ravel()] = True
    keep = np.zeros(nV, bool)
    keep[field.singularities] = True
    while True:
        ce = np.flatnonzero(cut)
        deg = np.bincount(edges[ce].ravel(), minlength=nV)
        leaf = (deg == 1) & ~boundary & ~keep
        drop = ce[leaf[edges[ce, 0]] | leaf[edges[ce, 1]]]
        if drop.size == 0:
            break
        cut[drop] = False
    # what is left: paths from singularities to the boundary, and one path per hole joining
    # it to the outer boundary (a cycle of the graph once the boundary is merged into a node)
    return cut


def _wedges(F, face_edges, edges, ef, cut):
    """Corner -> wedge id: corners of a vertex are merged across non-cut interior edges."""
    nF = len(F)
    corner = np.arange(3 * nF).reshape(nF, 3)
    rows, cols = [], []
    inner = np.flatnonzero((ef[:, 1] >= 0) & ~cut)
    f0, f1 = ef[inner, 0], ef[inner, 1]
    for end in (0, 1):
        vtx = edges[inner, end]
        c0 = corner[f0, np.argmax(F[f0] == vtx[:, None], axis=1)]
        c1 = corner[f1, np.argmax(F[f1] == vtx[:, None], axis=1)]
        rows.append(c0)
        cols.append(c1)
    rows = np.concatenate(rows)
    cols = np.concatenate(cols)
    g = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(3 * nF, 3 * nF))
    _, lab = csg.connected_components(g, directed=False)
    # wedge ids numbered by first appearance
    _, wid = np.unique(lab, return_inverse=True)
    return wid.reshape(nF, 3)


class _Alignment(NamedTuple):
    """The least-squares rows of the field alignment: ``G x ~ b`` per coordinate."""

    G: sp.csr_matrix       # (2 F, W): derivative of a wedge-valued function along t0, t1
    rhs_u: np.ndarray      # (2 F,): targets (1 / s1, 0), area weighted
    rhs_v: np.ndarray      # (2 F,): targets (0, 1 / s0)
    GtG: sp.csc_matrix     # (W, W)
    reg: float             # Tikhonov weight that pins the constant (1e-10 of the mean diagonal)


def _alignment(field: TorsalFrameField, wid: np.ndarray, n_wedges: int,
               spacings: tuple[float, float], g: np.ndarray, area: np.ndarray) -> _Alignment:
    """Per face the derivatives of u (and v) along t0 and t1 against (1 / s1, 0) (and
    (0, 1 / s0)): u counts the family-1 fins across t0, v the family-0 fins across t1. Same
    minimizer as |grad - dual frame|^2 where the field is integrable,
    but bounded where t0, t1 nearly coincide: there the dual frame grows like 1 / sin(angle)
    and a few such faces would dominate and fold the map."""
    nF = len(field.faces)
    sq = np.sqrt(area)
    R = np.repeat(np.arange(2 * nF).reshape(nF, 2)[:, :, None], 3, axis=2)  # (F, dir, corner)
    C = np.repeat(wid[:, None, :], 2, axis=1)
    vals = np.einsum("fkd,fcd->fkc", field.directions, g) * sq[:, None, None]
    G = sp.csr_matrix((vals.ravel(), (R.ravel(), C.ravel())), shape=(2 * nF, n_wedges))
    s0, s1 = spacings
    bu = (np.array([1.0 / s1, 0.0]) * sq[:, None]).ravel()
    bv = (np.array([0.0, 1.0 / s0]) * sq[:, None]).ravel()
    GtG = (G.T @ G).tocsc()
    return _Alignment(G, bu, bv, GtG, 1e-10 * GtG.diagonal().mean())


def _cut_constraints(field: TorsalFrameField, ce: np.ndarray, wid: np.ndarray,
                     n_wedges: int) -> sp.csr_matrix:
    """Rows of ``uv[f0] - M uv[f1] - t = 0`` at both ends of every cut edge, over the
    unknowns ``[u (W), v (W), t (nC, 2)]``."""
    F, ef, W, nC = field.faces, field.edge_faces, n_wedges, len(ce)
    f0, f1 = ef[ce, 0], ef[ce, 1]
    M = GROUP[field.matching[ce]]  # (nC, 2, 2)
    crow, ccol, cval = [], [], []
    r = 0
    for end in (0, 1):
        vtx = field.edges[ce, end]
        w0 = wid[f0, np.argmax(F[f0] == vtx[:, None], axis=1)]
        w1 = wid[f1, np.argmax(F[f1] == vtx[:, None], axis=1)]
        for i in range(2):  # component i: x0_i - sum_j M_ij x1_j - t_i = 0
            rid = r + np.arange(nC)
            crow += [rid]
            ccol += [i * W + w0]
            cval += [np.ones(nC)]
            for j in range(2):
                crow += [rid]
                ccol += [j * W + w1]
                cval += [-M[:, i, j].astype(float)]
            crow += [rid]
            ccol += [2 * W + 2 * np.arange(nC) + i]
            cval += [-np.ones(nC)]
            r += nC
    return sp.csr_matrix((np.concatenate(cval), (np.concatenate(crow), np.concatenate(ccol))),
                         shape=(r, 2 * W + 2 * nC))


def _solve_across_cuts(al: _Alignment, Cm: sp.csr_matrix, n_wedges: int, round_jumps: bool):
    """The constrained least squares (KKT system, slightly regularized); with
    ``round_jumps`` the translations are rounded to integers and the system solved again
    for u, v alone. Returns ``u (W,), v (W,), t (nC, 2)``."""
    W, r = n_wedges, Cm.shape[0]
    nC = (Cm.shape[1] - 2 * W) // 2
    Q = sp.block_diag([al.GtG, al.GtG, sp.csr_matrix((2 * nC, 2 * nC))]).tocsc()
    q = np.concatenate([al.G.T @ al.rhs_u, al.G.T @ al.rhs_v, np.zeros(2 * nC)])
    n = 2 * W + 2 * nC
    eps = 1e-9
    K = sp.bmat([[Q + al.reg * sp.identity(n), Cm.T], [Cm, -eps * sp.identity(r)]]).tocsc()
    x = spla.spsolve(K, np.concatenate([q, np.zeros(r)]))[:n]
    if not round_jumps:
        return x[:W], x[W:2 * W], x[2 * W:].reshape(nC, 2)
    t_int = np.round(x[2 * W:].reshape(nC, 2)).astype(int)
    # fixed t: moved to the right-hand side, unknowns only u, v
    Cx = Cm[:, :2 * W]
    d = -(Cm[:, 2 * W:] @ t_int.ravel().astype(float))
    K2 = sp.bmat([[Q[:2 * W, :2 * W] + al.reg * sp.identity(2 * W), Cx.T],
                  [Cx, -eps * sp.identity(r)]]).tocsc()
    x2 = spla.spsolve(K2, np.concatenate([q[:2 * W], d]))
    return x2[:W], x2[W:2 * W], t_int


def _lattice_offset(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(2,) shift of the lattice that keeps every vertex value farthest from an integer (a
    search over 37 x 7 fractions): extraction then never meets a vertex on an iso-line."""
    vals = np.stack([u, v], axis=1)
    best, best_d = None, -1.0
    for cand in np.linspace(0.0, 1.0, 37, endpoint=False):
        for cand2 in np.linspace(0.0, 1.0, 37, endpoint=False)[::6]:
            sh = np.array([cand, (cand + cand2) % 1.0])
            fr = (vals + sh) % 1.0
            dmin = float(np.minimum(fr, 1.0 - fr).min())
            if dmin > best_d:
                best, best_d = sh, dmin
    return best


def _alignment_quality(field: TorsalFrameField, g, area, uv, spacings: tuple[float, float]):
    """Area-weighted RMS of the derivatives along the field directions against their targets
    (the identity once u is scaled by s1 and v by s0), and the faces where the map's
    orientation disagrees with the dual frame's (folds). Returns ``(residual, flipped)``."""
    grad = np.einsum("fkd,fkc->fcd", g, uv)  # (F, 2(coord), 3)
    scale = np.array([spacings[1], spacings[0]])[None, :, None]
    dt = np.einsum("fcd,fkd->fck", grad, field.directions) * scale  # ideally identity
    residual = float(np.sqrt(np.average(((dt - np.eye(2)[None]) ** 2).sum((1, 2)), weights=area)))
    _, _, nrm = face_bases(field.vertices, field.faces)
    w = field.dual_frame()
    det = np.einsum("ij,ij->i", np.cross(grad[:, 0], grad[:, 1]), nrm)
    ref = np.einsum("ij,ij->i", np.cross(w[:, 0], w[:, 1]), nrm)
    return residual, np.flatnonzero(np.sign(det) != np.sign(ref))


def parametrize(field: TorsalFrameField, spacing, *, round_jumps: bool = True,
                offset: bool = True) -> TorsalParametrization:
    """Global field-aligned parametrization with fin spacing ``spacing`` (model units), one
    for both torsal families or ``(s0, s1)`` (paper 4.2: the spacing of the two families of
    torsal lines; a sparse second family is ``s1 > s0``).

    Minimizes ``sum_f area_f sum_k ((<grad u, t_k> - delta_k0 / s1)^2 + (<grad v, t_k> -
    delta_k1 / s0)^2)`` (``t_0, t_1`` the combed torsal directions: ``u`` grows by one per
    family-1 spacing along ``t_0`` and is constant along ``t_1``, so ``grad u`` is the
    dual frame vector ``w1 / s1``; measured along ``t_k`` the error stays bounded where the two
    directions nearly coincide, at parabolic faces, instead of growing like
    ``1 / sin(angle)``) over per-corner values on the mesh cut open
    along :func:`cut_graph`, subject to ``uv[f0] = M uv[f1] + t`` across every cut edge, ``M`` the
    field's matching and ``t`` an integer translation (mixed-integer quadrangulation in the
    spirit of Bommes et al. 2009; here all jumps are rounded at once and the system solved
    again). For a singularity-free disk there is no cut: one sparse least-squares solve.

    Parameters
    ----------
    field : TorsalFrameField
    spacing : float or (2,) sequence of float
        Distance of neighbouring fins of one family, model units: one for both, or
        ``(s0, s1)`` for family 0 (iso-lines of ``v``) and family 1 (iso-lines of ``u``).
    round_jumps : bool, default True
        Round the translations across cuts to integers (needed for a consistent quad mesh).
    offset : bool, default True
        Shift ``(u, v)`` by a fraction of the lattice so that no mesh vertex lies on an
        integer iso-line (only when no cut carries a rotation; it keeps extraction generic).

    Returns
    -------
    TorsalParametrization

    Raises
    ------
    ParametrizationError
        Naming the faces where the result folds over, or a singularity on the boundary, or
        a cut across which the two families exchange while their spacings differ by other
        than a whole multiple (with a whole multiple ``m`` both take the smaller spacing and
        the sparse family keeps every ``m``-th line: ``metadata["thin"]``).

    Examples
    --------
    >>> from torsal.geometry.congruence import Congruence
    >>> from torsal.geometry.frame_field import torsal_frame_field
    >>> from torsal.geometry.surfaces import graph_surface
    >>> c = Congruence.from_normals(graph_surface(lambda x, y: 0.3 * (x**2 - 0.5 * y**2)))
    >>> p = parametrize(torsal_frame_field(c), 0.05)
    >>> p.uv.shape, p.residual < 0.1
    ((800, 3, 2), True)
    """
    t0 = time.perf_counter()
    spacings = per_family(spacing, "spacing")
    spacing = spacings[0] if spacings[0] == spacings[1] else spacings
    V, F = field.vertices, field.faces
    nF = len(F)
    _, face_edges = unique_edges(F)
    cut = cut_graph(field)
    ce = np.flatnonzero(cut)
    nonid = ce[field.matching[ce] != 0]
    wid = _wedges(F, face_edges, field.edges, field.edge_faces, cut)
    W = int(wid.max()) + 1
    g, area = _gradient_basis(V, F)
    thin = _thinning(field, ce, spacings)
    lattice = (min(spacings),) * 2 if thin else spacings
    al = _alignment(field, wid, W, lattice, g, area)
    nC = len(ce)
    if nC == 0:
        solve = spla.factorized((al.GtG + al.reg * sp.identity(W)).tocsc())
        u, v = solve(al.G.T @ al.rhs_u), solve(al.G.T @ al.rhs_v)
        t_jump = np.zeros((0, 2), int)
    else:
        u, v, t_jump = _solve_across_cuts(al, _cut_constraints(field, ce, wid, W), W, round_jumps)
    uv = np.stack([u[wid], v[wid]], axis=-1)  # (F, 3, 2)
    did_offset = None
    if offset and nonid.size == 0:
        best = _lattice_offset(u, v)
        uv = uv + best
        did_offset = best.tolist()
    transition = np.zeros((len(field.edges), 2), int)
    if nC:
        transition[ce] = np.round(t_jump).astype(int)
    residual, flipped = _alignment_quality(field, g, area, uv, lattice)
    meta = {"seconds": time.perf_counter() - t0, "wedges": W, "cut_edges": int(nC),
            "rotational_cut_edges": int(nonid.size), "offset": did_offset,
            "singularities": field.singularities.tolist(), "thin": thin}
    p = TorsalParametrization(field=field, spacing=spacing, uv=uv, cut=cut, transition=transition,
                              residual=residual, flipped=flipped, metadata=meta)
    if flipped.size > 0.02 * nF:
        near = _describe_faces(field, flipped)
        raise ParametrizationError(
            f"parametrization failed: the map (u, v) folds over in {flipped.size} of {nF} faces "
            f"({near}); the torsal field is too irregular there for spacing "
            f"{_spacing_text(spacing)} "
            "(optimize the congruence for smoothness, increase the spacing, or fill near-bundle "
            "faces with a larger bundle_tol)"
        )
    return p


def _thinning(field: TorsalFrameField, cut_edges: np.ndarray,
               spacings: tuple[float, float]) -> dict | None:
    """Two spacings where a cut exchanges the families (a matching that swaps ``u`` and ``v``,
    around a singularity of index 1/4: a family-0 fin continues as a family-1 fin there): one
    lattice at the smaller spacing for both, of which the sparse family keeps every ``m``-th
    line (``{"family": f, "every": m}``, for :func:`extract_quads`), when the larger spacing
    is ``m`` times the smaller; a ParametrizationError otherwise. None where the families
    keep their identity (a lattice of the two spacings)."""
    if spacings[0] == spacings[1] or not len(cut_edges):
        return None
    swaps = GROUP[field.matching[cut_edges]][:, 0, 0] == 0
    if not swaps.any():
        return None
    every = max(spacings) / min(spacings)
    if abs(every - round(every)) <= 1e-9 * every:
        return {"family": int(np.argmax(spacings)), "every": int(round(every))}
    faces = np.unique(field.edge_faces[cut_edges[swaps]].ravel())
    raise ParametrizationError(
        f"the two torsal families exchange around a singularity ({_describe_faces(field, faces[faces >= 0])}): "
        f"a fin of one family continues as a fin of the other there, so the families "
        f"cannot have different spacings {_spacing_text(spacings)} unless the larger is a "
        "whole multiple of the smaller (e.g. [0.6, 1.2]: every other line of the sparse "
        "family); give such spacings or one fins.spacing")


def _describe_faces(field, faces):
    faces = np.asarray(faces)
    c = field.vertices[field.faces[faces]].mean(1)
    msg = f"e.g. faces {faces[:5].tolist()} around {np.round(c.mean(0), 4).tolist()}"
    if len(field.singularities):
        d = np.linalg.norm(c[:, None] - field.vertices[field.singularities][None], axis=2)
        k = int(np.argmin(d.min(0)))
        msg += f"; nearest singularity at vertex {int(field.singularities[k])}"
    return msg


# ----------------------------------------------------------------------------- extraction
def _segments(uv, face_edges, edge_faces, matching, transition, fam):
    """Iso-line segments of one family within every triangle.

    Returns dict with, per segment: face, k (line value), the two crossings (local edge,
    barycentric coordinates, other coordinate value) and canonical crossing keys."""
    c = 1 - fam  # family 0 lies on v = const (coordinate 1), family 1 on u = const
    x = uv[:, :, c]
    y = uv[:, :, 1 - c]
    nF = len(x)
    lo = np.floor(x.min(1)).astype(np.int64)
    hi = np.floor(x.max(1)).astype(np.int64)
    cnt = hi - lo
    f = np.repeat(np.arange(nF), cnt)
    start = np.repeat(np.cumsum(cnt) - cnt, cnt)
    k = np.repeat(lo, cnt) + 1 + (np.arange(cnt.sum()) - start)
    xf, yf = x[f], y[f]
    above = xf >= k[:, None]
    pts = []
    for j in range(3):
        a, b = (j + 1) % 3, (j + 2) % 3
        crosses = above[:, a] != above[:, b]
        s = (k - xf[:, a]) / np.where(crosses, xf[:, b] - xf[:, a], 1.0)
        pts.append((crosses, a, b, s))
    cr = np.stack([p[0] for p in pts], 1)  # (S, 3)
    # first and second crossing edge per segment
    order = np.argsort(~cr, axis=1, kind="stable")
    j1, j2 = order[:, 0], order[:, 1]
    S = len(f)
    out = {"face": f, "k": k, "fam": np.full(S, fam)}
    for name, jj in (("p", j1), ("q", j2)):
        bary = np.zeros((S, 3))
        a = (jj + 1) % 3
        b = (jj + 2) % 3
        xa = xf[np.arange(S), a]
        xb = xf[np.arange(S), b]
        s = (k - xa) / (xb - xa)
        bary[np.arange(S), a] = 1 - s
        bary[np.arange(S), b] = s
        out[name + "_bary"] = bary
        out[name + "_y"] = (1 - s) * yf[np.arange(S), a] + s * yf[np.arange(S), b]
        ge = face_edges[f, jj]
        out[name + "_edge"] = ge
        # canonical key: line expressed in the chart of edge_faces[ge, 0]
        kf, kk = np.full(S, fam), k.copy()
        other = edge_faces[ge, 1] == f
        if other.any():
            o = np.flatnonzero(other)
            M = GROUP[np.maximum(matching[ge[o]], 0)]  # uv[f0] = M uv[f1] + t
            tt = transition[ge[o]]
            # coordinate c of f1 maps to row i of f0 with M[i, c] != 0
            col = M[:, :, c]  # (o, 2)
            i = np.argmax(col != 0, axis=1)
            sgn = col[np.arange(len(o)), i]
            kk[o] = sgn * k[o] + tt[np.arange(len(o)), i]
            kf[o] = 1 - i
        out[name + "_key"] = np.stack([ge, kf, kk], axis=1)
    return out


class _Crossings(NamedTuple):
    """Where iso-line segments cross the edges of A: one record per crossing point."""

    keys: np.ndarray      # (nX, 3) int: canonical (edge, family, line value) of each crossing
    at_p: np.ndarray      # (S,) int: crossing at each segment's p end
    at_q: np.ndarray      # (S,) int: crossing at each segment's q end
    face: np.ndarray      # (nX,) int: a triangle of A holding the crossing
    bary: np.ndarray      # (nX, 3) float: its barycentric coordinates there


def _crossings(seg: dict) -> _Crossings:
    """Merge the segment ends that are the same point (same canonical key)."""
    S = len(seg["face"])
    keys = np.concatenate([seg["p_key"], seg["q_key"]])
    ukeys, cinv = np.unique(keys, axis=0, return_inverse=True)
    cinv = cinv.ravel()
    first = np.full(len(ukeys), -1)                    # first occurrence of every crossing
    first[cinv[::-1]] = np.arange(2 * S)[::-1]
    face = np.concatenate([seg["face"], seg["face"]])[first]
    bary = np.concatenate([seg["p_bary"], seg["q_bary"]])[first]
    return _Crossings(ukeys, cinv[:S], cinv[S:], face, bary)


class _LatticeNodes(NamedTuple):
    """Lattice points (u = k and v = l both integer) on the iso-line segments."""

    per_segment: np.ndarray   # (S,) int: how many lie on each segment
    rank: np.ndarray          # (M,) int: position of each occurrence along its segment
    bary: np.ndarray          # (M, 3) float: barycentric coordinates of each occurrence
    node: np.ndarray          # (M,) int: the lattice node of each occurrence
    face: np.ndarray          # (nN,) int: triangle of each node
    node_bary: np.ndarray     # (nN, 3) float: barycentric coordinates of each node


def _lattice_nodes(seg: dict, thin: dict | None = None) -> _LatticeNodes:
    """The integer values l of the other coordinate y between a segment's two ends; a value
    exactly at an end is counted iff the other end is below (simulation of simplicity:
    l counted iff (yp >= l) != (yq >= l), i.e. l in (ylo, yhi]). With ``thin`` (see
    :func:`_thinning`) the dense family's segments keep only the values on the sparse
    family's kept lines."""
    S = len(seg["face"])
    yp, yq = seg["p_y"], seg["q_y"]
    lo = np.floor(np.minimum(yp, yq)).astype(np.int64)
    hi = np.floor(np.maximum(yp, yq)).astype(np.int64)
    m = hi - lo
    sid = np.repeat(np.arange(S), m)
    rank = np.arange(m.sum()) - np.repeat(np.cumsum(m) - m, m)
    asc = (yq >= yp)[sid]
    l_val = np.where(asc, lo[sid] + 1 + rank, hi[sid] - rank)
    if thin:
        keep = (seg["fam"][sid] == thin["family"]) | (l_val % thin["every"] == 0)
        sid, l_val = sid[keep], l_val[keep]
        m = np.bincount(sid, minlength=S)
        rank = np.arange(len(sid)) - np.repeat(np.cumsum(m) - m, m)
    sig = (l_val - yp[sid]) / np.where(yq[sid] != yp[sid], (yq - yp)[sid], 1.0)
    nb = (1 - sig)[:, None] * seg["p_bary"][sid] + sig[:, None] * seg["q_bary"][sid]
    fam, k = seg["fam"][sid], seg["k"][sid]
    nkeys = np.stack([seg["face"][sid], np.where(fam == 1, k, l_val),
                      np.where(fam == 1, l_val, k)], axis=1)           # (face, u, v)
    if not len(nkeys):
        return _LatticeNodes(m, rank, nb, np.zeros(0, np.int64), np.zeros(0, np.int64),
                             np.zeros((0, 3)))
    ukn, ninv = np.unique(nkeys, axis=0, return_inverse=True)
    ninv = ninv.ravel()
    nfirst = np.full(len(ukn), -1)
    nfirst[ninv[::-1]] = np.arange(len(ninv))[::-1]
    return _LatticeNodes(m, rank, nb, ninv, ukn[:, 0], nb[nfirst])


class _Pieces(NamedTuple):
    """Iso-line pieces between consecutive graph points (crossings 0..nX-1, lattice nodes
    nX..) inside one triangle."""

    a: np.ndarray      # (P,) int: graph id of the first end
    b: np.ndarray      # (P,) int: graph id of the second end
    family: np.ndarray  # (P,) int
    pos_a: np.ndarray  # (P, 3) float: position of the first end on A
    pos_b: np.ndarray  # (P, 3) float


def _pieces(seg: dict, X: _Crossings, N: _LatticeNodes, V, F) -> _Pieces:
    """Split every segment at its lattice nodes: the chain p, n_1..n_m, q."""
    S, m = len(seg["face"]), N.per_segment
    L = m + 2
    tot = int(L.sum())
    seq = np.empty(tot, np.int64)
    seq_bary = np.empty((tot, 3))
    offs = np.cumsum(L) - L
    seq[offs], seq[offs + L - 1] = X.at_p, X.at_q
    seq_bary[offs], seq_bary[offs + L - 1] = seg["p_bary"], seg["q_bary"]
    inner = np.repeat(offs + 1, m) + N.rank
    seq[inner] = len(X.keys) + N.node
    seq_bary[inner] = N.bary
    is_last = np.zeros(tot, bool)
    is_last[offs + L - 1] = True
    pa = np.flatnonzero(~is_last)
    pseg = np.repeat(np.arange(S), L)[pa]
    tri = V[F[seg["face"][pseg]]]
    return _Pieces(seq[pa], seq[pa + 1], seg["fam"][pseg],
                   np.einsum("pk,pkd->pd", seq_bary[pa], tri),
                   np.einsum("pk,pkd->pd", seq_bary[pa + 1], tri))


class _Fins(NamedTuple):
    """Fins: chains of pieces between two terminal graph points (a lattice node, or a
    crossing that is not passed through: on the boundary, or dangling)."""

    ends: np.ndarray        # (E, 2) int: graph ids of the two terminals
    leave_0: np.ndarray     # (E, 3) float: direction leaving ends[:, 0] along the fin
    leave_1: np.ndarray     # (E, 3) float: direction leaving ends[:, 1]
    family: np.ndarray      # (E,) int
    dropped_chains: int     # chains without exactly two terminals (closed loops)


def _chain_fins(P: _Pieces, n_crossings: int, n_graph: int) -> _Fins:
    """Join pieces through pass-through crossings (degree 2) into fins."""
    nP = len(P.a)
    ends = np.r_[P.a, P.b]
    end_piece = np.r_[np.arange(nP), np.arange(nP)]
    terminal = np.ones(n_graph, bool)
    terminal[:n_crossings] = np.bincount(ends, minlength=n_graph)[:n_crossings] != 2
    pt = np.flatnonzero(~terminal[ends])
    pt = pt[np.argsort(ends[pt], kind="stable")]
    pairs = end_piece[pt].reshape(-1, 2)               # two pieces sharing a pass-through point
    adj = sp.csr_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(nP, nP))
    n_chains, chain = csg.connected_components(adj, directed=False)
    te = np.flatnonzero(terminal[ends])
    good = np.bincount(chain[end_piece[te]], minlength=n_chains) == 2
    te = te[good[chain[end_piece[te]]]]
    te = te[np.argsort(chain[end_piece[te]], kind="stable")]
    tnode = ends[te].reshape(-1, 2)
    tpiece = end_piece[te].reshape(-1, 2)
    tside = (te >= nP).reshape(-1, 2)                  # True: the terminal is the piece's b end

    def leaving(pc, side):
        return np.where(side[:, None], P.pos_a[pc] - P.pos_b[pc], P.pos_b[pc] - P.pos_a[pc])

    keep = tnode[:, 0] != tnode[:, 1]
    return _Fins(tnode[keep], leaving(tpiece[:, 0], tside[:, 0])[keep],
                 leaving(tpiece[:, 1], tside[:, 1])[keep], P.family[tpiece[:, 0]][keep],
                 int((~good).sum()))


class _Vertices(NamedTuple):
    """Vertices of A~: the terminals that some fin uses."""

    graph_id: np.ndarray    # (n,) int: graph point of each vertex
    face: np.ndarray        # (n,) int: its triangle of A
    bary: np.ndarray        # (n, 3) float: its barycentric coordinates
    crossing: np.ndarray    # (n,) bool: an edge crossing (else a lattice node)
    boundary: np.ndarray    # (n,) bool: on the boundary of A
    dangling: np.ndarray    # (n,) bool: an iso-line end inside A (next to a singularity)


def _fin_vertices(fins: _Fins, X: _Crossings, N: _LatticeNodes, edge_faces):
    """The vertices of A~ and the fins as (E, 2) indices into them."""
    nX, nN = len(X.keys), len(N.face)
    used = np.unique(fins.ends.ravel())
    remap = np.full(nX + nN, -1)
    remap[used] = np.arange(len(used))
    is_x = used < nX
    face = np.where(is_x, X.face[np.minimum(used, nX - 1)],
                    N.face[np.maximum(used - nX, 0)] if nN else 0)
    bary = np.where(is_x[:, None], X.bary[np.minimum(used, nX - 1)],
                    N.node_bary[np.maximum(used - nX, 0)] if nN else 0.0)
    on_bnd = np.zeros(len(used), bool)
    on_bnd[is_x] = edge_faces[X.keys[used[is_x], 0], 1] < 0
    return _Vertices(used, face, bary, is_x, on_bnd, is_x & ~on_bnd), remap[fins.ends]


class _BoundarySides(NamedTuple):
    """Straight sides of the boundary polygons: between consecutive hits of iso-lines with
    a boundary loop of A."""

    ends: np.ndarray       # (B, 2) int: vertex indices
    leave_0: np.ndarray    # (B, 3) float: direction leaving ends[:, 0]
    leave_1: np.ndarray    # (B, 3) float


def _boundary_sides(vt: _Vertices, X: _Crossings, V, F, face_edges, edge_faces) -> _BoundarySides:
    hit = np.flatnonzero(vt.boundary)
    none = _BoundarySides(np.zeros((0, 2), np.int64), np.zeros((0, 3)), np.zeros((0, 3)))
    if not hit.size:
        return none
    ge = X.keys[vt.graph_id[hit], 0]
    fb = edge_faces[ge, 0]
    loc = np.argmax(face_edges[fb] == ge[:, None], axis=1)
    a_c, b_c = (loc + 1) % 3, (loc + 2) % 3
    s_along = vt.bary[hit, :][np.arange(hit.size), b_c]   # weight of the forward end
    va, vb = F[fb, a_c], F[fb, b_c]
    pos = {ab: (li, k) for li, loop in enumerate(_boundary_loops(F, face_edges, edge_faces))
           for k, ab in enumerate(loop)}
    lp = np.array([pos[(int(a), int(b))] for a, b in zip(va, vb)])
    o = np.lexsort((s_along, lp[:, 1], lp[:, 0]))      # hits in order along each loop
    hs, lid = hit[o], lp[o, 0]
    evec = (V[vb] - V[va])[o]
    sides, d0, d1 = [], [], []
    for li in np.unique(lid):
        idx = np.flatnonzero(lid == li)
        if idx.size < 2:
            continue
        nxt = np.roll(idx, -1)
        sides.append(np.stack([hs[idx], hs[nxt]], 1))
        d0.append(evec[idx])
        d1.append(-evec[nxt])
    if not sides:
        return none
    return _BoundarySides(np.concatenate(sides), np.concatenate(d0), np.concatenate(d1))


def _trace_faces(fin_edges, fins: _Fins, sides: _BoundarySides, vertex_face, V, F) -> list:
    """Faces of the embedded graph (fins and boundary sides): the rotation system at every
    vertex (half-edges sorted by angle in the tangent plane of its triangle), each face to
    the left of its half-edges; faces made of boundary sides only (the outside) dropped."""
    n_fins = len(fin_edges)
    all_e = np.concatenate([fin_edges, sides.ends])
    n_all = len(all_e)
    # half-edge h = 2e (a->b), 2e+1 (b->a); origin and leaving direction
    h_org = all_e.ravel()
    h_dir = np.empty((2 * n_all, 3))
    h_dir[0::2] = np.concatenate([fins.leave_0, sides.leave_0])
    h_dir[1::2] = np.concatenate([fins.leave_1, sides.leave_1])
    b1, b2, _ = face_bases(V, F)
    vf = vertex_face[h_org]
    ang = np.arctan2(np.einsum("ij,ij->i", h_dir, b2[vf]), np.einsum("ij,ij->i", h_dir, b1[vf]))
    o = np.lexsort((ang, h_org))
    org_sorted = h_org[o]
    n_v = len(vertex_face)
    startpos = np.searchsorted(org_sorted, np.arange(n_v))
    nval = np.searchsorted(org_sorted, np.arange(n_v), side="right") - startpos
    rank_in = np.empty(2 * n_all, np.int64)
    rank_in[o] = np.arange(2 * n_all) - startpos[org_sorted]
    # next(h) = the half-edge preceding twin(h) in the CCW order at twin(h)'s origin
    tw = np.arange(2 * n_all) ^ 1
    b_org = h_org[tw]
    nxt = o[startpos[b_org] + (rank_in[tw] - 1) % nval[b_org]]
    is_b = np.zeros(2 * n_all, bool)
    is_b[2 * n_fins:] = True
    visited = np.zeros(2 * n_all, bool)
    faces = []
    for h0 in range(2 * n_all):
        if visited[h0]:
            continue
        cyc = []
        h = h0
        while not visited[h]:
            visited[h] = True
            cyc.append(h)
            h = nxt[h]
        cyc = np.array(cyc)
        if len(cyc) >= 3 and not is_b[cyc].all():
            faces.append(h_org[cyc].tolist())
    return faces


class _Collapsed(NamedTuple):
    vertices: _Vertices
    fin_edges: np.ndarray
    family: np.ndarray
    faces: list
    n_collapsed: int


def _collapse_short_fins(vt: _Vertices, fin_edges, family, faces, min_length: float,
                         V, F) -> _Collapsed:
    """Merge the end points of fins shorter than ``min_length`` (an iso-line leaving A within
    ~1e-3 spacing of a lattice point, or through a vertex of A's boundary). The merged vertex
    is a lattice node of the group if it has one, else its smallest index; it stays on A."""
    pos = np.einsum("nk,nkd->nd", vt.bary, V[F[vt.face]])
    short = np.linalg.norm(pos[fin_edges[:, 1]] - pos[fin_edges[:, 0]], axis=1) < min_length
    n_collapsed = int(short.sum())
    if not n_collapsed:
        return _Collapsed(vt, fin_edges, family, faces, 0)
    n = len(vt.face)
    se = fin_edges[short]
    g = sp.csr_matrix((np.ones(len(se)), (se[:, 0], se[:, 1])), shape=(n, n))
    _, comp = csg.connected_components(g, directed=False)
    prio = np.where(vt.crossing, 1, 0) * n + np.arange(n)
    rep = np.full(comp.max() + 1, -1)
    order = np.argsort(prio)[::-1]
    rep[comp[order]] = order              # last write wins: the smallest priority
    grp_bnd = np.zeros(comp.max() + 1, bool)
    np.logical_or.at(grp_bnd, comp, vt.boundary)
    new_id = np.full(n, -1)
    reps = np.unique(rep[comp])
    new_id[reps] = np.arange(len(reps))
    vmap = new_id[rep[comp]]
    fin_edges, family = vmap[fin_edges[~short]], family[~short]
    nondeg = fin_edges[:, 0] != fin_edges[:, 1]
    fin_edges, family = fin_edges[nondeg], family[nondeg]
    new_faces = []
    for fc in faces:
        mapped = [int(vmap[v]) for v in fc]
        dedup = [v for k, v in enumerate(mapped) if v != mapped[k - 1]] if len(mapped) > 1 else mapped
        if len(set(dedup)) >= 3:
            new_faces.append(dedup)
    on_bnd = grp_bnd[comp[reps]]
    vt = _Vertices(vt.graph_id[reps], vt.face[reps], vt.bary[reps], vt.crossing[reps], on_bnd,
                   vt.dangling[reps] & ~on_bnd)
    # edges may now be duplicated (two short fins merged into one pair)
    _, uniq = np.unique(np.sort(fin_edges, axis=1), axis=0, return_index=True)
    uniq = np.sort(uniq)
    return _Collapsed(vt, fin_edges[uniq], family[uniq], new_faces, n_collapsed)


def extract_quads(param: TorsalParametrization, vertices_b=None, *, congruence=None,
                  min_edge: float = 1e-3) -> "SupportStructure":
    """Quad mesh A~ (and B~) from a parametrization: the integer iso-lines of ``(u, v)``.

    Wang et al. 2013, 4.2 and Fig. 8b. Vertices of A~ are the lattice points (intersections of
    the iso-lines ``u = k`` and ``v = l``) and the points where iso-lines leave A (its
    boundary); every iso-line piece between two of them is an edge (a fin) labelled by family
    (0: on ``v = l``, along the torsal direction ``t0``; 1: on ``u = k``). Faces are the cycles
    of the embedded graph: quads inside, polygons clipped by the boundary of A (their boundary
    sides are straight segments between consecutive hits and are not fins). Each vertex keeps
    its triangle of A and barycentric coordinates (``metadata['face']``,
    ``metadata['barycentric']``); ``b~`` is the same combination of B's vertices.

    Parameters
    ----------
    param : TorsalParametrization
    vertices_b : (n, 3) float, optional
        Vertices of B (``a_i + e_i``); taken from ``congruence.vertices_b`` if omitted.
    congruence : Congruence, optional
    min_edge : float, default 1e-3
        Fins shorter than ``min_edge`` times the smaller spacing are collapsed (their end points merged; the
        merged vertex is one of the two, so it stays exactly on A).

    Returns
    -------
    SupportStructure
        With ``metadata`` keys ``face`` (n,), ``barycentric`` (n, 3), ``uv`` (n, 2),
        ``boundary`` (n,) bool (on the boundary of A), ``dangling`` (n,) bool (an iso-line end
        next to a singularity), ``spacing``.

    Examples
    --------
    >>> from torsal.geometry.congruence import Congruence
    >>> from torsal.geometry.frame_field import torsal_frame_field
    >>> from torsal.geometry.surfaces import graph_surface
    >>> c = Congruence.from_normals(graph_surface(lambda x, y: 0.3 * (x**2 - 0.5 * y**2)))
    >>> s = extract_quads(parametrize(torsal_frame_field(c), 0.1), congruence=c)
    >>> sorted(set(map(len, s.faces)))[:2], s.delta_pl < 0.01
    ([3, 4], True)
    """
    from .support import SupportStructure  # the container lives one room up (see ARCHITECTURE)

    fld = param.field
    V, F = fld.vertices, fld.faces
    if vertices_b is None:
        if congruence is None:
            raise ValueError("extract_quads needs vertices_b or the congruence (for mesh B)")
        vertices_b = congruence.vertices_b
    VB = np.asarray(vertices_b, float)
    ef = fld.edge_faces
    _, face_edges = unique_edges(F)
    thin = param.metadata.get("thin")
    segs = [_segments(param.uv, face_edges, ef, fld.matching, param.transition, fam)
            for fam in (0, 1)]
    if thin:                 # the sparse family keeps every m-th line of the lattice
        sparse = segs[thin["family"]]
        keep = sparse["k"] % thin["every"] == 0
        segs[thin["family"]] = {key: x[keep] for key, x in sparse.items()}
    seg = {key: np.concatenate([s[key] for s in segs]) for key in segs[0]}
    if len(seg["face"]) == 0:
        raise ParametrizationError(
            f"no iso-line crosses the mesh: spacing {_spacing_text(param.spacing)} is larger "
            "than the patch")
    X = _crossings(seg)
    N = _lattice_nodes(seg, thin)
    fins = _chain_fins(_pieces(seg, X, N, V, F), len(X.keys), len(X.keys) + len(N.face))
    vt, fin_edges = _fin_vertices(fins, X, N, ef)
    faces = _trace_faces(fin_edges, fins, _boundary_sides(vt, X, V, F, face_edges, ef),
                         vt.face, V, F)
    c = _collapse_short_fins(vt, fin_edges, fins.family, faces, min_edge * min(param.spacings),
                             V, F)
    vt = c.vertices
    Fv = F[vt.face]
    meta = {"face": vt.face, "barycentric": vt.bary,
            "uv": np.einsum("nk,nkc->nc", vt.bary, param.uv[vt.face]),
            "boundary": vt.boundary, "dangling": vt.dangling, "spacing": param.spacing,
            "dropped_chains": fins.dropped_chains, "collapsed_fins": c.n_collapsed}
    return SupportStructure(np.einsum("nk,nkd->nd", vt.bary, V[Fv]),
                            np.einsum("nk,nkd->nd", vt.bary, VB[Fv]), c.faces, c.fin_edges,
                            c.family, metadata=meta)


def _boundary_loops(F, face_edges, ef):
    """Boundary loops as lists of directed edges (a, b) with the mesh on the left."""
    bf, bj = np.nonzero(ef[face_edges, 1] < 0)
    a = F[bf, (bj + 1) % 3]
    b = F[bf, (bj + 2) % 3]
    succ = {}
    for x, y in zip(a.tolist(), b.tolist()):
        succ.setdefault(x, []).append(y)
    seen = set()
    loops = []
    for x0 in a.tolist():
        if (x0, succ[x0][0]) in seen:
            continue
        loop = []
        x = x0
        while True:
            ys = [y for y in succ.get(x, []) if (x, y) not in seen]
            if not ys:
                break
            y = ys[0]
            seen.add((x, y))
            loop.append((x, y))
            x = y
            if x == x0:
                break
        loops.append(loop)
    return loops


def remesh_torsal(congruence, spacing, *, field_kwargs: dict | None = None,
                  param_kwargs: dict | None = None) -> "SupportStructure":
    """Torsal remeshing of a congruence into a support structure (Wang et al. 2013, 4.2, Fig. 8).

    Runs :func:`torsal_frame_field`, :func:`parametrize` and :func:`extract_quads`. The frame
    field is smoothed below half the (smaller) fin spacing (``smoothing = spacing / 2``, see
    :func:`torsal_frame_field`): a quad mesh with that spacing cannot follow the torsal
    directions on finer scales, and face-to-face noise in them (which a strongly weighted
    design term such as f_plane, eq. (9), leaves in the optimized congruence) would otherwise
    show up as dozens of spurious singularities and fold the parametrization.

    Parameters
    ----------
    congruence : Congruence
    spacing : float or (2,) sequence of float
        Fin spacing in model units: one for both families or ``(s0, s1)`` (see
        :func:`parametrize`).
    field_kwargs : dict, optional
        Passed to :func:`torsal_frame_field`; ``{"smoothing": None}`` follows the raw torsal
        directions exactly.
    param_kwargs : dict, optional
        Passed to :func:`parametrize`.

    Returns
    -------
    SupportStructure
        ``metadata`` as in :func:`extract_quads`, plus ``timings`` (seconds per step),
        ``singularities`` (vertex ids of A) and ``param_residual``.

    Examples
    --------
    >>> from torsal.geometry.congruence import Congruence
    >>> from torsal.geometry.surfaces import graph_surface
    >>> c = Congruence.from_normals(graph_surface(lambda x, y: 0.3 * (x**2 - 0.5 * y**2)))
    >>> s = remesh_torsal(c, 0.05)
    >>> len(s.edges) > 700, s.delta_pl < 0.01
    (True, True)
    >>> sparse = remesh_torsal(c, (0.05, 0.1))     # a sparse family 1: half its strips
    >>> [len(s.strips(f)) for f in (0, 1)], [len(sparse.strips(f)) for f in (0, 1)]
    ([20, 20], [20, 10])
    """
    t0 = time.perf_counter()
    fkw = {"smoothing": 0.5 * min(per_family(spacing, "spacing")), **(field_kwargs or {})}
    fld = torsal_frame_field(congruence, **fkw)
    t1 = time.perf_counter()
    p = parametrize(fld, spacing, **(param_kwargs or {}))
    t2 = time.perf_counter()
    s = extract_quads(p, congruence=congruence)
    t3 = time.perf_counter()
    s.metadata.update({"timings": {"frame_field": t1 - t0, "parametrize": t2 - t1, "extract": t3 - t2},
                       "singularities": fld.singularities.tolist(), "param_residual": p.residual,
                       "field_smoothing": fld.metadata["smoothing"],
                       "flipped_faces": int(len(p.flipped))})
    return s
