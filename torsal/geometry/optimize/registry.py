"""The terms of a problem and the congruences they act on: :class:`TermRegistry`.

:class:`~torsal.geometry.optimize.CongruenceProblem`'s term builders (:mod:`.energies`,
:mod:`.constraints`) register :class:`~torsal.geometry.optimize.catalogue.Term` objects here;
the NLP cache (:mod:`.cache`) reads the list an NLP is built from (:meth:`TermRegistry.term_list`)
and the parameter values a solve starts with (:meth:`TermRegistry.current`); the solve room
(:mod:`.solve`) reads the aligned congruences and the directions they carry.
"""
from __future__ import annotations

import math
from dataclasses import replace
from enum import Enum

import casadi as ca
import numpy as np

from . import terms as T
from ..congruence import Congruence
from ..mesh import edge_face_adjacency
from .catalogue import _KINDS, DEFAULT_WEIGHTS, Term, _as_index, _penalty_term, _var_index
from .forms import unlifted


class Normalize(str, Enum):
    """How ``||e_i|| = 1`` is kept (``CongruenceProblem(normalize=...)``, documented there)."""

    TANGENT = "tangent"
    CONSTRAINT = "constraint"
    RENORMALIZE = "renormalize"


#: the ``normalize`` options of :class:`~torsal.geometry.optimize.CongruenceProblem` (the first is the default)
NORMALIZE = tuple(n.value for n in Normalize)

#: the NLP mode of the L-BFGS baseline: constraints as penalties (:func:`.catalogue._penalty_term`)
PENALTY = "penalty"


def check_weights(weights: dict | None) -> dict:
    """The default weights with the user's overrides, checked (known names, finite, >= 0)."""
    weights = dict(weights or {})
    unknown = set(weights) - set(DEFAULT_WEIGHTS)
    if unknown:
        raise ValueError(f"unknown weight names {sorted(unknown)}; known: {sorted(DEFAULT_WEIGHTS)}")
    for k, w in weights.items():
        if not (np.isfinite(w) and w >= 0):
            raise ValueError(f"weight {k!r} must be a finite number >= 0, got {w}")
    return {**DEFAULT_WEIGHTS, **weights}


class TermRegistry:
    """The registered terms by name, over one congruence and those aligned with it (``align_with``).

    Parameters
    ----------
    congruence : Congruence
        Mesh A and the start directions of the first block.
    weights : dict
        Default weight per term name (:data:`DEFAULT_WEIGHTS` with the user's overrides).
    """

    def __init__(self, congruence: Congruence, weights: dict):
        self.congruence = congruence
        self.delta = congruence.delta
        self.weights = weights
        self.blocks: list[Congruence] = [congruence]
        self.offsets: list[int] = [0]
        self.terms: dict[str, Term] = {}
        self._edges = None
        #: terms registered before :meth:`move_vertices` and not since (their data are the old points)
        self.stale: set[str] = set()

    @property
    def n_var(self) -> int:
        """Direction coordinates over all blocks (3 per vertex)."""
        return int(sum(3 * len(b.vertices) for b in self.blocks))

    def weight(self, name: str, weight) -> float:
        """``weight``, or the default of ``name`` where it is None; checked."""
        w = self.weights[name] if weight is None else float(weight)
        if not (np.isfinite(w) and w >= 0):
            raise ValueError(f"weight of {name!r} must be a finite number >= 0, got {weight}")
        return w

    def add(self, term: Term) -> bool:
        """Register ``term`` (replacing one of its name); True where the NLP's structure changed
        (new elements, data or kernel), False where only parameters or the weight did."""
        old = self.terms.get(term.name)
        self.terms[term.name] = term
        self.stale.discard(term.name)
        return old is None or old.signature() != term.signature()

    def custom_term(self, name: str, fn, over: str, elements, params, *, weight: float | None = None,
                    lower: float = 0.0, upper: float = math.inf) -> Term:
        """A user's own energy (``weight`` given) or constraint (``lower <= fn <= upper``) over
        the ``over`` elements of mesh A (see ``add_term`` / ``add_constraint``)."""
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
        return Term(name, weight is None, el, _var_index(verts, 0), c.vertices[verts].reshape(m, 3 * k),
                    np.array(par), ids, scale=1.0 / m, weight=1.0 if weight is None else float(weight),
                    lower=float(lower), upper=float(upper))

    def move_vertices(self, vertices: np.ndarray) -> None:
        """Mesh A's vertices (n, 3) moved, its faces kept: the first congruence becomes the
        moved mesh with its normals as start directions (see
        :meth:`CongruenceProblem.move_vertices <torsal.geometry.optimize.CongruenceProblem.move_vertices>`)."""
        v = np.asarray(vertices, dtype=float)
        c = self.congruence
        if v.shape != c.vertices.shape or not np.isfinite(v).all():
            raise ValueError(f"moved vertices must be finite, shape {c.vertices.shape}; got {v.shape}")
        if len(self.blocks) > 1:
            raise ValueError("a problem aligned with another congruence (align_with) moves both: "
                             "make a new one")
        moved = Congruence.from_normals((v, c.faces))
        self.congruence, self.blocks[0], self.delta = moved, moved, moved.delta
        self.stale = set(self.terms)

    # ------------------------------------------------------------------ mesh data
    def face_data(self, faces: np.ndarray, block: int = 0):
        """Corner ids and corner points of A in units of delta (see the problem's notes)."""
        c = self.blocks[block]
        fv = c.faces[faces]
        return fv, c.vertices[fv].reshape(len(faces), 9) / self.delta

    def interior_edges(self):
        """``(edge ids, (m, 4) vertices i, j, k, l)`` of the interior edges: ``ij`` the edge,
        ``k`` and ``l`` the opposite corners of its two faces (cached)."""
        if self._edges is None:
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
            self._edges = (inner, np.stack([i, j, k, l], axis=1))
        return self._edges

    # ------------------------------------------------------------------ directions
    def directions(self) -> np.ndarray:
        """The blocks' current directions, stacked (N, 3)."""
        return np.concatenate([b.directions for b in self.blocks])

    def congruences(self, e: np.ndarray) -> list[Congruence]:
        """The aligned congruences with stacked directions ``e`` (N, 3)."""
        out, start = [], 0
        for c in self.blocks:
            n = len(c.vertices)
            out.append(c.with_directions(e[start:start + n]))
            start += n
        return out

    def check_directions(self, directions) -> np.ndarray:
        """``directions`` as stacked (N, 3) (None: the current ones), or a clear error."""
        e = self.directions() if directions is None else np.asarray(directions, float).reshape(-1, 3)
        if e.size != self.n_var:
            raise ValueError(f"directions must have {self.n_var // 3} rows, got {e.size // 3}")
        return e

    # ------------------------------------------------------------------ the NLP's view
    def implied_hyperbolic(self, t: Term) -> Term | None:
        """``hyperbolic`` without the faces where ``min_torsal_angle`` implies it (None if all).

        On a face where both rows of the split torsal-angle form hold,
        ``sqrt(rho^2 + s^2) >= (s + |p|) / cos(alpha) > s + |p|``, so ``rho > |p|``: the face
        is hyperbolic (``c_hyp > 0``). With margin 0 its ``c_hyp`` row adds nothing but a
        row whose gradient vanishes near a line bundle (LICQ fails there) and barrier terms
        (measured on row 7c, 300 iterations: objective 0.74 without those rows, 0.90 with
        them). It is left out of the NLP there and still measured on every face.
        """
        if t.kind != "hyperbolicity" or np.any(t.par[:, 0] > 0):
            return t
        covered = [a.elements for a in self.terms.values()
                   if a.kind == "torsal_angle" and a.block == t.block
                   and a.element.fn.name() in ("c_ang_split", "c_ang_lift")]
        if not covered:
            return t
        keep = ~np.isin(t.elements, np.concatenate(covered))
        if not keep.any():
            return None
        return replace(t, idx=t.idx[keep], data=t.data[keep], par=t.par[keep], elements=t.elements[keep])

    def term_list(self, mode: str) -> list[Term]:
        """The terms an NLP of ``mode`` (a :class:`Normalize` value or :data:`PENALTY`) is built from."""
        # the L-BFGS baseline has no variables but the directions: a lifted form as split rows
        out = [(_penalty_term(unlifted(t)) if (mode == PENALTY and t.constraint) else self.implied_hyperbolic(t))
               for t in self.terms.values()]
        out = [t for t in out if t is not None]
        nv = self.n_var // 3
        allv = np.arange(nv)
        idx = 3 * allv[:, None] + np.arange(3)
        if mode == Normalize.CONSTRAINT:
            out.append(Term("unit_length", True, T.unit_length_element(), idx, np.zeros((nv, 0)),
                            np.zeros((nv, 0)), allv, lower=0.0, upper=0.0))
        elif mode == Normalize.RENORMALIZE:
            x, d, p = T.face_symbols(1, n_data=0)
            q = ca.dot(x, x) - 1.0
            el = T.ElementTerm("unit_penalty", ca.Function("f_unit", [x, d, p], [q * q]), 1)
            out.append(Term("unit_penalty", False, el, idx, np.zeros((nv, 0)), np.zeros((nv, 0)), allv,
                            scale=1.0 / nv, weight=1.0))
        return out

    def current(self) -> dict:
        """The terms' parameter values as the NLPs have them (hyperbolic without the rows
        min_torsal_angle implies; the penalties of lifted forms as their split rows)."""
        if self.stale:
            raise ValueError(f"the terms {sorted(self.stale)} were registered before mesh A's vertices "
                             "moved (move_vertices): register them again on the moved mesh")
        cur = {k: (self.implied_hyperbolic(t) or t) for k, t in self.terms.items()}
        for k, t in self.terms.items():
            if t.constraint:
                cur["penalty:" + k] = unlifted(t)
        return cur

    def constraints(self, mode: str) -> list[Term]:
        """Every constraint to measure: the user's (also where the NLP leaves one out as
        implied) and the NLP's own (``unit_length``)."""
        cons = [t for t in self.terms.values() if t.constraint]
        return cons + [t for t in self.term_list(mode) if t.constraint and t.name not in self.terms]

    def has_bounding_rows(self, mode: str) -> bool:
        """Inequality rows other than hyperbolicity (a torsal-angle bound, an angle to a line,
        a custom constraint) in the NLP of ``mode``."""
        return any(t.constraint and t.lower < t.upper and t.kind != "hyperbolicity" for t in self.term_list(mode))
