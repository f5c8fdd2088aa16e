"""One sheet packed by sparrow (Gardeyn & Wauters' strip-packing heuristic, through the
``spyrrow`` wheel): true shapes, any rotation, collision detection on the exact outlines.

Sparrow minimises the length of one strip of fixed height (spyrrow 0.9 has no bins and no
fixed obstacles), so a sheet is a strip of the sheet's height that must come out no longer
than the sheet. Each outline is centred on its centroid (sparrow mis-places items far from
their reference point), grown by half the distance two outlines keep (mitre join: slots
narrower than that close), simplified without shrinking, and oriented counter-clockwise
(sparrow mis-places clockwise rings). Every placement is checked again with shapely on the
true outlines before it is used.

Units: those of the outlines.
"""
from __future__ import annotations

import time

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient


def grown(outline: Polygon, half: float) -> Polygon:
    """The outline grown by ``half`` (mitre join: slots narrower than ``2 half`` close),
    simplified without shrinking below that, without holes, counter-clockwise."""
    s = max(0.05 * half, 1e-3 * np.sqrt(outline.area), 1e-9)
    g = outline.buffer(half + s, join_style="mitre", mitre_limit=2.0).simplify(s)
    if g.geom_type != "Polygon":
        g = g.convex_hull
    return orient(Polygon(g.exterior), 1.0)


class SheetSolver:
    """Sparrow solves of single sheets ``w x h`` with ``edge`` to the sheet edge and ``sep``
    between outlines; parts by name from ``outlines`` ``{name: Polygon}``.

    :meth:`fit` returns ``{name: (rotation deg, (dx, dy))}`` of the original outlines (turned
    about the origin, then moved) when sparrow packs all the parts inside the sheet, else None.
    """

    def __init__(self, outlines: dict, w: float, h: float, sep: float, edge: float,
                 seed: int, rotation_step: float | None):
        import spyrrow

        self.spyrrow = spyrrow
        self.w, self.h, self.sep, self.edge, self.seed = w, h, sep, edge, seed
        self.true = {}
        self.centre = {}
        self.shapes = {}
        for n, p in outlines.items():
            c = np.asarray(p.centroid.coords[0])
            self.centre[n] = c
            self.true[n] = affinity.translate(p, *(-c))
            self.shapes[n] = grown(self.true[n], 0.5 * sep)
        self.orientations = (None if rotation_step is None else
                             [float(a) for a in np.arange(0.0, 360.0, rotation_step)])
        self.calls = 0
        self.seconds = 0.0             # wall seconds the solves took
        self.asked = 0.0               # and the seconds they were given

    def fit(self, names: list, explore: int, compress: int) -> dict | None:
        """Pack ``names`` on one sheet (see the class docstring)."""
        sp = self.spyrrow
        items = [sp.Item(n, list(self.shapes[n].exterior.coords)[:-1], demand=1,
                         allowed_orientations=self.orientations) for n in names]
        cfg = sp.StripPackingConfig(early_termination=True, total_computation_time=None,
                                    exploration_time=int(explore), compression_time=int(compress),
                                    num_workers=1, seed=int(self.seed))
        t0 = time.perf_counter()
        sol = sp.StripPackingInstance("sheet", strip_height=float(self.h - 2 * self.edge + self.sep),
                                      items=items).solve(cfg)
        self.seconds += time.perf_counter() - t0
        self.asked += explore + compress
        self.calls += 1
        if sol.width > self.w - 2 * self.edge + self.sep + 1e-9:
            return None
        shift = self.edge - 0.5 * self.sep
        out = {}
        for p in sol.placed_items:
            rot = float(p.rotation)
            tx, ty = map(float, p.translation)
            c = self.centre[p.id]
            a = np.radians(rot)
            rc = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]) @ c
            # placed = rotate(outline - c) + t + shift = rotate(outline) - R c + t + shift
            out[p.id] = (rot, (tx + shift - rc[0], ty + shift - rc[1]))
        if len(out) != len(names) or not self.valid(out):
            return None
        return out

    def valid(self, where: dict) -> bool:
        """Whether the original outlines placed by ``where`` lie inside the sheet's margins and
        keep ``sep`` from each other (shapely, on the true outlines)."""
        polys = [affinity.translate(affinity.rotate(affinity.translate(self.true[n], *self.centre[n]),
                                                    rot, origin=(0, 0)), dx, dy)
                 for n, (rot, (dx, dy)) in where.items()]
        return sheet_ok(polys, self.w, self.h, self.edge, self.sep)


def sheet_ok(polys: list, w: float, h: float, edge: float, sep: float) -> bool:
    """Whether every polygon lies ``edge`` inside a ``w x h`` sheet and each pair keeps
    ``sep`` (a relative tolerance of 1e-6)."""
    tol = 1e-6 * max(w, h)
    b = shapely.bounds(np.array(polys, dtype=object))
    if len(polys) and ((b[:, :2] < edge - tol).any() or (b[:, 2] > w - edge + tol).any()
                       or (b[:, 3] > h - edge + tol).any()):
        return False
    tree = shapely.STRtree(polys)
    i, j = tree.query(polys, predicate="dwithin", distance=sep * (1 - 1e-6))
    keep = i < j
    return not keep.any()
