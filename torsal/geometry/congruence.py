"""Discrete line congruences over triangle meshes (Wang et al. 2013, sections 2.2 and 3.2).

A congruence is a triangle mesh A (vertices ``a_i``) with a line direction ``e_i`` at every
vertex; the lines are ``L_i = a_i + lambda e_i`` and mesh B has vertices ``b_i = a_i + e_i``.
Inside a face the correspondence A <-> B is linear, so the congruence is the affine one of
eq. (4)::

    x(u, v, lambda) = a(u, v) + lambda e(u, v)
    a(u, v) = a_i + u a_ji + v a_ki,   e(u, v) = e_i + u e_ji + v e_ki

with ``a_ji = a_j - a_i`` and ``(i, j, k)`` the face's corners in order. Every per-face quantity
is evaluated at the face barycenter ``u = v = 1/3``, as the paper does, so there
``a = a_c`` (centroid of the face of A) and ``e = e_c`` (mean of the three ``e_i``).

Index ``t`` in 0, 1 pairs everything: ``torsal_directions()[:, t]`` is the direction whose
developable has its edge of regression at ``focal_points()[:, t]`` (focal parameter
``focal_parameters()[:, t]``, sorted ascending) and whose tangent plane along the line is
``torsal_planes()[:, t]``. The pairing follows from differentiating ``x(u(t), v(t), lambda)``:
the ruled surface along the direction ``(u_t, v_t)`` is singular where
``a_t + lambda e_t`` is parallel to ``e``, which gives one root of eq. (3) per root of eq. (1).

The kernels (module-level functions) take ``(F, 3)`` arrays of face-frame vectors and are
fully vectorized; :class:`Congruence` holds a mesh and its directions and caches them.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .mesh import (
    MAX_COORDINATE,
    MeshError,
    average_edge_length,
    validate_mesh,
    vertex_normals,
)

__all__ = [
    "Congruence",
    "FaceFrame",
    "face_frame",
    "torsal_coefficients",
    "focal_coefficients",
    "solve_torsal_directions",
    "solve_focal_parameters",
    "normality_residual",
    "direction_spread",
]

_EPS = np.finfo(float).eps
#: A line direction this short (times the longest, or times one model unit) is zero.
ZERO_DIRECTION_RTOL = 1e-12


def _dot(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", x, y)


# Hot-path arithmetic on components: vectors as tuples (x, y, z) of 1-D arrays. Frames are
# stored column-major, so each component is contiguous; this is several times faster than
# np.cross / einsum over (F, 3) rows on million-face meshes.
def _c(x: np.ndarray) -> tuple:
    return x[..., 0], x[..., 1], x[..., 2]


def _cross3(a: tuple, b: tuple) -> tuple:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot3(a: tuple, b: tuple) -> np.ndarray:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _lin3(s: np.ndarray, a: tuple, t: np.ndarray, b: tuple) -> tuple:
    """s a + t b, componentwise."""
    return (s * a[0] + t * b[0], s * a[1] + t * b[1], s * a[2] + t * b[2])


def _stack3(a: tuple) -> np.ndarray:
    """Components back to an (F, 3) array (column-major)."""
    return np.stack(a, axis=0).T


def _norm(x: np.ndarray) -> np.ndarray:
    return np.sqrt(_dot(x, x))


@dataclass(frozen=True)
class FaceFrame:
    """The affine congruence of eq. (4) at one point per face, all (F, 3).

    ``a_u = a_j - a_i``, ``a_v = a_k - a_i``, ``e_u = e_j - e_i``, ``e_v = e_k - e_i``;
    ``a`` and ``e`` are the point of A and the line direction at the evaluation point.
    """

    a: np.ndarray
    e: np.ndarray
    a_u: np.ndarray
    a_v: np.ndarray
    e_u: np.ndarray
    e_v: np.ndarray


def face_frame(vertices, faces, directions, barycentric=None) -> FaceFrame:
    """Build the per-face affine frame of eq. (4).

    Parameters
    ----------
    vertices : (n, 3) float
        Vertices a_i of mesh A, model units.
    faces : (F, 3) int
    directions : (n, 3) float
        Line directions e_i (any length; the paper uses unit length).
    barycentric : (F, 3) or (3,) float, optional
        Point of evaluation in each face; default the barycenter (1/3, 1/3, 1/3).

    Returns
    -------
    FaceFrame
    """
    vt = np.asarray(vertices, dtype=float).T  # (3, n): gathers give contiguous components
    dt = np.asarray(directions, dtype=float).T
    f = np.asarray(faces)
    a0, a1, a2 = vt[:, f[:, 0]], vt[:, f[:, 1]], vt[:, f[:, 2]]
    e0, e1, e2 = dt[:, f[:, 0]], dt[:, f[:, 1]], dt[:, f[:, 2]]
    if barycentric is None:
        a = (a0 + a1 + a2) / 3.0
        e = (e0 + e1 + e2) / 3.0
    else:
        w = np.broadcast_to(np.asarray(barycentric, dtype=float), (len(f), 3)).T
        a = w[0] * a0 + w[1] * a1 + w[2] * a2
        e = w[0] * e0 + w[1] * e1 + w[2] * e2
    # (F, 3) views of (3, F) arrays: column-major, each component contiguous
    return FaceFrame(a=a.T, e=e.T, a_u=(a1 - a0).T, a_v=(a2 - a0).T, e_u=(e1 - e0).T,
                     e_v=(e2 - e0).T)


def _frame_crosses(fr: FaceFrame) -> dict:
    """The four cross products with e that eqs. (1), (3) and (7) share, as components."""
    e = _c(fr.e)
    return {k: _cross3(_c(getattr(fr, k)), e) for k in ("a_u", "a_v", "e_u", "e_v")}


def torsal_coefficients(fr: FaceFrame, crosses: dict | None = None) -> np.ndarray:
    """Coefficients (gamma_0, gamma_1, gamma_2) of eq. (1), (F, 3).

    Wang et al. 2013, eq. (1)::

        gamma_0 = [e_u, a_u, e],  2 gamma_1 = [e_u, a_v, e] + [e_v, a_u, e],  gamma_2 = [e_v, a_v, e]

    A direction ``u_t a_u + v_t a_v`` is torsal iff
    ``gamma_0 u_t^2 + 2 gamma_1 u_t v_t + gamma_2 v_t^2 = 0``.
    Units: length * |e|^3 (length^1 for unit directions).
    """
    x = crosses or _frame_crosses(fr)
    e_u, e_v, x_au, x_av = _c(fr.e_u), _c(fr.e_v), x["a_u"], x["a_v"]
    g0 = _dot3(e_u, x_au)
    g1 = 0.5 * (_dot3(e_u, x_av) + _dot3(e_v, x_au))
    g2 = _dot3(e_v, x_av)
    return np.stack([g0, g1, g2], axis=-1)


def focal_coefficients(fr: FaceFrame, crosses: dict | None = None) -> np.ndarray:
    """Coefficients (c_2, c_1, c_0) of the focal quadratic eq. (3), (F, 3).

    Wang et al. 2013, eq. (3): ``c_2 lambda^2 + c_1 lambda + c_0 = 0`` with
    ``c_2 = [e_u, e_v, e]``, ``c_1 = [a_u, e_v, e] + [e_u, a_v, e]``, ``c_0 = [a_u, a_v, e]``.
    Its discriminant ``c_1^2 - 4 c_2 c_0`` is eq. (2) / c_hyp of section 4.1.
    """
    x = crosses or _frame_crosses(fr)
    e_u, a_u, x_ev, x_av = _c(fr.e_u), _c(fr.a_u), x["e_v"], x["a_v"]
    c2 = _dot3(e_u, x_ev)
    c1 = _dot3(a_u, x_ev) + _dot3(e_u, x_av)
    c0 = _dot3(a_u, x_av)
    return np.stack([c2, c1, c0], axis=-1)


def _discriminant(c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Discriminant of eq. (3) and the size of its rounding error."""
    c2, c1, c0 = c[..., 0], c[..., 1], c[..., 2]
    disc = c1 * c1 - 4.0 * c2 * c0
    tol = 64.0 * _EPS * (c1 * c1 + 4.0 * np.abs(c2 * c0))
    return disc, tol


def solve_focal_parameters(c: np.ndarray, *, infinity_rtol: float = 1e-10,
                           scale: np.ndarray | None = None) -> np.ndarray:
    """Roots lambda of eq. (3), sorted ascending, (F, 2).

    Uses the cancellation-free form ``q = -(c_1 + sign(c_1) sqrt(D)) / 2``, roots ``q / c_2``
    and ``c_0 / q``. A root whose leading coefficient vanishes (``|c_2|`` below
    ``infinity_rtol * scale``) is a focal point at infinity and is returned as ``+inf``
    (a cylinder's rulings). ``D`` within rounding of zero is a double root; ``D < 0`` gives NaN.

    Examples
    --------
    >>> solve_focal_parameters(np.array([[1.0, 4.0, 4.0], [0.0, 1.0, 2.0]]))
    array([[-2., -2.],
           [-2., inf]])

    Parameters
    ----------
    c : (F, 3) float
        ``(c_2, c_1, c_0)`` from :func:`focal_coefficients`.
    infinity_rtol : float
        Relative size of ``c_2`` below which the quadratic degenerates.
    scale : (F,) float, optional
        Natural size of ``c_2`` (``|e_u| |e_v| |e|``); without it only ``c_2 == 0`` exactly
        counts as degenerate.
    """
    c2, c1, c0 = c[..., 0], c[..., 1], c[..., 2]
    disc, tol = _discriminant(c)
    hyperbolic = disc >= -tol
    # a discriminant within rounding of zero is a double root (a bundle): taking its square
    # root would turn rounding noise of size eps into a root error of size sqrt(eps)
    sq = np.sqrt(np.where(disc > tol, disc, 0.0))
    sign = np.where(c1 >= 0, 1.0, -1.0)
    q = -0.5 * (c1 + sign * sq)
    degenerate = np.abs(c2) <= (infinity_rtol * scale if scale is not None else 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        r1 = np.where(degenerate, np.inf, q / np.where(degenerate, 1.0, c2))
        r2 = np.where(q != 0, c0 / np.where(q != 0, q, 1.0), np.inf)
    # q == 0 with c2 != 0 means c1 == 0 and c0 == 0: a double root at 0
    r2 = np.where((q == 0) & ~degenerate, 0.0, r2)
    r1 = np.where(np.isinf(r1), np.inf, r1)  # a point at infinity has no sign
    r2 = np.where(np.isinf(r2), np.inf, r2)
    roots = np.sort(np.stack([r1, r2], axis=-1), axis=-1)
    roots[~hyperbolic] = np.nan
    return roots


def solve_torsal_directions(fr: FaceFrame, gamma: np.ndarray) -> np.ndarray:
    """The two solutions ``u_t : v_t`` of eq. (1) as parameter vectors, (F, 2, 2), unnormalized.

    Cancellation-free: with ``q = -(gamma_1 + sign(gamma_1) sqrt(gamma_1^2 - gamma_0 gamma_2))``
    the directions are ``(q, gamma_0)`` and ``(gamma_2, q)``; when one of them vanishes
    (a double root) the other is used for both. A negative discriminant is clamped to zero
    (callers mask non-hyperbolic faces by eq. (2)).
    """
    g0, g1, g2 = gamma[..., 0], gamma[..., 1], gamma[..., 2]
    d = np.maximum(g1 * g1 - g0 * g2, 0.0)
    sign = np.where(g1 >= 0, 1.0, -1.0)
    q = -(g1 + sign * np.sqrt(d))
    uv1 = np.stack([q, g0], axis=-1)
    uv2 = np.stack([g2, q], axis=-1)
    n1, n2 = _norm(uv1), _norm(uv2)
    uv1 = np.where((n1 == 0)[..., None], uv2, uv1)
    uv2 = np.where((n2 == 0)[..., None], uv1, uv2)
    return np.stack([uv1, uv2], axis=-2)


def _paired_focal_parameter(e: tuple, a_t: tuple, e_t: tuple) -> np.ndarray:
    """lambda where ``a_t + lambda e_t`` is parallel to ``e`` (components): the regression
    point of the developable through a torsal direction (least squares orthogonal to e)."""
    p = _cross3(a_t, e)
    q = _cross3(e_t, e)
    qq = _dot3(q, q)
    at_infinity = qq <= (1e-20 * _dot3(p, p))
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = -_dot3(p, q) / np.where(at_infinity, 1.0, qq)
    return np.where(at_infinity, np.inf, lam)


def normality_residual(fr: FaceFrame, crosses: dict | None = None) -> np.ndarray:
    """Residual of the discrete normality condition, eq. (7), (F,).

    Wang et al. 2013, eq. (7) with ``(i, j, k)`` the face's corners::

        r = <a_ij x e_c, e_ik x e_c> - <a_ik x e_c, e_ij x e_c>

    Zero iff the torsal planes at the barycenter are orthogonal (Prop. 1). Units:
    length * |e|^3. This is the quantity squared in f_norm (section 4.1).
    """
    x = crosses or _frame_crosses(fr)
    return _dot3(x["a_u"], x["e_v"]) - _dot3(x["a_v"], x["e_u"])


def direction_spread(directions: np.ndarray) -> float:
    """The widest angle between a line and the lines' mean direction, degrees.

    Near 0 the lines are nearly parallel: every face is close to a bundle at infinity. The
    optimized congruences of Fig. 12 rows 7a and 7b end within 0.2 degrees of parallel (from
    22), row 11's fins within 7 (from 38): their energies reach zero there (examples/README.md).

    Parameters
    ----------
    directions : (n, 3) array
        Line directions (any length but zero; the sign of a direction is kept).

    Returns
    -------
    float
        Degrees in [0, 180]; NaN for no lines or a zero mean direction.

    Examples
    --------
    >>> import numpy as np
    >>> d = np.array([[0, 0, 1.0], [0, np.sin(np.radians(20)), np.cos(np.radians(20))]])
    >>> round(direction_spread(d), 6)       # the mean lies halfway: 10 degrees from each
    10.0
    """
    d = np.asarray(directions, dtype=float).reshape(-1, 3)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    m = d.sum(axis=0)
    norm = float(np.linalg.norm(m))
    if d.shape[0] == 0 or norm <= ZERO_DIRECTION_RTOL * d.shape[0]:
        return float("nan")
    return float(np.degrees(np.arccos(np.clip(d @ (m / norm), -1.0, 1.0))).max())


def _as_arrays(mesh) -> tuple[np.ndarray, np.ndarray]:
    if hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        return np.asarray(mesh.vertices, dtype=float), np.asarray(mesh.faces, dtype=np.int64)
    if isinstance(mesh, (tuple, list)) and len(mesh) == 2:
        return np.asarray(mesh[0], dtype=float), np.asarray(mesh[1], dtype=np.int64)
    raise TypeError("expected a trimesh.Trimesh or a (vertices, faces) pair")


class Congruence:
    """A discrete line congruence: mesh A with a line ``a_i + lambda e_i`` at every vertex.

    Wang et al. 2013, section 2.2. All per-face quantities are evaluated at face
    barycenters and vectorized over faces; results are cached (the object is immutable).

    Parameters
    ----------
    vertices : (n, 3) float
        Vertices ``a_i`` of mesh A in model units.
    faces : (F, 3) int
        Consistently oriented, manifold triangles (validated).
    directions : (n, 3) float
        Line directions ``e_i`` (B has vertices ``a_i + e_i``); need not be unit.
    bundle_rtol : float, default 1e-8
        A face whose eq. (1) coefficients are all below ``bundle_rtol`` times their natural
        size (``|a_u| |e_u| |e|``) is a line bundle: every direction is torsal.

    Examples
    --------
    >>> import trimesh
    >>> sphere = trimesh.creation.icosphere(subdivisions=2, radius=2.0)
    >>> c = Congruence(sphere.vertices, sphere.faces, sphere.vertices / 2.0)
    >>> bool(c.is_bundle().all()), float(np.abs(c.focal_parameters() + 2.0).max()) < 1e-9
    (True, True)
    """

    def __init__(self, vertices, faces, directions, *, bundle_rtol: float = 1e-8):
        v = np.array(vertices, dtype=float)
        f = np.array(faces, dtype=np.int64)
        validate_mesh(v, f)
        v.flags.writeable = f.flags.writeable = False
        self._v, self._f = v, f
        self._set_directions(directions)
        self.bundle_rtol = float(bundle_rtol)

    def with_directions(self, directions) -> "Congruence":
        """The congruence on the same mesh with other ``directions`` (n, 3).

        The mesh is shared, not validated again (an optimizer measures every iterate this
        way); the directions are checked as in the constructor.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> c = Congruence.from_normals(facade_patch(nu=4, nv=3))
        >>> c.with_directions(-c.directions).vertices is c.vertices
        True
        """
        out = object.__new__(type(self))
        out._v, out._f, out.bundle_rtol = self._v, self._f, self.bundle_rtol
        out.__dict__["delta"] = self.delta       # a property of the mesh alone (cached)
        out._set_directions(directions)
        return out

    def _set_directions(self, directions) -> None:
        v = self._v
        d = np.array(directions, dtype=float)
        if d.shape != v.shape:
            raise ValueError(
                f"directions must have one row per vertex, shape {v.shape}, got {d.shape}"
            )
        bad = np.flatnonzero(~np.isfinite(d).all(axis=1))
        if bad.size:
            raise ValueError(f"directions of vertices {bad[:10].tolist()} are NaN or infinite")
        big = np.abs(d).max(axis=1)
        huge = np.flatnonzero(big > MAX_COORDINATE)
        if huge.size:  # squared they overflow: such a row is not zero, it is out of range
            raise ValueError(
                f"directions of vertices {huge[:10].tolist()} have components up to "
                f"{big.max():.3g}, beyond {MAX_COORDINATE:g}: their squares overflow; scale them "
                "(e.g. to unit length)")
        length = _norm(d)
        zero = np.flatnonzero(length <= ZERO_DIRECTION_RTOL * max(1.0, float(length.max())))
        if zero.size:
            raise ValueError(
                f"directions of vertices {zero[:10].tolist()} are zero vectors (length "
                f"{length[zero].max():.3g}); a line needs a direction"
            )
        d.flags.writeable = False
        self._d = d

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_normals(cls, mesh, **kwargs) -> "Congruence":
        """The normal congruence of A: e_i = area-weighted unit vertex normal.

        ``mesh`` is a ``trimesh.Trimesh`` or a ``(vertices, faces)`` pair.
        """
        v, f = _as_arrays(mesh)
        validate_mesh(v, f)
        n = vertex_normals(v, f)
        bad = np.flatnonzero(~np.isfinite(n).all(axis=1))
        if bad.size:
            raise MeshError(f"vertices {bad[:10].tolist()} have no normal: the areas of their faces "
                            "cancel (the surface folds back onto itself there); fix the mesh or "
                            "give line directions")
        return cls(v, f, n, **kwargs)

    @classmethod
    def from_mesh_pair(cls, mesh_a, mesh_b, **kwargs) -> "Congruence":
        """The congruence of lines a_i b_i joining corresponding vertices of A and B.

        A and B must have the same faces (combinatorially equivalent, paper 2.2).
        """
        va, fa = _as_arrays(mesh_a)
        vb, fb = _as_arrays(mesh_b)
        if va.shape != vb.shape or fa.shape != fb.shape or not np.array_equal(fa, fb):
            raise MeshError(
                "meshes A and B must be combinatorially equivalent (same vertex count and faces); "
                f"got {va.shape[0]}/{fa.shape[0]} and {vb.shape[0]}/{fb.shape[0]} vertices/faces"
            )
        return cls(va, fa, vb - va, **kwargs)

    # ------------------------------------------------------------------ data
    @property
    def vertices(self) -> np.ndarray:
        """Vertices a_i of A, (n, 3)."""
        return self._v

    @property
    def faces(self) -> np.ndarray:
        """Triangles of A (and B), (F, 3)."""
        return self._f

    @property
    def directions(self) -> np.ndarray:
        """Line directions e_i, (n, 3)."""
        return self._d

    @property
    def vertices_b(self) -> np.ndarray:
        """Vertices b_i = a_i + e_i of mesh B, (n, 3)."""
        return self._v + self._d

    @cached_property
    def delta(self) -> float:
        """Average edge length of A (model units), the paper's normalizing length."""
        return average_edge_length(self._v, self._f)

    @cached_property
    def _frame(self) -> FaceFrame:
        return face_frame(self._v, self._f, self._d)

    @cached_property
    def _norms(self) -> dict:
        fr = self._frame
        return {k: np.sqrt(_dot3(_c(getattr(fr, k)), _c(getattr(fr, k))))
                for k in ("a_u", "a_v", "e_u", "e_v", "e")}

    @cached_property
    def _crosses(self) -> dict:
        return _frame_crosses(self._frame)

    @cached_property
    def _gamma(self) -> np.ndarray:
        return torsal_coefficients(self._frame, self._crosses)

    @cached_property
    def _focal_c(self) -> np.ndarray:
        return focal_coefficients(self._frame, self._crosses)

    @cached_property
    def _disc(self) -> tuple[np.ndarray, np.ndarray]:
        return _discriminant(self._focal_c)

    @cached_property
    def _lambda(self) -> np.ndarray:
        n = self._norms
        lam = solve_focal_parameters(self._focal_c, scale=n["e_u"] * n["e_v"] * n["e"])
        lam.flags.writeable = False
        return lam

    def barycenters(self) -> np.ndarray:
        """Face barycenters a_c of A, (F, 3)."""
        return self._frame.a.copy()

    def barycenter_directions(self) -> np.ndarray:
        """Line directions e_c at the face barycenters (mean of the corners' e_i), (F, 3)."""
        return self._frame.e.copy()

    # ------------------------------------------------------------------ per-face quantities
    def hyperbolicity(self) -> np.ndarray:
        """c_hyp of section 4.1 (the discriminant of eq. (3), i.e. eq. (2)), (F,).

        ``>= 0`` where the face has two (real) torsal directions. Units length^2 |e|^6.
        """
        return self._disc[0].copy()

    def is_hyperbolic(self) -> np.ndarray:
        """(F,) bool: eq. (2) holds (up to rounding), so torsal directions are real."""
        disc, tol = self._disc
        return disc >= -tol

    def bundle_deviation(self) -> np.ndarray:
        """How far each face is from a line bundle, (F,), dimensionless.

        ``max |gamma_i|`` of eq. (1) divided by ``max(|a_u|,|a_v|) max(|e_u|,|e_v|) |e|``;
        zero for an exact bundle (all directions torsal, paper 2.1 remark), where torsal
        directions are undefined. Parallel lines (``e_u = e_v = 0``) count as a bundle.
        """
        n = self._norms
        scale = np.maximum(n["a_u"], n["a_v"]) * np.maximum(n["e_u"], n["e_v"]) * n["e"]
        g = np.abs(self._gamma).max(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(scale > 0, g / np.where(scale > 0, scale, 1.0), 0.0)

    def is_bundle(self) -> np.ndarray:
        """(F,) bool: the face is a line bundle (within ``bundle_rtol``), see :meth:`bundle_deviation`."""
        return self.bundle_deviation() <= self.bundle_rtol

    @cached_property
    def _torsal(self) -> tuple[np.ndarray, np.ndarray]:
        fr = self._frame
        uv = solve_torsal_directions(fr, self._gamma)  # (F, 2, 2)
        e, a_u, a_v, e_u, e_v = _c(fr.e), _c(fr.a_u), _c(fr.a_v), _c(fr.e_u), _c(fr.e_v)
        dirs, lams = [], []
        for k in (0, 1):
            u, v = uv[:, k, 0], uv[:, k, 1]
            a_t = _lin3(u, a_u, v, a_v)
            lams.append(_paired_focal_parameter(e, a_t, _lin3(u, e_u, v, e_v)))
            dirs.append(a_t)
        # order the pair like the sorted focal parameters (inf last)
        swap = lams[0] > lams[1]
        invalid = ~self.is_hyperbolic() | self.is_bundle()
        t = np.empty((len(self._f), 2, 3))
        for k in (0, 1):
            d = tuple(np.where(swap, dirs[1 - k][i], dirs[k][i]) for i in range(3))
            with np.errstate(divide="ignore", invalid="ignore"):  # bundles: zero vectors, masked
                inv_len = 1.0 / np.sqrt(_dot3(d, d))
                for i in range(3):
                    t[:, k, i] = np.where(invalid, np.nan, d[i] * inv_len)
        return t, invalid

    def torsal_directions(self) -> np.ndarray:
        """The two torsal directions at each face barycenter, (F, 2, 3), unit length.

        Wang et al. 2013, eq. (1): the solutions ``u_t : v_t`` mapped to 3D as
        ``u_t a_u + v_t a_v`` (tangent to A). Row ``t`` pairs with ``focal_parameters()[:, t]``.
        NaN rows where the face is not hyperbolic (eq. (2) < 0) or is a line bundle
        (every direction torsal; see :meth:`is_bundle`). The sign of each direction is arbitrary.
        """
        return self._torsal[0].copy()

    def focal_parameters(self) -> np.ndarray:
        """Roots lambda of eq. (3), (F, 2), sorted ascending.

        Focal point t is ``a_c + lambda_t e_c``. ``+inf`` marks a focal point at infinity
        (the quadratic degenerates, as for a cylinder's rulings); NaN where not hyperbolic.
        Units: multiples of ``e_c`` (model units when directions are unit vectors).
        """
        return self._lambda.copy()

    def focal_points(self) -> np.ndarray:
        """Focal points ``a_c + lambda_t e_c``, (F, 2, 3), paired with :meth:`torsal_directions`.

        Point t is the edge-of-regression point of the developable through torsal
        direction t. Points at infinity are ``+inf`` in all coordinates; NaN where not hyperbolic.
        """
        lam = self._lambda
        fr = self._frame
        finite = np.isfinite(lam)
        safe = np.where(finite, lam, 0.0)
        p = fr.a[:, None, :] + safe[..., None] * fr.e[:, None, :]
        p[np.isinf(lam)] = np.inf
        p[np.isnan(lam)] = np.nan
        return p

    def torsal_planes(self) -> np.ndarray:
        """Unit normals of the two torsal planes, (F, 2, 3).

        Plane t is spanned by the line direction ``e_c`` and torsal direction t (Def. 4);
        NaN where torsal directions are undefined.
        """
        t = self._torsal[0]
        e = _c(self._frame.e)
        out = np.empty_like(t)
        for k in (0, 1):
            n = _cross3(e, _c(t[:, k]))
            with np.errstate(divide="ignore", invalid="ignore"):
                inv_len = 1.0 / np.sqrt(_dot3(n, n))
                for i in range(3):
                    out[:, k, i] = n[i] * inv_len
        return out

    def torsal_plane_angle(self) -> np.ndarray:
        """Angle at which the two torsal planes cross, degrees in [0, 90], (F,); NaN where undefined.

        The planes share the line ``e_c``, so this is the angle between the torsal directions
        seen along the line (projected orthogonally to ``e_c``): the "transversality of torsal
        planes" that Wang et al. 2013, 4.1 bound with c_ang. It is the angle at which the fins
        of the two families cross. It is at most :meth:`torsal_angle` where the lines are
        orthogonal to the face and smaller where they lean towards it.

        Examples
        --------
        >>> import numpy as np
        >>> from torsal.geometry.congruence import Congruence
        >>> a = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
        >>> e = np.array([[0, 0, 1], [0.1, 0, 1], [0, -0.1, 1.0]])   # torsal directions x, y
        >>> f = np.array([[0, 1, 2]])
        >>> float(Congruence(a, f, e).torsal_plane_angle()[0].round(1))
        89.9
        >>> lean = Congruence(a, f, e + [1, 1, 0])      # the lines lean 55 deg along x + y
        >>> float(lean.torsal_angle()[0]), float(lean.torsal_plane_angle()[0].round(1))
        (90.0, 60.0)
        """
        n = self.torsal_planes()
        s = np.linalg.norm(np.cross(n[:, 0], n[:, 1]), axis=1)
        return np.degrees(np.arcsin(np.clip(s, 0.0, 1.0)))

    def torsal_angle(self) -> np.ndarray:
        """Angle between the two torsal directions in the face, degrees in [0, 90], (F,); NaN
        where undefined. :meth:`torsal_plane_angle` is the angle the fins cross at."""
        t = self._torsal[0]
        c = np.clip(np.abs(_dot3(_c(t[:, 0]), _c(t[:, 1]))), 0.0, 1.0)
        return np.degrees(np.arccos(c))

    def normality_residual(self) -> np.ndarray:
        """Eq. (7) residual per face, (F,); zero for a discrete normal congruence (Prop. 1)."""
        return normality_residual(self._frame, self._crosses)

    def summary(self) -> dict:
        """Counts and statistics of the per-face quantities, as plain Python numbers (JSON-ready)."""
        hyp = self.is_hyperbolic()
        bundle = self.is_bundle()
        lam = self.focal_parameters()
        e_len = _norm(self._frame.e)
        dist = np.abs(lam) * e_len[:, None]
        finite = np.isfinite(dist)
        res = np.abs(self.normality_residual())
        rel = res / np.maximum(self.delta * e_len**3, 1e-300)
        ang = self.torsal_angle()

        def stats(x):
            x = x[np.isfinite(x)]
            if x.size == 0:
                return None
            return {"min": float(x.min()), "median": float(np.median(x)),
                    "mean": float(x.mean()), "max": float(x.max())}

        return {
            "vertices": int(len(self._v)),
            "faces": int(len(self._f)),
            "average_edge_length": self.delta,
            "hyperbolic_faces": int(hyp.sum()),
            "hyperbolic_share": float(hyp.mean()),
            "bundle_faces": int(bundle.sum()),
            "focal_points_at_infinity": int(np.isinf(lam).sum()),
            "focal_distance": stats(dist[finite]),
            "normality_residual_abs": stats(res),
            "normality_residual_relative": stats(rel),
            "torsal_angle_deg": stats(ang),
        }
