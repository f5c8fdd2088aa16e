"""Tabs instead of brackets: butt joints that need no separate part (issue 42).

Where a part end is butted against a plate and fastened with a bracket
(:meth:`~.connectors.ConnectorPlacer._bracket`: T and L junctions, crossings where a strip is
split, splits at sharp folds), the end itself can be bent into a **tab** that lies where the
bracket's leg on that plate lay and is bolted to the plate: the joint then needs no part of its
own (:attr:`~torsal.fabrication.model.JointKind.BUTT_TAB`, geometry in
:func:`~torsal.fabrication.joints.tab_panel`). The tab is an extra panel of the butted part, at
the start or end of its chain of panels (structure edge and free node line -1; the bend line
keeps the node): its solid (STEP), flat pattern (DXF: the tab is part of the outline, its bend
line a fold line and one bend more in the bill of quantities), its holes (its own, their bolts
counted on its parts-list row; :mod:`.fasteners`) and its parts-list row are the part's.

Whether a bracket becomes a tab is decided *per joint*, once the rest of the design is settled
(the rebuilds of :class:`~.rebuild.Rebuilder` are done and every path is clear):

1. The tab goes where the bracket's leg on the plate lay (the corner and the stretch along
   the node line the bracket found room for), else in another corner the bracket's site
   allows. None can be bent (:attr:`TabReason.GEOMETRY`) where the end's edges run nearly
   along the plate, the tab would lie more than the clearance off the plate (the end is
   trimmed back past the bend to clear another part's end, or the plate folds at the node
   towards the butted part so that its other panel reaches the bend's corners), the panel is
   too short or the tab is no convex quad; nor where the part with its tabs would no longer
   fit the sheet or ``max_part_length`` (:attr:`TabReason.SHEET`).
2. The assembly check (:func:`~torsal.fabrication.assembly.check_assembly`, the independent
   one) on the solids around the node (:meth:`TabJoints._local`: the tabbed parts' panels
   next to it with their tabs, the plates they lie on, and the panels of every part,
   connector and fixing near the tabs or the tabbed ends' paths into place, with their joint
   records), at a tenth of its least interference volume (:data:`LOCAL_VOLUME_SHARE`): none
   may interfere and every one must go in (:attr:`TabReason.ASSEMBLY`; a solid that cannot be
   built: :attr:`TabReason.SOLID`). The tabs of a node are checked together, with the
   brackets of the other nodes as they are; where the check refuses several, each on its own,
   then those it proves together. An end whose tab is refused tries its next place.

An end bends into one tab: where it had brackets in both corners (a bridge across the other
family's seam at a node where both families are split) the other stays
(:attr:`TabReason.SECOND_CORNER`), unless the parts it joins are joined at the node without it
(through the other tabs and brackets there): then it is taken away (``spare_brackets``).

A refused tab leaves its bracket (the joint as before), named in ``FinSystem.joint_fallbacks``
(a :class:`~.seams.JointFallback` whose reason is a :class:`TabReason`); the tabs made are
``FinSystem.tab_joints`` (:class:`TabJoint`). ``FinSystem(tabs=False)`` keeps every bracket.
Lengths in the fin system's ``unit``.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from enum import Enum

import numpy as np

from torsal.core.units import UNIT_TO_MM

from ..joints import TabGeometry, _Untrimmable, place_connector, tab_panel
from ..model import (CONNECTOR_FAMILY, FIXING_FAMILY, Joint, JointKind, Part, _miter,
                     _oriented_size, quad_normals)
from ..unroll import unroll
from .connectors import CONNECTOR_GAP, _starts_on
from .proximity import _swept_and_still_distances
from .seams import JointFallback

__all__ = ["TabReason", "TabJoint", "TabJoints", "with_tabs", "tab_report"]


#: the gap between a tab's face and the face of the plate it lies on, as a share of the
#: clearance: half of it, as the butted end it replaces kept (the part may slide in along a
#: direction that closes that end's gap by as much over the joint's depth, so the tab's too)
TAB_GAP = 0.5


#: how much farther off the plate (a share of the clearance) a tab may lie where the butted
#: end is trimmed back past its bend already (clear of another part's end there): the tab's
#: face then stands up to the clearance off the plate's, which its bolts close
TAB_RISE = 0.5


#: mm more than ``FinSystem.fit_margin`` a tabbed part keeps off the sheet's edges when it is
#: checked against ``fit_sheet`` (the nester keeps the margin and the kerf, up to 1 mm for a
#: waterjet): a part cut to fit the sheet does not outgrow it by a tab's length
TAB_FIT_ALLOWANCE_MM = 1.0


#: the local check proves a tab with this share of the assembly check's least interference
#: volume (1 mm^3): a tab whose path grazes a plate by less than that locally may graze it by
#: more once the part is seen whole, with a tab at each end (example 9: five parts with two
#: tabs blocked by 1.0-2.4 mm^3 in the whole design, each tab proved on its own)
LOCAL_VOLUME_SHARE = 0.1


class TabReason(str, Enum):
    """Why a bracket stayed (no tab bent from the butted end there)."""

    #: no tab can be bent there (the end's edges nearly along the plate, the tab more than the
    #: clearance off it, the panel too short, the tab no convex quad beyond its bend)
    GEOMETRY = "tab-geometry"
    #: the end bends into a tab in its other corner; this bracket joins parts the others at
    #: the node do not (it bridges the other family's seam: an end makes one tab)
    SECOND_CORNER = "tab-second-corner"
    #: the part with its tab (or tabs) laid flat does not fit the sheet (``fit_sheet``)
    SHEET = "tab-sheet"
    #: the assembly check on the solids around the node found them interfering or blocked
    ASSEMBLY = "tab-assembly"
    #: a solid around the node could not be built, so nothing proves the tab
    SOLID = "tab-solid"


@dataclass(frozen=True)
class TabJoint:
    """A butt joint made with a tab bent from the butted part: ``part``'s ``start`` (else end)
    at ``node`` lies on panel ``host_panel`` of ``host``, in place of the bracket
    ``bracket``."""

    node: int
    part: str
    host: str
    host_panel: int
    start: bool
    bracket: str

    def panel(self, part: Part) -> int:
        """Index of the tab among the panels of ``part`` (the tabbed part)."""
        return 0 if self.start else len(part.panels) - 1


@dataclass(frozen=True)
class _Proposal:
    """A tab that may replace the bracket of joint ``joint`` (an index of ``fs.joints``)."""

    joint: int
    bracket: str
    part: str
    start: bool
    host: str
    host_panel: int
    node: int
    geometry: TabGeometry
    #: 0: in the corner of the bracket it replaces; 1: in another corner of its site
    corner: int = 0

    @property
    def key(self) -> tuple[str, bool]:
        return self.part, self.start


def with_tabs(part: Part, tabs: dict) -> Part:
    """A copy of ``part`` with a tab bent from its start and / or end: ``tabs`` is ``{start
    (bool): TabGeometry}``. The end panel's end corners move onto the bend line, the tab becomes
    a panel before (start) or after (end) the others with the fold's mitre between them and a
    square end cap; its free edge's node line and its structure edge are -1 (the bend line
    keeps the end's node), and the slots' node lines move by one where a tab goes first."""
    panels, miters = part.panels.copy(), part.miters.copy()
    nodes, edges, slots = np.asarray(part.nodes).copy(), np.asarray(part.edges).copy(), list(part.slots)
    for start in sorted(tabs, reverse=True):           # the end first: indices stay put
        g = tabs[start]
        j = 0 if start else len(panels) - 1
        for cc, x in g.moved.items():
            panels[j, cc] = x
        n_end, n_tab = quad_normals(np.array([panels[j], g.tab]))
        if start:
            panels = np.concatenate([g.tab[None], panels])
            miters = np.concatenate([n_tab[None], _miter(n_tab, n_end)[None], miters[1:]])
            nodes, edges = np.r_[-1, nodes], np.r_[-1, edges]
            slots = [dataclasses.replace(s, position=s.position + 1) for s in slots]
        else:
            panels = np.concatenate([panels, g.tab[None]])
            miters = np.concatenate([miters[:-1], _miter(n_end, n_tab)[None], n_tab[None]])
            nodes, edges = np.r_[nodes, -1], np.r_[edges, -1]
    return dataclasses.replace(part, panels=panels, miters=miters, nodes=nodes.astype(int),
                               edges=edges.astype(int), slots=slots)


def _local(part: Part, lo: int, hi: int) -> Part:
    """Panels ``lo..hi-1`` of ``part`` with their slots, under the same name (holes left out)."""
    slots = [dataclasses.replace(s, position=s.position - lo) for s in part.slots
             if lo <= s.position <= hi]
    return dataclasses.replace(part, panels=part.panels[lo:hi].copy(),
                               nodes=np.asarray(part.nodes)[lo:hi + 1].copy(),
                               edges=np.asarray(part.edges)[lo:hi].copy(),
                               miters=part.miters[lo:hi + 1].copy(), slots=slots, holes=())


@dataclass(frozen=True)
class _Verdict:
    """The local assembly check of the tabs at one node: ``ok`` or refused (``detail``)."""

    ok: bool
    reason: TabReason | None = None
    detail: str = ""
    parts: tuple = ()


def _local_check(ask: tuple) -> _Verdict:
    """:func:`~torsal.fabrication.assembly.check_assembly` of the local parts with their joint
    records (``(parts, joints, thickness, unit)``), in this process (one argument: a task for
    a worker process)."""
    from ..assembly import MIN_INTERFERENCE_VOLUME, check_assembly
    from ..plates import InvalidSolidError, part_solid

    parts, joints, thickness, unit = ask
    try:
        solids = {p.name: part_solid(p, thickness) for p in parts}
    except InvalidSolidError as e:
        return _Verdict(False, TabReason.SOLID, f"{e}")
    names = set(solids)
    local = []
    for j in joints:
        keep = tuple(n for n in j.parts if n in names)
        if keep:
            local.append(dataclasses.replace(
                j, parts=keep, connector=j.connector if j.connector in names else None))
    r = check_assembly(solids, joints=local, workers=1, unit=unit,
                       min_volume=LOCAL_VOLUME_SHARE * MIN_INTERFERENCE_VOLUME / UNIT_TO_MM[unit] ** 3)
    if r.buildable:
        return _Verdict(True)
    bad = tuple(sorted(set(r.interfering_parts) | {s.part for s in r.blocked}))
    return _Verdict(False, TabReason.ASSEMBLY, r.problems(limit=3).replace("\n", "; "), bad)


class TabJoints:
    """Turns the brackets of a finished fin system ``fs`` into tabs where the assembly check
    proves them (rules in the module text): fills ``fs.tab_joints``, appends the brackets kept
    to ``fs.joint_fallbacks``, and changes ``fs.parts`` (tabbed parts, brackets gone),
    ``fs.joints`` (the brackets' joints become :attr:`~.model.JointKind.BUTT_TAB`) and what
    names a panel of a part that got a tab at its start (connector and fixing sites)."""

    #: how far (multiples of the thickness) around a tab and its end the local check looks
    REACH = 2.0

    def __init__(self, fs):
        self.fs = fs

    # ------------------------------------------------------------------ proposals
    def _ends(self) -> tuple[dict, dict, list[JointFallback]]:
        """The tabs each bracketed end may bend into, in the order they are tried:
        ``({(part, start): [_Proposal]}, {(part, start): [bracket names]}, fallbacks)``. First
        the corner of each of its brackets (by name), then the other corners the first
        bracket's site allows (:meth:`~.connectors.ConnectorPlacer._bracket`; the tab there,
        its free edge that of the largest bracket that fits); those that cannot be bent
        (:func:`~.joints.tab_panel`) are named with why."""
        fs = self.fs
        by_name = {p.name: p for p in fs.parts}
        ends: dict[tuple[str, bool], list[_Proposal]] = {}
        brackets: dict[tuple[str, bool], list[str]] = {}
        why: dict[tuple[str, bool], list] = {}
        order = sorted((j.connector, k) for k, j in enumerate(fs.joints)
                       if j.kind == JointKind.BUTT_BRACKET and j.connector and j.connector in by_name)
        for conn, k in order:
            j = fs.joints[k]
            site = fs._sites.get(conn)
            if site is None:
                continue
            a, b, options = site
            (host, hj), (name, pj) = options[0][6]
            p, h = by_name.get(name), by_name.get(host)
            if p is None or h is None or p.family not in (0, 1):
                continue
            start = _starts_on(p.panels[pj], a, b)
            if (pj != 0 and start) or (pj != len(p.panels) - 1 and not start):
                continue
            key = (name, start)
            first = key not in brackets
            brackets.setdefault(key, []).append(conn)
            c = by_name[conn]
            places = [(options[0], np.array([c.panels[0, 0], c.panels[0, 3]]), 0)]
            if first:
                places += [(opt, None, 1) for opt in options[1:]]
            for opt, free, corner in places:
                pr = self._proposal(k, conn, key, j.node, opt, free, corner, a, b, by_name)
                if isinstance(pr, _Proposal):
                    ends.setdefault(key, []).append(pr)
                elif pr is not None:
                    why.setdefault(key, []).append((j.node, p.family, pr, tuple(
                        n for n in j.parts if n != conn)))
        # the corners of an end's brackets first, then the other corners of its site (those
        # of another of its brackets once)
        for key, prs in ends.items():
            own = {(pr.host, pr.host_panel) for pr in prs if pr.corner == 0}
            ends[key] = sorted((pr for pr in prs if pr.corner == 0
                                or (pr.host, pr.host_panel) not in own),
                               key=lambda pr: (pr.corner, pr.bracket))
        refused = [JointFallback(node, fam, reason, detail, parts)
                   for key, ws in why.items() if key not in ends
                   for node, fam, (reason, detail), parts in ws[:1]]
        return ends, brackets, refused

    def _proposal(self, k: int, conn: str, key: tuple, node: int, opt, free, corner: int, a, b,
                  by_name):
        """The :class:`_Proposal` of a tab in the corner ``opt`` of a bracket's site (with the
        free edge ``free`` (2, 3), else that of the largest bracket there; ``corner`` 0: the
        bracket's own, 1: another), or ``(reason, detail)`` of why there is none (None: no
        bracket fits that corner either)."""
        fs = self.fs
        (host, hj), (name, pj) = opt[6]
        p, h = by_name.get(name), by_name.get(host)
        if p is None or h is None or h.family not in (0, 1):
            return None
        if free is None:
            plates = tuple(by_name[n].slab_corners(i, fs.thickness) for n, i in opt[6])
            q = self._kernel(place_connector, a, b, *opt[:4], thickness=fs.thickness,
                             gap=CONNECTOR_GAP * fs.thickness, plates=plates)
            if q is None:
                return None
            free = np.array([q[0, 0], q[0, 3]])
        # the other panels of the plate at the node (where it folds, or its other part)
        others = np.array([q.panels[i] for q, i in self._panels_at(node)
                           if q.family == h.family and (q.name, i) != (host, hj)]).reshape(-1, 4, 3)
        try:
            g = self._kernel(tab_panel, p.panels[pj], key[1], h.panels[hj], opt[0][0], free,
                             thickness=fs.thickness, gap=TAB_GAP * fs.clearance,
                             rise=TAB_RISE * fs.clearance, others=others)
        except _Untrimmable as e:
            return TabReason.GEOMETRY, f"no tab from {name} onto {host}: {e}"
        if not self._fits(p, {key[1]: g}):
            return TabReason.SHEET, f"{name} with a tab onto {host} does not fit the sheet"
        return _Proposal(k, conn, name, key[1], host, hj, node, g, corner)

    def _panels_at(self, node: int) -> list[tuple[Part, int]]:
        """``[(plate, panel)]``: the fin panels with a node line at ``node``."""
        at = self.__dict__.get("_at")
        if at is None:
            at = self._at = {}
            for q in sorted(self.fs.parts, key=lambda q: q.name):
                if q.family not in (0, 1):
                    continue
                k = len(q.panels)
                for line, v in enumerate(np.asarray(q.nodes).tolist()):
                    for i in (line - 1, line):
                        if v >= 0 and 0 <= i < k:
                            at.setdefault(v, []).append((q, i))
        return at.get(node, [])

    def _fits(self, part: Part, tabs: dict) -> bool:
        """Whether ``part`` with the ``tabs`` (``{start: TabGeometry}``) is no longer than
        ``max_part_length`` along its ``a`` and ``b`` edges and, laid flat, fits ``fit_sheet``
        with the margin and :data:`TAB_FIT_ALLOWANCE_MM` all round. Laid flat, a tab lies
        within its length of its bend, an edge of the part without it: where the part without
        tabs fits with that much more all round, so does the part with them (the exact flat
        outline is looked at only for a part near the sheet's size)."""
        fs = self.fs
        q = with_tabs(part, tabs).panels
        if fs.max_part_length is not None and max(
                np.linalg.norm(q[:, 1] - q[:, 0], axis=1).sum(),
                np.linalg.norm(q[:, 2] - q[:, 3], axis=1).sum()) > fs.max_part_length:
            return False
        if fs.fit_sheet is None:
            return True
        sw, sh = sorted(fs.fit_sheet, reverse=True)
        m = 2.0 * (fs.fit_margin + TAB_FIT_ALLOWANCE_MM / UNIT_TO_MM[fs.unit])
        size = self.__dict__.setdefault("_sizes", {})
        if part.name not in size:
            size[part.name] = _flat_size(part.panels)
        w, h = size[part.name]
        r = 2.0 * max(_reach(g) for g in tabs.values())
        if w + r <= sw - m and h + r <= sh - m:
            return True
        w, h = _flat_size(q)
        return w <= sw - m and h <= sh - m

    def _kernel(self, fn, *args, **kw):
        """``fn(*args, **kw)``, remembered across the rebuilds' memo while there is one."""
        fs = self.fs
        return fs._cached(fn, *args, **kw) if "_memo" in fs.__dict__ else fn(*args, **kw)

    # ------------------------------------------------------------------ the local check
    def _stack(self) -> tuple:
        """``(parts by name, quads (N, 4, 3), owner part (N,), panel (N,), lo (N, 3), hi (N, 3),
        names, {name: index})``: every panel of the fin system's parts, once per
        :meth:`make`."""
        st = self.__dict__.get("_stacked")
        if st is None:
            parts = sorted(self.fs.parts, key=lambda q: q.name)
            quads = np.concatenate([q.panels for q in parts])
            owner = np.repeat(np.arange(len(parts)), [len(q.panels) for q in parts])
            panel = np.concatenate([np.arange(len(q.panels)) for q in parts])
            names = [q.name for q in parts]
            st = self._stacked = (parts, quads, owner, panel, quads.min(axis=1), quads.max(axis=1),
                                  names, {n: i for i, n in enumerate(names)})
        return st

    def _local(self, props: list[_Proposal], tabbed: dict[str, Part], joints: list[Joint],
               gone: set) -> tuple:
        """``(parts, joints, thickness, unit)`` of the local assembly check of the tabs
        ``props`` (of one node): what changed there (each tab, and the end it is bent from
        :attr:`REACH` thicknesses into its end panel), swept along the tabbed part's way into
        place both ways over its joint's depth (the parts that go in after it must keep clear
        of the tab too); of every part (plate, connector, fixing; not the brackets ``gone``,
        which tabs replace; the tabbed parts with their tabs) the panels whose mid-surfaces
        come within :attr:`REACH` thicknesses of that region, with their slots; and the joint
        records."""
        fs = self.fs
        t = fs.thickness
        reach = self.REACH * t
        region, sweeps = [], []
        for pr in props:
            p = tabbed[pr.part]
            k = len(p.panels)
            tab = p.panels[0 if pr.start else k - 1]
            end = p.panels[1 if pr.start else k - 2]
            (b0, f0), (b1, f1) = ((0, 1), (3, 2)) if pr.start else ((1, 0), (2, 3))
            into = [end[b] + min(1.0, reach / max(float(np.linalg.norm(end[f] - end[b])), 1e-12))
                    * (end[f] - end[b]) for b, f in ((b0, f0), (b1, f1))]
            strip = np.array([end[b0], into[0], into[1], end[b1]])
            j = fs.joints[pr.joint]
            d = np.asarray(j.insert_direction, float)
            travel = (float(j.depth) if j.depth is not None else 0.0) + 2 * t
            region.append(np.array([tab, strip]))
            sweeps.append(travel * d)
        parts, quads, owner, panel, qlo, qhi, names, index = self._stack()
        # (the region each sweeps, both ways, grown by the reach: the boxes first)
        pts = np.concatenate([np.concatenate([r.reshape(-1, 3) - v, r.reshape(-1, 3) + v])
                              for r, v in zip(region, sweeps)])
        lo, hi = pts.min(axis=0) - reach, pts.max(axis=0) + reach
        skip = np.zeros(len(parts), bool)
        skip[[index[n] for n in set(gone) | set(tabbed) if n in index]] = True
        cand = np.flatnonzero(((qlo <= hi) & (qhi >= lo)).all(axis=1) & ~skip[owner])
        near_of: dict[int, set] = {}

        def near(others: np.ndarray) -> np.ndarray:
            out = np.zeros(len(others), bool)
            for r, v in zip(region, sweeps):
                # boxes in a frame along the sweep first (the region is thin across it), then
                # the mid-surfaces' distances
                frame = _frame(v)
                o = others @ frame.T                                 # (m, 4, 3)
                rr = r.reshape(-1, 3) @ frame.T
                rlo, rhi = rr.min(axis=0) - reach, rr.max(axis=0) + reach
                rlo[2] -= np.linalg.norm(v)
                rhi[2] += np.linalg.norm(v)
                box = np.flatnonzero(((o.min(axis=1) <= rhi) & (o.max(axis=1) >= rlo)).all(axis=1))
                if len(box):
                    dist = _swept_and_still_distances(r - v, 2.0 * v, others[box], within=reach)[0]
                    out[box[(dist < reach).any(axis=0)]] = True
            return out

        for i in cand[near(quads[cand])]:
            near_of.setdefault(int(owner[i]), set()).add(int(panel[i]))
        for name, q in tabbed.items():
            hit = np.flatnonzero(near(q.panels))
            if len(hit):
                near_of.setdefault(index[name], set()).update(hit.tolist())
        out = []
        for k in sorted(near_of):
            idx = near_of[k]
            q = tabbed.get(names[k], parts[k])
            out.append(q if q.family in (CONNECTOR_FAMILY, FIXING_FAMILY)
                       else _local(q, min(idx), max(idx) + 1))
        names = {q.name for q in out}
        # a slot whose partner plate is not among the local parts holds nothing there: the
        # notch is not cut (the exact cut is the dearest part of a local solid)
        out = [q if all(any(n in names for n in s.partner.split("+")) for s in q.slots)
               else dataclasses.replace(q, slots=[s for s in q.slots if any(
                   n in names for n in s.partner.split("+"))]) for q in out]
        local = [joints[k] for k in sorted({k for n in names for k in self._joints_of(n)})]
        return out, local, t, fs.unit

    def _joints_of(self, name: str) -> list[int]:
        """Indices of the joints (``fs.joints``, in order) that name the part ``name``."""
        of = self.__dict__.get("_of")
        if of is None:
            of = self._of = {}
            for k, j in enumerate(self.fs.joints):
                for n in j.parts:
                    of.setdefault(n, []).append(k)
        return of.get(name, [])

    def _verdicts(self, asks: list[tuple]) -> list[_Verdict]:
        from ..workers import map_prepared

        return map_prepared(_local_check, asks)

    # ------------------------------------------------------------------ making them
    def make(self) -> None:
        """Tabs for the brackets the check proves (rules in the module text)."""
        fs = self.fs
        fs.tab_joints, fs.spare_brackets = [], []
        if not fs.joints or not getattr(fs, "tabs", True):
            return
        ends, brackets, refused = self._ends()
        by_name = {p.name: p for p in fs.parts}
        kept: dict[tuple[str, bool], _Proposal] = {}
        tried: dict[tuple[str, bool], list] = {}
        # each end's first place, then the next for the ends whose check refused it
        for turn in range(max((len(v) for v in ends.values()), default=0)):
            new = [alts[turn] for key, alts in sorted(ends.items())
                   if key not in kept and turn < len(alts)]
            if not new:
                break
            for pr, vd in self._settle(new, kept, by_name):
                if vd.ok:
                    kept[pr.key] = pr
                else:
                    tried.setdefault(pr.key, []).append((pr, vd))
        for key, alts in sorted(tried.items()):
            if key not in kept:
                pr, vd = alts[0]
                self._refuse(pr, vd, refused)
        # a part with a tab at both ends must fit the sheet with both (each fits alone)
        for (name, start), pr in sorted(kept.items()):
            other = kept.get((name, not start))
            if start or other is None:
                continue
            if not self._fits(by_name[name], {True: other.geometry, False: pr.geometry}):
                del kept[(name, False)]
                self._refuse(pr, _Verdict(False, TabReason.SHEET, f"{name} with tabs at both ends "
                                          "does not fit the sheet"), refused)
        # an end bends into one tab: its other brackets stay, unless the parts they join are
        # joined at the node without them (through the tabs and brackets of the others)
        second = [(pr, conn) for key, names in sorted(brackets.items())
                  for pr in [kept.get(key)] if pr is not None
                  for conn in names if conn != pr.bracket]
        spare = self._spare([conn for _, conn in second], kept)
        for pr, conn in second:
            if conn not in spare:
                refused.append(self._second(pr, conn))
        self._apply(kept, by_name, spare)
        fs.joint_fallbacks = list(fs.joint_fallbacks) + sorted(
            refused, key=lambda f: (f.node, f.family, f.detail))

    def _spare(self, candidates: list[str], kept: dict) -> dict[str, str]:
        """``{bracket: why}``: of the brackets ``candidates`` (left at ends bent into a tab in
        their other corner), those whose two parts (the plate under each leg) are joined at
        the node without them, through the other joints there (egg-crates, the tabs
        ``kept``, brackets, splice plates), taken away one after the other: a bracket
        bridging the other family's seam at a node where both families are split is needed
        once, not by both halves of the strip butted there."""
        fs = self.fs
        tab_of = {pr.bracket: pr for pr in kept.values()}
        edges: dict[int, dict[str, tuple]] = {}        # node -> {joint id: (part, part)}
        for k, j in enumerate(fs.joints):
            if j.kind in (JointKind.EGG_CRATE, JointKind.MITRE_SPLICE):
                ps = [n for n in j.parts if n != j.connector]
                pairs = [(ps[0], q) for q in ps[1:]]
            elif j.connector in tab_of:
                pr = tab_of[j.connector]
                pairs = [(pr.host, pr.part)]
            elif j.connector and j.connector in fs._sites:
                (h, _), (q, _) = fs._sites[j.connector][2][0][6]
                pairs = [(h, q)]
            else:
                continue
            for i, pq in enumerate(pairs):
                edges.setdefault(j.node, {})[f"{k}:{i}" if j.connector is None else
                                             f"{j.connector}:{i}"] = pq
        out = {}
        for conn in sorted(candidates):
            j = next(j for j in fs.joints if j.connector == conn)
            here = edges.get(j.node, {})
            mine = here.get(f"{conn}:0")
            if mine is None:
                continue
            rest = [pq for key, pq in here.items() if not key.startswith(f"{conn}:")]
            if _joined(mine[0], mine[1], rest):
                out[conn] = (f"{mine[1]} and {mine[0]} are joined at node {j.node} without it")
                del here[f"{conn}:0"]
        return out

    def _second(self, pr: _Proposal, conn: str) -> JointFallback:
        """The fallback of bracket ``conn`` that stays at an end bent into the tab ``pr``."""
        j = next(j for j in self.fs.joints if j.connector == conn)
        return JointFallback(j.node, int(pr.part[1]), TabReason.SECOND_CORNER,
                             f"{pr.part} bends into a tab onto {pr.host} in its other corner "
                             f"({pr.bracket} replaced): {conn} stays",
                             tuple(n for n in j.parts if n != conn))

    def _settle(self, new: list[_Proposal], kept: dict, by_name: dict) -> list[tuple]:
        """``[(proposal, _Verdict)]`` of the tabs ``new`` (at most one per end), each node's
        checked together with the tabs ``kept`` there already (the brackets of the other
        nodes as they are: tabs of two nodes lie a node's spacing apart); where the check
        refuses several new tabs of a node together, each is checked on its own, then those
        it proves together (else the first of them)."""
        by_node: dict[int, list[_Proposal]] = {}
        for pr in new:
            by_node.setdefault(pr.node, []).append(pr)
        there: dict[int, list[_Proposal]] = {}
        for pr in kept.values():
            there.setdefault(pr.node, []).append(pr)
        ctx = {v: tuple(there.get(v, ())) for v in by_node}
        first = self._check({v: tuple(prs) for v, prs in by_node.items()}, ctx, by_name)
        out, alone = [], {}
        for v in sorted(by_node):
            prs = by_node[v]
            if first[v].ok or len(prs) == 1:
                out += [(pr, first[v]) for pr in prs]
            else:
                alone.update(((v, i), (pr,)) for i, pr in enumerate(prs))
        single = self._check(alone, {key: ctx[key[0]] for key in alone}, by_name)
        together = {}
        for v in sorted({v for v, _ in alone}):
            ok = [pr for i, pr in enumerate(by_node[v]) if single[(v, i)].ok]
            out += [(pr, single[(v, i)]) for i, pr in enumerate(by_node[v]) if not single[(v, i)].ok]
            if len(ok) > 1:
                together[v] = tuple(ok)
            else:
                out += [(pr, _Verdict(True)) for pr in ok]
        both = self._check(together, {v: ctx[v] for v in together}, by_name)
        for v, prs in sorted(together.items()):
            use = prs if both[v].ok else prs[:1]
            out += [(pr, _Verdict(True)) for pr in use]
            out += [(pr, both[v]) for pr in prs[len(use):]]
        return out

    def _check(self, groups: dict, context: dict, by_name: dict) -> dict:
        """``{key: _Verdict}``: the local check of each group of tabs (``{key: proposals}``)
        with the tabs ``context[key]`` (proved before, at the same node)."""
        keys = sorted(groups, key=str)
        asks = []
        for key in keys:
            prs = groups[key] + tuple(context.get(key, ()))
            sub = {pr.key: pr for pr in prs}
            tabbed, joints = self._design(sub, by_name)
            asks.append(self._local(list(groups[key]), tabbed, joints, {pr.bracket for pr in prs}))
        return dict(zip(keys, self._verdicts(asks)))

    def _refuse(self, pr: _Proposal, vd: _Verdict, refused: list) -> None:
        refused.append(JointFallback(pr.node, int(pr.part[1]), vd.reason or TabReason.ASSEMBLY,
                                     f"{pr.bracket} stays: {vd.detail}",
                                     tuple(n for n in self.fs.joints[pr.joint].parts
                                           if n != pr.bracket)))

    def _design(self, kept: dict, by_name: dict) -> tuple[dict[str, Part], list[Joint]]:
        """The tabbed parts (``{name: Part}``) and the joint records with the tabs ``kept``."""
        fs = self.fs
        per_part: dict[str, dict] = {}
        for (name, start), pr in kept.items():
            per_part.setdefault(name, {})[start] = pr.geometry
        tabbed = {name: with_tabs(by_name[name], tabs) for name, tabs in per_part.items()}
        gone = {pr.joint: pr for pr in kept.values()}
        joints = []
        for k, j in enumerate(fs.joints):
            pr = gone.get(k)
            if pr is not None:
                j = dataclasses.replace(j, kind=JointKind.BUTT_TAB,
                                        parts=tuple(n for n in j.parts if n != pr.bracket),
                                        connector=None, connector_direction=None)
            joints.append(j)
        return tabbed, joints

    def _apply(self, kept: dict, by_name: dict, spare: dict) -> None:
        """The tabs ``kept`` made and the brackets ``spare`` taken away: parts, joints,
        connector and fixing sites, ``tab_joints``, ``spare_brackets``."""
        fs = self.fs
        tabbed, joints = self._design(kept, by_name)
        gone = {pr.bracket for pr in kept.values()}
        fs.spare_brackets = [(j.node, j.connector, tuple(n for n in j.parts if n != j.connector),
                              spare[j.connector]) for j in joints if j.connector in spare]
        gone |= set(spare)
        joints = [j for j in joints if j.connector not in spare]
        fs.parts = [tabbed.get(p.name, p) for p in fs.parts if p.name not in gone]
        fs._connectors = [c for c in fs._connectors if c.name not in gone]
        fs.joints = joints
        for name in gone:
            fs._sites.pop(name, None)
        # a tab before a part's first panel moves the indices of its panels by one
        first = {pr.part for pr in kept.values() if pr.start}
        for conn, (a, b, options) in list(fs._sites.items()):
            fs._sites[conn] = (a, b, [opt[:6] + (tuple((n, j + (n in first)) for n, j in opt[6]),)
                                      for opt in options])
        for fx, (plate, j) in list(fs._fixing_sites.items()):
            fs._fixing_sites[fx] = (plate, j + (plate in first))
        fs.tab_joints = sorted((TabJoint(pr.node, pr.part, pr.host,
                                         pr.host_panel + (pr.host in first), pr.start, pr.bracket)
                                for pr in kept.values()), key=lambda x: (x.node, x.part, x.start))


def _flat_size(quads: np.ndarray) -> tuple[float, float]:
    """(long, short) sides of the least rectangle round the panels ``quads`` laid flat (inf:
    they overlap themselves laid flat)."""
    try:
        return _oriented_size(unroll(quads, slots=[]).outline)
    except ValueError:
        return np.inf, np.inf


def _reach(g: TabGeometry) -> float:
    """How far the tab ``g`` reaches from its bend line (the segment its end panel ends on)."""
    ba, bb = (np.asarray(x, float) for x in g.moved.values())
    e = bb - ba
    ee = float(e @ e)
    out = 0.0
    for x in g.tab:
        s_ = min(1.0, max(0.0, float((x - ba) @ e) / ee)) if ee > 0 else 0.0
        out = max(out, float(np.linalg.norm(x - (ba + s_ * e))))
    return out


def _frame(v: np.ndarray) -> np.ndarray:
    """(3, 3) rows: two unit vectors square to ``v`` (3,) and ``v``'s unit direction."""
    d = v / np.linalg.norm(v)
    e1 = np.cross(d, np.eye(3)[int(np.argmin(np.abs(d)))])
    e1 /= np.linalg.norm(e1)
    return np.array([e1, np.cross(d, e1), d])


def _joined(a: str, b: str, pairs: list[tuple]) -> bool:
    """Whether the parts ``a`` and ``b`` are joined through the ``pairs`` of joined parts."""
    reach, todo = {a}, [a]
    while todo:
        x = todo.pop()
        for p, q in pairs:
            for u, w in ((p, q), (q, p)):
                if u == x and w not in reach:
                    reach.add(w)
                    todo.append(w)
    return b in reach


def tab_report(fs) -> dict:
    """The tabs of a finished fin system for its report: ``tabs`` (butt joints made with a tab,
    no bracket), ``fallbacks`` (brackets that stayed, by :class:`TabReason`; each named in
    ``joint_fallbacks``) and ``spare_brackets`` (taken away where the parts they joined are
    joined at the node without them).

    >>> tab_report(fs)["tabs"]                                    # doctest: +SKIP
    167
    """
    falls: dict[str, int] = {}
    for f in getattr(fs, "joint_fallbacks", []):
        if isinstance(f.reason, TabReason):
            falls[f.reason.value] = falls.get(f.reason.value, 0) + 1
    return {"tabs": len(getattr(fs, "tab_joints", [])), "fallbacks": dict(sorted(falls.items())),
            "spare_brackets": len(getattr(fs, "spare_brackets", []))}
