"""The real parts of the final cut in their stand-ins' places (:mod:`.final_cut`, step 3):
the fin system built again with the cuts (:func:`rebuilt_with_cuts`), and its parts turned
onto the stand-ins of the split search's sheets (:func:`mapped_layout`), the parts that have
no stand-in or leave theirs put into a sheet's hole, else onto a new sheet.

Units: those of the fin system (``unit``).
"""
from __future__ import annotations

import dataclasses
from typing import Mapping

import numpy as np
from shapely import affinity

from ..model import CONNECTOR_FAMILY, FIXING_FAMILY
from .search import _Search, _sheets
from .split import SplitNesting, piece_name

__all__ = ["rebuilt_with_cuts", "mapped_layout", "strip_cuts", "pieces_of"]

#: how far (``unit``) the corners of a real part may lie from its stand-in's when it is turned
#: onto it (a piece's end is trimmed back from its seam by a few tenths of a millimetre)
_FIT = 1.0

#: the FinSystem attributes its constructor sets from its options before it builds (a rebuild
#: with cuts copies them; tests/fabrication/test_yield_split.py checks it builds the same parts)
_OPTIONS = ("structure", "thickness", "clearance", "family_split", "slot_ratio", "max_fold_angle",
            "min_crossing_angle", "max_crossing_fold", "max_panels", "max_part_length",
            "fit_sheet", "fit_margin", "min_panel_width", "fixing_spacing", "model_unit", "unit",
            "scale")


def rebuilt_with_cuts(fs, cuts: Mapping[int, set]):
    """A fin system built like ``fs`` (its structure and options) with its strips cut also at
    ``cuts`` ``{strip index: node lines of the strip}`` (``FinSystem._yield_cuts``: each a seam
    inside a slot, or brackets where the check refuses it)."""
    from ..builder.rebuild import Rebuilder

    new = type(fs).__new__(type(fs))
    for name in _OPTIONS:
        setattr(new, name, getattr(fs, name))
    new.parts, new._solids, new._unrolled = [], None, None
    new._yield_cuts = {int(si): frozenset(int(j) for j in js) for si, js in sorted(cuts.items())}
    Rebuilder(new).build_until_trimmed()
    new.__dict__.pop("_memo", None)
    return new


def strip_cuts(fs, cuts: Mapping[str, tuple]) -> dict[int, set]:
    """``{strip index: node lines of the strip}`` of ``cuts`` ``{part: node lines of the part}``."""
    out: dict[int, set] = {}
    for name, js in cuts.items():
        p = fs.part(name)
        lead = _lead_tabs(p)
        out.setdefault(fs._strip_of[name], set()).update(p.span[0] + int(j) - lead for j in js)
    return out


def _lead_tabs(p) -> int:
    """1 where the plate ``p`` starts with a tab bent from its end (a panel of no fin, before
    its first: :mod:`~torsal.fabrication.builder.tabs`), else 0: its panel ``j`` is panel
    ``span[0] + j - _lead_tabs(p)`` of its strip."""
    return int(len(p.edges) > 0 and int(p.edges[0]) < 0)


def pieces_of(fs_old, fs_new, name: str) -> list[str]:
    """The plates of ``fs_new`` that lie within the plate ``name`` of ``fs_old`` (the same
    strip, panels inside its panels)."""
    p = fs_old.part(name)
    si, (lo, hi) = fs_old._strip_of[name], p.span
    return sorted(q.name for q in fs_new.plates if fs_new._strip_of.get(q.name) == si
                  and lo <= q.span[0] and q.span[1] <= hi)


def _rigid(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, float]:
    """``(degrees, shift, worst residual)`` of the rotation and shift that take the points
    ``src`` (n, 2) onto ``dst`` best (least squares, no mirror)."""
    ps, qs = src.mean(axis=0), dst.mean(axis=0)
    u, _, vt = np.linalg.svd((src - ps).T @ (dst - qs))
    r = (u @ vt).T
    if np.linalg.det(r) < 0:
        vt[-1] *= -1
        r = (u @ vt).T
    t = qs - ps @ r.T
    res = float(np.abs(src @ r.T + t - dst).max())
    return float(np.degrees(np.arctan2(r[1, 0], r[0, 0]))), t, res


def _stand_ins(fs_old, fs_new, names: set) -> dict[str, tuple[str, int, int]]:
    """``{new part: (stand-in name, lo, hi)}``: the stand-in (a part or a piece of
    :func:`~.split.piece_name`) of the old layout ``names`` that each part of ``fs_new`` takes
    the place of, and its panels in the old part."""
    by_strip: dict[int, list] = {}
    for p in fs_old.plates:
        by_strip.setdefault(fs_old._strip_of[p.name], []).append(p)
    out = {}
    for p in fs_new.parts:
        if p.family in (CONNECTOR_FAMILY, FIXING_FAMILY) or p.name not in fs_new._strip_of:
            if p.name in names:
                out[p.name] = (p.name, 0, len(p.panels))
            continue
        lo2, hi2 = p.span
        for q in by_strip.get(fs_new._strip_of[p.name], []):
            lo, hi = q.span
            if lo <= lo2 and hi2 <= hi:
                # (in the old part's panels: a piece at its start or end keeps the tab there)
                a = 0 if lo2 == lo else lo2 - lo + _lead_tabs(q)
                b = len(q.panels) if hi2 == hi else hi2 - lo + _lead_tabs(q)
                stand = q.name if (a, b) == (0, len(q.panels)) else piece_name(q.name, a, b)
                if stand in names:
                    out[p.name] = (stand, a, b)
                break
    return out


def mapped_layout(fs_old, fs_new, split: SplitNesting, options: dict):
    """The sheets of ``split`` (stand-ins of ``fs_old``'s parts) with ``fs_new``'s parts in
    their places (the module docstring), as a :class:`~..layout.Layout`; and the parts that
    were put elsewhere (no stand-in, or not inside it). ``options`` those of
    :func:`~.search.nest_search`."""
    lay = split.layout
    sheets, polys, loose = _turned_onto_stand_ins(fs_old, fs_new, split)
    loose += _too_close(polys, lay, options)
    for n in loose:
        if n in polys:
            del sheets[polys[n][0]][n]
    new_u = fs_new.unrolled()
    ctx = _Search(list(new_u.values()), sheets=[s for s in sheets if s], progress=None, **options)
    _place_loose(ctx, loose)
    if len(ctx.emptier.sheets) > lay.n_sheets:
        # parts put elsewhere took a sheet more than the stand-ins (the cuts changed joints
        # elsewhere too: the rebuild went another way): the search's own emptying (no cut)
        # in its tries, and the final cut's search afresh on the new parts; the fewer sheets
        ctx.run()
        fresh = _Search(list(new_u.values()), progress=None, **options)
        fresh.run()
        if len(fresh.emptier.sheets) < len(ctx.emptier.sheets):
            ctx = fresh
    out = ctx.layout(method=lay.stats.method)
    out.stats = dataclasses.replace(lay.stats, sheet_fill=out.sheet_utilization,
                                    area_bound=out.stats.area_bound)
    return out, sorted(loose)


def _turned_onto_stand_ins(fs_old, fs_new, split: SplitNesting):
    """``(sheets, polys, loose)``: each part of ``fs_new`` turned onto its stand-in on the
    sheets of ``split`` (``sheets`` ``[{name: (rot, offset)}]``; ``polys`` ``{name: (sheet,
    placed outline, inside its stand-in)}``), and the parts that have no stand-in or whose
    corners lie more than :data:`_FIT` from it (``loose``)."""
    old_u, new_u = fs_old.unrolled(), fs_new.unrolled()
    lay = split.layout
    at = {p.name: p for p in lay.placements}
    stand = _stand_ins(fs_old, fs_new, set(at))
    sheets: list[dict] = [{} for _ in range(lay.n_sheets)]
    loose: list[str] = []
    polys: dict = {}
    for p in fs_new.parts:
        got = stand.get(p.name)
        if got is None:
            loose.append(p.name)
            continue
        name, lo, hi = got
        pl, u = at[name], new_u[p.name]
        old = old_u[split.pieces[name][0] if name in split.pieces else name]
        src = u.panels.reshape(-1, 2)
        dst = old.panels[lo:hi].reshape(-1, 2)
        if src.shape != dst.shape:
            loose.append(p.name)
            continue
        deg, t, res = _rigid(src, dst)
        if res > _FIT:
            loose.append(p.name)
            continue
        c, s = np.cos(np.radians(pl.rotation)), np.sin(np.radians(pl.rotation))
        rot = (pl.rotation + deg) % 360.0
        off = (float(c * t[0] - s * t[1] + pl.offset[0]), float(s * t[0] + c * t[1] + pl.offset[1]))
        placed = affinity.translate(affinity.rotate(u.outline, rot, origin=(0, 0)), *off)
        sheets[pl.sheet][p.name] = (rot, off)
        polys[p.name] = (pl.sheet, placed, pl.polygon.buffer(1e-6).contains(placed))
    return sheets, polys, loose


def _place_loose(ctx: _Search, loose: list) -> None:
    """The parts ``loose`` onto the sheets of ``ctx``, largest first: each into the fullest
    sheet with the room that takes it as it is (the search's drop and hole filler), else all
    that are left packed onto new sheets."""
    em = ctx.emptier
    rest = []
    for n in sorted(loose, key=lambda n: (-ctx.area[n], n)):
        host = next((s for s in sorted(em.sheets, key=lambda s: (-em.filled(s), sorted(s)))
                     if em.usable - em.filled(s) >= ctx.area[n]
                     and em.drop(s, n) is not None), None)
        if host is None:
            rest.append(n)
        else:
            host[n] = em.drop(host, n)
    if rest:
        em.sheets += _sheets({n: v for n, v in ctx.sky.pack(rest, "area").items()})


def _too_close(polys: dict, lay, options: dict) -> list[str]:
    """The parts of ``polys`` ``{name: (sheet, placed outline, inside its stand-in)}`` that
    stand out of their stand-in and come nearer than the nesting's spacing to another part or
    the sheet's edge (the parts inside their stand-ins keep it: the stand-ins did)."""
    import shapely
    from shapely.geometry import box

    from ..layout import spacing

    sep, edge = spacing(options.get("gap", 5.0), options.get("margin", 10.0), options.get("cutting"))
    w, h = lay.sheet
    inner = box(edge, edge, w - edge, h - edge)
    by_sheet: dict[int, list] = {}
    for n, (si, poly, _) in polys.items():
        by_sheet.setdefault(si, []).append((n, poly))
    out = []
    for n, (si, poly, inside) in sorted(polys.items()):
        if inside:
            continue
        others = [q for m, q in by_sheet[si] if m != n]
        if not inner.buffer(1e-6).contains(poly) or (
                others and float(shapely.distance(poly, others).min()) < sep - 1e-6):
            out.append(n)
    return out
