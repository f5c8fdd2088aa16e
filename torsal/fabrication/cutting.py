"""The cutting process: kerf and tool-radius compensation, and reliefs at inner slot corners.

A cutting machine does not cut on the drawn line: a laser beam, a waterjet or a router bit
removes a band ``kerf`` wide centred on the path its centre follows. To cut a part to its
nominal outline the path runs ``kerf / 2`` outside the outline (and inside every hole and
slot): :meth:`Cutting.toolpath`. A round tool also cannot reach into an inner corner: it leaves
a fillet of its radius. Where a square edge must seat - the bottom corners of an egg-crate slot,
into which the crossing plate slides - a router needs a relief cut beyond the corner:

* **dogbone**: the tool's centre goes along the corner's bisector until its edge reaches the
  corner (a disc of the tool's radius, centred ``r`` from the corner inside the slot's diagonal);
* **T-bone**: the tool's centre goes along the slot's bottom until its edge reaches the corner
  (a half disc into the bottom; the side walls the crossing plate bears on stay straight).

The STEP solids stay nominal; only the cutting sheets (DXF) carry the toolpath.

Defaults per process (``kerf_mm``, ``tool_diameter_mm``, relief), typical values for 1-6 mm
aluminium sheet; set the machine's own values in the design file's ``[cutting]`` table:

=========  ========  =================  ========  =====================================================
process    kerf mm   tool diameter mm   relief    source
=========  ========  =================  ========  =====================================================
laser      0.2       0.2 (the beam)     none      fibre-laser kerf in thin aluminium is 0.1-0.3 mm (the
                                                  focused spot plus melt); the fillet it leaves (0.1 mm)
                                                  is within the slot clearance
waterjet   1.0       1.0 (the jet)      none      abrasive waterjets cut a kerf about the bore of the
                                                  carbide mixing tube, 0.76-1.1 mm (1.0-1.05 mm tubes
                                                  are common on 4000 bar machines)
router     3.175     3.175 (1/8 in)     dogbone   a 1/8 in single-flute end mill, the usual bit for
                                                  1-6 mm aluminium sheet; kerf = bit diameter
=========  ========  =================  ========  =====================================================

Units: the ``unit`` of the outlines (mm by default); the process keys are in mm and converted.

Example
-------
>>> from shapely.geometry import box
>>> cut = Cutting.for_process("router")
>>> cut.kerf, cut.relief.value
(3.175, 'dogbone')
>>> round(cut.toolpath(box(0, 0, 100, 50)).bounds[0], 4)      # kerf / 2 outside the outline
-1.5875
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np
from shapely.geometry import Point, Polygon

from torsal.core.errors import TorsalError
from torsal.core.units import UNIT_TO_MM

__all__ = ["Process", "Relief", "Cutting", "PROCESS_DEFAULTS", "CuttingError",
           "slot_corners", "relief_centres"]


class CuttingError(TorsalError, ValueError):
    """The cutting process cannot cut the parts as drawn (e.g. a router bit wider than a slot)."""


class Process(str, Enum):
    """How the sheets are cut."""

    LASER = "laser"
    WATERJET = "waterjet"
    ROUTER = "router"


class Relief(str, Enum):
    """Relief cut at the inner corners of slots (where a round tool leaves a fillet)."""

    NONE = "none"
    DOGBONE = "dogbone"
    TBONE = "t-bone"


@dataclass(frozen=True)
class _Defaults:
    kerf_mm: float
    tool_diameter_mm: float
    relief: Relief


#: the one source of each process's defaults (see the module docstring for the values' sources)
PROCESS_DEFAULTS: dict[Process, _Defaults] = {
    Process.LASER: _Defaults(0.2, 0.2, Relief.NONE),
    Process.WATERJET: _Defaults(1.0, 1.0, Relief.NONE),
    Process.ROUTER: _Defaults(3.175, 3.175, Relief.DOGBONE),
}


@dataclass(frozen=True)
class Cutting:
    """A cutting process with its kerf and tool diameter in ``unit``.

    Attributes
    ----------
    process : Process
    kerf : float
        Width of the cut (``unit``): the toolpath runs ``kerf / 2`` outside each outline.
    tool_diameter : float
        Diameter of the tool (``unit``): it sets the radius of the reliefs and the smallest
        hole the tool can cut (smaller holes are drilled).
    relief : Relief
        Relief at the inner corners of slots.
    unit : str
    """

    process: Process = Process.LASER
    kerf: float = PROCESS_DEFAULTS[Process.LASER].kerf_mm
    tool_diameter: float = PROCESS_DEFAULTS[Process.LASER].tool_diameter_mm
    relief: Relief = Relief.NONE
    unit: str = "mm"
    #: segments per quarter circle of the toolpath's arcs around convex corners
    quad_segs: int = field(default=4, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "process", Process(self.process))
        object.__setattr__(self, "relief", Relief(self.relief))
        if not (self.kerf >= 0 and np.isfinite(self.kerf)):
            raise CuttingError(f"kerf must be >= 0, got {self.kerf}")
        if not (self.tool_diameter >= 0 and np.isfinite(self.tool_diameter)):
            raise CuttingError(f"tool diameter must be >= 0, got {self.tool_diameter}")
        if self.unit not in UNIT_TO_MM:
            raise CuttingError(f"unknown unit {self.unit!r}; use one of {sorted(UNIT_TO_MM)}")

    @classmethod
    def for_process(cls, process: Process | str = Process.LASER, *, kerf_mm: float | None = None,
                    tool_diameter_mm: float | None = None, relief: Relief | str | None = None,
                    unit: str = "mm") -> "Cutting":
        """The process with its defaults (:data:`PROCESS_DEFAULTS`), any of them overridden;
        lengths given in mm, held in ``unit``. A router's kerf is its tool's diameter unless
        given."""
        try:
            p = Process(process)
        except ValueError:
            raise CuttingError(f"unknown cutting process {process!r}; use one of "
                               f"{[x.value for x in Process]}") from None
        d = PROCESS_DEFAULTS[p]
        tool = d.tool_diameter_mm if tool_diameter_mm is None else float(tool_diameter_mm)
        if kerf_mm is None:
            kerf_mm = tool if p == Process.ROUTER else d.kerf_mm
        f = 1.0 / UNIT_TO_MM.get(unit, np.nan)
        return cls(p, float(kerf_mm) * f, tool * f, Relief(relief) if relief is not None else d.relief,
                   unit)

    def in_unit(self, unit: str) -> "Cutting":
        """The same process with its lengths in ``unit``."""
        f = UNIT_TO_MM[self.unit] / UNIT_TO_MM[unit]
        return replace(self, kerf=self.kerf * f, tool_diameter=self.tool_diameter * f, unit=unit)

    @property
    def radius(self) -> float:
        """Tool radius (``unit``)."""
        return 0.5 * self.tool_diameter

    def toolpath(self, outline: Polygon, reliefs=()) -> Polygon:
        """The path of the tool's centre around a nominal outline: the outline minus the
        relief discs (centres ``reliefs`` (n, 2), radius :attr:`radius`), offset by
        ``kerf / 2`` (outwards, so inwards in holes and slots; arcs around convex corners, as a
        controller's tool-radius compensation cuts them)."""
        part = outline
        if len(reliefs) and self.radius > 0:
            from shapely.ops import unary_union

            part = part.difference(unary_union([Point(c).buffer(self.radius, quad_segs=16)
                                                 for c in np.asarray(reliefs, float)]))
            if part.geom_type != "Polygon":       # reliefs never split a sound part
                part = max(getattr(part, "geoms", [part]), key=lambda g: g.area)
        if self.kerf <= 0:
            return part
        return part.buffer(0.5 * self.kerf, quad_segs=self.quad_segs, join_style="round")

    def hole_path(self, diameter: float) -> tuple[str, float]:
        """``("cut", path diameter)`` for a hole the tool can cut (the path ``kerf`` smaller
        than the hole), else ``("drill", diameter)`` for a hole no wider than the tool."""
        if diameter > self.kerf and (self.process != Process.ROUTER or diameter > self.tool_diameter):
            return "cut", float(diameter - self.kerf)
        return "drill", float(diameter)

    def check_slots(self, unrolled_parts) -> None:
        """CuttingError naming the parts whose slots are narrower than the tool (a router bit
        that does not fit the slot cannot cut it)."""
        if self.process != Process.ROUTER:
            return
        narrow = sorted({u.name for u in unrolled_parts for s in u.slot_records
                         if s.width < self.tool_diameter - 1e-9})
        if narrow:
            w = min(s.width for u in unrolled_parts for s in u.slot_records)
            raise CuttingError(
                f"the router bit ({self.tool_diameter:g} {self.unit}) is wider than the slots "
                f"({w:g} {self.unit}) of {len(narrow)} parts ({', '.join(narrow[:5])}"
                f"{' ...' if len(narrow) > 5 else ''}): set [cutting] tool_diameter_mm to at most "
                f"the slot width, or cut with a laser or waterjet")


def slot_corners(unrolled) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The inner (bottom) corners of the slots of an unrolled part that are corners of its
    outline: ``[(corner (2,), u, v)]`` with ``u`` the unit direction from the slot's mouth to
    its bottom and ``v`` the unit direction along the bottom into the slot."""
    out = []
    body = unrolled.outline
    size = np.sqrt(body.area)
    for rect in unrolled.slots:
        r = np.asarray(rect, float)
        u = r[1] - r[0]
        u /= np.linalg.norm(u)
        across = r[2] - r[1]
        across /= np.linalg.norm(across)
        for corner, v in ((r[1], across), (r[2], -across)):
            p = Point(corner)
            # a corner of the outline: on its boundary, with material beyond the bottom
            if body.exterior.distance(p) > 1e-7 * size:
                continue
            if not body.contains(Point(corner + 1e-4 * size * (u - v))):
                continue
            out.append((corner, u, v))
    return out


def relief_centres(unrolled, cutting: Cutting) -> np.ndarray:
    """Centres (n, 2) of the relief discs (radius ``cutting.radius``) at the inner slot
    corners of an unrolled part; none for :attr:`Relief.NONE`. Dogbone: ``r`` from the corner
    along the bisector into the slot; T-bone: ``r`` from the corner along the slot's bottom.
    Either disc passes through the corner, so the tool clears it."""
    r = cutting.radius
    if cutting.relief == Relief.NONE or r <= 0:
        return np.zeros((0, 2))
    centres = []
    for corner, u, v in slot_corners(unrolled):
        d = (v - u) / np.sqrt(2.0) if cutting.relief == Relief.DOGBONE else v
        centres.append(corner + r * d)
    return np.asarray(centres, float).reshape(-1, 2)
