"""Torsal frame fields: smoothing, combing, matchings and singularities (Wang et al. 2013, 4.2).

The torsal directions of a congruence (eq. (1), :meth:`Congruence.torsal_directions`) give per
face two *lines* (sign-free, not orthogonal): a non-orthogonal frame field in the sense of
libigl's ``FrameField``. Its symmetry group is the dihedral group of order 8 (swap the two
lines and/or flip either sign), represented here by 2x2 signed permutation matrices.

Steps of :func:`torsal_frame_field`:

1. Faces whose torsal directions are undefined (not hyperbolic, eq. (2)), close to a line
   bundle (paper 2.1 remark) or nearly parabolic (the two directions almost coincide) get
   directions from a smoothness energy: the PolyVector representation of Diamanti et al.
   2014 (coefficients ``z1^2 + z2^2`` and ``z1^2 z2^2`` of the per-face complex polynomial
   are invariant under the symmetry group) is interpolated harmonically with the Levi-Civita
   connection of the mesh, the torsal faces held fixed. With a ``smoothing`` length the
   torsal faces are not held fixed but pulled towards their data with a weight
   (:func:`torsal_confidence`), a screened smoothing that removes direction noise below
   that length (see :func:`torsal_frame_field`).
2. The field is combed along a breadth-first dual spanning tree: every face picks the
   permutation and signs that best match its parent (libigl ``comb_frame_field`` does the
   same on the bisector cross field; written by hand here so that the permutation group of
   a *non-orthogonal* line pair is used directly and the dual tree is returned for cutting).
3. The matching of every interior edge after combing (identity on tree edges) and the
   holonomy around every interior vertex give the singularities (libigl
   ``cross_field_mismatch`` / ``find_cross_field_singularities`` work on cross fields; here the
   same is done for the order-8 group, vectorized over faces).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
import scipy.sparse.csgraph as csg
import scipy.sparse.linalg as spla

from .mesh import edge_face_adjacency, face_areas
from torsal.core.errors import TorsalError

__all__ = ["TorsalFrameField", "torsal_frame_field", "torsal_confidence", "face_bases",
           "FrameFieldError"]


class FrameFieldError(TorsalError, ValueError):
    """The torsal frame field cannot be built (e.g. no face has torsal directions)."""


# the 8 signed permutation matrices M with frame_f = M @ frame_g (rows: target vectors)
def _group() -> np.ndarray:
    mats = []
    for perm in ((0, 1), (1, 0)):
        for s0 in (1, -1):
            for s1 in (1, -1):
                m = np.zeros((2, 2), int)
                m[0, perm[0]] = s0
                m[1, perm[1]] = s1
                mats.append(m)
    return np.array(mats)


GROUP = _group()  #: (8, 2, 2) int, index 0 is the identity


def _group_index(m: np.ndarray) -> np.ndarray:
    """Index into GROUP of (..., 2, 2) signed permutation matrices."""
    flat = m.reshape(-1, 4)
    g = GROUP.reshape(8, 4)
    eq = (flat[:, None, :] == g[None]).all(-1)
    return eq.argmax(1).reshape(m.shape[:-2])


def face_bases(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Orthonormal per-face frames ``(b1, b2, n)``, each (F, 3).

    ``b1`` along the face's first edge ``p1 - p0``, ``n`` the unit normal (right-handed with
    the face's winding), ``b2 = n x b1`` (libigl ``local_basis`` convention).
    """
    v = np.asarray(vertices, float)
    f = np.asarray(faces)
    e1 = v[f[:, 1]] - v[f[:, 0]]
    e2 = v[f[:, 2]] - v[f[:, 0]]
    n = np.cross(e1, e2)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    b1 = e1 / np.linalg.norm(e1, axis=1, keepdims=True)
    b2 = np.cross(n, b1)
    return b1, b2, n


@dataclass
class TorsalFrameField:
    """A combed torsal frame field on a triangle mesh.

    Attributes
    ----------
    vertices : (n, 3) float
    faces : (F, 3) int
    directions : (F, 2, 3) float
        Combed unit directions per face (tangent to the face). Row 0 is "family 0".
    from_torsal : (F,) bool
        True where the congruence's torsal directions (eq. (1)) are usable data (kept exactly,
        or with ``smoothing`` the data the field is pulled towards), False where the
        directions were filled in by the smoothness energy alone.
    edges : (E, 2) int
        Unique mesh edges; ``edge_faces`` (E, 2) their faces (-1 on the boundary).
    matching : (E,) int
        Index into :data:`GROUP` of the matching ``M`` with ``frame[f0] ~ M @ frame[f1]`` after
        combing (0 = identity; -1 on boundary edges).
    tree_edge : (E,) bool
        Edges crossed by the dual spanning tree used for combing (matching is identity there).
    singularities : (s,) int
        Interior vertices whose holonomy (product of matchings around the one-ring) is not
        the identity.
    holonomy : (s,) int
        Index into :data:`GROUP` of the holonomy at each singularity (``-I`` = index +-1/2 of
        both line fields, a swap = index +-1/4).
    """

    vertices: np.ndarray
    faces: np.ndarray
    directions: np.ndarray
    from_torsal: np.ndarray
    edges: np.ndarray
    edge_faces: np.ndarray
    matching: np.ndarray
    tree_edge: np.ndarray
    singularities: np.ndarray
    holonomy: np.ndarray
    metadata: dict = field(default_factory=dict)

    def dual_frame(self) -> np.ndarray:
        """Per face the dual frame ``(w1, w2)``, (F, 2, 3): in the face plane with
        ``<w_i, t_j> = delta_ij`` for the combed directions ``t_0, t_1``.

        A function with gradient ``w1`` increases by one along ``t_0`` and is constant along
        ``t_1``: its iso-lines follow family 1.
        """
        t = self.directions
        _, _, n = face_bases(self.vertices, self.faces)
        t0, t1 = t[:, 0], t[:, 1]
        # w1 is orthogonal to t1 (in plane), w2 orthogonal to t0
        p1 = np.cross(n, t1)
        p0 = np.cross(n, t0)
        w1 = p1 / np.einsum("ij,ij->i", p1, t0)[:, None]
        w2 = p0 / np.einsum("ij,ij->i", p0, t1)[:, None]
        return np.stack([w1, w2], axis=1)

    @property
    def is_seamless(self) -> bool:
        """True when every interior edge has the identity matching (a disk-like, singularity-free
        combing: the parametrization needs no cuts)."""
        inner = self.matching >= 0
        return bool((self.matching[inner] == 0).all())


def _edge_transport(vertices, faces, edges, edge_faces, b1, b2):
    """Unit complex ``r`` per interior edge with ``z_in_f0 = r * z_in_f1`` (parallel transport
    across the hinge: the shared edge has the same angle in both faces)."""
    v = np.asarray(vertices, float)
    inner = edge_faces[:, 1] >= 0
    f0 = edge_faces[:, 0]
    f1 = np.where(inner, edge_faces[:, 1], edge_faces[:, 0])
    ev = v[edges[:, 1]] - v[edges[:, 0]]
    a0 = np.einsum("ij,ij->i", ev, b1[f0]) + 1j * np.einsum("ij,ij->i", ev, b2[f0])
    a1 = np.einsum("ij,ij->i", ev, b1[f1]) + 1j * np.einsum("ij,ij->i", ev, b2[f1])
    r = (a0 / np.abs(a0)) / (a1 / np.abs(a1))
    return r, inner


def _best_matching(zf: np.ndarray, zg: np.ndarray) -> np.ndarray:
    """Per pair, the GROUP index of M maximizing alignment of ``M @ zg`` with ``zf``.

    zf, zg : (m, 2) complex unit directions already expressed in the same basis.
    """
    # alignment of line i of f with line j of g
    c = np.real(np.conj(zf)[:, :, None] * zg[:, None, :])  # (m, 2, 2)
    keep = np.abs(c[:, 0, 0]) + np.abs(c[:, 1, 1])
    swap = np.abs(c[:, 0, 1]) + np.abs(c[:, 1, 0])
    use_swap = swap > keep
    s0 = np.where(use_swap, np.sign(c[:, 0, 1]), np.sign(c[:, 0, 0]))
    s1 = np.where(use_swap, np.sign(c[:, 1, 0]), np.sign(c[:, 1, 1]))
    s0 = np.where(s0 == 0, 1, s0)
    s1 = np.where(s1 == 0, 1, s1)
    # GROUP order: perm (id, swap) x s0 (+,-) x s1 (+,-)
    return (use_swap.astype(int) * 4 + (s0 < 0).astype(int) * 2 + (s1 < 0).astype(int))


def _polyvector(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """PolyVector coefficients ``(z1^2 + z2^2, z1^2 z2^2)`` of (F, 2) complex directions."""
    return z[:, 0] ** 2 + z[:, 1] ** 2, z[:, 0] ** 2 * z[:, 1] ** 2


def _polyvector_roots(c1: np.ndarray, c0: np.ndarray) -> np.ndarray:
    """Unit directions (m, 2) complex whose PolyVector coefficients are ``c1, c0`` (up to scale):
    ``z1^2, z2^2`` are the roots of ``w^2 - c1 w + c0``."""
    disc = np.sqrt(c1 ** 2 - 4 * c0 + 0j)
    za = np.sqrt(0.5 * (c1 + disc))
    zb = np.sqrt(0.5 * (c1 - disc))
    # degenerate (both zero): pick an orthogonal pair
    za = np.where(np.abs(za) < 1e-300, 1.0 + 0j, za)
    zb = np.where(np.abs(zb) < 1e-300, 1j * za, zb)
    return np.stack([za / np.abs(za), zb / np.abs(zb)], axis=1)


def _smooth_fill(z, fixed, edges_inner, r_inner, ef_inner, n_faces, *, data_weight=None,
                 edge_weight=None):
    """PolyVector smoothing of a face-based frame field, (F, 2) complex unit directions.

    Minimizes, for each coefficient ``x`` of :func:`_polyvector` (``c1`` transported with
    ``r^2``, ``c0`` with ``r^4``), the connection Dirichlet energy
    ``sum_e omega_e |x_f0 - r_e^p x_f1|^2`` plus ``sum_f mu_f |x_f - x_f^data|^2``.

    Without ``data_weight`` the ``fixed`` faces keep their data exactly and the others are
    interpolated harmonically (``omega = 1``). With ``data_weight`` (F,) (``mu``, zero where
    there are no data) nothing is held fixed: a screened smoothing whose solution is
    ``(L + diag(mu)) x = mu x_data``; ``edge_weight`` (m,) gives ``omega`` per inner edge.
    """
    c1, c0 = _polyvector(z)
    f0, f1 = ef_inner[:, 0], ef_inner[:, 1]
    om = np.ones(len(f0)) if edge_weight is None else np.asarray(edge_weight, float)
    screened = data_weight is not None
    free = np.ones(n_faces, bool) if screened else ~fixed
    if not free.any():
        return z
    fi = np.flatnonzero(free)
    xi = np.flatnonzero(~free)
    sol = []
    for coef, power in ((c1, 2), (c0, 4)):
        rr = r_inner ** power  # coef_in_f0 = rr * coef_in_f1
        # energy sum omega |x_f0 - rr x_f1|^2 -> Hermitian Laplacian
        rows = np.r_[f0, f1, f0, f1]
        cols = np.r_[f0, f1, f1, f0]
        vals = np.r_[om, om, -om * rr, -om * np.conj(rr)]
        L = sp.csr_matrix((vals, (rows, cols)), shape=(n_faces, n_faces))
        if screened:
            mu = np.asarray(data_weight, float)
            sol.append(spla.spsolve((L + sp.diags(mu)).tocsc(), mu * coef))
            continue
        Lff = L[fi][:, fi] + sp.identity(len(fi)) * 1e-10
        out = coef.copy()
        out[fi] = spla.spsolve(Lff.tocsc(), -(L[fi][:, xi] @ coef[xi]))
        sol.append(out)
    out = z.copy()
    out[fi] = _polyvector_roots(sol[0][fi], sol[1][fi])
    return out


def torsal_confidence(congruence) -> np.ndarray:
    """How well each face determines its torsal directions, (F,), in 1/length.

    ``sqrt(c_hyp) / (|a_u x a_v| |e_c|^2)`` with ``c_hyp`` the discriminant of eq. (3)
    (:meth:`Congruence.hyperbolicity`, section 4.1; it scales like ``|e|^4``): invariant under
    the choice of the face's corner order and a common scale of the ``e_i``. For a normal
    congruence it is ``|kappa_1 - kappa_2|``, the anisotropy that defines the principal
    directions (zero at umbilics). An error ``d`` in the coefficients of eq. (1) turns the
    torsal directions by about ``d / confidence``: it vanishes where they are ill-defined
    (parabolic faces, where the two directions coincide, and line bundles) and is 0 on
    non-hyperbolic faces.

    Parameters
    ----------
    congruence : Congruence

    Returns
    -------
    (F,) float, 1/length (model units), >= 0

    Examples
    --------
    >>> from torsal.geometry.congruence import Congruence
    >>> from torsal.geometry.surfaces import graph_surface
    >>> c = Congruence.from_normals(graph_surface(lambda x, y: 0.5 * (x**2 - y**2)))
    >>> round(float(torsal_confidence(c).max()), 2)  # |kappa_1 - kappa_2| = 2 at the origin
    2.0
    """
    dbl = 2.0 * face_areas(congruence.vertices, congruence.faces)   # |a_u x a_v|
    e = np.linalg.norm(congruence.barycenter_directions(), axis=1)
    hyp = np.nan_to_num(congruence.hyperbolicity(), nan=0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.sqrt(np.maximum(hyp, 0.0)) / (dbl * e ** 2)
    return np.where(np.isfinite(s), s, 0.0)


def _screening_weights(V, F, edges, ef_inner, usable, confidence, smoothing):
    """Edge weights ``omega`` (m,), data weights ``mu`` (F,) and confidences ``kappa`` (F,)
    of the screened smoothing.

    ``omega_e = |e| / |c_f0 - c_f1|`` (dual over primal length: the Dirichlet energy of a
    piecewise constant field), ``mu_f = kappa_f area_f / smoothing^2`` with the confidence
    ``kappa_f = min(1, (s_f / median s)^2)`` (inverse variance of the direction, capped so that
    no face is smoothed over less than ``smoothing``), ``kappa = 0`` on unusable faces.
    """
    area = face_areas(V, F)
    bc = V[F].mean(axis=1)
    f0, f1 = ef_inner[:, 0], ef_inner[:, 1]
    el = np.linalg.norm(V[edges[:, 1]] - V[edges[:, 0]], axis=1)
    omega = el / np.maximum(np.linalg.norm(bc[f0] - bc[f1], axis=1), 1e-12 * el)
    s = np.where(usable, confidence, 0.0)
    ref = np.median(s[usable]) if usable.any() else 0.0
    kappa = np.where(usable, np.minimum(1.0, (s / ref) ** 2) if ref > 0 else 1.0, 0.0)
    return omega, kappa * area / smoothing ** 2, kappa


def _check_filled_regions(adj, usable: np.ndarray) -> None:
    """Every face without usable torsal directions must be connected (through such faces)
    to one with them: the fill interpolates from there."""
    free_idx = np.flatnonzero(~usable)
    if not free_idx.size:
        return
    sub = adj[free_idx][:, free_idx]
    ncomp, lab = csg.connected_components(sub, directed=False)
    touches = np.zeros(ncomp, bool)
    nb = (adj + adj.T)[free_idx][:, np.flatnonzero(usable)]
    has_nb = np.asarray(nb.sum(axis=1)).ravel() > 0
    touches[np.unique(lab[has_nb])] = True
    if not touches.all():
        bad = free_idx[lab == np.flatnonzero(~touches)[0]]
        raise FrameFieldError(
            f"faces {bad[:10].tolist()} (a region of {bad.size} faces without torsal directions) "
            "are not connected to any face with torsal directions; the mesh has a component "
            "that is a line bundle or non-hyperbolic everywhere"
        )


class _Combing(NamedTuple):
    frames: np.ndarray       # (F, 2) complex: combed directions in each face's basis
    tree_edge: np.ndarray    # (nE,) bool: edges of the dual spanning tree


def _comb(z: np.ndarray, adj, edges, ef, inner_edges, r, root: int) -> _Combing:
    """Comb the frames along a BFS dual spanning tree from ``root``: each child's frame is
    permuted (a signed permutation of GROUP) to best match its parent's."""
    nF = len(z)
    ei = inner_edges
    ncomp, _ = csg.connected_components(adj, directed=False)
    if ncomp > 1:
        raise FrameFieldError(f"the mesh has {ncomp} face-connected components; remesh each separately")
    order, pred = csg.breadth_first_order(adj + adj.T, root, directed=False, return_predecessors=True)
    depth = np.zeros(nF, int)
    for fidx in order[1:]:
        depth[fidx] = depth[pred[fidx]] + 1
    # transport factor from a child g into its parent p: z_in_p = rho * z_in_g, from a
    # lookup of the inner edge of each (p, g) pair
    lut = sp.csr_matrix((np.arange(1, len(ei) + 1), (ef[ei, 0], ef[ei, 1])), shape=(nF, nF))
    lut = lut + lut.T
    child = order[1:]
    par = pred[child]
    ee = ei[np.asarray(lut[par, child]).ravel() - 1]
    rho_full = np.ones(nF, complex)
    rho_full[child] = np.where(ef[ee, 0] == par, r[ee], np.conj(r[ee]))  # r maps f1 -> f0
    zc = z.copy()
    for d in range(1, depth.max() + 1 if nF > 1 else 1):
        fs = np.flatnonzero(depth == d)
        g = _best_matching(zc[pred[fs]], zc[fs] * rho_full[fs][:, None])
        zc[fs] = np.einsum("mij,mj->mi", GROUP[g].astype(complex), zc[fs])
    tree_edge = np.zeros(len(edges), bool)
    tree_edge[ee] = True
    return _Combing(zc, tree_edge)


def torsal_frame_field(congruence, *, bundle_tol: float = 1e-3, min_angle_deg: float = 10.0,
                       root: int | None = None, smoothing: float | None = None) -> TorsalFrameField:
    """Per face the two torsal directions of a congruence, filled, combed, with singularities.

    Wang et al. 2013, section 4.2 (Fig. 8a): the frame field of torsal directions at face
    barycenters (eq. (1)); faces that are not hyperbolic (eq. (2)), near a line bundle
    (:meth:`Congruence.bundle_deviation` below ``bundle_tol``, paper 2.1 remark) or nearly
    parabolic (torsal angle below ``min_angle_deg``) get directions from a smoothness energy.

    Parameters
    ----------
    congruence : Congruence
    bundle_tol : float, default 1e-3
        Dimensionless bundle deviation below which torsal directions are not trusted.
    min_angle_deg : float, default 10
        Faces whose two torsal directions make a smaller angle (degrees) are filled in.
    root : int, optional
        Root face of the combing tree (default: the torsal face with the largest torsal angle).
    smoothing : float, optional
        Length in model units below which the field is smoothed. Default (None or 0): the
        torsal faces keep their directions exactly. Otherwise every face is pulled towards
        its torsal directions with weight ``kappa_f area_f / smoothing^2`` against the
        connection Dirichlet energy of the PolyVector coefficients (a screened Poisson
        problem: variation on scales below ``smoothing`` is damped, by ``1 / (1 + (2 pi
        smoothing / wavelength)^2)``), ``kappa_f`` in [0, 1] from :func:`torsal_confidence`
        (faces whose directions are ill-defined, e.g. near-parabolic, are smoothed more).
        The paper remeshes along the torsal directions (4.2); a quad mesh of fin spacing
        ``h`` cannot follow them on scales below ``h``, and where the optimized congruence
        carries face-to-face noise in its torsal directions (strong design terms such as
        f_plane fighting f_fair, eq. (9)) the raw field has spurious singularities that fold
        the parametrization. :func:`remesh_torsal` uses ``h / 2``.

    Returns
    -------
    TorsalFrameField

    Raises
    ------
    FrameFieldError
        If no face has usable torsal directions, or a region of filled faces has no torsal
        neighbour to interpolate from.

    Examples
    --------
    >>> from torsal.geometry.congruence import Congruence
    >>> from torsal.geometry.surfaces import graph_surface
    >>> c = Congruence.from_normals(graph_surface(lambda x, y: 0.3 * (x**2 - 0.5 * y**2)))
    >>> ff = torsal_frame_field(c)
    >>> ff.is_seamless, len(ff.singularities)
    (True, 0)
    """
    V = np.asarray(congruence.vertices, float)
    F = np.asarray(congruence.faces, np.int64)
    nF = len(F)
    t = congruence.torsal_directions()
    ang = congruence.torsal_angle()
    dev = congruence.bundle_deviation()
    usable = np.isfinite(t).all(axis=(1, 2)) & (dev > bundle_tol) & (ang >= min_angle_deg)
    if not usable.any():
        raise FrameFieldError(
            "no face has usable torsal directions (all faces are non-hyperbolic, near a line bundle "
            f"with bundle deviation <= {bundle_tol}, or have torsal angle < {min_angle_deg} deg); "
            "optimize the congruence for hyperbolicity (c_hyp) or lower bundle_tol/min_angle_deg"
        )
    b1, b2, nrm = face_bases(V, F)
    edges, ef = edge_face_adjacency(F)
    r, inner = _edge_transport(V, F, edges, ef, b1, b2)
    tt = np.where(usable[:, None, None], t, 0.0)
    z = np.einsum("fkj,fj->fk", tt, b1) + 1j * np.einsum("fkj,fj->fk", tt, b2)
    z = np.where(usable[:, None], z / np.where(np.abs(z) > 0, np.abs(z), 1.0), 1.0 + 0j)
    ei = np.flatnonzero(inner)
    adj = sp.csr_matrix((np.ones(len(ei)), (ef[ei, 0], ef[ei, 1])), shape=(nF, nF))
    _check_filled_regions(adj, usable)
    kappa = usable.astype(float)
    if smoothing:
        if not smoothing > 0:
            raise ValueError(f"smoothing must be a positive length in model units, got {smoothing}")
        omega, mu, kappa = _screening_weights(V, F, edges[ei], ef[ei], usable,
                                              torsal_confidence(congruence), float(smoothing))
        z = _smooth_fill(z, usable, edges[ei], r[ei], ef[ei], nF, data_weight=mu, edge_weight=omega)
    else:
        z = _smooth_fill(z, usable, edges[ei], r[ei], ef[ei], nF)
    if root is None:
        root = int(np.argmax(np.where(usable, ang, -1.0)))
    comb = _comb(z, adj, edges, ef, ei, r, root)
    zc = comb.frames
    # ---- matchings after combing: frame[f0] ~ M frame[f1]
    matching = np.full(len(edges), -1, int)
    matching[ei] = _best_matching(zc[ef[ei, 0]], zc[ef[ei, 1]] * r[ei][:, None])
    if np.any(matching[comb.tree_edge] != 0):
        raise FrameFieldError("internal error: combing left a non-identity matching on a tree edge")
    directions = (np.real(zc)[..., None] * b1[:, None, :] + np.imag(zc)[..., None] * b2[:, None, :])
    sing, hol = _singularities(F, edges, ef, matching, len(V))
    return TorsalFrameField(
        vertices=V, faces=F, directions=directions, from_torsal=usable, edges=edges, edge_faces=ef,
        matching=matching, tree_edge=comb.tree_edge, singularities=sing, holonomy=hol,
        metadata={"root": root, "filled_faces": int((~usable).sum()),
                  "mismatched_edges": int((matching > 0).sum()),
                  "smoothing": float(smoothing) if smoothing else None,
                  "confidence_weight": kappa},
    )


def _singularities(F, edges, ef, matching, n_vertices):
    """Interior vertices with non-identity holonomy. Only vertices touching a mismatched edge
    can be singular; their one-rings are walked explicitly."""
    bad_e = np.flatnonzero(matching > 0)
    if bad_e.size == 0:
        return np.zeros(0, int), np.zeros(0, int)
    boundary = np.zeros(n_vertices, bool)
    boundary[edges[ef[:, 1] < 0].ravel()] = True
    cand = np.unique(edges[bad_e].ravel())
    cand = cand[~boundary[cand]]
    # edge lookup
    emap = {(int(a), int(b)): k for k, (a, b) in enumerate(edges)}
    sing, hol = [], []
    flat = F.ravel()
    order = np.argsort(flat, kind="stable")
    starts = np.searchsorted(flat[order], cand)
    ends = np.searchsorted(flat[order], cand, side="right")
    vf = {int(c): (order[s:e] // 3).tolist() for c, s, e in zip(cand, starts, ends)}
    for vtx in cand:
        faces_v = vf[int(vtx)]
        # walk the ring: start at a face, go to the neighbour across the edge (vtx, next corner)
        start = faces_v[0]
        cur = start
        H = np.eye(2, dtype=int)
        ok = True
        for _ in range(len(faces_v)):
            tri = F[cur]
            k = int(np.flatnonzero(tri == vtx)[0])
            nxt_v = int(tri[(k + 1) % 3])
            a, b = min(vtx, nxt_v), max(vtx, nxt_v)
            e = emap[(int(a), int(b))]
            f0, f1 = ef[e]
            if f1 < 0:
                ok = False
                break
            other = f1 if f0 == cur else f0
            M = GROUP[matching[e]]  # frame[f0] = M frame[f1]
            # transformation taking frame coordinates of `cur` to those of `other`
            step = np.linalg.inv(M).round().astype(int) if cur == f0 else M
            H = step @ H
            cur = other
            if cur == start:
                break
        if ok and not np.array_equal(H, np.eye(2, dtype=int)):
            sing.append(int(vtx))
            hol.append(int(_group_index(H[None])[0]))
    return np.array(sing, int), np.array(hol, int)
