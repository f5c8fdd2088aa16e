"""The cutting process on a constructed slot: the DXF re-read with ezdxf, the slot width on the
toolpath and the reliefs measured with shapely; holes as circles; a router bit wider than the
slots is refused."""
from __future__ import annotations

import math
from dataclasses import dataclass

import ezdxf
import numpy as np
import pytest
from shapely.geometry import LineString, Point, Polygon

from torsal.fabrication import Slot, SlotSide
from torsal.fabrication.cutting import Cutting, CuttingError, Relief
from torsal.fabrication.layout import read_dxf_parts
from torsal.fabrication.nesting import nest
from torsal.fabrication.unroll import unroll

W, DEPTH, L, H = 3.5, 60.0, 300.0, 150.0      # slot width and depth, plate length and height (mm)


@dataclass
class _Hole:
    center: np.ndarray
    diameter: float


@dataclass
class _Plate:
    """A flat plate 300 x 150 mm in the xz-plane with one slot open on its b edge, centred at
    x = 150, and fastener holes: what unroll() reads of a Part."""
    name: str = "P"
    holes: tuple = ()

    @property
    def panels(self):
        # two panels meeting at x = 150: the slot sits on the fold line between them
        return np.array([[[0, 0, 0], [150, 0, 0], [150, 0, H], [0, 0, H]],
                         [[150, 0, 0], [300, 0, 0], [300, 0, H], [150, 0, H]]], float)

    @property
    def slots(self):
        return [Slot(node=0, position=1, side=SlotSide.B, depth=DEPTH, width=W)]


def _sheet(tmp_path, cutting, plate=None):
    """Nest the plate alone, write the DXF, re-read it with ezdxf: the CUT and NOMINAL closed
    polylines as shapely polygons, and the circles per layer."""
    u = unroll(plate or _Plate())
    lay = nest([u], sheet=(500.0, 300.0), gap=5.0, margin=10.0, rotations=(0,), cutting=cutting)
    path = lay.export_dxf(tmp_path / "cut.dxf", svg=False)[0]
    doc = ezdxf.readfile(path)
    assert not doc.audit().has_errors
    msp = doc.modelspace()
    polys = {layer: [Polygon([p[:2] for p in e.get_points("xy")])
                     for e in msp.query(f"LWPOLYLINE[layer=='{layer}']")]
             for layer in ("CUT", "NOMINAL")}
    circles = {layer: [(tuple(e.dxf.center)[:2], 2 * e.dxf.radius)
                       for e in msp.query(f"CIRCLE[layer=='{layer}']")]
               for layer in ("CUT", "NOMINAL", "DRILL")}
    (pl,) = lay.placements
    return polys, circles, pl


def _slot_frame(pl):
    """Where the slot of the placed part is: its mouth centre and the unit vectors from the
    mouth into the plate (u) and across the slot (v), from the placement's transform."""
    rot = math.radians(pl.rotation)
    R = np.array([[math.cos(rot), -math.sin(rot)], [math.sin(rot), math.cos(rot)]])
    return R, np.asarray(pl.offset)


def _toolpath_width(path: Polygon, a, b) -> float:
    """Width of the slot on the toolpath along the segment a-b across it: the length of the
    segment outside the path's polygon."""
    seg = LineString([a, b])
    return seg.length - seg.intersection(path).length


def _slot_geometry(pl):
    """The nominal slot (a Polygon: the cut-out inside the plate), the mid-depth cross-section
    end points, on the sheet."""
    u = unroll(_Plate())
    rect = u.slots[0]
    R, t = _slot_frame(pl)
    on_sheet = lambda pts: np.asarray(pts) @ R.T + t               # noqa: E731
    r = on_sheet(rect)
    mouth, bottom = 0.5 * (r[0] + r[3]), 0.5 * (r[1] + r[2])
    along = (bottom - mouth) / np.linalg.norm(bottom - mouth)
    across = (r[2] - r[1]) / np.linalg.norm(r[2] - r[1])
    mid = bottom - 0.5 * DEPTH * along
    slot = Polygon([bottom - 0.5 * W * across, bottom + 0.5 * W * across,
                    bottom + 0.5 * W * across - DEPTH * along, bottom - 0.5 * W * across - DEPTH * along])
    return slot, mid - 5 * W * across, mid + 5 * W * across, bottom, along, across


@pytest.mark.parametrize("process, kerf", [("laser", 0.2), ("waterjet", 1.0)])
def test_toolpath_is_offset_by_half_the_kerf_and_the_slot_narrowed_by_the_kerf(tmp_path, process, kerf):
    cut = Cutting.for_process(process)
    assert cut.kerf == pytest.approx(kerf)
    polys, _, pl = _sheet(tmp_path, cut)
    (nominal,), (path,) = polys["NOMINAL"], polys["CUT"]
    assert nominal.area == pytest.approx(L * H - W * DEPTH, rel=1e-9)
    # every point of the toolpath is kerf / 2 from the nominal outline (arcs at convex corners)
    pts = np.asarray(path.exterior.coords)
    d = [nominal.exterior.distance(Point(p)) for p in pts]
    assert min(d) == pytest.approx(0.5 * kerf, abs=1e-6) and max(d) == pytest.approx(0.5 * kerf, rel=0.01)
    assert path.contains(nominal)
    slot, a, b, *_ = _slot_geometry(pl)
    assert _toolpath_width(nominal, a, b) == pytest.approx(W, abs=1e-6)
    assert _toolpath_width(path, a, b) == pytest.approx(W - kerf, abs=1e-6)
    # what the beam removes (kerf wide around the path) leaves exactly the nominal slot width
    finished = path.buffer(-0.5 * kerf, quad_segs=32)
    assert _toolpath_width(finished, a, b) == pytest.approx(W, abs=1e-3)


@pytest.mark.parametrize("relief", [Relief.DOGBONE, Relief.TBONE])
def test_router_reliefs_clear_the_slot_corners_so_the_crossing_plate_seats(tmp_path, relief):
    tool = 3.175
    cut = Cutting.for_process("router", relief=relief)
    assert cut.kerf == pytest.approx(tool) and cut.tool_diameter == pytest.approx(tool)
    polys, _, pl = _sheet(tmp_path, cut)
    (path,) = polys["CUT"]
    slot, a, b, bottom, along, across = _slot_geometry(pl)
    assert _toolpath_width(path, a, b) == pytest.approx(W - tool, abs=1e-6)
    # the material a round bit of radius r leaves: the toolpath shrunk by r; the crossing
    # plate's square section (the nominal slot) must be clear of it, corners included
    finished = path.buffer(-0.5 * tool, quad_segs=64)
    assert finished.intersection(slot).area < 1e-3
    # the relief is where it should be: the bit reaches both bottom corners
    corners = [bottom - 0.5 * W * across, bottom + 0.5 * W * across]
    for c in corners:
        assert path.distance(Point(c)) <= 0.5 * tool + 1e-6
    # what the bit removes: a band of its radius around the path. Dogbone: a disc on the
    # corner's bisector, biting into the wall beside the corner; T-bone: a disc on the bottom,
    # biting into the web below it, the walls the crossing plate bears on stay straight
    r = 0.5 * tool
    removed = path.exterior.buffer(r, quad_segs=64)
    into_wall = Point(bottom + (0.5 * W + 0.15 * r) * across - 0.3 * r * along)
    into_web = Point(bottom + 0.5 * r * along)
    assert removed.contains(into_wall) is (relief == Relief.DOGBONE)
    assert removed.contains(into_web) is (relief == Relief.TBONE)
    # elsewhere the walls are cut on the nominal line: nothing beyond them is removed
    assert not removed.contains(Point(bottom + (0.5 * W + 0.05 * r) * across - 3 * r * along))


def test_without_reliefs_a_router_leaves_fillets_in_the_slot_corners(tmp_path):
    tool = 3.175
    polys, _, pl = _sheet(tmp_path, Cutting.for_process("router", relief="none"))
    finished = polys["CUT"][0].buffer(-0.5 * tool, quad_segs=64)
    slot, *_ = _slot_geometry(pl)
    fillets = finished.intersection(slot).area
    # two fillets of the bit's radius: (1 - pi / 4) r^2 each
    assert fillets == pytest.approx(2 * (1 - math.pi / 4) * (0.5 * tool) ** 2, rel=0.05)


def test_holes_are_circles_compensated_on_cut_or_drilled(tmp_path):
    holes = (_Hole(np.array([60.0, 0.0, 40.0]), 8.0), _Hole(np.array([240.0, 0.0, 100.0]), 2.5))
    _, circles, pl = _sheet(tmp_path, Cutting.for_process("router"), _Plate(holes=holes))
    # on the sheet where the part's transform puts them; the 8 mm hole cut with the bit on a
    # path 8 - 3.175 mm across, the 2.5 mm one narrower than the bit: drilled
    assert sorted(d for _, d in circles["NOMINAL"]) == pytest.approx([2.5, 8.0])
    assert [d for _, d in circles["CUT"]] == pytest.approx([8.0 - 3.175])
    assert [d for _, d in circles["DRILL"]] == pytest.approx([2.5])
    u = unroll(_Plate(holes=holes))
    corner = u.panels[0, 0]
    for (c, d), hole in zip(u.holes, holes):    # unrolled isometrically with the part
        assert np.linalg.norm(c - corner) == pytest.approx(np.linalg.norm(hole.center), abs=1e-9)
    R, t = _slot_frame(pl)
    placed = {round(d, 3): np.asarray(c) for c, d in circles["NOMINAL"]}
    for c, d in u.holes:
        assert placed[round(d, 3)] == pytest.approx(R @ c + t, abs=1e-6)
    # the parts' outlines read back (nominal layer) carry the holes
    polys, _, _ = read_dxf_parts(tmp_path / "cut_sheet01.dxf")
    assert len(polys[0].interiors) == 2


def test_a_router_bit_wider_than_the_slots_is_refused_naming_the_fix():
    with pytest.raises(CuttingError, match="tool_diameter_mm"):
        Cutting.for_process("router", tool_diameter_mm=6.0).check_slots([unroll(_Plate())])
    with pytest.raises(CuttingError, match="unknown cutting process"):
        Cutting.for_process("plasma")
