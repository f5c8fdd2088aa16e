"""What a live session keeps warm between edits: stage results in memory
(:class:`WarmCache`) and the built congruence problem with its last optimum
(:class:`WarmProblem`)."""
from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from ..geometry.optimize import CongruenceProblem
from ..geometry.optimize.solve import Solver, route
from ..pipeline.cache import MISSING, StageCache
from ..pipeline.design_file import DesignSpec
from ..pipeline.problem import congruence_problem

__all__ = ["WarmCache", "WarmProblem"]


#: stage results a session keeps in memory per stage. The stage cache on disk keeps one entry
#: per stage, so an edit taken back finds its results only here: with 4, session_bench's rows
#: (a setup and an edit each) pushed the file's design out after two rows, and going back to
#: it re-solved its congruence (1 s). A 7a result at full size is about 50 kB
KEEP_RESULTS = 16


class WarmCache(StageCache):
    """A :class:`~torsal.pipeline.cache.StageCache` with the last results of each stage kept
    in memory too: a session reads an unchanged stage's result without unpickling it, and
    an edit undone finds its results again. Thread-safe (the preview and the background
    build share it).

    Parameters
    ----------
    folder : path
        The stage cache on disk (``OUT/.torsal-cache``, as ``torsal design`` keeps it).
    keep : int
        Results kept in memory per stage (the most recent; default :data:`KEEP_RESULTS`).

    Examples
    --------
    >>> import tempfile
    >>> c = WarmCache(tempfile.mkdtemp())
    >>> c.store("remesh", "k1", {"delta_pl": 0.1})
    >>> c.load("remesh", "k1")["delta_pl"], c.load("remesh", "k2") is MISSING
    (0.1, True)
    """

    def __init__(self, folder, *, keep: int | None = None):
        super().__init__(folder, enabled=True, prune=True)
        self.keep = KEEP_RESULTS if keep is None else int(keep)
        self._memory: dict[str, OrderedDict] = {}
        self._lock = threading.Lock()

    def _remember(self, name: str, key: str, value) -> None:
        entries = self._memory.setdefault(name, OrderedDict())
        entries[key] = value
        entries.move_to_end(key)
        while len(entries) > self.keep:
            entries.popitem(last=False)

    def load(self, name: str, key: str):
        with self._lock:
            entries = self._memory.get(name, {})
            if key in entries:
                return entries[key]
        value = super().load(name, key)
        if value is not MISSING:
            with self._lock:
                self._remember(name, key, value)
        return value

    def has(self, name: str, key: str) -> bool:
        with self._lock:
            if key in self._memory.get(name, {}):
                return True
        return super().has(name, key)

    def store(self, name: str, key: str, value) -> None:
        with self._lock:
            self._remember(name, key, value)
        super().store(name, key, value)


def _structure(p: CongruenceProblem) -> dict:
    return {name: kind for name, (kind, _, _) in p.terms.items()}


def _energy_vertices(p: CongruenceProblem) -> dict[str, np.ndarray]:
    """The vertices (sorted ids) each energy of one line per element (``f_perp``, ``f_par``,
    lines through points) of ``p`` acts on: those with a nonzero weight where the term has
    per-vertex weights (a let-through region as NLP parameters, ``weighted_subsets``)."""
    out = {}
    for name, t in p.registry.terms.items():
        if t.constraint or t.element is None or t.idx.shape[1] != 3:
            continue
        idx = t.idx if t.element_weights is None else t.idx[np.asarray(t.element_weights) > 0]
        out[name] = np.unique(idx // 3)
    return out


#: a moved region's lines restart within this many mean edge lengths of its edge, before or
#: after the edit (:func:`restarted`): 7a's lines bend towards a let-through region's edge over
#: about three rings (full size, the region moved 0.5 m: 3 and 6 gave 6 Newton steps, 27-30
#: factorizations, against 8 and 38 restarting only the vertices whose goal changed)
RESTART_BAND = 4.0
#: how much a line's signed distance from its region's edge counts against its place on the
#: surface when a restarted line is matched (:func:`restarted`; 3 and 10 gave the same steps)
RESTART_SIDE_WEIGHT = 10.0


def _signed_distance(v: np.ndarray, members: np.ndarray) -> np.ndarray:
    """(n,) distance of each vertex of ``v`` (n, 3) from the edge of the set ``members``:
    positive inside (to the nearest vertex outside), negative outside (to the nearest member)."""
    from scipy.spatial import cKDTree

    inside = np.zeros(len(v), bool)
    inside[members] = True
    to_out = cKDTree(v[~inside]).query(v[inside])[0]
    to_in = cKDTree(v[inside]).query(v[~inside])[0]
    out = np.empty(len(v))
    out[inside], out[~inside] = to_out, -to_in
    return out


def _matched(e: np.ndarray, last: np.ndarray, v: np.ndarray, old: np.ndarray, new: np.ndarray,
             changed: np.ndarray, band: float) -> None:
    """Into ``e``: for each vertex of mesh A (``v`` (n, 3)) within ``band`` of the edge of
    ``old`` or ``new`` (an energy's vertices before and after the edit) or in ``changed``, the
    last design's line (``last``) at the vertex on the same side of the old edge whose
    signed distance from it and place are nearest its own from the new edge
    (:data:`RESTART_SIDE_WEIGHT`)."""
    from scipy.spatial import cKDTree

    s_old, s_new = _signed_distance(v, old), _signed_distance(v, new)
    near = (np.abs(s_old) < band) | (np.abs(s_new) < band)
    near[changed[changed < len(v)]] = True
    was, now = np.isin(np.arange(len(v)), old), np.isin(np.arange(len(v)), new)
    for side in (True, False):
        # sides by membership (a vertex on top of another has distance 0 from the edge)
        to = np.flatnonzero(near & (now == side))
        src = np.flatnonzero(was == side)
        if to.size and src.size:
            tree = cKDTree(np.c_[v[src], RESTART_SIDE_WEIGHT * s_old[src]])
            j = tree.query(np.c_[v[to], RESTART_SIDE_WEIGHT * s_new[to]])[1]
            e[to] = last[src[j]]


def restarted(optimum, before: dict[str, np.ndarray], problem: CongruenceProblem):
    """``optimum`` with the lines about a moved goal region put where its new goal's lines are:
    for an energy of one line per vertex whose vertices an edit changed (a let-through or
    see-through region moved), each vertex of mesh A within :data:`RESTART_BAND` mean edge
    lengths of the region's edge, old or new, or whose goal changed, takes the last design's
    line at a vertex on the same side of the old edge, at nearly the same signed distance
    from it and nearest on the surface. Where the energy was or is over no vertex or every
    vertex of A (a region added or removed: no edge to match), a vertex it now takes has the
    line of the nearest vertex that had that goal before and keeps it, and the others whose
    goal changed restart where a cold solve starts them (the problem's start directions).

    A vertex that an edit moves into or out of an energy of its own line (a region moved)
    keeps a line made for its old goal, and that line can be a stationary point of its new
    one: a line the blocking goal made perpendicular to the sun is one of ``|e x d|^2``'s
    maxima when a let-through region takes it over (``f_par``), so a warm re-solve would
    leave it there (7a at test size: energy 0.100 against a cold run's 0.057). A line made
    for the new goal at the same distance from the region's edge is also bent as the edge
    bends the lines next to it: 7a at full size, the let-through region x [4, 6] moved to
    [3.5, 5.5] / [4.5, 6.5] / widened to [3, 6] m, re-solved in 6 / 6 / 9 Newton steps (27 /
    30 / 40 factorizations) against 8 / 10 / 10 (38 / 44 / 45) restarting only the vertices
    whose goal changed (from the nearest line across the old edge), energies 0.01-0.03 %
    lower. A stroke's faces (``f_dir``, an energy of a face's three lines) keep their lines:
    from them a moved stroke reaches a cold run's energy (tests/session), and restarted,
    7a's at full size took 7 IPOPT iterations instead of 0. ``before``:
    :func:`_energy_vertices` of the problem ``optimum`` solved; energies present in both with
    other vertices are compared (an energy added or removed as a whole changes no vertex's
    goal more than another's). A substructure's lines (after mesh A's) whose goal changed
    restart from their start.

    >>> from torsal.geometry import Congruence
    >>> from torsal.geometry.surfaces import facade_patch
    >>> from torsal.geometry.optimize.strategy import Optimum
    >>> p = CongruenceProblem(Congruence.from_normals(facade_patch(nu=5, nv=5)))
    >>> p = p.perpendicular([0, 1, 0], vertices=[0, 1, 2])
    >>> last = np.tile([0.0, 0, 1], (25, 1)); last[[0, 1, 3]] = [1.0, 0, 0]   # made for each goal
    >>> e = restarted(Optimum(directions=last), {"perpendicular": np.array([0, 1, 3])}, p).directions
    >>> e[2].tolist(), e[3].tolist(), e[0].tolist(), e[24].tolist()
    ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0])
    """
    from scipy.spatial import cKDTree

    from ..geometry.mesh import average_edge_length

    now = _energy_vertices(problem)
    shared = [k for k in sorted(before.keys() & now.keys()) if not np.array_equal(before[k], now[k])]
    if not shared:
        return optimum
    ids = np.unique(np.concatenate([np.setxor1d(before[k], now[k]) for k in shared]))
    last = np.array(optimum.directions, float).reshape(-1, 3)
    e = last.copy()
    e[ids] = problem.registry.directions()[ids]
    v = problem.congruence.vertices
    band = RESTART_BAND * average_edge_length(v, problem.congruence.faces)
    for k in shared:
        # (a substructure's lines, stacked after mesh A's, restart from their start)
        old, new = before[k][before[k] < len(v)], now[k][now[k] < len(v)]
        if 0 < old.size < len(v) and 0 < new.size < len(v):
            _matched(e, last, v, old, new, ids, band)
            continue
        entered = np.setdiff1d(new, old)
        kept = np.setdiff1d(np.intersect1d(new, old), ids)
        if entered.size and kept.size:
            _, nearest = cKDTree(v[kept]).query(v[entered])
            e[entered] = last[kept[nearest]]
    return replace(optimum, directions=e)


#: congruence problems a session keeps built, by structure (the most recent first): an edit
#: undone (a bound removed, a region taken away) finds its problem's NLP built. Four: the
#: design's own terms and the goals a designer adds and takes back (a region, a bound; strokes
#: share 7a's structure, its boundary's f_dir, since the strokes' faces are weights:
#: session_bench's rows), so a moved point after them re-solves the design's NLP
KEEP_PROBLEMS = 4


class _Kept(NamedTuple):
    """A built problem the session keeps, and mesh A's faces it was made on."""

    problem: CongruenceProblem
    faces: np.ndarray


def _key(p: CongruenceProblem, f: np.ndarray) -> tuple:
    """What a kept problem must share with a design's to take its terms: the terms by name and
    kind, mesh A's faces and size, compiled kernels or not."""
    return (tuple(sorted(_structure(p).items())), len(p.congruence.vertices), f.shape,
            hashlib.sha256(np.ascontiguousarray(f, np.int64).tobytes()).hexdigest(), p.jit)


class WarmProblem:
    """The congruence problems a session keeps built (their compiled kernels and NLPs, up to
    :data:`KEEP_PROBLEMS` structures) and the last good optimum (directions, multipliers,
    penalties) it re-solves from.

    :meth:`make` is the congruence stage's ``make_problem``
    (:func:`~torsal.pipeline.stages.run_congruence`): the design's terms are registered again on
    a kept problem with mesh A's faces and the same terms by name (a weight, a light direction,
    a bound, a moved vertex, and with the let-through region and the strokes' faces as
    per-element weights (``weighted_subsets`` of
    :func:`~torsal.pipeline.problem.congruence_problem`) a moved region or stroke, is then a
    parameter of the built NLP: no rebuild), else a new
    problem is made; either way the solve starts from the last good optimum where it is a
    good start (:meth:`_resumable`). :meth:`commit` keeps the problem and its optimum after a
    good solve; after a rejected edit nothing is committed, so the next solve starts from the
    last good design.

    Examples
    --------
    >>> warm = WarmProblem()
    >>> warm.optimum is None, warm.problem is None
    (True, True)
    """

    def __init__(self, keep: int = KEEP_PROBLEMS):
        self.keep = int(keep)
        self.optimum = None
        self._kept: OrderedDict[tuple, _Kept] = OrderedDict()   # the most recent last
        self._pending: tuple | None = None
        self.reused = 0          # solves on a kept problem (no rebuild of its NLP)
        # the energies' vertices of the design the optimum belongs to, or how to find them
        self._goals: dict[str, np.ndarray] | None = {}
        self._origin: tuple | None = None

    @property
    def problem(self) -> CongruenceProblem | None:
        """The problem solved last (None before a solve)."""
        return next(reversed(self._kept.values())).problem if self._kept else None

    def _kept_for(self, fresh: CongruenceProblem, f: np.ndarray, spec: DesignSpec) -> CongruenceProblem | None:
        """A kept problem that takes ``spec``'s terms (see :func:`_key`), or None."""
        if spec.substructure is not None:
            return None
        kept = self._kept.get(_key(fresh, f))
        return None if kept is None or not np.array_equal(kept.faces, f) else kept.problem

    def _resumable(self, problem: CongruenceProblem, spec: DesignSpec) -> bool:
        """The last optimum is a good start for ``problem``: its size fits, and where the
        augmented Lagrangian solves ``problem`` (a torsal-angle bound, ...), the optimum carries
        the augmented Lagrangian's state. An answer of IPOPT has none (7a without a bound): from
        it the augmented Lagrangian would measure its Newton decrements against the last
        optimum's energy, near zero on a zero-residual design, not against a cold start's, and
        take hundreds of Newton steps for digits no figure shows (7a at full size, a bound of 20
        degrees added: 300 Newton steps and IPOPT's 40 iterations, 23 s of processor time,
        against 7 Newton steps, 0.85 s, cold). Such a problem starts cold, as ``torsal design``
        does; the edits after it re-solve from its answer (7a, 20 -> 22 degrees: 2 Newton steps)."""
        last = self.optimum
        if last is None or np.size(last.directions) != problem.n_var:
            return False
        return last.alm is not None or \
            route(problem.registry, problem.nlp, spec.constraints.solver.value) is not Solver.ALM

    def _before(self) -> dict[str, np.ndarray]:
        """The energies' vertices of the design the last optimum belongs to (:func:`restarted`)."""
        if self._goals is None:
            self._goals = _energy_vertices(congruence_problem(*self._origin, weighted_subsets=True))
        return self._goals

    def make(self, spec: DesignSpec, v: np.ndarray, f: np.ndarray, sun: np.ndarray,
             w_sun: np.ndarray) -> CongruenceProblem:
        """The problem of ``spec`` on mesh A (``v`` (n, 3), ``f`` (m, 3)) with sun
        directions (k, 3) and weights (k,), warm: see the class notes."""
        fresh = congruence_problem(spec, v, f, sun, w_sun, weighted_subsets=True)
        kept = self._kept_for(fresh, f, spec)
        if kept is not None:
            if not np.array_equal(kept.congruence.vertices, v):
                kept.move_vertices(v)    # a moved point: its terms are registered again below
            chosen = congruence_problem(spec, v, f, sun, w_sun, into=kept, weighted_subsets=True)
            self.reused += 1
        else:
            chosen = fresh
        if self._resumable(chosen, spec):
            last = self._origin
            same_faces = last is not None and np.array_equal(last[2], f)
            chosen.warm_start_from(restarted(self.optimum, self._before(), chosen) if same_faces
                                   else self.optimum)
        self._pending = (chosen, np.array(f), (spec, np.array(v), np.array(f), sun, w_sun))
        return chosen

    def commit(self, optimum, origin: tuple | None = None) -> None:
        """A solve succeeded: keep its problem (if :meth:`make` made one) and ``optimum``.
        ``origin``: ``(spec, vertices, faces, sun, sun_weights)`` of the design ``optimum``
        belongs to, where it came from the stage cache (no solve: its goals are found when
        the next solve needs them)."""
        if self._pending is not None:
            problem, faces, origin = self._pending
            key = _key(problem, faces)
            self._kept.pop(key, None)
            self._kept[key] = _Kept(problem, faces)
            while len(self._kept) > self.keep:
                self._kept.popitem(last=False)
            self._goals, self._origin = _energy_vertices(problem), origin
        elif optimum is not None and origin is not None:
            self._goals, self._origin = None, origin
        self._pending = None
        if optimum is not None:
            self.optimum = optimum

    def rollback(self) -> None:
        """An edit was rejected: the next solve starts from the last committed optimum."""
        self._pending = None
