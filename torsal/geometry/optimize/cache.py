"""The NLP cache of a problem: :class:`NlpCache`.

A problem's NLPs (:class:`~torsal.geometry.optimize.nlp.Built`: IPOPT's main one, its pass
without inequalities, the augmented Lagrangian's, the L-BFGS penalty form) are built from the
registry's terms (:class:`~torsal.geometry.optimize.registry.TermRegistry`) on first use and
kept, with the element kernels they share, until a term's structure changes: weights, light
directions, strokes and bounds are parameters, so the interactive loop re-solves without a
rebuild.
"""
from __future__ import annotations

from enum import Enum

import numpy as np

from .measure import Measurement, measure
from .nlp import Built
from .registry import PENALTY, TermRegistry


class Hessian(str, Enum):
    """The ``hessian`` options of :class:`~torsal.geometry.optimize.CongruenceProblem` (documented there)."""

    PROJECTED = "projected"
    EXACT = "exact"
    GUARDED = "guarded"
    GAUSS_NEWTON = "gauss-newton"
    AUTO = "auto"


#: the ``hessian`` options of :class:`CongruenceProblem` (the first is the default)
HESSIANS = tuple(h.value for h in Hessian)


class NlpKind(str, Enum):
    """The NLPs a solve asks the cache for."""

    IPOPT = "ipopt"       # the NLP IPOPT solves (also the one energies and rows are evaluated with)
    ALM = "alm"           # the same terms, every element Hessian projected (:mod:`.alm`)
    LBFGS = "lbfgs"       # constraints as penalties


class NlpCache:
    """The built NLPs of one problem, by kind, and the element kernels they share.

    Parameters
    ----------
    registry : TermRegistry
    normalize, jit, hessian, elastic
        As :class:`~torsal.geometry.optimize.CongruenceProblem` takes them (checked there).
    """

    def __init__(self, registry: TermRegistry, *, normalize: str, jit: bool, hessian: str, elastic: float):
        self.registry = registry
        self.normalize, self.jit, self.hessian, self.elastic = normalize, jit, hessian, elastic
        self.built: dict[str, Built] = {}
        self.kernels: dict = {}          # element kernels, shared by the NLPs built (Built's ``kernels``)
        # "guarded": Gauss-Newton collapsed on this structure, so the exact Hessian is kept
        self.exact_after_collapse = False

    def mode(self, kind: str) -> str:
        """The NLP mode of ``kind``: constraints as penalties for L-BFGS, else ``normalize``."""
        return PENALTY if kind == NlpKind.LBFGS else self.normalize

    def key(self, kind: str) -> str:
        """The key of ``kind``'s NLP in :attr:`built`."""
        return self.mode(kind) + ("/alm" if kind == NlpKind.ALM else "")

    def build(self, kind: str = NlpKind.IPOPT) -> float:
        """Build ``kind``'s NLP unless it is built; the seconds it took."""
        if kind not in tuple(NlpKind):
            raise ValueError(f"solver must be 'ipopt', 'alm' or 'lbfgs', got {kind!r}")
        key = self.key(kind)
        if key in self.built:
            return 0.0
        if not self.registry.terms:
            raise ValueError("the problem has no terms; add energies (e.g. .normal().fair()) before solving")
        mode = self.mode(kind)
        terms = self.registry.term_list(mode)
        hessian = "projected-all" if kind == NlpKind.ALM else self.hessian_of(False, terms)
        # IPOPT's main NLP: derivatives on first use (pass 1 answers many designs without them)
        self.built[key] = Built(terms, self.registry.n_var // 3, mode, self.jit, hessian,
                                elastic=self.elastic if mode != PENALTY and kind != NlpKind.ALM else 0.0,
                                lazy=kind == NlpKind.IPOPT, kernels=self.kernels)
        return self.built[key].seconds

    def get(self, kind: str) -> tuple[Built, float]:
        """``kind``'s NLP, built where needed, and the seconds building took."""
        seconds = self.build(kind)
        return self.built[self.key(kind)], seconds

    def without_inequalities(self, mode: str) -> tuple[Built, float]:
        """The NLP of ``mode`` without its inequality constraints (IPOPT's pass 1), built once."""
        key = mode + "/without-inequalities"
        if key in self.built:
            return self.built[key], 0.0
        terms = [t for t in self.registry.term_list(mode) if not (t.constraint and (t.lower < t.upper or t.lift))]
        self.built[key] = Built(terms, self.registry.n_var // 3, mode, self.jit, self.hessian_of(True, terms),
                                kernels=self.kernels)
        return self.built[key], self.built[key].seconds

    def forget(self) -> None:
        """The terms' structure changed: the built NLPs and their element kernels are dropped
        (rebuilt at the next solve), and a collapse's exact Hessian with them."""
        self.built.clear()
        self.kernels.clear()
        self.exact_after_collapse = False

    def keep_exact(self, kind: str) -> None:
        """``hessian="guarded"``: Gauss-Newton collapsed; ``kind``'s NLP is rebuilt with the
        exact Hessian, kept for this structure."""
        self.exact_after_collapse = True
        self.built.pop(self.key(kind), None)

    def hessian_of(self, pass1: bool, terms: list) -> str:
        """The energies' Hessian of the NLP of ``terms`` (``hessian="auto"``: Gauss-Newton for
        pass 1 of a solve with inequalities, exact otherwise; ``"projected"``: projected where
        the NLP has no constraint rows, exact where it has; see the problem's docstring)."""
        if self.hessian == Hessian.PROJECTED:
            return "exact" if any(t.constraint for t in terms) else "projected"
        if self.hessian == Hessian.GUARDED:
            constrained = any(t.constraint for t in self.registry.terms.values())
            return "exact" if constrained or self.exact_after_collapse else "gauss-newton"
        if self.hessian != Hessian.AUTO:
            return self.hessian
        return "gauss-newton" if pass1 else "exact"

    def main(self) -> Built:
        """The NLP energies and rows are evaluated with: IPOPT's, or the augmented Lagrangian's
        when only that one is built (same values); IPOPT's is built where neither is."""
        b = self.built.get(self.normalize) or self.built.get(self.key(NlpKind.ALM))
        if b is None:
            self.build(NlpKind.IPOPT)
            b = self.built[self.normalize]
        return b

    def evaluate(self, e: np.ndarray, rows: bool = True):
        """``(energies dict, objective, g, built)`` at stacked directions ``e`` with :meth:`main`;
        ``rows=False``: ``g`` is not valid where the NLP has lifted variables (not fitted)."""
        b = self.main()
        x, fr = b.pack(e)
        ev, f, g = b.evaluate(x, b.parameters(self.registry.current(), fr), rows=rows)
        out = {k: float(v) for k, v in zip(b.energy_names, np.asarray(ev).ravel())}
        out["total"] = float(f)
        return out, float(f), np.asarray(g).ravel(), b

    def objective(self, e: np.ndarray) -> float:
        """The weighted objective of eq. (9) at stacked directions ``e``."""
        return self.evaluate(e, rows=False)[1]

    def measure(self, e: np.ndarray, *, angle_tol_deg: float, constraint_tol: float) -> dict[str, Measurement]:
        """Every constraint measured on the geometry at stacked directions ``e`` (see
        :meth:`CongruenceProblem.measure <torsal.geometry.optimize.CongruenceProblem.measure>`)."""
        reg = self.registry
        cons = reg.constraints(self.normalize)
        g_by = {}
        if any(t.kind == "value" for t in cons):
            _, _, g, b = self.evaluate(e)
            g_by = {t.name: g[rows] for t, rows in zip(b.cons, b.g_slices)}
        congs = reg.congruences(e) if cons else []
        return {t.name: measure(t, congs[t.block], reg.delta, g_by.get(t.name), angle_tol_deg=angle_tol_deg,
                                value_tol=constraint_tol) for t in cons}
