"""Integration of torsal directions into polylines and discrete developables (Wang et al. 2013, 2.2, Fig. 4).

Inside one face the congruence is the affine congruence of eq. (4), whose developables are
planar (property 2 of the affine example): a torsal curve is a straight segment in each face,
and the lines along it fill one torsal plane. Crossing an edge, the curve continues with the
torsal direction of the next face that deviates least from the previous one. Connecting the
polyline on A with the corresponding polyline on B (piecewise-linear correspondence) gives
a strip of planar quads: a discrete developable contained in the congruence.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .congruence import (
    Congruence,
    _discriminant,
    face_frame,
    focal_coefficients,
    solve_torsal_directions,
    torsal_coefficients,
)
from .mesh import edge_face_adjacency, unique_edges

__all__ = ["TorsalCurve", "trace_torsal_curve", "torsal_directions_at"]


@dataclass(frozen=True)
class TorsalCurve:
    """A traced torsal curve and its developable.

    Attributes
    ----------
    points_a : (m, 3) float
        Polyline on A (model units): the start point, then one point per crossed edge.
    points_b : (m, 3) float
        The corresponding polyline on B, ``sum_k beta_k b_k`` of the containing face.
    faces : (m-1,) int
        Face of A containing each segment.
    barycentric : (m, 3) float
        Barycentric coordinates of ``points_a[s]`` in the face of the segment it ends
        (the first point: the segment it starts).
    stop_reasons : tuple of str
        Why tracing stopped at the start end and at the far end: ``"boundary"``,
        ``"not hyperbolic"``, ``"bundle"``, ``"turned back"``, ``"step limit"``
        (or ``"start"`` when only one direction was traced).
    """

    points_a: np.ndarray
    points_b: np.ndarray
    faces: np.ndarray
    barycentric: np.ndarray
    stop_reasons: tuple

    @property
    def strip(self) -> np.ndarray:
        """The developable between the polylines as quads ``a_s a_{s+1} b_{s+1} b_s``, (m-1, 4, 3)."""
        a, b = self.points_a, self.points_b
        return np.stack([a[:-1], a[1:], b[1:], b[:-1]], axis=1)

    @property
    def length(self) -> float:
        """Length of the polyline on A, model units."""
        return float(np.linalg.norm(np.diff(self.points_a, axis=0), axis=1).sum())


def torsal_directions_at(congruence: Congruence, face: int, barycentric) -> tuple[np.ndarray, str]:
    """The two torsal directions of the affine congruence of ``face`` at a point, (2, 3) unit.

    Wang et al. 2013, eq. (1) evaluated at the barycentric point instead of the barycenter.
    Returns the directions and a status: ``"ok"``, ``"not hyperbolic"`` or ``"bundle"``
    (directions are NaN unless ``"ok"``).
    """
    fr = face_frame(congruence.vertices, congruence.faces[[face]], congruence.directions,
                    barycentric=np.asarray(barycentric, float)[None, :])
    disc, tol = _discriminant(focal_coefficients(fr))
    if disc[0] < -tol[0]:
        return np.full((2, 3), np.nan), "not hyperbolic"
    gamma = torsal_coefficients(fr)
    scale = (max(np.linalg.norm(fr.a_u[0]), np.linalg.norm(fr.a_v[0]))
             * max(np.linalg.norm(fr.e_u[0]), np.linalg.norm(fr.e_v[0])) * np.linalg.norm(fr.e[0]))
    if scale == 0 or np.abs(gamma[0]).max() <= congruence.bundle_rtol * scale:
        return np.full((2, 3), np.nan), "bundle"
    uv = solve_torsal_directions(fr, gamma)[0]
    t = uv[:, :1] * fr.a_u[0] + uv[:, 1:] * fr.a_v[0]
    return t / np.linalg.norm(t, axis=1, keepdims=True), "ok"


class _Tracer:
    """Walks straight segments face by face; holds the adjacency needed to step over edges."""

    def __init__(self, c: Congruence):
        self.c = c
        self.v = c.vertices
        self.f = c.faces
        self.b = c.vertices_b
        _, self.face_edges = unique_edges(self.f)
        _, self.edge_faces = edge_face_adjacency(self.f)

    def bary_of_direction(self, face: int, d: np.ndarray) -> np.ndarray:
        """Barycentric velocity of a tangent direction d in ``face`` (sums to zero)."""
        a0, a1, a2 = self.v[self.f[face]]
        basis = np.stack([a1 - a0, a2 - a0], axis=1)  # 3x2
        duv = np.linalg.lstsq(basis, d, rcond=None)[0]
        return np.array([-duv[0] - duv[1], duv[0], duv[1]])

    def bary_of_point(self, face: int, p: np.ndarray) -> np.ndarray:
        a0, a1, a2 = self.v[self.f[face]]
        basis = np.stack([a1 - a0, a2 - a0], axis=1)
        uv = np.linalg.lstsq(basis, p - a0, rcond=None)[0]
        return np.array([1.0 - uv[0] - uv[1], uv[0], uv[1]])

    def point(self, face: int, beta: np.ndarray) -> np.ndarray:
        return beta @ self.v[self.f[face]]

    def point_b(self, face: int, beta: np.ndarray) -> np.ndarray:
        return beta @ self.b[self.f[face]]

    def walk(self, face: int, beta: np.ndarray, d: np.ndarray, max_steps: int):
        """Trace from (face, beta) along d.

        Returns the points crossed (3D, starting with the start point), the face of each
        segment between them, and the stop reason.
        """
        points, seg_faces = [self.point(face, beta)], []
        for _ in range(max_steps):
            dbeta = self.bary_of_direction(face, d)
            with np.errstate(divide="ignore", invalid="ignore"):
                s = np.where(dbeta < -1e-15, -beta / dbeta, np.inf)
            s = np.where(s < 1e-12, np.inf, s)  # ignore the edge we stand on
            k = int(np.argmin(s))
            if not np.isfinite(s[k]):
                return points, seg_faces, "turned back"
            exit_beta = beta + s[k] * dbeta
            exit_beta[k] = 0.0
            exit_beta = np.clip(exit_beta, 0.0, 1.0)
            exit_beta /= exit_beta.sum()
            q = self.point(face, exit_beta)
            points.append(q)
            seg_faces.append(face)
            nxt = self.edge_faces[self.face_edges[face, k]]
            nxt = nxt[(nxt != face) & (nxt >= 0)]
            if nxt.size == 0:
                return points, seg_faces, "boundary"
            face = int(nxt[0])
            beta = np.clip(self.bary_of_point(face, q), 0.0, 1.0)
            beta /= beta.sum()
            dirs, status = torsal_directions_at(self.c, face, beta)
            if status != "ok":
                return points, seg_faces, status
            # least deviation from the previous direction (paper 2.2), kept pointing forward
            cos = dirs @ d
            j = int(np.argmax(np.abs(cos)))
            d = dirs[j] * (1.0 if cos[j] >= 0 else -1.0)
        return points, seg_faces, "step limit"


def trace_torsal_curve(congruence: Congruence, face: int, point=None, family: int = 0, *,
                       both_ways: bool = True, max_steps: int = 10_000) -> TorsalCurve:
    """Integrate one family of torsal directions from a point (Wang et al. 2013, 2.2, Fig. 4).

    Straight within each face (the affine congruence's developables are planar), continuing
    across each edge with the torsal direction of least deviation; stops at the boundary, at a
    non-hyperbolic or bundle face, when no direction continues forward, or after ``max_steps``.

    Parameters
    ----------
    congruence : Congruence
    face : int
        Face of A containing the start point.
    point : (3,) float, optional
        Start point (model units), projected into the face plane; default the barycenter.
    family : {0, 1}
        Which torsal direction to follow at the start: the one closest to
        ``congruence.torsal_directions()[face, family]``.
    both_ways : bool, default True
        Trace forwards and backwards from the point and join the two halves.
    max_steps : int
        Maximal number of faces crossed in each direction.

    Returns
    -------
    TorsalCurve
        Polylines on A and B and the developable strip between them.

    Examples
    --------
    >>> from torsal.geometry.surfaces import cylinder_patch
    >>> v, f = cylinder_patch(radius=1.0, nu=9, nv=7)
    >>> curve = trace_torsal_curve(Congruence(v, f, v * [1, 1, 0]), face=20, family=0)
    >>> curve.stop_reasons, bool(np.ptp(curve.points_a[:, 2]) < 1e-12)  # a circle around the axis
    (('boundary', 'boundary'), True)
    """
    if family not in (0, 1):
        raise ValueError(f"family must be 0 or 1, got {family!r}")
    nf = len(congruence.faces)
    if not 0 <= int(face) < nf:
        raise ValueError(f"face {face} does not exist; the mesh has {nf} faces")
    face = int(face)
    tr = _Tracer(congruence)
    if point is None:
        beta = np.full(3, 1.0 / 3.0)
    else:
        beta = tr.bary_of_point(face, np.asarray(point, float))
        if beta.min() < -1e-9:
            raise ValueError(f"point {np.asarray(point).tolist()} is not inside face {face} "
                             f"(barycentric coordinates {beta.round(6).tolist()})")
        beta = np.clip(beta, 0.0, 1.0) / np.clip(beta, 0.0, 1.0).sum()
    dirs, status = torsal_directions_at(congruence, face, beta)
    if status != "ok":
        raise ValueError(f"face {face} has no torsal directions at the start point ({status}); "
                         "start from a hyperbolic face that is not a line bundle")
    ref = congruence.torsal_directions()[face, family]
    if np.all(np.isfinite(ref)):
        d = dirs[int(np.argmax(np.abs(dirs @ ref)))]
    else:
        d = dirs[family]

    p_fw, f_fw, why_fw = tr.walk(face, beta, d, max_steps)
    if both_ways:
        p_bw, f_bw, why_bw = tr.walk(face, beta, -d, max_steps)
    else:
        p_bw, f_bw, why_bw = p_fw[:1], [], "start"
    # join: backward half reversed (its start point is the forward half's first point)
    points = p_bw[:0:-1] + p_fw
    faces = f_bw[::-1] + f_fw
    # the face each point is evaluated in: the segment it starts or ends
    point_faces = faces[:1] + faces if faces else [face]
    pts_a = np.array(points)
    betas = np.array([tr.bary_of_point(fc, p) for fc, p in zip(point_faces, pts_a)])
    betas = np.clip(betas, 0.0, 1.0)
    betas /= betas.sum(axis=1, keepdims=True)
    pts_b = np.array([tr.point_b(fc, bb) for fc, bb in zip(point_faces, betas)])
    return TorsalCurve(points_a=pts_a, points_b=pts_b, faces=np.array(faces, dtype=np.int64),
                       barycentric=betas, stop_reasons=(why_bw, why_fw))
