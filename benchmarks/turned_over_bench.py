"""Would parts cut turned over (mirrored, face down) fill the sheets better? The final cut's
search (:class:`~torsal.fabrication.nesting.search._Search`, counted tries) on dumped outlines
(``benchmarks/final_cut_dump.py``), three ways:

* **as unrolled**: the parts as the fin system unrolls them;
* **cut where free**: every plate cut at each node line where its seam stays in a crossing slot
  and adds no fixing (the final cut's allowed cuts that cost contour only: the pieces the split
  search could use, all at once);
* **... and turned over**: those pieces, each mirrored where its ends slant the other way (a
  part's outline in its minimum rectangle's frame: mean x of its upper half minus that of its
  lower half), so that every piece's ends slant the same way and meet head to tail in a row.

Why: in a row of parallelogram strips two neighbours whose ends slant opposite ways leave a
triangle between them; turning a part half a turn keeps its slant, only turning it over
(cutting its mirror image, the fold directions reversed) changes it. On 3 mm aluminium coated
after cutting a workshop may turn parts over; torsal does not yet (the flat pattern, the DXF,
the fold directions and the final cut's pieces would all have to follow). This measures what
it would give before building it.

    nice -n 19 .venv/bin/python benchmarks/turned_over_bench.py 7a 7b --dump /tmp/final_cut_dump

Measured 2026-11-29 on dumps of main 2b1ed90 (sheets as unrolled / cut where free / and
turned over; the cuts, the yield of the last):

* 7a: 39 / 38 / 37 (128 cuts, 81.4 %); every one of its 248 allowed cuts made (120 of them
  adding a fixing), not turned over: 38;
* 7b: 40 / 38 / 37 (135 cuts, 81.9 %); its whole plates turned over, not cut: 41;
* 13: 29 / 28 / 28 (154 cuts, 82.0 %): cutting is enough;
* 7c: 36 / 37 / 36 (69 cuts): neither helps;
* 9: every allowed cut (175): 45, as unrolled: 45 (the search's sheets of bent, tapered strips
  are 50-81 % full: not the cuts, the packing of such shapes is what is left).

So turning over saves one more sheet on 7a and 7b, but only with 128-135 cuts. At the rates of
examples/rates/workshop_rates.toml a cut costs about 4 EUR (some 0.8 m of laser cut at 1.45
EUR/m, a pierce at 0.15 EUR, 3 minutes placing one part more at 1.16 EUR/min, less a bend at
0.58 EUR) and a sheet 127 EUR: some 30 cuts pay for a sheet saved, not 130. The final cut's
split search keeps 3-7 cuts that empty a sheet on 7a and 7b.
"""
from __future__ import annotations

import pickle
import time

import numpy as np
from shapely import affinity
from shapely.geometry import Polygon

from final_cut_replay import dumped_args


def slant(poly: Polygon) -> float:
    """How far the upper half of ``poly`` lies along its minimum rectangle's long side past
    its lower half (outline units): the sign says which way its ends slant."""
    x, y = np.asarray(poly.minimum_rotated_rectangle.exterior.coords.xy)
    edges = np.diff(np.c_[x, y], axis=0)[:2]
    i = int(np.argmax(np.hypot(*edges.T)))
    turned = affinity.rotate(poly, -np.degrees(np.arctan2(edges[i, 1], edges[i, 0])),
                             origin="centroid")
    c = np.asarray(turned.exterior.coords)
    mid = (c[:, 1].min() + c[:, 1].max()) / 2
    upper, lower = c[c[:, 1] > mid, 0], c[c[:, 1] <= mid, 0]
    return float((upper.mean() if len(upper) else 0.0) - (lower.mean() if len(lower) else 0.0))


def mirrored(poly: Polygon) -> Polygon:
    """``poly`` turned over (x -> -x), its rings counter-clockwise again."""
    m = affinity.scale(poly, xfact=-1, origin=(0, 0))
    return Polygon(m.exterior.coords[::-1], [r.coords[::-1] for r in m.interiors])


def outlines(d: dict, *, cut: bool, turn: bool) -> tuple[list, int, int]:
    """``[(name, polygon)]`` of the dumped parts, cut where free and turned over as asked;
    the cuts made and the pieces turned."""
    from torsal.fabrication.nesting.items import _as_items
    from torsal.fabrication.nesting.pieces import Pieces, _ranges

    items = {it.name: it for it in _as_items(d["outlines"], d["options"]["cutting"])}
    unrolled = {u.name: u for u in d["outlines"] if hasattr(u, "panels")}
    pieces = Pieces(items, unrolled, d["cuts"], d["fixings"])
    out, n_cuts, n_turned = [], 0, 0
    for u in d["outlines"]:
        sites = [j for j in pieces.cuts.get(u.name, ()) if not d["fixings"].get((u.name, j), 0)]
        parts = [(u.name, Polygon(u.outline))]
        if cut and sites:
            cut_parts = [(f"{u.name}[{lo}:{hi}]", pieces.polygon(u.name, lo, hi))
                         for lo, hi in _ranges(len(u.panels), sites)]
            if all(p is not None for _, p in cut_parts):
                parts, n_cuts = cut_parts, n_cuts + len(sites)
        for name, poly in parts:
            if turn and name.startswith("F") and slant(poly) < 0:
                poly, n_turned = mirrored(poly), n_turned + 1
            out.append((name, poly))
    return out, n_cuts, n_turned


def main() -> None:
    from torsal.fabrication.nesting.search import _Search

    a = dumped_args(__doc__)
    print("| example | way | sheets | yield | cuts | turned over | starts (sheets) | CPU s |")
    print("|---|---|---|---|---|---|---|---|")
    for key in a.keys:
        with open(a.dump / f"{key}.pkl", "rb") as f:
            d = pickle.load(f)
        kw = dict(d["options"], unit=d["unit"], time_limit=None, progress=None)
        for way, cut, turn in (("as unrolled", False, False), ("cut where free", True, False),
                               ("... and turned over", True, True)):
            parts, n_cuts, n_turned = outlines(d, cut=cut, turn=turn)
            c0 = time.process_time()
            search = _Search(parts, **kw)
            search.run()
            n = len(search.emptier.sheets)
            starts = ", ".join(f"{k} {v}" for k, v in search.start_sheets.items())
            print(f"| {key} | {way} | {n} | {100 * search.total / (n * search.w * search.h):.1f} % | "
                  f"{n_cuts} | {n_turned} | {starts} | {time.process_time() - c0:.0f} |", flush=True)


if __name__ == "__main__":
    main()
