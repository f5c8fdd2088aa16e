"""The whole final cut on dumped fin systems (``benchmarks/final_cut_dump.py``'s
OUT/<key>.fs.pkl): :func:`~torsal.fabrication.nesting.final_cut.final_cut` as
``examples/run_all.py`` calls it (the split search, the fin system rebuilt with the cuts, the
bill's verdict), without running the design again. Prints per example the sheets and yield,
whether the cuts were kept and why not, the cut sites and the fixings each adds, the seams held
and fallen back, processor seconds and the load.

    nice -n 19 .venv/bin/python benchmarks/final_cut_run.py 7d 13 --dump /tmp/final_cut_dump
"""
import os
import pickle
import sys
import time
from collections import Counter
from pathlib import Path

from final_cut_replay import dumped_args

HERE = Path(__file__).resolve().parent


def run(key: str, dump: Path) -> dict:
    from torsal.design import Design
    from torsal.fabrication import verify_assembly
    from torsal.fabrication.nesting import final_cut as fc
    from torsal.pipeline.stages import nest_options

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 100000))
    spec = Design.from_toml(next((HERE.parent / "examples").glob(f"{key}_*.toml"))).spec
    with open(dump / f"{key}.fs.pkl", "rb") as f:
        fs = pickle.load(f)
    rates = None if spec.costs is None else spec.costs.rates()
    c0 = time.process_time()
    sites, fixings = fc.yield_cut_sites(fs, rates)
    fs2, lay, split = fc.final_cut(fs, nest_options(spec, fs.unit), rates=rates,
                                   density=spec.material.density)
    out = {"sheets": lay.n_sheets, "yield": lay.utilization, "split": split.as_report(),
           "sites": sum(map(len, sites.values())),
           "adds": Counter(fixings.get((n, j), 0) for n, js in sites.items() for j in js),
           "cpu": time.process_time() - c0, "load": os.getloadavg()[0]}
    if fs2 is not fs:
        check = verify_assembly(fs2)
        out["buildable"] = bool(check.buildable)
    return out


def main() -> None:
    a = dumped_args(__doc__)
    print("| example | sheets / yield | kept (why not) | cut sites (fixings added: count) "
          "| cuts, seams held, fallen back | fixings +- | buildable | CPU s | load |")
    print("|---|---|---|---|---|---|---|---|---|")
    for key in a.keys:
        r = run(key, a.dump)
        s = r["split"]
        adds = ", ".join(f"{k}: {v}" for k, v in sorted(r["adds"].items()))
        print(f"| {key} | {r['sheets']} / {100 * r['yield']:.1f} % | "
              f"{'yes' if s['kept'] else 'no (' + s['why'] + ')'} | {r['sites']} ({adds}) | "
              f"{s['cuts']}, {s['seams_in_slot']}, {len(s['fallbacks'])} | "
              f"{s['delta'].get('fixings', '-')} | {r.get('buildable', '-')} | {r['cpu']:.0f} | "
              f"{r['load']:.1f} |", flush=True)


if __name__ == "__main__":
    main()
