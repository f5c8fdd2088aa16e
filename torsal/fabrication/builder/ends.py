"""Part ends: butt joints with brackets, butts at sharp folds, mitres with splice plates
(issue 15; the rules are in :mod:`torsal.fabrication.joints`).

:class:`EndJoiner` trims every part end that meets another plate (T and L junctions,
crossings where a strip is split, splits at sharp folds) and records the joint and its
connector part (``C-N<node>-<i>``), or mitres the ends of a strip split on a mild fold with a
splice plate across the seam. Lengths in the fin system's ``unit``.
"""
from __future__ import annotations

import warnings
from typing import NamedTuple

import numpy as np

from ..joints import (BRACKET_TRIM_SINE, _Untrimmable, butt_trim, continues, corners,
                      direction_into, into_direction, mitre_trim, place_connector, seam_trim,
                      trim_further)
from ..model import (CONNECTOR_FAMILY, FAMILY_COLORS, Joint, JointKind, Part, PartId, _cross,
                     _fold_deg, _miter, quad_normals)
from .strips import _Strips

#: gap left between a connector and the plates it lies on, as a fraction of the thickness
#: (so that touching faces are not coincident for the boolean checks; 0.03 mm at 3 mm)
CONNECTOR_GAP = 0.01


def _slide(n_plate: np.ndarray, quad: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Direction a butted part slides into place along: the line where its plane meets the
    plate's (so its trimmed end face slides along the plate, ``clearance/2`` off it),
    oriented like ``axis`` (the node axis, ``a_i - b_i``, as for an egg-crate)."""
    d = _cross(n_plate, quad_normals(quad[None])[0])
    if not np.linalg.norm(d) > 1e-9:
        return axis / np.linalg.norm(axis)
    d = d / np.linalg.norm(d)
    return d if d @ axis >= 0 else -d


def _seam_plane(p: Part) -> tuple[np.ndarray, np.ndarray] | None:
    """The bisector plane of the mitred fold at the start of part ``p``: a point on it (a copy
    of the node point ``a``, so trimming the panel does not move it) and its unit normal; None
    where the fold's mitre runs along the node line (no plane)."""
    a, b = p.panels[0][0].copy(), p.panels[0][3]
    seam = _cross(b - a, p.miters[0])
    if not np.linalg.norm(seam) > 0:
        return None
    return a, seam / np.linalg.norm(seam)


def _starts_on(quad: np.ndarray, a: np.ndarray, b: np.ndarray) -> bool:
    """Whether the edge of ``quad`` (4, 3) on the node line ``a -> b`` is its ``a_i b_i`` edge
    (corners 0, 3; a trimmed end stands a little off the line), not its ``a_j b_j`` edge."""
    u = (b - a) / np.linalg.norm(b - a)
    r = quad - a
    off = np.linalg.norm(r - np.outer(r @ u, u), axis=1)
    return bool(off[0] + off[3] <= off[1] + off[2])


class _SeamLegs(NamedTuple):
    """The two panels meeting at a seam, seen from its node line: ``v1``, ``v2`` the unit
    directions from the line into each panel (square to the line, :func:`~.joints.direction_into`),
    ``n1``, ``n2`` their normals (:func:`~.model.quad_normals`)."""

    v1: np.ndarray
    v2: np.ndarray
    n1: np.ndarray
    n2: np.ndarray


def _seam_legs(qe: np.ndarray, qp: np.ndarray, a: np.ndarray, b: np.ndarray) -> _SeamLegs:
    """:class:`_SeamLegs` of the panels ``qe``, ``qp`` (4, 3) at the node line ``a -> b``,
    where a splice plate's two legs go."""
    v1, v2 = direction_into(qe, _starts_on(qe, a, b), a, b), direction_into(qp, _starts_on(qp, a, b), a, b)
    return _SeamLegs(v1, v2, quad_normals(qe[None])[0], quad_normals(qp[None])[0])


def seam_splice(e: Part, je: int, p: Part, jp: int, a, b, towards, *, thickness: float,
                gap: float, memo=None):
    """The splice plate across a seam where panel ``je`` of part ``e`` ends on the node line
    ``a -> b`` and panel ``jp`` of part ``p`` carries its fin on (flat within
    :data:`~.joints.CONTINUE_ANGLE`), on the side the unit vector ``towards`` points to, ``gap``
    off both plates' solids (:func:`~.joints.place_connector`). Returns ``(quads (2, 4, 3) or
    None, option)``, the option as ``FinSystem._sites`` keeps them: ``(side1, side2, panel1,
    panel2, direction, fold angle, hosts)``. ``memo``: a kernel cache
    (``FinSystem._cached``)."""
    qe, qp = e.panels[je], p.panels[jp]
    v1, v2, n1, n2 = _seam_legs(qe, qp, a, b)
    n2 = n2 if n2 @ n1 >= 0 else -n2
    fold = _fold_deg(n1, n2)
    s = 1.0 if towards @ n1 >= 0 else -1.0
    opt = ((s * n1, v1), (s * n2, v2), qe, qp, -(n1 + n2) * s, fold, ((e.name, je), (p.name, jp)))
    # p folds at this node line where its other panel stands on the far side of the seam:
    # its mitred edge stands out past the line, under the leg on e
    plates = (e.slab_corners(je, thickness), p.slab_corners(jp, thickness))
    args = (place_connector, a, b, *opt[:4])
    kw = {"thickness": thickness, "gap": gap, "plates": plates}
    q = memo(*args, **kw) if memo is not None else args[0](*args[1:], **kw)
    return q, opt


class EndJoiner:
    """Joins the part ends of a fin system ``fs`` under construction: fills its ``joints``,
    connectors, ``untrimmed_joints``, ``unconnected_joints`` and the faces each butted part
    ends against (``_walls``, for its insertion direction)."""

    def __init__(self, fs):
        self.fs = fs

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
                        trimmed[end] = self._butt(p, end, node, g, st, gap, h,
                                                  bridge=fam == 1 and bridged)
                    elif b is not None and b[0][2][0] != si and kind in ("end", "dropped"):
                        trimmed[end] = self._butt(p, end, node, list(b), st, gap, h)
                        b += [e for e in plate.get((fam, node), []) if e[2][0] == si]
                    elif kind == "fold" and end == 0:
                        prev = self._previous(parts, p, st.quads[si])
                        trimmed[0] = self._fold_butt(p, prev, st.quads[si], node, gap, h,
                                                     bracket=not bridged)
                    elif kind == "miter" and end == 0 and not bridged and not seamed:
                        prev = self._previous(parts, p, st.quads[si])
                        if prev is not None:
                            self._splice(prev, p, node, g)
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

    def _butt(self, p: Part, end: int, node: int, panels, st: "_Strips", gap, h, *,
              bridge: bool = False) -> bool:
        """Trim an end of ``p`` against the other family's plate ``panels`` at ``node`` and put
        a bracket in the corner (in both corners with ``bridge``: the plate is two parts there);
        False (listed in ``untrimmed_joints``) if it cannot be trimmed."""
        fs = self.fs
        j = 0 if end == 0 else len(p.panels) - 1
        quad = p.panels[j]
        n_end, v_end = quad_normals(quad[None])[0], into_direction(quad, end == 0)[2]
        carried = [k for k, (n, v, _) in enumerate(panels) if continues(n_end, v_end, n, v)]
        if carried and self._continuation(p, end, node, panels, carried[0], st, h):
            return True
        try:
            moved, m_end, nbar = fs._cached(butt_trim, quad, end == 0, [(n, v) for n, v, _ in panels],
                                           st.a[node], gap, h)
            # strips of this family that already end here on the same side of the plate meet
            # this one in the corner: its end clears them too
            others = [(n, v) for n, v, nb in fs._ends_at.get((p.family, node), []) if nb @ nbar > 0]
            if others:
                moved = fs._cached(trim_further, quad, end == 0, others, st.a[node], m_end, moved,
                                     gap, h)
        except _Untrimmable as why:
            fs.untrimmed_joints.append((p.name, node, str(why)))
            self._untrimmable(p, j, node, str(why))
            return False
        fs._ends_at.setdefault((p.family, node), []).append(
            (quad_normals(quad[None])[0], into_direction(quad, end == 0)[2], nbar))
        # every face it ends against, turned towards it: its insertion must not close those gaps
        centre = direction_into(quad, end == 0, st.a[node], st.b[node])
        fs._walls.setdefault(p.name, []).extend(
            n if centre @ n >= 0 else -n for n in [n for n, _, _ in panels] + [n for n, _ in others])
        quad0 = quad.copy()
        for cc, x in moved.items():
            quad[cc] = x
        p.miters[0 if end == 0 else -1] = m_end
        cont = [(n, v, self._panel_quad(ref), self._host(ref)) for n, v, ref in panels]
        names = tuple(sorted({fs._where[ref][0].name for _, _, ref in panels}))
        placed = self._bracket(p, j, node, cont, names, st.a[node], st.b[node],
                               insert=_slide(nbar, quad, st.a[node] - st.b[node]),
                               n_corners=2 if bridge else 1, start=end == 0)
        if not placed and self._shallow(quad0, end == 0, panels, st.a[node], gap, h):
            # trimmed along the plate (an edge meets it at under 11.5 deg) and no bracket fits on
            # what is left: not kept unfastened, left out as before (not the joint changed: the
            # other family's ends would butt against this sheared panel, with no room either)
            self._note_untrimmable(p, j, node, "it meets the plate at under "
                                   f"{np.degrees(np.arcsin(BRACKET_TRIM_SINE)):.1f} deg and no "
                                   "bracket fits on it once trimmed")
        return True

    def _continuation(self, p: Part, end: int, node: int, panels, k: int, st: "_Strips",
                      h: float) -> bool:
        """End ``end`` of ``p`` where a panel of the other family's plate (``panels[k]``)
        carries its fin on, flat (:func:`~.joints.continues`): trimmed back from the seam
        between them by the clearance (the other panel is not trimmed; more where the other
        plate folds there, its mitred corner standing out) and clear of the plate's other
        panels, and joined to the carrying plate by a splice plate across the seam, on the side
        away from those panels. False (unchanged) if it cannot be trimmed so."""
        fs = self.fs
        j = 0 if end == 0 else len(p.panels) - 1
        quad = p.panels[j]
        a, b = st.a[node], st.b[node]
        line = (b - a) / np.linalg.norm(b - a)
        n_end = quad_normals(quad[None])[0]
        nk, vk, ref = panels[k]
        nk = nk if nk @ n_end >= 0 else -nk
        m = _miter(n_end, nk)
        seam = _cross(line, m)
        seam = seam / np.linalg.norm(seam)
        rest = [(n, v) for i, (n, v, _) in enumerate(panels) if i != k]
        # the splice plate goes on the side of the seam that no other panel at the node is on
        v_end = into_direction(quad, end == 0)[2]
        away = [w for w in fs._dirs.get(node, []) if min(np.linalg.norm(w - v_end),
                                                           np.linalg.norm(w - vk)) > 1e-6]
        sides = {float(np.sign(w @ n_end)) for w in away if abs(w @ n_end) > 1e-3}
        if len(sides) > 1:
            return False               # plates on both sides of the seam: no room for a splice
        side = -sides.pop() if sides else 1.0
        # the other plate's mitred fold (if it folds here) stands out by h tan(fold / 2)
        fold = max((_fold_deg(nk, n if n @ nk >= 0 else -n) for n, _ in rest), default=0.0)
        fold = max(fold, _fold_deg(n_end, nk))
        gap = fs.clearance + h * np.tan(np.radians(min(fold, 120.0)) / 2)
        try:
            moved = fs._cached(seam_trim, quad, end == 0, seam, a, gap, rest, m,
                               0.5 * fs.thickness + 0.5 * fs.clearance, h)
        except _Untrimmable:
            return False
        for cc, x in moved.items():
            quad[cc] = x
        p.miters[0 if end == 0 else -1] = m
        # parts of this family that end here later (butted against the carrying plate, on
        # either side of it) are trimmed clear of this end too: it stands where the plate's
        # fin goes on, which their trim against the plate alone does not see
        fs._ends_at.setdefault((p.family, node), []).extend(
            (n_end, v_end, side_n) for side_n in (nk, -nk))
        host, i = fs._where[ref]
        # the seam is a wall of both for their paths into place (normal turned to each)
        n_p = seam if direction_into(quad, end == 0, a, b) @ seam >= 0 else -seam
        for q, n_in, panel, other in ((p, n_p, j, host), (host, -n_p, i, p)):
            fs._walls.setdefault(q.name, []).append(n_in)
            fs._seams.setdefault(q.name, []).append((other.name, n_in, panel, node))
        self._seam_splice(p, j, host, i, node, side * n_end, a, b)
        return True

    def _seam_splice(self, e: Part, je: int, p: Part, jp: int, node: int, towards, a, b) -> None:
        """A bent splice plate across the seam where panel ``je`` of ``e`` ends and panel ``jp``
        of ``p`` carries it on, on the side of the seam the unit vector ``towards`` points to
        (no other plate at the node is there; :func:`seam_splice`); the joint is a mitre with
        a splice (the two parts in either order)."""
        fs = self.fs
        q, opt = seam_splice(e, je, p, jp, a, b, towards, thickness=fs.thickness,
                             gap=CONNECTOR_GAP * fs.thickness, memo=fs._cached)
        names = tuple(sorted((e.name, p.name)))
        self._record(JointKind.MITRE_SPLICE, node, names, -opt[0][1], q, opt[4], opt[5], e.name,
                     "the panels are too small for a splice plate",
                     site=(a.copy(), b.copy(), [opt]) if q is not None else None)

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
                    self._note_untrimmable(q, 0 if start else len(q.panels) - 1, node,
                                           f"mitred seam: {why}")
                continue
            for cc, x in moved.items():
                quad[cc] = x

    def _untrimmable(self, p: Part, j: int, node: int, why: str) -> None:
        """Panel ``j`` of ``p``, butted at ``node``, is left out in the next build, unless the
        joint there changes instead (``_swappable``: the other family's parts then butt against
        this plate)."""
        fs = self.fs
        self._note_untrimmable(p, j, node, why)
        si = getattr(fs, "_strip_of", {}).get(p.name)
        if si is not None and p.family in (0, 1):
            fs._swappable[(si, p.span[0] + j)] = (node, p.family)

    def _shallow(self, quad, start: bool, panels, pa, gap, h) -> bool:
        """Whether the end of ``quad`` butted against ``panels`` could be trimmed only because
        its edges may meet the plate at down to :data:`~.joints.MIN_TRIM_SINE`, not
        :data:`~.joints.BRACKET_TRIM_SINE`."""
        try:
            self.fs._cached(butt_trim, quad, start, [(n, v) for n, v, _ in panels], pa, gap, h,
                            min_sine=BRACKET_TRIM_SINE)
        except _Untrimmable:
            return True
        return False

    def _note_untrimmable(self, p: Part, j: int, node: int, why: str) -> None:
        """Remember panel ``j`` of ``p`` (strip index, panel of the strip) to leave it out."""
        fs = self.fs
        si = getattr(fs, "_strip_of", {}).get(p.name)
        if si is not None and p.family in (0, 1):
            fs._untrimmable.append((si, p.span[0] + j, p.name[:-4], int(p.edges[j]), node, why))

    def _panel_quad(self, ref) -> np.ndarray:
        fs = self.fs
        part, i = fs._where[ref]
        return part.panels[i]

    def _host(self, ref) -> tuple[str, int]:
        """(part name, panel index) of the strip panel ``ref``."""
        part, i = self.fs._where[ref]
        return part.name, i

    def _fold_butt(self, p: Part, prev: Part | None, quads, node: int, gap, h, *,
                   bracket: bool = True) -> bool:
        """Butt joint at a split on a sharp fold: the start of part ``p`` is trimmed back until it
        clears the (square) end of the previous part ``prev``; a bracket joins them."""
        fs = self.fs
        k = len(quads)
        i_prev = p.span[0] - 1 if p.span[0] > 0 else k - 1
        nprev = quad_normals(quads[i_prev][None])[0]
        quad = p.panels[0]
        ang = _fold_deg(nprev, quad_normals(quad[None])[0])
        what = f"fold of {ang:.1f} deg to {prev.name if prev else 'the previous part'}"
        pa, pb = quads[p.span[0] % k, 0].copy(), quads[p.span[0] % k, 3].copy()
        line = (pb - pa) / np.linalg.norm(pb - pa)
        into = quads[i_prev].mean(axis=0) - pa
        into = into - (into @ line) * line
        try:
            if not np.linalg.norm(into) > 0:
                raise _Untrimmable("the previous panel has no extent")
            # the previous panel's side of the line, not its centre's (where it is a dart, its
            # bracket's leg went off it: no bracket)
            into = direction_into(quads[i_prev], False, pa, pb)
            moved, m_end, nbar = fs._cached(butt_trim, quad, True, [(nprev, into)], pa, gap, h)
            fs._walls.setdefault(p.name, []).append(nbar)
        except _Untrimmable as why:
            fs.untrimmed_joints.append((p.name, node, f"{what}: {why}"))
            self._note_untrimmable(p, 0, node, f"{what}: {why}")
            return False
        for cc, x in moved.items():
            quad[cc] = x
        p.miters[0] = m_end
        if prev is not None and node >= 0 and bracket:
            self._bracket(p, 0, node, [(nprev, into, prev.panels[-1],
                                        (prev.name, len(prev.panels) - 1))], (prev.name,), pa, pb,
                          insert=_slide(nbar, quad, pa - pb), start=True)
        return True

    def _bracket(self, p: Part, j: int, node: int, cont, names, pa, pb, *, insert,
                 n_corners: int = 1, start: bool) -> int:
        """Bent brackets in the most open corner(s) between panel ``j`` of the butted part ``p``
        and a panel ``(n, v, quad, (part name, panel))`` of the continuous plate ``cont``;
        records the joint(s), and for each bracket the other corners it may move to
        (``_sites``); ``start``: ``p`` ends there with its start. Returns the number of
        brackets placed."""
        fs = self.fs
        quad = p.panels[j]
        line = pb - pa
        vb = direction_into(quad, start, pa, pb)
        # other parts' panels and the brackets already there must not be in the corner
        obstacles = [v for v in fs._dirs.get(node, [])] + fs._bracket_dirs.get(node, [])
        every = fs._cached(corners, [v for _, v, _, _ in cont], vb, line, obstacles)
        picks = every[:n_corners]
        nb0 = quad_normals(quad[None])[0]

        def option(i, angle):
            nc, vc, qc, host = cont[i]
            nc = nc if nc @ vb > 0 else -nc
            nb = nb0 if nb0 @ vc > 0 else -nb0
            return ((nc, vc), (nb, vb), qc, quad, -(vc + vb), angle, (host, (p.name, j)))

        placed = 0
        why = "no corner between 25 and 172 deg for a bracket"
        for i, angle in picks:
            opt = option(i, angle)
            # (no plate corners: in a corner under 180 deg each leg has only its own plate
            # under it, see joints.connector_offset)
            q = fs._cached(place_connector, pa, pb, *opt[:4], thickness=fs.thickness,
                           gap=CONNECTOR_GAP * fs.thickness)
            why = "the panels are too small for a bracket"
            if q is not None:
                others = [option(k, a) for k, a in every if (k, a) not in picks]
                self._record(JointKind.BUTT_BRACKET, node, names + (p.name,), insert, q,
                             opt[4], angle, p.name, why, site=(pa, pb, [opt] + others))
                vc = opt[0][1]
                fs._bracket_dirs.setdefault(node, []).append((vc + vb) / np.linalg.norm(vc + vb))
                placed += 1
        if not placed:
            self._record(JointKind.BUTT_BRACKET, node, names + (p.name,), insert, None, None,
                         picks[0][1] if picks else 90.0, p.name, why)
        return placed

    def _splice(self, e: Part, p: Part, node: int, other) -> None:
        """A bent splice plate across the mitred seam between ``e`` (ending at ``node``) and
        ``p`` (starting there), on the side clear of the other family's plate ``other``."""
        fs = self.fs
        qe, qp = e.panels[-1], p.panels[0]
        pa, pb = qp[0], qp[3]
        v1, v2, n1, n2 = _seam_legs(qe, qp, pa, pb)
        fold = _fold_deg(n1, n2)
        q = None
        why = "the other family's plate passes on both sides of the seam"
        site = None
        if len(other) < 2:
            side = -(other[0][1] @ (n1 + n2)) if other else (v1 + v2) @ (n1 + n2)
            s = 1.0 if side >= 0 else -1.0
            hosts = ((e.name, len(e.panels) - 1), (p.name, 0))
            # either side of the seam where no plate of the other family is (the first: the
            # one away from it, or the convex side)
            opts = [((sg * n1, v1), (sg * n2, v2), qe, qp, -(n1 + n2) * sg, fold, hosts)
                    for sg in ((s, -s) if not other else (s,))]
            q = fs._cached(place_connector, pa, pb, *opts[0][:4], thickness=fs.thickness,
                           gap=CONNECTOR_GAP * fs.thickness,
                           plates=(e.slab_corners(len(e.panels) - 1, fs.thickness),
                                   p.slab_corners(0, fs.thickness)))
            why = "the panels are too small for a splice plate"
            site = (pa.copy(), pb.copy(), opts)
        cdir = -(n1 + n2) * (1.0 if q is None else s)
        self._record(JointKind.MITRE_SPLICE, node, (e.name, p.name), -v2, q, cdir, fold, p.name, why,
                     site=site)

    def _record(self, kind, node, names, insert, q, cdir, angle, part, why, *, site=None) -> None:
        """Append a :class:`Joint` (and its connector part built from the quads ``q``, or an
        entry of ``unconnected_joints`` if there is none). ``site``: ``(a, b, options)`` where
        the connector may go instead, each option ``(side1, side2, panel1, panel2, direction,
        angle, hosts)`` as :func:`~.joints.connector_variants` takes them, the first the one
        used; ``hosts`` the (part name, panel) each leg lies on (``_sites``)."""
        fs = self.fs
        conn = None
        if q is not None:
            idx = fs._n_conn.get(node, 0)
            fs._n_conn[node] = idx + 1
            n = quad_normals(q)
            c = Part(id=PartId(CONNECTOR_FAMILY, node, idx), panels=q, nodes=np.full(3, node),
                     edges=np.full(2, -1), miters=np.array([n[0], _miter(n[0], n[1]), n[1]]),
                     color=FAMILY_COLORS[CONNECTOR_FAMILY], span=(0, 2))
            fs._connectors.append(c)
            conn = c.name
            names = names + (conn,)
            if site is not None:
                fs._sites[conn] = site
        else:
            fs.unconnected_joints.append((part, node, why))
        unit = lambda x: None if x is None else np.asarray(x, float) / np.linalg.norm(x)  # noqa: E731
        fs.joints.append(Joint(kind, int(node), tuple(names), unit(insert), conn, unit(cdir),
                                 float(angle)))

    def _warn_untrimmed(self, stacklevel: int = 4) -> None:
        fs = self.fs
        untrimmed = fs.untrimmed_joints
        if untrimmed:
            warnings.warn(
                f"{len(untrimmed)} part ends could not be butt-trimmed (or mitred) against the adjoining "
                f"plate and overlap it: " + "; ".join(f"{n} at node {v} ({w})" for n, v, w in untrimmed[:6])
                + (" ..." if len(untrimmed) > 6 else "") + "; see FinSystem.untrimmed_joints",
                stacklevel=stacklevel)
