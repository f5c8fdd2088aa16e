"""Parts of a fin system: strips of planar fins grouped into buildable plates (issues 6, 15).

A :class:`FinSystem` reads a :class:`~torsal.geometry.support.SupportStructure` and groups its
fins (one planar quad ``a_i a_j b_j b_i`` per edge) into *parts*, then joins them. It is the
facade of :mod:`torsal.fabrication`: the model (:mod:`.model`), the joinery (:mod:`.joints`),
development (:mod:`.unroll`), the builder (:mod:`.builder`: the rebuild loop, strips, ends,
crossings, clashes, assembly paths), solids (:mod:`.solids`) and sheets (:mod:`.layout`) sit
below it.

* By default (``family_split="egg-crate"``) every strip of either torsal family is one part, a
  folded plate of planar panels hinged on the node lines ``L_i = a_i b_i``. At every node where
  strips of both families pass, :func:`~.joints.choose_joinery` picks the joint: an egg-crate
  (half-depth slots, family 0 from its ``b`` edge, family 1 from its ``a`` edge, widths from the
  crossing angle, see :func:`~.joints.slot_width`) where the plates slide together along
  ``L_i``, else the strip that folds more is split there and both halves are butted against the
  continuous plate with a bracket (rules and limits in :mod:`.joints`).
* With ``family_split="family0-continuous"`` the strips of family 0 are continuous plates and
  family 1 is cut into single panels between them, butted with brackets.

Where a strip ends against a plate of the other family (a T or L junction on the boundary)
its end panel is trimmed back until its end face clears the faces of that plate (both panels
of it, if it folds there) by ``clearance/2`` and a bracket joins them. Panels meeting at a fold
sharper than ``max_fold_angle`` are split into separate parts: the later part is butt-trimmed
against the square end of the earlier one, with a bracket. Strips with more than
``max_panels`` panels, longer than ``max_part_length`` along their ``a`` and ``b`` edges, or
whose unrolled outline does not fit ``fit_sheet`` (cut into the longest runs that fit) are
split too;
closed strips are always cut into at least two parts. Those splits meet on the bisector plane
of the fold (mitred) with a splice plate, or, at a crossing, meet on that seam inside the
crossing plate's slot without a connector where the assembly check on the parts around the
joint proves it (``seams_in_slot``; else butted against the crossing plate with brackets, named
in ``joint_fallbacks``, :mod:`.builder.seams`). Once the design is settled, a butted end's
bracket becomes a tab bent from the end itself, lying on the plate and bolted to it, wherever
the assembly check on the parts around that joint proves it (``tab_joints``; a bracket that
stays is named in ``joint_fallbacks``, :mod:`.builder.tabs`). Connectors (brackets, splice
plates) are parts of their own, named ``C-N<node>-<i>``;
:attr:`FinSystem.joints` lists every joint (:class:`~.model.Joint`).

Every part goes in along one direction (:mod:`.joints`, "one insertion direction per part"):
the structure is rebuilt (at most ``MAX_REBUILDS`` times) leaving out end panels that cannot
be trimmed (``coplanar_panels``), butting crossings a plate cannot slide onto together with
its others, and re-splitting crossings where parts would butt on each other in a cycle.
Where two plates cross or come within ``thickness + clearance`` of each other away from any
joint (no node line in common: strips of one family crossing near a singularity of a rough
congruence), one of the two panels is left out too (``coplanar_panels``, naming the other).

**Every part's path into place is clear.** Once the joints are settled, the path of every
part that goes in after others (a butted part, a slotted family-1 plate) is checked against
the plates in place before it, in the order a workshop follows (plates a joint lists first go
first, otherwise by name): its panels, thickened and swept along the path (over the fin depth
of its joints: then it is clear of them), against theirs (:class:`.builder.paths._PathCheck`).
A workshop that finds a part blocked by a neighbouring plate first slides it in another way
its joints allow: a butted part takes the first clear one of its directions (along the node
axis of a butt joint, either sense, along the line where two faces it ends against meet, head
on). Only where none is clear (a slotted plate has one direction only) is a panel left out,
as the trimming does: of every pair of panels on the part's first path that overlap (more
than touch) or, at a joint, come nearer by more than ``clearance/2`` than in place, the
cheaper one (a panel at an end of its part before one inside it, then the one of the shorter
strip), named in ``coplanar_panels``; the structure is rebuilt and checked again. The order
itself is not changed: it follows from the joints, which the assembly check reads too.

Real structures from the remesher have defects near boundaries and at coarse resolution; they
are handled and reported (``warnings.warn`` naming parts, nodes and what to do), never turned
into NaN or invalid solids: degenerate panels (narrower than ``min_panel_width`` or
self-intersecting) are dropped and their strip split there (``dropped_panels``); butt trims
without a solution are skipped (``untrimmed_joints``); joints without room for a connector are
named (``unconnected_joints``); slots that would cut a part in two are made shallower, the
partner's slot deeper (``slot_conflicts``); single panels larger than ``fit_sheet`` are named
(``oversize_panels``; :meth:`FinSystem.layout` refuses them).

Units: the structure is in ``model_unit`` (metres by default); every length held by a
:class:`FinSystem` (``thickness``, ``clearance``, panel coordinates, slots, solids, sheets,
DXF) is in ``unit`` (millimetres by default).

Example
-------
>>> from torsal.fabrication import FinSystem
>>> fs = FinSystem(structure, thickness=3.0, clearance=0.5)        # doctest: +SKIP
>>> fs.parts[0].name, len(fs.parts[0].panels)                      # doctest: +SKIP
('F0-S000-P00', 3)
>>> sorted({j.kind.value for j in fs.joints})                      # doctest: +SKIP
['butt-bracket', 'egg-crate']
"""
from __future__ import annotations

import contextlib
import gc
from typing import Iterable, Sequence

import numpy as np

from torsal.core.units import INSUNITS, UNIT_TO_MM

from . import ifc as _ifc
from . import layout as _layout
from . import solids as _solids
from .nesting import nest_parts
from .builder.clash import ClashFinder
from .builder.fixings import FIXING_SPACING
from .builder.free import FreeStrips
from .builder.memo import Memo
from .builder.paths import AssemblyPlanner
from .builder.rebuild import MAX_REBUILDS, Rebuilder, init_joints
from .builder.strips import StripCutter
from .joints import MAX_CROSSING_FOLD, MIN_CROSSING_ANGLE
from .model import (CONNECTOR_FAMILY, FAMILY_COLORS, FIXING_FAMILY, MITER_LIMIT, Crossing, FamilySplit, Joint,
                    JointKind, Part, PartId, Slot, SlotSide, fold_angles, panel_widths,
                    quad_normals)
from .unroll import unroll

# importable from here as before the builder moved to .builder (tests, earlier code)
from .builder.ends import CONNECTOR_GAP  # noqa: F401
from .builder.paths import SLAB_TOUCH, _cycles  # noqa: F401
# (and the builder's phases and the rebuild loop, since FinSystem's rebuild loop moved to
# .builder.rebuild and its free strips to .builder.free)
from .builder.crossings import CrossingSlotter  # noqa: F401
from .builder.ends import EndJoiner  # noqa: F401
from .builder.fasteners import FastenerLayout  # noqa: F401
from .builder.fixings import FixingPlacer  # noqa: F401
from .builder.rebuild import reset_state  # noqa: F401
from .builder.seams import JointFallback, SlotSeam, SlotSeams  # noqa: F401
from .builder.strips import _plate_panels, _read_strips  # noqa: F401
from .joints import choose_joinery  # noqa: F401
from .builder.proximity import _near_panel_pairs, _quads_cross, _quads_on  # noqa: F401
from .builder.proximity import _slab_depths, _swept_distances  # noqa: F401
from .model import _bowtie, _oriented_size, _safe_normals  # noqa: F401

__all__ = [
    "FamilySplit", "SlotSide", "PartId", "Slot", "Crossing", "Part", "FinSystem", "Joint",
    "JointKind", "UNIT_TO_MM", "INSUNITS", "FAMILY_COLORS", "fold_angles", "quad_normals",
    "MITER_LIMIT", "panel_widths",
]


@contextlib.contextmanager
def _old_objects_frozen():
    """The objects that exist now left out of Python's cyclic garbage collection while the
    block runs (:func:`gc.freeze`; none is freed meanwhile: they were live), then put back.
    A fin system's build makes hundreds of thousands of objects, so the collector runs its full
    pass a few times, each over everything the process holds (the imported modules, the
    structure, the stages' results: 300,000 objects on 7a): 0.6 of its 0.8 s of collecting.
    Nothing is frozen by a caller that froze objects itself (``gc.get_freeze_count()``)."""
    if gc.get_freeze_count() or not gc.isenabled():
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


class FinSystem:
    """The fins of a support structure grouped into parts, thickened, slotted and laid out.

    Parameters
    ----------
    structure : SupportStructure
        Fins of ``structure.fins()``; coordinates in ``model_unit``.
    thickness : float
        Plate thickness in ``unit`` (mm by default), > 0. Panels are thickened about their
        mid-plane.
    family_split : FamilySplit or str
        ``"egg-crate"`` (default) or ``"family0-continuous"``.
    clearance : float
        Slot clearance in ``unit``, >= 0: slot width = ``thickness + clearance``.
    slot_ratio : float
        Fraction of the fin depth slotted into the family-0 plate (from its ``b`` edge), the
        rest into family 1 (from its ``a`` edge). 0.5 = half-depth slots.
    max_fold_angle : float
        Degrees; consecutive panels folding by more than this become separate parts. The
        parts meet mitred on the fold's bisector plane, up to a fold of :data:`MITER_LIMIT`
        (170 deg); at sharper folds (a strip doubling back on itself) they get square ends,
        overlap near the fold and are listed in ``untrimmed_joints`` (warned).
    min_panel_width : float or None
        Degenerate panels narrower than this (``unit``; area over longest edge, see
        :func:`panel_widths`), e.g. slivers whose ``a`` edge runs along the node lines, are
        dropped (the strip is split there) with a warning naming them; listed in
        ``dropped_panels``. Default: ``thickness`` (a plate cannot be narrower than it is
        thick); 0 drops only zero-area panels.
    max_part_length : float or None
        Split strips into parts no longer than this (``unit``, measured along the ``a`` and
        ``b`` edges, so the unrolled part is about this long), e.g. the sheet length minus the
        margins.
    max_panels : int or None
        Split strips into parts of at most this many panels.
    fit_sheet : (width, height) or None
        Sheet size (``unit``, default 2500 x 1250 mm): a part whose unrolled outline does not fit
        the sheet (less ``fit_margin`` all round) in any orientation is cut into the longest
        runs that do (a single panel that is still too large is left for :meth:`layout` to
        report). Pass the
        sheet you will nest on; ``None`` keeps whole strips.
    model_unit, unit : str
        One of ``mm, cm, m, in, ft``; the structure is scaled by ``model_unit -> unit``.
    tabs : bool
        Bend a butted end into a tab bolted to the plate it meets instead of a bracket, per
        joint where the assembly check on the parts around it proves it (default; issue 42,
        :mod:`.builder.tabs`). False keeps every bracket.

    Attributes
    ----------
    parts : list of Part
        In strip order; names ``F<family>-S<strip>-P<index>``.
    crossings : list of Crossing
        The slotted (egg-crate) nodes with both slot depths and ``required_clearance``; a
        ``UserWarning`` is issued when ``clearance`` is below it somewhere (folded or oblique
        plates that would collide).
    untrimmed_joints : list of (part name, node, reason)
        Part ends that meet the other plate too obliquely to be butt-trimmed, and splits at
        folds sharper than :data:`MITER_LIMIT` (square ends): they overlap there (warned).
    dropped_panels : list of (strip, structure edge, width)
        Degenerate panels left out (narrower than ``min_panel_width``; warned); ``strip`` is
        the part-id prefix ``F<family>-S<strip>``.
    coplanar_panels : list of (strip, structure edge, node, reason)
        End panels left out because they meet the plate they end against within about 12
        degrees (they lie along it, duplicate its fin and cannot be trimmed clear of it;
        warned); the strip then ends one node earlier, joined there as usual. Also panels of
        parts joined to nothing that pass through another part, and one panel of every pair of
        plates that cross or come within ``thickness + clearance`` of each other where no joint
        joins them (they share no node line; the cheaper one: a part's end panel, of the
        shorter strip), and one panel of every pair that blocks a part's path into place along
        every direction its joints allow (the cheaper one); ``reason`` names the other panel
        or part.
    held_crossings : list of :class:`~.builder.held.HeldCrossing`
        Egg-crate crossings the builder butted with brackets (or tabs) because the load path
        found a plate hung there loose (its way out of the slot dips, no fixing fits it): each
        names the plate, the plate it is now bolted to and why (warned; :mod:`.builder.held`).

    Examples
    --------
    >>> fs = FinSystem(structure, thickness=3.0, clearance=0.5, max_panels=6)  # doctest: +SKIP
    >>> fs.export_step("fins.step")                                           # doctest: +SKIP
    >>> lay = fs.layout(sheet=(2500, 1250)); lay.export_dxf("cut/sheet.dxf")  # doctest: +SKIP
    >>> fs.bill_of_materials("bom.csv", layout=lay)                            # doctest: +SKIP
    """

    def __init__(self, structure, thickness: float, *,
                 family_split: FamilySplit | str = FamilySplit.EGG_CRATE,
                 clearance: float = 0.5, slot_ratio: float = 0.5,
                 max_fold_angle: float = 60.0, max_panels: int | None = None,
                 max_part_length: float | None = None,
                 fit_sheet: tuple[float, float] | None = (2500.0, 1250.0), fit_margin: float = 10.0,
                 model_unit: str = "m", unit: str = "mm", min_panel_width: float | None = None,
                 min_crossing_angle: float = MIN_CROSSING_ANGLE,
                 max_crossing_fold: float = MAX_CROSSING_FOLD,
                 fixing_spacing: float | None = FIXING_SPACING, tabs: bool = True):
        self._check_common(thickness, clearance, model_unit, unit, max_panels)
        if not 0.0 < slot_ratio < 1.0:
            raise ValueError(f"slot_ratio must be in (0, 1), got {slot_ratio}")
        if not 0.0 < max_fold_angle < 180.0:
            raise ValueError(f"max_fold_angle must be in (0, 180) degrees, got {max_fold_angle}")
        self.structure = structure
        self.thickness = float(thickness)
        self.clearance = float(clearance)
        self.family_split = FamilySplit(family_split)
        self.slot_ratio = float(slot_ratio)
        self.max_fold_angle = float(max_fold_angle)
        if not 0.0 < min_crossing_angle <= 90.0:
            raise ValueError(f"min_crossing_angle must be in (0, 90] degrees, got {min_crossing_angle}")
        if not 0.0 <= max_crossing_fold < 90.0:
            raise ValueError(f"max_crossing_fold must be in [0, 90) degrees, got {max_crossing_fold}")
        self.min_crossing_angle = float(min_crossing_angle)
        self.max_crossing_fold = float(max_crossing_fold)
        self.max_panels = max_panels
        if max_part_length is not None and not max_part_length > 0:
            raise ValueError(f"max_part_length must be > 0, got {max_part_length}")
        self.max_part_length = max_part_length
        self._set_fit(fit_sheet, fit_margin)
        self._set_min_width(min_panel_width)
        if fixing_spacing is not None and not (np.isfinite(fixing_spacing) and fixing_spacing > 0):
            raise ValueError(f"fixing_spacing must be > 0 (or None: no fixings), got {fixing_spacing}")
        self.fixing_spacing = None if fixing_spacing is None else float(fixing_spacing)
        self.tabs = bool(tabs)
        self.model_unit, self.unit = model_unit, unit
        self.scale = UNIT_TO_MM[model_unit] / UNIT_TO_MM[unit]
        self.parts: list[Part] = []
        self._solids: dict | None = None
        self._unrolled: dict | None = None
        if len(structure.edges) == 0:
            raise ValueError("the support structure has no edges: nothing to fabricate")
        with _old_objects_frozen():
            Rebuilder(self).build_until_trimmed()
        self.__dict__.pop("_memo", None)        # only the rebuilds of this construction use it

    def _cached(self, fn, *args, **kw):
        """``fn(*args, **kw)`` of a pure joint kernel (butt trims, corners, connectors, sheet
        fits), remembered for the rebuilds of one :class:`FinSystem`
        (:class:`~.builder.memo.Memo`: :class:`~.builder.rebuild.Rebuilder` rebuilds the whole
        structure, and most ends and fits come out the same)."""
        return self.__dict__.setdefault("_memo", Memo())(fn, *args, **kw)

    @staticmethod
    def _check_common(thickness, clearance, model_unit, unit, max_panels):
        if not np.isfinite(thickness) or thickness <= 0:
            raise ValueError(f"thickness must be > 0, got {thickness}")
        if not np.isfinite(clearance) or clearance < 0:
            raise ValueError(f"clearance must be >= 0, got {clearance}")
        for u in (model_unit, unit):
            if u not in UNIT_TO_MM:
                raise ValueError(f"unknown unit {u!r}; use one of {sorted(UNIT_TO_MM)}")
        if max_panels is not None and max_panels < 1:
            raise ValueError(f"max_panels must be >= 1, got {max_panels}")

    def _set_min_width(self, min_panel_width) -> None:
        if min_panel_width is None:
            min_panel_width = self.thickness
        if not np.isfinite(min_panel_width) or min_panel_width < 0:
            raise ValueError(f"min_panel_width must be >= 0, got {min_panel_width}")
        self.min_panel_width = float(min_panel_width)

    def _set_fit(self, fit_sheet, fit_margin) -> None:
        if fit_sheet is not None:
            fit_sheet = tuple(float(x) for x in fit_sheet)
            if len(fit_sheet) != 2 or min(fit_sheet) <= 2 * fit_margin:
                raise ValueError(f"fit_sheet must be (width, height) larger than twice the margin "
                                 f"{fit_margin}; got {fit_sheet}")
        self.fit_sheet, self.fit_margin = fit_sheet, float(fit_margin)

    @classmethod
    def from_strips(cls, strips: Iterable, thickness: float, *, max_panels: int | None = None,
                    max_part_length: float | None = None,
                    fit_sheet: tuple[float, float] | None = (2500.0, 1250.0), fit_margin: float = 10.0,
                    max_fold_angle: float = 179.0, model_unit: str = "m", unit: str = "mm",
                    family: int = -1, min_panel_width: float | None = None) -> "FinSystem":
        """Parts from free strips of quads, e.g. the developables of ``refine_developable``.

        ``strips`` are :class:`~torsal.geometry.support.FinStrip` objects or (k, 4, 3) arrays
        of quads ``p0 p1 p2 p3`` with ``p1 p2`` of one quad equal to ``p0 p3`` of the next.
        They are thickened and unrolled like fins, without slots or trimming. Folds sharper
        than ``min(max_fold_angle, MITER_LIMIT)`` split the strip; degenerate panels are
        dropped (see ``min_panel_width`` of :class:`FinSystem`).
        """
        self = cls.__new__(cls)
        cls._check_common(thickness, 0.0, model_unit, unit, max_panels)
        self.structure = None
        self.thickness, self.clearance = float(thickness), 0.0
        self.family_split = FamilySplit.EGG_CRATE
        self.slot_ratio, self.max_fold_angle, self.max_panels = 0.5, float(max_fold_angle), max_panels
        self.max_part_length = max_part_length
        self._set_fit(fit_sheet, fit_margin)
        self._set_min_width(min_panel_width)
        self.fixing_spacing = None          # free strips: no design surface to fix them to
        self.tabs = False                   # (their splits at sharp folds have no bracket)
        self.model_unit, self.unit = model_unit, unit
        self.scale = UNIT_TO_MM[model_unit] / UNIT_TO_MM[unit]
        self.crossings, self.parts, self.untrimmed_joints = [], [], []
        self.dropped_panels, self.slot_conflicts, self.oversize_panels = [], [], []
        self._oversize = []
        self.unslotted_solids = []
        self._solids = self._unrolled = None
        self.min_crossing_angle, self.max_crossing_fold = MIN_CROSSING_ANGLE, MAX_CROSSING_FOLD
        init_joints(self)
        self.coplanar_panels = []
        free = FreeStrips(self)
        quads_of = free.cut_strips(strips, family)
        free.cut._warn_dropped()
        free.butt_folds(quads_of)
        free.ends._warn_untrimmed(stacklevel=3)
        self.__dict__.pop("_memo", None)
        return self

    @property
    def split_angle(self) -> float:
        """Degrees: folds sharper than this split a strip (``min(max_fold_angle, MITER_LIMIT)``)."""
        return min(self.max_fold_angle, MITER_LIMIT)

    # ------------------------------------------------------------------ the phases' hooks
    def _drop_mask(self, quads: np.ndarray) -> np.ndarray:
        """Panels of a strip too degenerate to fabricate (:meth:`StripCutter._drop_mask`)."""
        return StripCutter(self)._drop_mask(quads)

    def _clashing_panels(self, *, leaving: set = frozenset()) -> list[tuple]:
        """Panels of plates that run into each other without a joint
        (:meth:`~.builder.clash.ClashFinder._clashing_panels`)."""
        return ClashFinder(self)._clashing_panels(leaving=leaving)

    def _check_paths(self) -> None:
        """Every part's direction into place on a clear path, or listed as blocked
        (:meth:`~.builder.paths.AssemblyPlanner._check_paths`)."""
        AssemblyPlanner(self)._check_paths()

    # ------------------------------------------------------------------ access
    def part(self, name: str) -> Part:
        """The part called ``name`` (e.g. ``"F0-S002-P00"``)."""
        for p in self.parts:
            if p.name == name:
                return p
        raise KeyError(f"no part {name!r}")

    @property
    def n_panels(self) -> int:
        """Fin panels in the plates (connectors and fixings not counted)."""
        return int(sum(len(p.panels) for p in self.plates))

    @property
    def plates(self) -> list[Part]:
        """The fin plates (every part but the connectors and fixings)."""
        return [p for p in self.parts if p.family not in (CONNECTOR_FAMILY, FIXING_FAMILY)]

    @property
    def connectors(self) -> list[Part]:
        """The connector parts (brackets, splice plates), named ``C-N<node>-<i>``."""
        return [p for p in self.parts if p.family == CONNECTOR_FAMILY]

    @property
    def fixings(self) -> list[Part]:
        """The fixings (angles that fix the plates to the building), named ``A-E<edge>-<i>``."""
        return [p for p in self.parts if p.family == FIXING_FAMILY]

    def __repr__(self) -> str:
        return (f"FinSystem({len(self.parts)} parts, {self.n_panels} panels, "
                f"{len(self.crossings)} crossings, {len(self.connectors)} connectors, "
                f"{len(self.fixings)} fixings, t={self.thickness:g} {self.unit})")

    # ------------------------------------------------------------------ solids (solids.py)
    def solids(self, *, repair: bool = True, workers: int | None = None) -> dict:
        """``{part name: build123d.Solid}``, built once and cached; ``workers`` processes
        build them in parallel (default: one per core); see
        :func:`torsal.fabrication.solids.build_solids`."""
        if self._solids is None:
            pending, self._pending = getattr(self, "_pending", None), None
            self._solids = _solids.build_solids(self, repair=repair, workers=workers,
                                                pending=pending)
        return self._solids

    def start_solids(self, *, workers: int | None = None) -> bool:
        """Start building the solids in worker processes and return at once, so that this
        process can unroll, nest and write the sheets meanwhile; :meth:`solids` (and the
        exports) then collect them. False if there is nothing to start (built already, or
        one worker: they are built when asked for); see
        :func:`torsal.fabrication.solids.start_solids`."""
        if self._solids is not None or getattr(self, "_pending", None) is not None:
            return False
        self._pending = _solids.start_solids(self, workers=workers)
        return self._pending is not None

    def cancel_solids(self) -> None:
        """Drop a build started by :meth:`start_solids` (e.g. when a later step failed), and
        the 3DM's Breps its workers may still be making."""
        pending, self._pending = getattr(self, "_pending", None), None
        if pending is not None:
            pending.cancel()
        _solids.cancel_breps(self)

    def export_step(self, path) -> "object":
        """One STEP assembly with a named, coloured solid per part (``unit``)."""
        return _solids.export_step(self, path)

    def export_stl(self, path, *, tolerance: float | None = None):
        """Preview mesh of all parts as STL (through trimesh)."""
        return _solids.export_mesh(self, path, file_type="stl", tolerance=tolerance)

    def export_gltf(self, path, *, tolerance: float | None = None):
        """Preview scene as glTF binary (``.glb``) with a coloured node per part."""
        return _solids.export_mesh(self, path, file_type="glb", tolerance=tolerance)

    def export_3dm(self, path, *, tolerance: float | None = None):
        """Rhino ``.3dm`` with one named mesh object per part on a layer per family."""
        return _solids.export_3dm(self, path, tolerance=tolerance)

    def export_ifc(self, path, **options):
        """IFC4 for BIM tools: an ``IfcPlate`` per part named as in parts.csv, strips as
        ``IfcElementAssembly``, bolts and anchors as ``IfcMechanicalFastener``, material
        layer sets and torsal's property sets (``unit`` is the project's length unit); see
        :func:`torsal.fabrication.ifc.export_ifc` for the keyword-only ``options`` (site,
        material, ...).

        >>> fs.export_ifc("fins.ifc", latitude=48.21, longitude=16.37)   # doctest: +SKIP
        """
        return _ifc.export_ifc(self, path, **options)

    def start_ifc(self, path, **options):
        """:meth:`export_ifc` in a process of its own: collects the solids, then returns at once
        a :class:`~torsal.fabrication.ifc.PendingIfc` whose ``result()`` is ``path``, written
        (this process writes the STEP file meanwhile); the same file as :meth:`export_ifc`.

        >>> pending = fs.start_ifc("fins.ifc", latitude=48.21, longitude=16.37)  # doctest: +SKIP
        >>> fs.export_step("fins.step"); pending.result()                     # doctest: +SKIP
        PosixPath('fins.ifc')
        """
        return _ifc.start_export_ifc(self, path, **options)

    # ------------------------------------------------------------------ unrolling, layout
    def unrolled(self) -> dict:
        """``{part name: Unrolled}`` for every part (cached); see :func:`unroll`."""
        if self._unrolled is None:
            self._unrolled = {p.name: unroll(p) for p in self.parts}
        return self._unrolled

    def layout(self, *, sheet: tuple[float, float] = (2500.0, 1250.0), gap: float = 5.0,
               margin: float = 10.0, rotations: Sequence[float] = (0, 90, 180, 270), **options):
        """Nest the unrolled parts on sheets (``unit``); see
        :func:`torsal.fabrication.nesting.nest_parts` for ``options`` (``nester``, ``cutting``,
        ``time_limit``, ``seed``, ...). By default the fast bottom-left nester, the connectors
        in rows after the plates."""
        return nest_parts(self.unrolled(), **self._nest_options(sheet, gap, margin, rotations, options))

    def _nest_options(self, sheet, gap, margin, rotations, options: dict) -> dict:
        """The keyword arguments of :func:`~torsal.fabrication.nesting.nest_parts` for this
        fin system's parts (connectors and fixings named, its unit)."""
        return dict(connectors={p.name for p in self.connectors + self.fixings}, sheet=sheet,
                    gap=gap, margin=margin, rotations=rotations, unit=self.unit, **options)

    def start_layout(self, *, sheet: tuple[float, float] = (2500.0, 1250.0), gap: float = 5.0,
                     margin: float = 10.0, rotations: Sequence[float] = (0, 90, 180, 270), **options):
        """:meth:`layout` in a process of its own: returns at once a
        :class:`~torsal.fabrication.nesting.background.PendingNesting` whose ``result()`` is
        the layout (this process writes the solids' files meanwhile); with ``dxf`` (a path)
        the sheets are written there too (``.sheets``)."""
        from .nesting.background import start_nesting

        progress, dxf = options.pop("progress", None), options.pop("dxf", None)
        return start_nesting(self.unrolled(), progress=progress, dxf=dxf,
                             **self._nest_options(sheet, gap, margin, rotations, options))

    def bill_of_materials(self, path, *, density: float = 2700.0, layout=None):
        """CSV parts list; see :func:`torsal.fabrication.layout.bill_of_materials`."""
        return _layout.bill_of_materials(self, path, density=density, layout=layout)
