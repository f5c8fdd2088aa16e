"""Fasteners: the bolts that hold the connectors and fixings to the fins, and their holes
(issue 27).

Every connector (bracket, splice plate) and fixing is a bent plate of two legs
(:func:`~torsal.fabrication.joints.bracket_panels`: leg 1 from its free edge to the bend, leg 2
from the bend to its free edge). Each leg gets a row of holes along the bend line, one fastener
each: a bolt through the leg and the fin plate it lies on (the plate gets the matching hole,
same centre projected on its mid-plane, same diameter), or, on a fixing's leg that lies on the
building, an anchor. The fastener follows the sheet (:func:`fastener_for`): clearance holes
of ISO 273 (medium series), edge distance :data:`EDGE_FACTOR` ``d0`` from every edge and the
bend's inside radius (about ``t``), pitch at least :data:`PITCH_FACTOR` ``d0`` (EN 1993-1-8
and EN 1999-1-1 ask for at least 1.2 ``d0`` and 2.2 ``d0``). A row holds one hole, or two when
the leg is long enough along the bend for two at that pitch (:func:`row_count`). A leg too
short across for a hole (:func:`min_leg`) gets none: its connector is welded or bonded, and
is counted as such.

A tab bent from a butted part instead of a bracket (:mod:`.tabs`) is drilled like the bracket's
leg it replaces: a row along its bend at the edge distance from its free edge
(:func:`tab_holes`), bolts through the tab and the plate it lies on. The tab's holes are the
part's own (:attr:`~torsal.fabrication.model.Hole.own`: their bolts are counted there, under
the joint kind ``butt-tab``), the plate's are its matching holes.

Lengths in the fin system's ``unit``; fastener sizes in mm (converted).

Example
-------
>>> f = fastener_for(3.0)
>>> f.name, f.hole_mm
('M6', 6.6)
>>> anchor_for(3.0).name
'M8'
>>> round(min_leg(f, thickness=3.0), 2)
16.2
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from torsal.core.units import UNIT_TO_MM

from ..model import CONNECTOR_FAMILY, FIXING_FAMILY, Hole, Part, _cross, quad_normals

__all__ = ["Fastener", "fastener_for", "anchor_for", "min_leg", "row_count", "leg_holes",
           "connector_holes", "matching_hole", "EDGE_FACTOR", "PITCH_FACTOR", "CLEARANCE_HOLES",
           "FastenerLayout", "FastenerCount", "fastener_counts", "part_fastening", "tab_holes"]

#: bolt size (mm) -> clearance hole diameter (mm), ISO 273 medium series
CLEARANCE_HOLES = {4: 4.5, 5: 5.5, 6: 6.6, 8: 9.0, 10: 11.0, 12: 13.5, 16: 17.5}
#: edge distance of a hole centre, in hole diameters (from free edges and the bend)
EDGE_FACTOR = 1.5
#: smallest distance of two hole centres in a row, in hole diameters
PITCH_FACTOR = 3.0


class Fastener(NamedTuple):
    """A metric bolt or anchor: ``name`` (``M6``), bolt diameter and clearance hole (mm),
    ``kind`` (``bolt``: through a connector and a fin; ``anchor``: into the building)."""

    name: str
    bolt_mm: float
    hole_mm: float
    kind: str = "bolt"

    @property
    def label(self) -> str:
        return f"{self.name} {self.kind}"


def fastener_for(thickness_mm: float) -> Fastener:
    """The bolt for plates ``thickness_mm`` thick: M4 up to 1.5 mm, M5 up to 2.5, M6 up to 4,
    M8 up to 6, M10 up to 10, M12 beyond (about 1.5 to 2 times the sheet, the usual range for
    thin sheet joints in bearing)."""
    for limit, size in ((1.5, 4), (2.5, 5), (4.0, 6), (6.0, 8), (10.0, 10)):
        if thickness_mm <= limit:
            break
    else:
        size = 12
    return Fastener(f"M{size}", float(size), CLEARANCE_HOLES[size], "bolt")


def anchor_for(thickness_mm: float) -> Fastener:
    """The anchor that fixes a fixing to the building: one size above the bolt, at least M8."""
    sizes = sorted(CLEARANCE_HOLES)
    bolt = int(fastener_for(thickness_mm).bolt_mm)
    size = max(8, sizes[min(sizes.index(bolt) + 1, len(sizes) - 1)])
    return Fastener(f"M{size}", float(size), CLEARANCE_HOLES[size], "anchor")


def _in_unit(f: Fastener, unit: str) -> tuple[float, float]:
    """(hole diameter, edge distance) of ``f`` in ``unit``."""
    d0 = f.hole_mm / UNIT_TO_MM[unit]
    return d0, EDGE_FACTOR * d0


def min_leg(f: Fastener, *, thickness: float, unit: str = "mm") -> float:
    """Shortest leg (bend line to free edge, ``unit``) that takes a hole of ``f``: the edge
    distance from the free edge, and the hole clear of the bend's inside radius (``t``) by
    half its diameter."""
    d0, e = _in_unit(f, unit)
    return e + thickness + 0.5 * d0


def row_count(length: float, f: Fastener, *, unit: str = "mm") -> int:
    """Holes in a row along a leg ``length`` long (``unit``): 2 where two fit at the pitch
    with the edge distance at both ends, 1 where one does, else 0."""
    d0, e = _in_unit(f, unit)
    if length >= 2 * e + PITCH_FACTOR * d0:
        return 2
    return 1 if length >= 2 * e else 0


def leg_holes(bend0: np.ndarray, bend1: np.ndarray, free0: np.ndarray, f: Fastener, *,
              thickness: float, unit: str = "mm") -> list[np.ndarray]:
    """Hole centres (each (3,)) of one leg: the bend line ``bend0 -> bend1`` and the free-edge
    corner ``free0`` across from ``bend0`` (mid-surface corners). The row runs along the bend,
    the edge distance from the free edge; none if the leg is too short across
    (:func:`min_leg`) or along (:func:`row_count`)."""
    d0, e = _in_unit(f, unit)
    across = free0 - bend0
    leg = float(np.linalg.norm(across))
    along = bend1 - bend0
    length = float(np.linalg.norm(along))
    if leg < min_leg(f, thickness=thickness, unit=unit) or not length > 0:
        return []
    n = row_count(length, f, unit=unit)
    if not n:
        return []
    at = bend0 + (leg - e) / leg * across
    if n == 1:
        return [at + 0.5 * along]
    # two holes: as far apart as the edge distance allows, no more than 5 pitches
    gap = min(length - 2 * e, 5 * PITCH_FACTOR * d0)
    lo = 0.5 * (length - gap) / length
    return [at + lo * along, at + (1 - lo) * along]


def connector_holes(q: np.ndarray, legs: tuple[Fastener | None, Fastener | None], *,
                    thickness: float, unit: str = "mm") -> tuple[Hole, ...]:
    """The holes of a two-leg connector, mid-surface ``q`` (2, 4, 3) as
    :func:`~torsal.fabrication.joints.bracket_panels` makes it (leg 1: free edge ``q[0, 0] q[0,
    3]``, bend ``q[0, 1] q[0, 2]``; leg 2: bend ``q[1, 0] q[1, 3]``, free edge ``q[1, 1] q[1,
    2]``); ``legs`` the fastener of each leg (None: no holes in that leg)."""
    out = []
    ends = ((q[0, 1], q[0, 2], q[0, 0]), (q[1, 0], q[1, 3], q[1, 1]))
    for panel, (f, (b0, b1, free)) in enumerate(zip(legs, ends)):
        if f is None:
            continue
        for c in leg_holes(b0, b1, free, f, thickness=thickness, unit=unit):
            out.append(Hole(c, f.hole_mm / UNIT_TO_MM[unit], panel, f.label))
    return tuple(out)


def tab_holes(bend0: np.ndarray, bend1: np.ndarray, free0: np.ndarray, free1: np.ndarray,
              f: Fastener, *, thickness: float, unit: str = "mm") -> list[np.ndarray]:
    """Hole centres (each (3,)) of a tab (:func:`~torsal.fabrication.joints.tab_panel`): its bend
    line ``bend0 -> bend1`` and its free edge ``free0 -> free1`` (mid-surface corners, the
    ``a`` side first; the free edge may be shorter than the bend, a trapezoid). As
    :func:`leg_holes` on the rectangle under the free edge: the row along the free edge's
    stretch, the edge distance from it; none if the tab is too short across or along.

    >>> h = tab_holes(np.zeros(3), np.array([0, 0, 100.0]), np.array([20, 0, 25.0]),
    ...               np.array([20, 0, 75.0]), fastener_for(3.0), thickness=3.0)
    >>> [x.round(1).tolist() for x in h]
    [[10.1, 0.0, 34.9], [10.1, 0.0, 65.1]]
    """
    e = (bend1 - bend0) / np.linalg.norm(bend1 - bend0)
    w = 0.5 * (free0 + free1) - bend0
    w = w - (w @ e) * e
    leg = float(np.linalg.norm(w))
    if not leg > 0:
        return []
    b0 = bend0 + ((free0 - bend0) @ e) * e
    b1 = bend0 + ((free1 - bend0) @ e) * e
    return leg_holes(b0, b1, b0 + w, f, thickness=thickness, unit=unit)


def matching_hole(hole: Hole, plate: Part, panel: int, *, margin: float = 0.0) -> Hole | None:
    """The hole in ``plate`` (panel ``panel``) that a bolt through ``hole`` of a connector leg
    lying on it passes: the centre projected on the panel's mid-plane; None where that falls
    outside the panel (less ``margin`` plus the hole's radius from its edges)."""
    quad = plate.panels[panel]
    n = quad_normals(quad[None])[0]
    c = hole.center - ((hole.center - quad[0]) @ n) * n
    e1 = quad[1] - quad[0] if np.linalg.norm(quad[1] - quad[0]) > 0 else quad[2] - quad[3]
    e1 = e1 / np.linalg.norm(e1)
    e2 = _cross(n, e1)
    poly = np.c_[(quad - quad[0]) @ e1, (quad - quad[0]) @ e2]
    x = np.array([(c - quad[0]) @ e1, (c - quad[0]) @ e2])
    edges = np.roll(poly, -1, axis=0) - poly
    lengths = np.linalg.norm(edges, axis=1)
    ok = lengths > 0
    # signed distance from every edge (the quad is convex; orient by its area's sign)
    cross = edges[ok, 0] * (x[1] - poly[ok, 1]) - edges[ok, 1] * (x[0] - poly[ok, 0])
    area = 0.5 * np.sum(poly[:, 0] * np.roll(poly[:, 1], -1) - np.roll(poly[:, 0], -1) * poly[:, 1])
    dist = np.sign(area) * cross / lengths[ok]
    if not (dist >= margin + 0.5 * hole.diameter).all():
        return None
    return Hole(c, hole.diameter, panel, hole.fastener)


def tab_bolts(tab: np.ndarray, start: bool, plate: Part, panel: int, f: Fastener, *,
              thickness: float, unit: str = "mm") -> list[tuple[np.ndarray, Hole]]:
    """The bolts of a tab: ``[(centre in the tab, matching hole in the plate)]``, for the tab
    quad ``tab`` (the first panel of its part when ``start``, else the last) lying on panel
    ``panel`` of ``plate``: :func:`tab_holes` whose :func:`matching_hole` falls inside that
    panel (a hole off it has no bolt). Empty: the tab cannot be bolted, it holds nothing."""
    q = np.asarray(tab, float)
    (b0, b1), (f0, f1) = ((q[1], q[2]), (q[0], q[3])) if start else ((q[0], q[3]), (q[1], q[2]))
    out = []
    for c in tab_holes(b0, b1, f0, f1, f, thickness=thickness, unit=unit):
        m = matching_hole(Hole(c, f.hole_mm / UNIT_TO_MM[unit], -1, f.label), plate, panel)
        if m is not None:
            out.append((c, m))
    return out


class FastenerLayout:
    """Drills the finished fin system ``fs``: the holes of every connector (bolts through both
    legs, :func:`connector_holes`) and fixing (bolts through the leg on the fin, anchors
    through the leg on the building), and the matching holes of the plates they lie on
    (:func:`matching_hole`). A connector hole whose match would not lie inside its plate's
    panel is left out with it (a bolt needs both)."""

    def __init__(self, fs):
        self.fs = fs

    def _drill(self) -> None:
        fs = self.fs
        mm = UNIT_TO_MM[fs.unit]
        t = fs.thickness
        bolt, anchor = fastener_for(t * mm), anchor_for(t * mm)
        by_name = {p.name: p for p in fs.parts}
        plate_holes: dict[str, list[Hole]] = {}
        legs_on: list[tuple[Part, tuple, tuple]] = []
        for c in fs.connectors:
            site = fs._sites.get(c.name)
            hosts = site[2][0][6] if site is not None else (None, None)
            legs_on.append((c, (bolt, bolt), hosts))
        for f in fs.fixings:
            legs_on.append((f, (bolt, anchor), (fs._fixing_sites.get(f.name), None)))
        for part, legs, hosts in legs_on:
            keep = []
            for h in connector_holes(part.panels, legs, thickness=t, unit=fs.unit):
                host = hosts[h.panel]
                if host is None:                   # the building: an anchor, no plate hole
                    keep.append(h)
                    continue
                plate = by_name.get(host[0])
                m = None if plate is None else matching_hole(h, plate, host[1])
                if m is None:
                    continue
                there = plate_holes.setdefault(plate.name, [])
                if any(np.linalg.norm(o.center - m.center) < 0.1 * m.diameter for o in there):
                    # a connector on the plate's other face has a hole here: one bolt for both
                    keep.append(Hole(h.center, h.diameter, h.panel, h.fastener, shared=True))
                else:
                    keep.append(h)
                    there.append(m)
            part.holes = tuple(keep)
        # the tabs bent from butted parts (.tabs): their holes are the part's own
        own: dict[str, list[Hole]] = {}
        for tj in getattr(fs, "tab_joints", []):
            p, plate = by_name.get(tj.part), by_name.get(tj.host)
            if p is None or plate is None:
                continue
            i = tj.panel(p)
            for c, m in tab_bolts(p.panels[i], tj.start, plate, tj.host_panel, bolt,
                                  thickness=t, unit=fs.unit):
                h = Hole(c, bolt.hole_mm / mm, i, bolt.label, own=True)
                there = plate_holes.setdefault(plate.name, [])
                shared = any(np.linalg.norm(o.center - m.center) < 0.1 * m.diameter for o in there)
                own.setdefault(p.name, []).append(Hole(c, h.diameter, i, h.fastener, shared=shared,
                                                       own=True))
                if not shared:
                    there.append(m)
        for p in fs.parts:
            if p.family not in (CONNECTOR_FAMILY, FIXING_FAMILY):
                p.holes = tuple(plate_holes.get(p.name, []) + own.get(p.name, []))


class FastenerCount(NamedTuple):
    """Fasteners of one kind of joint: ``connectors`` (separate parts: brackets, splice
    plates, fixings), ``bolts`` (through a connector and a fin), ``anchors`` (into the
    building), ``unfastened`` (connectors without room for a hole: welded or bonded), the
    ``fastener`` sizes used and the hole diameters (``unit``)."""

    connectors: int
    bolts: int
    anchors: int
    unfastened: int
    fastener: str
    hole: float


def fastener_counts(fs) -> dict[str, FastenerCount]:
    """``{joint kind: FastenerCount}`` of a finished fin system, for every kind with a connector
    (``butt-bracket``, ``mitre-splice``, ``fixing``); the holes are counted on the connectors
    (one fastener each; the matching plate holes take the same fastener, and a bolt through two
    connectors on the two faces of a plate is counted once).

    >>> fastener_counts(fs)["butt-bracket"].bolts                            # doctest: +SKIP
    1040
    """
    kind_of = {j.connector: j.kind.value for j in fs.joints if j.connector}
    kind_of.update((f.name, "fixing") for f in fs.fixings)
    rows: dict[str, list] = {}
    for p in fs.connectors + fs.fixings:
        kind = kind_of.get(p.name, "connector")
        r = rows.setdefault(kind, [0, 0, 0, 0, set(), set()])
        r[0] += 1
        bolts = sum(1 for h in p.holes if h.fastener.endswith("bolt") and not h.shared)
        anchors = sum(1 for h in p.holes if h.fastener.endswith("anchor"))
        r[1] += bolts
        r[2] += anchors
        r[3] += not p.holes
        r[4].update(h.fastener for h in p.holes)
        r[5].update(round(float(h.diameter), 6) for h in p.holes)
    # tabs bent from the butted parts: no connector, their bolts counted at the tab's holes
    by_name = {p.name: p for p in fs.parts}
    for tj in getattr(fs, "tab_joints", []):
        p = by_name.get(tj.part)
        if p is None:
            continue
        r = rows.setdefault("butt-tab", [0, 0, 0, 0, set(), set()])
        holes = [h for h in p.holes if h.own and h.panel == tj.panel(p)]
        r[1] += sum(1 for h in holes if not h.shared)
        r[3] += not holes
        r[4].update(h.fastener for h in holes)
        r[5].update(round(float(h.diameter), 6) for h in holes)
    return {k: FastenerCount(r[0], r[1], r[2], r[3], ", ".join(sorted(r[4])),
                             max(r[5], default=0.0))
            for k, r in sorted(rows.items())}


def part_fastening(fs) -> dict[str, dict]:
    """Per part name, the parts list's fastener columns: ``kind`` (``plate``, the joint kind of
    a connector, or ``fixing``), ``holes`` (count), ``hole_diameter_mm`` (largest; 0 without
    holes), ``fasteners`` (the bolts and anchors that go through its own holes, for a connector
    or fixing, a bolt shared with the connector on the plate's other face counted there; for a
    plate those through the tabs bent from it, :mod:`.tabs`; not a connector's bolt, which
    passes its matching hole) and ``fastener`` (the sizes, e.g. ``M6 bolt``)."""
    kind_of = {j.connector: j.kind.value for j in getattr(fs, "joints", []) if j.connector}
    mm = UNIT_TO_MM[fs.unit]
    out = {}
    for p in fs.parts:
        kind = ("fixing" if p.family == FIXING_FAMILY else kind_of.get(p.name, "plate"))
        holes = getattr(p, "holes", ())
        own = [h for h in holes if kind != "plate" or getattr(h, "own", False)]
        out[p.name] = {
            "kind": kind, "holes": len(holes),
            "hole_diameter_mm": round(max((h.diameter for h in holes), default=0.0) * mm, 3),
            "fasteners": sum(1 for h in own if not h.shared),
            "fastener": " + ".join(sorted({h.fastener for h in own})),
        }
    return out
