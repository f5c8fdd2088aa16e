"""Constraints measured on the geometry they name, independently of the NLP's own values.

A constraint holds only if the quantity it names holds: after (and during) a solve the
torsal angles, hyperbolicity and angles to a direction are measured from the resulting
:class:`~torsal.geometry.congruence.Congruence` (its torsal directions, eq. (1), and
discriminant, eq. (2)), in the constraint's own units: degrees for angles, ``c_hyp /
delta^2`` for hyperbolicity. Only a user's own constraints (``add_constraint``) and the unit
length of ``normalize="constraint"`` are read from the NLP, since nothing else knows them.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..congruence import Congruence
from .terms import TorsalAngleBetween

#: How each constraint kind is measured: (quantity, unit).
KINDS = {
    "torsal_angle": ("minimum torsal angle", "deg"),
    "hyperbolicity": ("c_hyp / delta^2", "c_hyp/delta^2"),
    "angle_to": ("angle between line and direction", "deg"),
    "value": ("constraint function", "value"),
}


#: a violation beyond its tolerance by less than this share is rounding, and holds: a row stuck
#: at 0 under a margin equal to the tolerance (hyperbolicity 1e-6) misses by 1e-6 * (1 + 4e-16)
ROUNDING = 1e-9


class Measurement(NamedTuple):
    """One constraint measured on a congruence.

    Attributes
    ----------
    name : str
        The constraint's name (key of ``OptimizationResult.max_violation``).
    kind : str
        ``"torsal_angle"``, ``"hyperbolicity"``, ``"angle_to"`` or ``"value"`` (see :data:`KINDS`).
    unit : str
        ``"deg"`` for angles, ``"c_hyp/delta^2"``, or ``"value"``.
    bound : float
        The bound the user asked for, in ``unit`` (e.g. 40 for ``min_torsal_angle(40)``).
    elements : (m,) int
        Element ids (faces or vertices) the constraint is imposed on.
    values : (m,) float
        The measured quantity per element (torsal angle in degrees, 0 where the face has no
        torsal directions; ``c_hyp / delta^2``; angle to ``d``; or the constraint function).
    violation : (m,) float
        How far each element misses the bound, in ``unit``, 0 where it holds.
    tolerance : float
        Violation up to which the constraint counts as held (0.1 deg for angles).
    between : str or None
        For a torsal angle: which angle ``values`` are, ``"planes"`` (the torsal planes'
        crossing angle) or ``"directions"`` (the torsal directions' angle in the face); None
        for other kinds.
    """

    name: str
    kind: str
    unit: str
    bound: float
    elements: np.ndarray
    values: np.ndarray
    violation: np.ndarray
    tolerance: float
    between: str | None = None

    @property
    def worst(self) -> float:
        """Largest violation (0 if the constraint holds everywhere)."""
        return float(self.violation.max()) if self.violation.size else 0.0

    @property
    def _over(self) -> np.ndarray:
        return self.violation > self.tolerance * (1.0 + ROUNDING)

    @property
    def missed(self) -> np.ndarray:
        """Element ids that miss the bound by more than the tolerance."""
        return self.elements[self._over]

    @property
    def holds(self) -> bool:
        return not self._over.any()


def torsal_angle_deg(c: Congruence, faces: np.ndarray, between: str = "planes") -> np.ndarray:
    """Measured acute torsal angle (degrees), 0 where there are none.

    ``between="planes"``: the angle at which the torsal planes cross
    (:meth:`~torsal.geometry.congruence.Congruence.torsal_plane_angle`); ``"directions"``:
    the angle between the torsal directions in the face
    (:meth:`~torsal.geometry.congruence.Congruence.torsal_angle`, the paper's c_ang). A
    non-hyperbolic face (eq. (2) < 0) and a line bundle have no torsal directions; they
    count as angle 0 so that they fail any angle bound.
    """
    between = TorsalAngleBetween(between)
    ang = (c.torsal_angle() if between is TorsalAngleBetween.DIRECTIONS else c.torsal_plane_angle())[faces]
    return np.where(np.isfinite(ang), ang, 0.0)


def angle_to_deg(c: Congruence, vertices: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Angle (degrees) between the unit line directions at ``vertices`` and the unit rows ``d``."""
    e = c.directions[vertices]
    e = e / np.linalg.norm(e, axis=1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", e, d), -1.0, 1.0)))


def measure(term, c: Congruence, delta: float, g: np.ndarray | None, *, angle_tol_deg: float,
            value_tol: float) -> Measurement:
    """Measure one constraint term (see :class:`~torsal.geometry.optimize.catalogue.Term`).

    ``g`` are the NLP's values of this term's rows (used for ``kind == "value"`` only).
    """
    el = term.elements
    if term.kind == "torsal_angle":
        # the split form imposes each face twice (+p, -p): measure each face once
        el = el[np.sort(np.unique(el, return_index=True)[1])]
        vals = torsal_angle_deg(c, el, term.between)
        viol, tol = np.maximum(term.bound - vals, 0.0), angle_tol_deg
    elif term.kind == "hyperbolicity":
        vals = c.hyperbolicity()[el] / delta**2
        # a margin is asked so that faces stay off 0 (parabolic: no torsal planes); a tolerance
        # as large as the margin would let them sit at 0, so it is at most half the margin
        tol = min(value_tol, 0.5 * term.bound) if term.bound > 0 else value_tol
        viol = np.maximum(term.bound - vals, 0.0)
    elif term.kind == "angle_to":
        vals = angle_to_deg(c, el, term.par[:, 0:3])
        viol, tol = np.maximum(vals - term.bound, 0.0), angle_tol_deg
    else:
        vals = np.asarray(g, dtype=float) if g is not None else np.full(len(el), math.nan)
        viol = np.maximum(np.maximum(term.lower - vals, vals - term.upper), 0.0)
        tol = value_tol
    viol = np.where(np.isfinite(viol), viol, math.inf)
    return Measurement(term.name, term.kind, KINDS[term.kind][1], float(term.bound), el, vals, viol,
                       float(tol), term.between if term.kind == "torsal_angle" else None)


def worst_missed(measured: dict[str, Measurement]) -> tuple | None:
    """``(name, element id, violation)`` of the worst miss (largest violation relative to its
    tolerance) over all measured constraints, None if every one holds."""
    worst, rel = None, 0.0
    for name, m in measured.items():
        if m.holds:
            continue
        j = int(np.argmax(m.violation))
        r = m.violation[j] / m.tolerance if m.tolerance > 0 else math.inf
        if worst is None or r > rel:
            worst, rel = (name, int(m.elements[j]), float(m.violation[j])), r
    return worst
