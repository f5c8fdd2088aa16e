"""Seams inside a crossing slot: joints that need no separate part (issues 27, 42).

A strip split on a mild fold (mitred: for its length or the sheet) at an egg-crate crossing
whose other plate passes through whole can meet on its mitred seam *inside that plate's slot*:
both parts are slotted at their ends and the crossing plate holds them, as ribs longer than a
sheet are jointed at a notch in a waffle structure. No splice plate, no bracket: on 7a at
full size the butt joints these splits made cost 236 connectors of 509 parts (46 %), two
brackets each and more where the other family had to be split too against cycles.

Whether a seam can stay in its slot is decided *per joint*, in this order:

1. the slide plan (:class:`~.crossings.CrossingSlotter`): the two family-1 parts of a seam
   slide in from opposite edges and the fins are too shallow for a tongue each (where they are
   deep enough, the family-0 plate is slotted from both edges and each part enters with a
   tongue from its own side, :data:`~.joints.TONGUE_SHARE`; :attr:`SeamReason.OPPOSITE_SLIDES`),
   or a family-1 part's slide closes the clearance of its seam (:attr:`SeamReason.CLOSES_SEAM`);
2. the assembly check (:func:`~torsal.fabrication.assembly.check_assembly`, the independent
   one) on the solids around the joint only (:func:`local_part`: the panels of every part of
   the crossing next to its node line, slotted there), with the crossing's joint record: the
   two parts of the seam and the plate that holds them must neither interfere nor block each
   other's path in (:attr:`SeamReason.ASSEMBLY`; a local solid that cannot be built:
   :attr:`SeamReason.SOLID`). This is what refused the seam on examples 9 and 11 at test size
   (a family-1 plate could not slide onto a seam's two parts: 2,415 mm^3), which made the
   first version of this joint be reverted everywhere.

A refused seam falls back to the joint it replaced (the strip split and butted against the
crossing plate with brackets, in the next build), and is named in
``FinSystem.joint_fallbacks`` (:class:`JointFallback`: node, parts, reason, what the check
found); the seams kept are ``FinSystem.seams_in_slot`` (:class:`SlotSeam`). The local checks
are remembered by the bytes of their solids' parts across the rebuilds of one fin system: a
rebuild re-checks only a joint whose parts changed there. Lengths in the fin system's
``unit``.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from enum import Enum

import numpy as np

from ..joints import MAX_HOLDER_FOLD
from ..model import Joint, JointKind, Part
from .memo import _memo_key

__all__ = ["SeamReason", "SlotSeam", "JointFallback", "SlotSeams", "local_part", "joinery_report",
           "yield_cut_positions"]


class SeamReason(str, Enum):
    """Why a seam inside a slot fell back to butt joints with brackets."""

    #: the two family-1 parts of the seam would slide in from opposite edges of the slot, and
    #: the fins are too shallow for a tongue each (:data:`~.joints.TONGUE_SHARE`)
    OPPOSITE_SLIDES = "opposite-slides"
    #: a family-1 part sliding along its crossings' axes would close its seam's clearance
    CLOSES_SEAM = "closes-seam"
    #: the crossing made no slot there (the other family's plate is not slotted at the node)
    NO_SLOT = "no-slot"
    #: the assembly check on the solids around the joint found them interfering or blocked
    ASSEMBLY = "assembly"
    #: a solid around the joint could not be built, so nothing proves the joint
    SOLID = "solid"


@dataclass(frozen=True)
class SlotSeam:
    """A seam held in a crossing slot without a connector: the strip of ``family`` split at
    ``node`` into ``parts`` (the two, in strip order), held by the other family's plate(s)
    ``holders``."""

    node: int
    family: int
    parts: tuple[str, ...]
    holders: tuple[str, ...]


@dataclass(frozen=True)
class JointFallback:
    """A seam that could not stay in its slot: the strip of ``family`` is split at ``node`` and
    butted against the crossing plate with brackets instead; ``parts`` the parts of the
    crossing when it was refused, ``detail`` what refused it."""

    node: int
    family: int
    reason: SeamReason
    detail: str
    parts: tuple[str, ...] = ()

    def __str__(self) -> str:
        return f"node {self.node} (family {self.family}): {self.reason.value}: {self.detail}"


def local_part(part: Part, node: int) -> Part | None:
    """The panels of ``part`` next to its node line(s) at ``node`` (one on either side), with
    its slots there, under the same name: the part as the joint sees it (mitred ends and folds
    as in the whole part; holes and other slots left out). None if the part has no such line."""
    at = np.flatnonzero(np.asarray(part.nodes) == node)
    if not len(at):
        return None
    k = len(part.panels)
    lo, hi = max(0, int(at.min()) - 1), min(k, int(at.max()) + 1)
    slots = [dataclasses.replace(s, position=s.position - lo) for s in part.slots
             if s.node == node and lo <= s.position <= hi]
    return dataclasses.replace(part, panels=part.panels[lo:hi].copy(), nodes=part.nodes[lo:hi + 1].copy(),
                               edges=part.edges[lo:hi].copy(), miters=part.miters[lo:hi + 1].copy(),
                               slots=slots, holes=(), span=(part.span[0] + lo, part.span[0] + hi))


@dataclass(frozen=True)
class _Verdict:
    """The local assembly check of one seam: ``ok`` or refused for ``reason`` (``detail``)."""

    ok: bool
    reason: SeamReason | None = None
    detail: str = ""


def _local_check(parts: list[Part], joints: list[Joint], thickness: float, unit: str) -> _Verdict:
    """:func:`~torsal.fabrication.assembly.check_assembly` of the solids of ``parts`` (local
    parts of one crossing) with the crossing's joint records, in this process. The solids
    are the bare OCC shapes of :func:`~..plates.part_solid` (the same solid, unlabelled): a
    worker that checks seams need not import build123d (about 1.5 s of processor time in
    each of the two on 7a, while the fin system waits)."""
    from ..assembly import check_assembly
    from ..assembly.records import insertion_ways
    from ..plates import InvalidSolidError, _part_shape

    try:
        solids = {p.name: _part_shape(p, thickness) for p in parts}
    except InvalidSolidError as e:
        return _Verdict(False, SeamReason.SOLID, f"{e}")
    names = set(solids)
    local = [dataclasses.replace(j, parts=tuple(n for n in j.parts if n in names)) for j in joints]
    # each piece goes in only along the ways its joint records give it, as a tab's check
    # (free to try the other sense of its axis, a piece could clear the seam on a way its
    # whole part never takes)
    r = check_assembly(solids, joints=local, workers=1, unit=unit,
                       ways=insertion_ways(joints, names))
    if r.buildable:
        return _Verdict(True)
    return _Verdict(False, SeamReason.ASSEMBLY, r.problems(limit=3).replace("\n", "; "))


def _local_check_of(ask: tuple) -> _Verdict:
    """:func:`_local_check` of ``(parts, joints, thickness, unit)`` (one argument: a task for
    a worker process)."""
    return _local_check(*ask)


class SlotSeams:
    """The seams inside crossing slots of a fin system ``fs`` under construction: which splits
    may try one (:meth:`candidates`), refusals with their reason (:meth:`refuse`), the local
    assembly check of every seam made (:meth:`verify`) and the final lists (:meth:`publish`).

    ``fs`` keeps across rebuilds ``_seams_refused`` (``{(family, node): JointFallback}``) and
    ``_seam_verdicts`` (local checks by content); per build ``_seam_crossings`` (the seams
    tried) and ``_refuse_seams`` (refused during this build, butted in the next)."""

    def __init__(self, fs):
        self.fs = fs

    def candidates(self, st, part_of_strip, joinery: dict, cont: np.ndarray,
                   forced=frozenset()) -> set:
        """``{(family, node)}``: where a strip is split on a mild fold (mitred) at a crossing
        whose other plate passes through whole, not refused before and not a node whose joint
        changed (``_base_at``) or was ``forced`` to a butt joint (a family-1 plate that cannot
        slide onto all its crossings: on example 13 its two parts, each sliding along its own
        axis, could not both go into one slot, 56 of 56 refused by the check): at an
        egg-crate (split for its length or the sheet), or where the joinery split it for a
        fold (:meth:`_slottable_split`)."""
        fs = self.fs
        out: set = set()
        if fs.family_split.value != "egg-crate":
            return out
        for si, parts in enumerate(part_of_strip):
            fam = st.fins[si].family
            if fam not in (0, 1):
                continue
            for p in parts:
                v = int(p.nodes[0])
                x = joinery.get(v)
                if (p.ends[0] != "miter" or x is None or not cont[1 - fam, v]
                        or v in fs._base_at or (fam, v) in fs._seams_refused):
                    continue
                if x.kind == JointKind.EGG_CRATE or (self._slottable_split(x, fam)
                                                     and v not in forced):
                    out.add((fam, v))
        return out

    def _slottable_split(self, x, fam: int) -> bool:
        """Whether the crossing ``x`` (:class:`~.joints.NodeJoinery`), where the joinery split
        the strip of ``fam`` and butted it, can hold that split in the other plate's slot: the
        other plate folds no more than an egg-crate allows or, where the split strip folds
        more than that, up to :data:`~.joints.MAX_HOLDER_FOLD`, and the crossing angle narrowed
        by both folds (as :func:`~.joints.slot_width` narrows it) is still one an egg-crate
        allows. Why the split strip's own fold does not matter: its two parts are flat at the
        node, the fold is their seam; only the holder is bent through its slot (on example 9
        at full size about 45 splits were butted with two brackets each only because their
        holder folds more than 10 degrees)."""
        fs = self.fs
        limit = fs.max_crossing_fold if x.folds[fam] <= fs.max_crossing_fold else max(
            fs.max_crossing_fold, MAX_HOLDER_FOLD)
        return (x.kind == JointKind.BUTT_BRACKET and x.split == fam and x.folds[1 - fam] <= limit
                and x.angle - 0.5 * sum(x.folds) >= fs.min_crossing_angle)

    def slot(self, joinery: dict) -> None:
        """The crossings of this build's seams are slotted like egg-crates (``joinery`` and
        ``fs.joinery`` say so; a crossing split for a fold keeps its ``split`` and ``why``)."""
        fs = self.fs
        for _, v in sorted(self.fs._seam_crossings):
            joinery[v] = joinery[v]._replace(kind=JointKind.EGG_CRATE)
        fs.joinery = [joinery[v] for v in sorted(joinery)]

    def refuse(self, family: int, node: int, reason: SeamReason, detail: str,
               parts: tuple[str, ...] = ()) -> None:
        """The seam of ``family`` at ``node`` falls back to butt joints in the next build; a
        split made for the sheet moves to the node line before it where it can
        (``_bad_seams``), which may be a crossing whose seam stays in its slot."""
        fs = self.fs
        if (family, node) in fs._refuse_seams:
            return
        why = {x.node: x.why for x in fs.joinery}
        split = [p for p in fs.parts if p.family == family and len(p.nodes)
                 and int(p.nodes[0]) == node and p.ends[0] == "miter"]
        si = fs._strip_of.get(split[0].name) if split else None
        if si is not None and not why.get(node) and (si, split[0].span[0]) not in fs._avoid_splits:
            fs._bad_seams.add((si, split[0].span[0]))
            detail += "; the sheet's split moves to the node line before"
        fs._refuse_seams[(family, node)] = JointFallback(node, family, reason, detail, tuple(parts))

    def verify(self) -> list[JointFallback]:
        """The local assembly check of every seam of this build (remembered by content, run in
        the solids' prepared worker processes where there are any); returns those refused (also
        in ``_refuse_seams``)."""
        fs = self.fs
        crossing = self._crossing_joints()
        by_name = {p.name: p for p in fs.parts}
        asks: dict = {}                   # (family, node) -> (names, joints)
        for fam, node in sorted(fs._seam_crossings):
            joints = crossing.get(node, [])
            names = tuple(dict.fromkeys(n for j in joints for n in j.parts))
            mine = [n for n in names if n.startswith(f"F{fam}-")]
            if not joints or len(mine) < 2:
                self.refuse(fam, node, SeamReason.NO_SLOT, "the crossing plate is not slotted "
                            "there", tuple(mine))
                continue
            asks[(fam, node)] = (names, joints)
        verdicts = self._verdicts({(fam, node): ([local_part(by_name[n], node) for n in names], joints)
                                   for (fam, node), (names, joints) in asks.items()})
        # a slot that runs out of a narrow, slanted panel cuts the panels next to the node
        # apart but not the whole part: the whole parts decide
        verdicts.update(self._verdicts({k: ([by_name[n] for n in asks[k][0]], asks[k][1])
                                        for k, v in verdicts.items() if v.reason == SeamReason.SOLID}))
        for (fam, node), verdict in sorted(verdicts.items()):
            if not verdict.ok:
                self.refuse(fam, node, verdict.reason, verdict.detail, asks[(fam, node)][0])
        return [fs._refuse_seams[k] for k in sorted(fs._refuse_seams)]

    def _crossing_joints(self) -> dict[int, list[Joint]]:
        """``{node: [egg-crate joint records]}`` (two at a family-1 seam whose parts slide in
        along directions of their own, :class:`~.crossings.CrossingSlotter`)."""
        out: dict[int, list[Joint]] = {}
        for j in self.fs.joints:
            if j.kind == JointKind.EGG_CRATE:
                out.setdefault(j.node, []).append(j)
        return out

    def _verdicts(self, asks: dict) -> dict:
        """``{seam: _Verdict}``: :func:`_local_check` of each ``{seam: (parts, joints)}``,
        remembered by their content; those not remembered are checked together, in the
        prepared worker processes where there are any (:func:`~..workers.map_prepared`)."""
        from ..workers import map_prepared

        fs = self.fs
        keys, todo = {}, {}
        for seam, (parts, joints) in asks.items():
            parts = [p for p in parts if p is not None]
            key = _memo_key(([(p.name, p.panels, p.miters, [dataclasses.astuple(s) for s in p.slots])
                              for p in parts], [(j.parts, j.insert_direction, j.depth) for j in joints],
                             fs.thickness))
            keys[seam] = key
            if key not in fs._seam_verdicts:
                todo.setdefault(key, (parts, joints, fs.thickness, fs.unit))
        for key, verdict in zip(todo, map_prepared(_local_check_of, list(todo.values()))):
            fs._seam_verdicts[key] = verdict
        return {seam: fs._seam_verdicts[key] for seam, key in keys.items()}

    def publish(self) -> None:
        """``fs.seams_in_slot`` (the seams kept, each a joint without a connector) and
        ``fs.joint_fallbacks`` (the seams refused, by node)."""
        fs = self.fs
        crossing = self._crossing_joints()
        kept = []
        for fam, node in sorted(fs._seam_crossings):
            names = tuple(dict.fromkeys(n for j in crossing.get(node, []) for n in j.parts))
            if not names:
                continue
            mine = tuple(n for n in names if n.startswith(f"F{fam}-"))
            kept.append(SlotSeam(node, fam, mine, tuple(n for n in names if n not in mine)))
        fs.seams_in_slot = kept
        fs.joint_fallbacks = [fs._seams_refused[k] for k in sorted(fs._seams_refused,
                                                                   key=lambda k: (k[1], k[0]))]



def joinery_report(fs) -> dict:
    """The ``fabrication.joinery`` entry of a design's report: ``seams_in_slot`` (how many
    seams the crossing slots hold without a connector) and ``seams`` (each: node, family,
    parts, holders), ``fallbacks`` (each seam refused: node, family, the parts of the joint,
    ``reason`` (a :class:`SeamReason` value) and ``why``, what refused it) and
    ``fallbacks_by_reason``.

    >>> joinery_report(fs)["seams_in_slot"]                  # doctest: +SKIP
    56
    """
    seams, fallbacks = getattr(fs, "seams_in_slot", []), getattr(fs, "joint_fallbacks", [])
    by_reason: dict[str, int] = {}
    for f in fallbacks:
        by_reason[f.reason.value] = by_reason.get(f.reason.value, 0) + 1
    return {
        "seams_in_slot": len(seams),
        "seams": [{"node": s.node, "family": s.family, "parts": list(s.parts),
                   "holders": list(s.holders)} for s in seams],
        "fallbacks": [{"node": f.node, "family": f.family, "parts": list(f.parts),
                       "reason": f.reason.value, "why": f.detail} for f in fallbacks],
        "fallbacks_by_reason": dict(sorted(by_reason.items())),
    }


def yield_cut_positions(fs) -> dict[str, tuple[int, ...]]:
    """``{plate name: node lines}``: where each plate of ``fs`` may be split for the sheets'
    yield (the final cut, :mod:`~torsal.fabrication.nesting.split`) with a seam inside a
    crossing slot, no connector: the inner node lines (``1 .. panels - 1``) where the plate is
    slotted at an egg-crate crossing and the crossing plate passes through whole (not split
    there itself, with its own seam in this plate's slot); the plate folds there no more than
    a mitre allows (or it would have been split there already); not where a seam of its
    family was refused before or whose joint changed (``_base_at``). Whether the seam stays in
    its slot is the rebuilt fin system's to decide (:class:`SlotSeams`: the slide plan and the
    local assembly check; a refused one falls back to brackets, counted)."""
    if fs.family_split.value != "egg-crate":
        return {}
    refused = getattr(fs, "_seams_refused", {})
    changed = getattr(fs, "_base_at", {})
    # the nodes each family's plates pass through whole: the crossing plate must (a node
    # where the other family is split already, its own seam in this plate's slot, would
    # lose both seams to brackets)
    through = {f: {int(v) for p in fs.plates if p.family == f for v in p.nodes[1:-1]}
               for f in (0, 1)}
    out: dict[str, tuple[int, ...]] = {}
    for p in fs.plates:
        if p.family not in (0, 1):
            continue
        k = len(p.panels)
        slotted = sorted({int(s.position) for s in p.slots if 0 < s.position < k})
        keep = tuple(j for j in slotted if (p.family, int(p.nodes[j])) not in refused
                     and int(p.nodes[j]) not in changed
                     and int(p.nodes[j]) in through[1 - p.family])
        if keep:
            out[p.name] = keep
    return out
