"""Joinery per node: which joint a workshop makes where parts meet, and its geometry (issue 15).

Two families of planar fins meet on the node lines ``L_i = a_i b_i`` (paper section 4.3). At
every node the joint is chosen from the real geometry of the plates there:

* **Egg-crate** (:attr:`JointKind.EGG_CRATE`) where a strip of each family passes through
  the node, *neither plate folds there by more than* :data:`MAX_CROSSING_FOLD` and the plates
  cross at *at least* :data:`MIN_CROSSING_ANGLE`. Both plates contain ``L_i``, so they slide
  together along it: family 0 is slotted from its ``b`` edge, family 1 from its ``a`` edge
  (or the other way round, see below), depths adding up to ``|b_i - a_i|``. A laser cut is square to the sheet, so the slot must
  take the whole cross-section of the other plate, a parallelogram: at a crossing angle
  ``alpha`` the slot width is ``t (1 + cos alpha) / sin alpha + c`` (:func:`slot_width`;
  ``t + c`` at 90 degrees, ``2.41 t + c`` at 45, ``3.73 t + c`` at 30). A small fold
  ``theta`` of either plate is allowed for by narrowing ``alpha`` by the folds and thickening
  the crossing plate by its mitre (``1 / cos(theta/2)``).
* **Butt joint with a bracket** (:attr:`JointKind.BUTT_BRACKET`) everywhere else a part ends
  against a plate: at the boundary (T and L junctions, as before), where a strip must fold at a
  crossing or the plates cross too obliquely for a slot (the strip that folds more is split
  there, the other stays continuous), and where a strip is split at a crossing for length or
  sheet size, unless the split is held in the slot (next item). The end panel is trimmed back
  until its end face (along the continuous plate's
  mean plane) clears both faces of that plate by ``clearance/2``; a bent bracket of the same
  sheet (:func:`bracket_panels`) sits in the corner between the two plates, one leg flat on
  each, and is a part of its own (``C-N<node>-<index>``: solid, cutting outline, parts-list
  row). The bracket goes into the more open of the two corners (at most
  :data:`MAX_BRACKET_ANGLE`, at least :data:`MIN_BRACKET_ANGLE`), so its bend stays modest.
  The same joint joins the two parts of a strip split on a fold sharper than
  ``max_fold_angle``: the later part butts against the square end of the earlier one.
* **Seam inside the slot** (an :attr:`JointKind.EGG_CRATE` joint of three parts, no
  connector): a strip split at a crossing (for length or the sheet, or because it folds
  there while the other plate does not) meets on its mitred seam inside the other plate's
  slot, both parts slotted at their ends, held by it. The holder may be bent through its slot
  up to :data:`MAX_HOLDER_FOLD` where the split strip folds there too; where the two parts of
  a family-1 seam slide in from opposite edges, the family-0 plate is slotted from both edges
  and each part enters with a tongue from its own side (:data:`TONGUE_SHARE`). Kept per joint
  only where the assembly check on the solids around it proves it, else butted with brackets
  as above, the fallback named (:mod:`torsal.fabrication.builder.seams`).
* **Butt joint with a tab** (:attr:`JointKind.BUTT_TAB`, no connector): where a bracket
  was placed, the butted part's end is bent into a tab instead, a flange of the part itself
  that lies where the bracket's leg on the continuous plate lay and is bolted to that plate
  (:func:`tab_panel`). The end panel then ends on the bend line, where its mid-plane meets the
  plane ``t + clearance/2`` off the continuous plate's (the tab's face keeps the clearance/2
  of the butted end it replaces); the tab is an extra panel of the part, a trapezoid from the
  whole bend line to the bracket leg's free edge, so its solid, its flat pattern (one bend
  more) and its parts-list row are the part's. Kept per joint only where the assembly check
  on the solids around it proves it, else the bracket stays, the fallback named
  (:mod:`torsal.fabrication.builder.tabs`). An end bracketed in both corners (a bridge across
  the other family's seam) keeps one bracket: an end bends into one tab.
* **Mitre with a splice plate** (:attr:`JointKind.MITRE_SPLICE`) where a strip is split on a
  mild fold away from any crossing plate (``max_panels``, ``max_part_length``, sheet size): the
  ends are mitred on the fold's bisector plane, each trimmed back from it by ``clearance/2``
  (:func:`mitre_trim`: the parts leave the clearance between them, like a butt joint), and a
  bent splice plate covers the seam on the side clear of other parts.

**One insertion direction per part.** Family-0 plates go in first; each family-1 plate then
slides onto all its egg-crate crossings along one direction, the mean of their node axes. A
crossing whose axis is ``skew`` off it gets both slots ``2 depth tan(skew)`` wider; beyond
:data:`MAX_SLOT_SKEW` (2 degrees) the crossing is butted instead (the strip split there).
The sense (along ``a - b``, slots open on the family-1 ``a`` edge, or along ``b - a``, slots
on its ``b`` edge and family 0's ``a`` edge) is the one in which its butted ends do not close
their gaps to the plates they meet; if neither does, its crossings are butted. A part with
butt joints only slides along the node axis of one of them where that closes no gap (the end
slides along the plate), else along the line where two of the faces it ends against meet,
or head on. No parts butt on each other in a cycle (A against B, B against C, C against A: the
last could not go in): in a cycle, crossings where a family-0 part butts against a family-1
plate are split on family 1 instead (family 0 continuous, bracketed across), else one
crossing's split family is swapped; the design is rebuilt until no cycle is left. Last, each
part's path into place must clear the plates placed before it that it is not joined to (a
neighbouring fin of a rough congruence may stand in the way of a slide along the node axis):
the part takes the first clear direction its joints allow, else the cheaper panel of the pair
in the way is left out (rules in :mod:`.parts`).

**End panels that cannot be trimmed are left out.** A part end meeting the plate it ends
against within about 12 degrees (it lies along that plate and duplicates its fin) cannot be
trimmed clear of it: that end panel is left out (named in ``FinSystem.coplanar_panels``,
warned) and the strip ends one node earlier, joined there as usual. A part joined to nothing
(no joint, no slot) whose panels pass through another part's is left out the same way: the
structure runs through itself there.

Where several strips of one family end at the same node, the first is the base and each other
butts against it and those before it (ending against a plate of the other family, each end
also clears those of its family that end there on the same side); where both strips are split at a node, family 1's halves
get a bracket in both corners, which bridges family 0's seam. Node lines of the two families
that coincide (refined developable strips duplicate them) are one node. A panel folded back
onto its neighbour (more than ``MITER_LIMIT``) duplicates that fin and is dropped (named).

Limits: slots need a crossing angle of at least :data:`MIN_CROSSING_ANGLE` (30 degrees: the
slot is then already 3.7 plate thicknesses wide), folds of at most :data:`MAX_CROSSING_FOLD`
(10 degrees) at the crossing and node axes within :data:`MAX_SLOT_SKEW` of the plate's slide
direction; a butt trim needs the part to meet the plate at more than about 12 degrees (else
the end panel is left out; after ``MAX_REBUILDS`` rebuilds, or for strips from
:meth:`FinSystem.from_strips`, it is listed in ``FinSystem.untrimmed_joints``); a
bracket needs room for legs of at least ``2 t`` inside both panels (else the joint is listed in
``FinSystem.unconnected_joints``). Holes for rivets or bolts are not drawn: brackets are
placed and drilled, or welded, in the workshop. Folds are not moved away from crossings: the
strip is split there instead.

Units: lengths in the fin system's ``unit`` (mm by default), angles in degrees unless noted.

Example
-------
>>> round(slot_width(45.0, thickness=3.0, clearance=0.5), 3)
7.743
>>> JointKind.EGG_CRATE.value
'egg-crate'
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from shapely.geometry import Polygon

from .model import JointKind, _cross, _fold_deg, _miter, quad_normals

__all__ = ["MIN_CROSSING_ANGLE", "MAX_CROSSING_FOLD", "MAX_SLOT_SKEW", "MAX_HOLDER_FOLD", "TONGUE_SHARE", "MIN_BRACKET_ANGLE", "MAX_BRACKET_ANGLE",
           "slot_width", "crossing_angle", "NodeJoinery", "choose_joinery", "bracket_panels",
           "place_connector", "connector_variants", "connector_offset", "corner_point",
           "fixing_panels", "corners",
           "mitre_trim", "continues", "seam_trim", "CONTINUE_ANGLE", "JointKind", "MIN_TRIM_SINE",
           "BRACKET_TRIM_SINE", "tab_panel", "TabGeometry"]

#: degrees: plates crossing more obliquely than this are not slotted (butt joint + bracket)
MIN_CROSSING_ANGLE = 30.0
#: degrees: a plate folding more than this at a crossing is split there (butt joint + bracket)
MAX_CROSSING_FOLD = 10.0
#: degrees: a plate slotted at several crossings slides onto them all along the mean of their
#: node axes; its slots (and its partners') are widened by ``2 depth tan(skew)`` for a crossing
#: whose axis is ``skew`` off it. Beyond this skew the crossing is butted instead.
MAX_SLOT_SKEW = 2.0
#: degrees: a plate that holds the seam of a strip split at a crossing inside its slot (the
#: split strip folding there more than :data:`MAX_CROSSING_FOLD`) may fold this much at the
#: node, bent through its slot: the seam's two parts are flat there, so one plate is bent
#: through a slot, not two as at an egg-crate of two folding plates. Kept per joint only
#: where the assembly check on the solids around it proves it (:mod:`.builder.seams`). No more
#: than :data:`~.plates.SINGLE_BOX_FOLD`: a slot on a sharper fold is cut with a box in each
#: panel's plane, and at 30 degrees that left example 7c's F0-S036-P01 (22 deg at node 242) a
#: solid whose triangles do not close (no IFC face set, no 3DM Brep)
MAX_HOLDER_FOLD = 20.0
#: where the two parts of a family-1 strip split inside a crossing slot slide in from opposite
#: edges (each along its own plate's slide direction), the family-0 plate holding them is
#: slotted from *both* edges: each part keeps a tongue of this share of the fin depth at its
#: end that enters the slot from its own side, and the same share is left as the web between
#: the two slots (a halving joint from each side; no connector)
TONGUE_SHARE = 1.0 / 3.0
#: degrees: brackets are bent to corners between these angles (the bend is 180 - angle)
MIN_BRACKET_ANGLE = 25.0
MAX_BRACKET_ANGLE = 172.0
#: sine of the least angle at which the edges of a butted end panel may meet the plate it is
#: trimmed against (1.1 deg): each corner moves ``gap / sine`` along its edge, so an edge that
#: runs nearly along the plate (a sheared panel whose edges run nearly along the node line, or
#: plates crossing at a few degrees) is trimmed back by up to 50 times the gap (about 9 cm at
#: 3 mm sheet); a panel shorter than twice its trim is still left out
MIN_TRIM_SINE = 0.02
#: below this sine (11.5 deg) a trimmed end is kept only where its bracket still fits on it
#: (:meth:`torsal.fabrication.builder.ends.EndJoiner._butt`): the long trim may take away the
#: panel the bracket's leg would lie on. Until 2026-11 no end was trimmed below it: example 9
#: left 103 of its 867 panels out for it, the hypar canopy 19 of 178
BRACKET_TRIM_SINE = 0.2


class _Untrimmable(Exception):
    """A part end that cannot be butt-trimmed (too shallow an angle, too short a panel)."""


def slot_width(alpha: float, *, thickness: float, clearance: float, fold_self: float = 0.0,
               fold_other: float = 0.0) -> float:
    """Width of an egg-crate slot square to the sheet (``unit``).

    The crossing plate's cross-section (thickness ``t``, crossing at ``alpha`` degrees) is a
    parallelogram of width ``t (1 + cos alpha) / sin alpha`` along the slotted plate: that plus
    the clearance. Folds (degrees) of the slotted plate (``fold_self``) and the crossing plate
    (``fold_other``) at the node narrow the angle by ``(fold_self + fold_other) / 2`` and
    thicken the crossing plate by its mitre ``1 / cos(fold_other / 2)``; a slot on a folded
    plate is cut on the fold's bisector, which costs ``t tan(fold_self / 2)`` more.

    >>> slot_width(90.0, thickness=3.0, clearance=0.5)
    3.5
    """
    a = np.radians(min(90.0, abs(alpha)) - 0.5 * (fold_self + fold_other))
    if not a > 0:
        raise ValueError(f"plates crossing at {alpha:.1f} deg with folds {fold_self:.1f}, "
                         f"{fold_other:.1f} deg cannot be slotted")
    t_other = thickness / np.cos(np.radians(fold_other) / 2)
    w = t_other * (1.0 + abs(np.cos(a))) / np.sin(a)
    return float(w + thickness * np.tan(np.radians(fold_self) / 2) + clearance)


def _mean_normal(panels) -> np.ndarray:
    """Mean unit normal of a plate's panels [(n, v)] at a node, normals turned alike."""
    ns = [panels[0][0]] + [p[0] if p[0] @ panels[0][0] >= 0 else -p[0] for p in panels[1:]]
    m = np.sum(ns, axis=0)
    return m / np.linalg.norm(m)


def _plate_fold(panels) -> float:
    """Fold (degrees) of a plate at a node: angle between its two panels' normals (0 if one)."""
    if len(panels) < 2:
        return 0.0
    v0, v1 = panels[0][1], panels[1][1]
    # the panels lie on opposite sides of the node line: a flat plate has v0 = -v1 (its normals
    # may be either way round); measure the dihedral from the directions into the panels
    return float(180.0 - np.degrees(np.arccos(np.clip(v0 @ v1, -1.0, 1.0))))


def crossing_angle(panels0, panels1) -> float:
    """Angle (degrees, 0..90) between the mean planes of two plates at a node."""
    n0, n1 = _mean_normal(panels0), _mean_normal(panels1)
    return float(np.degrees(np.arcsin(np.clip(np.linalg.norm(_cross(n0, n1)), 0.0, 1.0))))


class NodeJoinery(NamedTuple):
    """The joint chosen at a node where strips of both families pass.

    ``kind`` egg-crate or butt-bracket; ``split`` the family whose strip is cut there (-1 for
    an egg-crate); ``angle`` the crossing angle and ``folds`` the folds of family 0 and 1
    (degrees); ``why`` says why an egg-crate was not possible."""

    node: int
    kind: JointKind
    split: int
    angle: float
    folds: tuple[float, float]
    why: str = ""


def choose_joinery(node: int, panels0, panels1, *, min_angle: float = MIN_CROSSING_ANGLE,
                   max_fold: float = MAX_CROSSING_FOLD) -> NodeJoinery:
    """Egg-crate or split-and-butt at an X node, from the plates' panels there.

    ``panels0`` / ``panels1`` are the (unit normal, in-plane direction from the node line into
    the panel) pairs of each family's panels at the node. The strip that folds more (family 1
    on a tie) is the one split.
    """
    alpha = crossing_angle(panels0, panels1)
    folds = (_plate_fold(panels0), _plate_fold(panels1))
    why = []
    if max(folds) > max_fold:
        why.append(f"a plate folds {max(folds):.0f} deg there (> {max_fold:g})")
    if alpha < min_angle:
        why.append(f"the plates cross at {alpha:.0f} deg (< {min_angle:g})")
    if not why:
        return NodeJoinery(node, JointKind.EGG_CRATE, -1, alpha, folds)
    split = 0 if folds[0] > folds[1] + 1e-9 else 1
    return NodeJoinery(node, JointKind.BUTT_BRACKET, split, alpha, folds, "; ".join(why))


def _in_plane(v: np.ndarray, n: np.ndarray) -> np.ndarray:
    """The unit direction ``v`` (3,) with its part along the unit normal ``n`` removed (``v``
    itself where that leaves nothing)."""
    w = v - (v @ n) * n
    nw = np.linalg.norm(w)
    return w / nw if nw > 1e-9 else v


def bracket_panels(p0: np.ndarray, p1: np.ndarray, side1, side2, offset: float,
                   leg: float) -> np.ndarray:
    """Mid-surface (2, 4, 3) of a bent plate lying on two plate faces that meet at a line.

    ``p0 -> p1`` is the stretch of the joint line it covers; ``side1`` / ``side2`` are
    ``(n, v)``: the unit normal of each plate, turned towards the connector, and the unit
    direction in that plate away from the line (square to it). The connector's mid-surface is
    ``offset`` off both faces' mid-planes (``t/2 + t_connector/2``); its bend line is where the
    two offset planes meet (``p + offset * m`` with the mitre ``m.n1 = m.n2 = 1``), each leg
    ``leg`` long. Quads ``a_i a_j b_j b_i`` as a 2-panel strip: leg 1 from its free edge to the
    bend, leg 2 from the bend to its free edge.
    """
    (n1, v1), (n2, v2) = side1, side2
    # each leg lies flat on its plate: v in the plate's plane (the direction into a dart panel
    # whose centre is near the node line tilts out of it: 7c at full size, 0.45 deg, a leg of
    # C-N0200-1 0.06 mm into its plate at the free edge, 6 mm^3)
    v1, v2 = _in_plane(v1, n1), _in_plane(v2, n2)
    m = _miter(n1, n2)
    c0, c1 = p0 + offset * m, p1 + offset * m
    return np.array([[c0 + leg * v1, c0, c1, c1 + leg * v1],
                     [c0, c0 + leg * v2, c1 + leg * v2, c1]])


def _inside(leg: np.ndarray, panel: np.ndarray, tol: float) -> bool:
    """Whether a leg quad (4, 3), projected on the plane of ``panel`` (4, 3), lies inside it."""
    n = quad_normals(panel[None])[0]
    e1 = panel[1] - panel[0] if np.linalg.norm(panel[1] - panel[0]) > 0 else panel[2] - panel[3]
    e1 = e1 - (e1 @ n) * n
    e1 /= np.linalg.norm(e1)
    e2 = _cross(n, e1)
    P = np.c_[(panel - panel[0]) @ e1, (panel - panel[0]) @ e2]
    Q = np.c_[(leg - panel[0]) @ e1, (leg - panel[0]) @ e2]
    poly = Polygon(P)
    if not poly.is_valid:
        return False
    return poly.buffer(tol).contains(Polygon(Q))


def connector_offset(a: np.ndarray, b: np.ndarray, side1, side2, offset: float, plates, *,
                     thickness: float, gap: float) -> float:
    """The offset of a connector's mid-surface off its plates' mid-planes (``offset``, or more)
    that keeps it ``gap`` clear of both plates' solids.

    On the convex side of a joint (each plate turning away from the other's connector side,
    ``v2 . n1 < 0``: a splice plate round the outside of a seam) the connector's face is the
    outer envelope of its two legs' planes, so a plate corner standing past the node line
    (the mitred edge of a plate that folds there stands out by ``t/2 tan(fold/2)``) lies under
    the *other* leg too, and must clear that leg's plane: the connector moves out along its
    mitre until every corner does (example 9 at 3db0016: a splice on the convex side of a plate
    folding 51 degrees at the node met the plate's mitred edge, 2 mm^3; now 0.17 mm off it).
    Both legs move alike: legs at two offsets would slide the bend along nearly coplanar
    plates by the difference over the sine of their angle. On the concave side (a bracket in
    a corner under 180 degrees) each leg has only its own plate under it. ``plates``: the
    (k, 3) corners of each plate's solid around its panel (:meth:`~.model.Part.slab_corners`),
    ``a -> b`` the node line (the connector's legs are offset from points of it; a normal
    not quite square to it, on warped panels, tilts the leg's plane along it: the farther end
    counts).
    """
    (n1, v1), (n2, v2) = side1, side2
    if plates is None or not v2 @ n1 < 0:
        return offset
    # leg j's face (t/2 off its mid-surface) stays gap below every corner of the other plate
    need = max(float((np.asarray(pl) @ n).max() - min(a @ n, b @ n)) + 0.5 * thickness + gap
               for pl, n in ((plates[1], n1), (plates[0], n2)))
    # a corner clear but for rounding does not move the connector
    return need if need > offset + 1e-6 * thickness else offset


def connector_variants(a: np.ndarray, b: np.ndarray, side1, side2, panel1: np.ndarray,
                       panel2: np.ndarray, *, thickness: float, leg: float | None = None,
                       gap: float = 0.0, min_leg: float | None = None, plates=None):
    """Every connector (2, 4, 3) on the node line ``a -> b`` between two plate panels whose
    legs lie inside their panels, largest first (a generator; see :func:`place_connector`).

    The stretch along the node line narrows (from the middle half of it) and the legs shorten
    (down to ``min_leg``, default ``2 t``) in five steps; a variant is given where the outer 60 %
    of each leg lies on its panel (nearer the bend a leg may pass the trimmed end of a butted
    part, the clearance, or a convex fold line). ``plates``: the corners of the two plates'
    solids there, which the connector clears (:func:`connector_offset`).
    """
    t = thickness
    leg = 6.0 * t if leg is None else leg
    shortest = 2.0 * t if min_leg is None else min_leg
    line = b - a
    depth = float(np.linalg.norm(line))
    u = line / depth
    # t/2 of the plate + t/2 of the connector; a real panel is planar only to the structure's
    # tolerance: the gap is kept from the corner that stands out most towards the connector
    proud = max(0.0, float(((panel1 - panel1.mean(axis=0)) @ side1[0]).max()),
                float(((panel2 - panel2.mean(axis=0)) @ side2[0]).max()))
    offset = connector_offset(a, b, side1, side2, t + gap + proud, plates, thickness=t,
                              gap=gap)
    for lo, f in ((0.25, 1.0), (0.25, 0.6), (0.3, 0.45), (0.35, 0.33), (0.4, 0.33)):
        ell = max(shortest, f * leg)
        if (1 - 2 * lo) * depth < 2.0 * t:
            break
        q = bracket_panels(a + lo * depth * u, a + (1 - lo) * depth * u, side1, side2, offset, ell)
        outer0 = np.array([q[0, 0], q[0, 0] + 0.6 * (q[0, 1] - q[0, 0]),
                           q[0, 3] + 0.6 * (q[0, 2] - q[0, 3]), q[0, 3]])
        outer1 = np.array([q[1, 1] + 0.6 * (q[1, 0] - q[1, 1]), q[1, 1], q[1, 2],
                           q[1, 2] + 0.6 * (q[1, 3] - q[1, 2])])
        if _inside(outer0, panel1, 1e-6 * depth) and _inside(outer1, panel2, 1e-6 * depth):
            yield q


def place_connector(a: np.ndarray, b: np.ndarray, side1, side2, panel1: np.ndarray,
                    panel2: np.ndarray, *, thickness: float, leg: float | None = None,
                    gap: float = 0.0, min_leg: float | None = None,
                    plates=None) -> np.ndarray | None:
    """A connector (2, 4, 3) on the node line ``a -> b`` between two plate panels, or None.

    ``side1``, ``side2`` as in :func:`bracket_panels`; ``panel1``, ``panel2`` (4, 3) are the
    panels the legs lie on: the legs are shortened (down to ``min_leg``, default ``2 t``) and
    the stretch along the node line narrowed (from the middle half of it) until both legs lie
    inside their panels (the first of :func:`connector_variants`). ``gap`` is left between the
    connector and the plates' faces, and their solids' corners ``plates`` (see
    :func:`connector_offset`).
    """
    return next(connector_variants(a, b, side1, side2, panel1, panel2, thickness=thickness,
                                   leg=leg, gap=gap, min_leg=min_leg, plates=plates), None)


def corner_point(n1: np.ndarray, n2: np.ndarray, o1: float, o2: float) -> np.ndarray:
    """Vector ``x`` in the span of unit normals ``n1``, ``n2`` with ``x . n1 = o1`` and
    ``x . n2 = o2``: from a point of the line where two planes meet to the line where their
    offsets by ``o1`` and ``o2`` meet (the mitre times ``o`` when both offsets are ``o``).

    >>> corner_point(np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), 2.0, 3.0)
    array([2., 3., 0.])
    """
    c = float(n1 @ n2)
    det = 1.0 - c * c
    if not det > 1e-12:
        raise ValueError("parallel planes have no corner")
    return ((o1 - c * o2) * n1 + (o2 - c * o1) * n2) / det


def fixing_panels(p0: np.ndarray, p1: np.ndarray, fin, surface, *, thickness: float,
                  gap: float, legs: tuple[float, float]) -> np.ndarray:
    """Mid-surface (2, 4, 3) of a fixing: a bent angle of the fin's sheet on the fin's foot
    ``p0 -> p1`` (a stretch of its ``a`` edge, on the design surface), one leg flat on the fin,
    the other flat on the surface (the building), ``gap`` off both.

    ``fin`` / ``surface`` are ``(n, v)`` as for :func:`bracket_panels`: the unit normal turned
    towards the fixing and the unit direction from the foot into the fin, and along the
    surface away from the fin. The fin's mid-plane is ``t/2`` inside its face, the surface is
    the face itself; ``legs`` are the leg lengths (fin, surface). Quads as
    :func:`bracket_panels`: leg 1 (on the fin) from its free edge to the bend, leg 2 from the
    bend to its free edge.
    """
    (n1, v1), (n2, v2) = fin, surface
    x = corner_point(n1, n2, thickness + gap, 0.5 * thickness + gap)
    c0, c1 = p0 + x, p1 + x
    l1, l2 = legs
    return np.array([[c0 + l1 * v1, c0, c1, c1 + l1 * v1],
                     [c0, c0 + l2 * v2, c1 + l2 * v2, c1]])


def corners(v_cont: list, v_butt: np.ndarray, line: np.ndarray,
            obstacles=()) -> list[tuple[int, float]]:
    """The panels of the continuous plate whose corners with the butted part can take a bracket.

    ``v_cont`` are the in-plane directions (from the node line) of the continuous plate's
    panels at the node, ``v_butt`` that of the butted part, ``line`` the node line direction.
    Returns ``[(index, angle in degrees)]`` of the corners between :data:`MIN_BRACKET_ANGLE`
    and :data:`MAX_BRACKET_ANGLE` that no other panel of the plate, nor any direction in
    ``obstacles`` (other parts' panels and brackets at the node), lies in, most open first.
    """
    u = line / np.linalg.norm(line)

    def ang(v):      # signed angle from v_butt to v about the node line, degrees
        return float(np.degrees(np.arctan2(_cross(v_butt, v) @ u, v_butt @ v)))

    angles = [ang(v) for v in v_cont]
    out = []
    for i, a in enumerate(angles):
        phi = abs(a)
        if not MIN_BRACKET_ANGLE <= phi <= MAX_BRACKET_ANGLE:
            continue
        # another panel of the plate inside this corner would be in the bracket's way
        if any(j != i and np.sign(b) == np.sign(a) and abs(b) < phi for j, b in enumerate(angles)):
            continue
        inside = [ang(o) for o in obstacles]
        if any(np.sign(b) == np.sign(a) and 0.5 < abs(b) < phi - 0.5 for b in inside):
            continue
        out.append((i, phi))
    return sorted(out, key=lambda x: -x[1])


def trim_corner(quad, cc, oc, panels, pa, m_end, gap, h, *, min_cos: float = 0.2,
                line: np.ndarray | None = None) -> np.ndarray:
    """Corner ``cc`` of an end panel moved along its edge towards ``oc`` until the end face
    (``+-h m_end``) clears every panel ``(n, v)`` of the crossing plate by ``gap`` from its
    mid-plane (``pa`` a point of the node line). With ``line`` (unit direction of the node
    line) the edge where the plate's faces meet at a fold (``pa + h m``, mitre ``m``) is kept
    ``gap - h`` clear of the end face too. Raises :class:`_Untrimmable`."""
    u = quad[oc] - quad[cc]
    L = np.linalg.norm(u)
    if not L > 0:
        raise _Untrimmable("its edge has zero length")
    u = u / L
    s_req = 0.0
    for _ in range(4):      # laterals move a little with the trim: iterate
        base = quad[cc] + s_req * u
        s_new = -np.inf
        pm, pp = base - h * m_end - pa, base + h * m_end - pa
        for nk, vk in panels:
            cos = u @ nk
            if cos < min_cos:
                raise _Untrimmable(f"its edge meets the plate at "
                                   f"{np.degrees(np.arcsin(np.clip(cos, -1, 1))):.1f} deg")
            lm, lp = pm @ vk, pp @ vk
            pts = [x for x, l in ((pm, lm), (pp, lp)) if l >= 0 or len(panels) == 1]
            if (lm < 0) != (lp < 0):   # the end face crosses the fold line
                pts.append(pm + (lm / (lm - lp)) * (pp - pm))
            for x in pts:
                s_new = max(s_new, s_req + (gap - x @ nk) / cos)
        if len(panels) > 1:
            # a point behind every panel's fold line is next to the mitred (convex) corner of
            # the plate: it clears the plate once it clears the face plane of any panel
            for x in (pm, pp):
                if all(x @ vk < 0 for _, vk in panels):
                    s_new = max(s_new, min(s_req + (gap - x @ nk) / (u @ nk) for nk, _ in panels))
            if line is not None and abs(panels[0][0] @ panels[1][0]) < 0.9999:
                # the plate's fold edge on this side must stay behind the end face
                edge = h * _miter(panels[0][0], panels[1][0])
                rel = base - pa
                pc = edge + ((rel - edge) @ line) * line           # at the height of this corner
                w = _cross(m_end, line)
                w = w / np.linalg.norm(w) * (1.0 if _cross(m_end, line) @ u >= 0 else -1.0)
                npan = m_end / np.linalg.norm(m_end)
                if abs((pc - rel) @ npan) <= h + (gap - h) and u @ w > 0.05:
                    s_new = max(s_new, s_req + ((gap - h) - (rel - pc) @ w) / (u @ w))
        if not np.isfinite(s_new):
            raise _Untrimmable("its end does not lie over the other plate's panels")
        done = abs(s_new - s_req) <= 1e-12 * L
        s_req = s_new
        if done:
            break
    if s_req >= 0.5 * L:
        raise _Untrimmable(f"panel too short ({L:.3g}) to trim by {s_req:.3g}")
    return quad[cc] + s_req * u


def butt_trim(quad: np.ndarray, start: bool, panels, pa: np.ndarray, gap: float, h: float, *,
              min_sine: float = MIN_TRIM_SINE):
    """Trim an end panel (``start``: its ``a_i b_i`` edge, else ``a_j b_j``) against a plate.

    ``panels`` are the plate's ``(n, v)`` at the node, ``pa`` a point of the node line. The end
    cap is laid along the plate's mean plane. An edge meeting a panel of the plate at less than
    ``asin(min_sine)`` cannot be trimmed (:data:`MIN_TRIM_SINE`). Returns ``(moved corners
    {index: point}, end mitre vector, mean plate normal turned towards the part)``; raises
    :class:`_Untrimmable`.
    """
    (ia, ib), (ja, jb) = ((0, 3), (1, 2)) if start else ((1, 2), (0, 3))
    panels = _facing(panels, quad, start, pa)
    nbar = sum((nk for nk, _ in panels), np.zeros(3))
    if not np.linalg.norm(nbar) > 1e-6:
        raise _Untrimmable("no usable panel of the other plate there")
    nbar = nbar / np.linalg.norm(nbar)
    npan = quad_normals(quad[None])[0]
    d = npan @ nbar
    if 1.0 - d * d < 0.04:
        # nearly parallel plates (< 11.5 deg): an end cap along the plate would be a long
        # sliver; cut the end square to the part instead and pull it back until it clears
        m_end = npan
    else:
        # end cap along the other plate's mean plane: m.n_panel = 1, m.nbar = 0
        m_end = (npan - d * nbar) / (1.0 - d * d)
    line = quad[ib] - quad[ia]
    line = line / np.linalg.norm(line)
    moved = {cc: trim_corner(quad, cc, oc, panels, pa, m_end, gap, h, min_cos=min_sine, line=line)
             for cc, oc in ((ia, ja), (ib, jb))}
    if not all(np.isfinite(x).all() for x in moved.values()):
        raise _Untrimmable("trim failed (non-finite)")
    return moved, m_end, nbar


def trim_further(quad: np.ndarray, start: bool, panels, pa: np.ndarray, m_end: np.ndarray,
                 moved: dict, gap: float, h: float) -> dict:
    """The corners ``moved`` by :func:`butt_trim` moved further along their edges, where needed,
    until the end face (mitre ``m_end``) also clears the plate ``panels`` ``[(n, v)]``, e.g. a
    strip of the same family that ends at the same node on the same side of the plate (the
    two would overlap in the corner they make). ``quad`` is the untrimmed panel. Raises
    :class:`_Untrimmable`."""
    (ia, ib), (ja, jb) = ((0, 3), (1, 2)) if start else ((1, 2), (0, 3))
    panels = _facing(panels, quad, start, pa)
    out = dict(moved)
    for cc, oc in ((ia, ja), (ib, jb)):
        x = trim_corner(quad, cc, oc, panels, pa, m_end, gap, h)
        u = quad[oc] - quad[cc]
        if (x - quad[cc]) @ u > (out[cc] - quad[cc]) @ u:
            out[cc] = x
    return out


def mitre_trim(quad: np.ndarray, start: bool, seam: np.ndarray, pa: np.ndarray,
               gap: float) -> dict:
    """Corners of a mitred end panel moved back from the fold's bisector plane by ``gap``.

    The two parts of a strip split on a mild fold meet on the bisector plane of the fold
    (unit normal ``seam``, through the node line at ``pa``); each is trimmed back by ``gap``
    (``clearance/2``) so that the parts leave the clearance between them, like a butt joint,
    and can be put in one after the other. ``start``: the panel's ``a_i b_i`` end (corners 0,
    3 moved along the edges to 1, 2), else its ``a_j b_j`` end (corners 1, 2 moved to 0, 3).
    A corner moves ``s = gap / (u . seam)`` along its edge ``u`` (``seam`` turned towards the
    panel), so the end cap, which contains the mitre vector of the fold (in the bisector plane),
    stays parallel to that plane. Returns ``{corner index: new point}``; raises
    :class:`_Untrimmable` if an edge runs (nearly) along the plane or the panel is too short.
    """
    (ia, ib), (ja, jb) = ((0, 3), (1, 2)) if start else ((1, 2), (0, 3))
    s_n = seam if far_side(quad, start, pa) @ seam >= 0 else -seam
    out = {}
    for cc, oc in ((ia, ja), (ib, jb)):
        u = quad[oc] - quad[cc]
        L = float(np.linalg.norm(u))
        cos = u @ s_n / L if L > 0 else 0.0
        if not cos > 0.05:
            raise _Untrimmable(f"its edge runs along the mitre plane ({np.degrees(np.arcsin(min(1.0, max(-1.0, cos)))):.1f} deg)")
        s = gap / cos
        if s >= 0.5 * L:
            raise _Untrimmable(f"panel too short ({L:.3g}) to trim by {s:.3g}")
        out[cc] = quad[cc] + (s / L) * u
    return out


#: degrees: a plate panel that meets a part's end panel within this of a straight, flat
#: continuation (into directions at least ``180 -`` this apart, normals within this) continues
#: it: the two are joined on a seam (a splice plate across it), not butted
CONTINUE_ANGLE = 12.0


def continues(n_end: np.ndarray, v_end: np.ndarray, n_other: np.ndarray, v_other: np.ndarray, *,
              tol: float = CONTINUE_ANGLE) -> bool:
    """Whether a plate panel (unit normal ``n_other``, unit direction ``v_other`` from the node
    line into it) continues an end panel (``n_end``, ``v_end``) through the node line, flat
    within ``tol`` degrees: a fin of the other family that carries the end's fin on (the
    remesher's two families meet that way at a boundary corner).

    >>> x, y, z = np.eye(3)
    >>> continues(z, x, z, -x), continues(z, x, y, -x)
    (True, False)
    """
    c = np.cos(np.radians(tol))
    return bool(v_end @ v_other <= -c and abs(n_end @ n_other) >= c)


def seam_trim(quad: np.ndarray, start: bool, seam: np.ndarray, pa: np.ndarray, gap: float,
              others, m_end: np.ndarray, clear: float, h: float) -> dict:
    """Corners of an end panel that ends on a seam with a plate panel continuing it: moved back
    from the seam plane (unit normal ``seam``, through the node line at ``pa``) by ``gap``
    (:func:`mitre_trim`), and further where needed so that its end face (mitre ``m_end``,
    half thickness ``h``) clears the plate panels ``others`` ``[(n, v)]`` that meet it there
    at an angle by ``clear`` (:func:`trim_corner`). Raises :class:`_Untrimmable`."""
    moved = mitre_trim(quad, start, seam, pa, gap)
    if not others:
        return moved
    (ia, ib), (ja, jb) = ((0, 3), (1, 2)) if start else ((1, 2), (0, 3))
    panels = _facing(others, quad, start, pa)
    for cc, oc in ((ia, ja), (ib, jb)):
        x = trim_corner(quad, cc, oc, panels, pa, m_end, clear, h)
        u = quad[oc] - quad[cc]
        if (x - quad[cc]) @ u > (moved[cc] - quad[cc]) @ u:
            if (x - quad[cc]) @ u >= 0.5 * (u @ u):
                raise _Untrimmable("panel too short to trim clear of the plate")
            moved[cc] = x
    return moved


def into_direction(quad: np.ndarray, start: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(a, b, v)`` of a panel's end node line (``start``: ``a_i b_i``) and the unit direction
    from that line into the panel, square to it: towards the panel's centre, turned round where
    the panel lies on the other side of that line (:func:`toward_panel`)."""
    a, b = (quad[0], quad[3]) if start else (quad[1], quad[2])
    return a, b, direction_into(quad, start, a, b)


def direction_into(quad: np.ndarray, start: bool, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Unit direction (3,) from the node line ``a -> b`` into ``quad`` (4, 3), which ends on it
    (``start``: its ``a_i b_i`` edge), square to the line: towards the panel's centre, turned
    round to the side the panel lies on along the line where the panel is a dart whose centre
    is across it (:func:`toward_panel`). The line may be the node's, which a trimmed end
    stands a little off.

    >>> q = np.array([[0, 0, 0], [2, 0, 0], [2, 0, 1], [0, 0, 1.0]])
    >>> direction_into(q, True, q[0], q[3]).round(6).tolist()
    [1.0, 0.0, 0.0]
    """
    u = (b - a) / np.linalg.norm(b - a)
    v = quad.mean(axis=0) - a
    v = v - (v @ u) * u
    return toward_panel(v / np.linalg.norm(v), quad, start)


def toward_panel(v: np.ndarray, quad: np.ndarray, start: bool, normal=None) -> np.ndarray:
    """The direction ``v`` (3,), square to an end node line of ``quad`` (4, 3) (``start``: its
    ``a_i b_i`` edge, corners 0, 3; else ``a_j b_j``, corners 1, 2), turned round if it points
    away from the side of that line the panel lies on there: the left of the edge as the quad's
    outline runs (3 -> 0, or 1 -> 2) seen from its Newell normal (``normal``, else computed).

    The direction to the panel's centre (how ``v`` is found) is on that side for a convex
    panel, but not for a sheared dart whose far edge runs across the node line's extension
    (one corner reflex): a butt trim that took its side from the centre left the butted end
    standing in that panel (example 7c at 700dfc6, 10.7 mm3).

    >>> dart = np.array([[0, 0, 0], [7, -0.4, 0], [10.8, 0.7, 0], [4, 0, 0.0]])  # reflex at b_i
    >>> bool(dart.mean(axis=0)[1] > 0), toward_panel(np.array([0, 1.0, 0]), dart, True)
    (True, array([-0., -1., -0.]))
    """
    n = quad_normals(quad[None])[0] if normal is None else normal
    edge = quad[0] - quad[3] if start else quad[2] - quad[1]
    return -v if _cross(n, edge) @ v < 0 else v


def far_side(quad: np.ndarray, start: bool, pa: np.ndarray) -> np.ndarray:
    """The vector (3,) from ``pa``, a point of an end node line of ``quad`` (4, 3) (``start``:
    its ``a_i b_i`` edge), to the middle of the panel's far edge, its part square to the line
    turned round where that middle lies across the line from the panel (a sheared dart whose
    far edge runs across the line's extension, :func:`toward_panel`): its dot product with a
    plate's normal says which side of a plate through that line the panel stands on.

    The far edge's middle alone put example 7c's dart at node 84 across the plate it was
    butted against in a first build. Such an end is untrimmable either way (the edge from its
    reflex corner runs to the other side of the plate) and the joint changes; with the side
    right, the angle its message names is that edge's.

    >>> dart = np.array([[0, 0, 0], [7, -0.4, 0], [10.8, 0.7, 0], [4, 0, 0.0]])  # reflex at b_i
    >>> far_side(dart, True, dart[0]).round(2)                      # middle (8.9, 0.15, 0)
    array([ 8.9 , -0.15,  0.  ])
    """
    (ia, ib), (ja, jb) = ((0, 3), (1, 2)) if start else ((1, 2), (0, 3))
    far = quad[[ja, jb]].mean(axis=0) - pa
    u = quad[ib] - quad[ia]
    u = u / np.linalg.norm(u)
    w = far - (far @ u) * u
    return far - 2.0 * w if toward_panel(w, quad, start) @ w < 0 else far


def _facing(panels, quad: np.ndarray, start: bool, pa: np.ndarray) -> list:
    """``panels`` ``[(n, v)]`` with each plate normal ``n`` (3,) turned to the side of the
    plate that ``quad`` (4, 3), ending on the node line through ``pa``, stands on
    (:func:`far_side`)."""
    far = far_side(quad, start, pa)
    return [(n if far @ n >= 0 else -n, v) for n, v in panels]


def fold_deg(n1: np.ndarray, n2: np.ndarray) -> float:
    """Unsigned angle between two unit normals, degrees."""
    return _fold_deg(n1, n2)


class TabGeometry(NamedTuple):
    """A tab bent from a butted part's end (:func:`tab_panel`): ``moved``, the end panel's two
    end corners on the bend line (``{corner index: point}``); ``tab``, the tab's quad (4, 3) in
    the order of the part's panels (``a_i a_j b_j b_i``: before the end panel at a start,
    after it at an end); ``fold``, the bend (degrees; 180 less the corner it fills); ``leg``,
    the tab's length from the bend line to its free edge (at the free edge's middle)."""

    moved: dict
    tab: np.ndarray
    fold: float
    leg: float


def tab_panel(quad: np.ndarray, start: bool, host: np.ndarray, n_host: np.ndarray,
              free: np.ndarray, *, thickness: float, gap: float, rise: float = 0.0,
              others: np.ndarray | None = None, min_sine: float = MIN_TRIM_SINE) -> TabGeometry:
    """The tab bent from the end of a butted part's end panel ``quad`` (4, 3) (``start``: its
    ``a_i b_i`` end, corners 0 and 3; else corners 1 and 2) onto the face of ``host`` (4, 3),
    the panel of the plate it ends against, instead of a bracket there.

    ``n_host`` is the host panel's unit normal turned towards the butted part (the face the
    tab lies on); ``free`` (2, 3) the two ends of the tab's free edge, the ``a`` side first
    (the free edge of the bracket leg it replaces: the stretch the bracket found room for).
    The tab's mid-plane is ``thickness + gap`` off the host's mid-plane (more where a corner
    of a panel that is planar only to the structure's tolerance stands out), so its face
    stays ``gap`` off the host's face (``clearance/2``, as the butted end it replaces). The
    end panel's end corners move along its ``a`` and ``b`` edges onto that plane: the bend
    line, where the end panel and the tab meet. The fold's mitred outer corner then lies on
    the end panel's face plane and the tab's: no nearer the host than the tab.

    The tab lies up to ``rise`` farther off the host where it must: where the end is trimmed
    back past that plane already (it clears another part's end there: the tab then lies on
    the plane through the end's farther corner), and where the plate folds at the node
    towards the butted part, so that its other panels there (``others``, (k, 4, 3) quads)
    would reach the fold's corners.

    Raises :class:`_Untrimmable` where there is no such tab: an edge meets the host at less
    than ``asin(min_sine)``, the tab would have to lie more than ``rise`` off the host, the
    panel is too short, or the tab is no convex quad beyond the bend.

    >>> q = np.array([[0, 1.75, 0], [0, 50, 0], [0, 50, 40], [0, 1.75, 40.0]])  # a butted end
    >>> host = np.array([[-60, 0, -5], [60, 0, -5], [60, 0, 45], [-60, 0, 45.0]])
    >>> g = tab_panel(q, True, host, np.array([0, 1.0, 0]), np.array([[20, 0, 10], [20, 0, 30.0]]),
    ...               thickness=3.0, gap=0.25)
    >>> g.moved[0].tolist(), round(g.fold, 1), round(g.leg, 1)
    ([0.0, 3.25, 0.0], 90.0, 20.0)
    """
    t, h = float(thickness), 0.5 * float(thickness)
    n_host = np.asarray(n_host, float)
    centre = host.mean(axis=0)
    proud = max(0.0, float(((host - centre) @ n_host).max()))
    base = float(centre @ n_host) + t + gap + proud      # the tab's mid-plane: x . n_host
    (ia, ib), (ja, jb) = ((0, 3), (1, 2)) if start else ((1, 2), (0, 3))
    level = max(base, float(quad[ia] @ n_host), float(quad[ib] @ n_host))
    planes = _host_planes(others, n_host)
    for _ in range(4):
        if level - base > rise + 1e-9 * t:
            raise _Untrimmable(f"the tab would lie {level - base + gap:.3g} off the plate "
                               f"(the end is trimmed back past its bend, or the plate folds "
                               f"towards it)")
        moved = _bend_line(quad, ((ia, ja), (ib, jb)), n_host, level, min_sine)
        ba, bb = moved[ia], moved[ib]
        end = quad.copy()
        end[ia], end[ib] = ba, bb
        f2 = np.asarray(free, float)
        f2 = f2 - (f2 @ n_host - level)[:, None] * n_host[None]
        tab = np.array([f2[0], ba, bb, f2[1]]) if start else np.array([ba, f2[0], f2[1], bb])
        n_end, n_tab = quad_normals(np.array([end, tab]))
        if n_end @ n_tab <= -0.999:
            raise _Untrimmable("the tab would fold back onto its end panel")
        m = _miter(n_end, n_tab)
        # the bend's corners (both faces) stay off the host's other panels' faces (the
        # mitred outer corner stands out past the bend a real bend's radius keeps inside)
        corners = np.array([x + sg * h * m for x in (ba, bb) for sg in (1.0, -1.0)])
        short = max((1.01 * h - float((corners @ no - off).min()) for no, off in planes),
                    default=0.0)
        if short <= 1e-9 * t:
            break
        level += short
    else:
        raise _Untrimmable("the plate folds towards the tab at the node")
    leg = _tab_leg(tab, ba, bb, f2, n_host, t)
    fold = _fold_deg(n_end, n_tab)
    if not fold < 180.0 - MIN_BRACKET_ANGLE + 1e-9:
        raise _Untrimmable(f"the tab would bend {fold:.0f} deg")
    return TabGeometry(moved, tab, fold, leg)


def _host_planes(others: np.ndarray | None, n_host: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """``[(unit normal, offset)]``: the face towards the host's side of each of the host
    plate's other panels at the node (``others``, (k, 4, 3)), ``x . normal = offset`` (the
    normal turned towards ``n_host``; the offset includes how far a corner stands out of a
    panel planar only to the structure's tolerance); one in the host's plane adds nothing."""
    planes = []
    for o in (() if others is None else np.asarray(others, float).reshape(-1, 4, 3)):
        no = quad_normals(o[None])[0]
        no = no if no @ n_host >= 0 else -no
        if abs(no @ n_host) < 1.0 - 1e-9:
            c = o.mean(axis=0)
            planes.append((no, float(c @ no) + max(0.0, float(((o - c) @ no).max()))))
    return planes


def _bend_line(quad: np.ndarray, edges: tuple, n_host: np.ndarray, level: float,
               min_sine: float) -> dict:
    """``{corner index: point}``: the end corners of the end panel ``quad`` (4, 3) moved along
    its edges ``edges`` (``((end corner, other corner), ...)``, its ``a`` and ``b`` edges) onto
    the plane ``x . n_host = level`` (lengths as the quad's; a corner past the plane already
    stays). Raises :class:`_Untrimmable` where an edge has no length, meets the plane at less
    than ``asin(min_sine)`` or would lose half its length or more."""
    moved = {}
    for cc, oc in edges:
        u = quad[oc] - quad[cc]
        L = float(np.linalg.norm(u))
        if not L > 0:
            raise _Untrimmable("its edge has zero length")
        u = u / L
        cos = float(u @ n_host)
        if cos < min_sine:
            raise _Untrimmable(f"its edge meets the plate at "
                               f"{np.degrees(np.arcsin(np.clip(cos, -1, 1))):.1f} deg")
        s = (level - float(quad[cc] @ n_host)) / cos
        if s >= 0.5 * L:
            raise _Untrimmable(f"panel too short ({L:.3g}) to bend a tab {s:.3g} from its end")
        moved[cc] = quad[cc] + max(s, 0.0) * u
    return moved


def _tab_leg(tab: np.ndarray, ba: np.ndarray, bb: np.ndarray, free: np.ndarray,
             n_host: np.ndarray, thickness: float) -> float:
    """The length of the tab ``tab`` (4, 3) from its bend line ``ba -> bb`` to the middle of
    its free edge ``free`` (2, 3). Raises :class:`_Untrimmable` where the free edge does not
    lie more than ``thickness`` beyond the bend (both its ends) or the tab is no convex quad
    (its corners do not all turn the same way about ``n_host``)."""
    e = (bb - ba) / np.linalg.norm(bb - ba)
    w = free.mean(axis=0) - ba
    w = w - (w @ e) * e
    leg = float(np.linalg.norm(w))
    if not leg > thickness or min((f - ba) @ w for f in free) <= thickness * leg:
        raise _Untrimmable("the tab's free edge does not lie beyond its bend")
    turns = [float(_cross(tab[i] - tab[i - 1], tab[(i + 1) % 4] - tab[i]) @ n_host)
             for i in range(4)]
    if not (all(x > 0 for x in turns) or all(x < 0 for x in turns)):
        raise _Untrimmable("the tab is no convex quad")
    return leg
