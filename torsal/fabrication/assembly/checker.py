"""The assembly check as an object: :class:`AssemblyChecker` owns the solids of one check and
everything made from them (face records, covers, boundary triangles), runs the touching pairs
and the paths into place (in forked workers that inherit it, :mod:`.workers`) and returns an
:class:`~.result.AssemblyCheck`. :func:`check_assembly` and :func:`verify_assembly` are its
front doors (the rules are in :mod:`torsal.fabrication.assembly`).

Units: those of the solids (``unit``, mm by default): volumes in unit^3.
"""
from __future__ import annotations

import os
import time
from collections import Counter
from typing import Callable, Iterable, Mapping

import numpy as np

from .memo import AssemblyMemo, solid_digest
from .occ import (INSIDE_TOLERANCE, _bbox, _boundary_triangles, _boundary_triangles_by_face,
                  _face_records, _first_vertex,
                  _inside, _mesh, _near, _shape, _vertices, common_volume, is_upright)
from .records import (AssemblyJoint, _as_joint, _candidate_directions, _placement_order,
                      joint_groups, joints_of)
from .result import MIN_INTERFERENCE_VOLUME, TOUCHING_TOLERANCE, AssemblyCheck, AssemblyStep, Interference
from .prepared import PreparedSolid, SolidRecords, face_records_of
from .separation import _boxes_meet, prisms_clear_of_each, solid_clear, solid_cover, surfaces_clear
from .sweep import swept_overlap
from .workers import JobPool

__all__ = ["AssemblyChecker", "check_assembly", "verify_assembly"]

Progress = Callable[[str, int, int], None]


def _box_pairs(boxes: np.ndarray, grow: float) -> list[tuple[int, int]]:
    """Index pairs (i < j) whose boxes, grown by ``grow``, overlap (sort and sweep on x)."""
    lo, hi = boxes[:, 0] - grow, boxes[:, 1] + grow
    # all pairs at once, a block of rows at a time (n^2 comparisons: 0.1 M for 7a's 318
    # solids, where a sweep in Python took 0.2 s); row-major order is the sorted order
    pairs = []
    for r in range(0, len(boxes), 1024):
        rows = slice(r, r + 1024)
        meet = np.triu(_boxes_meet(lo[rows], hi[rows], lo, hi), 1 + r)
        pairs += [(int(i) + r, int(j)) for i, j in zip(*np.nonzero(meet))]
    return pairs


class AssemblyChecker:
    """One assembly check of named OCC solids and their joint records.

    It meshes the solids once (before any worker is forked) and keeps, per solid and per
    process, what the cheap tests need (face records, covers, boundary triangles); a forked
    worker inherits the checker and fills its own copies. Nothing outlives the object but
    ``memo`` (:class:`~.memo.AssemblyMemo`): pairs and paths proved before for the same
    solids are taken from it, and what this check proves is added to it.

    >>> from build123d import Box, Pos
    >>> chk = AssemblyChecker(["a", "b"], [Box(2, 2, 2), Pos(1, 0, 0) * Box(2, 2, 2)], workers=1)
    >>> [(x.parts, round(x.volume, 6)) for x in chk.run().interfering]
    [(('a', 'b'), 4.0)]
    """

    def __init__(self, names: list[str], solids: list, joints: Iterable = (), *,
                 tolerance: float = TOUCHING_TOLERANCE, min_volume: float = MIN_INTERFERENCE_VOLUME,
                 workers: int | None = None, unit: str = "mm", progress: Progress | None = None,
                 memo: AssemblyMemo | None = None, ways: Mapping | None = None):
        self.names = [str(n) for n in names]
        dup = sorted({n for n in self.names if self.names.count(n) > 1})
        if dup:
            raise ValueError(f"solids with the same name {dup[:8]}: every part needs one solid "
                             "of its own")
        self.shapes = [_shape(s) for s in solids]
        self.joints = [_as_joint(j) for j in joints]
        self.tolerance, self.min_volume, self.unit = float(tolerance), float(min_volume), unit
        self.workers = min(2, os.cpu_count() or 1) if workers is None else workers
        self.progress = progress
        self.memo = memo
        #: name -> the only directions that part may go in along (see :func:`check_assembly`)
        self.ways = {str(n): [np.asarray(w, float) / np.linalg.norm(w) for w in ws]
                     for n, ws in (ways or {}).items()}
        self.memo_hits = self.memo_misses = 0
        self._mesh_done = False
        self._kept: dict = {}             # (what, solid index) -> faces, cover or triangles
        for k, s in enumerate(solids):    # records made where the solids were read
            if isinstance(s, PreparedSolid):
                self._take_records(k, s.records)

    # ------------------------------------------------------------------ per-solid records
    def _keep(self, what: str, k: int, make):
        key = (what, k)
        if key not in self._kept:
            self._kept[key] = make()
        return self._kept[key]

    def _take_records(self, k: int, rec: SolidRecords) -> None:
        """Keep the :class:`~.prepared.SolidRecords` of solid ``k`` as its own (the
        records of a :class:`~.prepared.PreparedSolid`: made once, where it was read)."""
        faces = face_records_of(self.shapes[k], rec)
        self._kept[("faces", k)] = faces
        self._kept[("vertices", k)] = rec.vertices
        self._kept[("cover", k)] = [(faces[n], rec.cover_vector) for n in rec.cover_faces]
        self._kept[("boundary", k)] = rec.triangles
        self._kept[("face counts", k)] = rec.face_triangle_counts

    def faces(self, k: int) -> list:
        """Face records of solid ``k``, made once per process."""
        return self._keep("faces", k, lambda: _face_records(self.shapes[k]))

    def vertices(self, k: int) -> np.ndarray:
        """(v, 3) vertices of solid ``k``, made once per process."""
        return self._keep("vertices", k, lambda: _vertices(self.shapes[k]))

    def upright(self, k: int) -> bool:
        """:func:`~.occ.is_upright` of solid ``k``, once per process, when a boolean needs it
        (not checked by OpenCascade in each of its booleans)."""
        return self._keep("upright", k, lambda: is_upright(self.shapes[k]))

    def _meshed(self) -> None:
        """Triangulate the solids for the cheap tests, once, before any worker is forked (a
        check whose pairs and paths all come from its memo needs no triangles)."""
        if not self._mesh_done:
            _mesh(self.shapes, self.tolerance)
            self._mesh_done = True

    def cover(self, k: int) -> list:
        """:func:`~.separation.solid_cover` of solid ``k``, made once per process."""
        return self._keep("cover", k, lambda: solid_cover(self.shapes[k], self.faces(k)))

    def triangles(self, k: int) -> tuple:
        """``(triangles, box, triangle boxes)`` of solid ``k`` for the cheap tests."""
        def make():
            tri = self._kept.get(("boundary", k))
            if tri is None:
                tri, self._kept[("face counts", k)] = _boundary_triangles_by_face(self.shapes[k])
            return tri, _bbox(self.shapes[k]), (tri.min(axis=1), tri.max(axis=1))
        return self._keep("triangles", k, make)

    def face_triangles(self, k: int) -> list[np.ndarray]:
        """The boundary triangles of each face of solid ``k`` (:meth:`faces`' order), once per
        process: slices of :meth:`triangles` (the numbers :func:`~.occ._boundary_triangles`
        of each face gives), where each face's count is known, else read face by face."""
        def make():
            tri = self.triangles(k)[0]
            counts = self._kept.get(("face counts", k))
            if counts is None or len(counts) != len(self.faces(k)):
                return [_boundary_triangles(f.face) for f in self.faces(k)]
            return np.split(tri, np.cumsum(counts)[:-1])
        return self._keep("face triangles", k, make)

    # ------------------------------------------------------------------ jobs (any process)
    def pair(self, job) -> tuple:
        """``(i, j, distance, common volume, error)`` of a candidate pair ``(i, j)``."""
        return self.pairs_of((job[0], (job[1],)))[0]

    def pairs_of(self, job) -> list[tuple]:
        """:meth:`pair` of ``(i, j)`` for each ``j`` of ``job = (i, js)``, the first cheap proof
        of the touching ones (the cover of ``i`` clear of ``j``) made for all of them in one
        vectorized pass (:meth:`_covers_clear`): the same proof per pair, without numpy's
        overhead per call (most touching pairs are proved apart by it)."""
        i, js = job
        first = [self._apart(i, j) for j in js]          # None: touching, to be proved
        clear = self._covers_clear(i, [j for j, r in zip(js, first) if r is None])
        # the second cheap proof (the cover of each j clear of i) for all those left at once
        second = self._clear_of_covers(i, [j for j, r in zip(js, first)
                                           if r is None and j in clear and not clear[j]])
        return [r if r is not None else
                (i, j, 0.0, 0.0, "") if clear.get(j) else
                self._touching(i, j, j in clear, second.get(j))
                for j, r in zip(js, first)]

    def _apart(self, i: int, j: int) -> tuple | None:
        """The result of pair ``(i, j)`` when their boundaries are apart and neither is inside
        the other (distance inf) or the test failed; None: they touch."""
        try:
            a, b = self.shapes[i], self.shapes[j]
            if not _near(a, b, self.tolerance) and not (self._inside(i, j) or self._inside(j, i)):
                return i, j, float("inf"), 0.0, ""     # boundaries apart, neither inside
            return None
        except Exception as e:   # OpenCascade failures: reported per pair, never assumed clear
            return i, j, float("nan"), float("nan"), f"{type(e).__name__}: {e}"

    def _covers_clear(self, i: int, js: list[int]) -> dict[int, bool]:
        """``{j: solid_clear(cover(i), triangles(j))}`` for ``js`` in one pass of
        :func:`~.separation.prisms_clear_of_each` (exactly as one call per pair: the same
        axes, the tolerance scaled per solid); ``{}`` where it fails (each pair tries
        again on its own)."""
        try:
            cover = self.cover(i)
            if not cover or not js:
                return {j: False for j in js}
            each = prisms_clear_of_each([f for f, _ in cover], np.array([w for _, w in cover]),
                                        [self.triangles(j) for j in js],
                                        np.ones((len(cover), len(js)), bool))
            return dict(zip(js, each.all(axis=0).tolist()))
        except Exception:
            return {}

    def _clear_of_covers(self, i: int, js: list[int]) -> dict[int, bool]:
        """``{j: solid_clear(cover(j), triangles(i))}`` for ``js`` in one pass of
        :func:`~.separation.prisms_clear_of_each` (the prisms of all the covers against the
        one solid ``i``, grouped by cover: the same axes and the tolerance scaled per cover,
        as one call per pair); ``{}`` where it fails (each pair tries again on its own)."""
        try:
            covers = {j: self.cover(j) for j in js}
            out = {j: False for j, c in covers.items() if not c}      # no cover: no proof
            have = [j for j in js if covers[j]]
            if not have:
                return out
            faces = [f for j in have for f, _ in covers[j]]
            vectors = np.array([w for j in have for _, w in covers[j]])
            groups = np.repeat(np.arange(len(have)), [len(covers[j]) for j in have])
            each = prisms_clear_of_each(faces, vectors, [self.triangles(i)],
                                        np.ones((len(faces), 1), bool), groups=groups)[:, 0]
            bad = np.zeros(len(have), bool)
            np.logical_or.at(bad, groups, ~each)
            return out | dict(zip(have, (~bad).tolist()))
        except Exception:
            return {}

    def _touching(self, i: int, j: int, first_done: bool, second: bool | None = None) -> tuple:
        """The result of a touching pair ``(i, j)``: within the tolerance on the
        triangulations (exact for planar faces), so touching; the exact distance
        (solid_distance) would cost ten booleans a pair. A pair that a cheap exact test proves
        apart has nothing in common (``first_done``: the cover of ``i`` was tried already;
        ``second``: what the cover of ``j`` proved, if tried, :meth:`_clear_of_covers`);
        the others get the boolean."""
        try:
            a, b = self.shapes[i], self.shapes[j]
            (ta, ba, tba), (tb, bb, tbb) = self.triangles(i), self.triangles(j)
            if second is None:
                second = solid_clear(self.cover(j), ta, ba, triangle_boxes=tba)
            if (not first_done and solid_clear(self.cover(i), tb, bb, triangle_boxes=tbb)) or \
                    second or surfaces_clear(ta, tb, ba, bb, triangle_boxes=tbb):
                return i, j, 0.0, 0.0, ""
            return i, j, 0.0, common_volume(a, b, upright=self.upright(i) and self.upright(j)), ""
        except Exception as e:   # OpenCascade failures: reported per pair, never assumed clear
            return i, j, float("nan"), float("nan"), f"{type(e).__name__}: {e}"

    def _inside(self, k: int, other: int) -> bool:
        """:func:`~.occ._inside` of solid ``k`` in solid ``other``: a point outside the box
        of ``other`` (a solid lies in its box) is not inside it, without classifying it."""
        p = _first_vertex(self.shapes[k])
        if p is None:
            return False
        lo, hi = self.boxes[other]
        xyz = np.array([p.X(), p.Y(), p.Z()])
        if (xyz < lo - INSIDE_TOLERANCE).any() or (xyz > hi + INSIDE_TOLERANCE).any():
            return False
        return _inside(self.shapes[k], self.shapes[other])

    def sweep(self, job) -> tuple:
        """``(k, [swept overlap with each other])`` of solid ``k`` moved by ``vector``."""
        k, vector, others, stop_above = job
        return k, swept_overlap(self.shapes[k], vector, [self.shapes[o] for o in others],
                                stop_above=stop_above, faces=self.faces(k),
                                face_triangles=self.face_triangles(k),
                                upright=lambda n: self.upright(others[n]),
                                triangles=lambda n: self.triangles(others[n])[0],
                                boxes=lambda n: self.boxes[others[n]])

    def _map(self, method: str, jobs: list, what: str) -> list:
        if method == "pair":            # one job per first solid: :meth:`pairs_of`
            groups: dict[int, list[int]] = {}
            for i, j in jobs:
                groups.setdefault(i, []).append(j)
            done = self._pool.map("pairs_of", [(i, tuple(js)) for i, js in groups.items()],
                                  progress=self.progress, what=what)
            found = {(r[0], r[1]): r for rs in done for r in rs}
            return [found[tuple(job)] for job in jobs]
        return self._pool.map(method, jobs, progress=self.progress, what=what)

    def _memoized(self, method: str, jobs: list, keys: list, what: str) -> list:
        """``_map(method, jobs)``, the results of jobs whose key the memo holds taken from it
        (``keys[n]`` None: not memoized); new results are added to the memo."""
        if self.memo is None:
            self._meshed()
            return self._map(method, jobs, what)
        get, keep = ((self.memo.pair, self.memo.keep_pair) if method == "pair" else
                     (self.memo.path, self.memo.keep_path))
        known = [None if k is None else get(k) for k in keys]
        todo = [n for n, v in enumerate(known) if v is None]
        self.memo_hits += len(jobs) - len(todo)
        self.memo_misses += len(todo)
        if todo:
            self._meshed()
        done = self._map(method, [jobs[n] for n in todo], what) if todo else []
        for n, result in zip(todo, done):
            known[n] = result
            if keys[n] is not None and not (method == "pair" and result[4]):
                keep(keys[n], result)         # a failed boolean is tried again next time
        return known

    def _pair_key(self, i: int, j: int):
        a, b = sorted((self.digests[i], self.digests[j]))
        return (a, b, self.tolerance, self.min_volume)

    # ------------------------------------------------------------------ the check
    def run(self) -> AssemblyCheck:
        """Touching pairs, interference and the assembly order (see the package text)."""
        t0 = time.perf_counter()
        try:
            self.boxes = np.array([_bbox(s) for s in self.shapes]).reshape(-1, 2, 3)
            self.digests = ([solid_digest(s, self.vertices(k)) for k, s in enumerate(self.shapes)]
                            if self.memo is not None else None)
            # one pool of workers for the pairs and every try of the paths: a worker keeps the
            # face records, covers and triangles it made (forked after the meshing and boxes)
            with JobPool(self, workers=self.workers) as self._pool:
                touching, interfering, failed = self._touching_pairs()
                order = self._assembly_order()
        finally:
            self._kept.clear()
            self._pool = None
        kinds = Counter(j.kind for j in self.joints)
        # connector parts (brackets, splice plates) by the kind of joint they fasten
        connectors = Counter(j.kind for j in
                             {j.connector: j for j in self.joints if j.connector}.values())
        return AssemblyCheck(parts=self.names, pairs_checked=len(touching),
                             interfering=interfering, order=order, failed_pairs=failed,
                             joints=dict(sorted(kinds.items())),
                             connectors=dict(sorted(connectors.items())),
                             min_volume=self.min_volume, unit=self.unit,
                             seconds=time.perf_counter() - t0, memo_hits=self.memo_hits,
                             memo_misses=self.memo_misses)

    def _touching_pairs(self):
        names = self.names
        jobs = _box_pairs(self.boxes, 0.5 * self.tolerance)
        keys = [self._pair_key(i, j) if self.memo is not None else None for i, j in jobs]
        touching, interfering, failed = set(), [], []
        results = self._memoized("pair", jobs, keys, "pairs")
        # a memo keeps (i, j) of the check that proved it: the pair is this check's
        for (i, j), (_, _, dist, vol, err) in zip(jobs, results):
            if err:
                failed.append((names[i], names[j], err))
                touching.add((i, j))
            elif dist <= self.tolerance:
                touching.add((i, j))
                if vol > self.min_volume:
                    interfering.append(Interference((names[i], names[j]), float(vol)))
        interfering.sort(key=lambda x: -x.volume)
        return touching, interfering, failed

    def _plans(self) -> list[tuple]:
        """Per step in the placement order: ``(solid, partners placed before, joint kinds,
        [(direction, travel, solids placed before near the path)])``."""
        names, boxes, tol = self.names, self.boxes, self.tolerance
        index = {n: i for i, n in enumerate(names)}
        order = [index[n] for n in _placement_order(names, self.joints)]
        rank = {k: r for r, k in enumerate(order)}
        in_order = np.asarray(order, dtype=np.int64)
        before_lo, before_hi = boxes[in_order, 0], boxes[in_order, 1]
        joint_of: dict[int, list[AssemblyJoint]] = {k: [] for k in range(len(names))}
        for jt in self.joints:
            for p in jt.parts:
                if p in index:
                    joint_of[index[p]].append(jt)
        plans = []
        for k in order:
            partners, kinds, axes, slotted, depths = set(), [], [], [], []
            for jt in joint_of[k]:
                groups = joint_groups(jt)
                mine = next(g for g, ps in enumerate(groups) if names[k] in ps)
                placed = [index[p] for g in groups[:mine] for p in g
                          if p in index and rank[index[p]] < rank[k]]
                if placed:
                    partners.update(placed)
                    kinds.append(jt.kind)
                    own = (jt.connector_direction if names[k] == jt.connector
                           and jt.connector_direction is not None else jt.insert_direction)
                    axes.append(np.asarray(own, float))
                    slotted.append(jt.kind == "egg-crate")
                    depths.append(jt.depth if jt.connector != names[k] else None)
            verts = self.vertices(k)
            cands = []
            ways = self.ways.get(names[k]) if axes else None
            for d in (ways if ways else _candidate_directions(axes, slotted)):
                # start one depth of the part (its extent along d) back: disengaged from its
                # joints (a slot is at most as long as the part is deep along its axis)
                ext = verts @ d
                travel = float(ext.max() - ext.min())
                if depths and all(x is not None and x > 0 for x in depths):
                    # disengaged from its joints once slid back by their depth (a long, skewed
                    # plate need not come from beyond its own far end)
                    travel = min(travel, max(depths))
                travel += tol
                lo = np.minimum(boxes[k, 0], boxes[k, 0] - travel * d) - tol
                hi = np.maximum(boxes[k, 1], boxes[k, 1] - travel * d) + tol
                # the parts placed before whose boxes meet the path's (vectorized: a loop in
                # Python over every part placed before was quadratic, 5 s on example 9)
                before = in_order[:rank[k]]
                near = (before_lo[:rank[k]] <= hi).all(axis=1) & (lo <= before_hi[:rank[k]]).all(axis=1)
                others = before[near].tolist()
                cands.append((d, travel, others))
            plans.append((k, sorted(partners, key=rank.get), tuple(sorted(set(kinds))), cands))
        return plans

    def _assembly_order(self) -> list[AssemblyStep]:
        """Steps with the first clear insertion direction of every part: the first direction
        of every part is tried at once, then the next for those still blocked."""
        names, plans = self.names, self._plans()
        best: dict[int, tuple] = {n: (None, 0.0, ()) for n, p in enumerate(plans) if not p[3]}
        pending = [n for n, p in enumerate(plans) if p[3]]
        attempt = 0
        while pending:
            jobs = [(plans[n][0], plans[n][3][attempt][1] * plans[n][3][attempt][0],
                     plans[n][3][attempt][2], self.min_volume) for n in pending]
            keys = [None if self.memo is None else
                    (self.digests[k], tuple(np.round(np.asarray(v, float), 9) + 0.0),
                     tuple(self.digests[o] for o in others), mv)
                    for k, v, others, mv in jobs]
            results = self._memoized("sweep", jobs, keys, f"paths (try {attempt + 1})")
            still = []
            for n, (_, vols) in zip(pending, results):
                d, travel, others = plans[n][3][attempt]
                hits = tuple(sorted((Interference((names[plans[n][0]], names[o]), float(v))
                                     for o, v in zip(others, vols) if not v <= self.min_volume),
                                    key=lambda x: -x.volume))
                total = sum(h.volume for h in hits)
                if n not in best or total < sum(h.volume for h in best[n][2]):
                    best[n] = (d, travel, hits)
                if hits and attempt + 1 < len(plans[n][3]):
                    still.append(n)
            pending, attempt = still, attempt + 1
        steps = []
        for n, (k, partners, kinds, _) in enumerate(plans):
            d, travel, hits = best[n]
            steps.append(AssemblyStep(step=n + 1, part=names[k],
                                      insert_direction=None if d is None else tuple(float(x) for x in d),
                                      travel=float(travel), partners=tuple(names[o] for o in partners),
                                      joint_kinds=kinds, collisions=hits))
        return steps


def check_assembly(solids: Mapping | Iterable, *, joints: Iterable = (),
                   tolerance: float = TOUCHING_TOLERANCE, min_volume: float = MIN_INTERFERENCE_VOLUME,
                   workers: int | None = None, unit: str = "mm",
                   progress: Progress | None = None,
                   memo: AssemblyMemo | None = None, ways: Mapping | None = None) -> AssemblyCheck:
    """Check named solids for interference and find an assembly order (see the package text).

    Parameters
    ----------
    solids : mapping name -> solid, or iterable of (name, solid)
        build123d or OCP solids, e.g. ``FinSystem.solids()`` or ``read_step("fins.step")``.
        Names must be unique.
    joints : iterable of joint records
        Objects with ``kind, node, parts, insert_direction, connector`` (see
        :class:`~.records.AssemblyJoint` and :func:`~.records.joints_of`). Parts without
        joints are set down in place (no path is checked).
    tolerance : float
        Pairs closer than this (unit) are touching and get the exact boolean.
    min_volume : float
        Common volume (unit^3) above which two parts interfere or a path collides.
    workers : int, optional
        Processes for the pair and path checks; default ``min(2, cpu count)``.
    progress : callable(phase, done, total), optional
    memo : AssemblyMemo, optional
        Pairs and paths proved before, by the solids' content: taken from it, and what this
        check proves added (``AssemblyCheck.memo_hits`` counts what it saved).
    ways : mapping name -> sequence of (3,) directions, optional
        The only directions (in that sense, in that order) the named parts may go in along,
        in place of those their joints suggest (a part with no joint to a part placed before
        it is still set down in place). A check of a few parts cut out of a design passes the
        ways along which each whole part was proved to go in: a local check free to try
        others could clear a part along a way its parts far off block.

    Returns
    -------
    AssemblyCheck

    >>> from build123d import Box, Pos
    >>> check_assembly({"a": Box(1, 1, 1), "b": Pos(3, 0, 0) * Box(1, 1, 1)}, workers=1).buildable
    True
    """
    items = list(solids.items()) if isinstance(solids, Mapping) else list(solids)
    return AssemblyChecker([n for n, _ in items], [s for _, s in items], joints,
                           tolerance=tolerance, min_volume=min_volume, workers=workers,
                           unit=unit, progress=progress, memo=memo, ways=ways).run()


def verify_assembly(fin_system, *, step_file=None, tolerance: float = TOUCHING_TOLERANCE,
                    min_volume: float = MIN_INTERFERENCE_VOLUME, workers: int | None = None,
                    progress: Progress | None = None) -> AssemblyCheck:
    """:func:`check_assembly` of a :class:`~torsal.fabrication.FinSystem`: its solids (or, with
    ``step_file``, the solids re-read from that STEP file, as a fabricator would get them) and
    its joints (:func:`~.records.joints_of`)."""
    if step_file is not None:
        from ..solids import read_step

        solids = read_step(step_file)
    else:
        solids = fin_system.solids()
    return check_assembly(solids, joints=joints_of(fin_system), tolerance=tolerance,
                          min_volume=min_volume, workers=workers, unit=fin_system.unit,
                          progress=progress)
