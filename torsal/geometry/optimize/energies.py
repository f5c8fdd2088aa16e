"""The energies of eq. (9) and section 4.1 as builder methods: :class:`EnergyTerms`.

Each method registers one :class:`~torsal.geometry.optimize.catalogue.Term` (an element
function of :mod:`torsal.geometry.optimize.terms` with its elements' variable indices, mesh
data and NLP parameters) in the problem's :class:`~torsal.geometry.optimize.registry.TermRegistry`
and returns the problem, so calls chain. :class:`~torsal.geometry.optimize.CongruenceProblem`
is built from this and :class:`~torsal.geometry.optimize.constraints.ConstraintTerms`.
"""
from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from dataclasses import replace
from typing import Callable, Self

import numpy as np
import scipy.sparse as sp

from . import terms as T
from ..mesh import umbrella_laplacian
from .catalogue import Term, _as_index, _points, _stroke_barycentric, _unit_rows, _var_index


#: f_fair's matrices kept by mesh A's faces (a live session registers a design's terms again
#: on every edit, on the same faces: the Laplacian and its Kronecker product took 14 ms of the
#: 35 of 7a's full-size problem)
_FAIR_KEEP = 4
_FAIR: OrderedDict = OrderedDict()
_FAIR_LOCK = threading.Lock()      # a session's preview and its background build share it


def _fair_matrix(faces: np.ndarray, n: int) -> sp.csr_matrix:
    """``L^T L (x) I_3`` of the umbrella Laplacian ``L`` of ``faces`` over ``n`` vertices (kept
    for the last :data:`_FAIR_KEEP` meshes; not to be changed in place)."""
    f = np.ascontiguousarray(faces, dtype=np.int64)
    key = (n, f.shape, hashlib.sha1(f.tobytes()).hexdigest())
    with _FAIR_LOCK:
        Q = _FAIR.get(key)
        if Q is not None:
            _FAIR.move_to_end(key)
            return Q
    L = umbrella_laplacian(f, n)
    Q = sp.kron((L.T @ L).tocsr(), sp.identity(3), format="csr")
    with _FAIR_LOCK:
        _FAIR[key] = Q
        while len(_FAIR) > _FAIR_KEEP:
            _FAIR.popitem(last=False)
    return Q


class EnergyTerms:
    """The energies of :class:`~torsal.geometry.optimize.CongruenceProblem` (its ``registry``
    holds what they register; ``_add`` registers a term and returns the problem)."""

    def fair(self, weight: float | None = None) -> Self:
        """f_fair = 1/|V| sum ||Delta e_i||^2, umbrella Laplacian (Wang et al. 2013, 4.1).

        Quadratic: ``1/|V| e^T (L^T L (x) I_3) e``; evaluated as a sparse matrix product, its
        Hessian is the constant ``2/|V| L^T L (x) I_3``.

        Examples
        --------
        >>> from torsal.geometry import Congruence, CongruenceProblem
        >>> from torsal.geometry.surfaces import sphere_patch
        >>> p = CongruenceProblem(Congruence.from_normals(sphere_patch(nu=5, nv=5))).fair()
        >>> p.terms["fair"]
        ('energy', 1.0, 25)
        """
        c = self.congruence
        n = len(c.vertices)
        Q = _fair_matrix(c.faces, n)
        t = Term("fair", False, None, np.zeros((n, 0), np.int64), np.zeros((n, 0)), np.zeros((n, 0)),
                  np.arange(n), scale=1.0 / n, weight=self.registry.weight("fair", weight), matrix=Q)
        return self._add(t)

    def normal(self, weight: float | None = None, faces=None) -> Self:
        """f_norm = 1/(delta^2 |F'|) sum r^2 with r the eq. (7) residual (Wang et al. 2013, 4.1).

        Examples
        --------
        >>> from torsal.geometry import Congruence, CongruenceProblem
        >>> from torsal.geometry.surfaces import sphere_patch
        >>> v, f = sphere_patch(nu=5, nv=5)      # unit sphere: the exact normals are v
        >>> CongruenceProblem(Congruence(v, f, v)).normal().energies()["normal"] < 1e-20
        True
        """
        fi = _as_index(faces, len(self.congruence.faces), "faces")
        fv, a = self.registry.face_data(fi)
        t = Term("normal", False, T.normality_element(), _var_index(fv, 0), a, np.zeros((len(fi), 0)),
                  fi, scale=1.0 / len(fi), weight=self.registry.weight("normal", weight))
        return self._add(t)

    def fair_torsal(self, weight: float | None = None) -> Self:
        """f_fair/t: no jump of torsal planes across interior edges (Wang et al. 2013, 4.1).

        ``1/|E_int| sum ||r||^2`` with the residual of
        :func:`torsal.geometry.optimize.terms.fair_torsal_residual_sx` (barycentric-coordinate condition,
        denominators cleared, divided by ``delta^4``).

        Examples
        --------
        >>> from torsal.geometry import Congruence, CongruenceProblem
        >>> from torsal.geometry.surfaces import sphere_patch
        >>> p = CongruenceProblem(Congruence.from_normals(sphere_patch(nu=5, nv=5)))
        >>> p.fair_torsal().terms["fair_torsal"][0]
        'energy'
        """
        inner, quad = self.registry.interior_edges()
        if len(inner) == 0:
            raise ValueError("fair_torsal needs interior edges; the mesh has none")
        a = self.congruence.vertices[quad].reshape(len(quad), 12) / self.delta
        t = Term("fair_torsal", False, T.fair_torsal_element(1.0), _var_index(quad, 0), a,
                  np.zeros((len(quad), 0)), inner, scale=1.0 / len(quad),
                  weight=self.registry.weight("fair_torsal", weight))
        return self._add(t)

    def perpendicular(self, d, vertices=None, weight: float | None = None,
                      name: str = "perpendicular", *, vertex_weights=None) -> Self:
        """f_perp: lines orthogonal to the light, 1/|V'| sum w_i <e_i, d_i>^2 (eq. (9)).

        Parameters
        ----------
        d : (3,) or (|V'|, 3) float
            Light (sun) direction(s), any length (normalized here). An NLP parameter.
        vertices : int array or bool mask, optional
            The subset V' (default all vertices).
        name : str
            Use distinct names for several perpendicular terms (e.g. per sun position).
        vertex_weights : (|V'|,) float, optional
            A factor ``w_i >= 0`` per vertex of V' (default 1). NLP parameters (folded into
            ``d_i`` as ``sqrt(w_i) d_i``): a region given as weights over every vertex
            (0 outside it, ``|V| / |region|`` inside: the region's mean) moves without
            rebuilding the NLP, where a subset ``vertices`` is its structure.

        Examples
        --------
        >>> from torsal.geometry import Congruence, CongruenceProblem
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> round(p.perpendicular([0, 1, 0]).energies()["perpendicular"], 2)
        0.95
        >>> w = np.zeros(25); w[[0, 1]] = 25 / 2                # vertices 0, 1 as weights
        >>> a = p.perpendicular([0, 1, 0], vertex_weights=w).energies()["perpendicular"]
        >>> b = p.perpendicular([0, 1, 0], vertices=[0, 1]).energies()["perpendicular"]
        >>> bool(np.isclose(a, b, rtol=1e-14))
        True
        """
        return self._direction_term(name, T.perpendicular_element(), d, vertices, weight,
                                    "perpendicular", "light direction d", vertex_weights)

    def parallel(self, d, vertices=None, weight: float | None = None,
                 name: str = "parallel", *, vertex_weights=None) -> Self:
        """f_par: lines parallel to ``d``, 1/|V'| sum w_i ||e_i x d_i||^2 (eq. (9), Fig. 9).

        ``vertex_weights``: as in :meth:`perpendicular` (a let-through region as NLP
        parameters).

        Examples
        --------
        >>> from torsal.geometry import Congruence, CongruenceProblem
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> round(p.parallel([0, -1, 0], vertices=[0, 1]).energies()["parallel"], 2)
        0.08
        """
        return self._direction_term(name, T.parallel_element(), d, vertices, weight,
                                    "parallel", "direction d", vertex_weights)

    def _direction_term(self, name: str, element, d, vertices, weight, kind: str,
                        what: str, vertex_weights=None) -> Self:
        """A term of one unit direction per vertex of V' (f_perp, f_par): mean over V',
        each summand times its vertex weight (``par = sqrt(w_i) d_i``: both energies are
        quadratic in ``d_i``)."""
        vi = _as_index(vertices, len(self.congruence.vertices), "vertices")
        dd = _unit_rows(d, len(vi), what)
        w = None
        if vertex_weights is not None:
            w = np.asarray(vertex_weights, dtype=float)
            if w.shape != (len(vi),) or not np.isfinite(w).all() or np.any(w < 0):
                raise ValueError(f"vertex_weights must be {len(vi)} finite numbers >= 0 (one per vertex "
                                 f"of the subset), got shape {w.shape}")
            dd = dd * np.sqrt(w)[:, None]
        t = Term(name, False, element, _var_index(vi, 0), np.zeros((len(vi), 0)), dd,
                 vi, scale=1.0 / len(vi), weight=self.registry.weight(kind, weight),
                 element_weights=None if w is None else w.copy())
        return self._add(t)

    def through_points(self, points, vertices, weight: float | None = None,
                       name: str = "through_points") -> Self:
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
        >>> from torsal.geometry import Congruence, CongruenceProblem
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
                  weight=self.registry.weight("through_points", weight))
        return self._add(t)

    def closeness(self, initial=None, weight: float | None = None) -> Self:
        """Regularizer 1/|V| sum ||e_i - e_i,0||^2 to stay near ``initial`` (default: the start).

        Examples
        --------
        >>> from torsal.geometry import Congruence, CongruenceProblem
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
                  np.array(e0), np.arange(n), scale=1.0 / n, weight=self.registry.weight("closeness", weight))
        return self._add(t)

    def _strokes(self, fi, segments, normals=None):
        fv, a = self.registry.face_data(fi)
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
                         name: str = "torsal_direction", *, face_weights=None) -> Self:
        """f_dir: prescribed torsal directions (design strokes), Wang et al. 2013, 4.1 and eq. (9).

        ``1/|F'| sum w_f ([a_p2 - a_p1, e_p1, e_p2] / delta)^2``: the lines through the stroke's
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
            With ``face_weights``, a face of weight 0 needs none (a zero row, or any).
        face_weights : (|F'|,) float, optional
            A factor ``w_f >= 0`` per face of F' (default 1). NLP parameters: the residual
            is of degree 3 in the endpoints' barycentric coordinates, so they are scaled by
            ``w_f^(1/6)``. Strokes given as weights over every face (0 off them, ``|F| /
            |F'|`` on them: their mean) move without rebuilding the NLP, where a subset
            ``faces`` is its structure.

        Examples
        --------
        >>> from torsal.geometry import Congruence, CongruenceProblem
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p.torsal_direction([0, 1], [1.0, 0, 0]).terms["torsal_direction"]
        ('energy', 0.1, 2)
        >>> e = np.random.default_rng(0).normal(size=(25, 3))
        >>> a = p.energies(e)["torsal_direction"]
        >>> w = np.zeros(32); w[[0, 1]] = 32 / 2                 # faces 0, 1 as weights
        >>> d = np.zeros((32, 3)); d[[0, 1]] = [1.0, 0, 0]
        >>> b = p.torsal_direction(None, d, face_weights=w).energies(e)["torsal_direction"]
        >>> bool(np.isclose(a, b, rtol=1e-12))
        True
        """
        fi = _as_index(faces, len(self.congruence.faces), "faces")
        if face_weights is None:
            fv, w, fw = *self._strokes(fi, segments), None
        else:
            fw = np.asarray(face_weights, dtype=float)
            if fw.shape != (len(fi),) or not np.isfinite(fw).all() or np.any(fw < 0):
                raise ValueError(f"face_weights must be {len(fi)} finite numbers >= 0 (one per face "
                                 f"of the subset), got shape {fw.shape}")
            live = fw > 0
            fv, w = self.congruence.faces[fi], np.zeros((len(fi), 6))
            if live.any():
                seg = np.asarray(segments, dtype=float)
                seg = seg[live] if seg.ndim >= 2 and len(seg) == len(fi) else seg
                w[live] = self._strokes(fi[live], seg)[1] * fw[live, None] ** (1.0 / 6.0)
            fw = fw.copy()
        t = Term(name, False, T.torsal_direction_element(1.0), _var_index(fv, 0),
                  self.congruence.vertices[fv].reshape(len(fi), 9) / self.delta, w,
                  fi, scale=1.0 / len(fi), weight=self.registry.weight("torsal_direction", weight),
                  element_weights=fw)
        return self._add(t)

    def torsal_plane(self, faces, segments=None, normals=None, weight: float | None = None,
                     name: str = "torsal_plane") -> Self:
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
        >>> from torsal.geometry import Congruence, CongruenceProblem
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
                  weight=self.registry.weight("torsal_plane", weight))
        return self._add(t)

    def align_with(self, other: Self, weight: float | None = None,
                   label: str = "aligned") -> Self:
        """f_extra: optimize ``other`` together with this problem so torsal directions coincide.

        Wang et al. 2013, 4.3 (Fig. 11): ``1/|F| sum (||g_L x g_L'|| / delta^2)^2`` with
        ``g = (gamma_0, 2 gamma_1, gamma_2)`` (see
        :func:`torsal.geometry.optimize.terms.torsal_alignment_element` for the typesetting choice).
        ``other`` must have the same faces (its vertices may differ, e.g. an offset). Its terms
        and constraints at the time of this call are copied in under ``"<label>.<name>"``;
        the result's ``congruences[1]`` is the optimized ``other``.

        Examples
        --------
        >>> from torsal.geometry import Congruence, CongruenceProblem
        >>> from torsal.geometry.surfaces import facade_patch
        >>> v, f = facade_patch(nu=5, nv=5)
        >>> p, q = (CongruenceProblem(Congruence.from_normals((v + s, f))).fair() for s in (0, 0.5))
        >>> sorted(p.align_with(q).terms)
        ['align', 'aligned.fair', 'fair']
        """
        if not isinstance(other, EnergyTerms) or other is self:
            raise TypeError("align_with needs another CongruenceProblem")
        oc = other.congruence
        if oc.faces.shape != self.congruence.faces.shape or not np.array_equal(oc.faces, self.congruence.faces):
            raise ValueError("align_with needs a congruence over the same faces (combinatorially equal meshes)")
        if len(other.registry.blocks) > 1:
            raise ValueError("the other problem is already aligned with a third one; align pairwise from one problem")
        if any(b is oc for b in self.registry.blocks):
            raise ValueError("this congruence is already aligned")
        off = self.n_var
        self.registry.blocks.append(oc)
        self.registry.offsets.append(off)
        for name, t in other.registry.terms.items():
            nt = replace(t, name=f"{label}.{name}", idx=t.idx + off, par=t.par.copy(), offset=t.offset + off,
                         block=len(self.registry.blocks) - 1)
            self.registry.terms[nt.name] = nt
        fv = self.congruence.faces
        idx = np.concatenate([_var_index(fv, 0), _var_index(fv, off)], axis=1)
        data = np.concatenate([self.congruence.vertices[fv].reshape(len(fv), 9),
                               oc.vertices[fv].reshape(len(fv), 9)], axis=1) / self.delta
        t = Term("align", False, T.torsal_alignment_element(1.0), idx, data,
                  np.zeros((len(fv), 0)), np.arange(len(fv)), scale=1.0 / len(fv),
                  weight=self.registry.weight("align", weight))
        self._structure_changed()
        return self._add(t)

    def add_term(self, name: str, weight: float, fn: Callable, over: str = "faces", elements=None,
                 params=None) -> Self:
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
        >>> from torsal.geometry import Congruence, CongruenceProblem
        >>> import casadi as ca
        >>> from torsal.geometry.surfaces import facade_patch
        >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
        >>> p = p.add_term("vertical", 1.0, lambda e, a: e[0, 2] ** 2, over="vertices")
        >>> p.energies()["vertical"] < 0.2
        True
        """
        return self._add(self.registry.custom_term(name, fn, over, elements, params, weight=weight))
