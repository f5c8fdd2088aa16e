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

from ..model import JointKind, Part, _cross
from .clash import ClashFinder
from .proximity import _quad_distances, _slab_depths, _swept_distances

#: a part's path into place is blocked where its swept solid and a plate in place overlap by
#: more than this fraction of the thickness (less is touching, e.g. corners that meet)
SLAB_TOUCH = 0.01


def _assembly_order(names: list[str], after: dict) -> list[str]:
    """The plates ``names`` in the order they go in: a plate after those it must follow
    (``after`` = ``{a: {b: ...}}``: ``b`` after ``a``, see :meth:`FinSystem._butted_after`),
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


class _PathCheck:
    """The paths of parts into place, checked against the plates that may be in place before
    them, on the panels' mid-surfaces (:func:`_swept_distances`).

    A part goes in along a direction ``d`` over ``travel``: its extent along ``d`` (plus the
    thickness), but no more than the deepest joint at which it goes in after its partners (the
    fin depth there: then it is clear of them), plus the thickness. The plates go in in the
    order a workshop follows (:func:`_assembly_order`): those before it are in place. A pair of
    panels blocks the path when the one, thickened and swept along the path, and the other,
    thickened, overlap by more than :data:`SLAB_TOUCH` of the thickness (:func:`_slab_depths`;
    looked at where their mid-surfaces come within ``thickness + clearance/2``:
    :func:`_swept_distances`), or, for panels nearer than that in place (at a joint), when
    their mid-surfaces come nearer by more than ``clearance/2`` than in place (a butted end
    slides along the plate it meets; slotted panels cross and never block).
    """

    def __init__(self, fs):
        self.t, self.c = fs.thickness, fs.clearance
        self.plates = [p for p in fs.parts if p.family in (0, 1)]
        sizes = [len(p.panels) for p in self.plates]
        self.quads = (np.concatenate([p.panels for p in self.plates]) if self.plates
                      else np.zeros((0, 4, 3)))
        self.owner = np.repeat(np.arange(len(self.plates)), sizes)
        self.panel = np.concatenate([np.arange(n) for n in sizes]) if sizes else np.zeros(0, int)
        self.lo, self.hi = self.quads.min(axis=1), self.quads.max(axis=1)
        self.index = {p.name: k for k, p in enumerate(self.plates)}
        order = _assembly_order([p.name for p in self.plates], AssemblyPlanner(fs)._butted_after())
        self.rank = {n: r for r, n in enumerate(order)}
        self.order = np.array([self.rank[p.name] for p in self.plates], int)
        #: deepest joint at which a part goes in after its partners
        self.depth: dict[str, float] = {}
        for j in fs.joints:
            names = [n for n in j.parts if n != j.connector]
            if j.kind == JointKind.BUTT_BRACKET:
                later = names[-1:]
            elif j.kind == JointKind.EGG_CRATE:
                later = [n for n in names if n[:2] == "F1"]
            else:
                later = []
            for n in later:
                if j.depth is not None:
                    self.depth[n] = max(self.depth.get(n, 0.0), float(j.depth))

    def travel(self, p: Part, d: np.ndarray) -> float:
        ext = p.panels.reshape(-1, 3) @ d
        travel = float(ext.max() - ext.min()) + self.t
        if p.name in self.depth:
            travel = min(travel, self.depth[p.name])
        return travel + self.t

    def hits(self, p: Part, d: np.ndarray) -> list[tuple]:
        """``[(panel of p, plate, panel of the plate, least distance)]``, nearest first: the
        panel pairs that block the path of ``p`` along unit direction ``d``."""
        d = np.asarray(d, float)
        vec = -self.travel(p, d) * d
        reach = self.t + 0.5 * self.c          # the largest limit (see the class text)
        lo = np.minimum(p.panels.min(axis=(0, 1)), (p.panels + vec).min(axis=(0, 1))) - reach
        hi = np.maximum(p.panels.max(axis=(0, 1)), (p.panels + vec).max(axis=(0, 1))) + reach
        before = self.order < self.rank.get(p.name, -1)
        cand = np.flatnonzero(((self.lo <= hi) & (self.hi >= lo)).all(axis=1) & before[self.owner])
        if not len(cand):
            return []
        swept = _swept_distances(p.panels, vec, self.quads[cand])              # (k, m)
        i, j = np.divmod(np.arange(swept.size), len(cand))
        still = _quad_distances(p.panels[i], self.quads[cand][j]).reshape(swept.shape)
        # panels at a joint (nearer in place than plates can be apart) must not come nearer;
        # any others that come that near are checked as solids
        joint = still < reach
        near = ~joint & (swept < reach)
        ii, jj = np.nonzero(near)
        near[ii, jj] = _slab_depths(p.panels[ii], vec, self.quads[cand[jj]], self.t) > SLAB_TOUCH * self.t
        ii, jj = np.nonzero(near | (joint & (swept < still - 0.5 * self.c)))
        out = [(int(a), self.plates[self.owner[cand[b]]], int(self.panel[cand[b]]), float(swept[a, b]))
               for a, b in zip(ii, jj)]
        return sorted(out, key=lambda h: (h[3], h[1].name, h[0], h[2]))


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


class AssemblyPlanner:
    """Plans the assembly of a fin system ``fs`` under construction: the order its parts go in
    (:meth:`_butted_after`), crossings to split the other way (:meth:`_break_cycles`), each butted
    part's insertion direction (:meth:`_set_butt_directions`, :meth:`_check_paths`) and the
    panels to leave out where a path is blocked (:meth:`_blocked_panels`)."""

    def __init__(self, fs):
        self.fs = fs

    def _butted_after(self) -> dict:
        """``{part: {part placed after it: node}}``: family-1 plates go on family-0 plates
        at an egg-crate, a butted part after the plate it butts against (the two parts of a
        mitred seam in either order)."""
        fs = self.fs
        after: dict[str, dict[str, int]] = {}
        conn = {j.connector for j in fs.joints if j.connector}
        for j in fs.joints:
            names = [n for n in j.parts if n not in conn]
            if j.kind == JointKind.EGG_CRATE:
                pairs = [(a, b) for a in names for b in names if a[:2] == "F0" and b[:2] == "F1"]
            elif j.kind == JointKind.BUTT_BRACKET:
                pairs = [(a, names[-1]) for a in names[:-1]]
            else:
                pairs = []
            for a, b in pairs:
                after.setdefault(a, {})[b] = j.node
        return after

    def _break_cycles(self, forced: dict) -> dict:
        """Crossings to split the other way (``{node: (family split, reason)}``) so that no
        parts butt on each other in a cycle (A against B, B against C, C against A: the last
        one could not be put in). In every cycle, the crossings of two passing strips where
        family 0 is split are split on family 1 instead (family 0 continuous, as family-1
        plates are put on family-0 plates), or, if there are none, the first crossing whose
        joint is not yet forced has its split family swapped."""
        fs = self.fs
        after = self._butted_after()
        split_at = {x.node: x for x in fs.joinery}
        out = {}
        for comp in _cycles(after):
            why = f"the parts {', '.join(comp[:4])} would butt on each other in a cycle"
            # crossings where a family-0 part butts against a family-1 plate (family 0 split
            # there: by the joinery, or for length): split family 1 there too, bracketed across
            back = sorted({v for a in comp if a[:2] == "F1" for b, v in after.get(a, {}).items()
                           if b in comp and b[:2] == "F0" and v in split_at and v not in forced})
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

    def _check_paths(self) -> None:
        """The path of every part into place (:class:`_PathCheck`): each part goes in along the
        first of its directions (:meth:`_set_butt_directions`) whose path is clear, recorded in
        its joints; a part with no clear path keeps the first and is listed in
        ``_blocked_paths`` (panels are left out in the next build: :meth:`_blocked_panels`)."""
        fs = self.fs
        paths = _PathCheck(fs)
        fs._blocked_paths = []
        for name, (ks, cands) in fs._directions.items():
            p = paths.plates[paths.index[name]]
            tries = cands if cands else [fs.joints[ks[0]].insert_direction]
            first = None
            for d in tries:
                h = paths.hits(p, d)
                if not h:
                    break
                first = h if first is None else first
            else:
                d = tries[0]
                fs._blocked_paths.append((p, first))
            for k in ks if cands else ():
                fs.joints[k] = replace(fs.joints[k], insert_direction=np.asarray(d, float))

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

    def _blocked_panels(self, *, leaving: set = frozenset()) -> list[tuple]:
        """Panels to leave out so that every part can be put in (``_blocked_paths``: parts whose
        path, along every direction their joints allow, runs into a plate in place before
        them): of every such pair of panels the cheaper one
        (:meth:`.clash.ClashFinder._panel_cost`), unless one of the two is in ``leaving``
        ({(strip index, panel of the strip)}) already."""
        fs = self.fs
        cost = ClashFinder(fs)._panel_cost
        gone = set(leaving)
        out = []
        for p, hits in fs._blocked_paths:
            for i, o, jo, d in hits:
                mine = (fs._strip_of[p.name], p.span[0] + i)
                theirs = (fs._strip_of[o.name], o.span[0] + jo)
                if mine in gone or theirs in gone:
                    continue
                if cost(p, i) <= cost(o, jo):
                    q, j, key = p, i, mine
                    why = (f"its path into place comes within {d:.2f} {fs.unit} of panel "
                           f"{int(o.edges[jo])} of {o.name[:-4]}, which is in place before it")
                else:
                    q, j, key = o, jo, theirs
                    why = (f"the path of {p.name} into place comes within {d:.2f} {fs.unit} "
                           f"of it")
                gone.add(key)
                out.append((key[0], key[1], q.name[:-4], int(q.edges[j]), int(q.nodes[j]), why))
        return out
