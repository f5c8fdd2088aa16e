"""Parts of a fin system: strips of planar fins grouped into buildable plates (issue 6).

A :class:`FinSystem` reads a :class:`~torsal.geometry.support.SupportStructure` and groups its
fins (one planar quad ``a_i a_j b_j b_i`` per edge) into *parts*:

* by default (``family_split="egg-crate"``) every strip of either torsal family is one part, a
  folded plate of planar panels hinged on the node lines ``L_i = a_i b_i``. Where a strip of
  family 0 crosses a strip of family 1 (a node that is interior to a strip of both families),
  the two plates interlock with half-depth slots: the family-0 plate is slotted from its ``b``
  edge, the family-1 plate from its ``a`` edge, depths adding up to the fin depth
  ``|b_i - a_i|``, widths ``thickness + clearance``, centred on the node line.
* with ``family_split="family0-continuous"`` the strips of family 0 are continuous plates and
  family 1 is cut into single panels between them (no slots; they butt against family 0).

Where a strip ends against a plate of the other family (a T or L junction on the boundary)
its end panel is trimmed back until its end face clears the faces of that plate (both panels
of it, if it folds there) by ``clearance/2``, so solids never overlap. Panels meeting at a fold
sharper than ``max_fold_angle`` are split into separate parts before anything is mitred: the
later part is butt-trimmed against the square end of the earlier one (a fold that doubles back,
or one at an egg-crate crossing, keeps square ends and is listed in ``untrimmed_joints``).
Strips with more than ``max_panels`` panels, longer than ``max_part_length`` along their ``a``
and ``b`` edges, or whose unrolled outline does not fit ``fit_sheet`` (halved until it does) are
split too; closed strips are always cut into at least two parts. Those splits meet on the
bisector plane of the fold (mitred), with half slots if the split node is a crossing.

Real structures from the remesher have defects near boundaries and at coarse resolution; they
are handled and reported (``warnings.warn`` naming parts, nodes and what to do), never turned
into NaN or invalid solids: degenerate panels (narrower than ``min_panel_width`` or
self-intersecting) are dropped and their strip split there (``dropped_panels``); butt trims
without a solution are skipped (``untrimmed_joints``); slots that would cut a part in two are
made shallower, the partner's slot deeper (``slot_conflicts``); single panels larger than
``fit_sheet`` are named (``oversize_panels``; :meth:`FinSystem.layout` refuses them).

Units: the structure is in ``model_unit`` (metres by default); every length held by a
:class:`FinSystem` (``thickness``, ``clearance``, panel coordinates, slots, solids, sheets,
DXF) is in ``unit`` (millimetres by default).

Example
-------
>>> from torsal.fabrication import FinSystem
>>> fs = FinSystem(structure, thickness=3.0, clearance=0.5)        # doctest: +SKIP
>>> fs.parts[0].name, len(fs.parts[0].panels)                      # doctest: +SKIP
('F0-S000-P00', 3)
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from enum import Enum
from typing import Iterable, Sequence

import numpy as np

__all__ = [
    "FamilySplit", "SlotSide", "PartId", "Slot", "Crossing", "Part", "FinSystem",
    "UNIT_TO_MM", "INSUNITS", "FAMILY_COLORS", "fold_angles", "quad_normals",
]

from torsal.core.units import INSUNITS, UNIT_TO_MM

#: RGB colours (0..1) by family: family 0 orange, family 1 blue, developables green
FAMILY_COLORS = {0: (0.93, 0.55, 0.14), 1: (0.16, 0.45, 0.78), -1: (0.30, 0.65, 0.30)}


class FamilySplit(str, Enum):
    """How the two families of fins are grouped into parts."""

    EGG_CRATE = "egg-crate"
    FAMILY0_CONTINUOUS = "family0-continuous"


class SlotSide(str, Enum):
    """The edge of a fin a slot is cut from: ``a`` (design surface side) or ``b``."""

    A = "a"
    B = "b"


@dataclass(frozen=True, order=True)
class PartId:
    """Stable part identity: ``family`` (0, 1; -1 for free developable strips), ``strip``
    (number of the strip within its family, in :meth:`SupportStructure.fins` order) and
    ``index`` (number of the part along the strip)."""

    family: int
    strip: int
    index: int

    def __str__(self) -> str:
        fam = "D" if self.family < 0 else f"F{self.family}"
        return f"{fam}-S{self.strip:03d}-P{self.index:02d}"


@dataclass(frozen=True)
class Slot:
    """An egg-crate slot of a part, centred on the node line at ``position``.

    Attributes
    ----------
    node : int
        Structure node index (-1 for free strips).
    position : int
        Index of the node line along the part: 0 is the start edge of panel 0, ``k`` the
        end edge of panel ``k-1``; in between it is the fold between panels ``k-1`` and ``k``.
    side : SlotSide
        The slot is open on the ``a`` or ``b`` edge.
    depth : float
        Length of the slot along the node line from its open end (``unit``).
    width : float
        ``thickness + clearance`` (``unit``).
    partner : str
        Name of the crossing part(s) of the other family.
    """

    node: int
    position: int
    side: SlotSide
    depth: float
    width: float
    partner: str = ""


@dataclass(frozen=True)
class Crossing:
    """A node where a strip of family 0 and one of family 1 interlock (egg-crate).

    ``depth`` is the fin depth ``|b_i - a_i|`` (``unit``); ``depth0`` is the slot depth of the
    family-0 part(s) (from the ``b`` edge), ``depth1`` that of family 1 (from the ``a`` edge);
    ``width = thickness + clearance``. ``required_clearance`` is the clearance the two plates
    need to pass each other: 0 for flat plates crossing at right angles, more where a plate
    folds at the node (by ``theta``) or the plates cross obliquely (at ``alpha``):
    ``t (1/cos(theta/2) + tan(theta/2)) / sin(alpha) - t``.
    """

    node: int
    parts0: tuple[str, ...]
    parts1: tuple[str, ...]
    depth: float
    depth0: float
    depth1: float
    width: float
    required_clearance: float = 0.0


def quad_normals(quads: np.ndarray) -> np.ndarray:
    """Unit Newell normals of quads (k, 4, 3) -> (k, 3)."""
    q = np.asarray(quads, dtype=float)
    n = np.cross(q[:, 2] - q[:, 0], q[:, 3] - q[:, 1])
    nn = np.linalg.norm(n, axis=1, keepdims=True)
    if (nn <= 0).any():
        raise ValueError("degenerate fin quad (zero area)")
    return n / nn


def fold_angles(quads: np.ndarray) -> np.ndarray:
    """Signed dihedral (fold) angles between consecutive quads of a strip, radians, (k-1,).

    The angle turns the normal of panel ``k`` into that of panel ``k+1`` about the fold axis
    ``a_j -> b_j`` (right-hand rule); 0 is flat. Viewed from the ``+normal`` side (the top of
    the unrolled part) a positive angle is a mountain fold, a negative one a valley fold.
    """
    q = np.asarray(quads, dtype=float)
    if len(q) < 2:
        return np.zeros(0)
    n = quad_normals(q)
    axis = q[:-1, 2] - q[:-1, 1]
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    s = np.einsum("ij,ij->i", np.cross(n[:-1], n[1:]), axis)
    c = np.einsum("ij,ij->i", n[:-1], n[1:])
    return np.arctan2(s, c)


#: degrees: folds sharper than this are never mitred (the mitre vector grows as
#: ``1/cos(fold/2)``): such folds always split the strip, and the two parts get square ends
#: there (listed in ``FinSystem.untrimmed_joints``: they overlap near the fold)
MITER_LIMIT = 170.0


def _safe_normals(quads: np.ndarray) -> np.ndarray:
    """Unit Newell normals (k, 3); NaN rows for zero-area quads (never raises)."""
    q = np.asarray(quads, dtype=float)
    n = np.cross(q[:, 2] - q[:, 0], q[:, 3] - q[:, 1])
    nn = np.linalg.norm(n, axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(nn > 0, n / np.where(nn > 0, nn, 1.0), np.nan)


def _fold_deg(n1: np.ndarray, n2: np.ndarray) -> float:
    """Unsigned fold angle between two unit normals, degrees (NaN if either is NaN)."""
    return float(np.degrees(np.arccos(np.clip(n1 @ n2, -1.0, 1.0))))


def panel_widths(quads: np.ndarray) -> np.ndarray:
    """Narrowest width of every quad (k,): area over its longest edge (``unit``). A sliver
    panel (its ``a`` edge nearly along the node lines, or all edges tiny) has width ~0."""
    q = np.asarray(quads, dtype=float)
    area = 0.5 * np.linalg.norm(np.cross(q[:, 2] - q[:, 0], q[:, 3] - q[:, 1]), axis=1)
    edges = np.linalg.norm(q - np.roll(q, -1, axis=1), axis=2).max(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(edges > 0, area / np.where(edges > 0, edges, 1.0), 0.0)
    return np.where(np.isfinite(w), w, 0.0)


def _bowtie(quads: np.ndarray) -> np.ndarray:
    """Self-intersecting (bow-tie) quads (k,) bool: two corners turn against the normal."""
    q = np.asarray(quads, dtype=float)
    n = _safe_normals(q)
    e = np.roll(q, -1, axis=1) - q                       # edge i: corner i -> i+1
    turn = np.einsum("kij,kj->ki", np.cross(e, np.roll(e, -1, axis=1)), np.nan_to_num(n))
    return (turn < 0).sum(axis=1) >= 2


class _Untrimmable(Exception):
    """A part end that cannot be butt-trimmed (too shallow an angle, too short a panel)."""


def _oriented_size(poly) -> tuple[float, float]:
    """Side lengths (long, short) of the minimum rotated rectangle of a shapely polygon."""
    rect = np.asarray(poly.minimum_rotated_rectangle.exterior.coords)[:4]
    a = np.linalg.norm(rect[1] - rect[0])
    b = np.linalg.norm(rect[2] - rect[1])
    return max(a, b), min(a, b)


def _miter(n1: np.ndarray, n2: np.ndarray) -> np.ndarray:
    """Vector m with m.n1 = m.n2 = 1: offsets along it stay on both offset planes."""
    c = float(n1 @ n2)
    if c <= -0.999:
        raise ValueError("fold of nearly 180 degrees: cannot miter")
    return (n1 + n2) / (1.0 + c)


@dataclass
class Part:
    """One buildable plate: a chain of planar panels folded on node lines.

    Attributes
    ----------
    id : PartId
    panels : (k, 4, 3) float
        Panel quads ``a_i a_j b_j b_i`` in ``unit`` (after end trimming), consecutive
        panels share the fold line.
    nodes : (k+1,) int
        Structure node of every node line along the part (-1 for free strips).
    edges : (k,) int
        Structure edge of every panel (-1 for free strips).
    slots : list of Slot
    miters : (k+1, 3) float
        Offset vectors at every node line: the faces of the thickened plate are at
        ``p +- thickness/2 * miters[j]`` (mitred folds, end caps square or along the plate
        they butt against).
    trimmed : (2,) bool
        Whether the start / end panel was trimmed against a crossing plate.
    color : (3,) float
    span : (lo, hi)
        Panels ``lo..hi-1`` of the strip this part was cut from.
    """

    id: PartId
    panels: np.ndarray
    nodes: np.ndarray
    edges: np.ndarray
    slots: list = field(default_factory=list)
    miters: np.ndarray | None = None
    trimmed: tuple = (False, False)
    color: tuple = (0.5, 0.5, 0.5)
    span: tuple = (0, 0)
    #: how the start / end of the part is made: ``"end"`` (end of the strip), ``"miter"``
    #: (split inside the strip, e.g. by ``max_panels``, mitred on the fold's bisector plane),
    #: ``"fold"`` (split at a fold sharper than ``max_fold_angle``, or one too sharp to mitre:
    #: never mitred; the start of the later part is butt-trimmed against the earlier one, or
    #: square and listed in ``untrimmed_joints``) or ``"dropped"`` (next to a dropped
    #: degenerate panel: square end, trimmed like a strip end)
    ends: tuple = ("end", "end")

    @property
    def name(self) -> str:
        return str(self.id)

    @property
    def family(self) -> int:
        return self.id.family

    @property
    def normals(self) -> np.ndarray:
        return quad_normals(self.panels)

    @property
    def fold_angles(self) -> np.ndarray:
        """Signed fold angles between consecutive panels, radians (see :func:`fold_angles`)."""
        return fold_angles(self.panels)

    @property
    def panel_areas(self) -> np.ndarray:
        """Area of every panel (``unit``^2), from the Newell normal (exact for planar quads)."""
        q = self.panels
        return 0.5 * np.linalg.norm(np.cross(q[:, 2] - q[:, 0], q[:, 3] - q[:, 1]), axis=1)

    @property
    def size(self) -> float:
        """Diagonal of the bounding box of the part (``unit``)."""
        p = self.panels.reshape(-1, 3)
        return float(np.linalg.norm(p.max(0) - p.min(0)))

    def __repr__(self) -> str:
        return f"Part({self.name}, panels={len(self.panels)}, slots={len(self.slots)})"


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
        the sheet (less ``fit_margin`` all round) in any orientation is halved until it does (a
        single panel that is still too large is left for :meth:`layout` to report). Pass the
        sheet you will nest on; ``None`` keeps whole strips.
    model_unit, unit : str
        One of ``mm, cm, m, in, ft``; the structure is scaled by ``model_unit -> unit``.

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
                 model_unit: str = "m", unit: str = "mm", min_panel_width: float | None = None):
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
        self.max_panels = max_panels
        if max_part_length is not None and not max_part_length > 0:
            raise ValueError(f"max_part_length must be > 0, got {max_part_length}")
        self.max_part_length = max_part_length
        self._set_fit(fit_sheet, fit_margin)
        self._set_min_width(min_panel_width)
        self.model_unit, self.unit = model_unit, unit
        self.scale = UNIT_TO_MM[model_unit] / UNIT_TO_MM[unit]
        #: degenerate panels dropped: (part-id prefix of the strip, structure edge, width)
        self.dropped_panels: list[tuple[str, int, float]] = []
        #: parts whose solid could not be slotted by OpenCascade: (name, slot nodes, reason)
        self.unslotted_solids: list[tuple[str, list, str]] = []
        #: slots made shallower or left out: (part name, node, old depth, new depth, partner note)
        self.slot_conflicts: list[tuple[str, int, float, float, str]] = []
        #: parts of one panel that do not fit ``fit_sheet`` (warned; :meth:`layout` will refuse)
        self.oversize_panels: list[str] = []
        self._oversize: list[int] = []
        self.crossings: list[Crossing] = []
        #: part ends that could not be butt-trimmed: (part name, node, reason)
        self.untrimmed_joints: list[tuple[str, int, str]] = []
        self.parts: list[Part] = []
        self._solids: dict | None = None
        self._unrolled: dict | None = None
        if len(structure.edges) == 0:
            raise ValueError("the support structure has no edges: nothing to fabricate")
        self._build_from_structure()

    # ------------------------------------------------------------------ construction
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

    def _drop_mask(self, quads: np.ndarray) -> np.ndarray:
        """Panels too narrow, of zero area or self-intersecting (bow-tie: the node lines cross
        inside the fin) to be fabricated."""
        w = panel_widths(quads)
        tol = 1e-9 * max(1.0, float(np.abs(quads).max()))
        return ((w <= tol) | (w < self.min_panel_width) | _bowtie(quads)
                | ~np.isfinite(_safe_normals(quads)).all(axis=1))

    def _miter_ok(self, n1, n2, w1, w2) -> bool:
        """A fold can be mitred: at most MITER_LIMIT, and the bevel ``t/2 tan(fold/2)`` (how far
        the mitre shifts the faces of the plate across the node line) is at most a tenth of
        the narrowest width (:func:`panel_widths`) of both panels; beyond that the faces of a
        narrow, slanted panel twist too much (or cross) for a sound solid."""
        ang = _fold_deg(n1, n2)
        if not ang <= MITER_LIMIT:
            return False
        return 0.5 * self.thickness * np.tan(np.radians(ang) / 2) <= 0.1 * min(w1, w2)

    def _warn_dropped(self) -> None:
        if self.dropped_panels:
            d = self.dropped_panels
            warnings.warn(
                f"{len(d)} degenerate fin panels (narrower than min_panel_width="
                f"{self.min_panel_width:g} {self.unit}, or self-intersecting) were dropped (their "
                f"strips are split there): "
                + "; ".join(f"{s} edge {e} ({w:.3g} {self.unit} wide)" for s, e, w in d[:8])
                + (" ..." if len(d) > 8 else "") + "; see FinSystem.dropped_panels. Remesh more "
                "finely or move the boundary if these fins are needed", stacklevel=3)

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
        self.model_unit, self.unit = model_unit, unit
        self.scale = UNIT_TO_MM[model_unit] / UNIT_TO_MM[unit]
        self.crossings, self.parts, self.untrimmed_joints = [], [], []
        self.dropped_panels, self.slot_conflicts, self.oversize_panels = [], [], []
        quads_of: dict[int, np.ndarray] = {}
        self._oversize = []
        self.unslotted_solids = []
        self._solids = self._unrolled = None
        for s, st in enumerate(strips):
            q = np.asarray(getattr(st, "quads", st), dtype=float) * self.scale
            fam = int(family)
            if q.ndim != 3 or q.shape[1:] != (4, 3) or len(q) == 0:
                raise ValueError(f"strip {s}: expected (k, 4, 3) quads, got {q.shape}")
            nodes = np.full(len(q) + 1, -1)
            edges = np.full(len(q), -1)
            drop = self._drop_mask(q)
            quads_of[s] = q
            prefix = str(PartId(fam, s, 0))[:-4]
            self.dropped_panels += [(prefix, int(i), float(w))
                                    for i, w in zip(np.flatnonzero(drop), panel_widths(q)[drop])]
            for index, (lo, hi) in enumerate(self._split_ranges(q, closed=False, drop=drop)):
                self.parts.append(self._make_part(PartId(fam, s, index), q, lo, hi, nodes, edges,
                                                  closed=False, drop=drop))
        if not self.parts:
            raise ValueError("no strips given: nothing to fabricate")
        self._warn_dropped()
        # splits at sharp folds: butt joints (the later part trimmed back), never mitred
        gap, h = 0.5 * self.thickness, 0.5 * self.thickness
        untrimmed: list[tuple[str, int, str]] = []
        by_strip: dict[int, list[Part]] = {}
        for p in self.parts:
            by_strip.setdefault(p.id.strip, []).append(p)
        for sidx, parts in by_strip.items():
            q = quads_of[sidx]
            for p in parts:
                if p.ends[0] == "fold":
                    trimmed = list(p.trimmed)
                    self._trim_fold(p, parts, q, -1, None, gap, h, untrimmed, trimmed)
                    p.trimmed = tuple(trimmed)
        self.untrimmed_joints = untrimmed
        self._warn_untrimmed(stacklevel=3)
        return self

    @property
    def split_angle(self) -> float:
        """Degrees: folds sharper than this split a strip (``min(max_fold_angle, MITER_LIMIT)``)."""
        return min(self.max_fold_angle, MITER_LIMIT)

    def _split_ranges(self, quads: np.ndarray, closed: bool,
                      drop: np.ndarray | None = None) -> list[tuple[int, int]]:
        """Panel ranges [lo, hi) of the parts of one strip (dropped panels left out)."""
        k = len(quads)
        drop = np.zeros(k, dtype=bool) if drop is None else np.asarray(drop, dtype=bool)
        cuts = {0, k}
        n = _safe_normals(quads)
        with np.errstate(invalid="ignore"):
            ang = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n[:-1], n[1:]), -1, 1)))
        cuts.update((np.flatnonzero(ang > self.split_angle) + 1).tolist())
        ext = panel_widths(quads)
        cuts.update(j for j in range(1, k) if not self._miter_ok(n[j - 1], n[j], ext[j - 1], ext[j]))
        for i in np.flatnonzero(drop).tolist():
            cuts.update((i, i + 1))
        if closed and k >= 2 and len(cuts) == 2:
            cuts.add(k // 2)
        cuts = sorted(cuts)
        out = []
        for lo, hi in zip(cuts[:-1], cuts[1:]):
            if drop[lo:hi].all():
                continue
            if self.max_panels and hi - lo > self.max_panels:
                nchunk = -(-(hi - lo) // self.max_panels)
                bounds = np.linspace(lo, hi, nchunk + 1).round().astype(int)
                out.extend(zip(bounds[:-1].tolist(), bounds[1:].tolist()))
            else:
                out.append((lo, hi))
        if self.max_part_length:
            la = np.linalg.norm(quads[:, 1] - quads[:, 0], axis=1)
            lb = np.linalg.norm(quads[:, 2] - quads[:, 3], axis=1)
            seg = np.maximum(la, lb)
            split = []
            for lo, hi in out:
                start, acc = lo, 0.0
                for i in range(lo, hi):
                    if acc + seg[i] > self.max_part_length and i > start:
                        split.append((start, i))
                        start, acc = i, 0.0
                    acc += seg[i]
                split.append((start, hi))
            out = split
        if self.fit_sheet is not None:
            self._oversize = []
            out = [r for lo, hi in out for r in self._fit(quads, lo, hi)]
        return out

    def _fit(self, quads: np.ndarray, lo: int, hi: int) -> list[tuple[int, int]]:
        """Halve [lo, hi) until the unrolled part fits ``fit_sheet`` (any orientation)."""
        if hi - lo <= 1:
            if not self._fits(quads[lo:hi]):
                self._oversize.append(lo)
            return [(lo, hi)]
        if self._fits(quads[lo:hi]):
            return [(lo, hi)]
        mid = (lo + hi) // 2
        return self._fit(quads, lo, mid) + self._fit(quads, mid, hi)

    def _fits(self, quads: np.ndarray) -> bool:
        from .unroll import unroll

        try:
            outline = unroll(quads, slots=[]).outline
        except ValueError:          # overlaps itself when unrolled: too long anyway
            return False
        w, h = _oriented_size(outline)
        sw, sh = sorted(self.fit_sheet, reverse=True)
        m = 2.0 * self.fit_margin
        return max(w, h) <= sw - m and min(w, h) <= sh - m

    def _make_part(self, pid: PartId, quads, lo, hi, nodes, edges, closed,
                   drop: np.ndarray | None = None) -> Part:
        """Part of panels [lo, hi) of a strip, with mitred folds (also across part splits, up
        to a fold of MITER_LIMIT; square ends at sharper folds, next to dropped panels and at
        the strip ends)."""
        q = quads[lo:hi].copy()
        n_all = _safe_normals(quads)
        k = len(quads)
        drop = np.zeros(k, dtype=bool) if drop is None else np.asarray(drop, dtype=bool)
        ext = panel_widths(quads)
        miters = np.empty((hi - lo + 1, 3))
        ends = ["end", "end"]
        for j in range(lo, hi + 1):
            left = j - 1 if j > 0 else (k - 1 if closed else None)
            right = j if j < k else (0 if closed else None)
            end = 0 if j == lo else (1 if j == hi else None)
            if end is not None and left is not None and right is not None:
                other = left if end == 0 else right
                if drop[other]:
                    ends[end] = "dropped"
                elif (_fold_deg(n_all[left], n_all[right]) > self.split_angle or
                      not self._miter_ok(n_all[left], n_all[right], ext[left], ext[right])):
                    ends[end] = "fold"
                else:
                    ends[end] = "miter"
                if ends[end] != "miter":
                    left, right = (None, right) if end == 0 else (left, None)
            if left is None:
                m = n_all[right]
            elif right is None:
                m = n_all[left]
            else:
                m = _miter(n_all[left], n_all[right])
            miters[j - lo] = m
        return Part(id=pid, panels=q, nodes=np.asarray(nodes[lo:hi + 1]).copy(),
                    edges=np.asarray(edges[lo:hi]).copy(), miters=miters, span=(lo, hi),
                    color=FAMILY_COLORS.get(pid.family, FAMILY_COLORS[-1]), ends=tuple(ends))

    def _warn_untrimmed(self, stacklevel: int = 4) -> None:
        untrimmed = self.untrimmed_joints
        if untrimmed:
            warnings.warn(
                f"{len(untrimmed)} part ends could not be butt-trimmed (or mitred) against the adjoining "
                f"plate and overlap it: " + "; ".join(f"{n} at node {v} ({w})" for n, v, w in untrimmed[:6])
                + (" ..." if len(untrimmed) > 6 else "") + "; see FinSystem.untrimmed_joints",
                stacklevel=stacklevel)

    def _build_from_structure(self) -> None:
        st = self.structure
        t, c = self.thickness, self.clearance
        strips = st.fins()
        a = st.vertices_a * self.scale
        b = st.vertices_b * self.scale
        depth = np.linalg.norm(b - a, axis=1)
        used_nodes = np.unique(st.edges)
        if (depth[used_nodes] <= 1e-12 * max(1.0, float(np.abs(a).max()))).any():
            bad = used_nodes[depth[used_nodes] <= 1e-12 * max(1.0, float(np.abs(a).max()))]
            raise ValueError(f"nodes {bad[:10].tolist()} have zero fin depth (a_i == b_i)")
        strip_quads = [fs.quads * self.scale for fs in strips]
        drops = [self._drop_mask(q) for q in strip_quads]
        # how each family is present at each node: passes through (two kept panels of a strip
        # meet there) or ends there (one kept panel)
        n = len(a)
        passes = np.zeros((2, n), dtype=bool)
        ends = np.zeros((2, n), dtype=bool)
        for fs, drop in zip(strips, drops):
            v = np.asarray(fs.vertices)
            k = len(drop)
            for j in range(len(v)):
                if fs.closed and j == k:
                    continue
                left = j - 1 if j > 0 else (k - 1 if fs.closed else None)
                right = j if j < k else None
                cnt = sum(1 for i in (left, right) if i is not None and not drop[i])
                if cnt == 2:
                    passes[fs.family, v[j]] = True
                elif cnt == 1:
                    ends[fs.family, v[j]] = True
        present = passes | ends
        # parts
        strip_no = {0: 0, 1: 0}
        part_of_strip: list[list[Part]] = []
        dropped, oversize = [], []
        for fs, q, drop in zip(strips, strip_quads, drops):
            fam = fs.family
            ranges = self._split_ranges(q, fs.closed, drop)
            if self.family_split == FamilySplit.FAMILY0_CONTINUOUS and fam == 1:
                # family 1 is cut at every node where a family-0 plate is
                cuts = sorted({0, len(q)} | {j for j in range(1, len(q))
                                             if present[0, fs.vertices[j]]} |
                              {x for r in ranges for x in r})
                ranges = [(lo, hi) for lo, hi in zip(cuts[:-1], cuts[1:]) if not drop[lo:hi].all()]
            sn = strip_no[fam]
            strip_no[fam] += 1
            prefix = str(PartId(fam, sn, 0))[:-4]
            dropped += [(prefix, int(fs.edges[i]), float(w))
                        for i, w in zip(np.flatnonzero(drop), panel_widths(q)[drop])]
            parts = [self._make_part(PartId(fam, sn, i), q, lo, hi, fs.vertices, fs.edges, fs.closed,
                                     drop)
                     for i, (lo, hi) in enumerate(ranges)]
            over = set(self._oversize) if self.fit_sheet is not None else set()
            oversize += [p.name for p in parts if p.span[1] - p.span[0] == 1 and p.span[0] in over]
            part_of_strip.append(parts)
        self.dropped_panels = dropped
        self.oversize_panels = oversize
        self._warn_dropped()
        if oversize:
            warnings.warn(
                f"{len(oversize)} parts are ONE fin panel each and still larger than the "
                f"{self.fit_sheet[0]:g} x {self.fit_sheet[1]:g} {self.unit} sheet: {oversize[:8]}"
                + (" ..." if len(oversize) > 8 else "") + "; a single panel cannot be split: use a "
                "smaller fin spacing (finer remesh) or a larger sheet; see FinSystem.oversize_panels",
                stacklevel=3)
        # panels of each family's plate around each node: (normal, in-plane direction from the
        # node line into the panel), for trimming and slot clearances
        plate: dict[tuple[int, int], list[tuple[np.ndarray, np.ndarray]]] = {}
        for fs, q, drop in zip(strips, strip_quads, drops):
            nq = _safe_normals(q)
            for j, v in enumerate(fs.vertices):
                if fs.closed and j == len(nq):
                    continue
                adj = [i for i in (j - 1, j) if 0 <= i < len(nq)]
                if fs.closed and j == 0:
                    adj = [len(nq) - 1, 0]
                lst = plate.setdefault((fs.family, int(v)), [])
                for i in adj:
                    if drop[i]:
                        continue
                    line = b[v] - a[v]
                    line = line / np.linalg.norm(line)
                    into = q[i].mean(axis=0) - a[v]
                    into = into - (into @ line) * line
                    ni = np.linalg.norm(into)
                    if not ni > 1e-9 * depth[v]:
                        continue           # panel centre on the node line: no direction
                    lst.append((nq[i], into / ni))
        self._plate = plate

        # trimming of part ends against the dominant plate of the other family
        def dominant(fam: int, node: int) -> bool:
            other = 1 - fam
            if not present[other, node]:
                return False
            if self.family_split == FamilySplit.FAMILY0_CONTINUOUS:
                return fam == 1
            if passes[fam, node] and passes[other, node]:
                return False               # X crossing: slotted, not trimmed
            if passes[other, node]:
                return True                # T: this one ends against a through plate
            if passes[fam, node]:
                return False
            return fam == 1                # L: family 1 butts against family 0

        gap = 0.5 * t + 0.5 * c
        h = 0.5 * t
        untrimmed: list[tuple[str, int, str]] = []
        for si, (fs, parts) in enumerate(zip(strips, part_of_strip)):
            fam = fs.family
            for p in parts:
                trimmed = [False, False]
                for end, (j, (ia, ib), (ja, jb)) in enumerate(
                        ((0, (0, 3), (1, 2)), (len(p.panels) - 1, (1, 2), (0, 3)))):
                    node = int(p.nodes[0 if end == 0 else -1])
                    if p.ends[end] == "fold" and end == 0:
                        self._trim_fold(p, parts, strip_quads[si], node, passes, gap, h,
                                        untrimmed, trimmed)
                        continue
                    strip_end = p.ends[end] in ("end", "dropped")
                    f0c_cut = (self.family_split == FamilySplit.FAMILY0_CONTINUOUS and fam == 1
                               and present[0, node])
                    if not strip_end and not f0c_cut:
                        continue           # a split inside a strip: mitred joint, no trim
                    if not dominant(fam, node):
                        continue
                    quad = p.panels[j]
                    pa = a[node]
                    far = quad[[ja, jb]].mean(axis=0)
                    # the other plate's panels, normals turned towards this part
                    panels = [(nk if (far - pa) @ nk >= 0 else -nk, vk)
                              for nk, vk in plate.get((1 - fam, node), [])]
                    try:
                        nbar = sum((nk for nk, _ in panels), np.zeros(3))
                        if not np.linalg.norm(nbar) > 1e-6:
                            raise _Untrimmable("no usable panel of the other plate there")
                        nbar = nbar / np.linalg.norm(nbar)
                        npan = quad_normals(quad[None])[0]
                        d = npan @ nbar
                        if 1.0 - d * d < 0.04:
                            raise _Untrimmable(f"meets the plate at "
                                               f"{np.degrees(np.arccos(min(1.0, abs(d)))):.1f} deg")
                        # end cap along the other plate's mean plane: m.n_panel = 1, m.nbar = 0
                        m_end = (npan - d * nbar) / (1.0 - d * d)
                        moved = {cc: self._trim_corner(quad, cc, oc, panels, pa, m_end, gap, h)
                                 for cc, oc in ((ia, ja), (ib, jb))}
                    except _Untrimmable as why:
                        untrimmed.append((p.name, node, str(why)))
                        continue
                    if not all(np.isfinite(x).all() for x in moved.values()):
                        untrimmed.append((p.name, node, "trim failed (non-finite)"))
                        continue
                    for cc, x in moved.items():
                        quad[cc] = x
                    p.miters[0 if end == 0 else -1] = m_end
                    trimmed[end] = True
                p.trimmed = tuple(trimmed)
        self.parts = [p for parts in part_of_strip for p in parts]
        self.untrimmed_joints = untrimmed
        self._warn_untrimmed()
        # egg-crate slots at X crossings
        tight: list[tuple[int, float]] = []
        if self.family_split == FamilySplit.EGG_CRATE:
            at_node: dict[int, list[list[tuple[Part, int]]]] = {}
            for fs, parts in zip(strips, part_of_strip):
                for p in parts:
                    for pos, node in enumerate(p.nodes):
                        node = int(node)
                        if passes[0, node] and passes[1, node]:
                            at_node.setdefault(node, [[], []])[fs.family].append((p, pos))
            for node in sorted(at_node):
                l0, l1 = at_node[node]
                if not l0 or not l1:
                    continue
                d = float(depth[node])
                d0 = self.slot_ratio * d
                d1 = d - d0
                w = t + c
                need = self._required_width(node)
                if w < need - 1e-9 * t:
                    tight.append((node, need - t))
                names0 = tuple(sorted({p.name for p, _ in l0}))
                names1 = tuple(sorted({p.name for p, _ in l1}))
                for p, pos in l0:
                    p.slots.append(Slot(node, pos, SlotSide.B, d0, w, "+".join(names1)))
                for p, pos in l1:
                    p.slots.append(Slot(node, pos, SlotSide.A, d1, w, "+".join(names0)))
                self.crossings.append(Crossing(node, names0, names1, d, d0, d1, w, need - t))
            if tight:
                worst = max(x[1] for x in tight)
                warnings.warn(
                    f"{len(tight)} egg-crate crossings (nodes {[x[0] for x in tight[:8]]}...) need a "
                    f"clearance of up to {worst:.3g} {self.unit} for the folded or oblique plates to "
                    f"pass each other; with clearance={c:g} the slotted parts interfere there",
                    stacklevel=3)
        self.parts = [p for parts in part_of_strip for p in parts]
        names = [p.name for p in self.parts]
        assert len(set(names)) == len(names)
        self._fin_depth = depth
        self._resolve_slot_splits()

    def _resolve_slot_splits(self) -> None:
        """Slots that would cut a part in two (a narrow or slanted panel at the node: the slot
        band runs out of the panel) are made shallower, leaving a web of ``thickness``; the
        partner's slot is deepened by as much where that keeps it whole, else the two plates
        interfere there. A slot that cuts the part apart at any depth is left out. Each case
        is listed in ``slot_conflicts`` and warned about."""
        from dataclasses import replace

        from .unroll import unroll

        def whole(p: Part, slots) -> bool:
            try:
                unroll(p.panels, slots=list(slots), name=p.name)
            except ValueError as e:
                return "slots cut" not in str(e)
            return True

        conflicts: list[tuple[str, int, float, float, str]] = []
        for p in self.parts:
            if not p.slots or whole(p, p.slots):
                continue
            for s in list(p.slots):
                if whole(p, [s]):
                    continue
                i = p.slots.index(s)
                lo, hi = 0.0, s.depth
                if not whole(p, [replace(s, depth=1e-3 * s.depth)]):
                    new = 0.0
                else:
                    for _ in range(12):
                        mid = 0.5 * (lo + hi)
                        lo, hi = (mid, hi) if whole(p, [replace(s, depth=mid)]) else (lo, mid)
                    new = lo - self.thickness
                    if new <= 0.05 * s.depth:
                        new = 0.0
                if new > 0:
                    p.slots[i] = replace(s, depth=new)
                else:
                    del p.slots[i]
                # the partner(s) take the difference if they stay whole
                lack = s.depth - new
                notes = []
                for o in self.parts:
                    if o.family == p.family:
                        continue
                    for jo, so in enumerate(o.slots):
                        if so.node != s.node:
                            continue
                        deeper = replace(so, depth=min(so.depth + lack, float(self._fin_depth[s.node])))
                        trial = o.slots[:jo] + [deeper] + o.slots[jo + 1:]
                        if whole(o, trial):
                            o.slots[jo] = deeper
                            notes.append(f"{o.name} slotted {lack:.3g} deeper")
                        else:
                            notes.append(f"{o.name} cannot take it: the plates interfere by "
                                         f"{lack:.3g} {self.unit}")
                conflicts.append((p.name, s.node, float(s.depth), float(new),
                                  "; ".join(notes) or "no partner slot"))
        self.slot_conflicts = conflicts
        if conflicts:
            warnings.warn(
                f"{len(conflicts)} egg-crate slots would cut their part in two (narrow or slanted "
                f"panel at the node) and were made shallower or left out: "
                + "; ".join(f"{n} at node {v}: depth {d0:.3g} -> {d1:.3g} {self.unit} ({note})"
                            for n, v, d0, d1, note in conflicts[:6])
                + (" ..." if len(conflicts) > 6 else "") + "; see FinSystem.slot_conflicts",
                stacklevel=4)

    def _trim_fold(self, p: Part, parts, q, node, passes, gap, h, untrimmed, trimmed):
        """Butt joint at a split on a sharp fold: the start of part ``p`` is trimmed back until
        it clears the (square) end of the previous panel of the strip, or the joint is listed."""
        k = len(q)
        i_prev = p.span[0] - 1 if p.span[0] > 0 else k - 1
        prev = next((o for o in parts if o.span[1] == i_prev + 1), None)
        nprev = quad_normals(q[i_prev][None])[0]
        quad = p.panels[0]
        ang = _fold_deg(nprev, quad_normals(quad[None])[0])
        what = f"fold of {ang:.1f} deg to {prev.name if prev else 'the previous part'}"
        if passes is not None and passes[0, node] and passes[1, node]:
            untrimmed.append((p.name, node, f"{what} at an egg-crate crossing: square ends"))
            return
        pa = q[p.span[0] % k, 0]                   # a end of the node line (untrimmed)
        far = quad[[1, 2]].mean(axis=0)
        line = quad[3] - quad[0]
        line = line / np.linalg.norm(line)
        into = q[i_prev].mean(axis=0) - pa
        into = into - (into @ line) * line
        try:
            if not np.linalg.norm(into) > 0:
                raise _Untrimmable("the previous panel has no extent")
            panels = [(nprev if (far - pa) @ nprev >= 0 else -nprev, into / np.linalg.norm(into))]
            nbar = panels[0][0]
            npan = quad_normals(quad[None])[0]
            d = npan @ nbar
            if 1.0 - d * d < 0.04:
                raise _Untrimmable("too sharp to butt-trim: square ends overlap near the fold")
            m_end = (npan - d * nbar) / (1.0 - d * d)
            moved = {cc: self._trim_corner(quad, cc, oc, panels, pa, m_end, gap, h)
                     for cc, oc in ((0, 1), (3, 2))}
            if not all(np.isfinite(x).all() for x in moved.values()):
                raise _Untrimmable("trim failed (non-finite)")
        except _Untrimmable as why:
            untrimmed.append((p.name, node, f"{what}: {why}"))
            return
        for cc, x in moved.items():
            quad[cc] = x
        p.miters[0] = m_end
        trimmed[0] = True

    @staticmethod
    def _trim_corner(quad, cc, oc, panels, pa, m_end, gap, h) -> np.ndarray:
        """Corner ``cc`` of an end panel moved along its edge towards ``oc`` until the end face
        (``+-h m_end``) clears every panel of the crossing plate by ``gap`` from its mid-plane."""
        u = quad[oc] - quad[cc]
        L = np.linalg.norm(u)
        if not L > 0:
            raise _Untrimmable("its edge has zero length")
        u = u / L
        s_req = 0.0
        for _ in range(4):      # laterals move a little with the trim: iterate
            base = quad[cc] + s_req * u
            s_new = -np.inf
            for nk, vk in panels:
                cos = u @ nk
                if cos < 0.2:
                    raise _Untrimmable(f"its edge meets the plate at "
                                       f"{np.degrees(np.arcsin(np.clip(cos, -1, 1))):.1f} deg")
                pm, pp = base - h * m_end - pa, base + h * m_end - pa
                lm, lp = pm @ vk, pp @ vk
                pts = [x for x, l in ((pm, lm), (pp, lp)) if l >= 0 or len(panels) == 1]
                if (lm < 0) != (lp < 0):   # the end face crosses the fold line
                    pts.append(pm + (lm / (lm - lp)) * (pp - pm))
                for x in pts:
                    s_new = max(s_new, s_req + (gap - x @ nk) / cos)
            if not np.isfinite(s_new):
                raise _Untrimmable("its end does not lie over the other plate's panels")
            done = abs(s_new - s_req) <= 1e-12 * L
            s_req = s_new
            if done:
                break
        if s_req >= 0.5 * L:
            raise _Untrimmable(f"panel too short ({L:.3g}) to trim by {s_req:.3g}")
        return quad[cc] + s_req * u

    def _required_width(self, node: int) -> float:
        """Slot width for the plates of both families to pass at an X crossing."""
        t = self.thickness
        theta, means = 0.0, []
        for fam in (0, 1):
            lst = self._plate[(fam, node)]
            ns = [lst[0][0]] + [nk if nk @ lst[0][0] >= 0 else -nk for nk, _ in lst[1:]]
            if len(ns) > 1:
                theta = max(theta, float(np.arccos(np.clip(ns[0] @ ns[1], -1, 1))))
            mean = sum(ns)
            means.append(mean / np.linalg.norm(mean))
        sin_alpha = float(np.linalg.norm(np.cross(means[0], means[1])))
        if sin_alpha < 1e-6:
            raise ValueError(f"node {node}: the crossing plates are parallel; cannot slot them")
        return t * (1.0 / np.cos(theta / 2) + np.tan(theta / 2)) / sin_alpha

    # ------------------------------------------------------------------ access
    def part(self, name: str) -> Part:
        """The part called ``name`` (e.g. ``"F0-S002-P00"``)."""
        for p in self.parts:
            if p.name == name:
                return p
        raise KeyError(f"no part {name!r}")

    @property
    def n_panels(self) -> int:
        return int(sum(len(p.panels) for p in self.parts))

    def __repr__(self) -> str:
        return (f"FinSystem({len(self.parts)} parts, {self.n_panels} panels, "
                f"{len(self.crossings)} crossings, t={self.thickness:g} {self.unit})")

    # ------------------------------------------------------------------ solids (solids.py)
    def solids(self, *, repair: bool = True) -> dict:
        """``{part name: build123d.Solid}``, built once and cached; see
        :func:`torsal.fabrication.solids.build_solids`."""
        if self._solids is None:
            from .solids import build_solids

            self._solids = build_solids(self, repair=repair)
        return self._solids

    def export_step(self, path) -> "object":
        """One STEP assembly with a named, coloured solid per part (``unit``)."""
        from .solids import export_step

        return export_step(self, path)

    def export_stl(self, path, *, tolerance: float | None = None):
        """Preview mesh of all parts as STL (through trimesh)."""
        from .solids import export_mesh

        return export_mesh(self, path, file_type="stl", tolerance=tolerance)

    def export_gltf(self, path, *, tolerance: float | None = None):
        """Preview scene as glTF binary (``.glb``) with a coloured node per part."""
        from .solids import export_mesh

        return export_mesh(self, path, file_type="glb", tolerance=tolerance)

    def export_3dm(self, path, *, tolerance: float | None = None):
        """Rhino ``.3dm`` with one named mesh object per part on a layer per family."""
        from .solids import export_3dm

        return export_3dm(self, path, tolerance=tolerance)

    # ------------------------------------------------------------------ unrolling, layout
    def unrolled(self) -> dict:
        """``{part name: Unrolled}`` for every part (cached); see :func:`unroll`."""
        if self._unrolled is None:
            from .unroll import unroll

            self._unrolled = {p.name: unroll(p) for p in self.parts}
        return self._unrolled

    def layout(self, *, sheet: tuple[float, float] = (2500.0, 1250.0), gap: float = 5.0,
               margin: float = 10.0, rotations: Sequence[float] = (0, 90, 180, 270)):
        """Nest the unrolled parts on sheets (``unit``); see :func:`torsal.fabrication.layout.nest`."""
        from .layout import nest

        return nest(list(self.unrolled().values()), sheet=sheet, gap=gap, margin=margin,
                    rotations=rotations, unit=self.unit)

    def bill_of_materials(self, path, *, density: float = 2700.0, layout=None):
        """CSV parts list; see :func:`torsal.fabrication.layout.bill_of_materials`."""
        from .layout import bill_of_materials

        return bill_of_materials(self, path, density=density, layout=layout)
