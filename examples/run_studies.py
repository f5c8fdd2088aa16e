"""Run the depth x spacing study of every example against the standard devices and rewrite the
studies table of examples/README.md.

    python examples/run_studies.py [--out out/studies] [--only 7a 9 ...] [--workers 2]
    python examples/run_studies.py --table-only      # rewrite the table from the saved results

Each study is ``examples/studies/<key>_depth_spacing.toml`` (light only: no fabrication). Its
table is saved to ``examples/studies/results/<key>.csv`` and its Pareto plot to
``examples/studies/<key>_pareto.png``; the README table is computed from those files, so it can
be rewritten without running anything. A finished study folder is resumed, not recomputed
(delete ``OUT/<key>`` to measure again). Times are wall-clock seconds on the machine that ran
this script, with its load average.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from torsal import Study
from torsal.light.devices import DEVICE_NAMES
from torsal.study.study_report import X_KEY, Y_KEY, lead_over, pareto_front

HERE = Path(__file__).resolve().parent
STUDIES = HERE / "studies"
RESULTS = STUDIES / "results"
KEYS = ("7a", "7b", "7c", "7d", "9", "10", "11", "13")
BEGIN, END = "<!-- studies:begin -->", "<!-- studies:end -->"


def run(key: str, out: Path, workers: int) -> dict:
    """Run one study; save its table, plot and timing next to the study file."""
    study = Study.from_toml(STUDIES / f"{key}_depth_spacing.toml")
    load0 = os.getloadavg()[0]
    t0, c0 = time.perf_counter(), time.process_time()
    res = study.run(out / key, workers=workers,
                    progress=lambda p: print(f"\r{key}: {p.done + p.failed}/{p.total} done, "
                                             f"{p.failed} failed, {p.running} running   ",
                                             end="", flush=True))
    wall = time.perf_counter() - t0
    print()
    RESULTS.mkdir(parents=True, exist_ok=True)
    # the columns the README table reads, and the ones a reader checks it with
    keep = ["id", "kind", "device", "status", "note", *study.spec.axes, "fins.depth",
            "fins.spacing", Y_KEY, X_KEY, "light.blocked_share", "light.view_out",
            "light.transparency", "light.let_through.passed_inside",
            "light.let_through.blocked_outside", "material_kg", "wall_s", "failed_stage", "error"]
    table = res.table[[c for c in dict.fromkeys(keep) if c in res.table]]
    table.to_csv(RESULTS / f"{key}.csv", index=False, float_format="%.6g")
    shutil.copyfile(res.files["png"], STUDIES / f"{key}_pareto.png")
    ran = res.table[(res.table["kind"] == "torsal")]
    timing = {"key": key, "wall_s": wall, "variants": int(len(ran)), "solves": res.solves,
              "solves_saved": res.solves_saved, "resumed": res.resumed, "failed": res.failed,
              "load_start": load0, "load_end": os.getloadavg()[0],
              "date": time.strftime("%Y-%m-%d %H:%M"), "verdict": res.verdict,
              "main_process_cpu_s": time.process_time() - c0}
    earlier = RESULTS / f"{key}.json"
    if res.resumed == len(ran) and earlier.exists():
        # nothing ran (a finished study folder): the time it took is the earlier record's
        timing = json.loads(earlier.read_text()) | {"verdict": res.verdict}
    earlier.write_text(json.dumps(timing, indent=1))
    return timing


# ------------------------------------------------------------------ the README table
def balanced(row) -> float:
    """The smaller of the two shares (sun blocked, view clear): a point is as good as its worse
    side; the "best" variant or device of a kind maximizes it."""
    return float(min(row[Y_KEY], row[X_KEY]))


def _cell(r) -> str:
    return (f"{100 * r[Y_KEY]:.0f}% / {100 * r[X_KEY]:.0f}% "
            f"(d {r['fins.depth']:g}, s {r['fins.spacing']:g})")


CRATES = ("egg-crate", "optimized egg-crate")
#: a lead smaller than this (1 point of sun or view) is within the measurement's resolution
#: (1,500 sun sample points and a few hundred eye points, the same for torsal and the devices)
MARGIN = 0.01


def _leads(tv, dv) -> np.ndarray:
    """Each torsal variant's lead over the front of the devices ``dv`` (positive: beyond)."""
    bx, by = dv[X_KEY].to_numpy(), dv[Y_KEY].to_numpy()
    return np.array([lead_over(x, y, bx, by)[0] for x, y in zip(tv[X_KEY], tv[Y_KEY])])


def summarize(key: str) -> dict:
    """Best torsal variant, best device of each kind, and the verdict's numbers of a study."""
    t = pd.read_csv(RESULTS / f"{key}.csv")
    timing = json.loads((RESULTS / f"{key}.json").read_text())
    ok = t[t["status"] == "done"].dropna(subset=[X_KEY, Y_KEY])
    tv, dv = ok[ok["kind"] == "torsal"], ok[ok["kind"] == "baseline"]
    out = {"key": key, "timing": timing, "failed": int((t[t["kind"] == "torsal"]["status"]
                                                         == "failed").sum())}
    if not tv.empty:
        best = tv.loc[tv.apply(balanced, axis=1).idxmax()]
        weights = [c for c in t.columns if c.startswith("weights.") and t[c].nunique() > 1]
        extra = "".join(f", {c.split('.', 1)[1]} {best[c]:g}" for c in weights)
        out["torsal"] = _cell(best)[:-1] + extra + ")"
    for name in DEVICE_NAMES:
        d = dv[dv["device"] == name]
        if d.empty:
            na = t[(t["device"] == name) & (t["status"] == "not applicable")]
            out[name] = "n/a" if not na.empty else "-"
        else:
            out[name] = _cell(d.loc[d.apply(balanced, axis=1).idxmax()])
    if not tv.empty and not dv.empty:
        leads = _leads(tv, dv)
        out["beyond"], out["n"] = int((leads > MARGIN).sum()), int(len(leads))
        out["lead"] = float(leads.max())
        # where the torsal front lies beyond: the sun range of the variants beyond
        beyond = tv[leads > MARGIN]
        out["beyond_sun"] = (float(beyond[Y_KEY].min()), float(beyond[Y_KEY].max())) \
            if not beyond.empty else None
        out["max_sun"] = (float(tv[Y_KEY].max()), float(dv[Y_KEY].max()))
        front = dv.iloc[pareto_front(dv[X_KEY], dv[Y_KEY])]
        out["front_devices"] = [n for n in DEVICE_NAMES if n in set(front["device"])]
        # like for like: torsal's fins are two crossing families, as an egg-crate's are
        crates = dv[dv["device"].isin(CRATES)]
        out["lead_crates"] = float(_leads(tv, crates).max()) if not crates.empty else None
    return out


def verdict(s: dict) -> str:
    """One sentence from the numbers: does any torsal variant lie beyond every device's front,
    by how much, which devices hold the front, and how torsal does against the egg-crates."""
    if "lead" not in s:
        return "no comparison (a study did not finish)"
    held = ", ".join(s["front_devices"])
    crates = s.get("lead_crates")
    like = "" if crates is None else (
        f"; against the egg-crates alone (two crossing families, like torsal's fins) it is "
        + (f"ahead by up to {100 * crates:.1f} points" if crates > 0
           else f"{100 * -crates:.1f} points behind too"))
    if s["beyond"]:
        lo, hi = s["beyond_sun"]
        return (f"**torsal wins** at {100 * lo:.0f}-{100 * hi:.0f}% sun: {s['beyond']} of "
                f"{s['n']} variants lie beyond every device's front by more than a point, up "
                f"to {100 * s['lead']:.1f} points (front of the devices: {held})")
    if s["lead"] > -MARGIN:
        return (f"**level**: the best variant is within a point of the devices' front "
                f"({100 * s['lead']:+.1f} points; front: {held}; most sun: torsal "
                f"{100 * s['max_sun'][0]:.0f}%, devices {100 * s['max_sun'][1]:.0f}%){like}")
    return (f"**torsal loses**: no variant reaches the devices' front, the closest is "
            f"{100 * -s['lead']:.1f} points behind (front: {held}; most sun: torsal "
            f"{100 * s['max_sun'][0]:.0f}%, devices {100 * s['max_sun'][1]:.0f}%){like}")


def table_markdown(keys=KEYS) -> str:
    rows = [summarize(k) for k in keys if (RESULTS / f"{k}.csv").exists()]
    head = ("| example | best torsal variant | " + " | ".join(DEVICE_NAMES)
            + " | verdict | variants (failed) / solves | study time |")
    lines = [head, "|" + "---|" * (len(DEVICE_NAMES) + 5)]
    total = 0.0
    for s in rows:
        tm = s["timing"]
        total += tm["wall_s"]
        lines.append(f"| {s['key']} | {s.get('torsal', 'failed')} | "
                     + " | ".join(s.get(n, "-") for n in DEVICE_NAMES)
                     + f" | {verdict(s)} | {tm['variants']} ({s['failed']}) / {tm['solves']} | "
                     f"{tm['wall_s'] / 60:.1f} min (load {tm['load_start']:.0f}-{tm['load_end']:.0f}, "
                     f"{tm['date']}) |")
    lines.append("")
    lines.append(f"All {len(rows)} studies: {total / 60:.0f} min wall time.")
    return "\n".join(lines)


def update_readme(readme: Path = HERE / "README.md") -> None:
    text = readme.read_text()
    start, end = text.index(BEGIN) + len(BEGIN), text.index(END)
    readme.write_text(text[:start] + "\n" + table_markdown() + "\n" + text[end:])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/studies"))
    p.add_argument("--only", nargs="*", default=list(KEYS))
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--table-only", action="store_true",
                   help="rewrite the README table from examples/studies/results only")
    args = p.parse_args(argv)
    if not args.table_only:
        for key in args.only:
            timing = run(key, args.out, args.workers)
            print(f"{key}: {timing['wall_s']:.0f} s, {timing['variants']} variants, "
                  f"{timing['solves']} solves; {timing['verdict']}")
    update_readme()
    print(table_markdown())
    return 0


if __name__ == "__main__":
    sys.exit(main())
