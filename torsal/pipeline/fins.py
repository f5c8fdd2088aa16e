"""The design's fin system: one place that turns a design file's material and joinery keys
into :class:`~torsal.fabrication.FinSystem` options (used by the fabrication and assembly
stages).

Both stages of one run ask for the fin system of the same structure: it is built once and
handed to the second (with its solids, if the first built them). The memo keeps only the last
fin system of this thread or task (a :class:`~contextvars.ContextVar`, so two designs run by
the threads of one Dask worker never see each other's) and is keyed by the content of the
structure and the options, so a changed design or structure is always built afresh; the stage
cache (:mod:`.cache`) is not involved.
"""
from __future__ import annotations

import hashlib
import pickle
from contextvars import ContextVar

from .design_file import DesignSpec

__all__ = ["fin_system", "fabrication_summary", "last_fin_system", "forget_fin_system",
           "keep_fin_system", "kept_fin_system"]

#: (key, FinSystem) of the last call in this thread or task: the fabrication and assembly
#: stages of one run share it
_LAST: ContextVar[tuple | None] = ContextVar("torsal_last_fin_system", default=None)


def last_fin_system():
    """The fin system the last :func:`fin_system` call of this thread or task returned (None
    before any): what a benchmark measures after a run."""
    last = _LAST.get()
    return None if last is None else last[1]


def forget_fin_system() -> None:
    """Drop the memo: the next :func:`fin_system` call builds afresh (a cold run)."""
    _LAST.set(None)


def keep_fin_system(spec: DesignSpec, fs, *, structure=None) -> None:
    """Make ``fs`` what :func:`fin_system` returns in this thread or task for ``spec`` and
    ``structure`` (default ``fs.structure``): the final cut's split fin system stands for the
    one it was split from, for the stages after it.

    >>> keep_fin_system(spec, split, structure=unsplit.structure)     # doctest: +SKIP
    >>> fin_system(spec, unsplit.structure) is split                   # doctest: +SKIP
    True
    """
    structure = fs.structure if structure is None else structure
    _LAST.set((_key(structure, spec.material.thickness_mm, _options(spec)), fs))


def _options(spec: DesignSpec) -> dict:
    """FinSystem keyword arguments of the design file (material, sheet, joinery limits)."""
    m = spec.material
    options = {"family_split": m.family_split.value, "clearance": m.clearance_mm,
               "fit_sheet": tuple(m.sheet_mm), "model_unit": spec.units, "unit": "mm"}
    # unset: the joinery's own limit (torsal.fabrication.joints.MAX_CROSSING_FOLD)
    if spec.fins.max_fold_at_crossing is not None:
        options["max_crossing_fold"] = spec.fins.max_fold_at_crossing
    return options


def _key(structure, thickness: float, options: dict) -> str | None:
    """Content hash of the structure and the options (None: cannot be hashed, do not reuse)."""
    try:
        data = pickle.dumps((structure, thickness, sorted(options.items())), protocol=4)
    except Exception:
        return None
    return hashlib.sha256(data).hexdigest()


def kept_fin_system(spec: DesignSpec, structure):
    """The fin system :func:`fin_system` would return for ``spec`` and ``structure`` without
    building one: the one this thread or task built (or kept, :func:`keep_fin_system`), else
    None (the fabrication stage was taken from the cache).

    >>> kept_fin_system(spec, support["structure"]) is fin_system(spec, support["structure"])  # doctest: +SKIP
    True
    """
    key = _key(structure, spec.material.thickness_mm, _options(spec))
    last = _LAST.get()
    return last[1] if key is not None and last is not None and last[0] == key else None


def fin_system(spec: DesignSpec, structure):
    """The design's :class:`~torsal.fabrication.FinSystem` (material, sheet and joinery limits
    of the design file; parts in mm). A second call with the same structure and design keys
    returns the same object (see the module docstring).

    >>> fs = fin_system(spec, support["structure"])              # doctest: +SKIP
    >>> fin_system(spec, support["structure"]) is fs              # doctest: +SKIP
    True
    """
    from ..fabrication import FinSystem

    options = _options(spec)
    thickness = spec.material.thickness_mm
    key = _key(structure, thickness, options)
    last = _LAST.get()
    if key is not None and last is not None and last[0] == key:
        return last[1]
    fs = FinSystem(structure, thickness, **options)
    _LAST.set((key, fs) if key is not None else None)
    return fs


def fabrication_summary(fs) -> dict:
    """What a workshop prices a fin system by, for the ``fabrication`` report section: part
    counts (``plates``, ``connectors``: brackets and splice plates, ``fixings``), the
    ``connector_share`` (separate connectors of all parts), the fasteners (``bolts`` through
    connectors and fins, ``anchors`` into the building, and ``fasteners_by_joint``: per joint
    kind the connectors, bolts, anchors, connectors without room for a hole and the fastener
    sizes, from the holes of :mod:`torsal.fabrication.builder.fasteners`), the
    ``panels_left_out_share`` (fin panels not built, of the structure's fins) and the
    ``joinery`` (:func:`~torsal.fabrication.builder.seams.joinery_report`: seams in slots,
    fallbacks named, the brackets that stayed instead of a tab among them) and ``tabs``
    (:func:`~torsal.fabrication.builder.tabs.tab_report`: the butt joints made with a tab bent
    from the butted plate instead of a bracket, the fallbacks by reason, the brackets taken
    away where the parts were joined without them) and ``held_by_builder``
    (:func:`~torsal.fabrication.builder.held.held_report`: the crossings the builder bolted
    because the load path found a plate hung there loose, each plate named with why).

    >>> fabrication_summary(fs)["connector_share"]                    # doctest: +SKIP
    0.43
    """
    from ..fabrication.builder.fasteners import fastener_counts
    from ..fabrication.builder.held import held_report
    from ..fabrication.builder.seams import joinery_report
    from ..fabrication.builder.tabs import tab_report

    counts = fastener_counts(fs)
    parts = len(fs.parts)
    left = len(getattr(fs, "coplanar_panels", [])) + len(fs.dropped_panels)
    fins = len(fs.structure.edges) if fs.structure is not None else fs.n_panels + left
    return {
        "plates": len(fs.plates), "connectors": len(fs.connectors), "fixings": len(fs.fixings),
        "connector_share": len(fs.connectors) / parts if parts else 0.0,
        "bolts": int(sum(c.bolts for c in counts.values())),
        "anchors": int(sum(c.anchors for c in counts.values())),
        "fasteners_by_joint": {k: {"connectors": c.connectors, "bolts": c.bolts,
                                   "anchors": c.anchors, "without_holes": c.unfastened,
                                   "fastener": c.fastener}
                               for k, c in counts.items()},
        "panels_left_out_share": left / fins if fins else 0.0,
        # seams held in crossing slots without a connector, and those that fell back to
        # brackets, named with why (issue 42)
        "joinery": joinery_report(fs),
        # butt joints made with a tab bent from the butted plate, no bracket (issue 42)
        "tabs": tab_report(fs),
        # crossings bolted because the load path found a plate hung there loose (issue 40)
        "held_by_builder": held_report(fs),
    }
