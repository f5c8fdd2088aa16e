"""check_assembly on a finished design run: its time and its verdicts, for a before/after
comparison of the assembly check (issue 15).

    nice -n 19 .venv/bin/python benchmarks/assembly_bench.py OUT --json verdicts.json [--workers 1] [--profile] [--memo]
    .venv/bin/python benchmarks/assembly_bench.py --compare before.json after.json

``OUT`` is the output folder of ``torsal design`` (``fins.step`` and the stage cache with the
fabrication stage's joint records). The verdicts written are the interfering pairs with their
volumes, the failed pairs, ``pairs_checked``, the assembly order (part, direction, travel,
partners, collision volumes) and the blocked parts. ``--compare`` exits 1 when any verdict
differs (volumes within 1e-6 relative, directions and travels within 1e-9).

Example 7a at full size (453 solids, 398 joints; 2026-11-23, 2 cores shared, load in
brackets), CPU including the worker processes:

=====================================  ===================  ===================
check_assembly                         before (da2aa42)     after
=====================================  ===================  ===================
workers=1                              21.5 s CPU (2.6)     12.8 s CPU (2.9)
workers=2 (default)                    23.9 s CPU, 12.7 s   14.6 s CPU, 9.4 s
                                       wall (1.7)           wall (2.9)
booleans: touching pairs / path prisms 2,442 / 5,069        290 / 607
=====================================  ===================  ===================

Loading (fins.step re-read, joints from the stage cache): 3.7 s CPU, unchanged. Verdicts
identical before and after on 7a and on the 9 cases of ``--fixtures``.

2026-11-28 (issue 40), 7a at full size, 314 solids, 405 joints, ``--memo``, load 4.3 (the two
workers got one core between them)::

    | check                  | pairs | paths | seconds | memo hits | memo misses |
    | cold                   | 1481  | 314   | 18.0    | 0         | 1744        |
    | re-run, from the memo  | 1481  | 314   | 0.5     | 1744      | 0           |

Booleans, touching pairs / path prisms: 262 / 635 before the egg-crate slots' ends stood the
clearance apart (commit 6872e6c), 0 / 0 after (204f94c): 36.0 -> 18.4 s of CPU with one
worker, the same verdicts. What is left is the cheap exact tests (separating axes, about
two thirds) and the solids' meshing, which the process that re-reads fins.step now does.
"""
from __future__ import annotations

import argparse
import json
import pickle
import sys
import time
from pathlib import Path


def load(out: Path, prepared: bool = False):
    """``(solids, joints, seconds)`` of a design run folder: the solids re-read from fins.step
    (with ``prepared``, as the pipeline's background read gives them: meshed, with the
    records of the cheap tests, :mod:`torsal.fabrication.assembly.prepared`), the joint
    records from the cached fabrication stage."""
    from torsal.fabrication import read_step
    from torsal.fabrication.assembly import TOUCHING_TOLERANCE
    from torsal.fabrication.exports import read_step_for_check

    t = time.process_time()
    solids = (read_step_for_check(out / "fins.step", mesh_tolerance=TOUCHING_TOLERANCE)
              if prepared else read_step(out / "fins.step"))
    pkl = sorted((out / ".torsal-cache").glob("fabrication-*.pkl"))[-1]
    with open(pkl, "rb") as fh:
        fab = pickle.load(fh)
    joints = fab["joints"] if isinstance(fab, dict) and "joints" in fab else fab.value["joints"]
    return solids, joints, time.process_time() - t


def verdicts(check) -> dict:
    return {
        "pairs_checked": check.pairs_checked,
        "interfering": sorted([sorted(x.parts), x.volume] for x in check.interfering),
        "failed": sorted(list(x[:2]) for x in check.failed_pairs),
        "blocked": sorted(s.part for s in check.blocked),
        "order": [{"part": s.part, "direction": s.insert_direction, "travel": s.travel,
                   "partners": list(s.partners), "kinds": list(s.joint_kinds),
                   "collisions": [[list(c.parts), c.volume] for c in s.collisions]}
                  for s in check.order],
    }


def fixture_verdicts() -> dict:
    """Verdicts of check_assembly on the constructed cases of tests/fabrication: buildable,
    interfering (a crossing kept) and blocked (the path check off) ones."""
    import warnings

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "fabrication"))
    from fab_structures import (blocked_slide_structure, crossing_strips_structure,
                                cylinder_structure, sphere_structure)

    from torsal.fabrication import FinSystem, check_assembly

    def fs(structure, **kw):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return FinSystem(structure, **({"thickness": 3.0, "clearance": 0.5} | kw))

    cases = {
        "sphere": lambda: fs(sphere_structure(nu=4, nv=3, step=0.12)),
        "cylinder-closed": lambda: fs(cylinder_structure(nu=6, nv=3, closed=True)),
        "cylinder-mitred": lambda: fs(cylinder_structure(nu=6, nv=1), max_panels=2, fit_sheet=None),
        "crossing-strips": lambda: fs(crossing_strips_structure()),
        "blocked-slide": lambda: fs(blocked_slide_structure()),
        "blocked-slide-behind": lambda: fs(blocked_slide_structure(behind=True)),
    }
    out = {}
    t0 = time.process_time()
    for name, make in cases.items():
        f = make()
        out[name] = verdicts(check_assembly(f.solids(workers=1), joints=f.joints, workers=1))
    # controls that the checks must find: a clash kept, paths left unchecked by the builder
    orig_clash, orig_paths = FinSystem._clashing_panels, FinSystem._check_paths
    try:
        FinSystem._clashing_panels = lambda self, **kw: []
        f = fs(crossing_strips_structure())
        out["crossing-strips-kept"] = verdicts(check_assembly(f.solids(workers=1),
                                                              joints=f.joints, workers=1))
        FinSystem._clashing_panels = orig_clash
        FinSystem._check_paths = lambda self: None
        for behind in (False, True):
            f = fs(blocked_slide_structure(behind=behind))
            out[f"blocked-slide-unchecked-{behind}"] = verdicts(
                check_assembly(f.solids(workers=1), joints=f.joints, workers=1))
    finally:
        FinSystem._clashing_panels, FinSystem._check_paths = orig_clash, orig_paths
    for name, v in out.items():
        print(f"{name}: {v['pairs_checked']} pairs, {len(v['interfering'])} interfering, "
              f"{len(v['blocked'])} blocked, {len(v['order'])} steps")
    print(f"{time.process_time() - t0:.1f} s CPU")
    return out


def _close(a, b, rel):
    return abs(a - b) <= rel * max(abs(a), abs(b)) or a == b


def compare(a: dict, b: dict) -> list[str]:
    """Differences between two verdict records (empty: identical)."""
    bad = []
    for key in ("pairs_checked", "failed", "blocked"):
        if a[key] != b[key]:
            bad.append(f"{key}: {a[key]} != {b[key]}")
    ia, ib = a["interfering"], b["interfering"]
    if [x[0] for x in ia] != [x[0] for x in ib] or not all(
            _close(x[1], y[1], 1e-6) for x, y in zip(ia, ib)):
        bad.append(f"interfering: {ia[:5]} != {ib[:5]}")
    if len(a["order"]) != len(b["order"]):
        bad.append("order length differs")
    for sa, sb in zip(a["order"], b["order"]):
        same = (sa["part"] == sb["part"] and sa["partners"] == sb["partners"]
                and sa["kinds"] == sb["kinds"] and _close(sa["travel"], sb["travel"], 1e-9)
                and (sa["direction"] is None) == (sb["direction"] is None)
                and (sa["direction"] is None or all(abs(x - y) <= 1e-9 for x, y in
                                                    zip(sa["direction"], sb["direction"])))
                and [c[0] for c in sa["collisions"]] == [c[0] for c in sb["collisions"]]
                and all(_close(x[1], y[1], 1e-6) for x, y in zip(sa["collisions"], sb["collisions"])))
        if not same:
            bad.append(f"step {sa['part']}: {sa} != {sb}")
    return bad


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", nargs="?", type=Path)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--profile", type=Path, help="write cProfile stats here (workers=1)")
    ap.add_argument("--compare", nargs=2, type=Path)
    ap.add_argument("--prepared", action="store_true",
                    help="the solids as the pipeline gives them (records made while loading)")
    ap.add_argument("--memo", action="store_true",
                    help="also the check again from its memo (pairs, seconds, memo hits)")
    ap.add_argument("--fixtures", action="store_true",
                    help="the test-size cases of tests/fabrication instead of OUT (--json: one "
                         "record per case)")
    args = ap.parse_args(argv)
    if args.compare:
        a, b = (json.loads(p.read_text()) for p in args.compare)
        if "order" not in a:                 # --fixtures records: one per case
            bad = [f"{k}: {x}" for k in sorted(set(a) | set(b))
                   for x in (compare(a[k], b[k]) if k in a and k in b else ["missing"])]
            print("\n".join(bad[:20]) if bad else f"identical: {len(a)} cases")
            return 1 if bad else 0
        bad = compare(a, b)
        print("\n".join(bad[:20]) if bad else
              f"identical: {a['pairs_checked']} pairs checked, {len(a['interfering'])} "
              f"interfering, {len(a['blocked'])} blocked, {len(a['order'])} steps")
        return 1 if bad else 0
    import os

    from torsal.fabrication import check_assembly

    if args.fixtures:
        got = fixture_verdicts()
        if args.json:
            args.json.write_text(json.dumps(got, indent=0))
        return 0

    t0w = time.perf_counter()
    solids, joints, load_cpu = load(args.out, args.prepared)
    load_wall = time.perf_counter() - t0w
    phases = {}

    def progress(phase, done, total):
        if done == 1:
            phases[phase] = time.perf_counter()

    t0, w0 = time.process_time(), time.perf_counter()
    c0 = os.times()
    if args.profile:
        import cProfile

        prof = cProfile.Profile()
        prof.enable()
    check = check_assembly(solids, joints=joints, workers=args.workers, progress=progress)
    if args.profile:
        prof.disable()
        prof.dump_stats(str(args.profile))
    c1 = os.times()
    cpu = (c1.user - c0.user) + (c1.system - c0.system) + (c1.children_user - c0.children_user) \
        + (c1.children_system - c0.children_system)
    wall = time.perf_counter() - w0
    load1 = os.getloadavg()[0]
    print(f"{len(solids)} solids, {len(joints)} joints: load (read STEP + joints) "
          f"{load_cpu:.1f} s CPU {load_wall:.1f} s wall; check_assembly {cpu:.1f} s CPU "
          f"(incl. workers) {wall:.1f} s wall, workers={args.workers}, load avg {load1:.2f}")
    print("phase starts (s after start):", {k: round(v - w0, 1) for k, v in phases.items()})
    print(f"pairs_checked {check.pairs_checked}, interfering {check.interfering_pairs}, "
          f"blocked {len(check.blocked)}, buildable {check.buildable}")
    if args.json:
        args.json.write_text(json.dumps(verdicts(check), indent=0))
    if args.memo:
        memo_table(args.out, solids, joints, args.workers)
    return 0


def memo_table(out: Path, solids, joints, workers) -> None:
    """The check cold, then again from its memo on the solids re-read (a design's re-run or a
    study variant whose parts did not change): pairs, seconds, memo hits, the same verdicts."""
    from torsal.fabrication import check_assembly, read_step
    from torsal.fabrication.assembly import AssemblyMemo

    memo = AssemblyMemo()
    rows = []
    for label, shapes in (("cold", solids), ("re-run, from the memo", read_step(out / "fins.step"))):
        w0 = time.perf_counter()
        check = check_assembly(shapes, joints=joints, workers=workers, memo=memo)
        rows.append((label, check, time.perf_counter() - w0))
    print("\n| check | pairs | paths | seconds | memo hits | memo misses | same verdicts |")
    print("|---|---|---|---|---|---|---|")
    first = verdicts(rows[0][1])
    for label, check, wall in rows:
        print(f"| {label} | {check.pairs_checked} | {len(check.order)} | {wall:.1f} | "
              f"{check.memo_hits} | {check.memo_misses} | "
              f"{'yes' if not compare(first, verdicts(check)) else 'NO'} |")


if __name__ == "__main__":
    sys.exit(main())
