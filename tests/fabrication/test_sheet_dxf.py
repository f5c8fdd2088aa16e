"""The sheets' DXF written as text (torsal.fabrication.sheet_dxf): the same bytes as ezdxf's
document of the sheet saved by ezdxf; read with ezdxf and with a reader of this file (group
code / value pairs, no ezdxf) the same entities, layers and coordinates as the drawing; the
parts' area of write_sheets the one the files give."""
from __future__ import annotations

import math

import ezdxf
import pytest
from shapely.geometry import LineString, Polygon, box

from fab_structures import sphere_structure
from torsal.fabrication import FinSystem
from torsal.fabrication.cutting import Cutting
from torsal.fabrication.layout import (Layout, Placement, _classes_in_fixed_order, _fixed_metadata,
                                       drawing_parts, read_dxf_parts)
from torsal.fabrication.nesting.background import write_sheets
from torsal.fabrication.sheet_dxf import plain


def _ezdxf_bytes(layout, sheet, path):
    """The sheet as ezdxf writes its document (the writer before torsal.fabrication.sheet_dxf)."""
    doc = layout.sheet_document(sheet)
    _classes_in_fixed_order(doc)
    with _fixed_metadata():
        doc.saveas(path)
    return path.read_bytes()


def _plate(name, x, y, *, sheet=0, angle=0.0, fold_angle=0.4):
    """A 200 x 80 plate at (x, y) with a rectangular cut-out, two fastener holes, a fold
    line across it (upright: its text turned, or along x: its text at 0 degrees) and a label."""
    outline = Polygon(box(x, y, x + 200, y + 80).exterior.coords,
                      [box(x + 20, y + 20, x + 50, y + 40).exterior.coords[::-1]])
    fold = (LineString([(x + 100, y), (x + 100, y + 80)]) if angle else
            LineString([(x + 60, y + 60), (x + 190, y + 60)]))
    return Placement(name, sheet, 0.0, (x, y), outline, folds=[(fold, fold_angle)],
                     label=(x + 150.0, y + 30.0), label_height=12.5, label_angle=angle,
                     holes=[((x + 170.0, y + 15.0), 8.0), ((x + 10.0, y + 70.0), 2.5)],
                     reliefs=[(x + 20.0, y + 20.0)])


def _layout(cutting, unit="mm"):
    placements = [_plate("A-1", 10.0, 10.0, angle=90.0), _plate("B-2", 250.0, 10.0),
                  _plate("C-3", 10.0, 10.0, sheet=1, angle=33.3, fold_angle=-1.1)]
    return Layout((600.0, 300.0), placements, 2, unit=unit, cutting=cutting)


@pytest.mark.parametrize("cutting", [None, Cutting.for_process("router"),
                                     Cutting.for_process("waterjet")],
                         ids=["no-process", "router", "waterjet"])
def test_sheets_written_as_text_are_the_bytes_ezdxf_writes(tmp_path, cutting):
    lay = _layout(cutting)
    paths = lay.export_dxf(tmp_path / "t.dxf", svg=False)
    kinds = set()
    for s, path in enumerate(paths):
        assert plain(lay.sheet_drawing(s))          # written as text, not by ezdxf
        assert path.read_bytes() == _ezdxf_bytes(lay, s, tmp_path / f"ezdxf{s}.dxf")
        kinds |= {e.dxftype() for e in ezdxf.readfile(path).modelspace()}
    assert kinds == {"LWPOLYLINE", "CIRCLE", "LINE", "TEXT"}


def test_a_text_ezdxf_would_change_is_written_by_ezdxf(tmp_path):
    """A label ending in ``^`` (ezdxf strips it): not plain, so ezdxf writes that sheet; the
    file is the same as ezdxf's either way."""
    lay = _layout(Cutting.for_process("laser"), unit="in")
    lay.placements[0].name = "odd^"
    assert not plain(lay.sheet_drawing(0)) and plain(lay.sheet_drawing(1))
    paths = lay.export_dxf(tmp_path / "t.dxf", svg=False)
    for s, path in enumerate(paths):
        assert path.read_bytes() == _ezdxf_bytes(lay, s, tmp_path / f"ezdxf{s}.dxf")
    texts = [e.dxf.text for e in ezdxf.readfile(paths[0]).modelspace().query("TEXT")]
    assert "odd" in texts


def _tags(path):
    """The file's (group code, value) pairs, read here without ezdxf."""
    lines = path.read_text(encoding="utf-8").split("\n")
    assert lines[-1] == "" and len(lines) % 2 == 1
    return [(int(lines[i]), lines[i + 1]) for i in range(0, len(lines) - 1, 2)]


def _entities(tags):
    """The ENTITIES section as [(type, {code: [values]})], and the file's handles (code 5)."""
    i = tags.index((2, "ENTITIES"))
    end = tags.index((0, "ENDSEC"), i)
    out = []
    for code, value in tags[i + 1:end]:
        if code == 0:
            out.append((value, {}))
        else:
            out[-1][1].setdefault(code, []).append(value)
    return out


def _reader_items(entities):
    """The entities as a drawing's items (Layout.sheet_drawing), numbers parsed from text."""
    items = []
    for kind, t in entities:
        f = {c: [float(v) for v in vs] for c, vs in t.items() if c in (10, 20, 11, 21, 40, 50)}
        layer = t[8][0]
        if kind == "LWPOLYLINE":
            assert t[70] == ["1"] and int(t[90][0]) == len(f[10])     # closed, all points
            items.append(("poly", layer, list(zip(f[10], f[20]))))
        elif kind == "CIRCLE":
            items.append(("circle", layer, (f[10][0], f[20][0]), 2 * f[40][0]))
        elif kind == "LINE":
            items.append(("line", layer, (f[10][0], f[20][0]), (f[11][0], f[21][0])))
        else:
            assert kind == "TEXT" and (f[10], f[20]) == (f[11], f[21])    # anchored there
            anchor = {("1", "2"): "middle", ("1", "1"): "bottom"}[(t[72][0], t[73][0])]
            items.append(("text", layer, t[1][0], (f[10][0], f[20][0]), f[40][0],
                          f.get(50, [0.0])[0], anchor))
    return items


def _as_read(item):
    """A drawing's item with its numbers as floats (the file holds floats only)."""
    kind, layer, *geo = item
    if kind == "poly":
        return (kind, layer, [(float(x), float(y)) for x, y, *_ in geo[0]])
    if kind == "circle":
        return (kind, layer, tuple(map(float, geo[0][:2])), 2 * (0.5 * float(geo[1])))
    if kind == "line":
        return (kind, layer, *(tuple(map(float, p[:2])) for p in geo))
    text, at, height, rot, anchor = geo
    return (kind, layer, text, tuple(map(float, at[:2])), float(height), float(rot), anchor)


@pytest.fixture(scope="module")
def fins_layout():
    fs = FinSystem(sphere_structure(nu=6, nv=5, step=0.1), thickness=3.0, clearance=0.5,
                   max_panels=3)
    return fs.layout(sheet=(1000.0, 500.0), gap=4.0, cutting=Cutting.for_process("router"))


def test_a_reader_of_its_own_finds_the_drawing_and_the_area_of_write_sheets(fins_layout, tmp_path):
    """Every sheet read as group codes here: valid structure (sections closed, handles unique
    and below $HANDSEED), the drawing's entities, layers and every coordinate's digits; the
    parts' area of write_sheets is the one ezdxf reads back and the one of the parts read
    here (outlines less the cut-outs and the 128-gon holes)."""
    lay = fins_layout
    sheets = write_sheets(lay, tmp_path / "f.dxf")
    assert len(sheets.paths) == lay.n_sheets >= 2
    area_here = 0.0
    for s, path in enumerate(sheets.paths):
        tags = _tags(path)
        assert tags[-1] == (0, "EOF")
        assert [v for c, v in tags if c == 0 and v in ("SECTION", "ENDSEC")] == \
            ["SECTION", "ENDSEC"] * 6
        handles = [int(v, 16) for c, v in tags if c == 5]
        seed = int(tags[tags.index((9, "$HANDSEED")) + 1][1], 16)
        handles.remove(seed)                         # $HANDSEED's own value, code 5 too
        assert len(set(handles)) == len(handles) and max(handles) < seed
        items = _reader_items(_entities(tags))
        assert items == [_as_read(i) for i in lay.sheet_drawing(s)]
        nominal = [Polygon(i[2]) for i in items if i[:2] == ("poly", "NOMINAL")]
        outer = [p for p in nominal if not any(q.contains(p) for q in nominal if q is not p)]
        n = 128                                     # a circle read back: a regular 128-gon
        holes = sum(n / 2 * (i[3] / 2) ** 2 * math.sin(2 * math.pi / n)
                    for i in items if i[:2] == ("circle", "NOMINAL"))
        area_here += sum(p.area for p in outer) - holes
    by_ezdxf = sum(p.area for f in sheets.paths for p in read_dxf_parts(f)[0])
    assert sheets.area_read_back == by_ezdxf                    # the same float
    assert sheets.area_read_back == pytest.approx(area_here, rel=1e-9)
    assert sum(p.area for s in range(lay.n_sheets) for p in drawing_parts(lay.sheet_drawing(s))) \
        == by_ezdxf


def test_the_same_layout_writes_the_same_bytes(fins_layout, tmp_path):
    a = fins_layout.export_dxf(tmp_path / "a" / "f.dxf")
    b = fins_layout.export_dxf(tmp_path / "b" / "f.dxf")
    assert [p.read_bytes() for p in a] == [p.read_bytes() for p in b]
    assert [p.with_suffix(".svg").read_bytes() for p in a] == \
        [p.with_suffix(".svg").read_bytes() for p in b]
