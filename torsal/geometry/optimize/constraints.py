"""The constraints of section 4.1 as builder methods: :class:`ConstraintTerms`.

c_hyp (:meth:`~ConstraintTerms.hyperbolic`), c_ang (:meth:`~ConstraintTerms.min_torsal_angle`,
in the forms of :mod:`.forms`), angles to a direction and a user's own rows; each registers one
:class:`~torsal.geometry.optimize.catalogue.Term` in the problem's registry. Every constraint is
measured on the geometry after (and during) a solve (:mod:`.measure`).
"""
from __future__ import annotations

import math
from typing import Callable, Self

import numpy as np

from . import terms as T
from .catalogue import Term, _as_index, _unit_rows, _var_index
from .forms import (ANGLE_BETWEEN, ANGLE_FORMS, TorsalAngleBetween, TorsalAngleForm, lifted_angle_term,
                    split_angle_term)


class ConstraintTerms:
    """The constraints of :class:`~torsal.geometry.optimize.CongruenceProblem` (its ``registry``
    holds what they register; ``_add`` registers a term and returns the problem)."""

    def add_constraint(self, name: str, fn: Callable, over: str = "faces", elements=None,
                       params=None, lower: float = 0.0, upper: float = math.inf) -> Self:
        """A user's own constraint ``lower <= fn(e, a[, p]) <= upper`` on every element.

        Arguments as in :meth:`add_term`. IPOPT enforces it; ``lbfgs`` penalizes violations.
        Scale ``fn`` to be dimensionless and of order 1 for good convergence.

        Examples
        --------
        >>> from torsal.geometry import Congruence, CongruenceProblem
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p = p.add_constraint("outward", lambda e, a: -e[0, 1], over="vertices", lower=0.1)
        >>> p.terms["outward"][0]
        'constraint'
        """
        if not (lower <= upper):
            raise ValueError(f"constraint {name!r}: lower bound {lower} exceeds upper bound {upper}")
        return self._add(self.registry.custom_term(name, fn, over, elements, params, lower=lower, upper=upper))

    def hyperbolic(self, faces=None, margin: float = 0.0) -> Self:
        """c_hyp(face) / delta^2 >= margin: two real torsal directions (Wang et al. 2013, 4.1, eq. (2)).

        ``margin`` is dimensionless (``c_hyp`` in units of ``delta^2``, for unit directions); a
        small positive margin keeps faces away from the parabolic limit.

        ``c_hyp = 4 (g1^2 - g0 g2)`` is quadratic in the torsal coefficients ``g`` of eq. (1),
        so its gradient vanishes on a face whose lines are parallel (``g = 0``, a line
        bundle), which satisfies ``c_hyp >= 0``. ``fair`` with ``perpendicular`` or
        ``parallel`` favours parallel lines; when many faces end near a bundle, IPOPT's
        multipliers grow and it may need hundreds of iterations. A ``closeness`` term keeps
        the lines near the start and away from a bundle. With ``margin = 0``, faces under a
        (split form) ``min_torsal_angle`` bound are hyperbolic by that bound; their rows are
        left out of IPOPT's NLP and still measured (see :meth:`.registry.TermRegistry.implied_hyperbolic`).

        Examples
        --------
        >>> from torsal.geometry import Congruence, CongruenceProblem
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p.hyperbolic().terms["hyperbolic"]
        ('constraint', None, 32)
        """
        if not np.isfinite(margin):
            raise ValueError("margin must be finite")
        fi = _as_index(faces, len(self.congruence.faces), "faces")
        fv, a = self.registry.face_data(fi)
        old = self.registry.terms.get("hyperbolic")
        if old is not None and bool(np.all(old.par[:, 0] <= 0)) != (margin <= 0):
            self.nlp.forget()     # rows implied by min_torsal_angle only at margin <= 0
        t = Term("hyperbolic", True, T.hyperbolicity_element(1.0), _var_index(fv, 0), a,
                  np.full((len(fi), 1), float(margin)), fi, kind="hyperbolicity", bound=float(margin))
        return self._add(t)

    def min_torsal_angle(self, alpha_deg: float = 40.0, faces=None, safety_deg: float = 0.01, *,
                         min_strength: float = 1e-3,
                         form: TorsalAngleForm | str = TorsalAngleForm.SPLIT,
                         between: TorsalAngleBetween | str = TorsalAngleBetween.PLANES) -> Self:
        """Torsal planes crossing at ``alpha_deg`` or more on every face (the fins of the two families) (c_ang, Wang et al. 2013, 4.1).

        ``between="planes"`` (default) bounds the angle at which the two torsal planes cross
        (each spanned by the line and a torsal direction): the angle the fins meet at.
        ``between="directions"`` bounds the angle between the two torsal directions in the
        face, as the paper states c_ang (4.1, "Transversality of torsal planes"): the same
        forms below with ``p`` and ``rho`` in the face's own metric instead of the face seen
        along the line (:class:`~torsal.geometry.optimize.terms.TorsalAngleBetween`,
        :func:`~torsal.geometry.optimize.terms.torsal_metric_sx`). The two agree where the
        lines are orthogonal to the face; where they lean, either can be the smaller. The
        bound is measured as it was asked: :meth:`Congruence.torsal_plane_angle
        <torsal.geometry.congruence.Congruence.torsal_plane_angle>` or
        :meth:`~torsal.geometry.congruence.Congruence.torsal_angle`.

        ``form="split"`` (default): two rows per face (:mod:`~torsal.geometry.optimize.forms`)::

            cos(alpha) sqrt(rho^2 + s^2) - s -+ p >= 0

        ``form="lift"``: the torsal form's coordinates ``(u, v, w)`` in an
        orthonormal frame of the face (:func:`~torsal.geometry.optimize.forms.torsal_form_coordinates_sx`,
        ``u = p`` its isotropic part, ``sqrt(v^2 + w^2) = rho`` its strength) are lifted into
        the NLP as three variables ``(r, t, phi)`` per face with three equality rows::

            (u, v, w)(e) = (cos(alpha) r t, r cos(phi), r sin(phi)),   r >= s,  -1 <= t <= 1

        The angle bound ``|p| <= cos(alpha) rho`` and the strength floor are bounds on
        variables: no inequality row, nothing whose gradient vanishes at the apex ``g = 0``
        (a line bundle, outside ``r >= s``), and the start needs not be feasible (pass 3
        starts from the energies' optimum). IPOPT converges in fewer iterations with it than
        with split, but not the default: its lower optimum has rougher lines, and the
        support structure extracted from example 9's ran through itself. The augmented
        Lagrangian has no lifted variables: it solves split (and cone) only.

        ``form="cone"`` (one row per face,
        :func:`torsal.geometry.optimize.terms.torsal_angle_cone_element`)::

            cos(alpha) sqrt(rho^2 + s^2) - sqrt(p^2 + s^2) >= 0

        (``p``, ``rho``: isotropic part and strength of the torsal form, eq. (1), per edge
        length; ``s = min_strength``). All imply hyperbolicity and make a line bundle
        infeasible. The split form needs no smoothing of ``|p|``, whose ``1/s`` curvature at
        ``p = 0`` the cone form carries: measured on a 9 x 7 patch at 85 degrees with
        ``s = 1e-5``, split 19 IPOPT iterations, cone not converged in 400. The strength floor:

        *Design choice*: a face that must have torsal directions at least ``alpha`` apart
        must have torsal directions, so the torsal form's strength is bounded below,
        ``rho >= s`` (lift; ``s tan(alpha)`` split and cone; radians of line rotation per
        edge length ``delta``; the default ``1e-3`` is about a thousandth of a degree per
        edge: a fin pattern you cannot see, but a face that is not a bundle). Set
        ``min_strength`` larger to keep fins away from the parallel-line limit.

        The result is measured, not trusted: ``OptimizationResult.max_violation`` gives how
        far the smallest measured torsal angle is below ``alpha_deg`` (degrees; a face without
        torsal directions counts as 0 degrees) and ``success`` is False beyond 0.1 degrees.
        The bound is imposed at ``alpha_deg + safety_deg``; IPOPT's constraint tolerance
        (1e-9) is worth at most ``1e-9 / (s tan(alpha) sin(alpha))`` radians (< 1e-4 degrees
        for ``alpha >= 5``; lift: ``1e-9 / (s sin(alpha))``).

        Examples
        --------
        >>> from torsal.geometry import Congruence, CongruenceProblem
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p.min_torsal_angle(40).terms["min_torsal_angle"][0]
        'constraint'
        >>> r = p.min_torsal_angle(40, between="directions").solve()
        >>> bool(np.nanmin(r.congruence.torsal_angle()) >= 40 - 0.1)   # the paper's c_ang
        True
        """
        if not (0.0 < alpha_deg < 90.0):
            raise ValueError(f"alpha_deg must be in (0, 90) degrees, got {alpha_deg}; "
                             "torsal directions are at most 90 degrees apart")
        if not (np.isfinite(min_strength) and min_strength > 0):
            raise ValueError(f"min_strength must be a finite number > 0, got {min_strength}")
        if form not in ANGLE_FORMS:
            raise ValueError(f"form must be one of {ANGLE_FORMS}, got {form!r}")
        form = TorsalAngleForm(form)
        if between not in ANGLE_BETWEEN:
            raise ValueError(f"between must be one of {ANGLE_BETWEEN}, got {between!r}")
        between = TorsalAngleBetween(between)
        fi = _as_index(faces, len(self.congruence.faces), "faces")
        fv, a = self.registry.face_data(fi)
        c = math.cos(math.radians(min(alpha_deg + safety_deg, 89.999)))
        if form is TorsalAngleForm.CONE:
            t = Term("min_torsal_angle", True, T.torsal_angle_cone_element(1.0, between), _var_index(fv, 0), a,
                     np.tile([c, float(min_strength)], (len(fi), 1)), fi, kind="torsal_angle",
                     bound=float(alpha_deg), between=between.value)
        elif form is TorsalAngleForm.LIFT:   # three rows per face, u, v, w = lifted variables (see .forms)
            t = lifted_angle_term(fi, fv, a, c, float(min_strength), float(alpha_deg), between)
        else:
            t = split_angle_term(fi, fv, a, c, float(min_strength), float(alpha_deg), between)
        return self._add(t)

    def max_angle_to(self, d, theta_deg: float, vertices=None) -> Self:
        """<e_i, d_i> - cos(theta) >= 0: lines within ``theta_deg`` of ``d`` (Wang et al. 2013, 4.1).

        Directions are unit vectors in the default ``normalize="tangent"`` (and with
        ``"constraint"``). Measured on the result as the angle between ``e_i`` and ``d_i`` in
        degrees; a constraint value error ``tau`` (IPOPT's 1e-9) is an angle error of
        ``tau / sin(theta)`` radians.

        Examples
        --------
        >>> from torsal.geometry import Congruence, CongruenceProblem
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p.max_angle_to([0, -1, 0], 30).terms["max_angle_to"][0]
        'constraint'
        """
        if not (0.0 < theta_deg < 180.0):
            raise ValueError(f"theta_deg must be in (0, 180) degrees, got {theta_deg}")
        vi = _as_index(vertices, len(self.congruence.vertices), "vertices")
        dd = _unit_rows(d, len(vi), "direction d")
        par = np.concatenate([dd, np.full((len(vi), 1), math.cos(math.radians(theta_deg)))], axis=1)
        t = Term("max_angle_to", True, T.max_angle_element(), _var_index(vi, 0), np.zeros((len(vi), 0)),
                 par, vi, kind="angle_to", bound=float(theta_deg))
        return self._add(t)

