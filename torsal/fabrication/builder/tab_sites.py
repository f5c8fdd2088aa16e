"""Where a tab may replace a bracket (:mod:`.tabs`): for each bracketed part end, the tabs it
may bend into, in the order they are tried (:class:`TabSites`), and the part with its tabs
(:func:`with_tabs`). The corner of each of the end's brackets comes first, then the other
corners the first bracket's site allows; a corner where no tab can be bent
(:func:`~torsal.fabrication.joints.tab_panel`) or where the part with it would not fit the sheet
is named with why (:class:`TabReason`). Lengths in the fin system's ``unit``.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from enum import Enum

import numpy as np

from torsal.core.units import UNIT_TO_MM

from ..joints import TabGeometry, _Untrimmable, place_connector, tab_panel
from ..model import JointKind, Part, _miter, _oriented_size, quad_normals
from ..unroll import flat_outline
from .connectors import CONNECTOR_GAP, _starts_on
from .seams import JointFallback

__all__ = ["TabReason", "TabSites", "with_tabs", "TAB_GAP", "TAB_RISE", "TAB_FIT_ALLOWANCE_MM"]


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
    #: no bolt hole of the tab falls on the plate's panel (the tab is too short for one, or
    #: its holes would lie off the panel): a tab without a bolt holds nothing
    BOLT = "tab-bolt"


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


class TabSites:
    """The tabs the bracketed ends of a finished fin system ``fs`` may bend into (rules in
    :mod:`.tabs`' module text), and whether a part with its tabs fits the sheet."""

    def __init__(self, fs):
        self.fs = fs

    def ends(self) -> tuple[dict, dict, list[JointFallback]]:
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
        # the other panels of the plate's family at the node (where it folds, its other part,
        # the family's other strips); never the tabbed part's own: its end panel holds the
        # bend's corners by construction (a T of one family)
        others = np.array([q.panels[i] for q, i in self._panels_at(node)
                           if q.family == h.family and q.name != name
                           and (q.name, i) != (host, hj)]).reshape(-1, 4, 3)
        try:
            g = self._kernel(tab_panel, p.panels[pj], key[1], h.panels[hj], opt[0][0], free,
                             thickness=fs.thickness, gap=TAB_GAP * fs.clearance,
                             rise=TAB_RISE * fs.clearance, others=others)
        except _Untrimmable as e:
            return TabReason.GEOMETRY, f"no tab from {name} onto {host}: {e}"
        if not self.fits(p, {key[1]: g}):
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

    def fits(self, part: Part, tabs: dict) -> bool:
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


def _flat_size(quads: np.ndarray) -> tuple[float, float]:
    """(long, short) sides of the least rectangle round the panels ``quads`` laid flat (inf:
    they overlap themselves laid flat)."""
    try:
        return _oriented_size(flat_outline(quads))
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

