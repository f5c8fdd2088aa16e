"""The load path: does every part reach the building through joints that hold it? (issue 42)

The assembly check (:mod:`.checker`) proves that the parts fit and go in; this check proves
that, once in, they are *held*: a graph whose nodes are the parts (plates, connectors,
fixings, named as in ``parts.csv``) and the building, whose edges are the joints that hold,
searched from the building. A part it does not reach is *unsupported*, and the design is not
buildable.

Which joints hold (the rule, plainly):

* **A bolt** holds the parts it passes through, in every direction. Bolts are read from the
  holes the workshop drills (:func:`fastenings_of`), not from the joint builder's plans: a
  hole of a connector, a fixing or a tab (:attr:`~torsal.fabrication.model.Hole.own`) and a
  hole of another part on its axis, of the same diameter, with a parallel axis, within
  ``BOLT_REACH`` plate thicknesses, are one bolt. So a bracket holds the plates its legs are
  bolted to, a splice plate the two parts of its seam, a tab the plate it lies on (whichever
  part of a split plate that is: the hole says so), a fixing the fin it carries. A connector
  leg without a bolt (no room for a hole, or its plate's hole would fall off the panel) holds
  nothing.
* **An anchor** (a fixing's hole on the building side, fastener ``... anchor``) holds the
  fixing to the building.
* **A slot crossing** (egg-crate, a seam in a slot alike) holds two plates against each other
  across both plates and against further travel the way the later plate slid in (the slot
  bottoms bear), *never back the way it came*: the later plate (the joint's later group,
  moved along ``insert_direction`` d) can slide out along ``-d``, the earlier one off it along
  ``+d``. Weight is what pulls a plate that way: a slot holds the later plate on the earlier
  one unless ``-d`` dips more than :data:`SLIDE_DIP_DEG` below the horizontal, and the
  earlier on the later unless ``+d`` does (model frame, ``up`` = +z). Friction is not counted
  on (tan 5 deg = 0.09, far below any sheet metal pair's). A part held through slots only
  (no bolt of its own) is still supported against its weight, and is listed in
  ``slot_held_parts``: wind suction along its slide axis could draw it out; a bolt or clip at
  one crossing locks it.
* **A weld** holds a connector's or fixing's leg to the plate it lies on where the builder
  drilled no hole in that leg (too small for one, or its plate's hole would fall off the
  panel: the parts list counts such connectors ``without_holes``, welded or bonded in the
  workshop). Read from the parts too: a leg without a hole, lying on a plate of its joint
  (parallel, within ``BOLT_REACH`` thicknesses, its centre over the plate's panel), is a
  :data:`WELD` to it; listed in ``welded``.
* **On site:** a butt joint the builder left without a connector because no bracket has room
  there (``FinSystem.unconnected_joints``, which the builder's warning tells the fitter to
  fasten on site: a weld or a clip set there) holds its plates to each other; listed in
  ``site_fastened`` (and, having no fastener drawn, in ``unfastened_joints``).
* Nothing else holds: a butted end whose bracket or tab has no bolt, parts that merely touch.

A bolt or anchor holds both ways; a slot one way or both, as above: the search from the
building follows an edge only in a direction it holds.

Lengths in the fin system's ``unit``.

Example
-------
>>> from torsal.fabrication.assembly import AssemblyJoint, Fastening, BUILDING, check_load_path
>>> import numpy as np
>>> chain = [Fastening(("A-E0000-0", BUILDING), "M8 anchor"),
...          Fastening(("A-E0000-0", "F0-S000-P00"), "M6 bolt")]
>>> lp = check_load_path(["A-E0000-0", "F0-S000-P00", "F1-S000-P00"], [], chain)
>>> lp.unsupported_parts, lp.components
(['F1-S000-P00'], 2)
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Iterable, NamedTuple

import numpy as np

__all__ = ["BUILDING", "SLIDE_DIP_DEG", "UP", "BOLT_REACH", "WELD", "slides_out", "Fastening", "LoadPath", "fastenings_of",
           "check_load_path", "load_path"]

#: the node of the graph that stands for the building (the fixings' anchors hold to it)
BUILDING = "building"
#: degrees: a slot holds a plate unless the way it slides out dips more than this below the
#: horizontal (its weight would draw it out; no friction is counted on)
SLIDE_DIP_DEG = 5.0
#: the upward direction of the model frame (z up)
UP = (0.0, 0.0, 1.0)
#: plate thicknesses: the longest distance along a bolt between the mid-surfaces of two parts
#: it passes through (a leg on a plate: ``t`` + the connector gap; on the far face of a
#: plate with a connector on each face: ``2 t`` + gaps)
BOLT_REACH = 3.0
#: hole diameters: the largest offset across the bolt's axis of two holes it passes through
#: (the builder's own tolerance for one bolt through two holes)
_AXIS_SHARE = 0.1
#: degrees: the largest angle between the axes of two holes one bolt passes through (both
#: square to their plates: a leg or tab lies on the plate it is bolted to)
_AXIS_ANGLE_DEG = 5.0
#: the fastener name of a leg welded to its plate (no room for a bolt)
WELD = "weld"
#: the joint kinds whose parts interlock in slots
_SLOT_KINDS = ("egg-crate",)


class Fastening(NamedTuple):
    """One fastener and the two parts it holds together: ``parts`` (names as in parts.csv,
    the second :data:`BUILDING` for an anchor) and ``fastener`` (e.g. ``M6 bolt``)."""

    parts: tuple[str, str]
    fastener: str


@dataclass
class LoadPath:
    """What :func:`check_load_path` finds.

    ``parts`` every part checked; ``components`` the number of connected groups of parts and
    the building, joined by the joints that hold (1: everything reaches the building; a group
    joined by slots that do not hold against its weight counts apart);
    ``unsupported_parts`` the parts not held to the building (sorted); ``groups`` those parts
    by the group they form (largest first); ``slot_held_parts`` supported parts with no
    fastener of their own (held through slots against their weight only); ``edges`` the
    holding connections by kind (``bolt``, ``anchor``, ``slot``: a slot crossing that holds
    at least one way); ``unfastened_joints`` the joints (other than slot crossings) whose
    parts no fastener joins, ``(kind, node, parts)``; ``checked`` False when no fastenings
    were given (nothing is judged); ``sliding_out`` the unsupported parts that sit in slots
    their weight draws them out of, with the steepest dip of their way out (degrees below the
    horizontal); ``bare_connectors`` the unsupported connectors (brackets, splice plates) with
    no fastener at all (no hole: too small for a bolt; the parts list counts them welded or
    bonded, which no drawing says).
    """

    parts: list[str]
    components: int
    unsupported_parts: list[str]
    groups: list[list[str]] = field(default_factory=list)
    slot_held_parts: list[str] = field(default_factory=list)
    edges: dict = field(default_factory=dict)
    unfastened_joints: list[tuple] = field(default_factory=list)
    checked: bool = True
    sliding_out: dict = field(default_factory=dict)
    bare_connectors: list[str] = field(default_factory=list)
    welded: list[tuple[str, str]] = field(default_factory=list)
    site_fastened: list[tuple] = field(default_factory=list)

    @property
    def supported(self) -> bool:
        """Every part reaches the building (True when not checked: nothing is claimed)."""
        return not self.unsupported_parts

    def problems(self, limit: int = 8) -> str:
        """One sentence naming the parts not held to the building and what to do ('' when all
        are)."""
        if not self.unsupported_parts:
            return ""
        named = ", ".join(self.unsupported_parts[:limit]) + (
            " ..." if len(self.unsupported_parts) > limit else "")
        loose = [j for j in self.unfastened_joints
                 if set(j[2]) & set(self.unsupported_parts)][:4]
        why = ("; their joints without a fastener: " + ", ".join(
            f"{k} at node {n} ({' / '.join(p)})" for k, n, p in loose)) if loose else ""
        if self.bare_connectors:
            why += (f"; {len(self.bare_connectors)} of them are connectors without a bolt hole "
                    "(too small for one: weld or bond them, or make room for a bolt)")
        if self.sliding_out:
            why += (f"; {len(self.sliding_out)} of them sit in slots whose way out dips up to "
                    f"{max(self.sliding_out.values()):.0f} deg below the horizontal, so their "
                    "weight draws them out")
        return (f"{len(self.unsupported_parts)} parts do not reach the building through joints "
                f"that hold them ({len(self.groups)} loose groups): {named}{why}; fix them to "
                "the building (more fixings: a smaller fixings spacing) or bolt them to a part "
                "that is (a bracket or a tab in place of a bare butt joint, a bolt or clip at a "
                "slot crossing they could slide out of)")

    def report(self) -> dict:
        """The ``load_path`` entry of the ``fabrication.assembly`` section of report.json."""
        return {
            "checked": bool(self.checked),
            "supported": bool(self.supported),
            "parts": len(self.parts),
            "components": int(self.components),
            "unsupported": len(self.unsupported_parts),
            "unsupported_parts": list(self.unsupported_parts),
            "groups": [list(g) for g in self.groups],
            "slot_held": len(self.slot_held_parts),
            "slot_held_parts": list(self.slot_held_parts),
            "edges": {str(k): int(v) for k, v in sorted(self.edges.items())},
            "unfastened_joints": [{"kind": k, "node": int(n), "parts": list(p)}
                                  for k, n, p in self.unfastened_joints],
            "sliding_out": dict(sorted(self.sliding_out.items())),
            "bare_connectors": list(self.bare_connectors),
            "welded": [list(w) for w in self.welded],
            "site_fastened": [{"kind": k, "node": int(n), "parts": list(p)}
                              for k, n, p in self.site_fastened],
            "slide_dip_deg": SLIDE_DIP_DEG,
        }


def fastenings_of(fin_system, *, reach: float = BOLT_REACH) -> list[Fastening]:
    """The fasteners of a finished fin system, read from its parts' holes: every *own* hole
    (of a connector, a fixing, or a tab: :attr:`~torsal.fabrication.model.Hole.own`) with the
    holes of other parts on its axis (the normal of the panel it is in, offset across it by
    less than a tenth of its diameter), of the same diameter, square to the same axis (within
    5 deg: a bolt is straight), within ``reach`` plate thicknesses along it: one bolt; an
    anchor's hole holds its part to :data:`BUILDING`.
    Sorted, one entry per pair of parts and fastener (several bolts between two parts count
    once).

    >>> fastenings_of(fs)[:2]                                        # doctest: +SKIP
    [Fastening(parts=('A-E0003-0', 'F0-S000-P00'), fastener='M6 bolt'), ...]
    """
    from ..model import CONNECTOR_FAMILY, FIXING_FAMILY, quad_normals

    rows = []                      # (part index, centre, axis, diameter, own, fastener)
    # one entry a name (a part listed twice is one part)
    parts = list({p.name: p for p in fin_system.parts}.values())
    for k, p in enumerate(parts):
        by_family = p.family in (CONNECTOR_FAMILY, FIXING_FAMILY)
        for h in getattr(p, "holes", ()):
            panel = h.panel if 0 <= h.panel < len(p.panels) else _panel_of(p, h.center)
            axis = quad_normals(p.panels[panel][None])[0]
            rows.append((k, np.asarray(h.center, float), axis, float(h.diameter),
                         by_family or bool(getattr(h, "own", False)), str(h.fastener)))
    out: set[tuple] = set()
    if not rows:
        return []
    centres = np.array([r[1] for r in rows])
    grip = reach * float(fin_system.thickness)
    parallel = np.cos(np.radians(_AXIS_ANGLE_DEG))
    from scipy.spatial import cKDTree

    tree = cKDTree(centres)
    for i, (k, c, axis, d, own, fastener) in enumerate(rows):
        if not own:
            continue
        if fastener.endswith("anchor"):
            out.add(((parts[k].name, BUILDING), fastener))
            continue
        for j in tree.query_ball_point(c, grip + d):
            kj, cj, aj, dj, _, _ = rows[j]
            if kj == k or abs(dj - d) > 1e-6 * max(d, 1.0) or abs(float(aj @ axis)) < parallel:
                continue
            off = cj - c
            along = float(off @ axis)
            if abs(along) <= grip and np.linalg.norm(off - along * axis) <= _AXIS_SHARE * d:
                a, b = sorted((parts[k].name, parts[kj].name))
                if a == b:
                    continue
                out.add(((a, b), fastener))
    out |= _welded_legs(fin_system, parts, rows, grip, parallel)
    return [Fastening(p, f) for p, f in sorted(out)]


def _welded_legs(fin_system, parts: list, rows: list, grip: float, parallel: float) -> set:
    """``{((a, b), WELD)}``: each panel (leg) of a connector or fixing with no hole, lying on a
    plate its joints name (parallel within 5 deg, its centre within ``grip`` of the plate's
    panel's mid-plane and over that panel), welded to it."""
    from ..model import CONNECTOR_FAMILY, FIXING_FAMILY, quad_normals

    drilled = set()
    by_name = {p.name: p for p in parts}
    index = {p.name: k for k, p in enumerate(parts)}
    for k, c, axis, *_ in rows:
        p = parts[k]
        if p.family in (CONNECTOR_FAMILY, FIXING_FAMILY):
            drilled.add((k, _panel_of(p, c)))
    hosts: dict[str, set] = {}
    for j in getattr(fin_system, "joints", ()):
        names = list(j.parts)
        if j.connector:
            hosts.setdefault(j.connector, set()).update(n for n in names if n != j.connector)
        elif str(getattr(j.kind, "value", j.kind)) == "fixing" and len(names) == 2:
            hosts.setdefault(names[0], set()).add(names[1])
    out = set()
    for name, plates in sorted(hosts.items()):
        c = by_name.get(name)
        if c is None:
            continue
        normals = quad_normals(c.panels)
        for i, (quad, n) in enumerate(zip(c.panels, normals)):
            if (index[name], i) in drilled:
                continue
            centre = quad.mean(axis=0)
            for host in sorted(plates):
                h = by_name.get(host)
                if h is not None and _lies_on(centre, n, h, grip, parallel):
                    out.add((tuple(sorted((name, host))), WELD))
    return out


def _lies_on(centre, normal, plate, grip: float, parallel: float) -> bool:
    """Whether a leg (its ``centre`` and ``normal``) lies on a panel of ``plate``: parallel,
    within ``grip`` of its mid-plane, the centre over the panel."""
    from ..model import quad_normals

    for quad, n in zip(plate.panels, quad_normals(plate.panels)):
        if abs(float(n @ normal)) < parallel or abs(float((centre - quad[0]) @ n)) > grip:
            continue
        x = centre - ((centre - quad[0]) @ n) * n
        edges = np.roll(quad, -1, axis=0) - quad
        side = np.einsum("ij,ij->i", np.cross(edges, x - quad), np.broadcast_to(n, edges.shape))
        if (side >= 0).all() or (side <= 0).all():
            return True
    return False


def _panel_of(part, centre) -> int:
    """The panel of ``part`` whose mid-plane is nearest ``centre`` (a hole that names none)."""
    from ..model import quad_normals

    n = quad_normals(part.panels)
    dist = np.abs(np.einsum("ij,ij->i", np.asarray(centre) - part.panels[:, 0], n))
    return int(np.argmin(dist))


def slides_out(way, *, up=UP, slide_dip_deg: float = SLIDE_DIP_DEG) -> bool:
    """Whether a plate whose way out of its slots is the unit vector ``way`` (3,) slides out
    under its weight: ``way`` dips more than ``slide_dip_deg`` below the horizontal (``up``
    a unit vector).

    >>> slides_out(np.array([0.0, 0.94, -0.34])), slides_out(np.array([0.0, 1.0, 0.0]))
    (True, False)
    """
    return bool(float(np.asarray(way, float) @ np.asarray(up, float))
                < -np.sin(np.radians(slide_dip_deg)))


def _slot_edges(joint, known: set, up: np.ndarray, dip_deg: float) -> tuple[list, list]:
    """Directed edges ``(holder, held)`` of a slot crossing: each earlier-group part holds each
    later-group part when the later's way out (``-d``) does not dip more than ``dip_deg``
    below the horizontal (:func:`slides_out`), and the other way when ``+d`` does not; and the
    edges refused, ``(held, degrees its way out dips)``."""
    from .records import joint_groups

    groups = [[p for p in g if p in known] for g in joint_groups(joint)]
    if len(groups) < 2:
        return [], []
    d = np.asarray(joint.insert_direction, float)
    d = d / np.linalg.norm(d)
    out, refused = [], []
    for first, later in zip(groups[:-1], groups[1:]):
        for a in first:
            for b in later:
                for holder, held, way in ((a, b, -d), (b, a, d)):
                    if not slides_out(way, up=up, slide_dip_deg=dip_deg):
                        out.append((holder, held))            # its way out is not downhill
                    else:
                        rise = float(way @ up)
                        refused.append((held, float(np.degrees(np.arcsin(min(1.0, -rise))))))
    return out, refused


def check_load_path(parts: Iterable[str], joints: Iterable, fastenings: Iterable | None, *,
                    up=UP, slide_dip_deg: float = SLIDE_DIP_DEG) -> LoadPath:
    """Which ``parts`` reach the building through joints that hold (rules in the module text).

    Parameters
    ----------
    parts : iterable of str
        Part names (as in parts.csv).
    joints : iterable
        Joint records (:class:`~.records.AssemblyJoint` or anything with its fields): the slot
        crossings are read from them (kind ``egg-crate``: groups and ``insert_direction``), and
        every other joint is listed in ``unfastened_joints`` when no fastener joins its parts.
    fastenings : iterable of :class:`Fastening`, or None
        Bolts and anchors (:func:`fastenings_of`); None: not known, nothing is judged
        (``checked`` False).
    up : (3,) float
        The upward direction in the model frame (+z).
    slide_dip_deg : float
        Degrees below the horizontal a plate's way out of its slots may dip and the slots
        still hold it against its weight.

    Returns
    -------
    LoadPath
    """
    from .records import _as_joint

    names = sorted(dict.fromkeys(str(p) for p in parts))
    if fastenings is None:
        return LoadPath(names, 0, [], checked=False)
    known = set(names)
    up = np.asarray(up, float) / np.linalg.norm(up)
    holds: dict[str, set] = {n: set() for n in names + [BUILDING]}   # holder -> held
    edges: dict[str, int] = {}
    welded: list[tuple[str, str]] = []
    fastened = set()                                                 # parts with a fastener
    joined = set()                                                   # unordered fastened pairs
    for f in fastenings:
        a, b = f.parts
        if a not in holds or b not in holds:
            continue
        holds[a].add(b)
        holds[b].add(a)
        kind = "anchor" if BUILDING in (a, b) else "weld" if f.fastener == WELD else "bolt"
        edges[kind] = edges.get(kind, 0) + 1
        if kind == "weld":
            welded.append((a, b))
        fastened.update((a, b))
        joined.add(frozenset((a, b)))
    slot_pairs, unfastened, sliding, connectors, site = set(), [], {}, set(), []
    for j in map(_as_joint, joints):
        connectors.add(j.connector)
        if j.kind in _SLOT_KINDS:
            kept, refused = _slot_edges(j, known, up, slide_dip_deg)
            for a, b in kept:
                holds[a].add(b)
                slot_pairs.add(frozenset((a, b)))
            for b, deg in refused:
                sliding[b] = max(deg, sliding.get(b, 0.0))
        elif not _joint_fastened(j, known, joined):
            ps = tuple(p for p in j.parts if p in known)
            unfastened.append((j.kind, int(j.node), ps))
            if j.kind == "butt-bracket" and not j.connector and len(ps) > 1:
                site.append((j.kind, int(j.node), ps))
                for a in ps:
                    holds[a].update(b for b in ps if b != a)
    if site:
        edges["site"] = len(site)
    if slot_pairs:
        edges["slot"] = len(slot_pairs)
    reached = _reach(holds, BUILDING)
    unsupported = [n for n in names if n not in reached]
    groups = _groups(unsupported, holds)
    components = 1 + len(groups) if len(reached) > 1 or not names else len(groups)
    slot_held = [n for n in names if n in reached and n not in fastened]
    sliding_out = {n: round(sliding[n], 1) for n in unsupported if n in sliding}
    bare = [n for n in unsupported if n in connectors and n not in fastened]
    return LoadPath(names, components, unsupported, groups, slot_held, edges, unfastened,
                    sliding_out=sliding_out, bare_connectors=bare, welded=welded,
                    site_fastened=site)


def _joint_fastened(j, known: set, joined: set) -> bool:
    """Whether a joint's fasteners hold its parts to one another: for a butt joint the butted
    part (its last plate) to a part of the plate it meets (through its bracket's legs, or its
    tab); for any other (a mitre and its splice plate, a fixing and its fin) every part it
    lists to the others. Only fastened pairs among the joint's own parts count."""
    ps = [p for p in j.parts if p in known]
    plates = [p for p in ps if p != j.connector]
    if len(plates) < 2:
        return True            # nothing to join here (a part left out of the check)
    adj: dict[str, set] = {p: set() for p in ps}
    for pair in joined:
        if pair <= adj.keys():
            a, b = tuple(pair)
            adj[a].add(b)
            adj[b].add(a)
    if j.kind.startswith("butt"):
        return bool(_reach(adj, plates[-1]) & set(plates[:-1]))
    return set(plates) <= _reach(adj, plates[0])


def _reach(holds: dict, start: str) -> set:
    """Nodes reached from ``start`` following ``holds`` (holder -> held)."""
    seen, todo = {start}, [start]
    while todo:
        x = todo.pop()
        for y in holds.get(x, ()):
            if y not in seen:
                seen.add(y)
                todo.append(y)
    return seen


def _groups(names: list[str], holds: dict) -> list[list[str]]:
    """``names`` split into the groups the edges among them join (either way), largest
    first, then by first name."""
    inside = set(names)
    adj: dict[str, set] = {n: set() for n in names}
    for a, bs in holds.items():
        for b in bs:
            if a in inside and b in inside:
                adj[a].add(b)
                adj[b].add(a)
    out, seen = [], set()
    for n in names:
        if n not in seen:
            g = _reach(adj, n)
            seen |= g
            out.append(sorted(g))
    return sorted(out, key=lambda g: (-len(g), g[0]))


def load_path(fin_system, *, up=UP) -> LoadPath:
    """:func:`check_load_path` of a finished :class:`~torsal.fabrication.FinSystem`: its parts,
    its joint records and the fasteners its holes make (:func:`fastenings_of`).

    >>> lp = load_path(fs)                                           # doctest: +SKIP
    >>> lp.supported, lp.components                                  # doctest: +SKIP
    (True, 1)
    """
    from .records import joints_of

    return check_load_path([p.name for p in fin_system.parts], joints_of(fin_system),
                           fastenings_of(fin_system), up=up)
