"""Plates that run into each other where no joint joins them (issue 15).

:class:`ClashFinder` names the panels to leave out of a built fin system: those of parts joined
to nothing that pass through another part, and of every pair of plates whose panels cross or
come within ``thickness + clearance`` of each other away from any joint (the cheaper panel,
:meth:`ClashFinder._panel_cost`). Lengths in the fin system's ``unit``.
"""
from __future__ import annotations

import numpy as np

from ..model import Part
from .proximity import _near_panel_pairs, _quads_cross, _quads_on


class ClashFinder:
    """Finds the panels of a built fin system ``fs`` that run into other plates without a
    joint; each as ``(strip index, panel of the strip, strip name, structure edge, node, reason)``."""

    def __init__(self, fs):
        self.fs = fs

    def _stray_parts(self) -> list[tuple]:
        """Parts joined to nothing (no joint, no slot) whose panels pass through another
        part's panels: the structure runs through itself there and such a fin could neither
        be fastened nor fitted; its panels are left out (as :meth:`.ends.EndJoiner._note_untrimmable`)."""
        fs = self.fs
        joined = {n for j in fs.joints for n in j.parts}
        plates = [p for p in fs.parts if p.family in (0, 1)]
        out = []
        for p in plates:
            if p.name in joined or p.slots or p.name not in fs._strip_of:
                continue
            lo, hi = p.panels.reshape(-1, 3).min(axis=0), p.panels.reshape(-1, 3).max(axis=0)
            for o in plates:
                if o is p:
                    continue
                q = o.panels.reshape(-1, 3)
                if (q.min(axis=0) > hi).any() or (q.max(axis=0) < lo).any():
                    continue
                if _quads_cross(p.panels, o.panels) or _quads_on(p.panels, o.panels, fs.thickness):
                    why = f"it crosses {o.name} without a joint (the structure runs through itself)"
                    out += [(fs._strip_of[p.name], p.span[0] + j, p.name[:-4], int(p.edges[j]),
                             int(p.nodes[j]), why) for j in range(len(p.panels))]
                    break
        return out

    def _clashing_panels(self, *, leaving: set = frozenset()) -> list[tuple]:
        """Panels of two plates that cross, or come within ``thickness + clearance`` of each
        other, where no joint joins them (they share no node line; e.g. two strips of one
        family crossing near a singularity of a rough congruence): the plates would interfere
        and neither could be put in past the other. Of every such pair the panel that costs
        least is left out (as :meth:`.ends.EndJoiner._note_untrimmable`): one at an end of its part (leaving
        it out splits nothing) before one inside it, then the one of the shorter strip. Pairs
        with a panel in ``leaving`` ({(strip index, panel of the strip)}, left out for another
        reason in this build) are resolved already."""
        fs = self.fs
        plates = [p for p in fs.parts if p.family in (0, 1) and p.name in fs._strip_of]
        if not plates:
            return []
        refs = [(p, j) for p in plates for j in range(len(p.panels))]
        quads = np.concatenate([p.panels for p in plates])
        nodes = np.concatenate([np.c_[p.nodes[:-1], p.nodes[1:]] for p in plates]).astype(int)
        pairs, dist = _near_panel_pairs(quads, nodes, fs.thickness + fs.clearance)

        def cost(k: int) -> tuple:
            return self._panel_cost(*refs[k])

        gone = {k for k, (p, j) in enumerate(refs) if (fs._strip_of[p.name], p.span[0] + j) in leaving}
        out = []
        for (i, k), d in sorted(zip(map(tuple, pairs.tolist()), dist.tolist()), key=lambda x: x[1]):
            if i in gone or k in gone:
                continue
            drop, keep = (i, k) if cost(i) <= cost(k) else (k, i)
            gone.add(drop)
            (p, j), (o, jo) = refs[drop], refs[keep]
            what = "crosses" if d == 0 else f"comes within {d:.2f} {fs.unit} of"
            why = (f"it {what} panel {int(o.edges[jo])} of {o.name[:-4]} without a joint (the "
                   f"structure runs through itself)")
            # the node of the panel nearer the other panel names where it is
            near = np.linalg.norm(quads[drop][[0, 1]] - quads[keep].mean(axis=0), axis=1)
            out.append((fs._strip_of[p.name], p.span[0] + j, p.name[:-4], int(p.edges[j]),
                        int(p.nodes[j + int(np.argmin(near))]), why))
        return out

    def _panel_cost(self, p: Part, j: int) -> tuple:
        """What leaving out panel ``j`` of plate ``p`` costs, for sorting: a panel at an end of
        its part (leaving it out splits nothing) before one inside it, then the panel of the
        shorter strip, then by name."""
        fs = self.fs
        lengths = fs.__dict__.get("_strip_len")
        if lengths is None or lengths[0] is not fs.parts:
            count: dict[int, int] = {}
            for q in fs.parts:
                si = fs._strip_of.get(q.name)
                if si is not None:
                    count[si] = count.get(si, 0) + len(q.panels)
            lengths = fs._strip_len = (fs.parts, count)
        return 0 < j < len(p.panels) - 1, lengths[1][fs._strip_of[p.name]], p.name, j
