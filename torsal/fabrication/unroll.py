"""Development (unrolling) of strips of planar panels into flat outlines (issue 6).

A strip of quads ``p0 p1 p2 p3`` whose consecutive quads share the fold line ``p1 p2`` /
``p0 p3`` is laid flat panel by panel: the first panel in its own plane frame, each next one
rotated about the shared fold line into that plane. For planar panels this is an isometry
of every panel (edge lengths preserved to rounding); for panels that are not quite planar each
panel is replaced by the flat quad that best matches its 4 edges and 2 diagonals (least
squares on the relative length errors, all panels of a strip at once by vectorized
Gauss-Newton, placed where it best fits the panel's projection on its plane) and the worst
relative edge-length error is reported.

Coordinates are in the unit of the input (``unit`` of a :class:`~.parts.Part`, usually mm).
The flat top side is the ``+normal`` side of the panels (Newell normal of ``a_i a_j b_j b_i``),
so the unrolled part is never mirrored.

Example
-------
>>> u = unroll(fin_system.parts[0])                            # doctest: +SKIP
>>> u.outline.area, np.degrees(u.fold_angles), u.max_edge_error  # doctest: +SKIP
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry import Point, Polygon
from shapely.ops import polylabel, unary_union

from .model import Slot, SlotSide, _cross, fold_angles, quad_normals

__all__ = ["Unrolled", "unroll", "flat_outline", "fold_back", "slot_rectangle", "flat_point",
           "FLAT_FOLD"]

#: radians: a fold line whose fold angle is at most this (in absolute value) is flat, not a bend
FLAT_FOLD = 1e-9

_PAIRS = np.array([[0, 1], [1, 2], [2, 3], [3, 0], [0, 2], [1, 3]])
_EDGES = _PAIRS[:4]


@dataclass
class Unrolled:
    """A flat part.

    Attributes
    ----------
    name : str
        Part name (``"F0-S001-P00"``) or ``"strip"``.
    panels : (k, 4, 2) float
        Flat panel corners; ``panels[k, 1:3]`` and ``panels[k+1, [0, 3]]`` are the same points.
    fold_angles : (k-1,) float
        Signed fold angles in radians (see :func:`torsal.fabrication.parts.fold_angles`):
        folding panel ``k+1`` about the fold line ``panels[k, 1] -> panels[k, 2]`` by this angle
        (right-hand rule, top = +z) restores the 3D part.
    fold_lines : (k-1, 2, 2) float
        Fold lines (``a`` end, ``b`` end).
    slots : list of (4, 2) float
        Slot cut-outs (rectangles reaching past the open edge), removed from ``outline``.
    outline : shapely Polygon
        Union of the panels minus the slots: what is cut.
    label_position : (2,) float
        A point well inside the outline (pole of inaccessibility of the roomiest panel, off
        the fold lines) for the engraved part id.
    label_angle, label_height : float
        Direction of the label text (radians, along the panel's ``a`` edge) and a text height
        that fits the panel.
    max_edge_error : float
        Worst relative difference between a 3D panel edge and its flat length.
    frame : (4, 3) float
        ``origin, e1, e2, normal`` placing the first flat panel in 3D:
        ``X = origin + x e1 + y e2``.
    planar : bool
        All panels planar to rounding (exact development).
    holes : list of ((2,) float, float)
        Fastener holes ``(centre, diameter)`` of the part (``Part.holes``) on the flat part.
    """

    name: str
    panels: np.ndarray
    fold_angles: np.ndarray
    fold_lines: np.ndarray
    slots: list
    outline: Polygon
    label_position: np.ndarray
    label_angle: float
    label_height: float
    max_edge_error: float
    frame: np.ndarray
    planar: bool
    slot_records: list = field(default_factory=list)
    holes: list = field(default_factory=list)

    @property
    def area(self) -> float:
        return float(self.outline.area)

    @property
    def fold_count(self) -> int:
        """Bends of the part: folds sharper than :data:`FLAT_FOLD`."""
        return int(np.count_nonzero(np.abs(self.fold_angles) > FLAT_FOLD))


def _plane_frame(quad: np.ndarray) -> np.ndarray:
    """origin, e1 (along p0 -> p1), e2 = n x e1, n for a quad (4, 3)."""
    n = quad_normals(quad[None])[0]
    e1 = quad[1] - quad[0]
    if np.linalg.norm(e1) <= 1e-9 * np.linalg.norm(quad[2] - quad[3]):   # triangle: a_i == a_j
        e1 = quad[2] - quad[3]
    e1 = e1 - (e1 @ n) * n
    e1 /= np.linalg.norm(e1)
    e2 = _cross(n, e1)
    return np.array([quad.mean(axis=0), e1, e2, n])


def _pair_lengths(pts: np.ndarray) -> np.ndarray:
    """Lengths (..., 6) of the 4 edges and 2 diagonals of quads (..., 4, d)."""
    return np.linalg.norm(pts[..., _PAIRS[:, 0], :] - pts[..., _PAIRS[:, 1], :], axis=-1)


def _rigid_2d(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation R (2, 2) and translation t with R src + t ~ dst (proper, least squares)."""
    cs, cd = src.mean(0), dst.mean(0)
    h = (src - cs).T @ (dst - cd)
    ang = np.arctan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1])
    r = np.array([[np.cos(ang), -np.sin(ang)], [np.sin(ang), np.cos(ang)]])
    return r, cd - r @ cs


def _best_flat_quads(target: np.ndarray, start: np.ndarray, *, iterations: int = 50) -> np.ndarray:
    """Flat quads (m, 4, 2) whose 4 edges and 2 diagonals best match ``target`` (m, 6):
    Gauss-Newton on the relative length errors ``(l - target) / target`` (minimum-norm steps,
    so the flat quad does not drift by a rigid motion), from ``start`` (m, 4, 2), then placed
    by the rigid motion that best fits it onto ``start``.

    The residual of a nearly planar quad is small (its out-of-plane offset over its size, squared),
    so Gauss-Newton converges to the least-squares optimum in a few steps; a step that does not
    lower a quad's cost is halved. Pairs of zero target length (a triangle's double corner) do
    not count.
    """
    w = np.divide(1.0, target, out=np.zeros_like(target), where=target > 0)
    y = start.copy()
    scale = np.linalg.norm(np.ptp(start, axis=1), axis=1)                  # (m,)

    def residual(pts, sel):
        return (_pair_lengths(pts) - target[sel]) * w[sel]

    r = residual(y, slice(None))
    cost = np.einsum("mp,mp->m", r, r)
    active = np.ones(len(y), bool)
    for _ in range(iterations):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        ya = y[idx]
        d = ya[:, _PAIRS[:, 0]] - ya[:, _PAIRS[:, 1]]                        # (m, 6, 2)
        length = np.linalg.norm(d, axis=2, keepdims=True)
        u = np.divide(d, length, out=np.zeros_like(d), where=length > 0) * w[idx, :, None]
        jac = np.zeros((idx.size, 6, 4, 2))
        rows = np.arange(6)
        jac[:, rows, _PAIRS[:, 0]] = u
        jac[:, rows, _PAIRS[:, 1]] = -u
        jac = jac.reshape(idx.size, 6, 8)
        step = -np.einsum("mij,mj->mi", np.linalg.pinv(jac, rcond=1e-12), r[idx]).reshape(-1, 4, 2)
        t = np.ones(idx.size)
        for _ in range(30):                       # halve the step of quads it does not improve
            trial = ya + t[:, None, None] * step
            rt = residual(trial, idx)
            ct = np.einsum("mp,mp->m", rt, rt)
            worse = ct > cost[idx]
            if not worse.any():
                break
            t[worse] *= 0.5
        ok = ~worse
        y[idx[ok]] = trial[ok]
        r[idx[ok]] = rt[ok]
        moved = t * np.abs(step).reshape(idx.size, -1).max(axis=1)
        cost[idx[ok]] = ct[ok]
        # converged: the step is at rounding level of the quad's size, or no step improves
        active[idx[(moved <= 1e-15 * scale[idx]) | worse]] = False
    for i in range(len(y)):
        rot, shift = _rigid_2d(y[i], start[i])
        y[i] = y[i] @ rot.T + shift
    return y


#: {(tol, the quad's bytes): (its flat quad (4, 2), planar)} of :func:`_flat_quads`: a fin
#: system's build unrolls the same panels again and again (the sheet fits' bisection unrolls
#: every prefix of a run; each rebuild unrolls its runs again: 2,934 quads of 656 distinct
#: on 7a), and each quad's flat version is its own (the Gauss-Newton of
#: :func:`_best_flat_quads` treats each quad apart: the same bits alone or in any batch)
_FLAT_MEMO: dict[tuple[float, bytes], tuple[np.ndarray, bool]] = {}
#: entries kept at most (then the memo starts afresh): about 300 bytes each
_FLAT_MEMO_SIZE = 100_000


def _flat_quads(quads: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Flat versions (k, 4, 2) of 3D quads (k, 4, 3), each in its own plane frame, and whether
    each is planar (corners within ``tol`` of its size from its plane): a planar quad is
    projected (an isometry), the others replaced by the flat quads that best match their
    edges and diagonals (:func:`_best_flat_quads`). Quads developed before are looked up
    (:data:`_FLAT_MEMO`), the others developed together."""
    quads = np.asarray(quads, dtype=float)
    keys = [(float(tol), q.tobytes()) for q in quads]
    found = [_FLAT_MEMO.get(k) for k in keys]
    todo = [i for i, f in enumerate(found) if f is None]
    if todo:
        x, planar = _develop_quads(quads[todo], tol)
        if len(_FLAT_MEMO) + len(todo) > _FLAT_MEMO_SIZE:
            _FLAT_MEMO.clear()
        for j, i in enumerate(todo):
            found[i] = _FLAT_MEMO[keys[i]] = (x[j].copy(), bool(planar[j]))
    x = np.empty((len(quads), 4, 2))
    for i, (flat, _) in enumerate(found):
        x[i] = flat
    return x, np.array([planar for _, planar in found], dtype=bool)


def _develop_quads(quads: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_flat_quads` computed (no memo)."""
    x = np.empty((len(quads), 4, 2))
    planar = np.empty(len(quads), bool)
    for i, quad in enumerate(quads):
        fr = _plane_frame(quad)
        x[i] = (quad - fr[0]) @ fr[1:3].T
        off = (quad - fr[0]) @ fr[3]
        size = np.linalg.norm(quad[2] - quad[0]) + np.linalg.norm(quad[3] - quad[1])
        planar[i] = np.abs(off).max() <= tol * size
    if not planar.all():
        bent = ~planar
        x[bent] = _best_flat_quads(_pair_lengths(quads[bent]), x[bent])
    return x, planar


def slot_rectangle(a2: np.ndarray, b2: np.ndarray, side: SlotSide, depth: float, width: float,
                   overshoot: float | None = None) -> np.ndarray:
    """The (4, 2) cut-out of a slot on the flat node line ``a2 -> b2``: ``width`` wide,
    centred on the line, from the open end (``a2`` or ``b2``) ``depth`` into the part and
    ``overshoot`` (default ``2 width`` plus the line's length: an open edge slanted along the
    line leaves no web across the slot's mouth) beyond the open edge."""
    a2, b2 = np.asarray(a2, float), np.asarray(b2, float)
    start, other = (b2, a2) if SlotSide(side) == SlotSide.B else (a2, b2)
    u = other - start
    u /= np.linalg.norm(u)
    v = np.array([-u[1], u[0]])
    o = 2.0 * width + float(np.linalg.norm(b2 - a2)) if overshoot is None else overshoot
    h = 0.5 * width
    return np.array([start - o * u - h * v, start + depth * u - h * v,
                     start + depth * u + h * v, start - o * u + h * v])


def unroll(strip, *, slots: list[Slot] | None = None, planar_tol: float = 1e-9,
           name: str | None = None) -> Unrolled:
    """Develop a strip of quads into the plane.

    Parameters
    ----------
    strip : Part, FinStrip or (k, 4, 3) array
        Quads ``p0 p1 p2 p3`` (``a_i a_j b_j b_i``); ``p1 p2`` of one quad is ``p0 p3`` of
        the next (the fold line).
    slots : list of Slot, optional
        Slot records (default: ``strip.slots`` for a Part); cut out of the outline.
    planar_tol : float
        Panels whose corners are within ``planar_tol * size`` of their plane are developed
        exactly; others by least squares.

    Returns
    -------
    Unrolled
        Outline, fold lines and angles, slot cut-outs, label position, worst edge error.
    """
    quads = _quads_of(strip)
    if slots is None:
        slots = list(getattr(strip, "slots", []))
    if name is None:
        name = getattr(strip, "name", "strip")
    k = len(quads)
    frame = _plane_frame(quads[0])
    flat, planar = _lay_flat(quads, planar_tol)
    # errors
    l3 = np.linalg.norm(quads[:, _EDGES[:, 0]] - quads[:, _EDGES[:, 1]], axis=2)
    l2 = np.linalg.norm(flat[:, _EDGES[:, 0]] - flat[:, _EDGES[:, 1]], axis=2)
    pos = l3 > 0                                   # a triangle panel has a zero-length edge
    err = float(np.max(np.abs(l2 - l3)[pos] / l3[pos], initial=0.0))
    outline, rects = _slotted_outline(flat, slots, name)
    label, label_angle, label_height = _label(flat, outline)
    fl = np.stack([flat[:-1, 1], flat[:-1, 2]], axis=1) if k > 1 else np.zeros((0, 2, 2))
    frames = _panel_frames(quads) if getattr(strip, "holes", ()) else None
    holes = [(flat_point(quads, flat, np.asarray(h.center, float), frames=frames), float(h.diameter))
             for h in getattr(strip, "holes", ())]
    return Unrolled(name=name, panels=flat, fold_angles=fold_angles(quads), fold_lines=fl,
                    slots=rects, outline=outline, label_position=label, label_angle=label_angle,
                    label_height=label_height, max_edge_error=err, frame=frame, planar=planar,
                    slot_records=list(slots), holes=holes)


def _quads_of(strip) -> np.ndarray:
    """The (k, 4, 3) float quads of a Part, a FinStrip or an array (ValueError otherwise)."""
    quads = np.asarray(getattr(strip, "panels", getattr(strip, "quads", strip)), dtype=float)
    if quads.ndim != 3 or quads.shape[1:] != (4, 3) or len(quads) == 0:
        raise ValueError(f"expected (k, 4, 3) quads, got {quads.shape}")
    return quads


def _lay_flat(quads: np.ndarray, planar_tol: float) -> tuple[np.ndarray, bool]:
    """The strip's flat panels (k, 4, 2): the first in its own plane frame, each next one
    rotated about the shared fold line onto the previous one; and whether every panel is
    planar (see :func:`_flat_quads`)."""
    k = len(quads)
    flat = np.empty((k, 4, 2))
    flats, planar_each = _flat_quads(quads, planar_tol)
    for i in range(k):
        f = flats[i]
        if i == 0:
            flat[0] = f
            continue
        # rotate about the shared fold line: align p0, p3 onto previous p1, p2
        dst = flat[i - 1, [1, 2]]
        r, t = _rigid_2d(f[[0, 3]], dst)
        g = f @ r.T + t
        g[[0, 3]] = dst                       # identical points on the shared fold
        flat[i] = g
    return flat, bool(planar_each.all())


def _flat_body(flat: np.ndarray, name: str):
    """The union (a shapely Polygon) of the flat panels; ValueError naming ``name`` if a panel
    is degenerate or the strip overlaps itself."""
    polys = [Polygon(f) for f in flat]
    for j, pg in enumerate(polys):
        if not pg.is_valid or pg.area <= 0:
            raise ValueError(f"{name}: flat panel {j} is self-intersecting or degenerate")
    body = unary_union(polys)
    total = sum(p.area for p in polys)
    if abs(body.area - total) > 1e-6 * total or body.geom_type != "Polygon":
        raise ValueError(f"{name}: the unrolled strip overlaps itself (union {body.area:.6g} vs "
                         f"panels {total:.6g}); split it into shorter parts (max_panels)")
    return body


def _slotted_outline(flat: np.ndarray, slots, name: str):
    """``(outline, slot rectangles)``: the union of the flat panels minus the slots' cut-outs;
    ValueError naming ``name`` where the panels do not make one polygon or the slots cut it
    apart."""
    body = _flat_body(flat, name)
    rects = []
    for s in slots:
        pos = s.position
        a2, b2 = (flat[0, 0], flat[0, 3]) if pos == 0 else (flat[pos - 1, 1], flat[pos - 1, 2])
        rects.append(slot_rectangle(a2, b2, s.side, s.depth, s.width))
    outline = body
    if rects:
        outline = body.difference(unary_union([Polygon(r) for r in rects]))
    if outline.geom_type != "Polygon":
        raise ValueError(f"{name}: slots cut the part into {len(getattr(outline, 'geoms', []))} pieces")
    return shapely.set_precision(outline, 0.0), rects


def flat_outline(strip, *, slots: list[Slot] = (), planar_tol: float = 1e-9, name: str | None = None):
    """The outline of a strip unrolled: ``unroll(strip, slots=slots).outline`` (the same
    polygon, the same ValueError where it cannot be made), without the label, fold angles
    and holes :func:`unroll` adds (the fin system's sheet fits ask only for the outline's
    size, hundreds of times). No slots unless given.

    >>> q = np.array([[[0, 0, 0], [2, 0, 0], [2, 0, 1], [0, 0, 1]]], float)
    >>> flat_outline(q).area
    2.0
    """
    quads = _quads_of(strip)
    flat, _ = _lay_flat(quads, planar_tol)
    return _slotted_outline(flat, slots, getattr(strip, "name", "strip") if name is None else name)[0]


def flat_point(quads: np.ndarray, flat: np.ndarray, point: np.ndarray, *,
               frames: list | None = None) -> np.ndarray:
    """Where a point on a part's plate (3D, on or near a panel) lies on the unrolled part (2,):
    on the panel it projects into (the nearest such panel's plane; else the nearest panel),
    carried by the rigid motion that lays that panel flat. ``frames``: the panels' frames of
    :func:`_panel_frames`, made once for all the points of a part.

    >>> q = np.array([[[0, 0, 0], [2, 0, 0], [2, 0, 1], [0, 0, 1]]], float)
    >>> u = unroll(q)
    >>> p = flat_point(q, u.panels, np.array([1.0, 0.0, 0.5]))
    >>> bool(np.allclose(p, u.panels[0].mean(axis=0)))       # the panel's centre
    True
    """
    best = None
    for i, (fr, local, poly) in enumerate(_panel_frames(quads) if frames is None else frames):
        x = (point - fr[0]) @ fr[1:3].T
        off = abs(float((point - fr[0]) @ fr[3]))
        outside = 0.0 if poly.covers(Point(x)) else poly.distance(Point(x))
        key = (outside, off)
        if best is None or key < best[0]:
            best = (key, i, local, x)
    _, i, local, x = best
    r, t = _rigid_2d(local, flat[i])
    return r @ x + t


def _panel_frames(quads: np.ndarray) -> list:
    """Per panel of ``quads`` (k, 4, 3): its plane frame (:func:`_plane_frame`), its corners
    in that frame (4, 2) and their polygon (what :func:`flat_point` looks points up in)."""
    out = []
    for quad in quads:
        fr = _plane_frame(quad)
        local = (quad - fr[0]) @ fr[1:3].T
        out.append((fr, local, Polygon(local)))
    return out


def _label(flat: np.ndarray, outline: Polygon) -> tuple[np.ndarray, float, float]:
    """Label point, direction (radians) and text height: inside the roomiest panel (so the
    text stays off the fold lines), along the panel's ``a`` edge, sized to fit."""
    best = None
    for q in flat:
        region = Polygon(q).intersection(outline)
        if region.is_empty:
            continue
        if region.geom_type != "Polygon":
            region = max(region.geoms, key=lambda g: g.area)
        pt = region.centroid
        if not region.contains(pt):
            pt = polylabel(region, tolerance=max(1e-3, 1e-3 * np.sqrt(region.area)))
        r = region.exterior.distance(pt)
        if best is None or r > best[0]:
            best = (r, pt, q)
    r, pt, q = best
    d = q[1] - q[0]
    ang = float(np.arctan2(d[1], d[0]))
    length = float(np.linalg.norm(d))
    height = float(np.clip(min(0.8 * r, length / 12.0), 1.0, 20.0))
    return np.array([pt.x, pt.y]), ang, height


def _rotate(points: np.ndarray, origin: np.ndarray, axis: np.ndarray, ang: float) -> np.ndarray:
    """Rotate points (..., 3) about the line ``origin + s axis`` by ``ang`` (Rodrigues)."""
    k = axis / np.linalg.norm(axis)
    p = points - origin
    c, s = np.cos(ang), np.sin(ang)
    return origin + p * c + np.cross(k, p) * s + np.outer(p.reshape(-1, 3) @ k, k).reshape(p.shape) * (1 - c)


def fold_back(u: Unrolled) -> np.ndarray:
    """Fold an unrolled part back by its recorded fold angles: 3D quads (k, 4, 3) placed
    with the first panel in ``u.frame``."""
    o, e1, e2, _ = u.frame
    x = o + u.panels[..., 0:1] * e1 + u.panels[..., 1:2] * e2
    for i, ang in enumerate(u.fold_angles):
        p, q = x[i, 1], x[i, 2]
        x[i + 1:] = _rotate(x[i + 1:], p, q - p, ang)
    return x
