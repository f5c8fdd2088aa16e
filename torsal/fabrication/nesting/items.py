"""The parts as every nester takes them: outlines prepared once (the cutting process's kerf,
fold lines, labels, holes, reliefs, the turn to the minimum rotated rectangle), and the check
that each fits the sheet in some rotation.

Units: those of the outlines.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import LineString, Point, Polygon

from ..cutting import Cutting, relief_centres
from ..layout import PartTooLargeError
from ..unroll import FLAT_FOLD

__all__ = ["check_fits"]


@dataclass
class _Item:
    name: str
    outline: Polygon
    folds: list
    label: tuple[float, float]
    label_height: float
    label_angle: float = 0.0
    base: float = 0.0            # degrees: rotation to the minimum rotated rectangle
    n_panels: int = 0            # panels of an unrolled part (0: unknown)
    holes: list = field(default_factory=list)      # [((x, y), diameter)]
    reliefs: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))


def _as_items(outlines, cutting: Cutting | None = None) -> list[_Item]:
    items = []
    if isinstance(outlines, Mapping):
        outlines = [(k, v) for k, v in outlines.items()]
    for i, o in enumerate(outlines):
        if isinstance(o, _Item):          # prepared already (a nester handing parts on)
            items.append(o)
            continue
        if isinstance(o, tuple):
            name, poly = o
            items.append(_Item(str(name), Polygon(poly) if not isinstance(poly, Polygon) else poly, [],
                               _label(poly), 0.0))
            continue
        if isinstance(o, Polygon):
            items.append(_Item(f"part{i}", o, [], _label(o), 0.0))
            continue
        # Unrolled
        poly = o.outline
        folds = []
        for line, ang in zip(o.fold_lines, o.fold_angles):
            if abs(ang) <= FLAT_FOLD:
                continue
            seg = LineString(line).intersection(poly)
            folds.append((seg, float(ang)))
        items.append(_Item(o.name, poly, folds, tuple(o.label_position), float(o.label_height),
                           float(np.degrees(o.label_angle)), n_panels=len(o.panels),
                           holes=[(tuple(c), float(d)) for c, d in getattr(o, "holes", [])],
                           reliefs=(relief_centres(o, cutting) if cutting is not None
                                    else np.zeros((0, 2)))))
    for it in items:
        if not it.outline.is_valid or it.outline.area <= 0:
            raise ValueError(f"part {it.name}: invalid or empty outline")
        # base orientation: the long side of the minimum rotated rectangle along x
        rect = np.asarray(it.outline.minimum_rotated_rectangle.exterior.coords)[:3]
        e1, e2 = rect[1] - rect[0], rect[2] - rect[1]
        d = e1 if np.linalg.norm(e1) >= np.linalg.norm(e2) else e2
        it.base = -float(np.degrees(np.arctan2(d[1], d[0])))
        if it.label_height <= 0:
            # text height: fits the part around the label point, 1..20 units
            r = it.outline.exterior.distance(Point(it.label))
            it.label_height = float(np.clip(0.8 * r, 1.0, 20.0)) if r > 0 else 1.0
    names = [it.name for it in items]
    if len(set(names)) != len(names):
        raise ValueError("part names must be unique")
    return items


def _label(poly) -> tuple[float, float]:
    from shapely.ops import polylabel

    p = polylabel(poly if isinstance(poly, Polygon) else Polygon(poly), tolerance=1e-3)
    return (p.x, p.y)


def _turned_shapes(it: _Item, rotations) -> list:
    """``[(outline turned by base + rotation and moved to the origin, (width, height))]``."""
    shapes = []
    for rot in rotations:
        p = affinity.rotate(it.outline, it.base + rot, origin=(0, 0))
        minx, miny, maxx, maxy = p.bounds
        p = affinity.translate(p, -minx, -miny)
        shapes.append((p, (maxx - minx, maxy - miny)))
    return shapes


def check_fits(items, prepared, w: float, h: float, margin: float, rotations, unit: str) -> None:
    """PartTooLargeError for the first part that fits a ``w x h`` sheet with ``margin`` in none
    of its turned shapes (:func:`_turned_shapes`), saying what to do."""
    for it, shapes in zip(items, prepared):
        if any(sw <= w - 2 * margin + 1e-9 and sh <= h - 2 * margin + 1e-9 for _, (sw, sh) in shapes):
            continue
        sw, sh = min((s[1] for s in shapes), key=lambda t: max(t[0] / w, t[1] / h))
        if it.n_panels == 1:
            raise PartTooLargeError(
                f"part {it.name} ({sw:.0f} x {sh:.0f} {unit}) is ONE fin panel and does not fit a "
                f"{w:.0f} x {h:.0f} {unit} sheet with margin {margin:g} in any rotation "
                f"{list(rotations)}; a single panel cannot be split into shorter parts: use a "
                f"smaller fin spacing (a finer remesh of the structure) or a larger sheet")
        raise PartTooLargeError(
            f"part {it.name} ({sw:.0f} x {sh:.0f} {unit}) does not fit a {w:.0f} x {h:.0f} {unit} "
            f"sheet with margin {margin:g} in any rotation {list(rotations)}; split it into "
            f"shorter parts (FinSystem(max_part_length=..., max_panels=...)) or use a larger sheet")
