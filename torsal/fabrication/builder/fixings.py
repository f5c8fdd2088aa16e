"""Fixings: where the fins are fixed to the building (issue 27).

Every fin stands on the design surface A with its ``a`` edge (paper section 4.3: the node lines
``L_i = a_i b_i`` start on A). The plates that go in first (nothing they are joined to is in
place before them: the family-0 plates of an egg-crate, the halves of a mitred strip, the
plate a butted part ends against) carry the others, and are fixed to the building: a
**fixing** (:data:`~torsal.fabrication.model.FIXING_FAMILY`, ``A-E<edge>-<i>``) is a bent angle
of the fin's sheet on the fin's foot, one leg bolted to the fin, the other anchored to the
surface (:func:`~torsal.fabrication.joints.fixing_panels`). A workshop sets the fixings first,
then lowers each plate onto its fixings along one direction, the mean node axis of the plate
(``a - b``: towards the building); its joint records say so (:attr:`JointKind.FIXING`).

Where: in the middle of fin panels (clear of the crossings at the node lines), one near each
end of a plate and more in between so that they are at most ``fixing_spacing`` apart along
the foot (one on a plate of one panel). Each fixing sits on the side of its panel the plate
comes down towards (so the plate never passes through its legs) and where the corner between
fin and surface takes a bent angle (between :data:`~.joints.MIN_BRACKET_ANGLE` and
:data:`~.joints.MAX_BRACKET_ANGLE`); a panel whose foot is too short, or whose fixing would
not lie on it, takes none (the next panel does).

The surface at a foot is the plane through the fin's ``a`` edge with the normal of the face of
A (the structure's faces, on ``a``) beside the fin on that side (the other face, or square to
the fin's node lines, where there is none).

Lengths in the fin system's ``unit``.
"""
from __future__ import annotations

import numpy as np

from torsal.core.units import UNIT_TO_MM

from ..joints import MAX_BRACKET_ANGLE, MIN_BRACKET_ANGLE, _inside, fixing_panels
from ..model import (FAMILY_COLORS, FIXING_FAMILY, Joint, JointKind, Part, PartId, _cross, _miter,
                     quad_normals)
from .fasteners import anchor_for, fastener_for, min_leg, row_count
from .ends import CONNECTOR_GAP
from .paths import _PathCheck

#: length of a fixing along the fin's foot (mm; never more than half the foot)
FIXING_LENGTH_MM = 100.0
#: default greatest distance of two fixings along a plate's foot (``FinSystem(fixing_spacing=)``,
#: in its ``unit``, meant as mm)
FIXING_SPACING = 1500.0


class FixingPlacer:
    """Places the fixings of a fin system ``fs`` under construction: fills its ``_fixings``
    (parts) and appends their joints to ``joints`` (rules in the module text)."""

    def __init__(self, fs):
        self.fs = fs

    # ------------------------------------------------------------------ the surface A
    def _face_normals(self) -> dict:
        """``{(i, j) sorted node pair: [(unit normal, centroid)]}`` of the faces of A beside each
        edge, normals turned to the fins' side (along ``b - a``)."""
        st = self.fs.structure
        a = np.asarray(st.vertices_a, float) * self.fs.scale
        b = np.asarray(st.vertices_b, float) * self.fs.scale
        out: dict[tuple[int, int], list] = {}
        for face in st.faces:
            f = [int(v) for v in face]
            if len(f) < 3:
                continue
            pts = a[f]
            n = np.zeros(3)
            for k in range(len(pts)):                      # Newell normal
                n += _cross(pts[k], pts[(k + 1) % len(pts)])
            if not np.linalg.norm(n) > 0:
                continue
            n = n / np.linalg.norm(n)
            if n @ (b[f] - a[f]).mean(axis=0) < 0:
                n = -n
            c = pts.mean(axis=0)
            for k in range(len(f)):
                key = tuple(sorted((f[k], f[(k + 1) % len(f)])))
                out.setdefault(key, []).append((n, c))
        return out

    # ------------------------------------------------------------------ placing
    def _place(self, roots: list[Part], directions: dict, *, exclude: set = frozenset(),
               single: set = frozenset()) -> None:
        """Fixings on every plate of ``roots``, each lowered along ``directions[name]``; no
        fixing on the panels ``exclude`` ({(strip index, panel of the strip)}: one there was in
        a part's way) nor where it would overlap a part. The plates named in ``single`` take
        one fixing, nearest the middle of the foot (a plate its slots carry, held by the
        fixing only against sliding back out: :meth:`.paths.AssemblyPlanner._slot_hung`)."""
        fs = self.fs
        fs._fixings = []
        fs._fixing_sites = {}
        if fs.structure is None or fs.fixing_spacing is None:
            return
        faces = self._face_normals()
        check = _PathCheck(fs)
        shares = self._yield_shares([p for p in roots if p.name not in single])
        for p in roots:
            d = directions.get(p.name)
            if d is None:
                continue
            want, placed = (1 if p.name in single else shares.get(p.name, self._count(p))), 0
            if not want:
                continue
            si = fs._strip_of.get(p.name)
            for j in self._panels(p, want):
                if (si, p.span[0] + j) in exclude:
                    continue
                site = self._site(p, j, d, faces)
                if site is None:
                    continue
                f = self._add(p, j, d, *site)
                if check.overlaps(f, joined={0: {(p.name, j)}}):
                    self._undo(f)
                    continue
                check.add(f, rank=-1)
                placed += 1
                if placed == want:
                    break

    def _count(self, p: Part) -> int:
        """How many fixings plate ``p`` gets: one on a plate of one panel, else one near each
        end and more so that they are at most ``fixing_spacing`` apart along the foot."""
        foot = float(np.linalg.norm(p.panels[:, 1] - p.panels[:, 0], axis=1).sum())
        k = len(p.panels)
        return 1 if k == 1 else min(k, max(2, int(np.ceil(foot / self.fs.fixing_spacing))))

    def _yield_shares(self, roots: list[Part]) -> dict[str, int]:
        """``{piece: fixings}`` of the ``roots`` that are pieces of a plate the final cut split
        at crossing slots (``FinSystem._yield_cuts``): the plate's own fixings
        (:meth:`_count` of the pieces joined at those seams, :func:`fixing_shares`), each
        on the piece it falls on; a piece none falls on takes one only where none of its
        slot crossings holds it (:func:`slot_held`: the crossing plate at its seam, held by
        the piece fixed, holds it in turn). Whether it is then held is the load path's to
        say (``Rebuilder._unheld`` fixes it in one more build where it is not)."""
        fs = self.fs
        cuts = getattr(fs, "_yield_cuts", {})
        runs: dict = {}
        for p in sorted(roots, key=lambda p: (fs._strip_of.get(p.name, -1), p.span[0])):
            si = fs._strip_of.get(p.name)
            if si not in cuts or p.family not in (0, 1):
                continue
            run = runs.setdefault(si, [])
            if run and run[-1][-1].span[1] == p.span[0] and p.span[0] in cuts[si]:
                run[-1].append(p)
            else:
                run.append([p])
        out: dict[str, int] = {}
        for run in (r for rs in runs.values() for r in rs if len(r) > 1):
            counts = fixing_shares(self, [p.panels for p in run])
            for p, c in zip(run, counts):
                out[p.name] = c if c or slot_held(fs, p.name) else 1
        return out

    def _panels(self, p: Part, n: int | None = None) -> list[int]:
        """Panels of ``p`` to try, best first: those nearest ``n`` (default :meth:`_count`)
        points evenly spread along the foot, then the others nearest to them."""
        foot = np.linalg.norm(p.panels[:, 1] - p.panels[:, 0], axis=1)
        n = self._count(p) if n is None else n
        targets = (np.arange(n) + 0.5) / n * float(foot.sum())
        mids = np.cumsum(foot) - 0.5 * foot
        first = [int(np.argmin(np.abs(mids - x))) for x in targets]
        rest = sorted(range(len(foot)), key=lambda j: (min(abs(j - f) for f in first), j))
        return list(dict.fromkeys(first + rest))

    def _site(self, p: Part, j: int, d: np.ndarray, faces: dict):
        """``(fixing quads (2, 4, 3), corner angle in degrees)`` on panel ``j`` of ``p``, or
        None (foot too short, no corner for an angle, the fin leg off the panel)."""
        fs = self.fs
        t = fs.thickness
        quad = p.panels[j]
        a0, a1 = quad[0], quad[1]
        foot = a1 - a0
        length = float(np.linalg.norm(foot))
        mm = UNIT_TO_MM[fs.unit]
        bolt, anchor = fastener_for(t * mm), anchor_for(t * mm)
        span = min(FIXING_LENGTH_MM / mm, 0.5 * length)
        legs = (max(6.0 * t, min_leg(bolt, thickness=t, unit=fs.unit) + t),
                max(6.0 * t, min_leg(anchor, thickness=t, unit=fs.unit) + t))
        if not (row_count(span, bolt, unit=fs.unit) and row_count(span, anchor, unit=fs.unit)):
            return None         # no room along the foot for a bolt and an anchor
        u = foot / length
        n = quad_normals(quad[None])[0]
        side = n if n @ d >= 0 else -n        # the plate comes down towards this side
        into = quad[[2, 3]].mean(axis=0) - quad[[0, 1]].mean(axis=0)
        into = into - (into @ u) * u
        into = into / np.linalg.norm(into)
        n_s = self._surface_normal(p, j, side, into, u, faces)
        along = _cross(n_s, u)                 # in the surface, square to the foot
        along = along if along @ side >= 0 else -along
        angle = float(np.degrees(np.arccos(np.clip(into @ along, -1.0, 1.0))))
        if not MIN_BRACKET_ANGLE <= angle <= MAX_BRACKET_ANGLE:
            return None
        mid = 0.5 * (a0 + a1)
        # a real panel is planar only to the structure's tolerance: the leg keeps the gap from
        # the corner that stands out most on its side
        proud = max(0.0, float(((quad - quad.mean(axis=0)) @ side).max()))
        q = fixing_panels(mid - 0.5 * span * u, mid + 0.5 * span * u, (side, into), (n_s, along),
                          thickness=t, gap=CONNECTOR_GAP * t + proud, legs=legs)
        # the outer 60 % of the leg on the fin lies on the panel (nearer the bend it may pass
        # the foot where the fin leans over its fixing)
        leg = q[0]
        outer = np.array([leg[0], leg[0] + 0.6 * (leg[1] - leg[0]), leg[3] + 0.6 * (leg[2] - leg[3]),
                          leg[3]])
        if not _inside(outer, quad, 1e-6 * length):
            return None
        return q, angle

    def _surface_normal(self, p: Part, j: int, side, into, u, faces: dict) -> np.ndarray:
        """Unit normal of A at the foot of panel ``j`` of ``p`` on the ``side`` of the fin,
        square to the foot ``u`` and turned to the fins."""
        e = int(p.edges[j])
        st = self.fs.structure
        cands = []
        if e >= 0:
            key = tuple(sorted(int(v) for v in st.edges[e]))
            here = faces.get(key, [])
            a0 = p.panels[j][0]
            cands = [n for n, c in here if (c - a0) @ side > 0] or [n for n, _ in here]
        if cands:
            n = np.mean(cands, axis=0)
        else:
            n = into                        # no face: the building square to the node lines
        n = n - (n @ u) * u
        n = n / np.linalg.norm(n)
        return n if n @ into >= 0 else -n

    def _undo(self, f: Part) -> None:
        fs = self.fs
        fs._fixings.remove(f)
        fs._fixing_sites.pop(f.name)
        fs.joints.pop()

    def _add(self, p: Part, j: int, d: np.ndarray, q: np.ndarray, angle: float) -> Part:
        fs = self.fs
        e = int(p.edges[j])
        idx = sum(1 for f in fs._fixings if f.id.strip == e)
        nq = quad_normals(q)
        f = Part(id=PartId(FIXING_FAMILY, e, idx), panels=q, nodes=np.full(3, -1),
                 edges=np.full(2, -1), miters=np.array([nq[0], _miter(nq[0], nq[1]), nq[1]]),
                 color=FAMILY_COLORS[FIXING_FAMILY], span=(0, 2))
        fs._fixings.append(f)
        # the leg on the fin lies on panel j of p; the other on the building
        fs._fixing_sites[f.name] = (p.name, j)
        node = int(p.nodes[j])
        depth = float(np.mean(np.linalg.norm(p.panels[j][[3, 2]] - p.panels[j][[0, 1]], axis=1)))
        fs.joints.append(Joint(JointKind.FIXING, node, (f.name, p.name), np.asarray(d, float),
                               None, None, float(angle), depth))
        return f


def fixing_shares(placer: FixingPlacer, pieces: list[np.ndarray]) -> list[int]:
    """How many of the fixings of a plate whose panels are ``pieces`` ``[(k_i, 4, 3)]`` end to
    end (:meth:`FixingPlacer._count` of the whole, evenly spread along its foot) fall on each
    piece: a plate cut at seams inside crossing slots keeps its fixings, each on its piece."""
    from types import SimpleNamespace

    panels = np.concatenate(pieces)
    n = placer._count(SimpleNamespace(panels=panels))
    foot = np.linalg.norm(panels[:, 1] - panels[:, 0], axis=1)
    targets = (np.arange(n) + 0.5) / n * float(foot.sum())
    mids = np.cumsum(foot) - 0.5 * foot
    panel = [int(np.argmin(np.abs(mids - x))) for x in targets]
    ends = np.cumsum([len(q) for q in pieces])
    return [min(int(hi - lo), sum(1 for j in panel if lo <= j < hi))
            for lo, hi in zip(np.r_[0, ends[:-1]], ends)]


def slot_held(fs, name: str, nodes=None) -> bool:
    """Whether an egg-crate crossing of the plate ``name`` of ``fs`` (at ``nodes``; None: any)
    holds it against its weight: its way off the other plate there does not dip
    (:func:`~torsal.fabrication.assembly.load_path.slides_out`; a family-0 plate's way off is
    the crossing's insert direction, a family-1 plate's the reverse), the load path's rule for
    a slot (:mod:`torsal.fabrication.assembly.load_path`)."""
    from ..assembly.load_path import slides_out

    nodes = None if nodes is None else {int(v) for v in nodes}
    family0 = fs.part(name).family == 0
    for j in fs.joints:
        if j.kind != JointKind.EGG_CRATE or name not in j.parts or (
                nodes is not None and int(j.node) not in nodes):
            continue
        d = np.asarray(j.insert_direction, float)
        d = d / np.linalg.norm(d)
        if not slides_out(d if family0 else -d):
            return True
    return False
