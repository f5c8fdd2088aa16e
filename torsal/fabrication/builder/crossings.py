"""Egg-crate crossings: the slots and the direction each family-1 plate slides in along
(issue 15; the rules are in :mod:`torsal.fabrication.joints`).

:class:`CrossingSlotter` slots the crossings the joinery leaves to an egg-crate (family 0 from
its ``b`` edge, family 1 from its ``a`` edge, or the other way round), plans the one direction
every family-1 plate slides onto all its crossings along (:meth:`CrossingSlotter._slide_plan`),
and makes slots that would cut a part in two shallower. Where the two parts of a family-1 strip
split inside a slot slide in from opposite edges, the family-0 plate is slotted from both edges
and each part keeps a tongue at its end that enters from its own side
(:data:`~.joints.TONGUE_SHARE`; a halving joint from each side, no connector). Lengths in the fin system's ``unit``.
"""
from __future__ import annotations

import warnings
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from ..joints import MAX_SLOT_SKEW, TONGUE_SHARE, slot_width
from ..model import Crossing, Joint, JointKind, Part, Slot, SlotSide, _cross
from ..unroll import flat_outline
from .seams import SeamReason, SlotSeams
from .strips import _Strips


def slot_depths(depths, ratio: float, sense: int, *, end_gap: float = 0.0) -> tuple[float, float]:
    """``(d0, d1)``: how deep the family-0 and family-1 plates are slotted at a crossing whose
    fins are ``depths`` (family 0, family 1) deep along the node line (``unit``). The two
    slots meet inside the stretch both plates cover, ``[0, min(depths)]`` from ``a``: family
    0's slot takes ``ratio`` of it, from its ``b`` edge where ``sense`` > 0 (family 1 then from
    its ``a`` edge), else from its ``a`` edge; each runs ``end_gap / 2`` past the meeting
    point (no deeper than its fin), so that the two plates sit flush with their slot ends
    ``end_gap`` apart instead of bottoming out on each other. Equal depths ``d``, no gap:
    ``(ratio d, (1 - ratio) d)``.

    Why the gap: slot ends that meet exactly touch over a face, so the independent assembly
    check could not prove the two plates apart by its separating axes and gave every
    egg-crate pair and path an exact boolean (897 on 7a at full size, two thirds of the
    check's time); a gap of the clearance proves them apart for free, as it does the slots'
    sides, and a workshop's slots are cut past half for the same reason.

    >>> slot_depths([0.4, 0.2], 0.5, 1)
    (0.30000000000000004, 0.1)
    >>> slot_depths([0.4, 0.2], 0.5, -1)
    (0.1, 0.1)
    >>> slot_depths([400.0, 400.0], 0.5, 1, end_gap=0.5)
    (200.25, 200.25)
    """
    D0, D1 = float(depths[0]), float(depths[1])
    both = min(D0, D1)
    if sense > 0:      # family 0 down from its b edge, family 1 up from a, meeting at m
        m = (1.0 - ratio) * both
        d0, d1 = D0 - m, m
    else:              # family 0 up from a, family 1 down from its b edge
        m = ratio * both
        d0, d1 = m, D1 - m
    return min(d0 + 0.5 * end_gap, D0), min(d1 + 0.5 * end_gap, D1)


class _Sense(NamedTuple):
    """The sense a family-1 part slides in (+1: along its direction), whether it keeps every
    gap of its butted ends (``ok``), and the largest sine it runs into one of their faces at."""

    sense: float
    ok: bool
    run_in: float


#: grid points per side of the square of directions :func:`slide_direction` searches
SLIDE_SEARCH_STEPS = 61


def slide_direction(axes: np.ndarray, walls: np.ndarray, *, max_skew: float, tol: float,
                    prefer_plus: bool = False) -> tuple[np.ndarray, float] | None:
    """``(direction, sense)``: a direction a plate slotted at crossings with node axes ``axes``
    (k, 3) unit vectors, signed alike) can slide onto all of them along, each at most
    ``max_skew`` degrees off it, and a sense (+1 or -1) in which it runs into none of the
    faces ``walls`` (m, 3) (unit normals turned towards the plate: its butted ends) at a sine
    over ``tol``; the direction is returned times the sense. Of the directions that do, the one
    with the smallest largest skew (the narrowest slots), sense +1 first where ``prefer_plus``
    (a part with a seam inside a slot: the two parts of the seam slide in alike); None if no
    direction does.

    The directions searched are a grid of :data:`SLIDE_SEARCH_STEPS` squared round the mean
    axis, ``2 max_skew`` to every side: a direction within ``max_skew`` of every axis lies
    within that of the mean (the same search on every machine).

    >>> ax = np.array([[0, 0, 1.0], [np.sin(np.radians(3.0)), 0, np.cos(np.radians(3.0))]])
    >>> d, s = slide_direction(ax, np.zeros((0, 3)), max_skew=2.0, tol=1e-3)
    >>> round(float(np.degrees(np.arccos(d @ ax[0]))), 1), s
    (1.5, 1.0)
    >>> slide_direction(ax, np.zeros((0, 3)), max_skew=1.0, tol=1e-3) is None
    True
    """
    axes = np.asarray(axes, float).reshape(-1, 3)
    walls = np.asarray(walls, float).reshape(-1, 3)
    m = axes.sum(axis=0)
    m = m / np.linalg.norm(m)
    e1 = _cross(m, np.eye(3)[int(np.argmin(np.abs(m)))])
    e1 = e1 / np.linalg.norm(e1)
    e2 = _cross(m, e1)
    r = np.tan(np.radians(2.0 * max_skew))
    g = np.linspace(-r, r, SLIDE_SEARCH_STEPS)
    u, v = np.meshgrid(g, g, indexing="ij")
    d = m + u.reshape(-1, 1) * e1 + v.reshape(-1, 1) * e2
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    cos = np.clip(d @ axes.T, -1.0, 1.0)
    skew = np.degrees(np.arccos(cos.min(axis=1)))
    best = None
    for sense in (1.0, -1.0):
        run_in = (sense * d @ walls.T).max(axis=1) if len(walls) else np.zeros(len(d))
        ok = (skew <= max_skew) & (run_in <= tol)
        if not ok.any():
            continue
        i = int(np.flatnonzero(ok)[np.argmin(skew[ok])])
        if best is None or skew[i] < best[2]:
            best = (d[i], sense, skew[i])
        if prefer_plus:
            break
    return None if best is None else (best[1] * best[0], best[1])


class CrossingSlotter:
    """Slots the egg-crate crossings of a fin system ``fs`` under construction: fills the parts'
    ``slots``, its ``crossings``, egg-crate ``joints``, ``slot_conflicts``, the slide plan of its
    family-1 plates (``_plan``) and the crossings they cannot slide onto (``_unslidable``)."""

    def __init__(self, fs):
        self.fs = fs

    def _slot_crossings(self, st: "_Strips", part_of_strip, joinery, cont) -> None:
        """Egg-crate slots where both plates pass and the joinery allows it: family 0 from its
        ``b`` edge, family 1 from its ``a`` edge, each as wide as :func:`~.joints.slot_width`
        says for the crossing angle and folds there."""
        fs = self.fs
        t, c = fs.thickness, fs.clearance
        at_node: dict[int, list[list[tuple[Part, int]]]] = {}
        # a family split inside the other's slot is slotted at both its parts' ends
        seams = fs._seam_crossings
        whole = cont | np.array([[(f, v) in seams for v in range(cont.shape[1])] for f in (0, 1)])
        for strip, parts in zip(st.fins, part_of_strip):
            for p in parts:
                for pos, node in enumerate(p.nodes):
                    node = int(node)
                    x = joinery.get(node)
                    if x is not None and x.kind == JointKind.EGG_CRATE and whole[0, node] and whole[1, node]:
                        at_node.setdefault(node, [[], []])[strip.family].append((p, pos))
        fs._plan = self._slide_plan(st, at_node)
        for node in sorted(at_node):
            l0, l1 = at_node[node]
            if not l0 or not l1:
                continue
            x = joinery[node]
            d = float(st.depth[node])
            # the family-1 plate slides along its own direction, a little off this node axis:
            # both slots are wider by the sideways travel over the fin depth, on either side
            plans = [fs._plan[p.name] for p, _ in l1]
            direction = plans[0][0]
            senses = sorted({s_ for _, s_ in plans}, reverse=True)
            if len(senses) > 1 and not self._tongues_fit(min(st.family_depth[:, node])):
                # the two parts of a family-1 strip split in this slot slide in from opposite
                # edges and the fins are too shallow for a tongue each: split it as before
                SlotSeams(fs).refuse(1, node, SeamReason.OPPOSITE_SLIDES,
                                     " and ".join(p.name for p, _ in l1) + " slide in from "
                                     "opposite edges of the slot and the fins are too shallow "
                                     "for a tongue each", tuple(p.name for p, _ in l1))
            axis = (st.a[node] - st.b[node]) / d
            # (the widest the slide of any of its family-1 parts needs, each in its own sense)
            skew = max(np.arctan2(np.linalg.norm(_cross(dd, axis)), abs(dd @ axis)) for dd, _ in plans)
            extra = 2.0 * d * np.tan(skew)
            w0 = slot_width(x.angle, thickness=t, clearance=c, fold_self=x.folds[0],
                            fold_other=x.folds[1]) + extra
            w1 = slot_width(x.angle, thickness=t, clearance=c, fold_self=x.folds[1],
                            fold_other=x.folds[0]) + extra
            names0 = tuple(sorted({p.name for p, _ in l0}))
            names1 = tuple(sorted({p.name for p, _ in l1}))
            # family 0 slotted from its b edge and family 1 from its a edge (family 1 moves
            # along a - b), or the other way round where family 1 slides in along b - a; both
            # where the two parts of a family-1 seam slide in from opposite edges: each keeps
            # a tongue at its end that enters the family-0 plate's slot from its own side
            share = fs.slot_ratio if len(senses) == 1 else TONGUE_SHARE
            b0, b1 = st.family_b(0, node), st.family_b(1, node)
            for s_ in senses:
                side0, side1 = (SlotSide.B, SlotSide.A) if s_ > 0 else (SlotSide.A, SlotSide.B)
                d0, d1 = self._slot_depths(st.family_depth[:, node], share, s_)
                for p, pos in l0:
                    p.slots.append(Slot(node, pos, side0, self._end_depth(p, pos, side0, d0, st.a[node], b0),
                                        w0, "+".join(names1)))
                for (p, pos), (_, ps) in zip(l1, plans):
                    if ps == s_:
                        p.slots.append(Slot(node, pos, side1, self._end_depth(p, pos, side1, d1, st.a[node], b1),
                                            w1, "+".join(names0)))
            d0, d1 = self._slot_depths(st.family_depth[:, node], share, senses[0])
            w = max(w0, w1)
            fs.crossings.append(Crossing(node, names0, names1, d, d0, d1, w, w - c - t,
                                           float(x.angle), float(max(x.folds))))
            if len(l1) > 1 and any(not np.array_equal(dd, direction) for dd, _ in plans):
                # a family-1 strip split in this slot: each part slides in along its own
                # direction, so each gets a record of its own (one record's direction made the
                # independent check slide the second part off its other slots: example 11 at
                # test size, F1-S008-P01, 2,415 mm^3, the seam's first version's failure)
                for (p, _), (dd, _) in zip(l1, plans):
                    fs.joints.append(Joint(JointKind.EGG_CRATE, node, names0 + (p.name,),
                                           dd, None, None, float(x.angle)))
            else:
                fs.joints.append(Joint(JointKind.EGG_CRATE, node, names0 + names1,
                                       direction, None, None, float(x.angle)))

    def _tongues_fit(self, depth: float) -> bool:
        """Whether fins ``depth`` deep along their node line (``unit``, the stretch both
        families cover) leave room for the tongues of a family-1 seam whose parts slide in
        from opposite edges: the family-0 plate is slotted from each edge so that each tongue
        and the web between the two slots take :data:`~.joints.TONGUE_SHARE` of the depth,
        each at least two plate thicknesses."""
        return TONGUE_SHARE * depth >= 2.0 * self.fs.thickness

    def _slot_depths(self, depths, ratio: float, sense: int) -> tuple[float, float]:
        """:func:`slot_depths` at a crossing of this fin system: the slot ends stand its
        clearance apart."""
        return slot_depths(depths, ratio, sense, end_gap=self.fs.clearance)

    @staticmethod
    def _end_depth(p: Part, pos: int, side: SlotSide, depth: float, a: np.ndarray,
                   b: np.ndarray) -> float:
        """The depth of a slot of ``p`` at node line ``pos`` (node ``a -> b``) so that it ends
        where the partner's begins: a slot at a part's end is measured from its trimmed end
        edge, whose corner has moved along the ``a`` or ``b`` edge (a strip split inside the
        slot, trimmed back from its seam), a few tenths of a millimetre along the node line
        (on the hypar canopy that left 2-4 mm^3 of the two plates overlapping)."""
        k = len(p.panels)
        if 0 < pos < k:
            return depth
        corner = (p.panels[0, 3] if pos == 0 else p.panels[-1, 2]) if side == SlotSide.B else (
            p.panels[0, 0] if pos == 0 else p.panels[-1, 1])
        start, other = (b, a) if side == SlotSide.B else (a, b)
        u = (other - start) / np.linalg.norm(other - start)
        return float(depth - (corner - start) @ u)

    def _slide_plan(self, st: "_Strips", at_node) -> dict:
        """``{family-1 part name: (unit direction, sense)}``: every family-1 plate slides onto
        all its egg-crate crossings along one direction, the mean of their node axes
        (``sense`` +1: along ``a - b``, slots open on its ``a`` edge; -1: along ``b - a``),
        the sense in which its butted ends do not run into the plates they meet. Where a
        crossing's axis is more than :data:`~.joints.MAX_SLOT_SKEW` off the mean, or the
        butted ends block it in both senses, the direction within that of every axis that
        keeps the gaps (:func:`slide_direction`); where there is none, the crossing farthest
        off, or every crossing of a plate blocked in both senses, is listed in
        ``_unslidable`` (butted in the next build)."""
        fs = self.fs
        nodes_of: dict[str, list[int]] = {}
        for node, (l0, l1) in sorted(at_node.items()):
            if l0 and l1:
                for p, _ in l1:
                    nodes_of.setdefault(p.name, []).append(node)
        plan = {}
        for name, nodes in nodes_of.items():
            axes = np.array([(st.a[v] - st.b[v]) / st.depth[v] for v in nodes])
            d = axes.sum(axis=0)
            d = d / np.linalg.norm(d)
            skew = np.degrees(np.arctan2(np.linalg.norm(_cross(axes, d), axis=1), axes @ d))
            if skew.max() > MAX_SLOT_SKEW or not self._sense_of(name, d, nodes, st).ok:
                # the mean axis is too far off one of them, or its butted ends close a gap
                # in both senses: another direction within MAX_SLOT_SKEW of every axis may
                # do (on 7c at full size 86 of 280 connectors were such crossings butted)
                found = slide_direction(axes, self._walls_of(name), max_skew=MAX_SLOT_SKEW,
                                        tol=self._tol(nodes, st),
                                        prefer_plus=self._has_seams(nodes))
                if found is not None:
                    plan[name] = found
                    continue
            if skew.max() > MAX_SLOT_SKEW:
                fs._unslidable[nodes[int(np.argmax(skew))]] = 1, (
                    f"its node axis is {skew.max():.1f} deg off the slide direction of {name} "
                    f"(> {MAX_SLOT_SKEW:g}): the plate cannot slide onto all its crossings")
            sense = self._sense(name, d, nodes, st)
            plan[name] = (sense * d, sense)
        return plan

    def _sense(self, name: str, d: np.ndarray, nodes: list[int], st: "_Strips") -> float:
        """The sense (+1: along ``d``) the family-1 part ``name`` slides onto its crossings
        ``nodes`` in: the one in which its butted ends run least into the plates they meet
        (walls). Where the part has a seam inside a slot, +1 wherever both senses keep every
        gap (its seam's plane holds the node line, so the run-in is a rounding's sign, opposite
        for the two parts of the seam, which must slide in alike); a seam its slide would
        close is refused (:class:`~.seams.SlotSeams`), any other crossing listed in
        ``_unslidable``."""
        fs = self.fs
        choice = self._sense_of(name, d, nodes, st)
        if choice.ok:
            return choice.sense
        sense, why = choice.sense, f"({np.degrees(np.arcsin(min(1.0, choice.run_in))):.1f} deg)"
        seams = [v for v in nodes if (1, v) in fs._seam_crossings]
        if seams:
            # a seam inside a slot may close: split there as before (next build)
            for v in seams:
                SlotSeams(fs).refuse(1, v, SeamReason.CLOSES_SEAM, f"{name} would close its "
                                     f"seam sliding along its node axes {why}", (name,))
        else:
            for v in nodes:
                fs._unslidable.setdefault(v, (1, f"{name} would run into a plate it butts "
                                              f"against while sliding along its node axes {why}"))
        return sense

    def _walls_of(self, name: str) -> np.ndarray:
        """(m, 3) unit normals of the faces the part ``name`` ends against, turned towards it."""
        return np.asarray(self.fs._walls.get(name, []), float).reshape(-1, 3)

    def _tol(self, nodes: list[int], st: "_Strips") -> float:
        """The sine a slide may run into a wall at: the butted end may close its gap
        (clearance / 2) over a travel of the deepest crossing's depth."""
        return 0.5 * self.fs.clearance / float(st.depth[nodes].max())

    def _has_seams(self, nodes: list[int]) -> bool:
        """Whether a family-1 part slotted at ``nodes`` has a seam inside one of their slots."""
        return any((1, v) in self.fs._seam_crossings for v in nodes)

    def _sense_of(self, name: str, d: np.ndarray, nodes: list[int], st: "_Strips") -> _Sense:
        """The sense the family-1 part ``name`` slides along ``d`` in (:meth:`_sense`), without
        refusing anything: the one whose butted ends run least into their walls (+1 where the
        part has a seam in a slot and +1 keeps every gap), whether it keeps every gap."""
        walls = self._walls_of(name)
        if not len(walls):
            return _Sense(1.0, True, 0.0)
        run_in = {s_: float((s_ * walls @ d).max()) for s_ in (1.0, -1.0)}
        tol = self._tol(nodes, st)
        sense = min(run_in, key=run_in.get)
        if self._has_seams(nodes) and run_in[1.0] <= tol:
            sense = 1.0
        return _Sense(sense, run_in[sense] <= tol, run_in[sense])

    def _resolve_slot_splits(self) -> None:
        """Slots that would cut a part in two (a narrow or slanted panel at the node: the slot
        band runs out of the panel) are made shallower, leaving a web of ``thickness``; the
        partner's slot is deepened by as much where that keeps it whole, else the two plates
        interfere there. A slot that cuts the part apart at any depth is left out. Each case
        is listed in ``slot_conflicts`` and warned about."""
        fs = self.fs

        def whole(p: Part, slots) -> bool:
            try:
                flat_outline(p.panels, slots=list(slots), name=p.name)
            except ValueError as e:
                return "slots cut" not in str(e)
            return True

        conflicts: list[tuple[str, int, float, float, str]] = []
        for p in fs.parts:
            if not p.slots or whole(p, p.slots):
                continue
            for s in list(p.slots):
                if whole(p, [s]):
                    continue
                i = p.slots.index(s)
                # first without the half clearance it runs past the partner's (slot_depths):
                # its end then stands clearance/2 off the partner's, as a 5 mm fin's slot
                # beside a slanted 3 mm plate needs (2.75 mm cut it in two, 2.5 mm did not)
                short = replace(s, depth=s.depth - 0.5 * fs.clearance)
                if fs.clearance > 0 and short.depth > 0 and whole(p, [short]):
                    p.slots[i] = short
                    continue
                lo, hi = 0.0, s.depth
                if not whole(p, [replace(s, depth=1e-3 * s.depth)]):
                    new = 0.0
                else:
                    for _ in range(12):
                        mid = 0.5 * (lo + hi)
                        lo, hi = (mid, hi) if whole(p, [replace(s, depth=mid)]) else (lo, mid)
                    new = lo - fs.thickness
                    if new <= 0.05 * s.depth:
                        new = 0.0
                if new > 0:
                    p.slots[i] = replace(s, depth=new)
                else:
                    del p.slots[i]
                # the partner(s) take the difference if they stay whole
                lack = s.depth - new
                notes = []
                for o in fs.parts:
                    if o.family == p.family or o.family not in (0, 1):
                        continue
                    for jo, so in enumerate(o.slots):
                        if so.node != s.node:
                            continue
                        deeper = replace(so, depth=min(so.depth + lack, float(fs._fin_depth[s.node])))
                        trial = o.slots[:jo] + [deeper] + o.slots[jo + 1:]
                        if whole(o, trial):
                            o.slots[jo] = deeper
                            notes.append(f"{o.name} slotted {lack:.3g} deeper")
                        else:
                            notes.append(f"{o.name} cannot take it: the plates interfere by "
                                         f"{lack:.3g} {fs.unit}")
                conflicts.append((p.name, s.node, float(s.depth), float(new),
                                  "; ".join(notes) or "no partner slot"))
        fs.slot_conflicts = conflicts
        if conflicts:
            warnings.warn(
                f"{len(conflicts)} egg-crate slots would cut their part in two (narrow or slanted "
                f"panel at the node) and were made shallower or left out: "
                + "; ".join(f"{n} at node {v}: depth {d0:.3g} -> {d1:.3g} {fs.unit} ({note})"
                            for n, v, d0, d1, note in conflicts[:6])
                + (" ..." if len(conflicts) > 6 else "") + "; see FinSystem.slot_conflicts",
                stacklevel=4)
