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
Lengths in the fin system's ``unit``. Where a tab may go: :mod:`.tab_sites`; the local check:
:mod:`.tab_check`.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from torsal.core.units import UNIT_TO_MM

from ..model import Joint, JointKind, Part
from .fasteners import fastener_for, tab_bolts
from .seams import JointFallback
from .tab_check import TabRegion, _Verdict
from .tab_sites import TabReason, TabSites, _Proposal, with_tabs

__all__ = ["TabReason", "TabJoint", "TabJoints", "with_tabs", "tab_report"]


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


class TabJoints:
    """Turns the brackets of a finished fin system ``fs`` into tabs where the assembly check
    proves them (rules in the module text): fills ``fs.tab_joints``, appends the brackets kept
    to ``fs.joint_fallbacks``, and changes ``fs.parts`` (tabbed parts, brackets gone),
    ``fs.joints`` (the brackets' joints become :attr:`~.model.JointKind.BUTT_TAB`) and what
    names a panel of a part that got a tab at its start (connector and fixing sites). Where
    a tab may go: :class:`~.tab_sites.TabSites`; the check around it:
    :class:`~.tab_check.TabRegion`."""

    def __init__(self, fs):
        self.fs = fs
        self.sites = TabSites(fs)
        self.region = TabRegion(fs)

    def make(self) -> None:
        """Tabs for the brackets the check proves (rules in the module text)."""
        fs = self.fs
        fs.tab_joints, fs.spare_brackets = [], []
        if not fs.joints or not getattr(fs, "tabs", True):
            return
        ends, brackets, refused = self.sites.ends()
        by_name = {p.name: p for p in fs.parts}
        ends = self._bolted(ends, by_name, refused)
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
            if not self.sites.fits(by_name[name], {True: other.geometry, False: pr.geometry}):
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

    def _bolted(self, ends: dict, by_name: dict, refused: list) -> dict:
        """``ends`` without the places where no bolt of the tab would pass through the plate
        (:func:`~.fasteners.tab_bolts`); an end left with none keeps its bracket
        (:attr:`TabReason.BOLT`)."""
        fs = self.fs
        bolt = fastener_for(fs.thickness * UNIT_TO_MM[fs.unit])
        out = {}
        for key, alts in sorted(ends.items()):
            ok = [pr for pr in alts if pr.host in by_name and tab_bolts(
                pr.geometry.tab, pr.start, by_name[pr.host], pr.host_panel, bolt,
                thickness=fs.thickness, unit=fs.unit)]
            if ok:
                out[key] = ok
            elif alts:
                self._refuse(alts[0], _Verdict(False, TabReason.BOLT, "no bolt hole of the tab "
                                               f"falls on {alts[0].host}"), refused)
        return out

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
            asks.append(self.region.local(list(groups[key]), tabbed, joints, {pr.bracket for pr in prs}))
        return dict(zip(keys, self.region.verdicts(asks)))

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
