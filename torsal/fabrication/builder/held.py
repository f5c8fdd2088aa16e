"""The builder's safety net: plates the load path finds loose in their slots are bolted to the
plate they hang on (issues 40, 42).

A plate whose way out of an egg-crate slot dips more than
:data:`~torsal.fabrication.assembly.load_path.SLIDE_DIP_DEG` below the horizontal would slide
out under its weight; the builder fixes such plates to the building
(:meth:`.paths.AssemblyPlanner._slot_hung`, and once more where the load path still finds them
loose: ``Rebuilder._unheld``). Where no fixing fits (the foot too short for a bolt and an
anchor, or a fixing there would overlap the crossing plate next to it) the load path still
finds the plate held by nothing. A workshop then bolts it to the plate it hangs on: the
crossing becomes a butt joint whose bracket is bolted to both (the joint every crossing falls
back to where a slot cannot be used: :mod:`.connectors`), its family split there, butted
against the plate that is held.

:func:`hold_crossings` picks, for each loose plate, one crossing to bolt so: one whose way out
dips and whose other plate the load path reaches from the building (a plate held that way
holds the loose plates hung on it in the next round), a crossing at the plate's own end (split
there already: a seam in the slot, or its end) before one it passes through, then by node.
``Rebuilder`` builds again with those crossings butted, at most :data:`MAX_HOLD_ROUNDS`
times, and names every crossing so bolted (:class:`HeldCrossing`, ``FinSystem.held_crossings``,
:func:`held_report`): a fabricator sees which plates the builder bolted and why.
"""
from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass

import numpy as np

from ..model import JointKind

#: how often the builder bolts loose plates to the plates they hang on and builds again, at
#: most (each round holds the plates next to a held one; a group of loose plates hung on each
#: other takes a round per plate it is deep)
MAX_HOLD_ROUNDS = 4


@dataclass(frozen=True)
class HeldCrossing:
    """An egg-crate crossing butted so that a loose plate is bolted to the plate it hung on:
    the strip of ``family`` is split at ``node`` and butted with brackets against ``holder``
    (held by the building); ``part`` the plate the load path found loose (its name in the build
    that found it), whose way out of the slot there dipped ``dip_deg`` degrees below the
    horizontal; ``parts``, ``brackets`` and ``tabs``: the butted parts at the node in the final
    build, the brackets bolting them and those whose end is bent into a tab bolted to the
    plate instead (:mod:`.tabs`; empty until :func:`publish_held`)."""

    node: int
    family: int
    part: str
    holder: str
    dip_deg: float
    parts: tuple[str, ...] = ()
    brackets: tuple[str, ...] = ()
    tabs: tuple[str, ...] = ()

    @property
    def why(self) -> str:
        return (f"{self.part} hung in the slot of {self.holder} at node {self.node}, its way out "
                f"dipping {self.dip_deg:.0f} deg below the horizontal, and no fixing held it: "
                f"family {self.family} split there, butted against {self.holder} and bolted to "
                "it (a bracket, or a tab bent from the butted end)")


def way_out_dip(joint, family: int, *, up=None) -> float:
    """Degrees the way out of a plate of ``family`` from the egg-crate ``joint`` dips below the
    horizontal (negative: it rises): a family-0 plate comes off along the unit insert direction
    ``d``, a family-1 plate out along ``-d`` (the load path's rule,
    :func:`~torsal.fabrication.assembly.load_path.slides_out`)."""
    from ..assembly.load_path import UP

    up = np.asarray(UP if up is None else up, float)
    d = np.asarray(joint.insert_direction, float)
    d = d / np.linalg.norm(d)
    way = d if family == 0 else -d
    return float(np.degrees(np.arcsin(np.clip(-(way @ up), -1.0, 1.0))))


def _candidates(fs, name: str, supported: dict, taken: set) -> list[tuple]:
    """``[(key, HeldCrossing)]``: the egg-crate crossings of the loose plate ``name`` whose way
    out dips more than the load path allows and whose other plate is ``supported`` (``{name:
    family}``), not in ``taken`` (nodes butted already), keyed best first (at the plate's end,
    then by node)."""
    from ..assembly.load_path import SLIDE_DIP_DEG

    p = fs.part(name)
    ends = {int(p.nodes[0]), int(p.nodes[-1])}
    out = []
    for j in fs.joints:
        if j.kind != JointKind.EGG_CRATE or name not in j.parts or int(j.node) in taken:
            continue
        dip = way_out_dip(j, p.family)
        holders = sorted(n for n in j.parts if supported.get(n, p.family) != p.family)
        if dip > SLIDE_DIP_DEG and holders:
            held = HeldCrossing(int(j.node), p.family, name, holders[0], round(dip, 1))
            out.append(((int(j.node) not in ends, int(j.node)), held))
    return sorted(out, key=lambda c: c[0])


def hold_crossings(fs, lp, *, taken=frozenset()) -> dict[int, HeldCrossing]:
    """``{node: HeldCrossing}``: for every fin plate of ``fs`` (families 0 and 1) the load path
    ``lp`` (:class:`~torsal.fabrication.assembly.load_path.LoadPath`) finds unsupported, the
    crossing to butt and bracket so that it is bolted to a plate the building holds (rules in
    the module text); none where it has no such crossing (a fixing or nothing holds it) or the
    crossing is in ``taken`` or chosen for a plate before it (by name).

    >>> hold_crossings(fs, load_path(fs))                            # doctest: +SKIP
    {30: HeldCrossing(node=30, family=1, part='F1-S001-P00', holder='F0-S000-P00', ...)}
    """
    loose = set(lp.unsupported_parts)
    supported = {p.name: p.family for p in fs.parts if p.name not in loose}
    out: dict[int, HeldCrossing] = {}
    for p in sorted(fs.parts, key=lambda p: p.name):
        if p.family not in (0, 1) or p.name not in loose:
            continue
        cands = _candidates(fs, p.name, supported, set(taken) | set(out))
        if cands:
            held = cands[0][1]
            out[held.node] = held
    return out


def publish_held(fs, held: dict[int, HeldCrossing]) -> list[HeldCrossing]:
    """The crossings of ``held`` with the parts butted there, their brackets and their tabs
    in the final build of ``fs``, by node (``FinSystem.held_crossings``)."""
    out = []
    for v in sorted(held):
        h = held[v]
        butts = [j for j in fs.joints if int(j.node) == v
                 and j.kind in (JointKind.BUTT_BRACKET, JointKind.BUTT_TAB)]
        mine = lambda j: [n for n in j.parts if n != j.connector][-1:]  # noqa: E731 (butted)
        names = {n for j in butts for n in mine(j)}
        brackets = {j.connector for j in butts if j.connector}
        tabs = {n for j in butts if j.kind == JointKind.BUTT_TAB for n in mine(j)}
        out.append(dataclasses.replace(h, parts=tuple(sorted(names)),
                                       brackets=tuple(sorted(brackets)), tabs=tuple(sorted(tabs))))
    return out


def held_report(fs) -> dict:
    """The ``fabrication.held_by_builder`` entry of a design's report: how many crossings the
    builder bolted because the load path found a plate hung there loose (``crossings``), the
    plates (``parts``: as named in the build that found them loose) and each crossing (node,
    family split, the loose plate, the plate it is now bolted to, how steeply its way out
    dipped, the parts butted there, their brackets and tabs, why).

    >>> held_report(fs)["parts"]                                      # doctest: +SKIP
    ['F0-S002-P03', 'F1-S001-P00', 'F1-S005-P00']
    """
    held = list(getattr(fs, "held_crossings", []))
    return {
        "crossings": len(held),
        "parts": sorted({h.part for h in held}),
        "list": [{"node": h.node, "family": h.family, "part": h.part, "holder": h.holder,
                  "dip_deg": h.dip_deg, "parts": list(h.parts), "brackets": list(h.brackets),
                  "tabs": list(h.tabs), "why": h.why} for h in held],
    }


def warn_held(held: list[HeldCrossing]) -> None:
    """Warn about the crossings the builder bolted (``FinSystem.held_crossings``)."""
    if not held:
        return
    warnings.warn(
        f"{len(held)} plates hung loose in slots their weight would draw them out of, and no "
        f"fixing fitted them: their crossings are butted and bolted instead: "
        + "; ".join(f"{h.part} to {h.holder} at node {h.node}" for h in held[:6])
        + (" ..." if len(held) > 6 else "") + "; see FinSystem.held_crossings", stacklevel=4)
