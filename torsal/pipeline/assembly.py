"""The assembly stage: after fabrication, check that the parts go together (issue 15).

:func:`run_assembly` checks the solids the fabrication stage built and wrote the design's
files from (``fins.step``, ``fins.3dm``, ``fins.ifc``): the solids' workers make the check's
copy of each with it (meshed at the touching tolerance, with the records of the cheap tests,
:func:`~torsal.fabrication.workers.check_solids`). That ``fins.step`` gives those solids back
(every named solid, its volume and box, none inside out) is proved by the tests
(tests/fabrication/test_step_fidelity.py, test_step_outward.py), not by reading the file
again on every run (8-15 s of processor time on 7a). Where the fabrication stage was taken
from the cache, the solids of its ``fins.step`` are read again
(:func:`prefetch_step_solids` / :func:`~torsal.fabrication.exports.read_step_for_check`);
with no STEP file, the fin system's. It checks every touching pair for interference and
finds an assembly order (:func:`torsal.fabrication.check_assembly`), writes
``assembly.csv`` and, with ``outputs.renders``, ``assembly.png`` (interfering parts in red).
Its report is ``fabrication.assembly`` in report.json.

What the check proved is kept in the design's cache by the solids' content
(:class:`~torsal.fabrication.assembly.AssemblyMemo`): a re-run, or a study variant, whose parts
did not change takes those pairs and paths from it (``memo_hits`` in the report).

The load path (:mod:`torsal.fabrication.assembly.load_path`): every part must reach the
building through joints that hold it (bolts and anchors read from the parts' holes, slots
that bear its weight); the parts that do not are ``unsupported_parts``, the rest of the graph
is ``load_path`` in the section.

A design whose parts interfere, cannot be inserted or are not held is not buildable:
:meth:`Design.run` raises :class:`UnbuildableDesignError` naming the parts after every output
(report included) is written, unless ``accept_unbuildable=True`` (``torsal design
--accept-unbuildable``).

Quality gates at the stages that cause joinery problems: :func:`congruence_gate` (faces whose
torsal planes cross more obliquely than the joinery's minimum crossing angle) and
:func:`support_gate` (nodes where a strip folds more than ``fins.max_fold_at_crossing`` at a
crossing), each a small report section naming faces or nodes.
"""
from __future__ import annotations

import os
from contextvars import ContextVar
from pathlib import Path
from typing import NamedTuple

import numpy as np

from .errors import DesignError
from .stage import StageInputs

__all__ = ["run_assembly", "UnbuildableDesignError", "unbuildable_message", "prefetch_step_solids",
           "drop_prefetched_solids", "congruence_gate", "support_gate", "MIN_CROSSING_ANGLE",
           "MAX_CROSSING_FOLD"]

# the joinery's limits: one source, the joint builder's (torsal.fabrication.joints)
from ..fabrication.joints import MAX_CROSSING_FOLD, MIN_CROSSING_ANGLE

#: how many faces / nodes / parts a report names (all are counted)
_NAMED = 20


class UnbuildableDesignError(DesignError):
    """The design's parts interfere or cannot be inserted: ``result`` is the finished run
    (all outputs written), ``parts`` the parts involved. Exit status 3 in the CLI."""

    def __init__(self, message: str, result=None, parts=()):
        super().__init__("assembly", message)
        self.result = result
        self.parts = list(parts)


def unbuildable_message(assembly: dict) -> str:
    """What makes a design unbuildable, naming the parts ('' when it is buildable)."""
    if assembly.get("buildable", True):
        return ""
    out = []
    inter = assembly.get("interfering", [])
    if inter:
        names = ", ".join(f"{a} / {b} ({v:.3g} mm^3)" for (a, b), v in
                          ((x["parts"], x["volume_mm3"]) for x in inter[:8]))
        out.append(f"{len(inter)} pairs of parts interfere (worst "
                   f"{assembly['worst_overlap_mm3']:.4g} mm^3): {names}"
                   + (" ..." if len(inter) > 8 else ""))
    blocked = assembly.get("blocked_parts", [])
    if blocked:
        out.append(f"{len(blocked)} parts cannot be inserted without collision: "
                   + ", ".join(blocked[:8]) + (" ..." if len(blocked) > 8 else ""))
    failed = assembly.get("failed_pairs", [])
    if failed:
        out.append(f"{len(failed)} pairs could not be checked: "
                   + ", ".join(f"{a} / {b}" for a, b, _ in failed[:8]))
    held = assembly.get("load_path") or {}
    if held.get("unsupported"):
        out.append(held["message"])
    return "the design is not buildable: " + "; ".join(out)


class _Prefetch(NamedTuple):
    """The STEP file being re-read in the background (:func:`prefetch_step_solids`)."""

    path: Path                # resolved
    stamp: tuple              # :func:`_stamp` of the file when the read started
    read: object              # its :class:`~torsal.fabrication.exports.PendingStepRead`


#: the re-read of this thread or task (a ContextVar: designs run side by side by one
#: process's threads keep theirs apart)
_PREFETCHED: ContextVar[_Prefetch | None] = ContextVar("torsal_prefetched_step", default=None)


def _stamp(path: Path) -> tuple:
    """What tells one written file from the next at the same path (a file written anew by
    ``atomic_path`` is a new inode)."""
    st = os.stat(path)
    return (st.st_ino, st.st_size, st.st_mtime_ns)


def prefetch_step_solids(path) -> None:
    """Start re-reading a STEP file in a process of its own
    (:func:`~torsal.fabrication.exports.start_read_step`) for a check of the solids it holds
    (the assembly stage reads ``fins.step`` itself only where the fabrication stage came
    from the cache): OpenCascade's reader (seconds for a thousand parts) runs while this
    process goes on, and the assembly stage takes its solids: those its own
    :func:`~torsal.fabrication.read_step` of that file would give, sent in OpenCascade's
    binary form (vertices bit for bit; a plane's direction is normalized again on reading,
    which moves volumes by round-off, about 1e-15 of them). Only the last file is kept; a
    file changed since is read again."""
    from ..fabrication.exports import start_read_step

    from ..fabrication.assembly import TOUCHING_TOLERANCE

    drop_prefetched_solids()
    path = Path(path)
    # (meshed there for the check too: a few seconds of this process's time on 7a)
    _PREFETCHED.set(_Prefetch(path.resolve(), _stamp(path),
                              start_read_step(path, mesh_tolerance=TOUCHING_TOLERANCE)))


def drop_prefetched_solids() -> None:
    """Stop a re-read started by :func:`prefetch_step_solids` (a later step failed)."""
    pre = _PREFETCHED.get()
    _PREFETCHED.set(None)
    if pre is not None:
        pre.read.cancel()


def _step_solids(path: Path):
    """``read_step(path)`` in OpenCascade's binary form, taken from
    :func:`prefetch_step_solids` when it read this file: the check gets the same solids
    whether they were read in the background or here."""
    from ..fabrication.assembly import TOUCHING_TOLERANCE
    from ..fabrication.exports import read_step_for_check

    pre = _PREFETCHED.get()
    if pre is not None and pre.path == path.resolve() and pre.stamp == _stamp(path):
        _PREFETCHED.set(None)
        return pre.read.result()
    drop_prefetched_solids()        # of another file, or of this one before it changed
    return read_step_for_check(path, mesh_tolerance=TOUCHING_TOLERANCE)


def _solids(inp: StageInputs):
    """The solids the check gets: those the fabrication stage of this run built the design's
    files from (:func:`~torsal.fabrication.workers.check_solids`: made by the solids' workers
    with the solids, meshed for the check, with its records); where the fabrication stage was
    taken from the cache, the solids of its ``fins.step`` (read again), else those of the fin
    system built here."""
    from ..fabrication.assembly import TOUCHING_TOLERANCE
    from ..fabrication.workers import check_solids
    from .fins import fin_system, kept_fin_system

    structure = inp["support"]["structure"]
    fs = kept_fin_system(inp.spec, structure)
    if fs is not None:      # (the workers' copies are the check's: let go once taken)
        return check_solids(fs, TOUCHING_TOLERANCE, release=True)
    step = inp["fabrication"].get("files", {}).get("step")
    if step and (inp.out / step).exists():
        return _step_solids(inp.out / step)
    return check_solids(fin_system(inp.spec, structure), TOUCHING_TOLERANCE)


#: where the pairs and paths the check proved are kept (one memo for a design, or for all
#: the variants of a study that share its cache)
_MEMO_NAME, _MEMO_KEY = "assembly", "proved"


def _assembly_memo(inp: StageInputs):
    """The :class:`~torsal.fabrication.assembly.AssemblyMemo` kept in the design's cache
    (a new one when there is none, or the cache is off)."""
    from ..fabrication.assembly import AssemblyMemo

    kept = inp.memo.load(_MEMO_NAME, _MEMO_KEY) if inp.memo is not None else None
    return kept if isinstance(kept, AssemblyMemo) else AssemblyMemo()


def run_assembly(inp: StageInputs) -> dict:
    """Interference check and assembly order of the fabricated parts. Returns the ``report``
    section (``fabrication.assembly``) and ``files`` (``assembly.csv``, ``assembly.png``)."""
    from ..fabrication import check_assembly
    from ..fabrication.assembly import check_load_path

    solids = _solids(inp)
    joints = inp["fabrication"].get("joints", [])

    def progress(phase, done, total):
        inp.progress("progress", {"phase": phase, "done": done, "total": total})

    memo = _assembly_memo(inp)
    check = check_assembly(solids, joints=joints, progress=progress, memo=memo)
    if inp.memo is not None:
        inp.memo.store(_MEMO_NAME, _MEMO_KEY, memo)
    files = {"assembly": check.write_csv(inp.out / "assembly.csv").name}
    report = check.report()
    # held, not only in place: every part must reach the building through joints that hold
    # (None from a fabrication stage cached before the fasteners were handed on: not judged)
    held = check_load_path(check.parts, joints, inp["fabrication"].get("fastenings"))
    report["load_path"] = {**held.report(), "message": held.problems()}
    report["unsupported_parts"] = list(held.unsupported_parts)
    report["buildable"] = bool(check.buildable and held.supported)
    if inp.spec.outputs.renders:
        from ..core.parallel import ForkedCall
        from .report import plot_assembly

        # drawn (a second of matplotlib) by a process of its own while the run writes its report
        inp.defer(ForkedCall(plot_assembly, solids, check, inp.out / "assembly.png"))
        files["assembly_png"] = report["picture"] = "assembly.png"
    report["csv"] = files["assembly"]
    return {"report": report, "files": files}


# ---------------------------------------------------------------------------- quality gates
def congruence_gate(congruence, min_angle: float = MIN_CROSSING_ANGLE) -> dict:
    """Faces whose two torsal planes (the planes the fins of the two families lie in) cross
    at less than ``min_angle`` degrees: there the joinery cannot slot the plates (the slot
    grows as ``t (1 + cos a) / sin a``). Raise ``constraints.min_torsal_angle`` to prevent it.

    Returns the ``joinery`` report section: ``min_crossing_angle_deg`` (the limit),
    ``faces_below`` (count), ``faces`` (the first indices, smallest angle first),
    ``min_plane_angle_deg`` and a ``message`` ('' when every face is fine).
    """
    ang = congruence.torsal_plane_angle()
    ok = np.isfinite(ang)
    below = np.flatnonzero(ok & (ang < min_angle))
    below = below[np.argsort(ang[below])]
    msg = ""
    if below.size:
        msg = (f"{below.size} faces have torsal planes crossing at less than {min_angle:g} deg "
               f"(down to {ang[below[0]]:.1f} deg; faces {below[:_NAMED].tolist()}"
               f"{' ...' if below.size > _NAMED else ''}): fins crossing there cannot be "
               "slotted together; set constraints.min_torsal_angle (the angle the torsal "
               f"planes cross at) to {min_angle:g} or more")
    return {"min_crossing_angle_deg": float(min_angle), "faces_below": int(below.size),
            "faces": below[:_NAMED].tolist(),
            "min_plane_angle_deg": float(ang[ok].min()) if ok.any() else None, "message": msg}


def support_gate(structure, max_fold: float) -> dict:
    """Nodes where a strip of one family folds by more than ``max_fold`` degrees while a strip
    of the other family passes through (a crossing): the folded plate cannot slide through an
    egg-crate slot there, so the joinery splits it (butt joint and connector). Lower the fin
    spacing or smooth the congruence to prevent it; ``fins.max_fold_at_crossing`` sets the limit.

    Returns the ``joinery`` report section: ``max_fold_at_crossing_deg`` (the limit),
    ``crossings``, ``nodes_above`` (count), ``nodes`` (the first, sharpest fold first),
    ``worst_fold_deg`` and a ``message``.
    """
    from ..geometry.support import crossing_folds

    nodes, folds = crossing_folds(structure)
    worst = folds.max(axis=1) if len(folds) else np.zeros(0)
    above = np.flatnonzero(worst > max_fold)
    above = above[np.argsort(-worst[above])]
    msg = ""
    if above.size:
        msg = (f"{above.size} of {len(nodes)} crossings have a strip folding more than "
               f"{max_fold:g} deg (up to {worst[above[0]]:.1f} deg; nodes "
               f"{nodes[above[:_NAMED]].tolist()}{' ...' if above.size > _NAMED else ''}): "
               "the folded plate cannot slide through a slot there, so it must be split "
               "(butt joint with a connector) or the parts interfere; a finer fin spacing or "
               "a smoother congruence (weights.fair) lowers the folds, "
               "fins.max_fold_at_crossing sets the limit")
    return {"max_fold_at_crossing_deg": float(max_fold), "crossings": int(len(nodes)),
            "nodes_above": int(above.size), "nodes": nodes[above[:_NAMED]].tolist(),
            "worst_fold_deg": float(worst.max()) if len(worst) else 0.0, "message": msg}
