"""Sheets out: the parts placed on sheets (:class:`Layout`), DXF/SVG cutting files, the bill of
materials (issue 6). The nesters that make a layout are in :mod:`.nesting` (the bottom-left
fill :func:`~.nesting.bottom_left.nest`, the rows, the skyline, the final cut's search).

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
  :func:`~.nesting.nest_search` nests for fewer sheets (the final cut).
* :func:`bill_of_materials` writes the parts list as CSV.

Units: sheet sizes, gaps and all coordinates in the fin system's ``unit`` (mm by default).

Example
-------
>>> lay = fin_system.layout(sheet=(2500, 1250), gap=5)                        # doctest: +SKIP
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

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import LineString, Point, Polygon
from shapely.prepared import prep

from torsal.core.atomic import atomic_path

from torsal.core.units import INSUNITS, UNIT_TO_MM
from torsal.core.errors import TorsalError

from .builder.fasteners import part_fastening
from .cutting import Cutting
from .quantities import bill_of_quantities

__all__ = ["Placement", "Layout", "PartTooLargeError", "sheet_svg", "bill_of_materials",
           "read_dxf_parts", "drawing_parts", "spacing", "placement_of"]


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

    def sheet_document(self, sheet: int, drawing: list[tuple] | None = None):
        """The ezdxf document of one sheet (0-based), of its ``drawing``
        (:meth:`sheet_drawing`, made here when not given). :meth:`export_dxf` writes the
        same bytes without it (:mod:`.sheet_dxf`) but where that writer would differ."""
        from ezdxf.enums import TextEntityAlignment

        doc = self._empty_document()
        msp = doc.modelspace()
        align = {"middle": TextEntityAlignment.MIDDLE_CENTER,
                 "bottom": TextEntityAlignment.BOTTOM_CENTER}
        for kind, layer, *geo in self.sheet_drawing(sheet) if drawing is None else drawing:
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

    def _empty_document(self):
        """A new ezdxf document for one of the sheets: header and layers, no entities."""
        import ezdxf

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
        return doc

    def export_dxf(self, path, *, svg: bool = True) -> list[Path]:
        """Write one DXF per sheet: ``<stem>_sheetNN.dxf`` next to ``path`` (and
        ``<stem>_sheetNN.svg`` previews). Files are written atomically. Returns the DXF paths."""
        return [target for target, _ in self.write_sheet_files(path, svg=svg)]

    def write_sheet_files(self, path, *, svg: bool = True) -> list[tuple[Path, list[tuple]]]:
        """:meth:`export_dxf`, returning each DXF path with the sheet's drawing
        (:meth:`sheet_drawing`) it was written from.

        The DXF is the bytes ezdxf writes for :meth:`sheet_document`, written as text
        (:func:`~.sheet_dxf.sheet_text`: 7a's 40 sheets in 0.15 CPU s instead of 2.2) in the
        frame ezdxf writes for an empty sheet; a drawing that writer does not cover
        (:func:`~.sheet_dxf.plain`) is written by ezdxf."""
        from .sheet_dxf import DxfSkeleton, plain, sheet_text

        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        out, skeleton = [], None
        for s in range(self.n_sheets):
            drawing = self.sheet_drawing(s)
            target = path.with_name(f"{path.stem}_sheet{s + 1:02d}.dxf")
            if plain(drawing):
                if skeleton is None:
                    doc = self._empty_document()
                    _classes_in_fixed_order(doc)
                    with _fixed_metadata():
                        skeleton = DxfSkeleton(doc)
                with atomic_path(target) as tmp:
                    tmp.write_bytes(sheet_text(skeleton, drawing).encode("utf-8"))
            else:
                doc = self.sheet_document(s, drawing)
                _classes_in_fixed_order(doc)
                with atomic_path(target) as tmp, _fixed_metadata():
                    doc.saveas(tmp)
            out.append((target, drawing))
            if svg:
                with atomic_path(target.with_suffix(".svg")) as tmp:
                    tmp.write_text(sheet_svg(drawing, self.sheet, self.unit), encoding="utf-8")
        return out


def _classes_in_fixed_order(doc) -> None:
    """Register the CLASS entries of ``doc`` now, sorted: ezdxf adds those of the entity types
    in use from a set of strings when it saves, in an order that changes with Python's string
    hashing from one process to the next (PYTHONHASHSEED), so the same sheet came out with
    LAYOUT and ACDBPLACEHOLDER swapped between two runs. Entries already registered keep their
    place when ezdxf adds the required ones again."""
    from collections import OrderedDict

    doc.classes.add_required_classes(doc.dxfversion)
    doc.classes.classes = OrderedDict(sorted(doc.classes.classes.items()))


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
def placement_of(it, sheet: int, rot: float, dx: float, dy: float, placed=None) -> Placement:
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


def spacing(gap: float, margin: float, cutting: Cutting | None) -> tuple[float, float]:
    """Distance between two nominal outlines and from an outline to the sheet edge (``unit``)
    that leave ``gap`` and ``margin`` of sheet between the cuts: each cut takes ``kerf``
    beyond its outline.

    >>> spacing(5.0, 10.0, Cutting.for_process("waterjet"))
    (7.0, 11.0)
    """
    kerf = 0.0 if cutting is None else cutting.kerf
    return gap + 2.0 * kerf, margin + kerf


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
    outlines = []
    for e in msp.query(f"LWPOLYLINE[layer=='{layer}']"):
        if not e.closed:
            raise ValueError(f"{path}: open {layer} polyline {e.dxf.handle}")
        outlines.append([p[:2] for p in e.get_points("xy")])
    circles = [((e.dxf.center.x, e.dxf.center.y), e.dxf.radius)
               for e in msp.query(f"CIRCLE[layer=='{layer}']")]
    texts = [e.dxf.text for e in msp.query("TEXT[layer=='ENGRAVE']")]
    return _parts_of_rings(outlines, circles), texts, auditor


def drawing_parts(drawing: list[tuple], *, layer: str | None = None) -> list[Polygon]:
    """The parts of a sheet's ``drawing`` (:meth:`Layout.sheet_drawing`) as
    :func:`read_dxf_parts` reads them from the DXF written from it, without writing or
    reading: the same polygons, built the same way from the same numbers (the DXF keeps a
    coordinate's every digit), so their areas are the same floats."""
    if layer is None:
        layer = "NOMINAL" if any(k == "poly" and g[0] == "NOMINAL" for k, *g in drawing) else "CUT"
    outlines = [geo[0] for kind, lay, *geo in drawing if kind == "poly" and lay == layer]
    circles = [(tuple(geo[0])[:2], 0.5 * geo[1])
               for kind, lay, *geo in drawing if kind == "circle" and lay == layer]
    return _parts_of_rings(outlines, circles)


def _parts_of_rings(outlines: list, circles: list) -> list[Polygon]:
    """Polygons of closed ``outlines`` (lists of (x, y)) and ``circles`` (((x, y), radius),
    made 128-gons), each ring inside a larger one a hole of it (by area, largest first)."""
    rings = [Polygon(o) for o in outlines]
    rings += [Point(c).buffer(r, quad_segs=32) for c, r in circles]
    rings.sort(key=lambda p: -p.area)
    outers: list[tuple[Polygon, tuple, list]] = []        # (ring, its bounds, its holes)
    for r in rings:
        x0, y0, x1, y1 = r.bounds
        for outer, (ox0, oy0, ox1, oy1), holes in outers:
            # a ring outside the outer's box is not in it: only the others need the test
            if ox0 <= x0 and oy0 <= y0 and x1 <= ox1 and y1 <= oy1 and outer.contains(r):
                holes.append(r)
                break
        else:
            outers.append((r, r.bounds, []))
    return [Polygon(o.exterior.coords, [h.exterior.coords for h in holes])
            for o, _, holes in outers]


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
