"""The working set of inequality constraints (pass 2 of the IPOPT strategy)."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .nlp import Built

# few elements need barrier terms; otherwise (e.g. a 60 degree torsal angle on a shading
# canopy, where half of them are violated) the working set would grow round after round
_WORKING_SET_MAX_SHARE = 0.05


def _near_bounds(g: np.ndarray, b: "Built", share: float = 0.1) -> np.ndarray:
    """Inequalities within ``share`` of their constraint's median slack of a bound, or violated."""
    slack = np.minimum(g - b.lbg, b.ubg - g)
    out = np.zeros(g.size, dtype=bool)
    for rows in b.g_slices:
        sl = slack[rows]
        fin = np.isfinite(sl)
        scale = float(np.median(np.abs(sl[fin]))) if fin.any() else 0.0
        out[rows] = ~fin | (sl <= share * scale)
    return out


def _working_ids(b: "Built", mask: np.ndarray) -> dict:
    """Element ids of the imposed inequality constraints, by constraint name (each once: the
    split torsal-angle form has two rows per face)."""
    return {t.name: np.unique(t.elements[mask[rows]]) for t, rows in zip(b.cons, b.g_slices)
            if t.lower < t.upper}

