"""The problem builder: :class:`CongruenceProblem` (Wang et al. 2013, 4.1, eq. (9)).

Energies and constraints are added by chaining methods (the term catalogue of
:mod:`~torsal.geometry.optimize.catalogue` and :mod:`torsal.geometry.optimize.terms`); :meth:`solve`
assembles the NLP (:mod:`~torsal.geometry.optimize.nlp`), runs IPOPT
(:mod:`~torsal.geometry.optimize.ipopt`) or the L-BFGS baseline
(:mod:`~torsal.geometry.optimize.lbfgs`), and measures the constraints on the answer
(:mod:`~torsal.geometry.optimize.measure`).
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Callable

import casadi as ca
import numpy as np
import scipy.sparse as sp

from . import terms as T
from ..congruence import Congruence
from ..mesh import edge_face_adjacency, umbrella_laplacian
from .catalogue import (DEFAULT_WEIGHTS, _KINDS, Term, _as_index, _penalty_term, _points,
                        _stroke_barycentric, _unit_rows, _var_index)
from .forms import (ANGLE_BETWEEN, ANGLE_FORMS, TorsalAngleBetween, TorsalAngleForm, torsal_angle_split_element,
                    torsal_form_coordinates_element)
from .measure import Measurement, measure
from .nlp import Built
from .result import OptimizationResult
from .solve import SOLVERS, Optimum, SolveCall, SolveOptions

#: the ``hessian`` options of :class:`CongruenceProblem` (the first is the default)
HESSIANS = ("projected", "exact", "guarded", "gauss-newton", "auto")


class CongruenceProblem:
    """An optimization problem over the line directions of a congruence (Wang et al. 2013, 4.1).

    Build it by chaining term and constraint methods, then call :meth:`solve`.

    Parameters
    ----------
    congruence : Congruence
        Mesh A and the initial directions (e.g. ``Congruence.from_normals``).
    weights : dict, optional
        Overrides of :data:`DEFAULT_WEIGHTS` by term name, used when a method gets no ``weight``.
    normalize : {"tangent", "constraint", "renormalize"}
        How ``||e_i|| = 1`` is kept. ``"tangent"`` (default, fastest): every ``e_i`` is a unit
        vector by construction, ``e = (f0 + z1 f1 + z2 f2) / sqrt(1 + z1^2 + z2^2)`` with 2
        variables per vertex around a frame re-centred at the start of every solve (a
        gnomonic chart; halves the KKT system compared to ``"constraint"``).
        ``"constraint"``: ``||e_i||^2 = 1`` as IPOPT equality constraints.
        ``"renormalize"``: the paper's way: no unit constraint; a penalty
        ``mean((||e_i||^2 - 1)^2)`` (weight 1) keeps lengths near 1 during a solve, and the
        directions are renormalized afterwards (and after every round of ``lbfgs``).
    hessian : {"projected", "exact", "guarded", "gauss-newton", "auto"}
        Hessian of the energies' part of the Lagrangian. ``"projected"`` (default): in an NLP
        without constraint rows (a problem without constraints, and pass 1 of a solve with
        inequalities, see ``try_unconstrained`` of :meth:`solve`), each energy element's
        Hessian and each vertex's chart curvature with its negative eigenvalues clamped to 0
        (projected Newton, :mod:`~torsal.geometry.optimize.projected`) for the first
        ``PROJECTED_ITERATIONS`` (10) IPOPT iterations, then exact; NLPs with constraint rows
        use the exact Hessian. The projected sum is positive semidefinite, so IPOPT factors
        once per iteration instead of searching for a regularization, and only the elements
        that curve down are flattened (fewer iterations than the exact Hessian on the
        unconstrained Fig. 12 rows and at 100k vertices, ``benchmarks/optimize_bench.py``);
        it switches to exact because projected Newton converges linearly where the
        energies' minimum is not zero. The augmented Lagrangian (``solve(solver="alm")``)
        builds its own NLP with every element projected (:mod:`~torsal.geometry.optimize.alm`).
        ``"gauss-newton"``: ``2 J_r^T J_r`` for
        every energy that is a sum of squares (all built-in ones but ``fair``, which is
        quadratic and exact either way), no chart curvature for them; positive semidefinite,
        so IPOPT's inertia correction only meets the constraints' curvature (the constraints
        keep their exact Hessian). ``"exact"``: the exact Hessian. ``"guarded"``:
        Gauss-Newton for a problem without constraints, checked: if its answer has more
        faces without torsal directions than the start, by more than ``solve.COLLAPSE_SHARE`` (2 %)
        of the faces (:meth:`_collapse`), the solve is repeated from the same start with the
        exact Hessian, which the problem then keeps; exact for a problem with constraints.
        ``"auto"``: Gauss-Newton for pass 1 of a solve with inequality constraints (the NLP
        without them, see ``try_unconstrained`` of :meth:`solve`), exact for every other NLP.
        Gauss-Newton converges in a few iterations where the exact Hessian is indefinite,
        but its full steps can land on a trivial zero of the energies, close to a line
        bundle (faces without torsal directions); the guard catches that and returns the
        exact Hessian's answer at the cost of a second solve, so it is not the default: it
        pays off where the energies' minimum is not zero (e.g. with ``closeness``).
    elastic : float, default 0
        ``rho > 0``: the elastic (l1-exact penalty) form of the one-sided inequalities (slacks
        ``p_j >= 0``, ``c_j + p_j >= l_j``, ``rho / |V| sum p_j`` in the objective; see
        :meth:`~torsal.geometry.optimize.nlp.Built._elastic`): LICQ holds everywhere, every
        start is feasible, multipliers are bounded by ``rho``. 0 (default): off. An option for
        IPOPT, not the default (it did not converge faster on row 7c); on small patches it
        reaches the same optimum (tests/geometry/test_optimize_forms.py).
    jit : bool, default False
        Compile the per-element kernels to C with the system compiler (casadi codegen; cached
        on disk in ``~/.cache/torsal/kernels`` or ``$TORSAL_KERNEL_CACHE``, so only the first
        build on a machine pays ~1 s per kernel). Evaluations get several times faster:
        use it for large meshes and the interactive loop.

    Notes
    -----
    Every element term sees mesh A in units of ``delta`` (``a / delta``, with unit line
    directions), so the paper's normalizations (``1/delta^2`` in f_norm, ``c_hyp / delta^2``,
    ...) are exact and every kernel is independent of the mesh (compiled once with
    ``jit=True``). For f_fair/t this means ``B = A/delta + e`` in the projection condition
    (its zero set does not depend on the distance of B; see
    :func:`torsal.geometry.optimize.terms.fair_torsal_residual_sx`).

    Examples
    --------
    >>> from torsal.geometry.surfaces import facade_patch
    >>> c = Congruence.from_normals(facade_patch(nu=9, nv=7))
    >>> res = (CongruenceProblem(c).normal().fair().perpendicular([0.3, -0.8, -0.5])
    ...        .hyperbolic().solve())
    >>> res.success, res.max_violation["hyperbolic"] <= 1e-6     # c_hyp / delta^2, measured
    (True, True)
    """

    def __init__(self, congruence: Congruence, weights: dict | None = None,
                 normalize: str = "tangent", jit: bool = False, hessian: str = HESSIANS[0],
                 elastic: float = 0.0):
        if not isinstance(congruence, Congruence):
            raise TypeError("CongruenceProblem needs a torsal Congruence (e.g. Congruence.from_normals(mesh))")
        if normalize not in ("tangent", "constraint", "renormalize"):
            raise ValueError(f"normalize must be 'tangent', 'constraint' or 'renormalize', got {normalize!r}")
        weights = dict(weights or {})
        unknown = set(weights) - set(DEFAULT_WEIGHTS)
        if unknown:
            raise ValueError(f"unknown weight names {sorted(unknown)}; known: {sorted(DEFAULT_WEIGHTS)}")
        for k, w in weights.items():
            if not (np.isfinite(w) and w >= 0):
                raise ValueError(f"weight {k!r} must be a finite number >= 0, got {w}")
        self.congruence = congruence
        self.normalize = normalize
        self.jit = bool(jit)
        if hessian not in HESSIANS:
            raise ValueError(f"hessian must be one of {HESSIANS}, got {hessian!r}")
        self.hessian = hessian
        self._exact_after_collapse = False     # "guarded": Gauss-Newton collapsed, see solve
        if not (np.isfinite(elastic) and elastic >= 0):
            raise ValueError(f"elastic must be a finite number >= 0 (0: off), got {elastic}")
        self.elastic = float(elastic)
        self.weights = {**DEFAULT_WEIGHTS, **weights}
        self.delta = congruence.delta
        self._blocks: list[Congruence] = [congruence]
        self._offsets: list[int] = [0]
        self._terms: dict[str, Term] = {}
        self._built: dict[str, Built] = {}
        self._kernels: dict = {}   # element kernels, shared by the NLPs built (Built's ``kernels``)
        self._last: dict | None = None
        self._strategy = None    # the IPOPT solve in progress (ipopt.IpoptStrategy)
        self._edges_cache = None

    # ------------------------------------------------------------------ helpers
    @property
    def n_var(self) -> int:
        return int(sum(3 * len(b.vertices) for b in self._blocks))

    @property
    def terms(self) -> dict:
        """Registered terms and constraints by name: ``{name: (kind, weight or None, n_elements)}``."""
        return {k: ("constraint" if t.constraint else "energy", None if t.constraint else t.weight,
                    len(np.unique(t.elements)))
                for k, t in self._terms.items()}

    def _weight(self, name: str, weight) -> float:
        w = self.weights[name] if weight is None else float(weight)
        if not (np.isfinite(w) and w >= 0):
            raise ValueError(f"weight of {name!r} must be a finite number >= 0, got {weight}")
        return w

    def _add(self, term: Term) -> "CongruenceProblem":
        old = self._terms.get(term.name)
        self._terms[term.name] = term
        if old is not None and old.signature() == term.signature():
            return self   # only parameters / weight changed: keep the built solver
        self._forget_built()
        self._last = None
        self._exact_after_collapse = False
        return self

    def _face_data(self, faces: np.ndarray, block: int = 0):
        """Corner ids and corner points of A in units of delta (see the class notes)."""
        c = self._blocks[block]
        fv = c.faces[faces]
        return fv, c.vertices[fv].reshape(len(faces), 9) / self.delta

    def _interior_edges(self):
        if self._edges_cache is None:
            f = self.congruence.faces
            edges, ef = edge_face_adjacency(f)
            inner = np.flatnonzero(ef[:, 1] >= 0)
            e, f0, f1 = edges[inner], ef[inner, 0], ef[inner, 1]

            def rotate(face_ids):
                fv = f[face_ids]
                other = (fv != e[:, :1]) & (fv != e[:, 1:])
                c = np.argmax(other, axis=1)
                r = np.arange(len(fv))
                return fv[r, (c + 1) % 3], fv[r, (c + 2) % 3], fv[r, c]

            i, j, k = rotate(f0)
            _, _, l = rotate(f1)
            self._edges_cache = (inner, np.stack([i, j, k, l], axis=1))
        return self._edges_cache

    # ------------------------------------------------------------------ energies
    def fair(self, weight: float | None = None) -> "CongruenceProblem":
        """f_fair = 1/|V| sum ||Delta e_i||^2, umbrella Laplacian (Wang et al. 2013, 4.1).

        Quadratic: ``1/|V| e^T (L^T L (x) I_3) e``; evaluated as a sparse matrix product, its
        Hessian is the constant ``2/|V| L^T L (x) I_3``.

        Examples
        --------
        >>> from torsal.geometry.surfaces import sphere_patch
        >>> p = CongruenceProblem(Congruence.from_normals(sphere_patch(nu=5, nv=5))).fair()
        >>> p.terms["fair"]
        ('energy', 1.0, 25)
        """
        c = self.congruence
        n = len(c.vertices)
        L = umbrella_laplacian(c.faces, n)
        Q = sp.kron((L.T @ L).tocsr(), sp.identity(3), format="csr")
        t = Term("fair", False, None, np.zeros((n, 0), np.int64), np.zeros((n, 0)), np.zeros((n, 0)),
                  np.arange(n), scale=1.0 / n, weight=self._weight("fair", weight), matrix=Q)
        return self._add(t)

    def normal(self, weight: float | None = None, faces=None) -> "CongruenceProblem":
        """f_norm = 1/(delta^2 |F'|) sum r^2 with r the eq. (7) residual (Wang et al. 2013, 4.1).

        Examples
        --------
        >>> from torsal.geometry.surfaces import sphere_patch
        >>> v, f = sphere_patch(nu=5, nv=5)      # unit sphere: the exact normals are v
        >>> CongruenceProblem(Congruence(v, f, v)).normal().energies()["normal"] < 1e-20
        True
        """
        fi = _as_index(faces, len(self.congruence.faces), "faces")
        fv, a = self._face_data(fi)
        t = Term("normal", False, T.normality_element(), _var_index(fv, 0), a, np.zeros((len(fi), 0)),
                  fi, scale=1.0 / len(fi), weight=self._weight("normal", weight))
        return self._add(t)

    def fair_torsal(self, weight: float | None = None) -> "CongruenceProblem":
        """f_fair/t: no jump of torsal planes across interior edges (Wang et al. 2013, 4.1).

        ``1/|E_int| sum ||r||^2`` with the residual of
        :func:`torsal.geometry.optimize.terms.fair_torsal_residual_sx` (barycentric-coordinate condition,
        denominators cleared, divided by ``delta^4``).

        Examples
        --------
        >>> from torsal.geometry.surfaces import sphere_patch
        >>> p = CongruenceProblem(Congruence.from_normals(sphere_patch(nu=5, nv=5)))
        >>> p.fair_torsal().terms["fair_torsal"][0]
        'energy'
        """
        inner, quad = self._interior_edges()
        if len(inner) == 0:
            raise ValueError("fair_torsal needs interior edges; the mesh has none")
        a = self.congruence.vertices[quad].reshape(len(quad), 12) / self.delta
        t = Term("fair_torsal", False, T.fair_torsal_element(1.0), _var_index(quad, 0), a,
                  np.zeros((len(quad), 0)), inner, scale=1.0 / len(quad),
                  weight=self._weight("fair_torsal", weight))
        return self._add(t)

    def perpendicular(self, d, vertices=None, weight: float | None = None,
                      name: str = "perpendicular") -> "CongruenceProblem":
        """f_perp: lines orthogonal to the light, 1/|V'| sum <e_i, d_i>^2 (eq. (9)).

        Parameters
        ----------
        d : (3,) or (|V'|, 3) float
            Light (sun) direction(s), any length (normalized here). An NLP parameter.
        vertices : int array or bool mask, optional
            The subset V' (default all vertices).
        name : str
            Use distinct names for several perpendicular terms (e.g. per sun position).

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> round(p.perpendicular([0, 1, 0]).energies()["perpendicular"], 2)
        0.95
        """
        return self._direction_term(name, T.perpendicular_element(), d, vertices, weight,
                                    "perpendicular", "light direction d")

    def parallel(self, d, vertices=None, weight: float | None = None,
                 name: str = "parallel") -> "CongruenceProblem":
        """f_par: lines parallel to ``d``, 1/|V'| sum ||e_i x d_i||^2 (eq. (9), Fig. 9).

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> round(p.parallel([0, -1, 0], vertices=[0, 1]).energies()["parallel"], 2)
        0.08
        """
        return self._direction_term(name, T.parallel_element(), d, vertices, weight,
                                    "parallel", "direction d")

    def _direction_term(self, name: str, element, d, vertices, weight, kind: str,
                        what: str) -> "CongruenceProblem":
        """A term of one unit direction per vertex of V' (f_perp, f_par): mean over V'."""
        vi = _as_index(vertices, len(self.congruence.vertices), "vertices")
        dd = _unit_rows(d, len(vi), what)
        t = Term(name, False, element, _var_index(vi, 0), np.zeros((len(vi), 0)), dd,
                 vi, scale=1.0 / len(vi), weight=self._weight(kind, weight))
        return self._add(t)

    def through_points(self, points, vertices, weight: float | None = None,
                       name: str = "through_points") -> "CongruenceProblem":
        """Lines through target points O_i (Fig. 7c see-through areas).

        ``1/(delta^2 |V'|) sum ||(O_i - a_i) x e_i||^2``: for unit ``e_i`` the mean squared
        distance of ``O_i`` from the line ``L_i``, in units of ``delta``.

        Parameters
        ----------
        points : (3,) or (|V'|, 3) float
            Target points O_i (model units). An NLP parameter.
        vertices : int array or bool mask
            The subset V'.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p = p.through_points([0.0, -10.0, 3.0], vertices=[12])
        >>> p.terms["through_points"]
        ('energy', 1.0, 1)
        """
        vi = _as_index(vertices, len(self.congruence.vertices), "vertices")
        pts = _points(points, len(vi), "target points")
        if np.any(np.linalg.norm(pts - self.congruence.vertices[vi], axis=1) < 1e-9 * self.delta):
            raise ValueError("a target point coincides with its vertex; every line passes through it")
        t = Term(name, False, T.through_point_element(), _var_index(vi, 0),
                  self.congruence.vertices[vi] / self.delta, pts / self.delta, vi, scale=1.0 / len(vi),
                  weight=self._weight("through_points", weight))
        return self._add(t)

    def closeness(self, initial=None, weight: float | None = None) -> "CongruenceProblem":
        """Regularizer 1/|V| sum ||e_i - e_i,0||^2 to stay near ``initial`` (default: the start).

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p.closeness().energies()["closeness"] < 1e-20
        True
        """
        n = len(self.congruence.vertices)
        e0 = self.congruence.directions if initial is None else np.asarray(initial, dtype=float)
        if e0.shape != (n, 3) or not np.isfinite(e0).all():
            raise ValueError(f"initial directions must be a finite ({n}, 3) array, got shape {e0.shape}")
        t = Term("closeness", False, T.closeness_element(), _var_index(np.arange(n), 0), np.zeros((n, 0)),
                  np.array(e0), np.arange(n), scale=1.0 / n, weight=self._weight("closeness", weight))
        return self._add(t)

    def _strokes(self, fi, segments, normals=None):
        fv, a = self._face_data(fi)
        corners = a.reshape(-1, 3, 3)
        if segments is None:
            if normals is None:
                raise ValueError("give stroke segments, or plane normals to derive them from")
            fn = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
            tdir = np.cross(normals, fn)
        else:
            s = np.asarray(segments, dtype=float)
            if s.shape == (len(fi), 2, 3):
                tdir = s[:, 1] - s[:, 0]
            elif s.shape in ((len(fi), 3), (3,)):
                tdir = np.broadcast_to(s, (len(fi), 3))
            else:
                raise ValueError(f"segments must have shape ({len(fi)}, 2, 3) (endpoints) or "
                                 f"({len(fi)}, 3) (directions), got {s.shape}")
            if not np.isfinite(tdir).all():
                raise ValueError("segments contain NaN or infinite values")
        return fv, _stroke_barycentric(corners, np.asarray(tdir, float))

    def torsal_direction(self, faces, segments, weight: float | None = None,
                         name: str = "torsal_direction") -> "CongruenceProblem":
        """f_dir: prescribed torsal directions (design strokes), Wang et al. 2013, 4.1 and eq. (9).

        ``1/|F'| sum ([a_p2 - a_p1, e_p1, e_p2] / delta)^2``: the lines through the stroke's
        endpoints are coplanar (see :func:`torsal.geometry.optimize.terms.torsal_direction_residual_sx`
        for why this replaces the printed ``[e_p1, e_p2, e_c]``). Each stroke only gives a
        direction: it is re-centred at the face barycenter (the paper requires ``c`` on
        ``p1 p2``) and extended to the triangle's boundary; ``e_p`` is interpolated linearly.

        Parameters
        ----------
        faces : int array or bool mask
            The subset F'.
        segments : (|F'|, 2, 3) or (|F'|, 3) float
            Stroke segments (endpoints) or stroke directions, one per face. NLP parameters.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p.torsal_direction([0, 1], [1.0, 0, 0]).terms["torsal_direction"]
        ('energy', 0.1, 2)
        """
        fi = _as_index(faces, len(self.congruence.faces), "faces")
        fv, w = self._strokes(fi, segments)
        t = Term(name, False, T.torsal_direction_element(1.0), _var_index(fv, 0),
                  self.congruence.vertices[fv].reshape(len(fi), 9) / self.delta, w,
                  fi, scale=1.0 / len(fi), weight=self._weight("torsal_direction", weight))
        return self._add(t)

    def torsal_plane(self, faces, segments=None, normals=None, weight: float | None = None,
                     name: str = "torsal_plane") -> "CongruenceProblem":
        """f_plane = f_dir + <e_c, n>^2: prescribed torsal planes (Wang et al. 2013, 4.1, Fig. 7d).

        Parameters
        ----------
        faces : int array or bool mask
        segments : optional
            As in :meth:`torsal_direction`; default the line where the plane meets the face
            (``n x`` face normal).
        normals : (3,) or (|F'|, 3) float
            Unit normals of the wanted torsal planes (e.g. the light direction).

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p.torsal_plane(None, normals=[0.0, 0.6, 0.8]).terms["torsal_plane"]
        ('energy', 20.0, 32)
        """
        fi = _as_index(faces, len(self.congruence.faces), "faces")
        if normals is None:
            raise ValueError("torsal_plane needs the plane normals n")
        nn = _unit_rows(normals, len(fi), "plane normals")
        fv, w = self._strokes(fi, segments, nn)
        t = Term(name, False, T.torsal_plane_element(1.0), _var_index(fv, 0),
                  self.congruence.vertices[fv].reshape(len(fi), 9) / self.delta,
                  np.concatenate([w, nn], axis=1), fi, scale=1.0 / len(fi),
                  weight=self._weight("torsal_plane", weight))
        return self._add(t)

    def align_with(self, other: "CongruenceProblem", weight: float | None = None,
                   label: str = "aligned") -> "CongruenceProblem":
        """f_extra: optimize ``other`` together with this problem so torsal directions coincide.

        Wang et al. 2013, 4.3 (Fig. 11): ``1/|F| sum (||g_L x g_L'|| / delta^2)^2`` with
        ``g = (gamma_0, 2 gamma_1, gamma_2)`` (see
        :func:`torsal.geometry.optimize.terms.torsal_alignment_element` for the typesetting choice).
        ``other`` must have the same faces (its vertices may differ, e.g. an offset). Its terms
        and constraints at the time of this call are copied in under ``"<label>.<name>"``;
        the result's ``congruences[1]`` is the optimized ``other``.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> v, f = facade_patch(nu=5, nv=5)
        >>> p, q = (CongruenceProblem(Congruence.from_normals((v + s, f))).fair() for s in (0, 0.5))
        >>> sorted(p.align_with(q).terms)
        ['align', 'aligned.fair', 'fair']
        """
        if not isinstance(other, CongruenceProblem) or other is self:
            raise TypeError("align_with needs another CongruenceProblem")
        oc = other.congruence
        if oc.faces.shape != self.congruence.faces.shape or not np.array_equal(oc.faces, self.congruence.faces):
            raise ValueError("align_with needs a congruence over the same faces (combinatorially equal meshes)")
        if len(other._blocks) > 1:
            raise ValueError("the other problem is already aligned with a third one; align pairwise from one problem")
        if any(b is oc for b in self._blocks):
            raise ValueError("this congruence is already aligned")
        off = self.n_var
        self._blocks.append(oc)
        self._offsets.append(off)
        for name, t in other._terms.items():
            nt = replace(t, name=f"{label}.{name}", idx=t.idx + off, par=t.par.copy(), offset=t.offset + off,
                         block=len(self._blocks) - 1)
            self._terms[nt.name] = nt
        fv = self.congruence.faces
        idx = np.concatenate([_var_index(fv, 0), _var_index(fv, off)], axis=1)
        data = np.concatenate([self.congruence.vertices[fv].reshape(len(fv), 9),
                               oc.vertices[fv].reshape(len(fv), 9)], axis=1) / self.delta
        t = Term("align", False, T.torsal_alignment_element(1.0), idx, data,
                  np.zeros((len(fv), 0)), np.arange(len(fv)), scale=1.0 / len(fv),
                  weight=self._weight("align", weight))
        self._forget_built()
        self._last = None
        return self._add(t)

    def add_term(self, name: str, weight: float, fn: Callable, over: str = "faces", elements=None,
                 params=None) -> "CongruenceProblem":
        """A user's own energy: ``weight * mean over elements of fn(e, a[, p])``.

        Parameters
        ----------
        name : str
        weight : float
        fn : callable
            ``fn(e, a)`` or, with ``params``, ``fn(e, a, p)``: casadi ``SX`` matrices ``e``, ``a``
            of shape (k, 3) (line directions and points of the element's vertices: k = 1 for
            vertices, 3 for faces in corner order, 2 for edges) and ``p`` (r,). Returns a
            scalar expression, evaluated once symbolically and mapped over all elements.
        over : {"faces", "vertices", "edges"}
        elements : int array or bool mask, optional
            Subset of the elements (default all).
        params : (r,) or (m, r) float, optional
            Per-element NLP parameters (changeable without rebuilding).

        Examples
        --------
        >>> import casadi as ca
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p = p.add_term("vertical", 1.0, lambda e, a: e[0, 2] ** 2, over="vertices")
        >>> p.energies()["vertical"] < 0.2
        True
        """
        return self._add_custom(name, fn, over, elements, params, weight=weight)

    def add_constraint(self, name: str, fn: Callable, over: str = "faces", elements=None,
                       params=None, lower: float = 0.0, upper: float = math.inf) -> "CongruenceProblem":
        """A user's own constraint ``lower <= fn(e, a[, p]) <= upper`` on every element.

        Arguments as in :meth:`add_term`. IPOPT enforces it; ``lbfgs`` penalizes violations.
        Scale ``fn`` to be dimensionless and of order 1 for good convergence.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p = p.add_constraint("outward", lambda e, a: -e[0, 1], over="vertices", lower=0.1)
        >>> p.terms["outward"][0]
        'constraint'
        """
        if not (lower <= upper):
            raise ValueError(f"constraint {name!r}: lower bound {lower} exceeds upper bound {upper}")
        return self._add_custom(name, fn, over, elements, params, lower=lower, upper=upper)

    def _add_custom(self, name, fn, over, elements, params, weight=None, lower=0.0, upper=math.inf):
        if over not in _KINDS:
            raise ValueError(f"over must be one of {_KINDS}, got {over!r}")
        if not callable(fn):
            raise TypeError("fn must be a callable returning a casadi expression")
        c = self.congruence
        if over == "vertices":
            ids = _as_index(elements, len(c.vertices), "vertices")
            verts = ids[:, None]
        elif over == "faces":
            ids = _as_index(elements, len(c.faces), "faces")
            verts = c.faces[ids]
        else:
            edges, _ = edge_face_adjacency(c.faces)
            ids = _as_index(elements, len(edges), "edges")
            verts = edges[ids]
        m, k = verts.shape
        if params is None:
            par = np.zeros((m, 0))
        else:
            par = np.asarray(params, dtype=float)
            par = np.broadcast_to(par, (m, par.size)) if par.ndim <= 1 else par
            if par.shape[0] != m or not np.isfinite(par).all():
                raise ValueError(f"params must be finite, shape (r,) or ({m}, r); got {np.shape(params)}")
        el = T.custom_element(name, fn, k, par.shape[1])
        t = Term(name, weight is None, el, _var_index(verts, 0), c.vertices[verts].reshape(m, 3 * k),
                  np.array(par), ids, scale=1.0 / m, weight=1.0 if weight is None else float(weight),
                  lower=float(lower), upper=float(upper))
        return self._add(t)

    # ------------------------------------------------------------------ constraints
    def hyperbolic(self, faces=None, margin: float = 0.0) -> "CongruenceProblem":
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
        left out of IPOPT's NLP and still measured (see ``_implied_hyperbolic``).

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p.hyperbolic().terms["hyperbolic"]
        ('constraint', None, 32)
        """
        if not np.isfinite(margin):
            raise ValueError("margin must be finite")
        fi = _as_index(faces, len(self.congruence.faces), "faces")
        fv, a = self._face_data(fi)
        old = self._terms.get("hyperbolic")
        if old is not None and bool(np.all(old.par[:, 0] <= 0)) != (margin <= 0):
            self._forget_built()     # rows implied by min_torsal_angle only at margin <= 0
        t = Term("hyperbolic", True, T.hyperbolicity_element(1.0), _var_index(fv, 0), a,
                  np.full((len(fi), 1), float(margin)), fi, kind="hyperbolicity", bound=float(margin))
        return self._add(t)

    def min_torsal_angle(self, alpha_deg: float = 40.0, faces=None, safety_deg: float = 0.01, *,
                         min_strength: float = 1e-3,
                         form: TorsalAngleForm | str = TorsalAngleForm.SPLIT,
                         between: TorsalAngleBetween | str = TorsalAngleBetween.PLANES) -> "CongruenceProblem":
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
        fv, a = self._face_data(fi)
        c = math.cos(math.radians(min(alpha_deg + safety_deg, 89.999)))
        if form is TorsalAngleForm.CONE:
            t = Term("min_torsal_angle", True, T.torsal_angle_cone_element(1.0, between), _var_index(fv, 0), a,
                     np.tile([c, float(min_strength)], (len(fi), 1)), fi, kind="torsal_angle",
                     bound=float(alpha_deg), between=between.value)
        elif form is TorsalAngleForm.LIFT:   # three rows per face, u, v, w = lifted variables (see .forms)
            t = _lifted_angle_term(fi, fv, a, c, float(min_strength), float(alpha_deg), between)
        else:
            t = _split_angle_term(fi, fv, a, c, float(min_strength), float(alpha_deg), between)
        return self._add(t)

    def max_angle_to(self, d, theta_deg: float, vertices=None) -> "CongruenceProblem":
        """<e_i, d_i> - cos(theta) >= 0: lines within ``theta_deg`` of ``d`` (Wang et al. 2013, 4.1).

        Directions are unit vectors in the default ``normalize="tangent"`` (and with
        ``"constraint"``). Measured on the result as the angle between ``e_i`` and ``d_i`` in
        degrees; a constraint value error ``tau`` (IPOPT's 1e-9) is an angle error of
        ``tau / sin(theta)`` radians.

        Examples
        --------
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

    def set_weight(self, name: str, weight: float) -> "CongruenceProblem":
        """Change one energy's weight (an NLP parameter: no rebuild)."""
        if name not in self._terms or self._terms[name].constraint:
            raise KeyError(f"no energy named {name!r}; energies: "
                           f"{sorted(k for k, t in self._terms.items() if not t.constraint)}")
        if not (np.isfinite(weight) and weight >= 0):
            raise ValueError(f"weight of {name!r} must be a finite number >= 0, got {weight}")
        self._terms[name].weight = float(weight)
        return self

    def remove(self, name: str) -> "CongruenceProblem":
        """Remove a term or constraint (the solver is rebuilt at the next solve)."""
        if name not in self._terms:
            raise KeyError(f"no term named {name!r}; terms: {sorted(self._terms)}")
        del self._terms[name]
        self._forget_built()
        self._last = None
        return self

    # ------------------------------------------------------------------ assembly
    def _mode(self, solver: str) -> str:
        return "penalty" if solver == "lbfgs" else self.normalize

    def _implied_hyperbolic(self, t: Term) -> Term | None:
        """``hyperbolic`` without the faces where ``min_torsal_angle`` implies it (None if all).

        On a face where both rows of the split torsal-angle form hold,
        ``sqrt(rho^2 + s^2) >= (s + |p|) / cos(alpha) > s + |p|``, so ``rho > |p|``: the face
        is hyperbolic (``c_hyp > 0``). With margin 0 its ``c_hyp`` row adds nothing but a
        row whose gradient vanishes near a line bundle (LICQ fails there) and barrier terms
        (measured on row 7c, 300 iterations: objective 0.74 without those rows, 0.90 with
        them). It is left out of IPOPT's NLP there and still measured on every face.
        """
        if t.kind != "hyperbolicity" or np.any(t.par[:, 0] > 0):
            return t
        covered = [a.elements for a in self._terms.values()
                   if a.kind == "torsal_angle" and a.block == t.block
                   and a.element.fn.name() in ("c_ang_split", "c_ang_lift")]
        if not covered:
            return t
        keep = ~np.isin(t.elements, np.concatenate(covered))
        if not keep.any():
            return None
        return replace(t, idx=t.idx[keep], data=t.data[keep], par=t.par[keep], elements=t.elements[keep])

    def _term_list(self, mode: str) -> list[Term]:
        # the L-BFGS baseline has no variables but the directions: a lifted form as split rows
        out = [(_penalty_term(_unlifted(t)) if (mode == "penalty" and t.constraint) else self._implied_hyperbolic(t))
               for t in self._terms.values()]
        out = [t for t in out if t is not None]
        nv = self.n_var // 3
        allv = np.arange(nv)
        idx = 3 * allv[:, None] + np.arange(3)
        if mode == "constraint":
            out.append(Term("unit_length", True, T.unit_length_element(), idx, np.zeros((nv, 0)),
                             np.zeros((nv, 0)), allv, lower=0.0, upper=0.0))
        elif mode == "renormalize":
            x, d, p = T.face_symbols(1, n_data=0)
            q = ca.dot(x, x) - 1.0
            el = T.ElementTerm("unit_penalty", ca.Function("f_unit", [x, d, p], [q * q]), 1)
            out.append(Term("unit_penalty", False, el, idx, np.zeros((nv, 0)), np.zeros((nv, 0)), allv,
                             scale=1.0 / nv, weight=1.0))
        return out

    def build(self, solver: str = "ipopt") -> float:
        """Assemble the NLP (done by :meth:`solve` when needed); returns the seconds it took.

        ``solver``: ``"ipopt"`` (the NLP IPOPT solves), ``"alm"`` (the same NLP with every
        element Hessian projected, see :mod:`.alm`) or ``"lbfgs"`` (constraints as
        penalties). The built NLP is kept until a term's element subset changes (parameters
        and weights can change freely).
        """
        if solver not in ("ipopt", "lbfgs", "alm"):
            raise ValueError(f"solver must be 'ipopt', 'alm' or 'lbfgs', got {solver!r}")
        key = self._key(solver)
        if key in self._built:
            return 0.0
        if not self._terms:
            raise ValueError("the problem has no terms; add energies (e.g. .normal().fair()) before solving")
        mode = self._mode(solver)
        terms = self._term_list(mode)
        hessian = "projected-all" if solver == "alm" else self._hessian_of(False, terms)
        # IPOPT's main NLP: derivatives on first use (pass 1 answers many designs without them)
        self._built[key] = Built(terms, self.n_var // 3, mode, self.jit, hessian,
                                 elastic=self.elastic if mode != "penalty" and solver != "alm" else 0.0,
                                 lazy=solver == "ipopt", kernels=self._kernels)
        return self._built[key].seconds

    def _forget_built(self) -> None:
        """The terms' structure changed: the built NLPs and their element kernels are dropped
        (rebuilt at the next solve)."""
        self._built.clear()
        self._kernels.clear()

    def _key(self, solver: str) -> str:
        """The key of ``solver``'s NLP in ``self._built``."""
        return self._mode(solver) + ("/alm" if solver == "alm" else "")

    def _hessian_of(self, pass1: bool, terms: list) -> str:
        """The energies' Hessian of the NLP of ``terms`` (``hessian="auto"``: Gauss-Newton for
        pass 1 of a solve with inequalities, exact otherwise; ``"projected"``: projected where
        the NLP has no constraint rows, exact where it has; see the class docstring)."""
        if self.hessian == "projected":
            return "exact" if any(t.constraint for t in terms) else "projected"
        if self.hessian == "guarded":
            constrained = any(t.constraint for t in self._terms.values())
            return "exact" if constrained or self._exact_after_collapse else "gauss-newton"
        if self.hessian != "auto":
            return self.hessian
        return "gauss-newton" if pass1 else "exact"

    def _free_built(self, mode: str) -> tuple[Built, float]:
        """The NLP of ``mode`` without its inequality constraints (built once, as needed)."""
        key = mode + "/without-inequalities"
        if key in self._built:
            return self._built[key], 0.0
        terms = [t for t in self._term_list(mode) if not (t.constraint and (t.lower < t.upper or t.lift))]
        self._built[key] = Built(terms, self.n_var // 3, mode, self.jit, self._hessian_of(True, terms),
                                 kernels=self._kernels)
        return self._built[key], self._built[key].seconds

    def _directions(self) -> np.ndarray:
        return np.concatenate([b.directions for b in self._blocks])

    def _current(self) -> dict:
        # the terms as the NLP has them (hyperbolic without the rows min_torsal_angle implies)
        cur = {k: (self._implied_hyperbolic(t) or t) for k, t in self._terms.items()}
        for k, t in self._terms.items():
            if t.constraint:   # penalties of lifted forms are their split rows
                cur["penalty:" + k] = _unlifted(t)
        return cur

    def _evaluate(self, e: np.ndarray, rows: bool = True):
        """(energies dict, objective, g, built) at stacked directions ``e`` with the main NLP
        (IPOPT's, or the augmented Lagrangian's when only that one is built: same values);
        ``rows=False``: ``g`` is not valid where the NLP has lifted variables (not fitted)."""
        b = self._built.get(self.normalize) or self._built.get(self._key("alm"))
        if b is None:
            self.build("ipopt")
            b = self._built[self.normalize]
        x, fr = b.pack(e)
        ev, f, g = b.evaluate(x, b.parameters(self._current(), fr), rows=rows)
        out = {k: float(v) for k, v in zip(b.energy_names, np.asarray(ev).ravel())}
        out["total"] = float(f)
        return out, float(f), np.asarray(g).ravel(), b

    def energies(self, directions=None) -> dict:
        """Unweighted energies and ``"total"`` (weighted, eq. (9)) at ``directions`` (default current).

        ``directions`` is (n, 3) for this congruence or the stacked (N, 3) of all aligned ones.
        """
        e = self._directions() if directions is None else np.asarray(directions, float).reshape(-1, 3)
        if e.size != self.n_var:
            raise ValueError(f"directions must have {self.n_var // 3} rows, got {e.size // 3}")
        return self._evaluate(e, rows=False)[0]


    def _congruences(self, e: np.ndarray) -> list[Congruence]:
        """The aligned congruences with stacked directions ``e`` (N, 3)."""
        out, start = [], 0
        for c in self._blocks:
            n = len(c.vertices)
            out.append(c.with_directions(e[start:start + n]))
            start += n
        return out

    def measure(self, directions=None, *, angle_tol_deg: float = 0.1,
                constraint_tol: float = 1e-6) -> dict[str, Measurement]:
        """Every constraint measured on the geometry at ``directions`` (default: current).

        Torsal angles, hyperbolicity and angles to ``d`` come from
        :class:`~torsal.geometry.congruence.Congruence` (not from the NLP); see
        :mod:`torsal.geometry.optimize.measure`.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5))).min_torsal_angle(30)
        >>> m = p.measure()["min_torsal_angle"]
        >>> m.unit, m.bound, bool(m.values.min() > 30)
        ('deg', 30.0, True)
        """
        e = self._directions() if directions is None else np.asarray(directions, float).reshape(-1, 3)
        if e.size != self.n_var:
            raise ValueError(f"directions must have {self.n_var // 3} rows, got {e.size // 3}")
        # every constraint the user imposed (also where the NLP leaves it out as implied),
        # and the NLP's own (unit_length)
        cons = [t for t in self._terms.values() if t.constraint]
        cons += [t for t in self._term_list(self.normalize) if t.constraint and t.name not in self._terms]
        g_by = {}
        if any(t.kind == "value" for t in cons):
            _, _, g, b = self._evaluate(e)
            g_by = {t.name: g[rows] for t, rows in zip(b.cons, b.g_slices)}
        congs = self._congruences(e) if cons else []
        return {t.name: measure(t, congs[t.block], self.delta, g_by.get(t.name), angle_tol_deg=angle_tol_deg,
                                value_tol=constraint_tol) for t in cons}

    # ------------------------------------------------------------------ solving
    def _report_iteration(self, it: dict) -> bool:
        """IPOPT's iteration callback (cached with the solver) -> the solve in progress
        (``it``: the iterate's ``"x"``, ``"f"``, ``"g"``, see ``IpoptStrategy.report``)."""
        return self._strategy.report(it) if self._strategy is not None else False

    @property
    def optimum(self) -> Optimum | None:
        """The last solve's answer with its multipliers and penalties, None before a solve.

        Picklable: keep it (the pipeline's stage cache does) and hand it to
        :meth:`warm_start_from` of a problem with the same structure to re-solve from it
        after a change of a weight, a light direction, a stroke or a bound.
        """
        if self._last is None:
            return None
        last = self._last
        return Optimum(directions=np.array(last["e"]), lam_g=last.get("lam_g"), alm=last.get("alm"),
                       active=last.get("active"), working=last.get("working"), lam_x=last.get("lam_x"))

    def warm_start_from(self, optimum: Optimum) -> "CongruenceProblem":
        """The next :meth:`solve` starts from ``optimum`` (of this problem or one of the same
        structure): its directions, and its multipliers and penalties where they fit.

        Examples
        --------
        >>> from torsal.geometry.surfaces import facade_patch
        >>> c = Congruence.from_normals(facade_patch(nu=7, nv=5))
        >>> p = CongruenceProblem(c).normal().fair().perpendicular([0.3, -0.8, -0.5]).hyperbolic()
        >>> first = p.solve()
        >>> q = CongruenceProblem(c).normal().fair().perpendicular([0.35, -0.8, -0.5]).hyperbolic()
        >>> q.warm_start_from(p.optimum).solve().success
        True
        """
        if not isinstance(optimum, Optimum):
            raise TypeError("warm_start_from needs an Optimum (CongruenceProblem.optimum)")
        e = np.asarray(optimum.directions, dtype=float)
        if e.size != self.n_var or not np.isfinite(e).all():
            raise ValueError(f"the optimum has {e.size // 3} directions; this problem has {self.n_var // 3}")
        self._last = {"e": e.reshape(-1, 3), "lam_g": optimum.lam_g, "alm": optimum.alm,
                      "active": optimum.active, "working": optimum.working, "lam_x": optimum.lam_x}
        return self

    def solve(self, solver: str = SOLVERS[0], max_iter: int | None = None, tol: float = 1e-4,
              callback: Callable | None = None, *, warm_start: bool = True, initial=None,
              raise_on_failure: bool = False, verbose: bool = False, constraint_tol: float = 1e-6,
              angle_tol_deg: float = 0.1, penalty: float = 1e3, ipopt_options: dict | None = None,
              try_unconstrained: bool = True, max_seconds: float | None = None,
              keep_best: bool = True, certify: bool = False) -> OptimizationResult:
        """Minimize the energies subject to the constraints.

        Parameters
        ----------
        solver : {"auto", "alm", "ipopt", "lbfgs"}
            ``"auto"`` (default): the fastest route to a measured-feasible optimum: the
            augmented Lagrangian for an NLP with inequality rows that it can solve (tangent
            chart, no lifted form or elastic slacks), IPOPT otherwise, where the augmented
            Lagrangian continues if IPOPT's pass without inequalities misses one (``"ipopt+alm"``);
            if the augmented Lagrangian ends without a measured-feasible answer, IPOPT
            continues from it. A warm re-solve of an augmented Lagrangian's answer continues
            with the augmented Lagrangian (its multipliers and penalties).
            ``"alm"``: the paper's augmented Lagrangian with projected-Newton steps, one
            sparse Cholesky factorization per step (:mod:`~torsal.geometry.optimize.alm`).
            ``"ipopt"``: interior point, exact Hessian, MUMPS, real inequality constraints
            (the solver of record).
            ``"lbfgs"``: the paper's baseline: scipy L-BFGS-B in rounds of 10 iterations with
            renormalization of the ``e_i`` after each round; constraints become penalties
            ``penalty * mean(min(c, 0)^2)``.
        max_iter : int, optional
            Iteration limit: Newton steps of the augmented Lagrangian (default 500), IPOPT
            iterations (default 200), L-BFGS iterations (default 1000). Limits are counts,
            so the answer does not depend on the machine's load.
        tol : float
            IPOPT's KKT tolerance, with the objective scaled by the number of vertices (the
            energies are means, so this makes the criterion per vertex and independent of the
            mesh size). The augmented Lagrangian stops at a relative Newton decrement of
            ``tol * 1e-2`` with every constraint holding as measured. L-BFGS: stop when a round decreases the objective by less than ``tol``
            times the starting objective.
        callback : callable, optional
            Called each iteration with ``{"iteration", "objective", "infeasibility",
            "measured_violation"}`` (the last: worst measured violation as a multiple of its
            tolerance, see :class:`IterationRecord`); returning True stops the solve.
        warm_start : bool
            Start from the last solution (with IPOPT's constraint multipliers) when the
            problem structure is unchanged; otherwise from the congruence's directions.
        initial : (n, 3) float, optional
            Explicit start directions (overrides the warm start).
        raise_on_failure : bool
            Raise :class:`OptimizationError` instead of returning an unsuccessful result.
        verbose : bool
            Let IPOPT print its log.
        constraint_tol : float
            Measured violation above which ``hyperbolic`` (in ``c_hyp / delta^2``) and a user's
            own constraint count as not met.
        angle_tol_deg : float
            Measured violation (degrees) above which ``min_torsal_angle`` and ``max_angle_to``
            count as not met (default 0.1).
        penalty : float
            Penalty weight of constraints for ``lbfgs``.
        ipopt_options : dict, optional
            Extra IPOPT options (e.g. ``{"mumps_pivot_order": 7}``).
        max_seconds : float, optional
            A safety net, not a way to shape the result: a wall-time limit; at the limit the
            best feasible iterate is returned and ``OptimizationResult.time_limited`` (and the
            status) say that the answer depends on the machine's load.
        certify : bool
            After the augmented Lagrangian, IPOPT with all constraints from its answer and
            multipliers (warm start): a KKT point to IPOPT's tolerances; ``solver`` of the
            result is then ``"alm+ipopt"`` (kept as the augmented Lagrangian's answer, with a
            status that says so, where IPOPT does not converge).
        keep_best : bool
            When the solver stops early (iteration or time limit, callback) or ends on an
            iterate that misses a constraint as measured, return the lowest-objective iterate
            that was feasible as measured, if any (``from_iteration`` says which).
        try_unconstrained : bool
            IPOPT with inequality constraints: solve in up to three passes.

            1. Without the inequalities (equalities stay). If that answer meets every
               inequality to IPOPT's ``constr_viol_tol`` (1e-9) it is kept: a feasible local
               minimizer of the energy is a local minimizer of the constrained problem. This
               pays off where the constraints are not active but slow IPOPT down, e.g.
               ``hyperbolic`` when the energies favour near-parallel lines (``c_hyp`` is
               degenerate there, see :meth:`hyperbolic`): the bench's row 7a with
               ``hyperbolic()`` needs 14 iterations instead of 200.
            2. If at most 5% of the inequalities are violated: from pass 1's answer, with only
               those and the ones near their bound (the working set) imposed, adding any that
               the answer then violates. The others hold with slack, so their multipliers are
               zero and the answer is a KKT point of the whole problem; IPOPT carries barrier
               terms for a few elements instead of all. (``solver="auto"`` hands passes 2
               and 3 to the augmented Lagrangian: Fig. 13's mirror fins, 78 IPOPT iterations
               in pass 2 against 8 Newton steps.)
            3. Otherwise, or if pass 2 does not converge: all constraints, from the start (or
               from pass 1's answer where that violates fewer of them, e.g. a flat facade).

            ``max_iter`` bounds the iterations of all passes together (pass 1 gets at most
            half, pass 2 half of the rest; in a re-solve, half). A re-solve (warm start) starts at the pass that
            answered last: pass 2 keeps its working set (and multipliers) and grows it as
            needed; pass 3 keeps all constraints. ``OptimizationResult.constraints_active`` and
            ``.working_set`` say which pass gave the result.

        Returns
        -------
        OptimizationResult
            ``success`` needs a converged solver *and* every constraint holding as measured.
        """
        opts = SolveOptions(solver=solver, max_iter=max_iter, tol=tol, callback=callback, warm_start=warm_start,
                            initial=initial, raise_on_failure=raise_on_failure, verbose=verbose,
                            constraint_tol=constraint_tol, angle_tol_deg=angle_tol_deg, penalty=penalty,
                            ipopt_options=ipopt_options, try_unconstrained=try_unconstrained,
                            max_seconds=max_seconds, keep_best=keep_best, certify=certify)
        return SolveCall(self, opts).run()


def _split_angle_term(fi, fv, a, c: float, s: float, alpha_deg: float,
                      between: TorsalAngleBetween = TorsalAngleBetween.PLANES,
                      name: str = "min_torsal_angle") -> Term:
    """c_ang in split form: two rows per face, ``+p`` and ``-p`` (see :mod:`.forms`)."""
    m = len(fi)
    par = np.concatenate([np.tile([c, s, 1.0], (m, 1)), np.tile([c, s, -1.0], (m, 1))])
    return Term(name, True, torsal_angle_split_element(between), _var_index(np.tile(fv, (2, 1)), 0),
                np.tile(a, (2, 1)), par, np.concatenate([fi, fi]), kind="torsal_angle", bound=alpha_deg,
                between=TorsalAngleBetween(between).value)


def _lifted_angle_term(fi, fv, a, c: float, s: float, alpha_deg: float,
                       between: TorsalAngleBetween = TorsalAngleBetween.PLANES) -> Term:
    """c_ang lifted: rows ``u``, ``v``, ``w`` per face, equal to lifted variables (``nlp.Built._lift``)."""
    m = len(fi)
    par = np.concatenate([np.tile(np.r_[c, s, k], (m, 1)) for k in np.eye(3)])
    return Term("min_torsal_angle", True, torsal_form_coordinates_element(between),
                _var_index(np.tile(fv, (3, 1)), 0), np.tile(a, (3, 1)), par, np.tile(fi, 3),
                kind="torsal_angle", bound=alpha_deg, lower=0.0, upper=0.0, lift=True,
                between=TorsalAngleBetween(between).value)


def _unlifted(t: Term) -> Term:
    """A lifted torsal-angle term as the split form over the same faces (for L-BFGS)."""
    if not t.lift:
        return t
    m = t.size // 3
    return replace(_split_angle_term(t.elements[:m], t.idx[:m, ::3] // 3, t.data[:m], float(t.par[0, 0]),
                                     float(t.par[0, 1]), t.bound, t.between, t.name), block=t.block,
                   idx=np.tile(t.idx[:m], (2, 1)))
