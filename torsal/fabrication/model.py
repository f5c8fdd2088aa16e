"""The fabrication model: parts, slots, joints and the quad helpers every other module uses.

This is the bottom of :mod:`torsal.fabrication` (it imports nothing from the package):
``joints``, ``unroll``, ``solids`` and ``layout`` build on it, and
:class:`~torsal.fabrication.parts.FinSystem` sits on top of them all.

Units: every length is in the ``unit`` of the fin system (mm by default); quads are
``(k, 4, 3)`` arrays of corners ``a_i a_j b_j b_i`` (paper section 4.3: the fin of edge ``ij``
spans the node lines ``L_i = a_i b_i`` and ``L_j``).

Example
-------
>>> import numpy as np
>>> q = np.array([[[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]]], float)
>>> quad_normals(q)
array([[ 0., -1.,  0.]])
>>> str(PartId(1, 3, 0)), str(PartId(CONNECTOR_FAMILY, 123, 1)), str(PartId(FIXING_FAMILY, 45, 0))
('F1-S003-P00', 'C-N0123-1', 'A-E0045-0')
"""
from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np

__all__ = [
    "FamilySplit", "SlotSide", "PartId", "Slot", "Crossing", "Part", "Joint", "JointKind", "Hole",
    "FAMILY_COLORS", "CONNECTOR_FAMILY", "FIXING_FAMILY", "MITER_LIMIT", "fold_angles",
    "quad_normals", "panel_widths", "slab_faces",
]

#: family number of connector parts (brackets, splices): named ``C-N<node>-<index>``
CONNECTOR_FAMILY = -2
#: family number of fixings (the angles that fix a fin to the building, on the design surface
#: A): named ``A-E<structure edge>-<index>``
FIXING_FAMILY = -3

#: RGB colours (0..1) by family: family 0 orange, family 1 blue, developables green,
#: connectors grey, fixings dark red
FAMILY_COLORS = {0: (0.93, 0.55, 0.14), 1: (0.16, 0.45, 0.78), -1: (0.30, 0.65, 0.30),
                 CONNECTOR_FAMILY: (0.55, 0.55, 0.58), FIXING_FAMILY: (0.55, 0.16, 0.16)}


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
    ``index`` (number of the part along the strip). Connectors have ``family`` =
    :data:`CONNECTOR_FAMILY`, ``strip`` = the structure node they sit at and ``index`` their
    number at that node; fixings ``family`` = :data:`FIXING_FAMILY`, ``strip`` = the structure
    edge (fin panel) they fix and ``index`` their number on it."""

    family: int
    strip: int
    index: int

    def __str__(self) -> str:
        if self.family == CONNECTOR_FAMILY:       # connectors: node number, index at the node
            return f"C-N{self.strip:04d}-{self.index}"
        if self.family == FIXING_FAMILY:          # fixings: structure edge, index on it
            return f"A-E{self.strip:04d}-{self.index}"
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
    ``width`` the slot width (see :func:`torsal.fabrication.joints.slot_width`: ``t + c`` for
    flat plates crossing at right angles, ``t (1 + cos alpha) / sin alpha + c`` at a crossing
    angle ``alpha``). ``required_clearance`` is how much wider than ``t`` the plates need the
    slot to pass each other (``width - clearance - t``); ``angle`` the crossing angle (degrees)
    and ``fold`` the larger fold of the two plates at the node (degrees).
    """

    node: int
    parts0: tuple[str, ...]
    parts1: tuple[str, ...]
    depth: float
    depth0: float
    depth1: float
    width: float
    required_clearance: float = 0.0
    angle: float = 90.0
    fold: float = 0.0



class JointKind(str, Enum):
    """How two or more parts are joined at a node (see :mod:`torsal.fabrication.joints`)."""

    #: two plates crossing at a node interlock with half-depth slots, slid together along L_i
    EGG_CRATE = "egg-crate"
    #: a part end butt-trimmed against a plate it meets and fastened with a bent bracket
    BUTT_BRACKET = "butt-bracket"
    #: a part end butted against a plate as for a bracket, bent into a tab of its own sheet that
    #: lies on that plate and is bolted to it: no connector (issue 42)
    BUTT_TAB = "butt-tab"
    #: two parts of one strip split on a mild fold, mitred on the fold's bisector plane and
    #: fastened with a bent splice plate across the seam
    MITRE_SPLICE = "mitre-splice"
    #: a fin fixed to the building: a bent angle (a part of its own, ``A-E<edge>-<i>``) bolted
    #: to the fin and anchored to the design surface A where the fin stands on it
    FIXING = "fixing"


@dataclass(frozen=True)
class Joint:
    """One joint of the assembly.

    Attributes
    ----------
    kind : JointKind
    node : int
        Structure node the joint sits at (-1 for free strips).
    parts : tuple of str
        Names of the joined parts, exactly as in ``parts.csv`` and the STEP labels: for an
        egg-crate the family-0 part(s) then the family-1 part(s); for a butt joint the
        continuous plate, then the butted part, then the connector; for a mitre the earlier
        part, the later one, then the connector; for a fixing the fixing, then the fin (the
        fixing is set in place first, fixed to the building, and the fin goes on it).
    insert_direction : (3,) float
        Unit vector (model coordinates, i.e. the fin system's frame) along which the later
        part slides into place: for an egg-crate the family-1 plate moves onto the family-0
        plate along its slide direction, the mean node axis of all its crossings (``a_i -
        b_i`` when its slots open on the ``a`` edge, ``b_i - a_i`` when they open on ``b``);
        for a butt joint the butted part's one insertion direction (that slide direction if
        it is slotted too, else a node axis or a line between the faces it ends against, see
        :mod:`~torsal.fabrication.joints`); for a mitre the later part moves towards the
        earlier one; for a fixing the direction the fin comes down onto its fixings.
    connector : str or None
        Name of the connector part (bracket or splice plate), ``None`` for an egg-crate.
    connector_direction : (3,) float or None
        Unit vector along which the connector is put on last (into the corner it sits in).
    angle : float
        Degrees: crossing angle of the plates (egg-crate, butt) or fold angle (mitre).
    depth : float or None
        Fin depth ``|b_i - a_i|`` at the node (``unit``): the parts engage over at most this
        length along the node line (a slot is never longer), so a part slid in along it by
        that much is disengaged from the joint (None: unknown).
    """

    kind: JointKind
    node: int
    parts: tuple[str, ...]
    insert_direction: np.ndarray = field(compare=False)
    connector: str | None = None
    connector_direction: np.ndarray | None = field(default=None, compare=False)
    angle: float = 90.0
    depth: float | None = None


def _cross(a, b) -> np.ndarray:
    """``np.cross`` of float 3-vectors ``(..., 3)`` (broadcast), bit for bit: the same products
    and differences (``a1 b2 - a2 b1``, ...), without its axis handling, which costs more than
    the product on the single vectors and short stacks of the joinery (called ~10^5 times per
    fin system)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape == b.shape == (3,):
        a0, a1, a2 = a.tolist()
        b0, b1, b2 = b.tolist()
        return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def quad_normals(quads: np.ndarray) -> np.ndarray:
    """Unit Newell normals of quads (k, 4, 3) -> (k, 3)."""
    q = np.asarray(quads, dtype=float)
    n = _cross(q[:, 2] - q[:, 0], q[:, 3] - q[:, 1])
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
    s = np.einsum("ij,ij->i", _cross(n[:-1], n[1:]), axis)
    c = np.einsum("ij,ij->i", n[:-1], n[1:])
    return np.arctan2(s, c)


#: degrees: folds sharper than this are never mitred (the mitre vector grows as
#: ``1/cos(fold/2)``): such folds always split the strip, and the two parts get square ends
#: there (listed in ``FinSystem.untrimmed_joints``: they overlap near the fold)
MITER_LIMIT = 170.0


def _safe_normals(quads: np.ndarray) -> np.ndarray:
    """Unit Newell normals (k, 3); NaN rows for zero-area quads (never raises)."""
    q = np.asarray(quads, dtype=float)
    n = _cross(q[:, 2] - q[:, 0], q[:, 3] - q[:, 1])
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
    area = 0.5 * np.linalg.norm(_cross(q[:, 2] - q[:, 0], q[:, 3] - q[:, 1]), axis=1)
    edges = np.linalg.norm(q - np.roll(q, -1, axis=1), axis=2).max(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(edges > 0, area / np.where(edges > 0, edges, 1.0), 0.0)
    return np.where(np.isfinite(w), w, 0.0)


def _bowtie(quads: np.ndarray) -> np.ndarray:
    """Self-intersecting (bow-tie) quads (k,) bool: two corners turn against the normal."""
    q = np.asarray(quads, dtype=float)
    n = _safe_normals(q)
    e = np.roll(q, -1, axis=1) - q                       # edge i: corner i -> i+1
    turn = np.einsum("kij,kj->ki", _cross(e, np.roll(e, -1, axis=1)), np.nan_to_num(n))
    return (turn < 0).sum(axis=1) >= 2




def slab_faces(panels: np.ndarray, miters: np.ndarray, thickness: float) -> tuple[np.ndarray, np.ndarray]:
    """Top and bottom faces (k, 4, 3) each of a thickened chain of panels (k, 4, 3) with the
    offset vectors ``miters`` (k+1, 3) at its node lines: ``panel +- thickness/2 * mitre`` of
    the corner's node line (corners 0, 3 on node line j, corners 1, 2 on j + 1), as the
    plate's solid is built (:mod:`torsal.fabrication.plates`).

    >>> top, bottom = slab_faces(np.zeros((1, 4, 3)), np.array([[0, 0, 1.0]] * 2), 2.0)
    >>> top[0, :, 2].tolist(), bottom[0, :, 2].tolist()
    ([1.0, 1.0, 1.0, 1.0], [-1.0, -1.0, -1.0, -1.0])
    """
    q, m = np.asarray(panels, float), np.asarray(miters, float)
    node = np.arange(len(q))[:, None] + np.array([0, 1, 1, 0])
    return q + 0.5 * thickness * m[node], q - 0.5 * thickness * m[node]


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



@dataclass(frozen=True, eq=False)
class Hole:
    """A round hole through a plate, for a bolt or a rivet (drilled or cut with the outline).

    Attributes
    ----------
    center : (3,) float
        Centre on the plate's mid-surface, in the part's model frame and ``unit`` (the fin
        system's frame, like :attr:`Part.panels`); the hole's axis is the normal of the panel
        it is in.
    diameter : float
        Hole diameter (``unit``): the fastener's clearance hole (ISO 273 medium), see
        :mod:`torsal.fabrication.builder.fasteners`.
    panel : int
        Index of the panel of the part the hole is in (-1: not known; find the panel whose
        mid-plane holds ``center``).
    fastener : str
        The fastener that goes through it, e.g. ``"M6 bolt"`` or ``"M8 anchor"`` (a matching hole
        in the plate a connector lies on names the same fastener).
    shared : bool
        The bolt through it is counted at another connector's hole: two connectors on the two
        faces of a plate, one bolt through both and the plate.
    own : bool
        The fastener through it is counted at this hole although the part is a fin plate: a
        hole of a tab bent from the plate (:attr:`JointKind.BUTT_TAB`), whose bolt holds it to
        the plate it lies on (the hole there is that plate's matching hole). A connector's or
        fixing's holes are its own by the part's family.
    """

    center: np.ndarray
    diameter: float
    panel: int = -1
    fastener: str = ""
    shared: bool = False
    own: bool = False


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
    holes : tuple of Hole
        Holes for the fasteners: those of a connector or fixing (bolts through it and the plate
        it lies on, anchors into the building) and the matching holes in a fin plate (same
        centre projected on the plate's mid-plane, same diameter). Empty until the fin system
        is finished (:mod:`torsal.fabrication.builder.fasteners`).
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
    holes: tuple = ()

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
        return 0.5 * np.linalg.norm(_cross(q[:, 2] - q[:, 0], q[:, 3] - q[:, 1]), axis=1)

    @property
    def size(self) -> float:
        """Diagonal of the bounding box of the part (``unit``)."""
        p = self.panels.reshape(-1, 3)
        return float(np.linalg.norm(p.max(0) - p.min(0)))

    def slab_corners(self, j: int, thickness: float) -> np.ndarray:
        """(8, 3) corners of panel ``j`` of the thickened plate (its top face's four, then its
        bottom face's, :func:`slab_faces`): what stands out of the panel's plane, e.g. past
        a node line where the plate folds (its mitred edge)."""
        top, bottom = slab_faces(self.panels[j:j + 1], self.miters[j:j + 2], thickness)
        return np.concatenate([top[0], bottom[0]])

    def __repr__(self) -> str:
        return f"Part({self.name}, panels={len(self.panels)}, slots={len(self.slots)})"

