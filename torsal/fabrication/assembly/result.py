"""What the assembly check finds: interfering pairs, the assembly steps and the verdict
(:class:`AssemblyCheck`, the ``fabrication.assembly`` section of report.json, ``assembly.csv``).

Units: those of the solids (``unit``, mm by default): volumes in unit^3.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

from torsal.core.atomic import atomic_path

__all__ = ["MIN_INTERFERENCE_VOLUME", "TOUCHING_TOLERANCE", "Interference", "AssemblyStep", "AssemblyCheck"]

#: unit^3 (mm^3): a common volume above this is an interference (below it: round-off of the
#: booleans on plates that touch)
MIN_INTERFERENCE_VOLUME = 1.0

#: unit (mm): parts closer than this touch and get the exact test; the solids are meshed at a
#: tenth of it for the cheap ones
TOUCHING_TOLERANCE = 1.0


@dataclass(frozen=True)
class Interference:
    """Two parts whose solids overlap by ``volume`` (unit^3)."""

    parts: tuple[str, str]
    volume: float


@dataclass(frozen=True)
class AssemblyStep:
    """One step of the assembly order.

    ``insert_direction`` is the unit direction the part moves in (None: it has no joint to a
    part placed before it and is set down in place); ``travel`` the length of its path
    (unit); ``partners`` the parts placed before it that it joins; ``collisions`` what the
    swept part meets on the best path tried (empty: the path is clear; volumes of a blocked
    path are lower bounds: the sum stops once it exceeds ``min_volume``).
    """

    step: int
    part: str
    insert_direction: tuple | None
    travel: float
    partners: tuple[str, ...]
    joint_kinds: tuple[str, ...]
    collisions: tuple[Interference, ...] = ()

    @property
    def clear(self) -> bool:
        return not self.collisions


@dataclass
class AssemblyCheck:
    """Result of :func:`check_assembly`.

    ``interfering`` lists the pairs whose common volume exceeds ``min_volume``, worst first;
    ``order`` the assembly steps; ``failed_pairs`` the pairs whose boolean failed
    ``(part, part, reason)``; ``joints`` the number of joints by kind and ``connectors`` the
    number of connector parts by the kind of joint they fasten; ``memo_hits`` the pairs and
    paths taken from an :class:`~.memo.AssemblyMemo` (proved before for the same solids),
    ``memo_misses`` those proved here.
    """

    parts: list[str]
    pairs_checked: int
    interfering: list[Interference]
    order: list[AssemblyStep]
    failed_pairs: list[tuple[str, str, str]] = field(default_factory=list)
    joints: dict = field(default_factory=dict)
    connectors: dict = field(default_factory=dict)
    min_volume: float = MIN_INTERFERENCE_VOLUME
    unit: str = "mm"
    seconds: float = 0.0
    memo_hits: int = 0
    memo_misses: int = 0

    @property
    def interfering_pairs(self) -> int:
        return len(self.interfering)

    @property
    def worst_overlap_mm3(self) -> float:
        """Largest common volume of two parts (unit^3; 0 when none interfere)."""
        return max((x.volume for x in self.interfering), default=0.0)

    @property
    def interfering_parts(self) -> list[str]:
        return sorted({n for x in self.interfering for n in x.parts})

    @property
    def blocked(self) -> list[AssemblyStep]:
        """Steps whose part cannot be inserted along any direction tried without collision."""
        return [s for s in self.order if not s.clear]

    @property
    def buildable(self) -> bool:
        return not self.interfering and not self.failed_pairs and not self.blocked

    def problems(self, limit: int = 8) -> str:
        """One sentence naming what makes the design unbuildable ('' when it is buildable)."""
        out = []
        if self.interfering:
            out.append(f"{len(self.interfering)} pairs of parts interfere (worst "
                       f"{self.worst_overlap_mm3:.4g} {self.unit}^3): " + ", ".join(
                           f"{a} / {b} ({v:.3g})" for (a, b), v in
                           ((x.parts, x.volume) for x in self.interfering[:limit]))
                       + (" ..." if len(self.interfering) > limit else ""))
        if self.failed_pairs:
            out.append(f"{len(self.failed_pairs)} pairs could not be checked: " + ", ".join(
                f"{a} / {b}" for a, b, _ in self.failed_pairs[:limit]))
        if self.blocked:
            out.append(f"{len(self.blocked)} parts cannot be inserted without collision: " + ", ".join(
                f"{s.part} (hits {', '.join(c.parts[1] for c in s.collisions[:3])})"
                for s in self.blocked[:limit]) + (" ..." if len(self.blocked) > limit else ""))
        return "; ".join(out)

    def report(self) -> dict:
        """The ``fabrication.assembly`` section of report.json."""
        return {
            "pairs_checked": int(self.pairs_checked),
            "interfering_pairs": int(self.interfering_pairs),
            "worst_overlap_mm3": float(self.worst_overlap_mm3),
            "buildable": bool(self.buildable),
            "joints": {str(k): int(v) for k, v in self.joints.items()},
            "connectors": {str(k): int(v) for k, v in self.connectors.items()},
            "parts": len(self.parts),
            "interfering": [{"parts": list(x.parts), "volume_mm3": float(x.volume)}
                            for x in self.interfering],
            "interfering_parts": self.interfering_parts,
            "failed_pairs": [list(x) for x in self.failed_pairs],
            "blocked_parts": [s.part for s in self.blocked],
            "steps": len(self.order),
            "sequence": [{"step": st.step, "part": st.part,
                          "insert_direction": None if st.insert_direction is None
                          else [round(float(x), 6) for x in st.insert_direction],
                          "partners": list(st.partners), "joints": list(st.joint_kinds),
                          "clear": st.clear} for st in self.order],
            "min_volume_mm3": float(self.min_volume),
            "seconds": float(self.seconds),
            "memo_hits": int(self.memo_hits), "memo_misses": int(self.memo_misses),
        }

    def write_csv(self, path) -> Path:
        """``assembly.csv``: one row per step (step, part, insert direction, travel, joint kinds,
        partners placed before, clear, collision volume and parts hit)."""
        path = Path(path)
        with atomic_path(path) as tmp:
            with open(tmp, "w", newline="") as fh:
                w = csv.writer(fh)
                w.writerow(["step", "part", "insert_dx", "insert_dy", "insert_dz",
                            f"travel_{self.unit}", "joint_kinds", "joint_partners", "clear",
                            f"collision_{self.unit}3", "collides_with"])
                for s in self.order:
                    d = s.insert_direction
                    w.writerow([s.step, s.part, *(("", "", "") if d is None else
                                                   (f"{x:.6f}" for x in d)),
                                f"{s.travel:.3f}", " ".join(s.joint_kinds), " ".join(s.partners),
                                "yes" if s.clear else "no",
                                f"{sum(c.volume for c in s.collisions):.3f}",
                                " ".join(c.parts[1] for c in s.collisions)])
        return path
