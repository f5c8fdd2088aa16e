"""Butt joints at part ends: an end trimmed back against the plate it meets (T and L
junctions, crossings where a strip is split), carried on flat across a seam, or butted against
the previous part at a sharp fold (issue 15; the trims are in :mod:`torsal.fabrication.joints`).

:class:`ButtTrimmer` trims the end, records the faces it ends against (``_walls``, for its
insertion direction) and has :class:`~.connectors.ConnectorPlacer` join it; an end that cannot
be trimmed is named for the next build. Lengths in the fin system's ``unit``.
"""
from __future__ import annotations

import numpy as np

from ..joints import (BRACKET_TRIM_SINE, _Untrimmable, butt_trim, continues, direction_into,
                      into_direction, seam_trim, trim_further)
from ..model import Part, _cross, _fold_deg, _miter, quad_normals
from .connectors import ConnectorPlacer
from .strips import _Strips


def _slide(n_plate: np.ndarray, quad: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Direction a butted part slides into place along: the line where its plane meets the
    plate's (so its trimmed end face slides along the plate, ``clearance/2`` off it),
    oriented like ``axis`` (the node axis, ``a_i - b_i``, as for an egg-crate)."""
    d = _cross(n_plate, quad_normals(quad[None])[0])
    if not np.linalg.norm(d) > 1e-9:
        return axis / np.linalg.norm(axis)
    d = d / np.linalg.norm(d)
    return d if d @ axis >= 0 else -d


class ButtTrimmer:
    """Trims the butted part ends of a fin system ``fs`` under construction (``untrimmed_joints``,
    ``_walls``, ``_ends_at``, the panels to leave out); its connectors are placed by
    :class:`~.connectors.ConnectorPlacer`."""

    def __init__(self, fs):
        self.fs = fs
        self.connectors = ConnectorPlacer(fs)

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
        placed = self.connectors._bracket(p, j, node, cont, names, st.a[node], st.b[node],
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
        self.connectors._seam_splice(p, j, host, i, node, side * n_end, a, b)
        return True
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
            self.connectors._bracket(p, 0, node, [(nprev, into, prev.panels[-1],
                                        (prev.name, len(prev.panels) - 1))], (prev.name,), pa, pb,
                          insert=_slide(nbar, quad, pa - pb), start=True)
        return True
