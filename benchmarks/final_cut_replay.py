"""The final cut's nester on dumped outlines (``benchmarks/final_cut_dump.py``): sheets,
yield, tries and processor seconds of the search and of its split phase, per example, and
the fill of the emptiest sheets (the split search of the final cut, without the rebuild).

    .venv/bin/python benchmarks/final_cut_replay.py 7a 13 --dump /tmp/final_cut_dump
"""
import argparse
import os
import pickle
import time
from pathlib import Path


def replay(path: Path) -> dict:
    from torsal.fabrication.nesting.cut_costs import cuts_pay
    from torsal.fabrication.nesting.search import DEFAULT_TRIES
    from torsal.fabrication.nesting.split import DEFAULT_SPLIT_TRIES, nest_split

    with open(path, "rb") as f:
        d = pickle.load(f)
    kw = d["options"]
    c0 = time.process_time()
    pa = dict(d["pays_args"])
    pays = cuts_pay(pa.pop("rates"), **pa)
    split_tries = DEFAULT_SPLIT_TRIES * kw.get("tries", DEFAULT_TRIES) // DEFAULT_TRIES
    res = nest_split(d["outlines"], cuts=d["cuts"], pays=pays, fixings=d["fixings"],
                     unit=d["unit"], split_tries=split_tries, **kw)
    lay = res.layout
    return {"sheets": lay.n_sheets, "yield": lay.utilization, "cpu": time.process_time() - c0,
            "base": res.base.n_sheets, "cuts": res.n_cuts, "why": res.why,
            "method": lay.stats.method, "fill": lay.sheet_utilization, "layout": lay}


def dumped_args(doc: str):
    """The examples' keys and the dump folder from the command line; prints the load."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("keys", nargs="+")
    ap.add_argument("--dump", type=Path, default=Path("/tmp/final_cut_dump"))
    a = ap.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f}")
    return a


def main() -> None:
    a = dumped_args(__doc__)
    print("| example | search sheets | final sheets | yield | cuts | CPU s | emptiest fills |")
    print("|---|---|---|---|---|---|---|")
    for key in a.keys:
        r = replay(a.dump / f"{key}.pkl")
        with open(a.dump / f"{key}.layout.pkl", "wb") as f:      # the sheets, for a later pass
            pickle.dump(r["layout"], f, protocol=pickle.HIGHEST_PROTOCOL)
        low = ", ".join(f"{100 * u:.0f}" for u in sorted(r["fill"])[:4])
        print(f"| {key} | {r['base']} | {r['sheets']} | {100 * r['yield']:.1f} % | {r['cuts']} | "
              f"{r['cpu']:.0f} | {low} |", flush=True)
        print(f"    {r['method']} {r['why']}", flush=True)


if __name__ == "__main__":
    main()
