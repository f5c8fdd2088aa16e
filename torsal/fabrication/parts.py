"""Parts of a fin system: strips of planar fins grouped into buildable plates (issues 6, 15).

A :class:`FinSystem` reads a :class:`~torsal.geometry.support.SupportStructure` and groups its
fins (one planar quad ``a_i a_j b_j b_i`` per edge) into *parts*, then joins them. It is the
facade of :mod:`torsal.fabrication`: the model (:mod:`.model`), the joinery (:mod:`.joints`),
development (:mod:`.unroll`), solids (:mod:`.solids`) and sheets (:mod:`.layout`) sit below it.

* By default (``family_split="egg-crate"``) every strip of either torsal family is one part, a
  folded plate of planar panels hinged on the node lines ``L_i = a_i b_i``. At every node where
  strips of both families pass, :func:`~.joints.choose_joinery` picks the joint: an egg-crate
  (half-depth slots, family 0 from its ``b`` edge, family 1 from its ``a`` edge, widths from the
  crossing angle, see :func:`~.joints.slot_width`) where the plates slide together along
  ``L_i``, else the strip that folds more is split there and both halves are butted against the
  continuous plate with a bracket (rules and limits in :mod:`.joints`).
* With ``family_split="family0-continuous"`` the strips of family 0 are continuous plates and
  family 1 is cut into single panels between them, butted with brackets.

Where a strip ends against a plate of the other family (a T or L junction on the boundary)
its end panel is trimmed back until its end face clears the faces of that plate (both panels
of it, if it folds there) by ``clearance/2`` and a bracket joins them. Panels meeting at a fold
sharper than ``max_fold_angle`` are split into separate parts: the later part is butt-trimmed
against the square end of the earlier one, with a bracket. Strips with more than
``max_panels`` panels, longer than ``max_part_length`` along their ``a`` and ``b`` edges, or
whose unrolled outline does not fit ``fit_sheet`` (halved until it does) are split too;
closed strips are always cut into at least two parts. Those splits meet on the bisector plane
of the fold (mitred) with a splice plate, or, at a crossing, are butted against the crossing
plate. Connectors (brackets, splice plates) are parts of their own, named ``C-N<node>-<i>``;
:attr:`FinSystem.joints` lists every joint (:class:`~.model.Joint`).

Every part goes in along one direction (:mod:`.joints`, "one insertion direction per part"):
the structure is rebuilt (at most ``MAX_REBUILDS`` times) leaving out end panels that cannot
be trimmed (``coplanar_panels``), butting crossings a plate cannot slide onto together with
its others, and re-splitting crossings where parts would butt on each other in a cycle.
Where two plates cross or come within ``thickness + clearance`` of each other away from any
joint (no node line in common: strips of one family crossing near a singularity of a rough
congruence), one of the two panels is left out too (``coplanar_panels``, naming the other).

**Every part's path into place is clear.** Once the joints are settled, the path of every
part that goes in after others (a butted part, a slotted family-1 plate) is checked against
the plates in place before it, in the order a workshop follows (plates a joint lists first go
first, otherwise by name): its panels, thickened and swept along the path (over the fin depth
of its joints: then it is clear of them), against theirs (:class:`_PathCheck`). A workshop
that finds a part blocked by a neighbouring plate first slides it in another way its joints
allow: a butted part takes the first clear one of its directions (along the node axis of a
butt joint, either sense, along the line where two faces it ends against meet, head on). Only
where none is clear (a slotted plate has one direction only) is a panel left out, as the
trimming does: of every pair of panels on the part's first path that overlap (more than
touch) or, at a joint, come nearer by more than ``clearance/2`` than in place, the cheaper
one (a panel at an end of its part before one inside it, then the one of the shorter strip),
named in ``coplanar_panels``; the structure is rebuilt and checked again. The order itself is
not changed: it follows from the joints, which the assembly check reads too.

Real structures from the remesher have defects near boundaries and at coarse resolution; they
are handled and reported (``warnings.warn`` naming parts, nodes and what to do), never turned
into NaN or invalid solids: degenerate panels (narrower than ``min_panel_width`` or
self-intersecting) are dropped and their strip split there (``dropped_panels``); butt trims
without a solution are skipped (``untrimmed_joints``); joints without room for a connector are
named (``unconnected_joints``); slots that would cut a part in two are made shallower, the
partner's slot deeper (``slot_conflicts``); single panels larger than ``fit_sheet`` are named
(``oversize_panels``; :meth:`FinSystem.layout` refuses them).

Units: the structure is in ``model_unit`` (metres by default); every length held by a
:class:`FinSystem` (``thickness``, ``clearance``, panel coordinates, slots, solids, sheets,
DXF) is in ``unit`` (millimetres by default).

Example
-------
>>> from torsal.fabrication import FinSystem
>>> fs = FinSystem(structure, thickness=3.0, clearance=0.5)        # doctest: +SKIP
>>> fs.parts[0].name, len(fs.parts[0].panels)                      # doctest: +SKIP
('F0-S000-P00', 3)
>>> sorted({j.kind.value for j in fs.joints})                      # doctest: +SKIP
['butt-bracket', 'egg-crate']
"""
from __future__ import annotations

import copy
import dataclasses
import warnings
from dataclasses import replace
from typing import Iterable, NamedTuple, Sequence

import numpy as np

from torsal.core.units import INSUNITS, UNIT_TO_MM

from . import layout as _layout
from . import solids as _solids
from .joints import (MAX_CROSSING_FOLD, MAX_SLOT_SKEW, MIN_CROSSING_ANGLE, _Untrimmable, butt_trim, choose_joinery,
                     corners, into_direction, mitre_trim, place_connector, slot_width, trim_corner,
                     trim_further)
from .model import (CONNECTOR_FAMILY, FAMILY_COLORS, MITER_LIMIT, Crossing, FamilySplit, Joint,
                    JointKind, Part, PartId, Slot, SlotSide, _bowtie, _cross, _fold_deg, _miter,
                    _oriented_size, _safe_normals, fold_angles, panel_widths, quad_normals)
from .unroll import unroll

__all__ = [
    "FamilySplit", "SlotSide", "PartId", "Slot", "Crossing", "Part", "FinSystem", "Joint",
    "JointKind", "UNIT_TO_MM", "INSUNITS", "FAMILY_COLORS", "fold_angles", "quad_normals",
    "MITER_LIMIT", "panel_widths",
]


#: how often :class:`FinSystem` rebuilds, leaving out end panels that cannot be trimmed
MAX_REBUILDS = 8

#: a part's path into place is blocked where its swept solid and a plate in place overlap by
#: more than this fraction of the thickness (less is touching, e.g. corners that meet)
SLAB_TOUCH = 0.01

#: gap left between a connector and the plates it lies on, as a fraction of the thickness
#: (so that touching faces are not coincident for the boolean checks; 0.03 mm at 3 mm)
CONNECTOR_GAP = 0.01


class _Strips(NamedTuple):
    """The structure's strips in ``unit``: ``quads`` (k, 4, 3) and ``drops`` (k,) per strip,
    node line ends ``a``, ``b`` (n, 3) and fin ``depth`` (n,), and per family and node whether
    a strip passes through it (two kept panels) or ends there (one)."""

    fins: list
    quads: list
    drops: list
    a: np.ndarray
    b: np.ndarray
    depth: np.ndarray
    passes: np.ndarray
    ends: np.ndarray


def _merge_coincident_nodes(structure):
    """The structure with nodes of identical node lines (``a`` and ``b`` equal to 1e-9 of its
    size) merged into one index, e.g. the two families of refined developable strips, which
    duplicate the nodes they share: the plates cross there and need a joint."""
    a, b = np.asarray(structure.vertices_a, float), np.asarray(structure.vertices_b, float)
    if not len(a):
        return structure
    tol = 1e-9 * max(1.0, float(np.abs(np.r_[a, b]).max()))
    key = np.round(np.c_[a, b] / tol).astype(np.int64)
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    canon = first[inv.ravel()]
    if (canon == np.arange(len(a))).all():
        return structure
    return dataclasses.replace(structure, edges=canon[np.asarray(structure.edges)],
                               faces=[[int(canon[v]) for v in f] for f in structure.faces])


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


def _memo_key(x):
    """A hashable key of nested arrays, sequences, dicts and scalars (arrays by their bytes)."""
    if isinstance(x, np.ndarray):
        return ("a", x.shape, x.dtype.str, x.tobytes())
    if isinstance(x, (list, tuple)):
        return (type(x).__name__, tuple(_memo_key(y) for y in x))
    if isinstance(x, dict):
        return ("d", tuple(sorted((k, _memo_key(v)) for k, v in x.items())))
    return x


def _quads_cross(p: np.ndarray, q: np.ndarray) -> bool:
    """Whether an edge of a quad of ``p`` (k, 4, 3) passes through a quad of ``q`` (m, 4, 3)
    or the other way round (mid-surfaces, two triangles per quad; Moller-Trumbore): every
    pair of :func:`_edges_pierce`."""
    i, j = np.divmod(np.arange(len(p) * len(q)), len(q))
    return bool((_edges_pierce(p[i], q[j], eps=1e-6) | _edges_pierce(q[j], p[i], eps=1e-6)).any())


def _quads_on(p: np.ndarray, q: np.ndarray, gap: float) -> bool:
    """Whether the centre of a quad of ``p`` (k, 4, 3) lies within ``gap`` of a quad of ``q``
    (m, 4, 3), over it (a fin folded back onto another: coplanar overlap, no edge crossing)."""
    c = p.mean(axis=1)                                                  # (k, 3)
    tris = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])           # (T, 3, 3)
    v0, e1, e2 = tris[:, 0], tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    n = np.cross(e1, e2)
    area2 = np.linalg.norm(n, axis=1)
    ok = area2 > 0
    n = n / np.where(ok, area2, 1.0)[:, None]
    w = c[:, None] - v0[None]                                           # (k, T, 3)
    dist = np.abs(np.einsum("ktj,tj->kt", w, n))
    # barycentric coordinates of the projection
    d00, d01, d11 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    d20, d21 = np.einsum("ktj,tj->kt", w, e1), np.einsum("ktj,tj->kt", w, e2)
    den = np.where(ok, d00 * d11 - d01 * d01, 1.0)
    v = (d11 * d20 - d01 * d21) / den
    u = (d00 * d21 - d01 * d20) / den
    inside = ok & (v > 0) & (u > 0) & (u + v < 1)
    return bool((inside & (dist <= gap)).any())


def _segment_distances(p0, p1, q0, q1) -> np.ndarray:
    """Distances of segments ``p0 p1`` and ``q0 q1`` (broadcast arrays (..., 3)): the closest
    points of the two lines, clamped to the segments (Ericson, Real-Time Collision Detection
    5.1.9)."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a, e = (d1 * d1).sum(-1), (d2 * d2).sum(-1)
    f, c, b = (d2 * r).sum(-1), (d1 * r).sum(-1), (d1 * d2).sum(-1)
    den = a * e - b * b
    safe = lambda x: np.where(x > 0, x, 1.0)  # noqa: E731
    s = np.where(den > 1e-12 * a * e, np.clip((b * f - c * e) / safe(den), 0.0, 1.0), 0.0)
    t = (b * s + f) / safe(e)
    # t outside [0, 1]: clamp it and recompute s for that end of q
    t_lo, t_hi = t < 0, t > 1
    s = np.where(t_lo, np.clip(-c / safe(a), 0.0, 1.0), s)
    s = np.where(t_hi, np.clip((b - c) / safe(a), 0.0, 1.0), s)
    t = np.clip(t, 0.0, 1.0)
    return np.linalg.norm(p0 + s[..., None] * d1 - q0 - t[..., None] * d2, axis=-1)


def _point_triangle_distances(x, tri) -> np.ndarray:
    """Distances of points ``x`` (..., 3) from triangles ``tri`` (..., 3, 3) (broadcast): to
    the plane where the projection falls inside, else to the nearest edge."""
    v0, e1, e2 = tri[..., 0, :], tri[..., 1, :] - tri[..., 0, :], tri[..., 2, :] - tri[..., 0, :]
    w = x - v0
    d00, d01, d11 = (e1 * e1).sum(-1), (e1 * e2).sum(-1), (e2 * e2).sum(-1)
    d20, d21 = (w * e1).sum(-1), (w * e2).sum(-1)
    den = d00 * d11 - d01 * d01
    ok = den > 1e-12 * d00 * d11
    den = np.where(ok, den, 1.0)
    v, u = (d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den
    n = np.cross(e1, e2)
    plane = np.abs((w * n).sum(-1)) / np.where(ok, np.linalg.norm(n, axis=-1), 1.0)
    edges = np.minimum.reduce([_segment_distances(x, x, tri[..., i, :], tri[..., (i + 1) % 3, :])
                               for i in range(3)])
    return np.where(ok & (u >= 0) & (v >= 0) & (u + v <= 1), plane, edges)


def _edges_pierce(p: np.ndarray, q: np.ndarray, *, eps: float = 1e-9) -> np.ndarray:
    """(m,) whether an edge of quad ``p[k]`` (m, 4, 3) passes through the inside of quad
    ``q[k]`` (two triangles; Moller-Trumbore), pair by pair; ``eps``: how far inside (in
    barycentric and edge parameters) a hit must be."""
    e0 = p[:, :, None]                                                  # (m, 4, 1, 3)
    d = np.roll(p, -1, axis=1)[:, :, None] - e0
    tris = np.stack([q[:, [0, 1, 2]], q[:, [0, 2, 3]]], axis=1)[:, None]  # (m, 1, 2, 3, 3)
    v0, v1, v2 = tris[..., 0, :], tris[..., 1, :] - tris[..., 0, :], tris[..., 2, :] - tris[..., 0, :]
    pv = np.cross(d, v2)
    det = (pv * v1).sum(-1)
    ok = np.abs(det) > 1e-12 * np.linalg.norm(v1, axis=-1) * np.linalg.norm(v2, axis=-1) * \
        np.linalg.norm(d, axis=-1)
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    tv = e0 - v0
    u = (tv * pv).sum(-1) * inv
    qv = np.cross(tv, v1)
    v = (d * qv).sum(-1) * inv
    t = (v2 * qv).sum(-1) * inv
    hit = ok & (u > eps) & (v > eps) & (u + v < 1 - eps) & (t > eps) & (t < 1 - eps)
    return hit.any(axis=(1, 2))


def _quad_distances(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(m,) distances of the mid-surfaces of quads ``p[k]`` and ``q[k]`` (m, 4, 3), pair by
    pair: 0 where one passes through the other, else the least of corner-to-quad (two
    triangles each) and edge-to-edge distances (two quads apart come nearest there)."""
    tri = lambda x: np.stack([x[:, [0, 1, 2]], x[:, [0, 2, 3]]], axis=1)  # noqa: E731
    tp, tq = tri(p)[:, None], tri(q)[:, None]                           # (m, 1, 2, 3, 3)
    corner = np.minimum(_point_triangle_distances(p[:, :, None], tq).min(axis=(1, 2)),
                        _point_triangle_distances(q[:, :, None], tp).min(axis=(1, 2)))
    pe0, pe1 = p[:, :, None], np.roll(p, -1, axis=1)[:, :, None]        # (m, 4, 1, 3)
    qe0, qe1 = q[:, None], np.roll(q, -1, axis=1)[:, None]              # (m, 1, 4, 3)
    edge = _segment_distances(pe0, pe1, qe0, qe1).min(axis=(1, 2))
    crossing = _edges_pierce(p, q) | _edges_pierce(q, p)
    return np.where(crossing, 0.0, np.minimum(corner, edge))


def _swept_faces(quads: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """(k, 6, 4, 3) the boundary of the region each quad of ``quads`` (k, 4, 3) sweeps when
    moved by ``vector`` (3,): the quad, its translate and the four parallelograms its edges
    sweep (a convex prism; flat when ``vector`` lies in the quad's plane)."""
    q = np.asarray(quads, float)
    e = q + np.asarray(vector, float)
    sides = np.stack([q, np.roll(q, -1, axis=1), np.roll(e, -1, axis=1), e], axis=2)
    return np.concatenate([q[:, None], e[:, None], sides], axis=1)


def _inside_sweeps(x: np.ndarray, quads: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """(m, k) whether point ``x[i]`` (m, 3) lies strictly inside the prism quad ``k`` (k, 4, 3,
    convex) sweeps along ``vector`` (False for a flat sweep: its faces cover it)."""
    v = np.asarray(vector, float)
    n = _safe_normals(quads)                                             # (k, 3)
    sn = n @ v
    ok = np.abs(sn) > 1e-9 * np.linalg.norm(v)
    mu = ((x[:, None] - quads[None, :, 0]) * n).sum(-1) / np.where(ok, sn, 1.0)   # (m, k)
    p = x[:, None] - mu[..., None] * v                                   # on the quad's plane
    edge = np.roll(quads, -1, axis=1) - quads                            # (k, 4, 3)
    turn = (_cross(edge[None], p[:, :, None] - quads[None]) * n[None, :, None]).sum(-1)
    return ok & (mu > 0) & (mu < 1) & (turn > 0).all(axis=-1)


def _swept_distances(moving: np.ndarray, vector: np.ndarray, others: np.ndarray) -> np.ndarray:
    """(k, m) least distance of the mid-surface of panel ``moving[i]`` (k, 4, 3), anywhere on
    its way from ``moving + vector`` to its place, from panel ``others[j]`` (m, 4, 3): the
    distance of the region it sweeps (:func:`_swept_faces`; 0 where a panel lies inside it)."""
    k, m = len(moving), len(others)
    if not (k and m):
        return np.zeros((k, m))
    faces = _swept_faces(moving, vector).reshape(-1, 4, 3)               # (6k, 4, 3)
    f, o = np.divmod(np.arange(len(faces) * m), m)
    d = _quad_distances(faces[f], others[o]).reshape(k, 6, m).min(axis=1)
    inside = _inside_sweeps(others.reshape(-1, 3), moving, vector).reshape(m, 4, k).any(axis=1)
    return np.where(inside.T, 0.0, d)


def _near_panel_pairs(quads: np.ndarray, nodes: np.ndarray, gap: float) -> tuple[np.ndarray, np.ndarray]:
    """Pairs ``(i, j)``, i < j, of panels ``quads`` (n, 4, 3) with no node in common
    (``nodes`` (n, 2): a joint joins panels only at a shared node line) whose mid-surfaces
    cross or come within ``gap`` of each other, and their distances (0: crossing)."""
    lo, hi = quads.min(axis=1) - gap, quads.max(axis=1) + gap
    order = np.argsort(lo[:, 0], kind="stable")
    ii, jj = [], []
    # sweep along x: only panels whose boxes overlap in x are compared in full
    stop = np.searchsorted(lo[order, 0], hi[order, 0], side="right")
    for k, i in enumerate(order):
        js = order[k + 1:stop[k]]
        js = js[((lo[js] <= hi[i]) & (hi[js] >= lo[i])).all(axis=1)]
        ii.append(np.full(len(js), i))
        jj.append(js)
    i, j = np.concatenate(ii).astype(int), np.concatenate(jj).astype(int)
    share = (nodes[i][:, :, None] == nodes[j][:, None, :]).any(axis=(1, 2))
    i, j = np.minimum(i[~share], j[~share]), np.maximum(i[~share], j[~share])
    dist = _quad_distances(quads[i], quads[j])
    near = dist < gap
    return np.c_[i[near], j[near]], dist[near]


def _slab_depths(moving: np.ndarray, vector: np.ndarray, others: np.ndarray,
                 thickness: float) -> np.ndarray:
    """(m,) how deep the plate panel ``moving[i]`` (m, 4, 3), thickened to ``thickness``
    about its mid-surface and swept from ``moving + vector`` to its place, and panel
    ``others[i]`` (m, 4, 3), thickened alike, overlap, pair by pair (< 0: apart, by about
    that much). Both are convex; the depth is the least overlap of their projections on the
    separating axes (the products of two of their edge directions, the sweep's among them:
    they hold every face normal and every edge-edge axis)."""
    def slab(q):
        h = 0.5 * thickness * _safe_normals(q)[:, None]
        return np.concatenate([q - h, q + h], axis=1), np.roll(q, -1, axis=1) - q, 2 * h

    pa, ea, na = slab(np.asarray(moving, float))
    pb, eb, nb = slab(np.asarray(others, float))
    v = np.broadcast_to(np.asarray(vector, float), (len(pa), 1, 3))
    pa = np.concatenate([pa, pa + v], axis=1)                            # (m, 16, 3)
    dirs = np.concatenate([ea, na, v, eb, nb], axis=1)                   # (m, 11, 3)
    i, j = np.triu_indices(dirs.shape[1], 1)
    ax = _cross(dirs[:, i], dirs[:, j])                                  # (m, 55, 3)
    norm = np.linalg.norm(ax, axis=-1, keepdims=True)
    ok = norm[..., 0] > 1e-9 * np.maximum(1.0, norm.max(axis=1))
    ax = ax / np.where(norm > 0, norm, 1.0)
    sa = np.einsum("mpk,mak->mpa", pa, ax)
    sb = np.einsum("mpk,mak->mpa", pb, ax)
    overlap = np.minimum(sa.max(axis=1) - sb.min(axis=1), sb.max(axis=1) - sa.min(axis=1))
    return np.where(ok, overlap, np.inf).min(axis=1)


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

    def __init__(self, fs: "FinSystem"):
        self.t, self.c = fs.thickness, fs.clearance
        self.plates = [p for p in fs.parts if p.family in (0, 1)]
        sizes = [len(p.panels) for p in self.plates]
        self.quads = (np.concatenate([p.panels for p in self.plates]) if self.plates
                      else np.zeros((0, 4, 3)))
        self.owner = np.repeat(np.arange(len(self.plates)), sizes)
        self.panel = np.concatenate([np.arange(n) for n in sizes]) if sizes else np.zeros(0, int)
        self.lo, self.hi = self.quads.min(axis=1), self.quads.max(axis=1)
        self.index = {p.name: k for k, p in enumerate(self.plates)}
        order = _assembly_order([p.name for p in self.plates], fs._butted_after())
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


def _read_strips(structure, scale: float, drop_mask, extra: dict | None = None) -> _Strips:
    """Strips of a support structure scaled to ``unit``, degenerate panels marked (and the
    panels ``extra`` {strip index: panel indices})"""
    strips = _merge_coincident_nodes(structure).fins()
    a = structure.vertices_a * scale
    b = structure.vertices_b * scale
    depth = np.linalg.norm(b - a, axis=1)
    used = np.unique(structure.edges)
    tiny = depth[used] <= 1e-12 * max(1.0, float(np.abs(a).max()))
    if tiny.any():
        raise ValueError(f"nodes {used[tiny][:10].tolist()} have zero fin depth (a_i == b_i)")
    quads = [fs.quads * scale for fs in strips]
    drops = [drop_mask(q) for q in quads]
    for si, panels in (extra or {}).items():
        drops[si][sorted(panels)] = True
    n = len(a)
    passes = np.zeros((2, n), dtype=bool)
    ends = np.zeros((2, n), dtype=bool)
    for fs, drop in zip(strips, drops):
        v = np.asarray(fs.vertices)
        k = len(drop)
        for j in range(len(v)):
            if fs.closed and j == k:
                continue
            left = j - 1 if j > 0 else (k - 1 if fs.closed else None)
            right = j if j < k else None
            cnt = sum(1 for i in (left, right) if i is not None and not drop[i])
            if cnt == 2:
                passes[fs.family, v[j]] = True
            elif cnt == 1:
                ends[fs.family, v[j]] = True
    return _Strips(strips, quads, drops, a, b, depth, passes, ends)


def _plate_panels(st: _Strips) -> dict:
    """``{(family, node): [(normal, direction into the panel square to the node line,
    (strip, panel))]}``: the kept panels of each family's plate around each node."""
    plate: dict[tuple[int, int], list] = {}
    for si, (fs, q, drop) in enumerate(zip(st.fins, st.quads, st.drops)):
        nq = _safe_normals(q)
        for j, v in enumerate(fs.vertices):
            if fs.closed and j == len(nq):
                continue
            adj = [i for i in (j - 1, j) if 0 <= i < len(nq)]
            if fs.closed and j == 0:
                adj = [len(nq) - 1, 0]
            lst = plate.setdefault((fs.family, int(v)), [])
            line = st.b[v] - st.a[v]
            line = line / np.linalg.norm(line)
            for i in adj:
                if drop[i]:
                    continue
                into = q[i].mean(axis=0) - st.a[v]
                into = into - (into @ line) * line
                ni = np.linalg.norm(into)
                if not ni > 1e-9 * st.depth[v]:
                    continue           # panel centre on the node line: no direction
                lst.append((nq[i], into / ni, (si, i)))
    return plate



class FinSystem:
    """The fins of a support structure grouped into parts, thickened, slotted and laid out.

    Parameters
    ----------
    structure : SupportStructure
        Fins of ``structure.fins()``; coordinates in ``model_unit``.
    thickness : float
        Plate thickness in ``unit`` (mm by default), > 0. Panels are thickened about their
        mid-plane.
    family_split : FamilySplit or str
        ``"egg-crate"`` (default) or ``"family0-continuous"``.
    clearance : float
        Slot clearance in ``unit``, >= 0: slot width = ``thickness + clearance``.
    slot_ratio : float
        Fraction of the fin depth slotted into the family-0 plate (from its ``b`` edge), the
        rest into family 1 (from its ``a`` edge). 0.5 = half-depth slots.
    max_fold_angle : float
        Degrees; consecutive panels folding by more than this become separate parts. The
        parts meet mitred on the fold's bisector plane, up to a fold of :data:`MITER_LIMIT`
        (170 deg); at sharper folds (a strip doubling back on itself) they get square ends,
        overlap near the fold and are listed in ``untrimmed_joints`` (warned).
    min_panel_width : float or None
        Degenerate panels narrower than this (``unit``; area over longest edge, see
        :func:`panel_widths`), e.g. slivers whose ``a`` edge runs along the node lines, are
        dropped (the strip is split there) with a warning naming them; listed in
        ``dropped_panels``. Default: ``thickness`` (a plate cannot be narrower than it is
        thick); 0 drops only zero-area panels.
    max_part_length : float or None
        Split strips into parts no longer than this (``unit``, measured along the ``a`` and
        ``b`` edges, so the unrolled part is about this long), e.g. the sheet length minus the
        margins.
    max_panels : int or None
        Split strips into parts of at most this many panels.
    fit_sheet : (width, height) or None
        Sheet size (``unit``, default 2500 x 1250 mm): a part whose unrolled outline does not fit
        the sheet (less ``fit_margin`` all round) in any orientation is halved until it does (a
        single panel that is still too large is left for :meth:`layout` to report). Pass the
        sheet you will nest on; ``None`` keeps whole strips.
    model_unit, unit : str
        One of ``mm, cm, m, in, ft``; the structure is scaled by ``model_unit -> unit``.

    Attributes
    ----------
    parts : list of Part
        In strip order; names ``F<family>-S<strip>-P<index>``.
    crossings : list of Crossing
        The slotted (egg-crate) nodes with both slot depths and ``required_clearance``; a
        ``UserWarning`` is issued when ``clearance`` is below it somewhere (folded or oblique
        plates that would collide).
    untrimmed_joints : list of (part name, node, reason)
        Part ends that meet the other plate too obliquely to be butt-trimmed, and splits at
        folds sharper than :data:`MITER_LIMIT` (square ends): they overlap there (warned).
    dropped_panels : list of (strip, structure edge, width)
        Degenerate panels left out (narrower than ``min_panel_width``; warned); ``strip`` is
        the part-id prefix ``F<family>-S<strip>``.
    coplanar_panels : list of (strip, structure edge, node, reason)
        End panels left out because they meet the plate they end against within about 12
        degrees (they lie along it, duplicate its fin and cannot be trimmed clear of it;
        warned); the strip then ends one node earlier, joined there as usual. Also panels of
        parts joined to nothing that pass through another part, and one panel of every pair of
        plates that cross or come within ``thickness + clearance`` of each other where no joint
        joins them (they share no node line; the cheaper one: a part's end panel, of the
        shorter strip), and one panel of every pair that blocks a part's path into place along
        every direction its joints allow (the cheaper one); ``reason`` names the other panel
        or part.

    Examples
    --------
    >>> fs = FinSystem(structure, thickness=3.0, clearance=0.5, max_panels=6)  # doctest: +SKIP
    >>> fs.export_step("fins.step")                                           # doctest: +SKIP
    >>> lay = fs.layout(sheet=(2500, 1250)); lay.export_dxf("cut/sheet.dxf")  # doctest: +SKIP
    >>> fs.bill_of_materials("bom.csv", layout=lay)                            # doctest: +SKIP
    """

    def __init__(self, structure, thickness: float, *,
                 family_split: FamilySplit | str = FamilySplit.EGG_CRATE,
                 clearance: float = 0.5, slot_ratio: float = 0.5,
                 max_fold_angle: float = 60.0, max_panels: int | None = None,
                 max_part_length: float | None = None,
                 fit_sheet: tuple[float, float] | None = (2500.0, 1250.0), fit_margin: float = 10.0,
                 model_unit: str = "m", unit: str = "mm", min_panel_width: float | None = None,
                 min_crossing_angle: float = MIN_CROSSING_ANGLE,
                 max_crossing_fold: float = MAX_CROSSING_FOLD):
        self._check_common(thickness, clearance, model_unit, unit, max_panels)
        if not 0.0 < slot_ratio < 1.0:
            raise ValueError(f"slot_ratio must be in (0, 1), got {slot_ratio}")
        if not 0.0 < max_fold_angle < 180.0:
            raise ValueError(f"max_fold_angle must be in (0, 180) degrees, got {max_fold_angle}")
        self.structure = structure
        self.thickness = float(thickness)
        self.clearance = float(clearance)
        self.family_split = FamilySplit(family_split)
        self.slot_ratio = float(slot_ratio)
        self.max_fold_angle = float(max_fold_angle)
        if not 0.0 < min_crossing_angle <= 90.0:
            raise ValueError(f"min_crossing_angle must be in (0, 90] degrees, got {min_crossing_angle}")
        if not 0.0 <= max_crossing_fold < 90.0:
            raise ValueError(f"max_crossing_fold must be in [0, 90) degrees, got {max_crossing_fold}")
        self.min_crossing_angle = float(min_crossing_angle)
        self.max_crossing_fold = float(max_crossing_fold)
        self.max_panels = max_panels
        if max_part_length is not None and not max_part_length > 0:
            raise ValueError(f"max_part_length must be > 0, got {max_part_length}")
        self.max_part_length = max_part_length
        self._set_fit(fit_sheet, fit_margin)
        self._set_min_width(min_panel_width)
        self.model_unit, self.unit = model_unit, unit
        self.scale = UNIT_TO_MM[model_unit] / UNIT_TO_MM[unit]
        self.parts: list[Part] = []
        self._solids: dict | None = None
        self._unrolled: dict | None = None
        if len(structure.edges) == 0:
            raise ValueError("the support structure has no edges: nothing to fabricate")
        self._build_until_trimmed()
        self.__dict__.pop("_memo", None)        # only the rebuilds of this construction use it

    # ------------------------------------------------------------------ construction
    def _reset_state(self) -> None:
        """Empty the lists one build fills."""
        #: degenerate panels dropped: (part-id prefix of the strip, structure edge, width)
        self.dropped_panels: list[tuple[str, int, float]] = []
        #: parts whose solid could not be slotted by OpenCascade: (name, slot nodes, reason)
        self.unslotted_solids: list[tuple[str, list, str]] = []
        #: slots made shallower or left out: (part name, node, old depth, new depth, partner note)
        self.slot_conflicts: list[tuple[str, int, float, float, str]] = []
        #: parts of one panel that do not fit ``fit_sheet`` (warned; :meth:`layout` will refuse)
        self.oversize_panels: list[str] = []
        self._oversize: list[int] = []
        self.crossings: list[Crossing] = []
        #: part ends that could not be butt-trimmed: (part name, node, reason)
        self.untrimmed_joints: list[tuple[str, int, str]] = []
        self._init_joints()
        self.parts = []

    def _cached(self, fn, *args, **kw):
        """``fn(*args, **kw)`` of a pure joint kernel (butt trims, corners, connectors, sheet
        fits), remembered by the bytes of its arguments for the rebuilds of one
        :class:`FinSystem` (:meth:`_build_until_trimmed` rebuilds the whole structure, and most
        ends and fits come out the same): the same result, a copy, or the same
        :class:`~.joints._Untrimmable` raised again."""
        memo = self.__dict__.setdefault("_memo", {})
        key = (fn.__name__, _memo_key(args), _memo_key(kw))
        hit = memo.get(key)
        if hit is None:
            try:
                hit = (True, fn(*args, **kw))
            except _Untrimmable as why:
                hit = (False, str(why))
            memo[key] = hit
        ok, value = hit
        if not ok:
            raise _Untrimmable(value)
        return copy.deepcopy(value)

    def _build_until_trimmed(self) -> None:
        """Build; where a part end meets the plate it butts against too obliquely to be
        trimmed (it lies along that plate, within about 12 degrees, and would overlap it), leave
        that end panel out (it duplicates the other plate's fin there) and build again, so that
        every part end is trimmed. The panels left out are named in ``coplanar_panels``
        (warned); at most :data:`MAX_REBUILDS` rebuilds. A rebuild changes only the ends next
        to the panels left out and the crossings forced to butt: the trims, bracket corners,
        connectors and sheet fits of all other ends are taken from the builds before
        (:meth:`_cached`), so each costs less than the first."""
        extra: dict[int, set] = {}
        forced: dict[int, str] = {}
        left_out: list[tuple[str, int, int, str]] = []
        for attempt in range(MAX_REBUILDS + 1):
            self._reset_state()
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                self._build_from_structure(extra, forced)
            new = {(si, i): rec for si, i, *rec in self._untrimmable + self._stray_parts()
                   if i not in extra.get(si, ())}
            new.update({(si, i): rec for si, i, *rec in self._clashing_panels(leaving=set(new))})
            new_forced = {v: why for v, why in self._unslidable.items() if v not in forced}
            new_forced.update((v, why) for v, why in self._break_cycles(forced).items()
                              if v not in new_forced)
            checked = not (new or new_forced)
            if checked:
                # the joints are settled: now the paths into place (they change with every
                # panel left out and every joint changed, so they are looked at last)
                self._check_paths()
                new = {(si, i): rec for si, i, *rec in self._blocked_panels()}
            if not (new or new_forced) or attempt == MAX_REBUILDS:
                if not checked:
                    self._check_paths()     # out of rebuilds: at least the clear directions
                break
            for (si, i), (prefix, edge, node, why) in sorted(new.items()):
                extra.setdefault(si, set()).add(i)
                left_out.append((prefix, edge, node, why))
            forced.update(new_forced)
        self.coplanar_panels = left_out
        for w in caught:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
        # slots that would cut a part in two: once, on the final parts (it unrolls them all)
        self._resolve_slot_splits()
        if left_out:
            warnings.warn(
                f"{len(left_out)} fin panels were left out because they meet the plate they end "
                f"against too obliquely to be trimmed (they lie along it and would overlap it), "
                f"cross another plate where no joint joins them, or block a part's path into "
                f"place: "
                + "; ".join(f"{s} edge {e} at node {v} ({why})" for s, e, v, why in left_out[:6])
                + (" ..." if len(left_out) > 6 else "") + "; see FinSystem.coplanar_panels. "
                "Raise constraints.min_torsal_angle to keep the two families' fins apart",
                stacklevel=3)

    def _init_joints(self) -> None:
        #: every joint of the assembly (egg-crate, butt + bracket, mitre + splice)
        self.joints: list[Joint] = []
        #: joints without a connector (no room for one): (part name, node, reason)
        self.unconnected_joints: list[tuple[str, int, str]] = []
        #: the joint chosen at every crossing of two strips (see :func:`~.joints.choose_joinery`)
        self.joinery: list = []
        self._connectors: list[Part] = []
        self._n_conn: dict[int, int] = {}
        #: part ends that could not be trimmed: (strip index, panel of the strip, strip name,
        #: structure edge, node, reason)
        self._untrimmable: list[tuple] = []
        #: crossings an egg-crate cannot join (node -> reason): butted in the next build
        self._unslidable: dict[int, str] = {}
        #: parts whose path into place is blocked: [(part, [(panel, plate, its panel, distance)])]
        self._blocked_paths: list = []
        #: part name -> [unit normal of a plate it butts against, turned towards the part]
        self._walls: dict[str, list] = {}
        #: (family, node) -> [(normal, into direction, plate normal)] of part ends butted there
        self._ends_at: dict[tuple[int, int], list] = {}

    @staticmethod
    def _check_common(thickness, clearance, model_unit, unit, max_panels):
        if not np.isfinite(thickness) or thickness <= 0:
            raise ValueError(f"thickness must be > 0, got {thickness}")
        if not np.isfinite(clearance) or clearance < 0:
            raise ValueError(f"clearance must be >= 0, got {clearance}")
        for u in (model_unit, unit):
            if u not in UNIT_TO_MM:
                raise ValueError(f"unknown unit {u!r}; use one of {sorted(UNIT_TO_MM)}")
        if max_panels is not None and max_panels < 1:
            raise ValueError(f"max_panels must be >= 1, got {max_panels}")

    def _set_min_width(self, min_panel_width) -> None:
        if min_panel_width is None:
            min_panel_width = self.thickness
        if not np.isfinite(min_panel_width) or min_panel_width < 0:
            raise ValueError(f"min_panel_width must be >= 0, got {min_panel_width}")
        self.min_panel_width = float(min_panel_width)

    def _drop_mask(self, quads: np.ndarray) -> np.ndarray:
        """Panels too narrow, of zero area, self-intersecting (bow-tie: the node lines cross
        inside the fin) or folded back onto the previous panel, to be fabricated."""
        w = panel_widths(quads)
        tol = 1e-9 * max(1.0, float(np.abs(quads).max()))
        n = _safe_normals(quads)
        drop = ((w <= tol) | (w < self.min_panel_width) | _bowtie(quads)
                | ~np.isfinite(n).all(axis=1))
        # a panel folded back (more than MITER_LIMIT) onto its kept neighbour lies on top of it:
        # it duplicates that fin and cannot be built; drop it
        for j in range(1, len(quads)):
            if not drop[j] and not drop[j - 1] and _fold_deg(n[j - 1], n[j]) > MITER_LIMIT:
                drop[j] = True
        return drop

    def _miter_ok(self, n1, n2, w1, w2) -> bool:
        """A fold can be mitred: at most MITER_LIMIT, and the bevel ``t/2 tan(fold/2)`` (how far
        the mitre shifts the faces of the plate across the node line) is at most a tenth of
        the narrowest width (:func:`panel_widths`) of both panels; beyond that the faces of a
        narrow, slanted panel twist too much (or cross) for a sound solid."""
        ang = _fold_deg(n1, n2)
        if not ang <= MITER_LIMIT:
            return False
        return 0.5 * self.thickness * np.tan(np.radians(ang) / 2) <= 0.1 * min(w1, w2)

    def _warn_dropped(self) -> None:
        if self.dropped_panels:
            d = self.dropped_panels
            warnings.warn(
                f"{len(d)} degenerate fin panels (narrower than min_panel_width="
                f"{self.min_panel_width:g} {self.unit}, self-intersecting or folded back onto their neighbour) were dropped (their "
                f"strips are split there): "
                + "; ".join(f"{s} edge {e} ({w:.3g} {self.unit} wide)" for s, e, w in d[:8])
                + (" ..." if len(d) > 8 else "") + "; see FinSystem.dropped_panels. Remesh more "
                "finely or move the boundary if these fins are needed", stacklevel=3)

    def _set_fit(self, fit_sheet, fit_margin) -> None:
        if fit_sheet is not None:
            fit_sheet = tuple(float(x) for x in fit_sheet)
            if len(fit_sheet) != 2 or min(fit_sheet) <= 2 * fit_margin:
                raise ValueError(f"fit_sheet must be (width, height) larger than twice the margin "
                                 f"{fit_margin}; got {fit_sheet}")
        self.fit_sheet, self.fit_margin = fit_sheet, float(fit_margin)

    @classmethod
    def from_strips(cls, strips: Iterable, thickness: float, *, max_panels: int | None = None,
                    max_part_length: float | None = None,
                    fit_sheet: tuple[float, float] | None = (2500.0, 1250.0), fit_margin: float = 10.0,
                    max_fold_angle: float = 179.0, model_unit: str = "m", unit: str = "mm",
                    family: int = -1, min_panel_width: float | None = None) -> "FinSystem":
        """Parts from free strips of quads, e.g. the developables of ``refine_developable``.

        ``strips`` are :class:`~torsal.geometry.support.FinStrip` objects or (k, 4, 3) arrays
        of quads ``p0 p1 p2 p3`` with ``p1 p2`` of one quad equal to ``p0 p3`` of the next.
        They are thickened and unrolled like fins, without slots or trimming. Folds sharper
        than ``min(max_fold_angle, MITER_LIMIT)`` split the strip; degenerate panels are
        dropped (see ``min_panel_width`` of :class:`FinSystem`).
        """
        self = cls.__new__(cls)
        cls._check_common(thickness, 0.0, model_unit, unit, max_panels)
        self.structure = None
        self.thickness, self.clearance = float(thickness), 0.0
        self.family_split = FamilySplit.EGG_CRATE
        self.slot_ratio, self.max_fold_angle, self.max_panels = 0.5, float(max_fold_angle), max_panels
        self.max_part_length = max_part_length
        self._set_fit(fit_sheet, fit_margin)
        self._set_min_width(min_panel_width)
        self.model_unit, self.unit = model_unit, unit
        self.scale = UNIT_TO_MM[model_unit] / UNIT_TO_MM[unit]
        self.crossings, self.parts, self.untrimmed_joints = [], [], []
        self.dropped_panels, self.slot_conflicts, self.oversize_panels = [], [], []
        quads_of: dict[int, np.ndarray] = {}
        self._oversize = []
        self.unslotted_solids = []
        self._solids = self._unrolled = None
        self.min_crossing_angle, self.max_crossing_fold = MIN_CROSSING_ANGLE, MAX_CROSSING_FOLD
        self._init_joints()
        self.coplanar_panels = []
        for s, st in enumerate(strips):
            q = np.asarray(getattr(st, "quads", st), dtype=float) * self.scale
            fam = int(family)
            if q.ndim != 3 or q.shape[1:] != (4, 3) or len(q) == 0:
                raise ValueError(f"strip {s}: expected (k, 4, 3) quads, got {q.shape}")
            nodes = np.full(len(q) + 1, -1)
            edges = np.full(len(q), -1)
            drop = self._drop_mask(q)
            quads_of[s] = q
            prefix = str(PartId(fam, s, 0))[:-4]
            self.dropped_panels += [(prefix, int(i), float(w))
                                    for i, w in zip(np.flatnonzero(drop), panel_widths(q)[drop])]
            for index, (lo, hi) in enumerate(self._split_ranges(q, closed=False, drop=drop)):
                self.parts.append(self._make_part(PartId(fam, s, index), q, lo, hi, nodes, edges,
                                                  closed=False, drop=drop))
        if not self.parts:
            raise ValueError("no strips given: nothing to fabricate")
        self._warn_dropped()
        # splits at sharp folds: butt joints (the later part trimmed back), never mitred
        gap, h = 0.5 * self.thickness, 0.5 * self.thickness
        by_strip: dict[int, list[Part]] = {}
        for p in self.parts:
            by_strip.setdefault(p.id.strip, []).append(p)
        for sidx, parts in by_strip.items():
            q = quads_of[sidx]
            for p in parts:
                if p.ends[0] == "fold":
                    trimmed = list(p.trimmed)
                    trimmed[0] = self._fold_butt(p, self._previous(parts, p, q), q, -1, gap, h)
                    p.trimmed = tuple(trimmed)
        self._warn_untrimmed(stacklevel=3)
        self.__dict__.pop("_memo", None)
        return self

    @property
    def split_angle(self) -> float:
        """Degrees: folds sharper than this split a strip (``min(max_fold_angle, MITER_LIMIT)``)."""
        return min(self.max_fold_angle, MITER_LIMIT)

    def _split_ranges(self, quads: np.ndarray, closed: bool,
                      drop: np.ndarray | None = None, extra_cuts=()) -> list[tuple[int, int]]:
        """Panel ranges [lo, hi) of the parts of one strip (dropped panels left out), cut also
        at the node lines ``extra_cuts`` (crossings joined by butt joints)."""
        k = len(quads)
        drop = np.zeros(k, dtype=bool) if drop is None else np.asarray(drop, dtype=bool)
        cuts = {0, k} | {int(j) % k if closed else int(j) for j in extra_cuts}
        n = _safe_normals(quads)
        with np.errstate(invalid="ignore"):
            ang = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n[:-1], n[1:]), -1, 1)))
        cuts.update((np.flatnonzero(ang > self.split_angle) + 1).tolist())
        ext = panel_widths(quads)
        cuts.update(j for j in range(1, k) if not self._miter_ok(n[j - 1], n[j], ext[j - 1], ext[j]))
        for i in np.flatnonzero(drop).tolist():
            cuts.update((i, i + 1))
        if closed and k >= 2 and len(cuts) == 2:
            cuts.add(k // 2)
        cuts = sorted(cuts)
        out = []
        for lo, hi in zip(cuts[:-1], cuts[1:]):
            if drop[lo:hi].all():
                continue
            if self.max_panels and hi - lo > self.max_panels:
                nchunk = -(-(hi - lo) // self.max_panels)
                bounds = np.linspace(lo, hi, nchunk + 1).round().astype(int)
                out.extend(zip(bounds[:-1].tolist(), bounds[1:].tolist()))
            else:
                out.append((lo, hi))
        if self.max_part_length:
            la = np.linalg.norm(quads[:, 1] - quads[:, 0], axis=1)
            lb = np.linalg.norm(quads[:, 2] - quads[:, 3], axis=1)
            seg = np.maximum(la, lb)
            split = []
            for lo, hi in out:
                start, acc = lo, 0.0
                for i in range(lo, hi):
                    if acc + seg[i] > self.max_part_length and i > start:
                        split.append((start, i))
                        start, acc = i, 0.0
                    acc += seg[i]
                split.append((start, hi))
            out = split
        if self.fit_sheet is not None:
            self._oversize = []
            out = [r for lo, hi in out for r in self._fit(quads, lo, hi)]
        return out

    def _fit(self, quads: np.ndarray, lo: int, hi: int) -> list[tuple[int, int]]:
        """Halve [lo, hi) until the unrolled part fits ``fit_sheet`` (any orientation)."""
        if hi - lo <= 1:
            if not self._fits(quads[lo:hi]):
                self._oversize.append(lo)
            return [(lo, hi)]
        if self._fits(quads[lo:hi]):
            return [(lo, hi)]
        mid = (lo + hi) // 2
        return self._fit(quads, lo, mid) + self._fit(quads, mid, hi)

    def _fits(self, quads: np.ndarray) -> bool:
        """Whether panels ``quads`` unrolled fit ``fit_sheet`` (remembered: see :meth:`_cached`)."""
        return self._cached(self._fits_sheet, np.ascontiguousarray(quads))

    def _fits_sheet(self, quads: np.ndarray) -> bool:
        try:
            outline = unroll(quads, slots=[]).outline
        except ValueError:          # overlaps itself when unrolled: too long anyway
            return False
        w, h = _oriented_size(outline)
        sw, sh = sorted(self.fit_sheet, reverse=True)
        m = 2.0 * self.fit_margin
        return max(w, h) <= sw - m and min(w, h) <= sh - m

    def _make_part(self, pid: PartId, quads, lo, hi, nodes, edges, closed,
                   drop: np.ndarray | None = None) -> Part:
        """Part of panels [lo, hi) of a strip, with mitred folds (also across part splits, up
        to a fold of MITER_LIMIT; square ends at sharper folds, next to dropped panels and at
        the strip ends)."""
        q = quads[lo:hi].copy()
        n_all = _safe_normals(quads)
        k = len(quads)
        drop = np.zeros(k, dtype=bool) if drop is None else np.asarray(drop, dtype=bool)
        ext = panel_widths(quads)
        miters = np.empty((hi - lo + 1, 3))
        ends = ["end", "end"]
        for j in range(lo, hi + 1):
            left = j - 1 if j > 0 else (k - 1 if closed else None)
            right = j if j < k else (0 if closed else None)
            end = 0 if j == lo else (1 if j == hi else None)
            if end is not None and left is not None and right is not None:
                other = left if end == 0 else right
                if drop[other]:
                    ends[end] = "dropped"
                elif (_fold_deg(n_all[left], n_all[right]) > self.split_angle or
                      not self._miter_ok(n_all[left], n_all[right], ext[left], ext[right])):
                    ends[end] = "fold"
                else:
                    ends[end] = "miter"
                if ends[end] != "miter":
                    left, right = (None, right) if end == 0 else (left, None)
            if left is None:
                m = n_all[right]
            elif right is None:
                m = n_all[left]
            else:
                m = _miter(n_all[left], n_all[right])
            miters[j - lo] = m
        return Part(id=pid, panels=q, nodes=np.asarray(nodes[lo:hi + 1]).copy(),
                    edges=np.asarray(edges[lo:hi]).copy(), miters=miters, span=(lo, hi),
                    color=FAMILY_COLORS.get(pid.family, FAMILY_COLORS[-1]), ends=tuple(ends))

    def _warn_untrimmed(self, stacklevel: int = 4) -> None:
        untrimmed = self.untrimmed_joints
        if untrimmed:
            warnings.warn(
                f"{len(untrimmed)} part ends could not be butt-trimmed (or mitred) against the adjoining "
                f"plate and overlap it: " + "; ".join(f"{n} at node {v} ({w})" for n, v, w in untrimmed[:6])
                + (" ..." if len(untrimmed) > 6 else "") + "; see FinSystem.untrimmed_joints",
                stacklevel=stacklevel)


    # ------------------------------------------------------------------ construction phases
    def _build_from_structure(self, extra: dict | None = None, forced: dict | None = None) -> None:
        """Parts from the structure in five phases: read the strips, choose the joint at every
        crossing (:func:`~.joints.choose_joinery`), cut the strips into parts, join the part
        ends (butt + bracket, mitre + splice) and slot the egg-crate crossings."""
        st = _read_strips(self.structure, self.scale, self._drop_mask, extra)
        self._extra = extra or {}
        plate = _plate_panels(st)
        joinery = {}
        if self.family_split == FamilySplit.EGG_CRATE:
            for v in np.flatnonzero(st.passes[0] & st.passes[1]).tolist():
                joinery[v] = choose_joinery(v, plate[(0, v)], plate[(1, v)],
                                            min_angle=self.min_crossing_angle,
                                            max_fold=self.max_crossing_fold)
                if v in (forced or {}):
                    # an egg-crate the family-1 plate cannot slide onto together with its
                    # others: split it here (butt joint + bracket); a butt joint in a cycle
                    # of parts butting on each other: split the other strip instead
                    split, why = forced[v]
                    joinery[v] = joinery[v]._replace(kind=JointKind.BUTT_BRACKET, split=split,
                                                     why=why)
        self.joinery = [joinery[v] for v in sorted(joinery)]
        part_of_strip = self._strip_parts(st, joinery)
        self.parts = [p for parts in part_of_strip for p in parts]
        self._strip_of = {p.name: si for si, parts in enumerate(part_of_strip) for p in parts}
        self._where = {(si, p.span[0] + i): (p, i) for si, parts in enumerate(part_of_strip)
                       for p in parts for i in range(len(p.panels))}
        # a family is continuous at a node where one of its parts passes through it
        cont = st.passes.copy()
        for si, parts in enumerate(part_of_strip):
            fam = st.fins[si].family
            for p in parts:
                for end in (0, 1):
                    if p.ends[end] in ("miter", "fold"):
                        cont[fam, int(p.nodes[-end])] = False
        self._join_ends(st, part_of_strip, plate, cont)
        self._slot_crossings(st, part_of_strip, joinery, cont)
        self.parts = ([p for parts in part_of_strip for p in parts]
                      + sorted(self._connectors, key=lambda p: p.id))
        self.joints = [replace(j, depth=float(st.depth[j.node])) if j.node >= 0 else j
                       for j in self.joints]
        self._set_butt_directions()
        names = [p.name for p in self.parts]
        assert len(set(names)) == len(names)
        self._fin_depth = st.depth

    def _strip_parts(self, st: "_Strips", joinery: dict) -> list[list[Part]]:
        """Cut every strip into parts: at sharp folds, dropped panels, length and sheet limits,
        and at crossings where its plate is to be butted against the other family's."""
        strip_no = {0: 0, 1: 0}
        part_of_strip: list[list[Part]] = []
        dropped, oversize = [], []
        present = st.passes | st.ends
        for si, (fs, q, drop) in enumerate(zip(st.fins, st.quads, st.drops)):
            fam = fs.family
            at = {int(v): j for j, v in enumerate(fs.vertices)}
            split_here = {at[x.node] for x in joinery.values()
                          if x.split == fam and x.node in at and 0 < at[x.node] < len(q) + fs.closed}
            ranges = self._split_ranges(q, fs.closed, drop, extra_cuts=split_here)
            if self.family_split == FamilySplit.FAMILY0_CONTINUOUS and fam == 1:
                # family 1 is cut at every node where a family-0 plate is
                cuts = sorted({0, len(q)} | {j for j in range(1, len(q))
                                             if present[0, fs.vertices[j]]} |
                              {x for r in ranges for x in r})
                ranges = [(lo, hi) for lo, hi in zip(cuts[:-1], cuts[1:]) if not drop[lo:hi].all()]
            sn = strip_no[fam]
            strip_no[fam] += 1
            prefix = str(PartId(fam, sn, 0))[:-4]
            dropped += [(prefix, int(fs.edges[i]), float(w))
                        for i, w in zip(np.flatnonzero(drop), panel_widths(q)[drop])
                        if i not in self._extra.get(si, ())]
            parts = [self._make_part(PartId(fam, sn, i), q, lo, hi, fs.vertices, fs.edges, fs.closed,
                                     drop)
                     for i, (lo, hi) in enumerate(ranges)]
            over = set(self._oversize) if self.fit_sheet is not None else set()
            oversize += [p.name for p in parts if p.span[1] - p.span[0] == 1 and p.span[0] in over]
            part_of_strip.append(parts)
        self.dropped_panels = dropped
        self.oversize_panels = oversize
        self._warn_dropped()
        if oversize:
            warnings.warn(
                f"{len(oversize)} parts are ONE fin panel each and still larger than the "
                f"{self.fit_sheet[0]:g} x {self.fit_sheet[1]:g} {self.unit} sheet: {oversize[:8]}"
                + (" ..." if len(oversize) > 8 else "") + "; a single panel cannot be split: use a "
                "smaller fin spacing (finer remesh) or a larger sheet; see FinSystem.oversize_panels",
                stacklevel=4)
        return part_of_strip

    def _join_ends(self, st: "_Strips", part_of_strip, plate, cont) -> None:
        """Every part end at a node where another plate is: butt-trimmed against it with a
        bracket (T, L, and crossings where the strip is split), butted against the previous
        part at a sharp fold, or mitred with a splice plate."""
        gap, h = 0.5 * self.thickness + 0.5 * self.clearance, 0.5 * self.thickness
        present = st.passes | st.ends
        # where several strips of one family end at a node (and none passes), the first is the
        # base; each other butts against the base and those butted before it
        base: dict[tuple[int, int], list] = {}
        for (fam, v), lst in plate.items():
            if not st.passes[fam, v] and len({ref[0] for _, _, ref in lst}) >= 2:
                base[(fam, v)] = [e for e in lst if e[2][0] == lst[0][2][0]]
        self._dirs: dict[int, list] = {}
        for (fam, v), lst in plate.items():
            self._dirs.setdefault(v, []).extend(d for _, d, _ in lst)
        self._bracket_dirs: dict[int, list] = {}
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
                    butted = fam in (0, 1) and (cont[other, node] or (fam == 1 and present[other, node]))
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
                    elif kind == "miter" and end == 0 and not bridged:
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
        if self.unconnected_joints:
            u = self.unconnected_joints
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
        j = 0 if end == 0 else len(p.panels) - 1
        quad = p.panels[j]
        try:
            moved, m_end, nbar = self._cached(butt_trim, quad, end == 0, [(n, v) for n, v, _ in panels],
                                           st.a[node], gap, h)
            # strips of this family that already end here on the same side of the plate meet
            # this one in the corner: its end clears them too
            others = [(n, v) for n, v, nb in self._ends_at.get((p.family, node), []) if nb @ nbar > 0]
            if others:
                moved = self._cached(trim_further, quad, end == 0, others, st.a[node], m_end, moved,
                                     gap, h)
        except _Untrimmable as why:
            self.untrimmed_joints.append((p.name, node, str(why)))
            self._note_untrimmable(p, j, node, str(why))
            return False
        self._ends_at.setdefault((p.family, node), []).append(
            (quad_normals(quad[None])[0], into_direction(quad, end == 0)[2], nbar))
        # every face it ends against, turned towards it: its insertion must not close those gaps
        centre = quad.mean(axis=0) - st.a[node]
        self._walls.setdefault(p.name, []).extend(
            n if centre @ n >= 0 else -n for n in [n for n, _, _ in panels] + [n for n, _ in others])
        for cc, x in moved.items():
            quad[cc] = x
        p.miters[0 if end == 0 else -1] = m_end
        cont = [(n, v, self._panel_quad(ref)) for n, v, ref in panels]
        names = tuple(sorted({self._where[ref][0].name for _, _, ref in panels}))
        self._bracket(p, j, node, cont, names, st.a[node], st.b[node],
                      insert=_slide(nbar, quad, st.a[node] - st.b[node]),
                      n_corners=2 if bridge else 1)
        return True

    def _stray_parts(self) -> list[tuple]:
        """Parts joined to nothing (no joint, no slot) whose panels pass through another
        part's panels: the structure runs through itself there and such a fin could neither
        be fastened nor fitted; its panels are left out (as :meth:`_note_untrimmable`)."""
        joined = {n for j in self.joints for n in j.parts}
        plates = [p for p in self.parts if p.family in (0, 1)]
        out = []
        for p in plates:
            if p.name in joined or p.slots or p.name not in self._strip_of:
                continue
            lo, hi = p.panels.reshape(-1, 3).min(axis=0), p.panels.reshape(-1, 3).max(axis=0)
            for o in plates:
                if o is p:
                    continue
                q = o.panels.reshape(-1, 3)
                if (q.min(axis=0) > hi).any() or (q.max(axis=0) < lo).any():
                    continue
                if _quads_cross(p.panels, o.panels) or _quads_on(p.panels, o.panels, self.thickness):
                    why = f"it crosses {o.name} without a joint (the structure runs through itself)"
                    out += [(self._strip_of[p.name], p.span[0] + j, p.name[:-4], int(p.edges[j]),
                             int(p.nodes[j]), why) for j in range(len(p.panels))]
                    break
        return out

    def _clashing_panels(self, *, leaving: set = frozenset()) -> list[tuple]:
        """Panels of two plates that cross, or come within ``thickness + clearance`` of each
        other, where no joint joins them (they share no node line; e.g. two strips of one
        family crossing near a singularity of a rough congruence): the plates would interfere
        and neither could be put in past the other. Of every such pair the panel that costs
        least is left out (as :meth:`_note_untrimmable`): one at an end of its part (leaving
        it out splits nothing) before one inside it, then the one of the shorter strip. Pairs
        with a panel in ``leaving`` ({(strip index, panel of the strip)}, left out for another
        reason in this build) are resolved already."""
        plates = [p for p in self.parts if p.family in (0, 1) and p.name in self._strip_of]
        if not plates:
            return []
        refs = [(p, j) for p in plates for j in range(len(p.panels))]
        quads = np.concatenate([p.panels for p in plates])
        nodes = np.concatenate([np.c_[p.nodes[:-1], p.nodes[1:]] for p in plates]).astype(int)
        pairs, dist = _near_panel_pairs(quads, nodes, self.thickness + self.clearance)

        def cost(k: int) -> tuple:
            return self._panel_cost(*refs[k])

        gone = {k for k, (p, j) in enumerate(refs) if (self._strip_of[p.name], p.span[0] + j) in leaving}
        out = []
        for (i, k), d in sorted(zip(map(tuple, pairs.tolist()), dist.tolist()), key=lambda x: x[1]):
            if i in gone or k in gone:
                continue
            drop, keep = (i, k) if cost(i) <= cost(k) else (k, i)
            gone.add(drop)
            (p, j), (o, jo) = refs[drop], refs[keep]
            what = "crosses" if d == 0 else f"comes within {d:.2f} {self.unit} of"
            why = (f"it {what} panel {int(o.edges[jo])} of {o.name[:-4]} without a joint (the "
                   f"structure runs through itself)")
            # the node of the panel nearer the other panel names where it is
            near = np.linalg.norm(quads[drop][[0, 1]] - quads[keep].mean(axis=0), axis=1)
            out.append((self._strip_of[p.name], p.span[0] + j, p.name[:-4], int(p.edges[j]),
                        int(p.nodes[j + int(np.argmin(near))]), why))
        return out

    def _seam_walls(self, prev: Part | None, p: Part) -> None:
        """The two parts of a strip split on a mitre touch on the fold's bisector plane: each is
        a wall of the other (normal of that plane, turned towards it) for its insertion."""
        plane = None if prev is None else _seam_plane(p)
        if plane is None:
            return
        a, seam = plane
        for q, quad in ((p, p.panels[0]), (prev, prev.panels[-1])):
            n = seam if (quad.mean(axis=0) - a) @ seam >= 0 else -seam
            self._walls.setdefault(q.name, []).append(n)

    def _mitre_gap(self, prev: Part | None, p: Part, node: int) -> None:
        """Trim both parts of a mitred seam back from the fold's bisector plane by
        ``clearance/2`` (:func:`~.joints.mitre_trim`), so that they do not touch (after the
        splice plate and the walls, which are placed on the untrimmed node line)."""
        plane = None if prev is None or not self.clearance > 0 else _seam_plane(p)
        if plane is None:
            return
        a, seam = plane
        for q, start in ((p, True), (prev, False)):
            quad = q.panels[0 if start else -1]
            try:
                moved = mitre_trim(quad, start, seam, a, 0.5 * self.clearance)
            except _Untrimmable as why:
                self.untrimmed_joints.append((q.name, node, f"mitred seam: {why}"))
                continue
            for cc, x in moved.items():
                quad[cc] = x

    def _note_untrimmable(self, p: Part, j: int, node: int, why: str) -> None:
        """Remember panel ``j`` of ``p`` (strip index, panel of the strip) to leave it out."""
        si = getattr(self, "_strip_of", {}).get(p.name)
        if si is not None and p.family in (0, 1):
            self._untrimmable.append((si, p.span[0] + j, p.name[:-4], int(p.edges[j]), node, why))

    def _panel_quad(self, ref) -> np.ndarray:
        part, i = self._where[ref]
        return part.panels[i]

    def _fold_butt(self, p: Part, prev: Part | None, quads, node: int, gap, h, *,
                   bracket: bool = True) -> bool:
        """Butt joint at a split on a sharp fold: the start of part ``p`` is trimmed back until it
        clears the (square) end of the previous part ``prev``; a bracket joins them."""
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
            into = into / np.linalg.norm(into)
            moved, m_end, nbar = self._cached(butt_trim, quad, True, [(nprev, into)], pa, gap, h)
            self._walls.setdefault(p.name, []).append(nbar)
        except _Untrimmable as why:
            self.untrimmed_joints.append((p.name, node, f"{what}: {why}"))
            self._note_untrimmable(p, 0, node, f"{what}: {why}")
            return False
        for cc, x in moved.items():
            quad[cc] = x
        p.miters[0] = m_end
        if prev is not None and node >= 0 and bracket:
            self._bracket(p, 0, node, [(nprev, into, prev.panels[-1])], (prev.name,), pa, pb,
                          insert=_slide(nbar, quad, pa - pb))
        return True

    def _bracket(self, p: Part, j: int, node: int, cont, names, pa, pb, *, insert,
                 n_corners: int = 1) -> None:
        """Bent brackets in the most open corner(s) between panel ``j`` of the butted part ``p``
        and a panel ``(n, v, quad)`` of the continuous plate ``cont``; records the joint(s)."""
        quad = p.panels[j]
        line = pb - pa
        u = line / np.linalg.norm(line)
        vb = quad.mean(axis=0) - pa
        vb = vb - (vb @ u) * u
        vb = vb / np.linalg.norm(vb)
        # other parts' panels and the brackets already there must not be in the corner
        obstacles = [v for v in self._dirs.get(node, [])] + self._bracket_dirs.get(node, [])
        picks = self._cached(corners, [v for _, v, _ in cont], vb, line, obstacles)[:n_corners]
        placed = 0
        why = "no corner between 25 and 172 deg for a bracket"
        for i, angle in picks:
            nc, vc, qc = cont[i]
            nb = quad_normals(quad[None])[0]
            nc = nc if nc @ vb > 0 else -nc
            nb = nb if nb @ vc > 0 else -nb
            q = self._cached(place_connector, pa, pb, (nc, vc), (nb, vb), qc, quad, thickness=self.thickness,
                                gap=CONNECTOR_GAP * self.thickness)
            why = "the panels are too small for a bracket"
            if q is not None:
                self._record(JointKind.BUTT_BRACKET, node, names + (p.name,), insert, q,
                             -(vc + vb), angle, p.name, why)
                self._bracket_dirs.setdefault(node, []).append((vc + vb) / np.linalg.norm(vc + vb))
                placed += 1
        if not placed:
            self._record(JointKind.BUTT_BRACKET, node, names + (p.name,), insert, None, None,
                         picks[0][1] if picks else 90.0, p.name, why)

    def _splice(self, e: Part, p: Part, node: int, other) -> None:
        """A bent splice plate across the mitred seam between ``e`` (ending at ``node``) and
        ``p`` (starting there), on the side clear of the other family's plate ``other``."""
        qe, qp = e.panels[-1], p.panels[0]
        pa, pb = qp[0], qp[3]
        u = (pb - pa) / np.linalg.norm(pb - pa)
        v1 = qe.mean(axis=0) - pa
        v2 = qp.mean(axis=0) - pa
        v1, v2 = v1 - (v1 @ u) * u, v2 - (v2 @ u) * u
        v1, v2 = v1 / np.linalg.norm(v1), v2 / np.linalg.norm(v2)
        n1, n2 = quad_normals(qe[None])[0], quad_normals(qp[None])[0]
        fold = _fold_deg(n1, n2)
        q = None
        why = "the other family's plate passes on both sides of the seam"
        if len(other) < 2:
            side = -(other[0][1] @ (n1 + n2)) if other else (v1 + v2) @ (n1 + n2)
            s = 1.0 if side >= 0 else -1.0
            q = self._cached(place_connector, pa, pb, (s * n1, v1), (s * n2, v2), qe, qp,
                                thickness=self.thickness, gap=CONNECTOR_GAP * self.thickness)
            why = "the panels are too small for a splice plate"
        cdir = -(n1 + n2) * (1.0 if q is None else s)
        self._record(JointKind.MITRE_SPLICE, node, (e.name, p.name), -v2, q, cdir, fold, p.name, why)

    def _record(self, kind, node, names, insert, q, cdir, angle, part, why) -> None:
        """Append a :class:`Joint` (and its connector part built from the quads ``q``, or an
        entry of ``unconnected_joints`` if there is none)."""
        conn = None
        if q is not None:
            idx = self._n_conn.get(node, 0)
            self._n_conn[node] = idx + 1
            n = quad_normals(q)
            c = Part(id=PartId(CONNECTOR_FAMILY, node, idx), panels=q, nodes=np.full(3, node),
                     edges=np.full(2, -1), miters=np.array([n[0], _miter(n[0], n[1]), n[1]]),
                     color=FAMILY_COLORS[CONNECTOR_FAMILY], span=(0, 2))
            self._connectors.append(c)
            conn = c.name
            names = names + (conn,)
        else:
            self.unconnected_joints.append((part, node, why))
        unit = lambda x: None if x is None else np.asarray(x, float) / np.linalg.norm(x)  # noqa: E731
        self.joints.append(Joint(kind, int(node), tuple(names), unit(insert), conn, unit(cdir),
                                 float(angle)))

    def _slot_crossings(self, st: "_Strips", part_of_strip, joinery, cont) -> None:
        """Egg-crate slots where both plates pass and the joinery allows it: family 0 from its
        ``b`` edge, family 1 from its ``a`` edge, each as wide as :func:`~.joints.slot_width`
        says for the crossing angle and folds there."""
        t, c = self.thickness, self.clearance
        at_node: dict[int, list[list[tuple[Part, int]]]] = {}
        for fs, parts in zip(st.fins, part_of_strip):
            for p in parts:
                for pos, node in enumerate(p.nodes):
                    node = int(node)
                    x = joinery.get(node)
                    if x is not None and x.kind == JointKind.EGG_CRATE and cont[0, node] and cont[1, node]:
                        at_node.setdefault(node, [[], []])[fs.family].append((p, pos))
        self._plan = self._slide_plan(st, at_node)
        for node in sorted(at_node):
            l0, l1 = at_node[node]
            if not l0 or not l1:
                continue
            x = joinery[node]
            d = float(st.depth[node])
            d0 = self.slot_ratio * d
            d1 = d - d0
            # the family-1 plate slides along its own direction, a little off this node axis:
            # both slots are wider by the sideways travel over the fin depth, on either side
            direction, sense = self._plan[l1[0][0].name]
            ax = sense * (st.a[node] - st.b[node]) / d
            skew = np.arctan2(np.linalg.norm(_cross(direction, ax)), direction @ ax)
            extra = 2.0 * d * np.tan(skew)
            w0 = slot_width(x.angle, thickness=t, clearance=c, fold_self=x.folds[0],
                            fold_other=x.folds[1]) + extra
            w1 = slot_width(x.angle, thickness=t, clearance=c, fold_self=x.folds[1],
                            fold_other=x.folds[0]) + extra
            names0 = tuple(sorted({p.name for p, _ in l0}))
            names1 = tuple(sorted({p.name for p, _ in l1}))
            # family 0 slotted from its b edge and family 1 from its a edge (family 1 moves
            # along a - b), or the other way round where family 1 slides in along b - a
            side0, side1 = (SlotSide.B, SlotSide.A) if sense > 0 else (SlotSide.A, SlotSide.B)
            for p, pos in l0:
                p.slots.append(Slot(node, pos, side0, d0, w0, "+".join(names1)))
            for p, pos in l1:
                p.slots.append(Slot(node, pos, side1, d1, w1, "+".join(names0)))
            w = max(w0, w1)
            self.crossings.append(Crossing(node, names0, names1, d, d0, d1, w, w - c - t,
                                           float(x.angle), float(max(x.folds))))
            self.joints.append(Joint(JointKind.EGG_CRATE, node, names0 + names1,
                                     direction, None, None, float(x.angle)))

    def _butted_after(self) -> dict:
        """``{part: {part placed after it: node}}``: family-1 plates go on family-0 plates
        at an egg-crate, a butted part after the plate it butts against (the two parts of a
        mitred seam in either order)."""
        after: dict[str, dict[str, int]] = {}
        conn = {j.connector for j in self.joints if j.connector}
        for j in self.joints:
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
        after = self._butted_after()
        split_at = {x.node: x for x in self.joinery}
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

    def _slide_plan(self, st: "_Strips", at_node) -> dict:
        """``{family-1 part name: (unit direction, sense)}``: every family-1 plate slides onto
        all its egg-crate crossings along one direction, the mean of their node axes
        (``sense`` +1: along ``a - b``, slots open on its ``a`` edge; -1: along ``b - a``),
        the sense in which its butted ends do not run into the plates they meet. A crossing
        whose axis is more than :data:`~.joints.MAX_SLOT_SKEW` off that direction, or a plate
        whose butted ends block it in both senses, is listed in ``_unslidable`` (butted in the
        next build)."""
        nodes_of: dict[str, list[int]] = {}
        for node, (l0, l1) in sorted(at_node.items()):
            if l0 and l1:
                for p, _ in l1:
                    nodes_of.setdefault(p.name, []).append(node)
        plan = {}
        for name, nodes in nodes_of.items():
            axes = np.array([(st.a[v] - st.b[v]) / st.depth[v] for v in nodes])
            d = axes.sum(axis=0)
            d = d / np.linalg.norm(d)
            skew = np.degrees(np.arctan2(np.linalg.norm(_cross(axes, d), axis=1), axes @ d))
            if skew.max() > MAX_SLOT_SKEW:
                self._unslidable[nodes[int(np.argmax(skew))]] = 1, (
                    f"its node axis is {skew.max():.1f} deg off the slide direction of {name} "
                    f"(> {MAX_SLOT_SKEW:g}): the plate cannot slide onto all its crossings")
            walls = self._walls.get(name, [])
            sense = 1.0
            if walls:
                run_in = {s_: max(s_ * d @ n for n in walls) for s_ in (1.0, -1.0)}
                sense = min(run_in, key=run_in.get)
                # the butted end may close its gap (clearance / 2) over a travel of the depth
                if run_in[sense] > 0.5 * self.clearance / float(st.depth[nodes].max()):
                    for v in nodes:
                        self._unslidable.setdefault(v, (1,
                            f"{name} would run into a plate it butts against while sliding "
                            f"along its node axes ({np.degrees(np.arcsin(min(1.0, run_in[sense]))):.1f} deg)"))
            plan[name] = (sense * d, sense)
        return plan

    def _node_axis(self, node: int) -> np.ndarray:
        """Unit node axis ``a_i - b_i`` (any vector when the node is -1)."""
        if node < 0:
            return np.zeros(3)
        d = np.asarray(self.structure.vertices_a[node] - self.structure.vertices_b[node], float)
        return d / np.linalg.norm(d)

    def _set_butt_directions(self) -> None:
        """Every part slides in along one direction: a family-1 plate with slots along its
        slide direction (:meth:`_slide_plan`), any other butted part along the first direction,
        of those its butt joints allow (:meth:`_butt_candidates`), that runs into none of the
        plates it butts against. The butt joints record it as their ``insert_direction``;
        :meth:`_check_paths` may pick a later one."""
        plan = getattr(self, "_plan", {})
        butted: dict[str, list[int]] = {}
        for k, j in enumerate(self.joints):
            if j.kind == JointKind.BUTT_BRACKET:
                names = [n for n in j.parts if n != j.connector]
                butted.setdefault(names[-1], []).append(k)
        #: part name -> (its butt joints, the directions it may go in along, best first; None:
        #: each joint keeps its own)
        self._directions: dict[str, tuple] = {}
        for name, ks in butted.items():
            walls = self._walls.get(name, [])
            if name in plan:
                cands = [plan[name][0]]
            elif not walls:
                cands = None
            else:
                cands = self._butt_candidates(ks, walls)
            self._directions[name] = (ks, cands)
            for k in ks if cands else ():
                self.joints[k] = replace(self.joints[k], insert_direction=np.asarray(cands[0], float))
        for name in sorted(set(plan) - set(butted)):      # slotted plates without butt joints
            self._directions[name] = ([], [plan[name][0]])

    def _check_paths(self) -> None:
        """The path of every part into place (:class:`_PathCheck`): each part goes in along the
        first of its directions (:meth:`_set_butt_directions`) whose path is clear, recorded in
        its joints; a part with no clear path keeps the first and is listed in
        ``_blocked_paths`` (panels are left out in the next build: :meth:`_blocked_panels`)."""
        paths = _PathCheck(self)
        self._blocked_paths = []
        for name, (ks, cands) in self._directions.items():
            p = paths.plates[paths.index[name]]
            tries = cands if cands else [self.joints[ks[0]].insert_direction]
            first = None
            for d in tries:
                h = paths.hits(p, d)
                if not h:
                    break
                first = h if first is None else first
            else:
                d = tries[0]
                self._blocked_paths.append((p, first))
            for k in ks if cands else ():
                self.joints[k] = replace(self.joints[k], insert_direction=np.asarray(d, float))

    def _butt_candidates(self, ks: list[int], walls: list) -> list[np.ndarray]:
        """Directions a part with butt joints ``ks`` and the faces ``walls`` it ends against
        may slide in along, best first: those that run into none of those faces (the node axis
        of a butt joint first: it lies in both plates, the end slides along the plate it meets;
        then the lines where two faces meet, then head on), else the one that runs in least."""
        cands = [self._node_axis(self.joints[k].node) for k in ks]
        cands += [self.joints[k].insert_direction for k in ks]
        cands += [_cross(a, b) for i, a in enumerate(walls) for b in walls[i + 1:]]
        cands.append(-np.sum(walls, axis=0))
        cands = [c / np.linalg.norm(c) for c in cands if np.linalg.norm(c) > 1e-9]
        cands = [s_ * c for c in cands for s_ in (1.0, -1.0)]
        run_in = [max(c @ n for n in walls) for c in cands]
        ok = [c for c, r in zip(cands, run_in) if r <= 1e-3]
        return ok if ok else [cands[int(np.argmin(run_in))]]

    def _blocked_panels(self, *, leaving: set = frozenset()) -> list[tuple]:
        """Panels to leave out so that every part can be put in (``_blocked_paths``: parts whose
        path, along every direction their joints allow, comes too near a plate that may be in
        place before them): of every such pair of panels the cheaper one (:meth:`_panel_cost`),
        unless one of the two is in ``leaving`` ({(strip index, panel of the strip)}) already."""
        gone = set(leaving)
        out = []
        for p, hits in self._blocked_paths:
            for i, o, jo, d in hits:
                mine = (self._strip_of[p.name], p.span[0] + i)
                theirs = (self._strip_of[o.name], o.span[0] + jo)
                if mine in gone or theirs in gone:
                    continue
                if self._panel_cost(p, i) <= self._panel_cost(o, jo):
                    q, j, key = p, i, mine
                    why = (f"its path into place comes within {d:.2f} {self.unit} of panel "
                           f"{int(o.edges[jo])} of {o.name[:-4]}, which is in place before it")
                else:
                    q, j, key = o, jo, theirs
                    why = (f"the path of {p.name} into place comes within {d:.2f} {self.unit} "
                           f"of it")
                gone.add(key)
                out.append((key[0], key[1], q.name[:-4], int(q.edges[j]), int(q.nodes[j]), why))
        return out

    def _panel_cost(self, p: Part, j: int) -> tuple:
        """What leaving out panel ``j`` of plate ``p`` costs, for sorting: a panel at an end of
        its part (leaving it out splits nothing) before one inside it, then the panel of the
        shorter strip, then by name."""
        lengths = self.__dict__.get("_strip_len")
        if lengths is None or lengths[0] is not self.parts:
            count: dict[int, int] = {}
            for q in self.parts:
                si = self._strip_of.get(q.name)
                if si is not None:
                    count[si] = count.get(si, 0) + len(q.panels)
            lengths = self._strip_len = (self.parts, count)
        return 0 < j < len(p.panels) - 1, lengths[1][self._strip_of[p.name]], p.name, j

    def _resolve_slot_splits(self) -> None:
        """Slots that would cut a part in two (a narrow or slanted panel at the node: the slot
        band runs out of the panel) are made shallower, leaving a web of ``thickness``; the
        partner's slot is deepened by as much where that keeps it whole, else the two plates
        interfere there. A slot that cuts the part apart at any depth is left out. Each case
        is listed in ``slot_conflicts`` and warned about."""

        def whole(p: Part, slots) -> bool:
            try:
                unroll(p.panels, slots=list(slots), name=p.name)
            except ValueError as e:
                return "slots cut" not in str(e)
            return True

        conflicts: list[tuple[str, int, float, float, str]] = []
        for p in self.parts:
            if not p.slots or whole(p, p.slots):
                continue
            for s in list(p.slots):
                if whole(p, [s]):
                    continue
                i = p.slots.index(s)
                lo, hi = 0.0, s.depth
                if not whole(p, [replace(s, depth=1e-3 * s.depth)]):
                    new = 0.0
                else:
                    for _ in range(12):
                        mid = 0.5 * (lo + hi)
                        lo, hi = (mid, hi) if whole(p, [replace(s, depth=mid)]) else (lo, mid)
                    new = lo - self.thickness
                    if new <= 0.05 * s.depth:
                        new = 0.0
                if new > 0:
                    p.slots[i] = replace(s, depth=new)
                else:
                    del p.slots[i]
                # the partner(s) take the difference if they stay whole
                lack = s.depth - new
                notes = []
                for o in self.parts:
                    if o.family == p.family or o.family not in (0, 1):
                        continue
                    for jo, so in enumerate(o.slots):
                        if so.node != s.node:
                            continue
                        deeper = replace(so, depth=min(so.depth + lack, float(self._fin_depth[s.node])))
                        trial = o.slots[:jo] + [deeper] + o.slots[jo + 1:]
                        if whole(o, trial):
                            o.slots[jo] = deeper
                            notes.append(f"{o.name} slotted {lack:.3g} deeper")
                        else:
                            notes.append(f"{o.name} cannot take it: the plates interfere by "
                                         f"{lack:.3g} {self.unit}")
                conflicts.append((p.name, s.node, float(s.depth), float(new),
                                  "; ".join(notes) or "no partner slot"))
        self.slot_conflicts = conflicts
        if conflicts:
            warnings.warn(
                f"{len(conflicts)} egg-crate slots would cut their part in two (narrow or slanted "
                f"panel at the node) and were made shallower or left out: "
                + "; ".join(f"{n} at node {v}: depth {d0:.3g} -> {d1:.3g} {self.unit} ({note})"
                            for n, v, d0, d1, note in conflicts[:6])
                + (" ..." if len(conflicts) > 6 else "") + "; see FinSystem.slot_conflicts",
                stacklevel=4)


    # ------------------------------------------------------------------ access
    def part(self, name: str) -> Part:
        """The part called ``name`` (e.g. ``"F0-S002-P00"``)."""
        for p in self.parts:
            if p.name == name:
                return p
        raise KeyError(f"no part {name!r}")

    @property
    def n_panels(self) -> int:
        """Fin panels in the plates (connectors not counted)."""
        return int(sum(len(p.panels) for p in self.parts if p.family != CONNECTOR_FAMILY))

    @property
    def connectors(self) -> list[Part]:
        """The connector parts (brackets, splice plates), named ``C-N<node>-<i>``."""
        return [p for p in self.parts if p.family == CONNECTOR_FAMILY]

    def __repr__(self) -> str:
        return (f"FinSystem({len(self.parts)} parts, {self.n_panels} panels, "
                f"{len(self.crossings)} crossings, {len(self.connectors)} connectors, "
                f"t={self.thickness:g} {self.unit})")

    # ------------------------------------------------------------------ solids (solids.py)
    def solids(self, *, repair: bool = True, workers: int | None = None) -> dict:
        """``{part name: build123d.Solid}``, built once and cached; ``workers`` processes
        build them in parallel (default: one per core); see
        :func:`torsal.fabrication.solids.build_solids`."""
        if self._solids is None:
            pending, self._pending = getattr(self, "_pending", None), None
            self._solids = _solids.build_solids(self, repair=repair, workers=workers,
                                                pending=pending)
        return self._solids

    def start_solids(self, *, workers: int | None = None) -> bool:
        """Start building the solids in worker processes and return at once, so that this
        process can unroll, nest and write the sheets meanwhile; :meth:`solids` (and the
        exports) then collect them. False if there is nothing to start (built already, or
        one worker: they are built when asked for); see
        :func:`torsal.fabrication.solids.start_solids`."""
        if self._solids is not None or getattr(self, "_pending", None) is not None:
            return False
        self._pending = _solids.start_solids(self, workers=workers)
        return self._pending is not None

    def cancel_solids(self) -> None:
        """Drop a build started by :meth:`start_solids` (e.g. when a later step failed)."""
        pending, self._pending = getattr(self, "_pending", None), None
        if pending is not None:
            pending.cancel()

    def export_step(self, path) -> "object":
        """One STEP assembly with a named, coloured solid per part (``unit``)."""
        return _solids.export_step(self, path)

    def export_stl(self, path, *, tolerance: float | None = None):
        """Preview mesh of all parts as STL (through trimesh)."""
        return _solids.export_mesh(self, path, file_type="stl", tolerance=tolerance)

    def export_gltf(self, path, *, tolerance: float | None = None):
        """Preview scene as glTF binary (``.glb``) with a coloured node per part."""
        return _solids.export_mesh(self, path, file_type="glb", tolerance=tolerance)

    def export_3dm(self, path, *, tolerance: float | None = None):
        """Rhino ``.3dm`` with one named mesh object per part on a layer per family."""
        return _solids.export_3dm(self, path, tolerance=tolerance)

    # ------------------------------------------------------------------ unrolling, layout
    def unrolled(self) -> dict:
        """``{part name: Unrolled}`` for every part (cached); see :func:`unroll`."""
        if self._unrolled is None:
            self._unrolled = {p.name: unroll(p) for p in self.parts}
        return self._unrolled

    def layout(self, *, sheet: tuple[float, float] = (2500.0, 1250.0), gap: float = 5.0,
               margin: float = 10.0, rotations: Sequence[float] = (0, 90, 180, 270)):
        """Nest the unrolled plates on sheets (``unit``; see :func:`torsal.fabrication.layout.nest`)
        and pack the connectors in rows on the sheets after them
        (:func:`~torsal.fabrication.layout.shelf_pack`: hundreds of small brackets would make
        the nesting quadratic)."""
        flat = self.unrolled()
        conn = {p.name for p in self.connectors}
        plates = _layout.nest([u for n, u in flat.items() if n not in conn], sheet=sheet, gap=gap,
                              margin=margin, rotations=rotations, unit=self.unit)
        if not conn:
            return plates
        kit = _layout.shelf_pack([u for n, u in flat.items() if n in conn], sheet=sheet, gap=gap,
                                 margin=margin, unit=self.unit, first_sheet=plates.n_sheets)
        return _layout.merge_layouts(plates, kit)

    def bill_of_materials(self, path, *, density: float = 2700.0, layout=None):
        """CSV parts list; see :func:`torsal.fabrication.layout.bill_of_materials`."""
        return _layout.bill_of_materials(self, path, density=density, layout=layout)
