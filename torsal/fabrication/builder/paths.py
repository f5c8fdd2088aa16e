"""The assembly plan: which part goes in after which, along which direction, on a clear path
(issue 15; the rules are in :mod:`torsal.fabrication.parts`).

:class:`AssemblyPlanner` orders the parts by their joints (family-1 plates after the family-0
plates they are slotted onto, a butted part after the plate it butts against), re-splits
crossings where parts would butt on each other in a cycle, gives every butted part its
insertion direction and checks its path into place (:class:`_PathCheck`), naming the panels
to leave out where no direction is clear. Lengths in the fin system's ``unit``.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from torsal.core.units import UNIT_TO_MM

from ..joints import connector_variants
from ..model import (CONNECTOR_FAMILY, FIXING_FAMILY, JointKind, Part, _cross, _miter,
                     quad_normals)
from .clash import ClashFinder
from .ends import CONNECTOR_GAP
from .fasteners import fastener_for, min_leg
from .proximity import _quad_distances, _slab_depths, _swept_and_still_distances

#: a part's path into place is blocked where its swept solid and a plate in place overlap by
#: more than this fraction of the thickness (less is touching, e.g. corners that meet)
SLAB_TOUCH = 0.01


def _assembly_order(names: list[str], after: dict) -> list[str]:
    """The plates ``names`` in the order they go in: a plate after those it must follow
    (``after`` = ``{a: {b: ...}}``: ``b`` after ``a``, see :func:`_butted_after`),
    otherwise by name; where the plates left all wait for one another (a cycle), the one that
    waits for the fewest goes next (connectors go on after the plates)."""
    before: dict[str, set] = {n: set() for n in names}
    for a, bs in after.items():
        for b in bs:
            if b in before and a in before and a != b:
                before[b].add(a)
    order, placed, remaining = [], set(), sorted(names)
    while remaining:
        nxt = next((n for n in remaining if before[n] <= placed), None)
        if nxt is None:
            nxt = min(remaining, key=lambda n: (len(before[n] - placed), n))
        order.append(nxt)
        placed.add(nxt)
        remaining.remove(nxt)
    return order


def _blocking_pairs(panels: np.ndarray, moving_loose: bool, vec: np.ndarray, quads: np.ndarray,
                    loose: np.ndarray, t: float, c: float):
    """``(ii, jj, swept)``: the pairs (panel ``ii`` of the moving part, panel ``jj`` of
    ``quads`` (m, 4, 3)) that block the path of ``panels`` (k, 4, 3) moved by ``vec`` (3,)
    into place, and the swept distances (k, m) (rules in :class:`_PathCheck`'s text;
    ``moving_loose``: the moving part is a connector or fixing, ``loose`` (m,) bool: the
    panel is one's; ``t`` thickness, ``c`` clearance)."""
    reach = t + 0.5 * c
    # (k, m): nearest on the way and in place (the swept region's first face is the panel)
    # (pairs farther apart than the reach block nothing: not measured)
    swept, still = _swept_and_still_distances(panels, vec, quads, within=reach)
    # panels at a joint (nearer in place than plates can be apart) must not come nearer;
    # any others that come that near are checked as solids. A connector or fixing is at a
    # joint only with what it lies on (a thickness apart): nothing crosses it
    joint = still < reach
    loose = moving_loose | loose
    joint &= ~loose[None, :] | (still >= 0.98 * t)
    near = ~joint & (swept < reach)
    ii, jj = np.nonzero(near)
    near[ii, jj] = _slab_depths(panels[ii], vec, quads[jj], t) > SLAB_TOUCH * t
    ii, jj = np.nonzero(near | (joint & (swept < still - 0.5 * c)))
    return ii, jj, swept


def _overlapping_pairs(panels: np.ndarray, quads: np.ndarray, t: float, c: float):
    """``(i, j, distance, deep)``: the pairs (panel ``i`` of ``panels`` (k, 4, 3), panel ``j``
    of ``quads`` (m, 4, 3)) whose mid-surfaces come within ``t + c/2``, their distances, and
    whether the two thickened panels overlap by more than :data:`SLAB_TOUCH` of ``t``."""
    i, j = np.divmod(np.arange(len(panels) * len(quads)), len(quads))
    dist = _quad_distances(panels[i], quads[j])
    keep = dist < t + 0.5 * c
    i, j, dist = i[keep], j[keep], dist[keep]
    deep = _slab_depths(panels[i], np.zeros(3), quads[j], t) > SLAB_TOUCH * t
    return i, j, dist, deep


def _families(fs) -> dict[str, int]:
    """``{part: family}`` of the parts of ``fs`` (0, 1; connectors and fixings their own)."""
    return {p.name: p.family for p in fs.parts}


class _PathCheck:
    """The paths of parts into place, checked against the parts that may be in place before
    them, on the panels' mid-surfaces (:func:`_swept_distances`).

    The parts go in in the order a workshop follows, the order the assembly check reads from
    the joints: the fixings first (set on the building), then the plates (:func:`_assembly_order`),
    then the connectors (brackets, splice plates) by name, each once the plates around it are
    in. A part goes in along a direction ``d`` over ``travel``: its extent along ``d`` (plus the
    thickness), but, for a plate, no more than the deepest joint at which it goes in after its
    partners (the fin depth there: then it is clear of them), plus the thickness. A pair of
    panels blocks the path when the one, thickened and swept along the path, and the other,
    thickened, overlap by more than :data:`SLAB_TOUCH` of the thickness (:func:`_slab_depths`;
    looked at where their mid-surfaces come within ``thickness + clearance/2``:
    :func:`_swept_distances`), or, for panels nearer than that in place (at a joint), when
    their mid-surfaces come nearer by more than ``clearance/2`` than in place (a butted end
    slides along the plate it meets, a connector onto the faces it lies on; slotted panels
    cross and never block). Connectors and fixings are plates of the same sheet.
    """

    def __init__(self, fs):
        self.t, self.c = fs.thickness, fs.clearance
        #: the memo of the fin system's rebuilds (None once it is built)
        self._memo = fs._cached if "_memo" in fs.__dict__ else None
        plates = [p for p in fs.parts if p.family not in (CONNECTOR_FAMILY, FIXING_FAMILY)]
        fixings = sorted((p for p in fs.parts if p.family == FIXING_FAMILY), key=lambda p: p.name)
        conns = sorted((p for p in fs.parts if p.family == CONNECTOR_FAMILY), key=lambda p: p.name)
        order = _assembly_order([p.name for p in plates], _butted_after(fs))
        self.bodies = fixings + plates + conns
        self.rank = {p.name: r for r, p in enumerate(fixings)}
        self.rank.update((n, len(fixings) + r) for r, n in enumerate(order))
        self.rank.update((p.name, len(fixings) + len(plates) + r) for r, p in enumerate(conns))
        self._stack()
        self.seams = fs._seams
        #: deepest joint at which a part goes in after its partners
        self.depth: dict[str, float] = {}
        family = _families(fs)
        for j in fs.joints:
            names = [n for n in j.parts if n != j.connector]
            if j.kind == JointKind.BUTT_BRACKET:
                later = names[-1:]
            elif j.kind == JointKind.EGG_CRATE:
                later = [n for n in names if family.get(n) == 1]
            elif j.kind == JointKind.FIXING:
                later = names[1:]
            else:
                later = []
            for n in later:
                if j.depth is not None:
                    self.depth[n] = max(self.depth.get(n, 0.0), float(j.depth))

    def _stack(self) -> None:
        """The panels of all bodies in one array (after a body was added, moved or removed)."""
        sizes = [len(p.panels) for p in self.bodies]
        self.quads = (np.concatenate([p.panels for p in self.bodies]) if self.bodies
                      else np.zeros((0, 4, 3)))
        self.owner = np.repeat(np.arange(len(self.bodies)), sizes)
        self.panel = np.concatenate([np.arange(n) for n in sizes]) if sizes else np.zeros(0, int)
        self.lo, self.hi = self.quads.min(axis=1), self.quads.max(axis=1)
        self.index = {p.name: k for k, p in enumerate(self.bodies)}
        self._loose = np.array([p.family in (CONNECTOR_FAMILY, FIXING_FAMILY) for p in self.bodies], bool)
        self.order = np.array([self.rank.get(p.name, -1) for p in self.bodies], int)

    @property
    def plates(self) -> list[Part]:
        return self.bodies

    def replace(self, part: Part) -> None:
        """Take a body's new panels (a connector moved to another place: same panel count)."""
        rows = np.flatnonzero(self.owner == self.index[part.name])
        if len(rows) != len(part.panels):
            self._stack()
            return
        self.quads[rows] = part.panels
        self.lo[rows], self.hi[rows] = part.panels.min(axis=1), part.panels.max(axis=1)

    def remove(self, name: str) -> None:
        """Take a body out (a fixing or connector removed)."""
        self.bodies = [p for p in self.bodies if p.name != name]
        self._stack()

    def add(self, part: Part, rank: int) -> None:
        """Put a body in, placed at ``rank`` (a fixing: before every plate)."""
        k = len(self.bodies)
        self.bodies.append(part)
        self.rank[part.name] = rank
        self.index[part.name] = k
        n = len(part.panels)
        self.quads = np.concatenate([self.quads, part.panels])
        self.owner = np.concatenate([self.owner, np.full(n, k)])
        self.panel = np.concatenate([self.panel, np.arange(n)])
        self.lo = np.concatenate([self.lo, part.panels.min(axis=1)])
        self.hi = np.concatenate([self.hi, part.panels.max(axis=1)])
        self.order = np.append(self.order, rank)
        self._loose = np.append(self._loose, part.family in (CONNECTOR_FAMILY, FIXING_FAMILY))

    def travel(self, p: Part, d: np.ndarray) -> float:
        ext = p.panels.reshape(-1, 3) @ d
        travel = float(ext.max() - ext.min()) + self.t
        if p.name in self.depth:
            travel = min(travel, self.depth[p.name])
        return travel + self.t

    def hits(self, p: Part, d: np.ndarray, *, travel: float | None = None) -> list[tuple]:
        """``[(panel of p, body, panel of the body, least distance)]``, nearest first: the
        panel pairs that block the path of ``p`` along unit direction ``d`` (``travel``:
        its length; default :meth:`travel`; 0: only where ``p`` stands in place)."""
        d = np.asarray(d, float)
        length = self.travel(p, d) if travel is None else travel
        vec = -length * d
        seams = self._seam_hits(p, d, length)
        reach = self.t + 0.5 * self.c          # the largest limit (see the class text)
        lo = np.minimum(p.panels.min(axis=(0, 1)), (p.panels + vec).min(axis=(0, 1))) - reach
        hi = np.maximum(p.panels.max(axis=(0, 1)), (p.panels + vec).max(axis=(0, 1))) + reach
        before = self.order < self.rank.get(p.name, -1)
        cand = np.flatnonzero(((self.lo <= hi) & (self.hi >= lo)).all(axis=1) & before[self.owner])
        if not len(cand):
            return seams
        ii, jj, swept = self._blocking(p, vec, self.quads[cand], self._loose[self.owner[cand]])
        out = [(int(a), self.bodies[self.owner[cand[b]]], int(self.panel[cand[b]]), float(swept[a, b]))
               for a, b in zip(ii, jj)] + seams
        return sorted(out, key=lambda h: (h[3], h[1].name, h[0], h[2]))

    def _blocking(self, p: Part, vec: np.ndarray, quads: np.ndarray, loose: np.ndarray):
        """``(panels of p, indices into quads, swept distances (k, m))``: the pairs of the
        panels of ``p`` moved by ``vec`` into place and the panels ``quads`` (m, 4, 3) that
        block the path (:func:`_blocking_pairs`; ``loose``: the panel is a connector's or
        fixing's). During the rebuilds of a fin system it is looked up in their memo: the
        second check of the paths finds most parts, their paths and their neighbours as the
        first left them."""
        args = (p.panels, p.family in (CONNECTOR_FAMILY, FIXING_FAMILY), vec, quads, loose,
                self.t, self.c)
        return self._memo(_blocking_pairs, *args) if self._memo else _blocking_pairs(*args)

    def _seam_hits(self, p: Part, d: np.ndarray, length: float) -> list[tuple]:
        """Mitred seams of ``p`` with parts in place before it that its path closes: the end
        faces lie along the seam's plane, ``clearance`` apart; a path that runs across that
        plane towards the other part by more than half of it would push the ends into each
        other (the mid-surfaces of two folded panels come nearer by less than that)."""
        out = []
        mine = self.rank.get(p.name, -1)
        for other, n, panel, _ in self.seams.get(p.name, ()):
            k = self.index.get(other)
            if k is None or not self.rank.get(other, mine) < mine:
                continue
            run = length * float(d @ n)
            if run > 0.5 * self.c:
                o = self.bodies[k]
                out.append((panel, o, 0 if panel else len(o.panels) - 1, max(0.0, self.c - run)))
        return out

    def overlaps(self, p: Part, *, joined: dict[int, set] | None = None) -> list[tuple]:
        """``[(panel of p, body, panel of the body, distance)]``: where ``p`` standing in place
        (not one of the bodies) and a body overlap as solids, or, for the panels ``joined``
        (``{panel of p: {(body name, its panel)}}``: the faces a connector lies on), none."""
        joined = joined or {}
        reach = self.t + 0.5 * self.c
        lo, hi = p.panels.min(axis=(0, 1)) - reach, p.panels.max(axis=(0, 1)) + reach
        cand = np.flatnonzero(((self.lo <= hi) & (self.hi >= lo)).all(axis=1))
        if not len(cand):
            return []
        args = (p.panels, self.quads[cand], self.t, self.c)
        i, j, dist, deep = self._memo(_overlapping_pairs, *args) if self._memo else _overlapping_pairs(*args)
        out = []
        for a, b, dd, hit in zip(i, j, dist, deep):
            body = self.bodies[self.owner[cand[b]]]
            pan = int(self.panel[cand[b]])
            if hit and (body.name, pan) not in joined.get(int(a), ()):
                out.append((int(a), body, pan, float(dd)))
        return sorted(out, key=lambda h: (h[3], h[1].name, h[0], h[2]))


def dipping_slot_plates(fs, *, exclude=frozenset()) -> dict[str, np.ndarray]:
    """``{plate: direction}``: the family-1 plates of ``fs`` (other than ``exclude`` and the
    connectors) slotted onto a crossing plate at an egg-crate joint whose way out of the slot,
    the reverse of the unit insert direction ``direction`` (shape (3,)), dips more than
    :data:`~torsal.fabrication.assembly.load_path.SLIDE_DIP_DEG` below the horizontal (model
    +z up): their weight would draw them back out the way they slid in (the load path,
    :mod:`torsal.fabrication.assembly.load_path`). The first such joint of a plate, in
    ``fs.joints`` order, gives its direction.

    Example: ``hung = dipping_slot_plates(fs, exclude={p.name for p in planner._roots()})``;
    ``hung["F1-S004-P01"]`` is the unit vector it slid in along. :meth:`AssemblyPlanner._slot_hung`
    then drops the plates bolted to a root, the final cut's
    :func:`~torsal.fabrication.nesting.cut_costs.fixings_added` keeps them per piece."""
    from ..assembly.load_path import slides_out

    family = _families(fs)
    conn = {j.connector for j in fs.joints if j.connector}
    out: dict[str, np.ndarray] = {}
    for j in fs.joints:
        if j.kind != JointKind.EGG_CRATE:
            continue
        d = np.asarray(j.insert_direction, float)
        d = d / np.linalg.norm(d)
        if not slides_out(-d):                          # its way out does not dip: it stays
            continue
        for name in j.parts:
            if family.get(name) == 1 and name not in exclude and name not in conn:
                out.setdefault(name, d)
    return out


def _cycles(after: dict) -> list[list[str]]:
    """Strongly connected components of more than one part of the graph ``{a: {b: ...}}``
    (``b`` placed after ``a``), each sorted, in a stable order (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack, on, out = [], set(), []
    for root in sorted(set(after) | {b for a in after for b in after[a]}):
        if root in index:
            continue
        work = [(root, iter(sorted(after.get(root, {}))))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(after.get(w, {})))))
                elif w in on:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    out.append(sorted(comp))
    return out


def _butted_after(fs) -> dict[str, dict[str, int]]:
    """``{part: {part placed after it: node}}``: family-1 plates go on family-0 plates
    at an egg-crate, a butted part after the plate it butts against (the two parts of a
    mitred seam in either order)."""
    after: dict[str, dict[str, int]] = {}
    conn = {j.connector for j in fs.joints if j.connector}
    family = _families(fs)
    for j in fs.joints:
        names = [n for n in j.parts if n not in conn]
        if j.kind == JointKind.EGG_CRATE:
            pairs = [(a, b) for a in names for b in names
                     if family.get(a) == 0 and family.get(b) == 1]
        elif j.kind == JointKind.BUTT_BRACKET:
            pairs = [(a, names[-1]) for a in names[:-1]]
        else:
            pairs = []
        for a, b in pairs:
            after.setdefault(a, {})[b] = j.node
    return after


class AssemblyPlanner:
    """Plans the assembly of a fin system ``fs`` under construction: the order its parts go in
    (:func:`_butted_after`), crossings to split the other way (:meth:`_break_cycles`), each butted
    part's insertion direction (:meth:`_set_butt_directions`, :meth:`_check_paths`) and the
    panels to leave out where a path is blocked (:meth:`_blocked_panels`)."""

    def __init__(self, fs):
        self.fs = fs

    def _break_cycles(self, forced: dict) -> dict:
        """Crossings to split the other way (``{node: (family split, reason)}``) so that no
        parts butt on each other in a cycle (A against B, B against C, C against A: the last
        one could not be put in). In every cycle, the crossings of two passing strips where
        family 0 is split are split on family 1 instead (family 0 continuous, as family-1
        plates are put on family-0 plates), or, if there are none, the first crossing whose
        joint is not yet forced has its split family swapped."""
        fs = self.fs
        after = _butted_after(self.fs)
        split_at = {x.node: x for x in fs.joinery}
        family = _families(fs)
        out = {}
        for comp in _cycles(after):
            why = f"the parts {', '.join(comp[:4])} would butt on each other in a cycle"
            # crossings where a family-0 part butts against a family-1 plate (family 0 split
            # there: by the joinery, or for length): split family 1 there too, bracketed across
            back = sorted({v for a in comp if family.get(a) == 1
                           for b, v in after.get(a, {}).items()
                           if b in comp and family.get(b) == 0 and v in split_at
                           and v not in forced})
            for v in back:
                x = split_at[v]
                out[v] = (1, f"{x.why + '; ' if x.why else ''}split family 1: {why}")
            if back:
                continue
            nodes = sorted({after[a][b] for a in comp for b in after.get(a, {}) if b in comp})
            xs = [split_at[v] for v in nodes if v in split_at and v not in forced
                  and split_at[v].kind == JointKind.BUTT_BRACKET]
            for x in xs[:1]:
                out[x.node] = (1 - x.split, f"{x.why}; split family {1 - x.split}: {why}")
        return out

    def _node_axis(self, node: int) -> np.ndarray:
        """Unit node axis ``a_i - b_i`` (any vector when the node is -1)."""
        fs = self.fs
        if node < 0:
            return np.zeros(3)
        d = np.asarray(fs.structure.vertices_a[node] - fs.structure.vertices_b[node], float)
        return d / np.linalg.norm(d)

    def _set_butt_directions(self) -> None:
        """Every part slides in along one direction: a family-1 plate with slots along its
        slide direction (:meth:`.crossings.CrossingSlotter._slide_plan`), any other butted
        part along the first direction, of those its butt joints allow
        (:meth:`_butt_candidates`), that runs into none of the plates it butts against. The
        butt joints record it as their ``insert_direction``; :meth:`_check_paths` may pick a
        later one."""
        fs = self.fs
        plan = getattr(fs, "_plan", {})
        butted: dict[str, list[int]] = {}
        for k, j in enumerate(fs.joints):
            if j.kind == JointKind.BUTT_BRACKET:
                names = [n for n in j.parts if n != j.connector]
                butted.setdefault(names[-1], []).append(k)
        #: part name -> (its butt joints, the directions it may go in along, best first; None:
        #: each joint keeps its own)
        fs._directions: dict[str, tuple] = {}
        for name, ks in butted.items():
            walls = fs._walls.get(name, [])
            if name in plan:
                cands = [plan[name][0]]
            elif not walls:
                cands = None
            else:
                cands = self._butt_candidates(ks, walls)
            fs._directions[name] = (ks, cands)
            for k in ks if cands else ():
                fs.joints[k] = replace(fs.joints[k], insert_direction=np.asarray(cands[0], float))
        for name in sorted(set(plan) - set(butted)):      # slotted plates without butt joints
            fs._directions[name] = ([], [plan[name][0]])

    def _roots(self) -> list[Part]:
        """The plates no plate they are joined to goes in before (the family-0 plates of an
        egg-crate, the halves of a mitred strip, a plate others butt against): they carry the
        others and are fixed to the building (:mod:`.fixings`)."""
        fs = self.fs
        after = _butted_after(self.fs)
        later = {b for a in after for b in after[a]}
        return [p for p in fs.parts if p.family in (0, 1) and p.name not in later]

    def _slot_hung(self, roots: list[Part]) -> dict[str, np.ndarray]:
        """``{plate: direction}``: the plates other than ``roots`` that hang in egg-crate slots
        only and whose way out of them dips more than
        :data:`~torsal.fabrication.assembly.load_path.SLIDE_DIP_DEG` below the horizontal
        (model +z up): their weight would draw them back out the way they slid in, so they
        are fixed to the building too, coming down onto their fixings along that slide
        direction (the load path, :mod:`torsal.fabrication.assembly.load_path`)."""
        fs = self.fs
        rooted = {p.name for p in roots}
        out = dipping_slot_plates(fs, exclude=rooted)
        # a plate bolted (bracket, splice) to a plate fixed to the building is held already
        for j in fs.joints:
            if j.connector and rooted & set(j.parts):
                for name in j.parts:
                    out.pop(name, None)
        return out

    def _root_direction(self, p: Part) -> np.ndarray | None:
        """The direction a plate comes down onto its fixings along (towards the building; None
        for a free strip): where it meets a part of its strip placed before it on a mitred
        seam (spliced, or bridged by the brackets of a crossing), that seam's node axis
        ``a - b`` (it lies in the seam's plane: the end slides along the other part's, the
        clearance kept); else its mean node axis."""
        fs = self.fs
        for other, _, _, node in sorted(fs._seams.get(p.name, ()), key=lambda x: x[0]):
            if other < p.name and node >= 0:    # placed before it (by name, as the check does)
                return self._node_axis(node)
        nodes = [int(v) for v in p.nodes if v >= 0]
        if not nodes:
            return None
        d = np.sum([self._node_axis(v) for v in nodes], axis=0)
        n = np.linalg.norm(d)
        return d / n if n > 1e-9 else None

    def _set_root_directions(self) -> None:
        """A plate on fixings goes in along its fixing joints' direction (one candidate: its
        fixings sit on the side it comes down towards)."""
        fs = self.fs
        ks: dict[str, list[int]] = {}
        for k, j in enumerate(fs.joints):
            if j.kind == JointKind.FIXING:
                ks.setdefault(j.parts[1], []).append(k)
        for name, idx in ks.items():
            fs._directions[name] = (idx, [fs.joints[idx[0]].insert_direction])

    def _check_paths(self) -> None:
        """The path of every part into place (:class:`_PathCheck`): each plate goes in along
        the first of its directions (:meth:`_set_butt_directions`, :meth:`_set_root_directions`)
        whose path is clear, recorded in its joints; then every connector
        (:meth:`_check_connectors`). A fixing in a plate's way is taken away (its panel is
        not fixed in the next build: ``_fixing_exclude``); a part with no clear path keeps its
        first direction and is listed in ``_blocked_paths`` (panels are left out in the next
        build: :meth:`_blocked_panels`)."""
        fs = self.fs
        paths = _PathCheck(fs)
        fs._blocked_paths = []
        fs._evicted = []
        for name, (ks, cands) in fs._directions.items():
            p = paths.bodies[paths.index[name]]
            tries = cands if cands else [fs.joints[ks[0]].insert_direction]
            first = None
            for d in tries:
                h = self._evict_fixings(paths, p, d)
                if not h:
                    break
                first = h if first is None else first
            else:
                d = tries[0]
                fs._blocked_paths.append((p, first))
            for k in ks if cands else ():
                fs.joints[k] = replace(fs.joints[k], insert_direction=np.asarray(d, float))
        self._check_connectors(paths)
        self._drop_evicted()

    def _evict_fixings(self, paths: "_PathCheck", p: Part, d, **kw) -> list[tuple]:
        """:meth:`_PathCheck.hits` of ``p`` along ``d`` once every fixing in its way (other than
        its own) is taken away and listed in ``_evicted``."""
        fs = self.fs
        while True:
            h = paths.hits(p, d, **kw)
            gone = {o.name for _, o, _, _ in h if o.family == FIXING_FAMILY
                    and fs._fixing_sites.get(o.name, ("",))[0] != p.name}
            if not gone:
                return h
            for name in sorted(gone):
                self._remove_fixing(name)
                paths.remove(name)

    def _remove_fixing(self, name: str) -> None:
        """Take fixing ``name`` out of the way: listed in ``_evicted`` (strip, panel of the strip:
        no fixing there in the next build); the part and its joint go once the paths are
        checked (:meth:`_drop_evicted`: joint indices stay valid meanwhile)."""
        fs = self.fs
        plate, j = fs._fixing_sites[name]
        part = fs.part(plate)
        fs._evicted.append((name, fs._strip_of.get(plate), part.span[0] + j))

    def _drop_evicted(self) -> None:
        """Take the fixings out of the way and the connectors dropped (their joints go)."""
        fs = self.fs
        gone = {name for name, _, _ in fs._evicted} | set(fs._dropped_connectors)
        if not gone:
            return
        fs.parts = [q for q in fs.parts if q.name not in gone]
        fs._fixings = [q for q in fs._fixings if q.name not in gone]
        fs._connectors = [q for q in fs._connectors if q.name not in gone]
        fs.joints = [j for j in fs.joints if not (j.kind == JointKind.FIXING and j.parts[0] in gone)
                     and j.connector not in gone]
        for name in gone:
            fs._fixing_sites.pop(name, None)
            fs._sites.pop(name, None)

    def _check_connectors(self, paths: "_PathCheck") -> None:
        """Every connector goes on last, by name, along its joint's ``connector_direction``: where
        that path is not clear of the parts in place (a plate that is not its joint's passing
        through the corner), it moves to another place its joint allows (another corner,
        the other side of a seam, smaller: ``_sites``, :func:`~.joints.connector_variants`);
        where none is clear it is listed in ``_blocked_paths`` like a plate."""
        fs = self.fs
        where = {j.connector: k for k, j in enumerate(fs.joints) if j.connector}
        moves = len(fs._moved_connectors)
        for c in sorted(fs.connectors, key=lambda c: c.name):
            k = where.get(c.name)
            if k is None:
                continue
            d = fs.joints[k].connector_direction
            h = self._evict_fixings(paths, c, d)
            if not h:
                continue
            moved = self._move_connector(paths, c, k)
            if moved is not None:
                continue
            # a connector placed before it in the way: move that one instead, where it can go
            # and leave this one's path clear
            for o in dict.fromkeys(o.name for _, o, _, _ in h if o.family == CONNECTOR_FAMILY):
                if o in where and self._move_connector(paths, paths.bodies[paths.index[o]], where[o],
                                                       also=(c, d)) is not None:
                    moved = c
                    break
            if moved is not None:
                continue
            if self._twin(k):
                # the butted part has another bracket at this node (in the other corner): the
                # joint does without this one
                fs._dropped_connectors.append(c.name)
                paths.remove(c.name)
                continue
            fs._blocked_paths.append((c, h))
        # a connector moved for a later one may now stand in the way of one between them;
        # where none moved, the parts only went away since each path was found clear (fixings
        # evicted, connectors dropped), so no path is checked twice (example 9: 648
        # connectors, none moved, 2.4 s a build)
        if len(fs._moved_connectors) == moves:
            return
        blocked = {p.name for p, _ in fs._blocked_paths}
        for c in sorted(fs.connectors, key=lambda c: c.name):
            k = where.get(c.name)
            if k is None or c.name in blocked or c.name in fs._dropped_connectors:
                continue
            h = self._evict_fixings(paths, c, fs.joints[k].connector_direction)
            if h:
                fs._blocked_paths.append((c, h))

    def _twin(self, k: int) -> bool:
        """Whether joint ``k``'s parts are joined at its node by another connector still in
        place (a butted part bracketed in both corners)."""
        fs = self.fs
        j = fs.joints[k]
        gone = set(fs._dropped_connectors)
        return any(o.connector and o.connector != j.connector and o.connector not in gone
                   and o.node == j.node and o.kind == j.kind and o.parts[:-1] == j.parts[:-1]
                   for o in fs.joints)

    def _move_connector(self, paths: "_PathCheck", c: Part, k: int, *, also=None):
        """Put connector ``c`` (joint ``k``) at the first place of its site whose path is clear
        (and, with ``also`` = (connector, direction), leaves that one's path clear too); None
        (unchanged) if there is none."""
        fs = self.fs
        site = fs._sites.get(c.name)
        if site is None:
            return None
        a, b, options = site
        old = (c.panels.copy(), c.miters.copy())
        shortest = min_leg(fastener_for(fs.thickness * UNIT_TO_MM[fs.unit]), thickness=fs.thickness,
                           unit=fs.unit)
        places = [(opt, q) for opt in options
                  for q in connector_variants(a, b, *opt[:4], thickness=fs.thickness,
                                              gap=CONNECTOR_GAP * fs.thickness,
                                              plates=tuple(fs.part(n).slab_corners(j, fs.thickness)
                                                           for n, j in opt[6]))
                  if not (q.shape == old[0].shape and np.allclose(q, old[0]))]
        # places whose legs take a bolt first (another corner or side at full size before a
        # smaller one in the same corner: a bracket without holes is not fastened)
        places.sort(key=lambda oq: _leg_length(oq[1]) < shortest)
        for opt, q in places:
            _, _, _, _, cdir, angle, _ = opt
            cdir = np.asarray(cdir, float) / np.linalg.norm(cdir)
            n = quad_normals(q)
            c.panels, c.miters = q, np.array([n[0], _miter(n[0], n[1]), n[1]])
            paths.replace(c)
            if not self._evict_fixings(paths, c, cdir) and (
                    also is None or not self._evict_fixings(paths, *also)):
                fs.joints[k] = replace(fs.joints[k], connector_direction=cdir, angle=float(angle))
                fs._moved_connectors.append(c.name)
                # the place used first: its legs lie on these panels (for the holes)
                fs._sites[c.name] = (a, b, [opt] + [o for o in options if o is not opt])
                return c
        c.panels, c.miters = old
        paths.replace(c)
        return None

    def _butt_candidates(self, ks: list[int], walls: list) -> list[np.ndarray]:
        """Directions a part with butt joints ``ks`` and the faces ``walls`` it ends against
        may slide in along, best first: those that run into none of those faces (the node axis
        of a butt joint first: it lies in both plates, the end slides along the plate it meets;
        then the lines where two faces meet, then head on), else the one that runs in least."""
        fs = self.fs
        cands = [self._node_axis(fs.joints[k].node) for k in ks]
        cands += [fs.joints[k].insert_direction for k in ks]
        cands += [_cross(a, b) for i, a in enumerate(walls) for b in walls[i + 1:]]
        cands.append(-np.sum(walls, axis=0))
        cands = [c / np.linalg.norm(c) for c in cands if np.linalg.norm(c) > 1e-9]
        cands = [s_ * c for c in cands for s_ in (1.0, -1.0)]
        run_in = [max(c @ n for n in walls) for c in cands]
        ok = [c for c, r in zip(cands, run_in) if r <= 1e-3]
        return ok if ok else [cands[int(np.argmin(run_in))]]

    def _plate_panels(self, body: Part, panel: int) -> list[tuple[Part, int]]:
        """The fin panels that leaving out would take ``panel`` of ``body`` away: the panel of a
        plate; the panels a connector's legs lie on (its joint goes with either)."""
        fs = self.fs
        if body.name in fs._strip_of:
            return [(body, panel)]
        site = fs._sites.get(body.name)
        if site is None:
            return []
        hosts = site[2][0][6]
        return [(fs.part(name), j) for name, j in hosts if name in fs._strip_of]

    def _loose_panels(self) -> list[tuple]:
        """The panels of the fin plates that nothing would hold: no joint with another part
        and no room for a fixing (a sliver of a strip between the boundary and its first
        crossing, say). They are left out (named, with the others, in ``coplanar_panels``):
        a workshop has no way to fix them, and the load path
        (:mod:`torsal.fabrication.assembly.load_path`) would refuse them."""
        fs = self.fs
        joined = {n for j in fs.joints for n in j.parts}
        unholdable = getattr(fs, "_unholdable", set())
        out = []
        for p in fs.parts:
            if p.family not in (0, 1):
                continue
            si = fs._strip_of[p.name]
            mine = [(si, p.span[0] + j) for j in range(len(p.panels))]
            gone = [k in unholdable for k in mine]
            if any(gone):
                why = (f"{p.name} is held by nothing: no fixing fits on it, and the parts it "
                       "meets reach the building through nothing either")
            elif p.name in joined or any(k in fs._fixing_exclude for k in mine):
                continue    # (a fixing taken out of a part's way: the load path judges it)
            else:
                gone = [True] * len(mine)
                why = (f"{p.name} is held by nothing: it meets no other part and has no room "
                       "for a fixing")
            out += [(si, k, p.name[:-4], int(p.edges[j]), int(p.nodes[j]), why)
                    for j, (_, k) in enumerate(mine) if gone[j]]
        return out

    def _blocked_panels(self, *, leaving: set = frozenset()) -> list[tuple]:
        """Panels to leave out so that every part can be put in (``_blocked_paths``: parts whose
        path, along every direction their joints allow, runs into a part in place before
        them): of every such pair of panels the cheaper one
        (:meth:`.clash.ClashFinder._panel_cost`; for a connector, the panels its legs lie on),
        unless one of the two is in ``leaving`` ({(strip index, panel of the strip)}) already."""
        fs = self.fs
        cost = ClashFinder(fs)._panel_cost
        gone = set(leaving)
        out = []
        for p, hits in fs._blocked_paths:
            for i, o, jo, d in hits:
                mine = self._plate_panels(p, i)
                theirs = self._plate_panels(o, jo)
                keys = {id(x): (fs._strip_of[x[0].name], x[0].span[0] + x[1]) for x in mine + theirs}
                if not mine + theirs or any(k in gone for k in keys.values()):
                    continue
                q, j = min(mine + theirs, key=lambda x: cost(*x))
                key = (fs._strip_of[q.name], q.span[0] + j)
                if any(q is x[0] and j == x[1] for x in mine):
                    why = (f"the path of {p.name} into place comes within {d:.2f} {fs.unit} of "
                           f"{o.name}, which is in place before it" if q is not p else
                           f"its path into place comes within {d:.2f} {fs.unit} of "
                           f"{o.name}, which is in place before it")
                else:
                    why = f"the path of {p.name} into place comes within {d:.2f} {fs.unit} of {o.name}"
                gone.add(key)
                out.append((key[0], key[1], q.name[:-4], int(q.edges[j]), int(q.nodes[j]), why))
        return out


def _leg_length(q: np.ndarray) -> float:
    """The shorter leg of a bent connector (2, 4, 3): bend line to free edge."""
    return float(min(np.linalg.norm(q[0, 1] - q[0, 0]), np.linalg.norm(q[1, 1] - q[1, 0])))
