"""How far the final cut can go without a connector: for each dumped example
(``benchmarks/final_cut_dump.py``), the area bound and the crossing bound
(:func:`~torsal.fabrication.nesting.bounds.crossing_bound`: the parts longer than half the
sheet cross its middle, so their chords there fill the sheets' heights) of the parts as they
are, and of the parts cut at EVERY node line where the final cut may cut them (a seam in its
crossing slot; :func:`~torsal.fabrication.nesting.cut_costs.yield_cut_sites`), and at
every one of those that adds no fixing: no split layout goes below those bounds (the first
ignores that without [costs] a sheet saved pays for at most one fixing).

    .venv/bin/python benchmarks/final_cut_bounds.py 7a 7b 7c 13 --dump /tmp/final_cut_dump
"""
import pickle
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from final_cut_replay import dumped_args  # noqa: E402


def bounds(path: Path) -> dict:
    from torsal.fabrication.nesting.bounds import crossing_bound
    from torsal.fabrication.nesting.rows import prepare

    with open(path, "rb") as f:
        d = pickle.load(f)
    kw = d["options"]
    w, h, items, sep, edge = prepare(d["outlines"], kw["sheet"], kw["gap"], kw["margin"],
                                     kw.get("cutting"), d["unit"])
    unrolled = {u.name: u for u in d["outlines"]}
    whole = [it.outline for it in items]
    out = {"parts": len(items), "area_sheets": sum(p.area for p in whole) / (w * h),
           "cross": crossing_bound(whole, sheet=(w, h), sep=sep, edge=edge)}
    for label, cuts in (("all", d["cuts"]), ("free", {
            n: tuple(j for j in js if d["fixings"].get((n, j), 0) == 0)
            for n, js in d["cuts"].items()})):
        out[label] = _cut_bound(items, unrolled, cuts, d["fixings"], w, h, sep, edge)
    out["sheets_80"] = int(np.floor(out["area_sheets"] / 0.8 + 1e-9))
    return out


def _cut_bound(items, unrolled, cuts, fixings, w, h, sep, edge) -> tuple[int, int]:
    """``(cuts, crossing bound)`` of ``items`` each cut at every node line of ``cuts``."""
    from torsal.fabrication.nesting.bounds import crossing_bound
    from torsal.fabrication.nesting.pieces import Pieces

    pieces = Pieces({it.name: it for it in items}, unrolled, cuts, fixings)
    cut = []
    n_cuts = 0
    for it in items:
        js = pieces.cuts.get(it.name, ())
        ends = [0, *js, len(unrolled[it.name].panels)]
        polys = [pieces.polygon(it.name, lo, hi) for lo, hi in zip(ends[:-1], ends[1:])]
        if js and all(p is not None for p in polys):
            cut += polys
            n_cuts += len(js)
        else:
            cut.append(it.outline)
    return n_cuts, crossing_bound(cut, sheet=(w, h), sep=sep, edge=edge)


def main() -> None:
    a = dumped_args(__doc__)
    print("| example | parts | area bound (sheets) | most sheets for 80 % | crossing bound | "
          "cuts allowed / crossing bound with all made | cuts adding no fixing / crossing "
          "bound with all made | CPU s |")
    print("|---|---|---|---|---|---|---|---|")
    for key in a.keys:
        c0 = time.process_time()
        r = bounds(a.dump / f"{key}.pkl")
        print(f"| {key} | {r['parts']} | {r['area_sheets']:.1f} | {r['sheets_80']} | "
              f"{r['cross']} | {r['all'][0]} / {r['all'][1]} | {r['free'][0]} / {r['free'][1]} | "
              f"{time.process_time() - c0:.1f} |", flush=True)


if __name__ == "__main__":
    main()
