"""Nesting of unrolled parts on sheets, DXF/SVG cutting files, bill of materials (issue 6).

* :func:`nest` places flat outlines (shapely) on rectangular sheets with a bottom-left fill:
  every part, turned so that its minimum rotated rectangle is axis-aligned, largest first, is tried on each open sheet in every allowed rotation at the
  candidate corners of the parts already there, then slid down and left as far as it stays
  free; the placement with the lowest top edge wins; a new sheet is opened when nothing fits.
  Overlap checks keep ``gap`` between parts and ``margin`` to the sheet edge.
* :meth:`Layout.export_dxf` writes one DXF (R2010, ezdxf) per sheet: layers ``CUT`` (the
  toolpath of the layout's :class:`~.cutting.Cutting` process: each outline offset by half
  the kerf, slots and holes compensated, reliefs at inner slot corners; the outline itself
  when there is no process), ``NOMINAL`` (the parts as designed, holes as circles; not cut),
  ``DRILL`` (holes narrower than the tool), ``FOLD`` (fold lines and their angle as TEXT,
  ``M``/``V`` for mountain/valley seen from the top), ``ENGRAVE`` (part id TEXT), ``SHEET``
  (sheet border, not to be cut); ``$INSUNITS`` set from the unit; plus an SVG preview of each
  sheet (:func:`sheet_svg`, the same drawing as SVG elements).
* Spacing: ``gap`` and ``margin`` are the sheet left between two cuts and between a cut and
  the sheet edge; the outlines keep ``gap + 2 kerf`` and ``margin + kerf`` (:func:`spacing`).
  :func:`~.nesting.nest_for_yield` nests for fewer sheets in a time budget.
* :func:`bill_of_materials` writes the parts list as CSV.

Units: sheet sizes, gaps and all coordinates in the fin system's ``unit`` (mm by default).

Example
-------
>>> lay = nest(list(fin_system.unrolled().values()), sheet=(2500, 1250), gap=5)  # doctest: +SKIP
>>> lay.n_sheets, round(lay.utilization, 3)                                    # doctest: +SKIP
>>> lay.export_dxf("out/fins.dxf")   # out/fins_sheet01.dxf, ..., out/fins_sheet01.svg  # doctest: +SKIP
"""
from __future__ import annotations

import csv
import io
import threading
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import LineString, Point, Polygon
from shapely.prepared import prep

from torsal.core.atomic import atomic_path

from torsal.core.units import INSUNITS, UNIT_TO_MM
from torsal.core.errors import TorsalError

from .builder.fasteners import part_fastening
from .cutting import Cutting, relief_centres
from .quantities import bill_of_quantities
from .unroll import FLAT_FOLD

__all__ = ["Placement", "Layout", "PartTooLargeError", "nest", "shelf_pack", "merge_layouts", "sheet_svg",
           "bill_of_materials", "read_dxf_parts", "spacing", "placement_of", "check_fits"]


class PartTooLargeError(TorsalError, ValueError):
    """A part does not fit the sheet in any allowed rotation."""


@dataclass
class Placement:
    """One part on one sheet: ``placed = translate(rotate(outline, rotation), dx, dy)``."""

    name: str
    sheet: int
    rotation: float
    offset: tuple[float, float]
    polygon: Polygon
    folds: list = field(default_factory=list)       # [(LineString, angle rad)]
    label: tuple[float, float] = (0.0, 0.0)
    label_height: float = 10.0
    label_angle: float = 0.0           # degrees
    holes: list = field(default_factory=list)      # [((x, y), diameter)] fastener holes
    reliefs: list = field(default_factory=list)    # [(x, y)] relief disc centres (cutting)


@dataclass
class Layout:
    """Result of :func:`nest`: placements on ``n_sheets`` sheets of size ``sheet``."""

    sheet: tuple[float, float]
    placements: list[Placement]
    n_sheets: int
    unit: str = "mm"
    gap: float = 5.0
    margin: float = 10.0
    #: the cutting process the DXF's CUT layer is compensated for (None: cut on the outline)
    cutting: Cutting | None = None
    #: how the nesting went (:class:`~.nesting.NestStats`), None for a layout made otherwise
    stats: object = None

    @property
    def sheet_of(self) -> dict[str, int]:
        """``{part name: sheet number (1-based)}``."""
        return {p.name: p.sheet + 1 for p in self.placements}

    @property
    def sheet_utilization(self) -> list[float]:
        """Part area / sheet area for every sheet."""
        a = np.zeros(self.n_sheets)
        for p in self.placements:
            a[p.sheet] += p.polygon.area
        return (a / (self.sheet[0] * self.sheet[1])).tolist()

    @property
    def utilization(self) -> float:
        """Total part area / total area of the sheets used."""
        if self.n_sheets == 0:
            return 0.0
        return float(sum(p.polygon.area for p in self.placements)
                     / (self.n_sheets * self.sheet[0] * self.sheet[1]))

    def on_sheet(self, sheet: int) -> list[Placement]:
        return [p for p in self.placements if p.sheet == sheet]

    @property
    def area_bound(self) -> float:
        """Parts' area / sheet area: the sheets the parts would need with no waste at all."""
        return float(sum(p.polygon.area for p in self.placements) / (self.sheet[0] * self.sheet[1]))

    # ------------------------------------------------------------------ DXF / SVG
    def sheet_drawing(self, sheet: int) -> list[tuple]:
        """What one sheet (0-based) shows, layer by layer, for the DXF and its SVG preview:
        ``("poly", layer, [(x, y), ...])`` closed outlines, ``("circle", layer, (x, y),
        diameter)``, ``("line", layer, p, q)``,
        ``("text", layer, text, (x, y), height, rotation deg, "middle" | "bottom")``
        (anchored at its centre, or the middle of its bottom edge)."""
        w, h = self.sheet
        items: list[tuple] = [("poly", "SHEET", [(0, 0), (w, 0), (w, h), (0, h)])]
        cut = self.cutting
        for p in self.on_sheet(sheet):
            rings = [p.polygon.exterior] + list(p.polygon.interiors)
            items += [("poly", "NOMINAL", list(r.coords)[:-1]) for r in rings]
            path = p.polygon if cut is None else cut.toolpath(p.polygon, p.reliefs)
            items += [("poly", "CUT", list(r.coords)[:-1])
                      for r in [path.exterior] + list(path.interiors)]
            for centre, dia in p.holes:
                items.append(("circle", "NOMINAL", tuple(centre), float(dia)))
                how, d = ("cut", float(dia)) if cut is None else cut.hole_path(float(dia))
                items.append(("circle", "CUT" if how == "cut" else "DRILL", tuple(centre), d))
            for line, ang in p.folds:
                segs = [line] if line.geom_type == "LineString" else list(getattr(line, "geoms", []))
                for seg in segs:
                    if seg.length <= 0:
                        continue
                    c = list(seg.coords)
                    items.append(("line", "FOLD", c[0], c[-1]))
                if segs and ang is not None:
                    longest = max(segs, key=lambda g: g.length)
                    mid = longest.interpolate(0.5, normalized=True)
                    deg = np.degrees(ang)
                    d = np.subtract(longest.coords[-1], longest.coords[0])
                    rot = float(np.degrees(np.arctan2(d[1], d[0])))
                    if (rot + 90.0) % 360.0 > 180.0:
                        rot = (rot + 180.0) % 360.0
                    items.append(("text", "FOLD", f"{'M' if deg >= 0 else 'V'} {abs(deg):.1f}°",
                                  (mid.x, mid.y), 0.5 * p.label_height, rot, "bottom"))
            up = (p.label_angle + 90.0) % 360.0 > 180.0      # keep text readable
            items.append(("text", "ENGRAVE", p.name, tuple(p.label), p.label_height,
                          (p.label_angle + 180.0 * up) % 360.0, "middle"))
        return items

    def sheet_document(self, sheet: int):
        """The ezdxf document of one sheet (0-based)."""
        import ezdxf
        from ezdxf.enums import TextEntityAlignment

        # no setup: the standard text style and line type the entities use are in every new
        # document; the extra styles, line types and dimension styles would only make the
        # file three times longer to create and write
        with _fixed_metadata():          # ezdxf stamps the creation time into the document
            doc = ezdxf.new("R2010", setup=False)
        doc.header["$INSUNITS"] = INSUNITS[self.unit]
        doc.header["$MEASUREMENT"] = 0 if self.unit in ("in", "ft") else 1
        doc.header["$EXTMIN"] = (0, 0, 0)
        doc.header["$EXTMAX"] = (self.sheet[0], self.sheet[1], 0)
        for name, color in _LAYERS.items():
            doc.layers.add(name, color=color)
        msp = doc.modelspace()
        align = {"middle": TextEntityAlignment.MIDDLE_CENTER,
                 "bottom": TextEntityAlignment.BOTTOM_CENTER}
        for kind, layer, *geo in self.sheet_drawing(sheet):
            if kind == "poly":
                msp.add_lwpolyline(geo[0], close=True, dxfattribs={"layer": layer})
            elif kind == "circle":
                msp.add_circle(geo[0], 0.5 * geo[1], dxfattribs={"layer": layer})
            elif kind == "line":
                msp.add_line(geo[0], geo[1], dxfattribs={"layer": layer})
            else:
                text, at, height, rot, anchor = geo
                msp.add_text(text, height=height, rotation=rot,
                             dxfattribs={"layer": layer}).set_placement(at, align=align[anchor])
        return doc

    def export_dxf(self, path, *, svg: bool = True) -> list[Path]:
        """Write one DXF per sheet: ``<stem>_sheetNN.dxf`` next to ``path`` (and
        ``<stem>_sheetNN.svg`` previews). Files are written atomically. Returns the DXF paths."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        out = []
        for s in range(self.n_sheets):
            doc = self.sheet_document(s)
            target = path.with_name(f"{path.stem}_sheet{s + 1:02d}.dxf")
            with atomic_path(target) as tmp, _fixed_metadata():
                doc.saveas(tmp)
            out.append(target)
            if svg:
                with atomic_path(target.with_suffix(".svg")) as tmp:
                    tmp.write_text(sheet_svg(self.sheet_drawing(s), self.sheet, self.unit),
                                   encoding="utf-8")
        return out


_EZDXF_OPTIONS = threading.Lock()


@contextmanager
def _fixed_metadata():
    """ezdxf stamps a file with the time and random GUIDs; a cutting sheet is a function of its
    layout, so the same layout writes the same bytes: ezdxf's fixed date (2000-01-01) and GUID
    while this writes (its option is global: one writer at a time)."""
    import ezdxf

    with _EZDXF_OPTIONS:
        old = ezdxf.options.write_fixed_meta_data_for_testing
        ezdxf.options.write_fixed_meta_data_for_testing = True
        try:
            yield
        finally:
            ezdxf.options.write_fixed_meta_data_for_testing = old


#: DXF layers of a sheet and their ACI colours: CUT the toolpath (red), NOMINAL the parts as
#: designed (cyan, not cut), DRILL holes narrower than the tool (magenta), FOLD (blue),
#: ENGRAVE (green), SHEET the border (grey, not cut)
_LAYERS = {"CUT": 1, "NOMINAL": 4, "DRILL": 6, "FOLD": 5, "ENGRAVE": 3, "SHEET": 8}
#: the same colours in the SVG preview, on white
_SVG_COLOURS = {"CUT": "#ff0000", "NOMINAL": "#00b0b0", "DRILL": "#ff00ff", "FOLD": "#0000ff",
                "ENGRAVE": "#008000", "SHEET": "#808080"}


def sheet_svg(drawing: list[tuple], sheet: tuple[float, float], unit: str) -> str:
    """SVG preview of a sheet's drawing (:meth:`Layout.sheet_drawing`): page ``sheet`` in
    ``unit`` (its size given in mm), y up as in the DXF, one group per layer, text as SVG text
    (written directly: ezdxf's drawing add-on took 0.8 s for 7a's 50 sheets, rendering every
    glyph as a path)."""
    from xml.sax.saxutils import escape

    w, h = map(float, sheet)
    f = UNIT_TO_MM[unit]
    lw = max(w, h) / 2000.0
    layers: dict[str, list[str]] = {k: [] for k in _SVG_COLOURS}
    for kind, layer, *geo in drawing:
        if kind == "poly":
            pts = " ".join(f"{x:.3f},{y:.3f}" for x, y in geo[0])
            layers[layer].append(f'<polygon points="{pts}"/>')
        elif kind == "circle":
            (x, y), d = geo
            layers[layer].append(f'<circle cx="{x:.3f}" cy="{y:.3f}" r="{0.5 * d:.3f}"/>')
        elif kind == "line":
            (x1, y1), (x2, y2) = geo[0][:2], geo[1][:2]
            layers[layer].append(f'<line x1="{x1:.3f}" y1="{y1:.3f}" x2="{x2:.3f}" y2="{y2:.3f}"/>')
        else:
            text, (x, y), height, rot, anchor = geo
            base = "central" if anchor == "middle" else "alphabetic"
            # text is drawn in a frame flipped back (y down) and turned by -rot
            layers[layer].append(
                f'<text transform="translate({x:.3f} {y:.3f}) scale(1 -1) rotate({-rot:.3f})" '
                f'font-size="{height:.3f}" text-anchor="middle" dominant-baseline="{base}" '
                f'fill="{_SVG_COLOURS[layer]}" stroke="none">{escape(text)}</text>')
    body = []
    for layer, elems in layers.items():
        body.append(f'<g id="{layer}" fill="none" stroke="{_SVG_COLOURS[layer]}" '
                    f'stroke-width="{lw:.4g}">')
        body += elems
        body.append("</g>")
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{w * f:.6g}mm" height="{h * f:.6g}mm" '
            f'viewBox="0 0 {w:.6g} {h:.6g}">\n<rect width="100%" height="100%" fill="white"/>\n'
            f'<g transform="matrix(1 0 0 -1 0 {h:.6g})">\n' + "\n".join(body) + "\n</g>\n</svg>\n")


# ---------------------------------------------------------------------------- nesting
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


class _Sheet:
    def __init__(self, w, h, margin, gap):
        self.w, self.h, self.margin, self.gap = w, h, margin, gap
        self.polys: list[Polygon] = []
        self.grown: list = []
        self.bounds = np.zeros((0, 4))

    def free_at(self, poly: Polygon, bounds, x: float, y: float) -> bool:
        """Whether ``poly`` (with ``bounds``) translated by ``(x, y)`` lies inside the margins
        and ``gap`` clear of every part on the sheet. The bounding box is tested first (the
        bounds of a translated polygon are its bounds translated, exactly: rounding is
        monotonic); the polygon is moved only when it meets another part's."""
        minx, miny, maxx, maxy = bounds[0] + x, bounds[1] + y, bounds[2] + x, bounds[3] + y
        m = self.margin
        if minx < m - 1e-9 or miny < m - 1e-9 or maxx > self.w - m + 1e-9 or maxy > self.h - m + 1e-9:
            return False
        if not len(self.bounds):
            return True
        g = self.gap
        b = self.bounds
        hit = np.flatnonzero((b[:, 0] - g < maxx) & (b[:, 2] + g > minx) &
                             (b[:, 1] - g < maxy) & (b[:, 3] + g > miny))
        if not hit.size:
            return True
        # the coordinates plus (x, y), as affinity.translate gives them (up to the sign of a
        # zero) at a quarter of its cost: this test runs ~10^6 times for 1,000 panels
        off = np.array([x, y], dtype=float)
        p = shapely.transform(poly, lambda c: c + off)
        for i in hit:
            if self.grown[i].intersects(p):
                return False
        return True

    def add(self, poly: Polygon):
        self.polys.append(poly)
        grown = poly.buffer(self.gap * (1 - 1e-6), join_style="mitre", mitre_limit=2.0) if self.gap > 0 else poly
        self.grown.append(prep(grown))
        self.bounds = np.vstack([self.bounds, poly.bounds])


def _slide(sheet: _Sheet, poly: Polygon, x: float, y: float, dx: int, dy: int, reach: float):
    """Largest shift along (dx, dy) up to ``reach`` that keeps the part free (bisection)."""
    bounds = poly.bounds

    def ok(s):
        return sheet.free_at(poly, bounds, x + dx * s, y + dy * s)

    lo, hi = 0.0, reach
    if hi <= 0:
        return 0.0
    if ok(hi):
        return hi
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        if ok(mid):
            lo = mid
        else:
            hi = mid
        if hi - lo < 0.05:
            break
    return lo


def _place_on(sheet: _Sheet, shapes) -> tuple | None:
    """Best (score, rotation index, x, y) of a part on a sheet, or None."""
    best = None
    m, g = sheet.margin, sheet.gap
    xs = np.unique(np.r_[m, sheet.bounds[:, 2] + g]) if len(sheet.bounds) else np.array([m])
    ys = np.unique(np.r_[m, sheet.bounds[:, 3] + g]) if len(sheet.bounds) else np.array([m])
    for r, (poly, (w, h)) in enumerate(shapes):
        cand = [(y, x) for y in ys for x in xs if x + w <= sheet.w - m + 1e-9 and y + h <= sheet.h - m + 1e-9]
        cand.sort()
        for y, x in cand:
            if best is not None and y + h >= best[0][0]:
                break                       # cannot beat the best top edge any more
            if not sheet.free_at(poly, poly.bounds, x, y):
                continue
            # slide down and left while free (bottom-left compaction)
            for _ in range(3):
                sy = _slide(sheet, poly, x, y, 0, -1, y - m)
                y -= sy
                sx = _slide(sheet, poly, x, y, -1, 0, x - m)
                x -= sx
                if sy < 0.05 and sx < 0.05:
                    break
            score = (y + h, x)
            if best is None or score < best[0]:
                best = (score, r, x, y)
            break
    return best



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


def placement_of(it: _Item, sheet: int, rot: float, dx: float, dy: float, placed=None) -> Placement:
    """The placement of a part on ``sheet``: its outline turned by ``rot`` degrees about the
    origin, then moved by ``(dx, dy)``; fold lines, label, holes and reliefs with it."""

    def tf(g):
        return affinity.translate(affinity.rotate(g, rot, origin=(0, 0)), dx, dy)

    def tf_points(pts):
        pts = np.asarray(pts, float).reshape(-1, 2)
        c, s = np.cos(np.radians(rot)), np.sin(np.radians(rot))
        return pts @ np.array([[c, s], [-s, c]]) + (dx, dy)

    lab = tf_points([it.label])[0]
    holes = [(tuple(tf_points([c])[0]), d) for c, d in it.holes]
    return Placement(it.name, sheet, rot, (dx, dy), tf(it.outline) if placed is None else placed,
                     [(tf(f), a) for f, a in it.folds], (float(lab[0]), float(lab[1])),
                     it.label_height, (it.label_angle + rot) % 360.0,
                     holes=holes, reliefs=[tuple(p) for p in tf_points(it.reliefs)])


def nest(outlines, *, sheet: tuple[float, float] = (2500.0, 1250.0), gap: float = 5.0,
         margin: float = 10.0, rotations: Sequence[float] = (0, 90, 180, 270),
         unit: str = "mm", open_sheets: int = 3, cutting: Cutting | None = None) -> Layout:
    """Nest flat parts on rectangular sheets (bottom-left fill over rotated candidates): the
    fast nester; :func:`~.nesting.nest_for_yield` uses fewer sheets in a time budget.

    Parameters
    ----------
    outlines : sequence of Unrolled, of (name, Polygon), of Polygon, or {name: Polygon}
        Flat parts in ``unit``; :class:`~.unroll.Unrolled` parts also carry their fold
        lines and label position onto the sheet.
    sheet : (width, height)
        Sheet size in ``unit`` (default 2500 x 1250 mm).
    gap : float
        Web of sheet left between the cuts of two parts, ``unit`` (the outlines are ``gap + 2
        kerf`` apart, see :func:`spacing`).
    margin : float
        Web left between the cuts and the sheet edge, ``unit``.
    rotations : sequence of float
        Allowed rotations in degrees, applied after turning each part so that its minimum
        rotated rectangle is axis-aligned (long side along x).
    open_sheets : int
        How many of the most recent sheets are still tried for a part (older sheets are
        closed); bounds the time for large jobs.
    cutting : Cutting, optional
        The cutting process (kerf, reliefs) the sheets are drawn for; None: cut on the outline.

    Raises
    ------
    PartTooLargeError
        If a part fits the sheet in no allowed rotation.
    """
    w, h = map(float, sheet)
    if w <= 0 or h <= 0:
        raise ValueError(f"sheet must have positive size, got {sheet}")
    if gap < 0 or margin < 0:
        raise ValueError("gap and margin must be >= 0")
    if not len(rotations):
        raise ValueError("at least one rotation is needed")
    items = _as_items(outlines, cutting)
    prepared = [_turned_shapes(it, rotations) for it in items]
    sep, edge = spacing(gap, margin, cutting)
    check_fits(items, prepared, w, h, edge, rotations, unit)
    order = sorted(range(len(items)), key=lambda i: -items[i].outline.area)
    sheets: list[_Sheet] = []
    placements = []
    for i in order:
        it, shapes = items[i], prepared[i]
        where = None
        for si in range(max(0, len(sheets) - open_sheets), len(sheets)):
            best = _place_on(sheets[si], shapes)
            if best is not None:
                where = (si, best)
                break
        if where is None:
            sheets.append(_Sheet(w, h, edge, sep))
            best = _place_on(sheets[-1], shapes)
            if best is None:  # pragma: no cover - guarded by the size check above
                raise PartTooLargeError(f"part {it.name} does not fit an empty sheet")
            where = (len(sheets) - 1, best)
        si, (_, r, x, y) = where
        rot = float(rotations[r]) + it.base
        placed = affinity.translate(shapes[r][0], x, y)
        sheets[si].add(placed)
        # transform of the original outline: rotate about origin, then shift
        p0 = affinity.rotate(it.outline, rot, origin=(0, 0))
        placements.append(placement_of(it, si, rot, x - p0.bounds[0], y - p0.bounds[1], placed))
    placements.sort(key=lambda p: (p.sheet, p.name))
    return Layout((w, h), placements, len(sheets), unit=unit, gap=gap, margin=margin, cutting=cutting)


def spacing(gap: float, margin: float, cutting: Cutting | None) -> tuple[float, float]:
    """Distance between two nominal outlines and from an outline to the sheet edge (``unit``)
    that leave ``gap`` and ``margin`` of sheet between the cuts: each cut takes ``kerf``
    beyond its outline.

    >>> spacing(5.0, 10.0, Cutting.for_process("waterjet"))
    (7.0, 11.0)
    """
    kerf = 0.0 if cutting is None else cutting.kerf
    return gap + 2.0 * kerf, margin + kerf


def shelf_pack(outlines, *, sheet: tuple[float, float] = (2500.0, 1250.0), gap: float = 5.0,
               margin: float = 10.0, unit: str = "mm", first_sheet: int = 0,
               cutting: Cutting | None = None) -> Layout:
    """Pack many small flat parts (connectors) in rows: each turned so that its minimum
    rotated rectangle is axis-aligned (long side along x), tallest first, left to right
    with ``gap`` between them, a new row above the tallest of the last one, a new sheet when
    the rows are full. Linear in the number of parts, where :func:`nest` is about quadratic;
    sheets are numbered from ``first_sheet``.

    Raises :class:`PartTooLargeError` if a part does not fit an empty sheet.
    """
    w, h = map(float, sheet)
    items = _as_items(outlines, cutting)
    layout_gap, layout_margin = gap, margin
    gap, margin = spacing(gap, margin, cutting)
    shapes = []
    for it in items:
        p = affinity.rotate(it.outline, it.base, origin=(0, 0))
        minx, miny, maxx, maxy = p.bounds
        if maxx - minx > w - 2 * margin + 1e-9 or maxy - miny > h - 2 * margin + 1e-9:
            raise PartTooLargeError(f"part {it.name} ({maxx - minx:.0f} x {maxy - miny:.0f} {unit}) "
                                    f"does not fit a {w:.0f} x {h:.0f} {unit} sheet")
        shapes.append((it, p, (minx, miny, maxx, maxy)))
    shapes.sort(key=lambda x: -(x[2][3] - x[2][1]))
    m0 = margin + 1e-6 * max(w, h)          # strictly inside the margin
    placements, sheet_no, x, y, row_h = [], first_sheet, m0, m0, 0.0
    for it, p, (minx, miny, maxx, maxy) in shapes:
        pw, ph = maxx - minx, maxy - miny
        if x + pw > w - margin + 1e-9:                  # new row
            x, y, row_h = m0, y + row_h + gap, 0.0
        if y + ph > h - margin + 1e-9:                  # new sheet
            sheet_no, x, y, row_h = sheet_no + 1, m0, m0, 0.0
        placements.append(placement_of(it, sheet_no, it.base, x - minx, y - miny))
        x += pw + gap
        row_h = max(row_h, ph)
    n = (sheet_no - first_sheet + 1) if placements else 0
    return Layout((w, h), placements, n, unit=unit, gap=layout_gap, margin=layout_margin,
                  cutting=cutting)


def merge_layouts(first: Layout, second: Layout) -> Layout:
    """One layout of the sheets of ``first`` followed by those of ``second`` (whose sheet
    numbers start at ``first.n_sheets``)."""
    places = sorted(first.placements + second.placements, key=lambda p: (p.sheet, p.name))
    return Layout(first.sheet, places, first.n_sheets + second.n_sheets, unit=first.unit,
                  gap=first.gap, margin=first.margin, cutting=first.cutting, stats=first.stats)


# ---------------------------------------------------------------------------- reading back
def read_dxf_parts(path, *, layer: str | None = None) -> tuple[list[Polygon], list[str], "object"]:
    """Re-read a sheet DXF: polygons of the closed polylines of ``layer`` (default: the
    nominal outlines, ``NOMINAL``, or ``CUT`` in files without that layer), with the holes
    (closed polylines and circles of the layer inside them) as interiors, the ENGRAVE texts,
    and the ezdxf auditor. For verification of written files."""
    import ezdxf

    doc = ezdxf.readfile(path)
    auditor = doc.audit()
    msp = doc.modelspace()
    if layer is None:
        layer = "NOMINAL" if len(msp.query("LWPOLYLINE[layer=='NOMINAL']")) else "CUT"
    rings = []
    for e in msp.query(f"LWPOLYLINE[layer=='{layer}']"):
        if not e.closed:
            raise ValueError(f"{path}: open {layer} polyline {e.dxf.handle}")
        rings.append(Polygon([p[:2] for p in e.get_points("xy")]))
    rings += [Point(e.dxf.center.x, e.dxf.center.y).buffer(e.dxf.radius, quad_segs=32)
              for e in msp.query(f"CIRCLE[layer=='{layer}']")]
    rings.sort(key=lambda p: -p.area)
    outers: list[list] = []
    for r in rings:
        for o in outers:
            if o[0].contains(r):
                o.append(r)
                break
        else:
            outers.append([r])
    polys = [Polygon(o[0].exterior.coords, [h.exterior.coords for h in o[1:]]) for o in outers]
    texts = [e.dxf.text for e in msp.query("TEXT[layer=='ENGRAVE']")]
    return polys, texts, auditor


# ---------------------------------------------------------------------------- BOM
BOM_COLUMNS = ["part_id", "family", "strip", "panels", "area_m2", "perimeter_m", "cut_length_m",
               "fold_count", "mass_kg", "sheet", "kind", "holes", "hole_diameter_mm", "fasteners",
               "fastener", "gross_kg", "pierces", "holes_drilled", "bend_length_m"]


def bill_of_materials(fin_system, path=None, *, density: float = 2700.0, layout: Layout | None = None) -> list[dict]:
    """Parts list as CSV (columns :data:`BOM_COLUMNS`), one row per part.

    The quantities are the part's line of the bill of quantities
    (:func:`~torsal.fabrication.quantities.bill_of_quantities`; the columns of all parts add
    up to its totals): ``area_m2`` is the net flat area (slots and holes removed),
    ``mass_kg = area * thickness * density`` (net kg) with ``density`` in kg/m^3 (default
    aluminium, 2700), ``gross_kg`` the part's share of the sheets of ``layout`` (empty
    without one), ``cut_length_m`` the contours cut (outline with slots, inner cut-outs and
    the holes ``layout``'s cutting process cuts; all holes without a layout), ``pierces``
    the closed contours cut, ``holes_drilled`` the holes no wider than the tool,
    ``fold_count`` the bends and ``bend_length_m`` their length. ``perimeter_m`` is the outer
    boundary of the flat part without its slots, ``sheet`` the 1-based sheet number from
    ``layout`` (empty if none), ``kind`` ``plate`` for a fin plate, else the joint kind of a
    connector (``butt-bracket``, ``mitre-splice``) or ``fixing``; a connector's ``family`` is
    -2 and its ``strip`` the node it sits at, a fixing's -3 and the structure edge it fixes.
    ``holes``, ``hole_diameter_mm``, ``fasteners`` and ``fastener`` count the holes and the
    bolts and anchors through a connector's or fixing's own holes
    (:func:`~torsal.fabrication.builder.fasteners.part_fastening`).
    Returns the rows; writes ``path`` (atomically) if given.
    """
    quantities = bill_of_quantities(fin_system, density=density, layout=layout)
    to_m = UNIT_TO_MM[fin_system.unit] / 1000.0
    sheets = layout.sheet_of if layout is not None else {}
    fastening = part_fastening(fin_system)
    rows = []
    for p, q in zip(fin_system.parts, quantities.parts):
        u = fin_system.unrolled()[p.name]
        body = shapely.union_all([Polygon(panel) for panel in u.panels])
        rows.append({
            "part_id": p.name, "family": p.family, "strip": p.id.strip, "panels": len(p.panels),
            "area_m2": round(q.net_m2, 8), "perimeter_m": round(body.exterior.length * to_m, 6),
            "cut_length_m": round(q.cut_m, 6), "fold_count": q.bends,
            "mass_kg": round(q.net_kg, 6), "sheet": sheets.get(p.name, ""), **fastening[p.name],
            "gross_kg": "" if q.gross_kg is None else round(q.gross_kg, 6),
            "pierces": q.pierces, "holes_drilled": q.holes_drilled,
            "bend_length_m": round(q.bend_m, 6),
        })
    if path is not None:
        buf = io.StringIO()
        wr = csv.DictWriter(buf, fieldnames=BOM_COLUMNS)
        wr.writeheader()
        wr.writerows(rows)
        with atomic_path(path) as tmp:
            tmp.write_text(buf.getvalue(), encoding="utf-8")
    return rows
