"""The local assembly check of tabs (:mod:`.tabs`): the parts around a node's tabs
(:class:`TabRegion`: the tabbed parts' panels next to it with their tabs, the plates they lie
on, and the panels of every part, connector and fixing near the tabs or the tabbed ends' paths
into place, with their joint records), checked by the independent assembly check
(:func:`~torsal.fabrication.assembly.check_assembly`) at a tenth of its least interference
volume (:data:`LOCAL_VOLUME_SHARE`), in worker processes. Lengths in the fin system's ``unit``.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from torsal.core.units import UNIT_TO_MM

from ..model import CONNECTOR_FAMILY, FIXING_FAMILY, Joint, Part
from .proximity import _swept_and_still_distances
from .tab_sites import TabReason, _Proposal
from ..assembly.records import insertion_ways

__all__ = ["LOCAL_VOLUME_SHARE", "TabRegion"]


#: the local check proves a tab with this share of the assembly check's least interference
#: volume (1 mm^3): a tab whose path grazes a plate by less than that locally may graze it by
#: more once the part is seen whole, with a tab at each end (example 9: five parts with two
#: tabs blocked by 1.0-2.4 mm^3 in the whole design, each tab proved on its own)
LOCAL_VOLUME_SHARE = 0.1


@dataclass(frozen=True)
class _Verdict:
    """The local assembly check of the tabs at one node: ``ok`` or refused (``detail``)."""

    ok: bool
    reason: TabReason | None = None
    detail: str = ""
    parts: tuple = ()


def _local_check(ask: tuple) -> _Verdict:
    """:func:`~torsal.fabrication.assembly.check_assembly` of the local parts with their joint
    records and the ways their whole parts go in (``(parts, joints, thickness, unit, ways)``,
    :func:`~..assembly.records.insertion_ways`), in this process (one argument: a task for a
    worker process).

    Each part goes in only along the ways its whole part was proved to go in along: free to
    try the other sense of its axis, a tabbed part could clear its tab where the rest of it
    runs into a plate far off (example 9: F1-S028-P07, tabbed at both ends, cleared its tab at
    node 405 going in the other way, through F0-S028-P04, 7,350 mm^3). The solids are the bare
    OCC shapes of :func:`~..plates.part_solid` (the same solids, unlabelled), as the seams'
    check takes them: a worker that checks tabs need not import build123d (1.5-2.4 s of
    processor time in each of the two on 7a, while the fin system waits for the verdicts)."""
    from ..assembly import MIN_INTERFERENCE_VOLUME, check_assembly
    from ..plates import InvalidSolidError, _part_shape

    parts, joints, thickness, unit, ways = ask
    try:
        solids = {p.name: _part_shape(p, thickness) for p in parts}
    except InvalidSolidError as e:
        return _Verdict(False, TabReason.SOLID, f"{e}")
    names = set(solids)
    local = []
    for j in joints:
        keep = tuple(n for n in j.parts if n in names)
        if keep:
            local.append(dataclasses.replace(
                j, parts=keep, connector=j.connector if j.connector in names else None))
    r = check_assembly(solids, joints=local, workers=1, unit=unit, ways=ways,
                       min_volume=LOCAL_VOLUME_SHARE * MIN_INTERFERENCE_VOLUME / UNIT_TO_MM[unit] ** 3)
    if r.buildable:
        return _Verdict(True)
    bad = tuple(sorted(set(r.interfering_parts) | {s.part for s in r.blocked}))
    return _Verdict(False, TabReason.ASSEMBLY, r.problems(limit=3).replace("\n", "; "), bad)


def _local_part(part: Part, lo: int, hi: int) -> Part:
    """Panels ``lo..hi-1`` of ``part`` with their slots, under the same name (holes left out)."""
    slots = [dataclasses.replace(s, position=s.position - lo) for s in part.slots
             if lo <= s.position <= hi]
    return dataclasses.replace(part, panels=part.panels[lo:hi].copy(),
                               nodes=np.asarray(part.nodes)[lo:hi + 1].copy(),
                               edges=np.asarray(part.edges)[lo:hi].copy(),
                               miters=part.miters[lo:hi + 1].copy(), slots=slots, holes=())


class TabRegion:
    """The local checks of the tabs of a finished fin system ``fs``: the parts and joint
    records around a node's tabs (:meth:`local`), checked in worker processes
    (:meth:`verdicts`)."""

    #: how far (multiples of the thickness) around a tab and its end the local check looks
    REACH = 2.0

    def __init__(self, fs):
        self.fs = fs

    def _stack(self) -> tuple:
        """``(parts by name, quads (N, 4, 3), owner part (N,), panel (N,), lo (N, 3), hi (N, 3),
        names, {name: index})``: every panel of the fin system's parts, once per
        :meth:`make`."""
        st = self.__dict__.get("_stacked")
        if st is None:
            parts = sorted(self.fs.parts, key=lambda q: q.name)
            quads = np.concatenate([q.panels for q in parts])
            owner = np.repeat(np.arange(len(parts)), [len(q.panels) for q in parts])
            panel = np.concatenate([np.arange(len(q.panels)) for q in parts])
            names = [q.name for q in parts]
            st = self._stacked = (parts, quads, owner, panel, quads.min(axis=1), quads.max(axis=1),
                                  names, {n: i for i, n in enumerate(names)})
        return st

    def local(self, props: list[_Proposal], tabbed: dict[str, Part], joints: list[Joint],
               gone: set) -> tuple:
        """``(parts, joints, thickness, unit, ways)`` of the local assembly check of the tabs
        ``props`` (of one node): what changed there (each tab, and the end it is bent from
        :attr:`REACH` thicknesses into its end panel), swept along the tabbed part's way into
        place both ways over its joint's depth (the parts that go in after it must keep clear
        of the tab too); of every part (plate, connector, fixing; not the brackets ``gone``,
        which tabs replace; the tabbed parts with their tabs) the panels whose mid-surfaces
        come within :attr:`REACH` thicknesses of that region, with their slots; and the joint
        records; and the ways each of those parts goes in along
        (:func:`~..assembly.records.insertion_ways`, from the whole design's joint records)."""
        fs = self.fs
        t = fs.thickness
        reach = self.REACH * t
        region, sweeps = [], []
        for pr in props:
            p = tabbed[pr.part]
            k = len(p.panels)
            tab = p.panels[0 if pr.start else k - 1]
            end = p.panels[1 if pr.start else k - 2]
            (b0, f0), (b1, f1) = ((0, 1), (3, 2)) if pr.start else ((1, 0), (2, 3))
            into = [end[b] + min(1.0, reach / max(float(np.linalg.norm(end[f] - end[b])), 1e-12))
                    * (end[f] - end[b]) for b, f in ((b0, f0), (b1, f1))]
            strip = np.array([end[b0], into[0], into[1], end[b1]])
            j = fs.joints[pr.joint]
            d = np.asarray(j.insert_direction, float)
            travel = (float(j.depth) if j.depth is not None else 0.0) + 2 * t
            region.append(np.array([tab, strip]))
            sweeps.append(travel * d)
        parts, quads, owner, panel, qlo, qhi, names, index = self._stack()
        # (the region each sweeps, both ways, grown by the reach: the boxes first)
        pts = np.concatenate([np.concatenate([r.reshape(-1, 3) - v, r.reshape(-1, 3) + v])
                              for r, v in zip(region, sweeps)])
        lo, hi = pts.min(axis=0) - reach, pts.max(axis=0) + reach
        skip = np.zeros(len(parts), bool)
        skip[[index[n] for n in set(gone) | set(tabbed) if n in index]] = True
        cand = np.flatnonzero(((qlo <= hi) & (qhi >= lo)).all(axis=1) & ~skip[owner])
        near_of: dict[int, set] = {}

        def near(others: np.ndarray) -> np.ndarray:
            out = np.zeros(len(others), bool)
            for r, v in zip(region, sweeps):
                # boxes in a frame along the sweep first (the region is thin across it), then
                # the mid-surfaces' distances
                frame = _frame(v)
                o = others @ frame.T                                 # (m, 4, 3)
                rr = r.reshape(-1, 3) @ frame.T
                rlo, rhi = rr.min(axis=0) - reach, rr.max(axis=0) + reach
                rlo[2] -= np.linalg.norm(v)
                rhi[2] += np.linalg.norm(v)
                box = np.flatnonzero(((o.min(axis=1) <= rhi) & (o.max(axis=1) >= rlo)).all(axis=1))
                if len(box):
                    dist = _swept_and_still_distances(r - v, 2.0 * v, others[box], within=reach)[0]
                    out[box[(dist < reach).any(axis=0)]] = True
            return out

        for i in cand[near(quads[cand])]:
            near_of.setdefault(int(owner[i]), set()).add(int(panel[i]))
        for name, q in tabbed.items():
            hit = np.flatnonzero(near(q.panels))
            if len(hit):
                near_of.setdefault(index[name], set()).update(hit.tolist())
        out = []
        for k in sorted(near_of):
            idx = near_of[k]
            q = tabbed.get(names[k], parts[k])
            out.append(q if q.family in (CONNECTOR_FAMILY, FIXING_FAMILY)
                       else _local_part(q, min(idx), max(idx) + 1))
        names = {q.name for q in out}
        # a slot whose partner plate is not among the local parts holds nothing there: the
        # notch is not cut (the exact cut is the dearest part of a local solid)
        out = [q if all(any(n in names for n in s.partner.split("+")) for s in q.slots)
               else dataclasses.replace(q, slots=[s for s in q.slots if any(
                   n in names for n in s.partner.split("+"))]) for q in out]
        local = [joints[k] for k in sorted({k for n in names for k in self._joints_of(n)})]
        return out, local, t, fs.unit, insertion_ways(local, names)

    def _joints_of(self, name: str) -> list[int]:
        """Indices of the joints (``fs.joints``, in order) that name the part ``name``."""
        of = self.__dict__.get("_of")
        if of is None:
            of = self._of = {}
            for k, j in enumerate(self.fs.joints):
                for n in j.parts:
                    of.setdefault(n, []).append(k)
        return of.get(name, [])

    def verdicts(self, asks: list[tuple]) -> list[_Verdict]:
        from ..workers import map_prepared

        return map_prepared(_local_check, asks)


def _frame(v: np.ndarray) -> np.ndarray:
    """(3, 3) rows: two unit vectors square to ``v`` (3,) and ``v``'s unit direction."""
    d = v / np.linalg.norm(v)
    e1 = np.cross(d, np.eye(3)[int(np.argmin(np.abs(d)))])
    e1 /= np.linalg.norm(e1)
    return np.array([e1, np.cross(d, e1), d])

