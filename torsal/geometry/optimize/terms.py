"""casadi building blocks for congruence optimization (Wang et al. 2013, section 4.1).

Every energy and constraint of section 4.1 is written here for **one element** (a vertex,
a face or an interior edge) as a casadi ``SX`` function; :mod:`torsal.geometry.optimize`
maps it over all elements (``Function.map``) and assembles gradient, Jacobian and the
exact Hessian of the Lagrangian from the per-element derivatives. Nothing here knows a
mesh: inputs are small vectors.

Every element function has the signature ``fn(x, data, par) -> value`` (all column vectors):

``x`` : (3 k,)
    The variables of the element: the line directions ``e`` of its ``k`` vertices,
    stacked ``[e_0, e_1, ...]`` (a face ``(i, j, k)`` has ``k = 3`` in corner order).
``data`` : (q,)
    Constants of the fixed mesh A, usually the corner points ``[a_0, a_1, ...]``.
``par`` : (r,)
    NLP parameters a designer may change without rebuilding the solver (light
    direction, target point, stroke, margin, ...).

Energies return the per-element summand exactly as printed in the paper (the global
normalization ``1/|V|``, ``1/(delta^2 |F|)``, ... is applied by the assembler, see
:class:`ElementTerm.scale`). Constraints return a value that must be ``>= 0`` (or ``== 0``
for the unit-length constraint), already scaled to be dimensionless.

Notation (paper eq. (4)): face corners ``(i, j, k)``; ``a_u = a_j - a_i``, ``a_v = a_k - a_i``,
``e_u = e_j - e_i``, ``e_v = e_k - e_i``; ``e_c`` is the mean of the three ``e`` (the line
through the face barycenter); ``[x, y, z]`` is the determinant ``<x, y x z>``.

Examples
--------
>>> import casadi as ca
>>> fn = perpendicular_element().fn
>>> round(float(fn([1.0, 0, 0], [], [0.6, 0.8, 0])), 12)  # <e, d>^2
0.36
"""
from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Callable

import casadi as ca

__all__ = [
    "ElementTerm",
    "triple",
    "face_symbols",
    "torsal_coefficients_sx",
    "focal_coefficients_sx",
    "normality_residual_sx",
    "normality_element",
    "laplacian_pair_element",
    "perpendicular_element",
    "parallel_element",
    "through_point_element",
    "closeness_element",
    "torsal_direction_residual_sx",
    "torsal_direction_element",
    "torsal_plane_element",
    "fair_torsal_residual_sx",
    "fair_torsal_element",
    "torsal_alignment_element",
    "hyperbolicity_element",
    "torsal_angle_element",
    "TorsalAngleBetween",
    "plane_metric_sx",
    "face_metric_sx",
    "torsal_metric_sx",
    "torsal_angle_sx",
    "torsal_form_invariants_sx",
    "torsal_angle_cone_element",
    "max_angle_element",
    "unit_length_element",
    "custom_element",
]


@dataclass(frozen=True)
class ElementTerm:
    """One energy or constraint of one element kind, ready to be mapped.

    Attributes
    ----------
    name : str
        Term name (the key in ``energies_before`` / ``max_violation``).
    fn : casadi.Function
        ``fn(x (3k,), data (q,), par (r,)) -> scalar``.
    k : int
        Number of line directions per element (1 vertex, 3 face, 4 edge, 6 aligned faces).
    residual : casadi.Function or None
        For a sum-of-squares energy, ``residual(x, data, par) -> r`` with ``fn = ||r||^2``: the
        assembler can then use the Gauss-Newton Hessian ``2 J_r^T J_r`` (positive
        semidefinite) instead of the exact one.
    """

    name: str
    fn: ca.Function
    k: int
    residual: ca.Function | None = None

    @classmethod
    def sum_of_squares(cls, name: str, fn_name: str, x, data, par, r, k: int) -> "ElementTerm":
        """An energy ``||r||^2`` that keeps its residual ``r`` (for a Gauss-Newton Hessian)."""
        return cls(name, ca.Function(fn_name, [x, data, par], [ca.dot(r, r)]), k,
                   ca.Function(fn_name + "_res", [x, data, par], [r]))

    @property
    def n_data(self) -> int:
        return int(self.fn.size1_in(1))

    @property
    def n_par(self) -> int:
        return int(self.fn.size1_in(2))


def triple(x, y, z):
    """Determinant ``[x, y, z] = <x, y x z>`` of three casadi 3-vectors."""
    return ca.dot(x, ca.cross(y, z))


def _split(v, k: int) -> list:
    return [v[3 * c:3 * c + 3] for c in range(k)]


def face_symbols(k: int = 3, n_par: int = 0, n_data: int | None = None):
    """Fresh SX symbols ``(x, data, par)`` for an element with ``k`` direction vectors.

    ``data`` defaults to the ``k`` corner points (``3 k`` entries).
    """
    x = ca.SX.sym("x", 3 * k)
    data = ca.SX.sym("a", 3 * k if n_data is None else n_data)
    par = ca.SX.sym("p", n_par)
    return x, data, par


def _frame(e, a):
    """Face frame of eq. (4) at the barycenter from corner lists ``e``, ``a`` (3 each)."""
    a_u, a_v = a[1] - a[0], a[2] - a[0]
    e_u, e_v = e[1] - e[0], e[2] - e[0]
    e_c = (e[0] + e[1] + e[2]) / 3.0
    return a_u, a_v, e_u, e_v, e_c


def torsal_coefficients_sx(a_u, a_v, e_u, e_v, e):
    """``(gamma_0, gamma_1, gamma_2)`` of eq. (1) (Wang et al. 2013) as casadi expressions.

    ``gamma_0 = [e_u, a_u, e]``, ``2 gamma_1 = [e_u, a_v, e] + [e_v, a_u, e]``,
    ``gamma_2 = [e_v, a_v, e]``.
    """
    g0 = triple(e_u, a_u, e)
    g1 = 0.5 * (triple(e_u, a_v, e) + triple(e_v, a_u, e))
    g2 = triple(e_v, a_v, e)
    return g0, g1, g2


def focal_coefficients_sx(a_u, a_v, e_u, e_v, e):
    """``(c_2, c_1, c_0)`` of the focal quadratic eq. (3) as casadi expressions."""
    c2 = triple(e_u, e_v, e)
    c1 = triple(a_u, e_v, e) + triple(e_u, a_v, e)
    c0 = triple(a_u, a_v, e)
    return c2, c1, c0


def normality_residual_sx(e, a):
    """Residual of eq. (7) for one face, corners ``(i, j, k)``::

        <a_ij x e_c, e_ik x e_c> - <a_ik x e_c, e_ij x e_c>

    with ``a_ij = a_j - a_i`` (the paper's orientation; the sign does not matter when squared).
    ``e`` and ``a`` are lists of three casadi 3-vectors.
    """
    a_u, a_v, e_u, e_v, e_c = _frame(e, a)
    return (ca.dot(ca.cross(a_u, e_c), ca.cross(e_v, e_c))
            - ca.dot(ca.cross(a_v, e_c), ca.cross(e_u, e_c)))


# ---------------------------------------------------------------------------------- energies
def normality_element() -> ElementTerm:
    """f_norm summand: the squared eq. (7) residual of one face (Wang et al. 2013, 4.1).

    ``x = [e_i, e_j, e_k]``, ``data = [a_i, a_j, a_k]``, no parameters. The assembler
    normalizes by ``1 / (delta^2 |F|)``.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([0, 0, 0, 1, 0, 0, 0, 1, 0.0])
    >>> float(normality_element().fn(np.tile([0, 0, 1.0], 3), a, []))  # parallel lines
    0.0
    """
    x, data, par = face_symbols()
    r = normality_residual_sx(_split(x, 3), _split(data, 3))
    return ElementTerm.sum_of_squares("normal", "f_norm", x, data, par, r, 3)


def laplacian_pair_element() -> ElementTerm:
    """One pair ``(i, j)``, ``i < j``, of f_fair = 1/|V| sum ||Delta e_i||^2 (Wang et al. 2013, 4.1).

    With the umbrella Laplacian ``L`` and ``Q = L^T L``,
    ``sum_i ||Delta e_i||^2 = sum_ij Q_ij <e_i, e_j>``. Every nonzero ``Q_ij`` (``i < j``, the
    2-ring) is an element with summand ``2 Q_ij <e_i, e_j> + alpha_i |e_i|^2 + alpha_j |e_j|^2``,
    where ``alpha_i = Q_ii / (number of pairs of i)`` spreads the diagonal over the pairs, so
    the sum over all pairs is exactly ``||L E||^2``. ``data = [2 Q_ij, alpha_i, alpha_j]``.

    Examples
    --------
    >>> float(laplacian_pair_element().fn([1.0, 0, 0, 0, 1.0, 0], [2.0, 0.5, 0.5], []))
    1.0
    """
    x, data, par = face_symbols(2, n_data=3)
    ei, ej = x[0:3], x[3:6]
    v = data[0] * ca.dot(ei, ej) + data[1] * ca.dot(ei, ei) + data[2] * ca.dot(ej, ej)
    return ElementTerm("fair", ca.Function("f_fair", [x, data, par], [v]), 2)


def perpendicular_element() -> ElementTerm:
    """f_perp,i = <e_i, d_i>^2 (Wang et al. 2013, 4.1); ``par = d_i`` (unit light direction).

    Examples
    --------
    >>> float(perpendicular_element().fn([0, 0, 1.0], [], [0, 0, 1.0]))
    1.0
    """
    x, data, par = face_symbols(1, n_par=3, n_data=0)
    v = ca.dot(x, par)
    return ElementTerm.sum_of_squares("perpendicular", "f_perp", x, data, par, v, 1)


def parallel_element() -> ElementTerm:
    """f_par,i = ||e_i x d_i||^2 (Wang et al. 2013, 4.1); ``par = d_i``.

    Examples
    --------
    >>> float(parallel_element().fn([1.0, 0, 0], [], [0, 1.0, 0]))
    1.0
    """
    x, data, par = face_symbols(1, n_par=3, n_data=0)
    c = ca.cross(x, par)
    return ElementTerm.sum_of_squares("parallel", "f_par", x, data, par, c, 1)


def through_point_element() -> ElementTerm:
    """Line ``a_i + lambda e_i`` through a target point ``O_i`` (Fig. 7c see-through).

    Summand ``||(O_i - a_i) x e_i||^2``: for a unit ``e_i`` the squared distance of ``O_i``
    from the line. The assembler divides by ``delta^2 |V'|`` (scale invariant).
    ``data = a_i``, ``par = O_i``.

    Examples
    --------
    >>> float(through_point_element().fn([0, 0, 1.0], [0, 0, 0], [2.0, 0, 5.0]))
    4.0
    """
    x, data, par = face_symbols(1, n_par=3)
    c = ca.cross(par - data, x)
    return ElementTerm.sum_of_squares("through_points", "f_thru", x, data, par, c, 1)


def closeness_element() -> ElementTerm:
    """Regularizer ``||e_i - e_i,0||^2`` (the e-part of eq. (8)'s proximity term); ``par = e_i,0``.

    Examples
    --------
    >>> float(closeness_element().fn([1.0, 0, 0], [], [0, 1.0, 0]))
    2.0
    """
    x, data, par = face_symbols(1, n_par=3, n_data=0)
    d = x - par
    return ElementTerm.sum_of_squares("closeness", "f_close", x, data, par, d, 1)


def _interpolate(e, w):
    return w[0] * e[0] + w[1] * e[1] + w[2] * e[2]


def torsal_direction_residual_sx(e, a, w1, w2, delta: float):
    """Residual of "the stroke ``p1 p2`` through the barycenter is a torsal direction".

    Wang et al. 2013, 4.1 states: ``p1 p2`` is torsal iff the lines of the congruence
    through ``p1``, ``p2`` and ``c`` are coplanar, and prints ``f_dir = [e_p1, e_p2, e_c]^2``.
    With linearly interpolated ``e`` and ``c`` on ``p1 p2``, ``e_c`` is a convex combination of
    ``e_p1`` and ``e_p2``, so that determinant vanishes identically (the printed formula
    compares directions, not lines). The coplanarity of the *lines*
    ``a_p1 + lambda e_p1`` and ``a_p2 + lambda e_p2`` is::

        [a_p2 - a_p1, e_p1, e_p2] = 0

    (then ``L_c`` lies in their plane too, by linearity), which for ``p1, p2 = c -+ s t`` equals
    ``2 s^2 [a_t, e_c, e_t]``: eq. (1) evaluated in the stroke direction. We return it
    divided by ``delta`` (dimensionless for unit ``e``). ``w1``, ``w2`` are the barycentric
    coordinates of ``p1``, ``p2``; ``e``, ``a`` lists of the three corners' vectors.
    """
    da = _interpolate(a, w2) - _interpolate(a, w1)
    return triple(da, _interpolate(e, w1), _interpolate(e, w2)) / delta


def torsal_direction_element(delta: float) -> ElementTerm:
    """f_dir(face): squared :func:`torsal_direction_residual_sx` (Wang et al. 2013, 4.1).

    ``x = [e_i, e_j, e_k]``, ``data = [a_i, a_j, a_k]``,
    ``par = [w(p1) (3), w(p2) (3)]`` barycentric coordinates of the stroke endpoints
    (the segment contains the barycenter).

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([0, 0, 0, 1, 0, 0, 0, 1, 0.0])
    >>> e = np.array([0, 0, 1, 0.1, 0, 1, 0, -0.1, 1.0])   # torsal directions along u and v
    >>> w = [1 / 3, 1 / 2, 1 / 6, 1 / 3, 1 / 6, 1 / 2]    # a stroke along a_v - a_u (through c)
    >>> round(float(torsal_direction_element(1.0).fn(e, a, w)), 12) > 0
    True
    >>> w = [1 / 2, 1 / 3, 1 / 6, 1 / 6, 1 / 3, 1 / 2]    # a stroke along a_v: torsal
    >>> round(float(torsal_direction_element(1.0).fn(e, a, w)), 12)
    0.0
    """
    x, data, par = face_symbols(3, n_par=6)
    v = torsal_direction_residual_sx(_split(x, 3), _split(data, 3), par[0:3], par[3:6], delta)
    return ElementTerm.sum_of_squares("torsal_direction", "f_dir", x, data, par, v, 3)


def torsal_plane_element(delta: float) -> ElementTerm:
    """f_plane(face) = f_dir(face) + <e_c, n>^2 (Wang et al. 2013, 4.1).

    ``data = [a_i, a_j, a_k]``, ``par = [w(p1) (3), w(p2) (3), n (3)]`` with ``n`` the unit
    normal of the wanted torsal plane.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([0, 0, 0, 1, 0, 0, 0, 1, 0.0])
    >>> fn = torsal_plane_element(1.0).fn
    >>> round(float(fn(np.tile([0, 0, 1.0], 3), a, [1, 0, 0, 0, 1, 0, 1, 0, 0])), 12)
    0.0
    """
    x, data, par = face_symbols(3, n_par=9)
    e = _split(x, 3)
    v = torsal_direction_residual_sx(e, _split(data, 3), par[0:3], par[3:6], delta)
    e_c = (e[0] + e[1] + e[2]) / 3.0
    m = ca.dot(e_c, par[6:9])
    return ElementTerm.sum_of_squares("torsal_plane", "f_plane", x, data, par, ca.vertcat(v, m), 3)


def fair_torsal_residual_sx(e, a, delta: float):
    """Residual of the "no jump of torsal planes" condition across one interior edge.

    Wang et al. 2013, 4.1 (fairness of torsal directions). Edge ``a_i a_j`` with the
    adjacent faces ``(i, j, k)`` and ``(j, i, l)``; ``e``, ``a`` are lists of the four
    casadi 3-vectors in the order ``i, j, k, l``.

    Derivation. Project A and B (``b = a + e``) orthogonally along the line through the
    edge midpoint, direction ``m = (e_i + e_j) / 2``. An orthogonal projection along ``m``
    preserves the triple products ``[x, y, m]`` (they are ``|m|`` times the signed area of
    the projected pair), so the barycentric coordinates of the projected ``l`` w.r.t. the
    projected triangle ``i j k`` are ratios of triple products, e.g. for A::

        lambda_i = N_i / D,  N_i = [a_j - a_l, a_k - a_l, m],  D = [a_j - a_i, a_k - a_i, m]

    (cyclically for ``lambda_j``, ``lambda_k``) and likewise ``mu = N'/D'`` for B.
    "No jump" is ``lambda = mu`` (the affine maps of the two projected faces A -> B agree,
    so their eigen-directions, the projected torsal directions, lie on common lines). We
    clear the denominators, which keeps the residual polynomial (smooth, defined also where
    a projected triangle degenerates)::

        r_c = (N_c D' - N'_c D) / delta^4,   c in {i, j, k}

    ``r`` vanishes for parallel lines and for a bundle (both make the projections of A and
    B similar). ``sum_c r_c = 0``, so two components are independent; all three are kept
    for symmetry. Returns a 3-vector, dimensionless for ``|e| ~ 1``.
    """
    ai, aj, ak, al = a
    bi, bj, bk, bl = (a[c] + e[c] for c in range(4))
    m = 0.5 * (e[0] + e[1])

    def bary(pi, pj, pk, pl):
        den = triple(pj - pi, pk - pi, m)
        num = ca.vertcat(triple(pj - pl, pk - pl, m),
                         triple(pk - pl, pi - pl, m),
                         triple(pi - pl, pj - pl, m))
        return num, den

    na, da = bary(ai, aj, ak, al)
    nb, db = bary(bi, bj, bk, bl)
    return (na * db - nb * da) / delta**4


def fair_torsal_element(delta: float) -> ElementTerm:
    """f_fair/t summand of one interior edge: ``||r||^2`` of :func:`fair_torsal_residual_sx`.

    ``x = [e_i, e_j, e_k, e_l]``, ``data = [a_i, a_j, a_k, a_l]``; the assembler divides by
    the number of interior edges.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([0, 0, 0, 1, 0, 0, 0, 1, 0, 1, -1, 0.2])
    >>> float(fair_torsal_element(1.0).fn(np.tile([0.1, 0.2, 1.0], 4), a, []))  # parallel lines
    0.0
    """
    x, data, par = face_symbols(4)
    r = fair_torsal_residual_sx(_split(x, 4), _split(data, 4), delta)
    return ElementTerm.sum_of_squares("fair_torsal", "f_fairt", x, data, par, r, 4)


def torsal_alignment_element(delta: float) -> ElementTerm:
    """f_extra summand for two congruences over combinatorially equal meshes (Fig. 11).

    Wang et al. 2013, 4.3: ``(||g_L x g_L'|| / delta^2)^2`` with ``g = (gamma_0, 2 gamma_1,
    gamma_2)`` of eq. (1) at the face barycenter. ``g`` is the coefficient vector of the
    torsal quadratic form ``gamma_0 u^2 + 2 gamma_1 u v + gamma_2 v^2`` in the face's ``(u, v)``
    parameters (shared by both meshes), so the cross product vanishes iff the two forms are
    proportional, i.e. iff both torsal directions coincide. The paper's typesetting shows
    ``gamma_1`` (not ``2 gamma_1``) in the second vector; we use ``2 gamma_1`` in both,
    which makes the term symmetric and exactly "same form up to a factor".

    ``x = [e_i, e_j, e_k of L, e_i, e_j, e_k of L']``, ``data = [a_i, a_j, a_k of A, of A']``.
    """
    x, data, par = face_symbols(6)
    e, a = _split(x, 6), _split(data, 6)
    g = []
    for s in (0, 3):
        a_u, a_v, e_u, e_v, e_c = _frame(e[s:s + 3], a[s:s + 3])
        g0, g1, g2 = torsal_coefficients_sx(a_u, a_v, e_u, e_v, e_c)
        g.append(ca.vertcat(g0, 2.0 * g1, g2))
    c = ca.cross(g[0], g[1]) / delta**2
    return ElementTerm.sum_of_squares("align", "f_extra", x, data, par, c, 6)


# ------------------------------------------------------------------------------- constraints
def hyperbolicity_element(delta: float) -> ElementTerm:
    """c_hyp(face) / delta^2 - margin >= 0 (Wang et al. 2013, 4.1 and eq. (2)).

    ``c_hyp = ([a_ij, e_ik, e_c] + [e_ij, a_ik, e_c])^2 - 4 [e_ij, e_ik, e_c][a_ij, a_ik, e_c]``,
    the discriminant of eq. (3) at the barycenter. Dividing by ``delta^2`` makes it
    dimensionless for unit ``e``; ``par = [margin]``.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([0, 0, 0, 1, 0, 0, 0, 1, 0.0])
    >>> e = np.array([0, 0, 1, 0.1, 0, 1, 0, -0.1, 1.0])   # a saddle-like face
    >>> float(hyperbolicity_element(1.0).fn(e, a, [0.0])) > 0
    True
    """
    x, data, par = face_symbols(3, n_par=1)
    a_u, a_v, e_u, e_v, e_c = _frame(_split(x, 3), _split(data, 3))
    c2, c1, c0 = focal_coefficients_sx(a_u, a_v, e_u, e_v, e_c)
    c = (c1 * c1 - 4.0 * c2 * c0) / delta**2 - par[0]
    return ElementTerm("hyperbolic", ca.Function("c_hyp", [x, data, par], [c]), 3)


def plane_metric_sx(a_u, a_v, e):
    """``(E, G12, G)``: the face metric of ``a_u``, ``a_v`` seen along the line ``e``.

    The two torsal planes share the line, so the angle at which they cross is the angle
    between the torsal directions projected orthogonally to ``e`` ("transversality of torsal
    planes", Wang et al. 2013, 4.1): ``x -> x - <x, e> e / <e, e>``. The projected metric is
    ``M - w w^T / <e, e>`` with ``w = (<a_u, e>, <a_v, e>)``; rational, so smooth for ``e != 0``.
    """
    ee = ca.dot(e, e)
    wu, wv = ca.dot(a_u, e), ca.dot(a_v, e)
    return (ca.dot(a_u, a_u) - wu * wu / ee, ca.dot(a_u, a_v) - wu * wv / ee,
            ca.dot(a_v, a_v) - wv * wv / ee)


class TorsalAngleBetween(str, Enum):
    """Which angle a torsal-angle bound (c_ang, Wang et al. 2013, 4.1) bounds.

    ``PLANES`` (``"planes"``): the angle at which the two torsal planes cross (each spanned
    by the line and a torsal direction): the angle the fins of the two families meet at,
    torsal's ``min_torsal_angle`` since its first release. ``DIRECTIONS``
    (``"directions"``): the angle between the two torsal directions in the face itself, as
    the paper states c_ang ("the angle between torsal directions in the face ... does not
    fall below alpha"). The two agree where the lines are orthogonal to the face and differ
    where they lean. A ``str`` enum: design files give the value
    (``constraints.torsal_angle_between = "directions"``).
    """

    PLANES = "planes"
    DIRECTIONS = "directions"


#: casadi function name suffix per angle (the NLP cache tells terms apart by function name)
_BETWEEN_SUFFIX = {TorsalAngleBetween.PLANES: "", TorsalAngleBetween.DIRECTIONS: "_dir"}


def face_metric_sx(a_u, a_v):
    """``(E, G12, G)``: the face's own metric (first fundamental form of ``u a_u + v a_v``),
    in which the angle between the torsal directions in the face is measured (c_ang as
    Wang et al. 2013, 4.1 state it)."""
    return ca.dot(a_u, a_u), ca.dot(a_u, a_v), ca.dot(a_v, a_v)


def torsal_metric_sx(a_u, a_v, e, between: TorsalAngleBetween = TorsalAngleBetween.PLANES):
    """The metric ``(E, G12, G)`` of the face in which a torsal angle is measured:
    :func:`plane_metric_sx` (the face seen along the line ``e``) for the angle of the torsal
    planes, :func:`face_metric_sx` for the angle of the torsal directions in the face."""
    if TorsalAngleBetween(between) is TorsalAngleBetween.DIRECTIONS:
        return face_metric_sx(a_u, a_v)
    return plane_metric_sx(a_u, a_v, e)


def torsal_angle_sx(a_u, a_v, e_u, e_v, e, cos2, sin2):
    """Smooth form of "the torsal planes cross at an angle >= alpha" (c_ang).

    Wang et al. 2013, 4.1 names c_ang ("transversality of torsal planes") but does not print
    it. Derivation: the torsal directions are the null directions ``(u, v)`` of the quadratic
    form of eq. (1), ``S = [[g0, g1], [g1, g2]]``, mapped to 3D as ``u a_u + v a_v``; the
    planes they span with the line ``e`` cross at the angle between these directions projected
    orthogonally to ``e``, measured by the metric ``M = [[E, G12], [G12, G]]`` of
    :func:`plane_metric_sx` (the face metric seen along the line; the angle in the face itself
    can stay large while the planes, and the fins in them, nearly coincide).
    In coordinates orthonormal for ``M`` the form has matrix ``S' = R^-T S R^-1`` with
    eigenvalues ``m1 > 0 > m2`` (hyperbolic case); its null lines make angles ``+-phi``
    with the first eigenvector, ``tan^2 phi = -m1/m2``, so the angle between them obeys::

        tan^2(theta) = 4 (-m1 m2) / (m1 + m2)^2 = -4 det S' / (tr S')^2
                     = 4 (g1^2 - g0 g2) det M / T^2,    T = g0 G - 2 g1 G12 + g2 E

    (``det S' = det S / det M``, ``tr S' = tr(M^-1 S) = T / det M``; theta is the acute
    angle, ``T = 0`` means orthogonal torsal directions). For ``0 < alpha < 90 deg``,
    ``theta >= alpha`` iff ``tan^2 theta >= tan^2 alpha``; multiplying by
    ``T^2 cos^2 alpha >= 0`` gives the polynomial (smooth) inequality::

        c_ang = 4 (g1^2 - g0 g2) det M cos^2(alpha) - T^2 sin^2(alpha) >= 0

    which also excludes non-hyperbolic faces (``g1^2 - g0 g2 < 0`` makes it negative), so
    ``c_ang >= 0`` implies ``c_hyp >= 0``. A line bundle (all ``g = 0``) gives ``c_ang = 0``.
    """
    g0, g1, g2 = torsal_coefficients_sx(a_u, a_v, e_u, e_v, e)
    E, G12, G = plane_metric_sx(a_u, a_v, e)
    det_m = E * G - G12 * G12
    t = g0 * G - 2.0 * g1 * G12 + g2 * E
    return 4.0 * (g1 * g1 - g0 * g2) * det_m * cos2 - t * t * sin2


def torsal_angle_element(delta: float) -> ElementTerm:
    """c_ang(face) / delta^6 >= 0: torsal planes crossing at least ``alpha`` (see
    :func:`torsal_angle_sx` for the derivation). ``par = [cos^2 alpha, sin^2 alpha]``.
    ``c_ang`` scales like ``delta^6 (delta kappa)^2``; dividing by ``delta^6`` makes it
    dimensionless.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([0, 0, 0, 1, 0, 0, 0, 1, 0.0])
    >>> e = np.array([0, 0, 1, 0.1, 0, 1, 0, -0.1, 1.0])   # torsal directions at 90 deg
    >>> c = np.cos(np.radians(40)) ** 2
    >>> float(torsal_angle_element(1.0).fn(e, a, [c, 1 - c])) > 0
    True
    """
    x, data, par = face_symbols(3, n_par=2)
    a_u, a_v, e_u, e_v, e_c = _frame(_split(x, 3), _split(data, 3))
    c = torsal_angle_sx(a_u, a_v, e_u, e_v, e_c, par[0], par[1]) / delta**6
    return ElementTerm("min_torsal_angle", ca.Function("c_ang", [x, data, par], [c]), 3)


def torsal_form_invariants_sx(a_u, a_v, e_u, e_v, e,
                              between: TorsalAngleBetween = TorsalAngleBetween.PLANES):
    """``(p, rho^2)`` of the torsal form in coordinates orthonormal for the face metric seen
    along the line (``between="planes"``) or for the face's own metric (``"directions"``,
    :func:`torsal_metric_sx`); the algebra below holds for either metric ``M``.

    With ``S = [[g0, g1], [g1, g2]]`` (eq. (1)) and the metric ``M`` of :func:`torsal_angle_sx`,
    ``S' = M^-1/2 S M^-1/2`` has eigenvalues ``m1 >= m2``; ``p = (m1 + m2) / 2 = T / (2 det M)``
    is its isotropic part and ``rho = (m1 - m2) / 2``, ``rho^2 = (T^2 + 4 (g1^2 - g0 g2) det M)
    / (4 det M^2)``, its strength: the torsal directions make angles ``+-phi`` with the first
    eigenvector where ``cos 2 phi = -p / rho``, so they are real iff ``rho >= |p|`` and enclose
    the acute angle ``theta`` with ``cos theta = |p| / rho``. A line bundle has ``p = rho = 0``.
    """
    g0, g1, g2 = torsal_coefficients_sx(a_u, a_v, e_u, e_v, e)
    E, G12, G = torsal_metric_sx(a_u, a_v, e, between)
    det_m = E * G - G12 * G12
    t = g0 * G - 2.0 * g1 * G12 + g2 * E
    p = t / (2.0 * det_m)
    rho2 = (t * t + 4.0 * (g1 * g1 - g0 * g2) * det_m) / (4.0 * det_m * det_m)
    return p, rho2


def torsal_angle_cone_element(delta: float,
                              between: TorsalAngleBetween = TorsalAngleBetween.PLANES) -> ElementTerm:
    """c_ang as a cone with a strength floor: ``cos(alpha) sqrt(rho^2 + s^2) - sqrt(p^2 + s^2) >= 0``.

    ``between`` picks the metric of ``p`` and ``rho`` (:func:`torsal_metric_sx`): the
    torsal planes' angle (default) or the torsal directions' angle in the face.

    The regular form of "torsal planes crossing at least ``alpha``" (Wang et al. 2013, 4.1)
    that :meth:`~torsal.geometry.optimize.CongruenceProblem.min_torsal_angle` imposes;
    ``p``, ``rho`` from :func:`torsal_form_invariants_sx` with ``a`` in units of ``delta`` (so
    ``rho`` is the difference of the torsal form's eigenvalues per edge length, radians per
    ``delta``). ``par = [cos alpha, s]``.

    Why. The polynomial :func:`torsal_angle_sx` is quartic in ``e`` and vanishes with its
    gradient at a line bundle (``g = 0``), which it admits as feasible: an energy that
    prefers parallel lines drives faces to that apex, IPOPT loses LICQ there and crawls,
    and the answer has no torsal directions at all. This form is positively homogeneous of
    degree 1 in ``g`` away from the apex (``cos(alpha) rho - |p|``, gradient of order 1),
    and ``s > 0`` makes the apex infeasible (value ``(cos(alpha) - 1) s < 0``): a feasible
    face has ``cos(alpha)^2 rho^2 - p^2 >= s^2 sin(alpha)^2``, so its torsal directions are
    real, at least ``alpha`` apart, and the form has strength ``rho >= s tan(alpha)``: the
    documented design choice "a face with a torsal-angle bound must have torsal
    directions". Near the bound the value is ``rho (cos alpha - cos theta)``, so a value
    error ``tau`` is an angle error of at most ``tau / (s tan(alpha) sin(alpha))`` radians.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([0, 0, 0, 1, 0, 0, 0, 1, 0.0])
    >>> e = np.array([0, 0, 1, 0.1, 0, 1, 0, -0.1, 1.0])   # torsal directions at 90 deg
    >>> fn = torsal_angle_cone_element(1.0).fn
    >>> float(fn(e, a, [np.cos(np.radians(40)), 1e-3])) > 0
    True
    >>> float(fn(np.tile([0, 0, 1.0], 3), a, [np.cos(np.radians(40)), 1e-3])) < 0   # parallel lines
    True
    """
    x, data, par = face_symbols(3, n_par=2)
    a_u, a_v, e_u, e_v, e_c = _frame(_split(x, 3), _split(data, 3))
    between = TorsalAngleBetween(between)
    p, rho2 = torsal_form_invariants_sx(a_u, a_v, e_u, e_v, e_c, between)
    s2 = par[1] * par[1]
    c = par[0] * ca.sqrt(rho2 + s2) - ca.sqrt(p * p + s2)
    return ElementTerm("min_torsal_angle", ca.Function("c_ang_cone" + _BETWEEN_SUFFIX[between],
                                                       [x, data, par], [c]), 3)



def max_angle_element() -> ElementTerm:
    """``<e_i, d_i> - cos(theta) >= 0`` (Wang et al. 2013, 4.1; needs ``||e_i|| = 1``).

    ``par = [d_i (unit, 3), cos theta]``.

    Examples
    --------
    >>> float(max_angle_element().fn([0, 0, 1.0], [], [0, 0, 1.0, 0.5]))
    0.5
    """
    x, data, par = face_symbols(1, n_par=4, n_data=0)
    c = ca.dot(x, par[0:3]) - par[3]
    return ElementTerm("max_angle_to", ca.Function("c_maxang", [x, data, par], [c]), 1)


def unit_length_element() -> ElementTerm:
    """``||e_i||^2 - 1 == 0``: the paper's unit line directions as an equality constraint.

    Examples
    --------
    >>> float(unit_length_element().fn([0, 3.0, 4.0], [], []))
    24.0
    """
    x, data, par = face_symbols(1, n_data=0)
    return ElementTerm("unit_length", ca.Function("c_unit", [x, data, par], [ca.dot(x, x) - 1.0]), 1)


def custom_element(name: str, fn: Callable, k: int, n_par: int = 0) -> ElementTerm:
    """Wrap a user's per-element expression ``fn(e, a[, p])`` as an :class:`ElementTerm`.

    Parameters
    ----------
    name : str
    fn : callable
        Called once with casadi ``SX`` matrices ``e`` (k, 3) (rows: line directions of
        the element's vertices), ``a`` (k, 3) (rows: their points on A) and, if
        ``n_par > 0``, ``p`` (n_par,) parameters; returns a scalar ``SX`` expression.
    k : int
        Vertices per element (1 vertex, 3 face, 2 edge).
    n_par : int
        Number of per-element parameters.

    Examples
    --------
    >>> import casadi as ca
    >>> t = custom_element("up", lambda e, a: ca.sumsqr(e[:, 2]), k=3)
    >>> float(t.fn([0, 0, 1.0] * 3, [0.0] * 9, []))
    3.0
    """
    x, data, par = face_symbols(k, n_par=n_par)
    e = ca.reshape(x, 3, k).T
    a = ca.reshape(data, 3, k).T
    out = fn(e, a, par) if n_par else fn(e, a)
    out = ca.SX(out)
    if out.numel() != 1:
        raise ValueError(
            f"term {name!r}: the expression must be a scalar per element, got shape {out.shape}; "
            "sum or square your residual vector (e.g. casadi.sumsqr)"
        )
    return ElementTerm(name, ca.Function(f"custom_{name}", [x, data, par], [out]), k)
