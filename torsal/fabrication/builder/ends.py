"""Part ends: butt joints with brackets, butts at sharp folds, mitres with splice plates
(issue 15; the rules are in :mod:`torsal.fabrication.joints`).

:class:`EndJoiner` trims every part end that meets another plate (T and L junctions,
crossings where a strip is split, splits at sharp folds) and records the joint and its
connector part (``C-N<node>-<i>``), or mitres the ends of a strip split on a mild fold with a
splice plate across the seam. Lengths in the fin system's ``unit``.

The butt trims are :class:`~.butts.ButtTrimmer`'s, the connectors
:class:`~.connectors.ConnectorPlacer`'s; this module decides which end gets which joint.
"""
from __future__ import annotations

import warnings

import numpy as np

from ..joints import _Untrimmable, direction_into, mitre_trim
from ..model import Part, _cross
from .butts import ButtTrimmer, _slide  # noqa: F401  (_slide: importable here as before)
# importable from here as before the connectors had a module of their own
from .connectors import (CONNECTOR_GAP, ConnectorPlacer, _seam_legs, _SeamLegs,  # noqa: F401
                         _starts_on, seam_splice)
from .strips import _Strips


def _seam_plane(p: Part) -> tuple[np.ndarray, np.ndarray] | None:
    """The bisector plane of the mitred fold at the start of part ``p``: a point on it (a copy
    of the node point ``a``, so trimming the panel does not move it) and its unit normal; None
    where the fold's mitre runs along the node line (no plane)."""
    a, b = p.panels[0][0].copy(), p.panels[0][3]
    seam = _cross(b - a, p.miters[0])
    if not np.linalg.norm(seam) > 0:
        return None
    return a, seam / np.linalg.norm(seam)


class EndJoiner:
    """Joins the part ends of a fin system ``fs`` under construction: fills its ``joints``,
    connectors, ``untrimmed_joints``, ``unconnected_joints`` and the faces each butted part
    ends against (``_walls``, for its insertion direction)."""

    def __init__(self, fs):
        self.fs = fs
        self.butts = ButtTrimmer(fs)
        self.connectors = self.butts.connectors

    def _join_ends(self, st: "_Strips", part_of_strip, plate, cont) -> None:
        """Every part end at a node where another plate is: butt-trimmed against it with a
        bracket (T, L, and crossings where the strip is split), butted against the previous
        part at a sharp fold, or mitred with a splice plate."""
        fs = self.fs
        gap, h = 0.5 * fs.thickness + 0.5 * fs.clearance, 0.5 * fs.thickness
        present = st.passes | st.ends
        # where several strips of one family end at a node (and none passes), the first is the
        # base; each other butts against the base and those butted before it
        base: dict[tuple[int, int], list] = {}
        for (fam, v), lst in plate.items():
            if not st.passes[fam, v] and len({ref[0] for _, _, ref in lst}) >= 2:
                base[(fam, v)] = [e for e in lst if e[2][0] == lst[0][2][0]]
        fs._dirs: dict[int, list] = {}
        for (fam, v), lst in plate.items():
            fs._dirs.setdefault(v, []).extend(d for _, d, _ in lst)
        fs._bracket_dirs: dict[int, list] = {}
        for si, parts in enumerate(part_of_strip):
            fam = st.fins[si].family
            for p in parts:
                trimmed = list(p.trimmed)
                for end in (0, 1):
                    node = int(p.nodes[-end])
                    kind = p.ends[end]
                    other = 1 - fam
                    g = plate.get((other, node), []) if fam in (0, 1) else []
                    # both plates split at this node: family 1's halves are bracketed to both
                    # halves of family 0, which bridges family 0's seam
                    bridged = fam in (0, 1) and not cont[other, node] and len(g) >= 2
                    b = base.get((fam, node))
                    swapped = fs._base_at.get(node) if fam in (0, 1) else None
                    # a seam inside the other family's slot (.seams.SlotSeams): the crossing
                    # holds both ends, no bracket, no splice plate
                    seamed = kind == "miter" and (fam, node) in fs._seam_crossings
                    if seamed:
                        butted = False
                    elif swapped is not None:
                        # the joint changed here (an end that could not be trimmed): the parts
                        # of the other family end against this family's plate, or this one's
                        # against the other's
                        butted = swapped == other and bool(present[other, node])
                    else:
                        butted = fam in (0, 1) and (cont[other, node] or
                                                    (fam == 1 and present[other, node]))
                    if butted:
                        trimmed[end] = self.butts._butt(p, end, node, g, st, gap, h,
                                                  bridge=fam == 1 and bridged)
                    elif b is not None and b[0][2][0] != si and kind in ("end", "dropped"):
                        trimmed[end] = self.butts._butt(p, end, node, list(b), st, gap, h)
                        b += [e for e in plate.get((fam, node), []) if e[2][0] == si]
                    elif kind == "fold" and end == 0:
                        prev = self._previous(parts, p, st.quads[si])
                        trimmed[0] = self.butts._fold_butt(p, prev, st.quads[si], node, gap, h,
                                                     bracket=not bridged)
                    elif kind == "miter" and end == 0 and not bridged and not seamed:
                        prev = self._previous(parts, p, st.quads[si])
                        if prev is not None:
                            self.connectors._splice(prev, p, node, g)
                    if kind == "miter" and end == 0:
                        prev = self._previous(parts, p, st.quads[si])
                        self._seam_walls(prev, p)
                        if not butted:      # (butted: both ends trimmed against the plate)
                            self._mitre_gap(prev, p, node)
                p.trimmed = tuple(trimmed)
        self._warn_untrimmed(stacklevel=5)
        if fs.unconnected_joints:
            u = fs.unconnected_joints
            warnings.warn(
                f"{len(u)} joints have no connector (no room for a bracket or splice plate): "
                + "; ".join(f"{n} at node {v} ({w})" for n, v, w in u[:6])
                + (" ..." if len(u) > 6 else "") + "; fasten them on site; see "
                "FinSystem.unconnected_joints", stacklevel=5)

    @staticmethod
    def _previous(parts, p: Part, quads) -> Part | None:
        """The part of the same strip that ends where ``p`` starts."""
        k = len(quads)
        i_prev = p.span[0] - 1 if p.span[0] > 0 else k - 1
        return next((o for o in parts if o.span[1] == i_prev + 1 and o is not p), None)
    def _seam_walls(self, prev: Part | None, p: Part) -> None:
        """The two parts of a strip split on a mitre touch on the fold's bisector plane: each is
        a wall of the other (normal of that plane, turned towards it) for its insertion."""
        fs = self.fs
        plane = None if prev is None else _seam_plane(p)
        if plane is None:
            return
        a, seam = plane
        b = p.panels[0][3]
        for q, quad, other, end in ((p, p.panels[0], prev, 0), (prev, prev.panels[-1], p, -1)):
            n = seam if direction_into(quad, end == 0, a, b) @ seam >= 0 else -seam
            fs._walls.setdefault(q.name, []).append(n)
            # (the other part, the plane's normal turned towards this one, this one's panel
            # there, the node)
            fs._seams.setdefault(q.name, []).append((other.name, n, end % len(q.panels),
                                                     int(q.nodes[0 if end == 0 else -1])))

    def _mitre_gap(self, prev: Part | None, p: Part, node: int) -> None:
        """Trim both parts of a mitred seam back from the fold's bisector plane by
        ``clearance/2`` (:func:`~.joints.mitre_trim`), so that they do not touch (after the
        splice plate and the walls, which are placed on the untrimmed node line)."""
        fs = self.fs
        plane = None if prev is None or not fs.clearance > 0 else _seam_plane(p)
        if plane is None:
            return
        a, seam = plane
        for q, start in ((p, True), (prev, False)):
            quad = q.panels[0 if start else -1]
            try:
                moved = mitre_trim(quad, start, seam, a, 0.5 * fs.clearance)
            except _Untrimmable as why:
                fs.untrimmed_joints.append((q.name, node, f"mitred seam: {why}"))
                si = getattr(fs, "_strip_of", {}).get(p.name)
                if si is not None and (si, p.span[0]) not in fs._avoid_splits:
                    # move the split off this node line in the next build
                    fs._bad_seams.add((si, p.span[0]))
                else:
                    self.butts._note_untrimmable(q, 0 if start else len(q.panels) - 1, node,
                                           f"mitred seam: {why}")
                continue
            for cc, x in moved.items():
                quad[cc] = x
    def _warn_untrimmed(self, stacklevel: int = 4) -> None:
        fs = self.fs
        untrimmed = fs.untrimmed_joints
        if untrimmed:
            warnings.warn(
                f"{len(untrimmed)} part ends could not be butt-trimmed (or mitred) against the adjoining "
                f"plate and overlap it: " + "; ".join(f"{n} at node {v} ({w})" for n, v, w in untrimmed[:6])
                + (" ..." if len(untrimmed) > 6 else "") + "; see FinSystem.untrimmed_joints",
                stacklevel=stacklevel)
