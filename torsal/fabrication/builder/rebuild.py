"""The fin system built until every end is trimmed and every path is clear (issue 15).

:class:`Rebuilder` runs the builder's phases on a fin system under construction (read the
strips, choose the joint at every crossing, cut the strips into parts, join the part ends, slot
the crossings, order the parts and fix the carrying plates to the building) and builds again,
leaving out panels and changing joints, until nothing changes or :data:`MAX_REBUILDS` is
reached. :func:`reset_state` and :func:`init_joints` empty the lists one build fills; they
name every record the phases keep on the fin system.
"""
from __future__ import annotations

import dataclasses
import warnings
from enum import Enum

import numpy as np

from ..joints import choose_joinery
from ..model import Crossing, FamilySplit, Joint, JointKind, Part
from .clash import ClashFinder
from .crossings import CrossingSlotter
from .ends import EndJoiner
from .fasteners import FastenerLayout
from .fixings import FixingPlacer
from .held import MAX_HOLD_ROUNDS, HeldCrossing, hold_crossings, publish_held, warn_held
from .paths import AssemblyPlanner
from .seams import JointFallback, SlotSeam, SlotSeams
from .strips import StripCutter, _plate_panels, _read_strips
from .tabs import TabJoints

#: how often a :class:`~torsal.fabrication.parts.FinSystem` rebuilds at most, changing joints
#: and leaving out panels
MAX_REBUILDS = 16


def reset_state(fs) -> None:
    """Empty the lists one build of the fin system ``fs`` fills."""
    #: degenerate panels dropped: (part-id prefix of the strip, structure edge, width)
    fs.dropped_panels: list[tuple[str, int, float]] = []
    #: parts whose solid could not be slotted by OpenCascade: (name, slot nodes, reason)
    fs.unslotted_solids: list[tuple[str, list, str]] = []
    #: slots made shallower or left out: (part name, node, old depth, new depth, partner note)
    fs.slot_conflicts: list[tuple[str, int, float, float, str]] = []
    #: parts of one panel that do not fit ``fit_sheet`` (warned; ``FinSystem.layout`` will refuse)
    fs.oversize_panels: list[str] = []
    fs._oversize: list[int] = []
    fs.crossings: list[Crossing] = []
    #: part ends that could not be butt-trimmed: (part name, node, reason)
    fs.untrimmed_joints: list[tuple[str, int, str]] = []
    #: crossings butted so that a loose plate is bolted to the plate it hung on (.held)
    fs.held_crossings: list = []
    init_joints(fs)
    fs.parts = []


def init_joints(fs) -> None:
    """Empty the joints of the fin system ``fs`` and the records its joints' phases keep."""
    #: every joint of the assembly (egg-crate, butt + bracket, mitre + splice)
    fs.joints: list[Joint] = []
    #: joints without a connector (no room for one): (part name, node, reason)
    fs.unconnected_joints: list[tuple[str, int, str]] = []
    #: the joint chosen at every crossing of two strips (see :func:`~.joints.choose_joinery`)
    fs.joinery: list = []
    fs._connectors: list[Part] = []
    fs._n_conn: dict[int, int] = {}
    #: part ends that could not be trimmed: (strip index, panel of the strip, strip name,
    #: structure edge, node, reason)
    fs._untrimmable: list[tuple] = []
    #: of those, the butt joints that may change: (strip index, panel) -> (node, family)
    fs._swappable: dict[tuple, tuple] = {}
    #: mitred seams that could not be trimmed: (strip index, node line of the strip)
    fs._bad_seams: set = set()
    #: crossings an egg-crate cannot join (node -> reason): butted in the next build
    fs._unslidable: dict[int, str] = {}
    #: parts whose path into place is blocked: [(part, [(panel, plate, its panel, distance)])]
    fs._blocked_paths: list = []
    #: splits at crossings tried as seams inside the slot ({(family, node)}), those refused
    #: during this build ({(family, node): JointFallback}: butted in the next), and the
    #: final lists (:mod:`.seams`): the seams kept and the fallbacks, named
    fs._seam_crossings: set = set()
    fs._refuse_seams: dict = {}
    fs.seams_in_slot: list[SlotSeam] = []
    fs.joint_fallbacks: list[JointFallback] = []
    #: the butt joints made with a tab bent from the butted part instead of a bracket (.tabs)
    fs.tab_joints: list = []
    #: brackets taken away at an end bent into a tab in its other corner, whose parts are
    #: joined at the node without them: (node, bracket, parts, why) (.tabs)
    fs.spare_brackets: list = []
    #: part name -> [unit normal of a plate it butts against, turned towards the part]
    fs._walls: dict[str, list] = {}
    #: (family, node) -> [(normal, into direction, plate normal)] of part ends butted there
    fs._ends_at: dict[tuple[int, int], list] = {}
    #: part name -> [(part across a mitred seam, seam normal turned to it, its panel there)]
    fs._seams: dict[str, list] = {}
    #: connector name -> (a, b, options): the places it may go (see EndJoiner._record)
    fs._sites: dict[str, tuple] = {}
    #: the fixings (parts) and fixing name -> (plate name, panel index) it lies on
    fs._fixings: list[Part] = []
    fs._fixing_sites: dict[str, tuple[str, int]] = {}
    #: fixings taken out of a part's way: (name, strip index, panel of the strip)
    fs._evicted: list[tuple] = []
    #: connectors moved to another place of their site so that their path is clear, and
    #: connectors left out where the part they fasten has another at that node
    fs._moved_connectors: list[str] = []
    fs._dropped_connectors: list[str] = []


class SlotReason(str, Enum):
    """Why an egg-crate crossing fell back to a butt joint with brackets after its slots were
    cut (named in ``FinSystem.joint_fallbacks``)."""

    #: a slot would cut its part in two (a narrow or slanted panel at the node) and the
    #: partner's slot cannot be deepened by what it was made shallower: the two plates would
    #: interfere there, so that part is split at the node and butted against the other
    CUTS_PART = "slot-cuts-part"


#: the largest share of a design's fin panels left out because nothing can hold their plates
#: (:meth:`Rebuilder.build_until_trimmed`): a few slivers at a corner; beyond it the design's
#: load path refuses it, which asks for a deeper structure or more room for fixings
MAX_UNHOLDABLE_SHARE = 0.05


class Rebuilder:
    """Builds the parts of a fin system ``fs`` from its structure, again and again until its
    joints are settled and its paths clear (the phases: :mod:`torsal.fabrication.builder`)."""

    def __init__(self, fs):
        self.fs = fs

    def build_until_trimmed(self) -> None:
        """Build; where a part end meets the plate it butts against too obliquely to be
        trimmed (it lies along that plate, within about 12 degrees, and would overlap it), leave
        that end panel out (it duplicates the other plate's fin there) and build again, so that
        every part end is trimmed. The panels left out are named in ``coplanar_panels``
        (warned); at most :data:`MAX_REBUILDS` rebuilds. A rebuild changes only the ends next
        to the panels left out and the crossings forced to butt: the trims, bracket corners,
        connectors and sheet fits of all other ends are taken from the builds before
        (``FinSystem._cached``), so each costs less than the first.

        Then the load path of the result (:meth:`_hold_loose`): plates it does not reach from
        the building are fixed in one more build (``_fix_also``: one fixing each, along the way
        they go in); those still held by nothing (no fixing fits them) that hang in a slot
        their weight draws them out of are bolted to the plate they hang on, that crossing
        butted with brackets (:mod:`.held`, named in ``held_crossings``); those still held by
        nothing are left out in the next (``_unholdable``, named in ``coplanar_panels``). A
        crossing where a slot would cut its part in two and the plates would interfere is
        butted in a new build (:meth:`_butt_slots`; named in ``joint_fallbacks``,
        ``slot-cuts-part``)."""
        fs = self.fs
        forced = self._start_records()
        extra: dict[int, set] = {}
        left_out: list[tuple[str, int, int, str]] = []
        for attempt in range(MAX_REBUILDS + 1):
            fs._rebuilds = attempt
            reset_state(fs)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                self._build_from_structure(extra, forced)
            new = {(si, i): rec for si, i, *rec in fs._untrimmable + ClashFinder(fs)._stray_parts()
                   if i not in extra.get(si, ())}
            swapped = len(fs._base_at)
            new_forced = self._change_joints(new, forced)
            # joints changed at T and L junctions, splits moved off seams that could not be
            # trimmed: build again
            moved = fs._bad_seams - fs._avoid_splits
            fs._avoid_splits |= moved
            changed = bool(moved) or len(fs._base_at) > swapped
            new.update({(si, i): rec for si, i, *rec in fs._clashing_panels(leaving=set(new))})
            new_forced.update((v, why) for v, why in fs._unslidable.items()
                              if v not in forced and v not in new_forced)
            cycles = AssemblyPlanner(fs)._break_cycles(forced)
            new_forced.update((v, why) for v, why in cycles.items() if v not in new_forced)
            changed |= self._settle_seams(settled=not (new or new_forced or changed))
            checked = not (new or new_forced or changed)
            excluded = set()
            if checked:
                # the joints are settled: now the paths into place (they change with every
                # panel left out and every joint changed, so they are looked at last)
                fs._check_paths()
                planner = AssemblyPlanner(fs)
                new = {(si, i): rec for si, i, *rec in planner._blocked_panels()}
                new.update({(si, i): rec for si, i, *rec in planner._loose_panels()
                            if (si, i) not in new})
                excluded = {(si, i) for _, si, i in fs._evicted} - fs._fixing_exclude
            fs._fixing_exclude |= excluded
            if not (new or new_forced or changed) or attempt == MAX_REBUILDS:
                if not checked:
                    fs._check_paths()     # out of rebuilds: at least the clear directions
                break
            for (si, i), (prefix, edge, node, why) in sorted(new.items()):
                extra.setdefault(si, set()).add(i)
                left_out.append((prefix, edge, node, why))
            forced.update(new_forced)
        fs.coplanar_panels = left_out
        SlotSeams(fs).publish()
        if self._butt_slots():
            return self.build_until_trimmed()
        # brackets whose butted end can bend into a tab instead, where the assembly check
        # around each proves it (issue 42)
        TabJoints(fs).make()
        # the fasteners' holes, in the connectors, fixings and the plates they lie on
        FastenerLayout(fs)._drill()
        if self._hold_loose():
            return self.build_until_trimmed()
        fs.held_crossings = publish_held(fs, fs._hold_butts)
        for w in caught:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        if left_out:
            _warn_left_out(left_out)
        warn_held(fs.held_crossings)

    def _start_records(self) -> dict[int, tuple[int, str]]:
        """Empty the records :meth:`build_until_trimmed` keeps through its rebuilds (those it
        keeps through the builds again after it, the load path's and the slots' changes and
        the seams' verdicts, only on the first); returns the crossings forced to butt from the
        start, ``{node: (family split, why)}``: where a slot would cut a part in two, and the
        crossings bolted for the load path."""
        fs = self.fs
        #: panels {(strip index, panel of the strip)} whose plates are fixed to the building
        #: because a build before left them held by nothing
        if not hasattr(fs, "_fix_also"):
            fs._fix_also: set[tuple[int, int]] = set()
            #: panels left out because even fixed their plates were held by nothing
            fs._unholdable: set[tuple[int, int]] = set()
            #: crossings butted because a slot there would cut its part in two and the plates
            #: would interfere (:meth:`_slot_butts`): {node: (family split, why, parts)}
            fs._slot_butts: dict[int, tuple] = {}
            #: crossings butted so that a plate the load path found loose is bolted to the
            #: plate it hung on ({node: HeldCrossing}, :mod:`.held`), and the rounds that did
            fs._hold_butts: dict[int, HeldCrossing] = {}
            fs._hold_rounds = 0
        #: (strip index, panel of the strip) that take no fixing: one there was in a part's way
        fs._fixing_exclude: set = set()
        #: (strip index, node line of the strip) where a split for the sheet must not be: a
        #: mitred seam there could not be trimmed
        fs._avoid_splits: set = set()
        #: node -> family whose plate the other family's parts end against there, where an end
        #: could not be trimmed the way the joinery first chose (the joint changed)
        fs._base_at: dict[int, int] = {}
        #: seams refused a crossing slot ({(family, node): JointFallback}) and the local
        #: assembly checks of the seams by content (.builder.seams: kept through the builds
        #: again below, which change a few joints and leave most seams as they were)
        fs._seams_refused: dict = {}
        if not hasattr(fs, "_seam_verdicts"):
            fs._seam_verdicts: dict = {}
        forced = {v: b[:2] for v, b in fs._slot_butts.items()}
        forced.update((v, (h.family, h.why)) for v, h in fs._hold_butts.items())
        return forced

    def _butt_slots(self) -> bool:
        """Slots that would cut a part in two, once, on the final parts (it unrolls them all:
        :meth:`~.crossings.CrossingSlotter._resolve_slot_splits`). True where the plates would
        then interfere at a crossing (:meth:`_slot_butts`): it is butted in a new build; else
        the crossings butted so far are named in ``joint_fallbacks``."""
        fs = self.fs
        with warnings.catch_warnings(record=True) as slot_warnings:
            warnings.simplefilter("always")
            CrossingSlotter(fs)._resolve_slot_splits()
        butts = self._slot_butts()
        if butts:
            fs._slot_butts.update(butts)
            return True
        for w in slot_warnings:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        fs.joint_fallbacks = list(fs.joint_fallbacks) + [
            JointFallback(v, fam, SlotReason.CUTS_PART, why, parts) for v, (fam, why, parts) in
            sorted(fs._slot_butts.items())]
        return False

    def _slot_butts(self) -> dict[int, tuple]:
        """``{node: (family, why, parts)}``: the egg-crate crossings where a slot would cut its part
        in two and was made shallower or left out while no partner's slot could be deepened
        by as much (``slot_conflicts``, :meth:`~.crossings.CrossingSlotter._resolve_slot_splits`:
        the plates would interfere by the difference; the bad-input corpus's 5 mm deep facade
        at 15 mm^3). That part's family is split there instead (butt joint + bracket); a
        crossing already butted is not changed again."""
        fs = self.fs
        egg = {j.node for j in fs.joints if j.kind == JointKind.EGG_CRATE}
        out: dict[int, tuple] = {}
        for name, node, d0, d1, note in fs.slot_conflicts:
            lack = d0 - d1
            if node in fs._slot_butts or node in out or node not in egg or lack <= 0:
                continue
            if note == "no partner slot" or "cannot take it" in note:
                out[node] = (int(name[1]), f"the slot of {name} would cut it in two and its "
                             f"partner cannot take {lack:.3g} {fs.unit} more ({note}): "
                             f"split family {name[1]}",
                             tuple(sorted({n for j in fs.joints if j.node == node
                                           and j.kind == JointKind.EGG_CRATE for n in j.parts})))
        return out

    def _hold_loose(self) -> bool:
        """Whether the plates the load path finds loose (:meth:`_unheld`) take one more build,
        and what changes in it (``True``: build again): plates that reach the building through
        nothing (a group of plates butted onto each other, none of them carrying the others)
        are fixed to it, each (``_fix_also``); those no fixing holds and that hang in a slot
        their weight draws them out of are bolted to the plate they hang on, that crossing
        butted with brackets (:func:`.held.hold_crossings`, ``_hold_butts``; at most
        :data:`.held.MAX_HOLD_ROUNDS` rounds); those still held by nothing, if few, are left
        out (``_unholdable``, named)."""
        from ..assembly.load_path import load_path

        fs = self.fs
        lp = load_path(fs)
        unheld = self._unheld(lp)
        if unheld - fs._fix_also:
            fs._fix_also |= unheld
            return True
        if unheld and fs._hold_rounds < MAX_HOLD_ROUNDS:
            new = hold_crossings(fs, lp, taken=set(fs._slot_butts) | set(fs._hold_butts))
            if new:
                fs._hold_butts.update(new)
                fs._hold_rounds += 1
                return True
        if unheld - fs._unholdable and len(unheld | fs._unholdable) <= (
                MAX_UNHOLDABLE_SHARE * sum(len(p.panels) for p in fs.parts if p.family in (0, 1))):
            # fixed where a fixing fits, bolted where a slot could hold them, and still held by
            # nothing: no room for a fixing on them: left out (named), as a workshop could not
            # hold them either. Not more than a few: a design most of whose fins no fixing
            # fits stays as it is, and its load path says so (not buildable)
            fs._unholdable |= unheld
            return True
        return False

    def _unheld(self, lp) -> set[tuple[int, int]]:
        """The panels ``(strip index, panel of the strip)`` of the fin plates (families 0 and
        1) the load path ``lp`` (:func:`torsal.fabrication.assembly.load_path.load_path` of the
        fin system) does not reach from the building: by panel, as a plate's name changes when
        a build leaves panels out."""
        fs = self.fs
        loose = set(lp.unsupported_parts)
        return {(fs._strip_of[p.name], p.span[0] + j) for p in fs.parts
                if p.family in (0, 1) and p.name in loose for j in range(len(p.panels))}

    def _settle_seams(self, *, settled: bool) -> bool:
        """Seams inside crossing slots refused during this build (by the slide plan) or, once
        every other joint is ``settled``, by the assembly check on the solids around each
        (:meth:`~.seams.SlotSeams.verify`): they fall back to butt joints with
        brackets in the next build. True if any was refused (build again)."""
        fs = self.fs
        if settled and not fs._refuse_seams:
            SlotSeams(fs).verify()
            # (a refused split for the sheet moves to the node line before, as a mitred seam
            # that cannot be trimmed does)
            fs._avoid_splits |= fs._bad_seams
        before = len(fs._seams_refused)
        fs._seams_refused.update(fs._refuse_seams)
        return len(fs._seams_refused) > before

    def _change_joints(self, new: dict, forced: dict) -> dict:
        """Part ends that could not be butt-trimmed against the other family's plate (``new``,
        the panels about to be left out): where the joint at that node was not changed yet,
        change it instead (the other family's parts end against this plate: at a crossing the
        other family is split, :data:`forced`; at a T or L junction ``_base_at``) and keep the
        panel. Returns the crossings to split the other way; removes the kept panels from
        ``new``."""
        fs = self.fs
        out: dict[int, tuple] = {}
        for key, (node, fam) in sorted(fs._swappable.items()):
            if key not in new or node in fs._base_at or node in forced or node in out:
                continue
            if node in {x.node for x in fs.joinery}:
                out[node] = (1 - fam, f"the ends of family {fam} cannot be trimmed against "
                             f"family {1 - fam} there: split family {1 - fam}")
            fs._base_at[node] = fam
            del new[key]
        return out

    def _build_from_structure(self, extra: dict | None = None, forced: dict | None = None) -> None:
        """Parts from the structure in five phases: read the strips, choose the joint at every
        crossing (:func:`~.joints.choose_joinery`), cut the strips into parts, join the part
        ends (butt + bracket, mitre + splice) and slot the egg-crate crossings."""
        fs = self.fs
        st = _read_strips(fs.structure, fs.scale, fs._drop_mask, extra)
        fs._extra = extra or {}
        plate = _plate_panels(st)
        joinery = {}
        if fs.family_split == FamilySplit.EGG_CRATE:
            for v in np.flatnonzero(st.passes[0] & st.passes[1]).tolist():
                joinery[v] = choose_joinery(v, plate[(0, v)], plate[(1, v)],
                                            min_angle=fs.min_crossing_angle,
                                            max_fold=fs.max_crossing_fold)
                if v in (forced or {}):
                    # an egg-crate the family-1 plate cannot slide onto together with its
                    # others: split it here (butt joint + bracket); a butt joint in a cycle
                    # of parts butting on each other: split the other strip instead
                    split, why = forced[v]
                    joinery[v] = joinery[v]._replace(kind=JointKind.BUTT_BRACKET, split=split,
                                                     why=why)
        fs.joinery = [joinery[v] for v in sorted(joinery)]
        part_of_strip = StripCutter(fs)._strip_parts(st, joinery)
        fs.parts = [p for parts in part_of_strip for p in parts]
        fs._strip_of = {p.name: si for si, parts in enumerate(part_of_strip) for p in parts}
        fs._where = {(si, p.span[0] + i): (p, i) for si, parts in enumerate(part_of_strip)
                    for p in parts for i in range(len(p.panels))}
        # a family is continuous at a node where one of its parts passes through it
        cont = st.passes.copy()
        for si, parts in enumerate(part_of_strip):
            fam = st.fins[si].family
            for p in parts:
                for end in (0, 1):
                    if p.ends[end] in ("miter", "fold"):
                        cont[fam, int(p.nodes[-end])] = False
        seams = SlotSeams(fs)
        fs._seam_crossings = seams.candidates(st, part_of_strip, joinery, cont, set(forced or ()))
        seams.slot(joinery)
        EndJoiner(fs)._join_ends(st, part_of_strip, plate, cont)
        CrossingSlotter(fs)._slot_crossings(st, part_of_strip, joinery, cont)
        fs.parts = ([p for parts in part_of_strip for p in parts]
                    + sorted(fs._connectors, key=lambda p: p.id))
        fs.joints = [dataclasses.replace(j, depth=float(st.depth[j.node])) if j.node >= 0 else j
                     for j in fs.joints]
        planner = AssemblyPlanner(fs)
        planner._set_butt_directions()
        # the plates that carry the others are fixed to the building; they come down onto
        # their fixings along their mean node axis. So are the plates that hang in slots
        # their weight would draw them out of, along the way they slide in
        roots = planner._roots()
        directions = {p.name: planner._root_direction(p) for p in roots}
        hung = planner._slot_hung(roots)
        # and the plates an earlier build left held by nothing (:meth:`Rebuilder._unheld`),
        # each along the way it goes in
        rooted = {p.name for p in roots}
        also = getattr(fs, "_fix_also", set())
        for p in fs.parts:
            si = fs._strip_of.get(p.name)
            if p.name not in rooted and any((si, p.span[0] + j) in also
                                            for j in range(len(p.panels))):
                cands = fs._directions.get(p.name, ((), None))[1]
                hung.setdefault(p.name, cands[0] if cands else planner._root_direction(p))
        hung = {n: d for n, d in hung.items() if d is not None}
        directions.update(hung)
        FixingPlacer(fs)._place(roots + [p for p in fs.parts if p.name in hung], directions,
                                exclude=getattr(fs, "_fixing_exclude", set()), single=set(hung))
        fs.parts += sorted(fs._fixings, key=lambda p: p.id)
        planner._set_root_directions()
        names = [p.name for p in fs.parts]
        assert len(set(names)) == len(names)
        fs._fin_depth = st.depth


def _warn_left_out(left_out: list) -> None:
    """Warn about the fin panels a build left out (``(strip, edge, node, why)``)."""
    warnings.warn(
        f"{len(left_out)} fin panels were left out because they meet the plate they end "
        f"against too obliquely to be trimmed (they lie along it and would overlap it), "
        f"cross another plate where no joint joins them, block a part's path into "
        f"place, or are held by nothing: "
        + "; ".join(f"{s} edge {e} at node {v} ({why})" for s, e, v, why in left_out[:6])
        + (" ..." if len(left_out) > 6 else "") + "; see FinSystem.coplanar_panels. "
        "Raise constraints.min_torsal_angle to keep the two families' fins apart",
        stacklevel=4)
