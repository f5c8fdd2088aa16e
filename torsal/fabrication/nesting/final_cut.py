"""The final cut of a fin system: its sheets nested for yield, and its plates split where the
bill of quantities says a sheet saved is worth the cuts (issues 40, 42).

1. **Where a plate may be split at no connector.** At the inner node lines where it is
   slotted at an egg-crate crossing: the crossing plate holds the two pieces, their seam
   inside its slot (:func:`~torsal.fabrication.builder.seams.yield_cut_positions`).
2. **Which splits.** :func:`~.split.nest_split`: the final cut's search, then plates cut where
   that empties a sheet; every sheet emptied must *pay*: ``pays(cuts, sheets saved)``
   (:func:`~.cut_costs.cuts_pay`): with the user's rates, the sheets' material against what the cuts add
   (their contour, a pierce and a part to place each, less the bend a cut at a fold removes,
   and the fixings a cut adds: :func:`~.cut_costs.fixings_added`, a plate's fixings stay on
   its pieces, and a piece gets one of its own only where its slots do not hold it);
   without rates, a sheet emptied pays for the seams that empty it (contour and pierces,
   which the report gives) and at most one fixing more (a cut of a plate fixed to the
   building: :data:`~.cut_costs.FIXINGS_PER_SHEET_SAVED`, argued in :mod:`.cut_costs`).
3. **The real parts.** The fin system is built again with those cuts
   (:func:`~.mapped.rebuilt_with_cuts`: the same structure and options, the plates cut once more at
   those node lines, ``FinSystem._yield_cuts``): each cut becomes a seam inside its slot,
   proved by the local assembly check, or falls back to brackets where the check refuses it
   (counted; the split is then searched once more without those cuts). The pieces take the
   places of their stand-ins on the sheets (:func:`~.mapped.mapped_layout`: each real piece turned
   onto its stand-in, inside it or the spacing clear of its neighbours); a part that has no
   stand-in or does not fit its place (a new bracket or fixing, a part whose joints the
   rebuild settled otherwise) is put into a hole of a sheet, else onto a new one.
4. **The bill decides** (:func:`~torsal.fabrication.quantities.bill_of_quantities` of both
   designs on their sheets). The split design is kept where it has fewer sheets, leaves out
   no more fin panels and blocks no more parts' paths and, with rates, costs less; without
   rates, has no more connectors or connectors' bolts and anchors, and at most one fixing
   more (with its own fasteners) a sheet saved. Else the fin system and the
   sheets without splits stand (:attr:`YieldSplit.kept` False, saying why).

Every step counts tries, never seconds: the same design gives the same parts and sheets on
every machine. Units: those of the fin system (``unit``).

>>> fs, layout, split = final_cut(fs, nest_options)              # doctest: +SKIP
>>> split.plates[0]["plate"], split.sheets_saved                # doctest: +SKIP
('F1-S010-P01', 2)
"""
from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

from .cut_costs import (FIXINGS_PER_SHEET_SAVED, cuts_pay, fixings_added, per_fixing,
                        yield_cut_sites)
from .mapped import mapped_layout, pieces_of, rebuilt_with_cuts, strip_cuts
from .search import DEFAULT_TRIES
from .split import DEFAULT_SPLIT_TRIES, SplitNesting, nest_split

__all__ = ["YieldSplit", "final_cut", "cuts_pay", "rebuilt_with_cuts", "mapped_layout",
           "yield_cut_sites", "fixings_added"]

#: the memo's name for the split search (:class:`~torsal.pipeline.memo.Memo`)
_MEMO = "final-cut"


@dataclass
class YieldSplit:
    """What the final cut's splits did, for the report (``fabrication.nesting.split``).

    ``kept`` whether the split design was kept (``why`` not, when not); ``plates``
    ``[{"plate", "pieces", "node_lines", "nodes"}]`` each plate split (its name before, its
    pieces' names after, where); ``sheets_before`` / ``sheets_after`` and the utilizations;
    ``cuts``; the bill's differences ``delta`` (``cut_m``, ``pierces``, ``bends``, ``parts``,
    ``connectors``, ``bolts``, ``anchors``, ``panels_left_out``, and ``price`` with rates);
    ``seams`` the cuts held in a slot and ``fallbacks`` those that fell back to brackets;
    ``tries`` and ``seconds`` of the split search and of the rebuild."""

    kept: bool
    why: str = ""
    plates: list = field(default_factory=list)
    sheets_before: int = 0
    sheets_after: int = 0
    utilization_before: float = 0.0
    utilization_after: float = 0.0
    cuts: int = 0
    delta: dict = field(default_factory=dict)
    seams: int = 0
    fallbacks: list = field(default_factory=list)
    tries: int = 0
    seconds: dict = field(default_factory=dict)
    currency: str = ""

    @property
    def sheets_saved(self) -> int:
        return self.sheets_before - self.sheets_after if self.kept else 0

    def as_report(self) -> dict:
        return {"kept": self.kept, "why": self.why, "plates_split": len(self.plates),
                "plates": self.plates, "cuts": self.cuts, "sheets_before": self.sheets_before,
                "sheets_after": self.sheets_after, "sheets_saved": self.sheets_saved,
                "utilization_before": self.utilization_before,
                "utilization_after": self.utilization_after, "delta": self.delta,
                "seams_in_slot": self.seams, "fallbacks": self.fallbacks, "tries": self.tries,
                "seconds": self.seconds, "currency": self.currency}


def _counts(fs) -> dict:
    from ..builder.fasteners import fastener_counts

    counts = fastener_counts(fs)
    return {"connectors": len(fs.connectors), "fixings": len(fs.fixings),
            "bolts": int(sum(c.bolts for c in counts.values())),
            "anchors": int(sum(c.anchors for c in counts.values())),
            # the fasteners of the connectors alone (what a cut may not add without rates)
            "connector_bolts": int(sum(c.bolts for k, c in counts.items() if k != "fixing")),
            "connector_anchors": int(sum(c.anchors for k, c in counts.items() if k != "fixing")),
            "panels_left_out": len(getattr(fs, "coplanar_panels", [])) + len(fs.dropped_panels),
            "blocked": len(getattr(fs, "_blocked_paths", []))}


def final_cut(fs, options: dict, *, rates=None, density: float = 2700.0, progress=None,
              memo=None, key: str | None = None) -> tuple[object, object, YieldSplit]:
    """``(fin system, layout, YieldSplit)``: the final cut of ``fs`` (see the module
    docstring); ``options`` :func:`~torsal.pipeline.stages.nest_options`'s (the sheet, gap,
    margin, cutting, tries, ...), ``rates`` the user's
    :class:`~torsal.fabrication.quantities.Rates` (None: no price), ``density`` kg/m^3 for
    the bill. The split design's fin system is a new one (``fs`` is not changed); where none
    is kept, ``fs`` and the search's sheets with the split's record saying why. Where a cut
    did not become a seam in its slot (the rebuilt fin system refused it: brackets), the
    split is searched once more without those cuts. With ``memo``
    (:class:`~torsal.pipeline.memo.Memo`) and ``key`` (the content of ``fs``'s flat parts,
    ``options``, ``rates``, ``density`` and :func:`yield_cut_sites`) the split searches are
    kept there and read back."""
    t0 = time.perf_counter()
    kw = {k: options[k] for k in ("sheet", "gap", "margin", "cutting", "rotation_step", "tries",
                                  "time_limit") if k in options}
    kw["sheet"] = tuple(kw.get("sheet", (2500.0, 1250.0)))
    cutting = kw.get("cutting")
    if cutting is not None:
        cutting.check_slots(fs.unrolled().values())
    pays = cuts_pay(rates, sheet=kw["sheet"], thickness=fs.thickness, density=density,
                    unit=fs.unit, process=None if cutting is None else cutting.process,
                    per_fixing=per_fixing(fs, rates, density, cutting))
    excluded: set = set()
    best = None
    for attempt in range(2):
        res = _split_search(fs, kw, rates, pays, progress, memo,
                            key if not excluded or key is None else
                            f"{key}-{content_hash(sorted(excluded))}", excluded)
        got = _attempt(fs, res, kw, rates, density, t0)
        if best is None or (got[2].kept and not best[2].kept):
            best = got
        refused = got[3]
        if not refused or attempt:
            break
        excluded |= refused
    fs_out, layout, split, _ = best
    return fs_out, layout, split


def content_hash(value) -> str:
    """16 hex digits of ``repr(value)`` (a memo key's suffix)."""
    import hashlib

    return hashlib.sha256(repr(value).encode()).hexdigest()[:16]


def _split_search(fs, kw: dict, rates, pays, progress, memo, key, excluded: set) -> SplitNesting:
    """:func:`~.split.nest_split` of ``fs``'s parts at :func:`yield_cut_sites` less
    ``excluded`` ``{(plate, node line)}``, kept in ``memo`` under ``key``."""
    res = None if memo is None or key is None else memo.load(_MEMO, key)
    if res is not None:
        for lay in {id(res.base): res.base, id(res.layout): res.layout}.values():
            lay.stats.method += ", kept from an earlier run of the same parts"
        return res
    cuts, fixings = yield_cut_sites(fs, rates)
    cuts = {n: tuple(j for j in js if (n, j) not in excluded) for n, js in cuts.items()}
    # the split phases' drops and repacks in proportion to the search's tries (the design's
    # nesting.tries): 2,000 to its 600
    split_tries = DEFAULT_SPLIT_TRIES * kw.get("tries", DEFAULT_TRIES) // DEFAULT_TRIES
    res = nest_split(list(fs.unrolled().values()), cuts={n: js for n, js in cuts.items() if js},
                     pays=pays, fixings=fixings, unit=fs.unit, progress=progress,
                     split_tries=split_tries, **kw)
    if memo is not None and key is not None and not res.base.stats.time_limited:
        memo.store(_MEMO, key, res)
    return res


def _unsplit(layout, res: SplitNesting, why: str, t0: float, **more) -> YieldSplit:
    """The record of a final cut that keeps the design without splits, saying ``why``, on
    its ``layout`` (the search's, or one with sheets emptied without a cut)."""
    split = YieldSplit(False, why, sheets_before=res.base.n_sheets, sheets_after=layout.n_sheets,
                       utilization_before=float(res.base.utilization),
                       utilization_after=float(layout.utilization), tries=res.tries,
                       seconds={"search": float(res.layout.stats.seconds),
                                "total": time.perf_counter() - t0}, **more)
    layout.stats.split = split.as_report()
    return split


def _verdict(delta: dict, p0, p1, base, lay2, currency: str) -> str:
    """Why the split design is not kept (empty: it is; the module docstring, step 4)."""
    if delta["sheets"] >= 0:
        return f"the real pieces took {lay2.n_sheets} sheets, not fewer than {base.n_sheets}"
    if delta["panels_left_out"] > 0 or delta["blocked"] > 0:
        return ("the cut design leaves out more fin panels or blocks more parts' paths than the "
                "design without the cuts")
    if p0 is not None:
        return "" if p1.total < p0.total else (
            f"the price went up by {p1.total - p0.total:.2f} {currency}".rstrip())
    # without rates (cut_costs' module docstring): no connector or connector fastener more,
    # at most FIXINGS_PER_SHEET_SAVED fixings (with their own fasteners) a sheet saved
    worse = [k.replace("_", " ") for k in ("connectors", "connector_bolts", "connector_anchors")
             if delta.get(k, 0) > 0]
    if worse:
        return "more " + ", ".join(worse) + " than without the cuts"
    if delta["fixings"] > FIXINGS_PER_SHEET_SAVED * -delta["sheets"]:
        return (f"{delta['fixings']} fixings more for {-delta['sheets']} sheets saved (at most "
                f"{FIXINGS_PER_SHEET_SAVED} a sheet without [costs])")
    return ""


def _attempt(fs, res: SplitNesting, kw: dict, rates, density: float, t0: float):
    """``(fin system, layout, YieldSplit, cuts refused)``: the split search ``res`` built
    (step 3 of the module docstring) and weighed by the bill (step 4); ``cuts refused``
    ``{(plate, node line)}`` the cuts the rebuilt fin system did not hold in their slots."""
    from ..quantities import bill_of_quantities, price

    base = res.base
    if not res.cuts:                # (the layout may have fewer sheets: emptied without a cut)
        return fs, res.layout, _unsplit(res.layout, res, res.why, t0), set()
    t1 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            # (what the build warns of, the build without the cuts warned of already; what
            # the cuts change is in the split's record)
            warnings.simplefilter("ignore")
            fs2 = rebuilt_with_cuts(fs, strip_cuts(fs, res.cuts))
        t2 = time.perf_counter()
        lay2, loose = mapped_layout(fs, fs2, res, dict(kw, unit=fs.unit))
    except Exception as e:        # the design without the cuts stands, saying why
        return fs, base, _unsplit(base, res, f"the fin system with the cuts could not be "
                                  f"built: {e}", t0, cuts=res.n_cuts), set()
    t3 = time.perf_counter()
    q0 = bill_of_quantities(fs, density=density, layout=base)
    q1 = bill_of_quantities(fs2, density=density, layout=lay2)
    c0, c1 = _counts(fs), _counts(fs2)
    delta = {"sheets": lay2.n_sheets - base.n_sheets, "parts": len(fs2.parts) - len(fs.parts),
             "cut_m": q1.cut_m - q0.cut_m, "pierces": q1.pierces - q0.pierces,
             "bends": q1.bends - q0.bends, "gross_kg": (q1.gross_kg or 0.0) - (q0.gross_kg or 0.0),
             **{k: c1[k] - c0[k] for k in c0}}
    if loose:
        delta["parts_placed_again"] = len(loose)
    p0, p1 = price(q0, rates), price(q1, rates)
    if p0 is not None:
        delta["price"] = p1.total - p0.total
    # the cuts' seams: held in a slot, or fallen back to brackets
    at = {(n, j): (fs.part(n).family, int(fs.part(n).nodes[j])) for n, js in res.cuts.items()
          for j in js}
    held = {(s.family, s.node) for s in fs2.seams_in_slot}
    refused = {c for c, node in at.items() if node not in held}
    fallbacks = [{"node": f.node, "family": f.family, "reason": f.reason.value, "why": f.detail}
                 for f in fs2.joint_fallbacks if (f.family, f.node) in set(at.values())]
    currency = "" if rates is None else rates.currency
    why = _verdict(delta, p0, p1, base, lay2, currency)
    plates = [{"plate": name, "pieces": pieces_of(fs, fs2, name), "node_lines": list(js),
               "nodes": [int(fs.part(name).nodes[j]) for j in js]}
              for name, js in sorted(res.cuts.items())]
    split = YieldSplit(
        not why, why, plates, base.n_sheets, lay2.n_sheets, float(base.utilization),
        float(lay2.utilization), res.n_cuts, delta, len(at) - len(refused), fallbacks, res.tries,
        {"search": float(res.layout.stats.seconds), "rebuild": t2 - t1, "layout": t3 - t2,
         "total": time.perf_counter() - t0}, currency)
    if why:
        base.stats.split = split.as_report()
        return fs, base, split, refused
    lay2.stats.split = split.as_report()
    lay2.stats.method = (f"{base.stats.method}; then {res.n_cuts} cuts of {len(plates)} plates "
                         f"(seams in their slots), {base.n_sheets - lay2.n_sheets} sheets fewer")
    return fs2, lay2, split, refused
