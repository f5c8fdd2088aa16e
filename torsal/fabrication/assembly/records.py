"""The joint records the assembly check reads, and what it makes of them: which parts go in
one after the other (:func:`joint_groups`), the order parts are placed in and the directions
each may go in along.

Only the records' fields are read (kind, node, parts, insert direction, connector, depth), never
the joint builder's code: the check stays independent of it.
"""
from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np

__all__ = ["AssemblyJoint", "joints_of", "joint_groups", "insertion_ways"]


class AssemblyJoint(NamedTuple):
    """What the check needs of a joint (``torsal.fabrication`` ``Joint`` records have these
    fields too): ``kind`` (e.g. ``"egg-crate"``), structure ``node``, the ``parts`` it joins
    (names; earlier names are placed first), ``insert_direction`` ((3,) unit vector, model
    coordinates, the sense the later parts move in; the other sense is tried too) and the
    ``connector`` part, if any."""

    kind: str
    node: int
    parts: tuple
    insert_direction: np.ndarray
    connector: str | None = None
    #: (3,) direction the connector is put on along (None: ``insert_direction``)
    connector_direction: np.ndarray | None = None
    #: length (unit) over which the joint's parts engage along its axis, e.g. the fin depth at
    #: the node (a slot is never longer); None: unknown (the part's own extent is used)
    depth: float | None = None


def joints_of(fin_system) -> list[AssemblyJoint]:
    """Joint records of a fin system: ``fin_system.joints`` when it has them, else its egg-crate
    crossings (family-0 parts first; the family-1 plate, slotted from its ``a`` edge, moves
    along the node axis ``a_i - b_i`` onto them) and the mitred splits inside a strip (the
    later part slides along the node line of the split)."""
    joints = getattr(fin_system, "joints", None)
    if joints is not None:
        return [_as_joint(j) for j in joints]
    st = fin_system.structure
    out = []

    def axis(node):
        d = np.asarray(st.vertices_a[node] - st.vertices_b[node], float)
        return d / np.linalg.norm(d)

    for x in fin_system.crossings:
        out.append(AssemblyJoint("egg-crate", int(x.node), tuple(x.parts0) + tuple(x.parts1),
                                 axis(x.node), None))
    # parts of one strip split inside it meet mitred on the bisector plane of the fold, which
    # holds the node line: the later part slides along it
    parts = list(fin_system.parts)
    for prev, nxt in zip(parts[:-1], parts[1:]):
        if (prev.id.family, prev.id.strip) == (nxt.id.family, nxt.id.strip) and \
                nxt.ends[0] == "miter" and int(nxt.nodes[0]) >= 0:
            out.append(AssemblyJoint("mitre", int(nxt.nodes[0]), (prev.name, nxt.name),
                                     axis(int(nxt.nodes[0])), None))
    return out


def _as_joint(j) -> AssemblyJoint:
    """An :class:`AssemblyJoint` from any record with the same fields."""
    if isinstance(j, AssemblyJoint):
        return j
    cd = getattr(j, "connector_direction", None)
    depth = getattr(j, "depth", None)
    return AssemblyJoint(str(getattr(j.kind, "value", j.kind)), int(j.node), tuple(j.parts),
                         np.asarray(j.insert_direction, float), getattr(j, "connector", None),
                         None if cd is None else np.asarray(cd, float),
                         None if depth is None else float(depth))


def joint_groups(joint: AssemblyJoint) -> list[tuple[str, ...]]:
    """The parts of a joint in the groups that go in one after the other: for an egg-crate the
    plates of one family, then those of the other (named ``F<family>-...``: two parts of one
    strip split at the crossing are not each other's partners); for a butt joint the parts of
    the plate it butts against (one group: they are not joined to each other by it), the butted
    part, the connector (a ``butt-tab``: the butted part's end bent into a tab lying on the
    plate, no connector); for a mitre the two parts (either may go in first: they meet on the
    fold's bisector plane), then the splice plate; otherwise one part at a time."""
    if joint.kind == "egg-crate":
        groups: dict[str, list] = {}
        for p in joint.parts:
            groups.setdefault(p.split("-", 1)[0], []).append(p)
        return [tuple(g) for g in groups.values()]
    if joint.kind in ("butt-bracket", "butt-tab"):
        plates = [p for p in joint.parts if p != joint.connector]
        return ([tuple(plates[:-1])] if len(plates) > 1 else []) + [(plates[-1],)] + (
            [(joint.connector,)] if joint.connector else [])
    if joint.kind == "mitre-splice":
        return [tuple(p for p in joint.parts if p != joint.connector)] + (
            [(joint.connector,)] if joint.connector else [])
    return [(p,) for p in joint.parts]


def _placement_order(names: list[str], joints: list[AssemblyJoint]) -> list[str]:
    """Parts in an order where, for every joint, the groups it lists first come first (as far
    as the joints agree; a conflicting precedence is dropped), ties by name."""
    index = {n: i for i, n in enumerate(names)}
    before: dict[str, set] = {n: set() for n in names}
    for j in joints:
        groups = [[p for p in g if p in index] for g in joint_groups(j)]
        for ga, gb in zip(groups[:-1], groups[1:]):
            for b in gb:
                before[b].update(a for a in ga if a != b)
    connectors = {j.connector for j in joints if j.connector}
    order, placed = [], set()
    remaining = sorted(names)
    while remaining:
        ready = [n for n in remaining if before[n] <= placed]
        if not any(n not in connectors for n in ready):
            # plates wait only for connectors, or for each other (a cycle): take the plate with
            # the fewest plates missing before it
            plates = [n for n in remaining if n not in connectors]
            if plates:
                ready = [min(plates, key=lambda n: (len(before[n] - placed - connectors), n))]
            elif not ready:
                ready = [min(remaining, key=lambda n: (len(before[n] - placed), n))]
        # connectors (brackets, splice plates) go on once the plates around them are in
        nxt = next((n for n in ready if n not in connectors), ready[0])
        order.append(nxt)
        placed.add(nxt)
        remaining.remove(nxt)
    return order


def _candidate_directions(axes: list[np.ndarray], slotted: list[bool] | None = None) -> list[np.ndarray]:
    """Directions to try: the mean axis of the slotted joints (a slot allows one direction; a
    butt end slides along the plate it meets), the mean of all axes (signed alike), then each
    distinct axis; both senses."""
    if not axes:
        return []
    ref = axes[0]
    signed = [a if a @ ref >= 0 else -a for a in axes]
    cands = []
    slotted = slotted or [False] * len(axes)
    for group in ([a for a, sl in zip(signed, slotted) if sl], signed):
        mean = np.sum(group, axis=0) if group else np.zeros(3)
        if np.linalg.norm(mean) > 1e-9 and all(abs(mean @ c) < (1.0 - 1e-12) * np.linalg.norm(mean)
                                              for c in cands):
            cands.append(mean / np.linalg.norm(mean))
    for a in signed:           # each joint's own axis, exactly: the path a slot allows
        if all(abs(a @ c) < 1.0 - 1e-12 for c in cands):
            cands.append(a)
    # a part held between plates it butts against slides along the line where their faces
    # meet: the cross product of two butt directions (plate normals)
    for a, b in itertools.combinations([a for a, sl in zip(signed, slotted) if not sl][:4], 2):
        c = np.cross(a, b)
        if np.linalg.norm(c) > 1e-6:
            cands.append(c / np.linalg.norm(c))
    # at most ten directions, both senses: a part that none of these lets in is blocked (only
    # blocked parts pay for the further tries)
    return [s * c for c in cands[:10] for s in (1.0, -1.0)]


def insertion_ways(joints, names: set) -> dict[str, tuple]:
    """``{part: (3,) directions}``: for each of the parts ``names``, the directions its joint
    records ``joints`` (the whole design's) give it where it goes in after a partner (the
    builder proved its whole path along them: the builder's ``AssemblyPlanner._check_paths``),
    each once, in the joints' order; a connector's own ``connector_direction``. A local
    check passes them as :func:`~.checker.check_assembly`'s ``ways``, so that a part is not
    cleared on a way its whole part never takes.

    >>> j = AssemblyJoint("egg-crate", 3, ("A", "B"), np.array([0.0, 0.0, 1.0]))
    >>> insertion_ways([j], {"A", "B"})          # A is placed first: it has no way in here
    {'B': (array([0., 0., 1.]),)}"""
    out: dict[str, list] = {}
    for j in joints:
        rec = _as_joint(j)
        for group in joint_groups(rec)[1:]:
            for n in group:
                if n not in names:
                    continue
                w = (rec.connector_direction if n == rec.connector
                     and rec.connector_direction is not None else rec.insert_direction)
                w = np.asarray(w, float)
                have = out.setdefault(n, [])
                if np.linalg.norm(w) > 0 and not any(np.allclose(w, x, atol=1e-12) for x in have):
                    have.append(w)
    return {n: tuple(ws) for n, ws in out.items()}
