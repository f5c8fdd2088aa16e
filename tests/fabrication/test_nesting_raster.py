"""The raster hole filler of the final cut (issues 40, 42): its cells against hand counts, the
spacing it keeps against shapely's distances, and a hole under a part that the skyline cannot
reach from above."""
import numpy as np
from shapely import affinity
from shapely.geometry import Polygon, box

from torsal.fabrication.nesting.raster import RasterGrid, RasterPacker, longest_runs, rasterize
from torsal.fabrication.nesting.skyline import SkylinePacker, column_profiles


def test_rasterize_counts_the_centres_inside():
    # a 95 x 42 box from (3, 1): centres (i + 1/2) 10 inside for i = 0..9 along x (5..95) and
    # j = 0..3 along y (5..35): 10 x 4 cells
    cells = rasterize(box(3.0, 1.0, 98.0, 43.0), 0.0, 0.0, 12, 6, 10.0)
    assert cells.shape == (12, 6)
    assert cells.sum() == 10 * 4 and cells[:10, :4].all()
    # a triangle below the diagonal y = x / 2 of a 100 x 50 box: the centres under it
    tri = rasterize(Polygon([(0, 0), (100, 0), (100, 50)]), 0.0, 0.0, 10, 5, 10.0)
    xc = (np.arange(10) + 0.5) * 10
    yc = (np.arange(5) + 0.5) * 10
    assert np.array_equal(tri, yc[None, :] < xc[:, None] / 2)


def test_longest_runs_along_and_across():
    cells = np.zeros((6, 5), dtype=bool)
    cells[1:4, 3] = True                 # 3 along axis 0
    cells[5, 0:5] = True                 # 5 along axis 1
    cells[0, 3] = True                   # joins the first: 4 along axis 0
    assert longest_runs(cells) == (4, 5)
    assert longest_runs(np.zeros((3, 2), dtype=bool)) == (0, 0)


def test_parts_placed_keep_the_spacing_and_the_frame():
    sep, length, height = 5.0, 1000.0, 600.0
    grid = RasterGrid(length=length, height=height, sep=sep, res=7.0)
    shapes = [Polygon([(0, 0), (400, 0), (400, 60), (60, 60), (60, 300), (0, 300)]),   # an L
              Polygon([(0, 0), (350, 0), (0, 200)]),                                    # a triangle
              affinity.rotate(box(0, 0, 500, 80), 17, origin=(0, 0)),                    # a slanted strip
              Polygon([(0, 0), (200, 40), (400, 0), (400, 90), (200, 130), (0, 90)])]   # a chevron
    packer = RasterPacker(grid)
    placed = []
    for k in range(12):
        s = shapes[k % 4]
        feet = [grid.footprint(s, r, f"p{k}") for r in (0.0, 90.0, 180.0, 270.0)]
        assert packer.add(f"p{k}", s, feet)
        si, spot = packer.placed[f"p{k}"]
        f = spot.footprint
        poly = affinity.translate(affinity.rotate(s, f.rot, origin=(0, 0)), f.shift[0] + spot.x,
                                  f.shift[1] + spot.y)
        placed.append((si, poly))
    assert len(packer.sheets) >= 1
    frame = box(0, 0, length, height)
    for i, (si, p) in enumerate(placed):
        assert frame.buffer(1e-6).contains(p)
        for sj, q in placed[:i]:
            if si == sj:
                assert p.distance(q) >= sep - 1e-6
    # the same parts, the same places
    again = RasterPacker(grid)
    for k in range(12):
        s = shapes[k % 4]
        again.add(f"p{k}", s, [grid.footprint(s, r, f"p{k}") for r in (0.0, 90.0, 180.0, 270.0)])
    assert {n: (si, sp.x, sp.y, sp.footprint.rot) for n, (si, sp) in again.placed.items()} == \
           {n: (si, sp.x, sp.y, sp.footprint.rot) for n, (si, sp) in packer.placed.items()}


def test_a_hole_under_a_bridge_that_the_skyline_cannot_reach():
    """A bridge 800 mm long standing on two 300 mm legs leaves a 600 x 290 mm hole under it;
    a 400 x 200 mm plate goes in there, at the bottom. Dropped from above, the skyline lays it
    on the bridge."""
    sep = 5.0
    bridge = Polygon([(0, 0), (100, 0), (100, 300), (700, 300), (700, 0), (800, 0), (800, 400),
                      (0, 400)])
    plate = box(0, 0, 400, 200)
    grid = RasterGrid(length=1000.0, height=700.0, sep=sep, res=5.0)
    sheet = grid.sheet()
    sheet.add(bridge)
    spot = grid.spot(sheet, [grid.footprint(plate, 0.0)])
    assert spot is not None and spot.y <= 2 * grid.res
    assert 100.0 + sep <= spot.x and spot.x + 400.0 <= 700.0 - sep
    placed = affinity.translate(plate, spot.x, spot.y)
    assert bridge.distance(placed) >= sep - 1e-9 and not bridge.intersects(placed)
    res = 5.0
    sky = SkylinePacker(1000.0, 700.0, sep, res)
    sky.add("bridge", column_profiles([bridge], [0.0], res=res, sep=sep), new_sheet=True)
    sky.add("plate", column_profiles([plate], [0.0], res=res, sep=sep), new_sheet=False)
    _, _, x, y = sky.placed["plate"]
    assert y >= 400.0 or x >= 800.0      # on the bridge or beside it, never under it
