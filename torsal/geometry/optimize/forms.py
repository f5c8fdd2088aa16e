"""Regular forms of the torsal-angle constraint c_ang (Wang et al. 2013, 4.1).

The constraint "torsal directions at least ``alpha`` apart" is ``|p| <= cos(alpha) rho`` in
the invariants of the torsal form (isotropic part ``p``, strength ``rho``, see
:func:`torsal.geometry.terms.torsal_form_invariants_sx`). Two smooth ways to impose it:

- ``"cone"``: one row per face, ``cos(alpha) sqrt(rho^2 + s^2) - sqrt(p^2 + s^2) >= 0``
  (:func:`torsal.geometry.terms.torsal_angle_cone_element`). ``sqrt(p^2 + s^2)`` smooths the
  kink of ``|p|`` over a width ``s`` (the strength floor, 1e-3 by default), so its curvature
  is ``1/s`` at ``p = 0``: exactly where a face has orthogonal torsal directions, the best
  case. Times the constraint's multiplier, that curvature is what IPOPT's inertia correction
  met (measured on row 7c: regularizations of 1e4 to 1e6 for hundreds of iterations).
- ``"split"``: two rows per face, ``cos(alpha) sqrt(rho^2 + s^2) - s -+ p >= 0``
  (:func:`torsal_angle_split_element`): each is linear in ``p``, so ``|p|`` needs no
  smoothing. Their curvature is that of ``sqrt(rho^2 + s^2)`` alone, ``<= 1/rho`` on feasible
  faces (the inherent curvature of a norm), not ``1/s``. The apex (a line bundle, ``rho = p
  = 0``) stays infeasible, value ``(cos(alpha) - 1) s < 0``, and a feasible face has the same
  strength floor ``rho >= s tan(alpha)`` as the cone form.
"""
from __future__ import annotations

import casadi as ca

from .. import terms as T

#: The forms :meth:`~torsal.geometry.optimize.CongruenceProblem.min_torsal_angle` offers.
ANGLE_FORMS = ("split", "cone")


def torsal_angle_split_element() -> T.ElementTerm:
    """One half of c_ang in split form: ``cos(alpha) sqrt(rho^2 + s^2) - s - sign * p >= 0``.

    ``x`` the face's 3 unit line directions (9), ``data`` its corners in units of ``delta``
    (9), ``par = [cos alpha, s, sign]`` with ``sign = +1`` or ``-1``; a face is imposed with
    both signs, which together say ``|p| <= cos(alpha) sqrt(rho^2 + s^2) - s``.

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
    p, rho2 = T.torsal_form_invariants_sx(a_u, a_v, e_u, e_v, e_c)
    s = par[1]
    c = par[0] * ca.sqrt(rho2 + s * s) - s - par[2] * p
    return T.ElementTerm("min_torsal_angle", ca.Function("c_ang_split", [x, data, par], [c]), 3)
