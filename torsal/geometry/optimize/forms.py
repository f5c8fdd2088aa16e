"""Regular forms of the torsal-angle constraint c_ang (Wang et al. 2013, 4.1).

The constraint "torsal planes crossing at least ``alpha``" is ``|p| <= cos(alpha) rho`` in
the invariants of the torsal form (isotropic part ``p``, strength ``rho``, see
:func:`torsal.geometry.optimize.terms.torsal_form_invariants_sx`). Two smooth ways to impose it:

- ``"cone"``: one row per face, ``cos(alpha) sqrt(rho^2 + s^2) - sqrt(p^2 + s^2) >= 0``
  (:func:`torsal.geometry.optimize.terms.torsal_angle_cone_element`). ``sqrt(p^2 + s^2)`` smooths the
  kink of ``|p|`` over a width ``s`` (the strength floor, 1e-3 by default), so its curvature
  is ``1/s`` at ``p = 0``: exactly where a face has orthogonal torsal directions, the best
  case. Times the constraint's multiplier, that curvature is what IPOPT's inertia correction
  met: large regularizations for hundreds of iterations on row 7c.
- ``"split"`` (the default): two rows per face, ``cos(alpha) sqrt(rho^2 + s^2) - s -+ p >= 0``
  (:func:`torsal_angle_split_element`): each is linear in ``p``, so ``|p|`` needs no
  smoothing. Their curvature is that of ``sqrt(rho^2 + s^2)`` alone, ``<= 1/rho`` on feasible
  faces (the inherent curvature of a norm), not ``1/s``. The apex (a line bundle, ``rho = p
  = 0``) stays infeasible, value ``(cos(alpha) - 1) s < 0``, and a feasible face has the same
  strength floor ``rho >= s tan(alpha)`` as the cone form. Each row is divided by the form's
  magnitude ``sqrt(p^2 + rho^2 + k^2)`` (:data:`SPLIT_SCALE`): the same feasible set, but
  bounded rows where a line turns into its face's plane (there ``p`` and ``rho`` grow
  without bound).
- ``"lift"``: the coordinates ``(u, v, w)`` of the form in an orthonormal frame
  (:func:`torsal_form_coordinates_sx`, linear in ``g``) equal lifted variables
  ``(cos(alpha) r t, r cos(phi), r sin(phi))``; the bound is ``r >= s``, ``|t| <= 1`` on
  variables (assembled in :meth:`torsal.geometry.optimize.nlp.Built._lift`). IPOPT converges
  in fewer iterations with it, to a lower energy but rougher lines (on example 9 the
  extracted structure could not be built where split's could), so split stays the default;
  lift is an option per design (IPOPT only: the augmented Lagrangian has no lifted variables).
"""
from __future__ import annotations

import functools
from dataclasses import replace
from enum import Enum

import casadi as ca
import numpy as np

from . import terms as T
from .catalogue import Term, _var_index
from .terms import TorsalAngleBetween

#: The angles :meth:`~torsal.geometry.optimize.CongruenceProblem.min_torsal_angle` can bound.
ANGLE_BETWEEN = tuple(b.value for b in TorsalAngleBetween)


class TorsalAngleForm(str, Enum):
    """How :meth:`~torsal.geometry.optimize.CongruenceProblem.min_torsal_angle` imposes c_ang.

    A ``str`` enum: ``TorsalAngleForm("lift") is TorsalAngleForm.LIFT``, and design files
    give the value (``constraints.torsal_angle_form = "lift"``).
    """

    SPLIT = "split"
    LIFT = "lift"
    CONE = "cone"


#: The forms :meth:`~torsal.geometry.optimize.CongruenceProblem.min_torsal_angle` offers.
ANGLE_FORMS = tuple(f.value for f in TorsalAngleForm)


def torsal_form_coordinates_sx(a_u, a_v, e_u, e_v, e,
                               between: TorsalAngleBetween = TorsalAngleBetween.PLANES):
    """``(u, v, w)``: the torsal form in an orthonormal frame of the face, linear in ``g``.

    With ``M = R^T R`` (Cholesky, ``R`` upper triangular) the form has matrix
    ``S' = R^-T S R^-1 = [[u + v, w], [w, u - v]]`` in the orthonormal frame ``(a_u/|a_u|, ...)``
    (Gram-Schmidt of the face edges). ``u = p`` is its isotropic part and ``v^2 + w^2 = rho^2``
    its strength squared (:func:`torsal.geometry.optimize.terms.torsal_form_invariants_sx`): the torsal
    planes cross at ``alpha`` or more iff ``|u| <= cos(alpha) sqrt(v^2 + w^2)``. ``M`` is the face
    metric seen along the line (:func:`torsal.geometry.optimize.terms.plane_metric_sx`), or the
    face's own metric for ``between="directions"`` (:func:`~torsal.geometry.optimize.terms.torsal_metric_sx`).
    """
    g0, g1, g2 = T.torsal_coefficients_sx(a_u, a_v, e_u, e_v, e)
    E, F, G = T.torsal_metric_sx(a_u, a_v, e, between)
    r11 = ca.sqrt(E)
    r12 = F / r11
    r22 = ca.sqrt(E * G - F * F) / r11
    # R^-1 = [[1/r11, -r12/(r11 r22)], [0, 1/r22]]; S' = R^-T S R^-1
    i11, i12, i22 = 1.0 / r11, -r12 / (r11 * r22), 1.0 / r22
    s11 = g0 * i11 * i11
    s12 = i11 * (g0 * i12 + g1 * i22)
    s22 = g0 * i12 * i12 + 2.0 * g1 * i12 * i22 + g2 * i22 * i22
    return 0.5 * (s11 + s22), 0.5 * (s11 - s22), s12


@functools.lru_cache(maxsize=None)
def torsal_form_coordinates_element(
        between: TorsalAngleBetween = TorsalAngleBetween.PLANES) -> T.ElementTerm:
    """One coordinate of the torsal form of a face, ``k . (u, v, w)`` (lifted form of c_ang;
    ``between``: the metric, :func:`~torsal.geometry.optimize.terms.torsal_metric_sx`).

    ``x`` the face's 3 unit line directions (9), ``data`` its corners in units of ``delta``
    (9), ``par = [cos alpha, s, k0, k1, k2]`` with ``k`` a unit vector selecting ``u``, ``v``
    or ``w`` (:func:`torsal_form_coordinates_sx`); ``cos alpha`` and the strength floor ``s``
    are read by the lifted variables' part of the NLP (:mod:`~torsal.geometry.optimize.nlp`).

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([0, 0, 0, 1, 0, 0, 0, 1, 0.0])
    >>> e = np.array([0, 0, 1, 0.1, 0, 1, 0, -0.1, 1.0])   # torsal directions at 90 deg
    >>> fn = torsal_form_coordinates_element().fn
    >>> u, v, w = (float(fn(e, a, [0.7, 1e-3] + list(k))) for k in np.eye(3))
    >>> round(float(np.degrees(np.arccos(abs(u) / np.hypot(v, w)))), 2)  # the planes' angle
    89.94
    """
    x, data, par = T.face_symbols(3, n_par=5)
    a_u, a_v, e_u, e_v, e_c = T._frame(T._split(x, 3), T._split(data, 3))
    between = TorsalAngleBetween(between)
    u, v, w = torsal_form_coordinates_sx(a_u, a_v, e_u, e_v, e_c, between)
    c = par[2] * u + par[3] * v + par[4] * w
    return T.ElementTerm("min_torsal_angle", ca.Function("c_ang_lift" + T._BETWEEN_SUFFIX[between],
                                                         [x, data, par], [c]), 3)


#: ``k`` of the split rows' divisor ``sqrt(p^2 + rho^2 + k^2)`` (the torsal form's magnitude,
#: in the units of :func:`torsal.geometry.optimize.terms.torsal_form_invariants_sx` with the
#: corners in units of ``delta``). Why divide: a face whose line turns into the face's plane
#: sees its face degenerate (the metric along the line), and its ``p`` and ``rho`` grow without
#: bound. Undivided, those rows jumped far past their linear model and wrecked full Newton
#: steps (the augmented Lagrangian's "erratic" rows), and the solves of Fig. 12 row 9 ended
#: at energies 0.0174-0.0178, 2-5 % above what the divided rows reach (0.0170-0.0172). ``k``
#: keeps the divisor away from zero at the apex (``k = 0.01``: on row 9 the line search found
#: no decrease with a face left non-hyperbolic). Measured with the augmented Lagrangian
#: (Newton steps / final energy, the divided rows to the final decrement of
#: ``DECREMENT_PER_TOL`` in :mod:`.alm`):
#: k = 0.1: 7c 64 / 0.42723, row 9 161 / 0.01700; k = 0.2: 7c 32 / 0.42723, row 9 206 /
#: 0.01704; k = 0.25: 7c 31 / 0.42724, row 9 217 / 0.01716; k = 0.3: 7c 37, row 9 362 /
#: 0.01718; undivided: 7c 47 / 0.42721, row 9 105 / 0.01777. The 80 designs of the family
#: (benchmarks/optimize_bench.py) all converged either way, the divided rows in half the
#: processor time. 0.25, not 0.2: with 0.2 example 7c's fin system (examples/run_all.py) had
#: three brackets cutting a plate (up to 6 mm³); with 0.25 examples 7c and 9 build without an
#: interfering pair
SPLIT_SCALE = 0.25


@functools.lru_cache(maxsize=None)
def torsal_angle_split_element(
        between: TorsalAngleBetween = TorsalAngleBetween.PLANES) -> T.ElementTerm:
    """One half of c_ang in split form: ``(cos(alpha) sqrt(rho^2 + s^2) - s - sign * p) / m >= 0``.

    ``p`` and ``rho`` in the metric ``between`` picks
    (:func:`~torsal.geometry.optimize.terms.torsal_metric_sx`): the torsal planes' angle
    (default) or the torsal directions' angle in the face (the paper's c_ang).

    ``x`` the face's 3 unit line directions (9), ``data`` its corners in units of ``delta``
    (9), ``par = [cos alpha, s, sign]`` with ``sign = +1`` or ``-1``; a face is imposed with
    both signs, which together say ``|p| <= cos(alpha) sqrt(rho^2 + s^2) - s``. The divisor
    ``m = sqrt(p^2 + rho^2 + k^2)`` (``k`` = :data:`SPLIT_SCALE`) is positive, so it leaves
    the feasible set as it is and bounds the rows: ``|row| <= (1 + cos(alpha)) (1 + s / k)``.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([0, 0, 0, 1, 0, 0, 0, 1, 0.0])
    >>> e = np.array([0, 0, 1, 0.1, 0, 1, 0, -0.1, 1.0])   # torsal directions at 90 deg
    >>> fn = torsal_angle_split_element().fn
    >>> c40 = np.cos(np.radians(40))
    >>> bool(min(float(fn(e, a, [c40, 1e-3, s])) for s in (1, -1)) > 0)
    True
    >>> float(fn(np.tile([0, 0, 1.0], 3), a, [c40, 1e-3, 1])) < 0   # parallel lines
    True
    """
    x, data, par = T.face_symbols(3, n_par=3)
    a_u, a_v, e_u, e_v, e_c = T._frame(T._split(x, 3), T._split(data, 3))
    between = TorsalAngleBetween(between)
    p, rho2 = T.torsal_form_invariants_sx(a_u, a_v, e_u, e_v, e_c, between)
    s = par[1]
    c = (par[0] * ca.sqrt(rho2 + s * s) - s - par[2] * p) / ca.sqrt(p * p + rho2 + SPLIT_SCALE ** 2)
    return T.ElementTerm("min_torsal_angle", ca.Function("c_ang_split" + T._BETWEEN_SUFFIX[between],
                                                         [x, data, par], [c]), 3)


def split_angle_term(fi, fv, a, c: float, s: float, alpha_deg: float,
                     between: TorsalAngleBetween = TorsalAngleBetween.PLANES,
                     name: str = "min_torsal_angle") -> Term:
    """c_ang in split form over faces ``fi`` (corner ids ``fv``, corners ``a`` in units of
    delta): two rows per face, ``+p`` and ``-p`` (:func:`torsal_angle_split_element`)."""
    m = len(fi)
    par = np.concatenate([np.tile([c, s, 1.0], (m, 1)), np.tile([c, s, -1.0], (m, 1))])
    return Term(name, True, torsal_angle_split_element(between), _var_index(np.tile(fv, (2, 1)), 0),
                np.tile(a, (2, 1)), par, np.concatenate([fi, fi]), kind="torsal_angle", bound=alpha_deg,
                between=TorsalAngleBetween(between).value)


def lifted_angle_term(fi, fv, a, c: float, s: float, alpha_deg: float,
                      between: TorsalAngleBetween = TorsalAngleBetween.PLANES) -> Term:
    """c_ang lifted: rows ``u``, ``v``, ``w`` per face, equal to lifted variables (``nlp.Built._lift``)."""
    m = len(fi)
    par = np.concatenate([np.tile(np.r_[c, s, k], (m, 1)) for k in np.eye(3)])
    return Term("min_torsal_angle", True, torsal_form_coordinates_element(between),
                _var_index(np.tile(fv, (3, 1)), 0), np.tile(a, (3, 1)), par, np.tile(fi, 3),
                kind="torsal_angle", bound=alpha_deg, lower=0.0, upper=0.0, lift=True,
                between=TorsalAngleBetween(between).value)


def unlifted(t: Term) -> Term:
    """A lifted torsal-angle term as the split form over the same faces (for L-BFGS); any
    other term as it is."""
    if not t.lift:
        return t
    m = t.size // 3
    return replace(split_angle_term(t.elements[:m], t.idx[:m, ::3] // 3, t.data[:m], float(t.par[0, 0]),
                                    float(t.par[0, 1]), t.bound, t.between, t.name), block=t.block,
                   idx=np.tile(t.idx[:m], (2, 1)))
