"""The fabrication and assembly stages of one design, timed and fingerprinted, for a before/after
comparison of their speed (issue 25: example 9 end to end in <= 90 s).

    nice -n 5 .venv/bin/python benchmarks/design_fabrication_bench.py [--design examples/9_selective_shading.toml]
        [--congruence directions.npz] [--out DIR] [--label after] [--repeat 1]
    .venv/bin/python benchmarks/design_fabrication_bench.py --save-congruence directions.npz

The stages before the fabrication run once and are cached in ``OUT/cache`` (with
``--congruence`` the optimized directions are read from that file instead of being solved:
the congruence solve is not this benchmark's and takes a minute). Then the ``fabrication`` and
``assembly`` stages run afresh and print one row: wall and CPU seconds of each (this process,
and the processes it starts: the solid workers, the nester, the assembly check's workers),
where the wall seconds go, the load average, and fingerprints of the results: ``parts`` a
hash of every part (panels, mitres, slots, holes) and ``joints`` of every joint (kind, node,
parts, connector, directions, angle, depth), bit for bit; ``verdicts`` of the assembly
check's findings (interfering and failed pairs with their volumes, the blocked parts, the
touching pairs counted, and the assembly order with every part's direction, travel and
collisions). A speed change must leave all three as they were.

Run it with the ``torsal`` of another checkout on ``PYTHONPATH`` for the row before a change
(the script itself only uses what both have). Results below; uptime's load average at the row.

Example 9 (``--congruence`` of the augmented Lagrangian's answer on main a9bb42d, 353 Newton
steps), 2026-11-26 on the shared 2-core machine (a VM: under load its CPU seconds swell as
much as its wall seconds), ``nice -n 5``; before = cea6f27 (the build branch after the splice
fix), after = 623a96d. The same parts, joints and verdicts in every row::

    | run | commit | parts | parts hash | joints hash | verdicts hash | buildable | fabrication s | fabrication CPU s | solid workers CPU s | nester CPU s | fin system s | STEP s | 3DM s | wait for nester s | parts list s | assembly s | assembly CPU s | assembly workers CPU s | STEP re-read s | pairs s | paths s | both stages s | both stages CPU s (all processes) | load |
    |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|
    | before | cea6f27 | 1177 | 880c6a5ea298 | a7e292b778cb | 1c1331e0c1df | True | 51.2 | 24.8 | 16.5 | 1.9 | 16.0 | 24.7 | 3.4 | 0.0 | 0.1 | 40.5 | 11.2 | 30.6 | 7.1 | 15.6 | 14.7 | 91.7 | 84.9 | 2.03 / 2.73 |
    | after | 9fd9803 | 1177 | 880c6a5ea298 | a7e292b778cb | 1c1331e0c1df | True | 49.4 | 25.8 | 14.4 | 1.5 | 18.8 | 21.2 | 3.1 | 0.0 | 0.1 | 29.7 | 10.5 | 25.0 | 6.7 | 12.6 | 7.5 | 79.0 | 77.2 | 2.73 / 2.81 |
    | before | cea6f27 | 1177 | 880c6a5ea298 | a7e292b778cb | 1c1331e0c1df | True | 50.0 | 23.8 | 15.9 | 1.8 | 16.4 | 22.6 | 3.4 | 0.0 | 0.1 | 38.4 | 9.9 | 28.1 | 6.4 | 14.2 | 14.9 | 88.3 | 79.6 | 3.41 / 3.84 |
    | after | 623a96d | 1177 | 880c6a5ea298 | a7e292b778cb | 1c1331e0c1df | True | 46.8 | 22.4 | 14.3 | 1.5 | 15.6 | 22.7 | 3.3 | 0.0 | 0.1 | 43.5 | 11.1 | 31.8 | 6.7 | 15.8 | 17.6 | 90.4 | 81.0 | 3.84 / 3.95 |
    | before | cea6f27 | 1177 | 880c6a5ea298 | a7e292b778cb | 1c1331e0c1df | True | 53.8 | 26.4 | 16.3 | 2.0 | 18.1 | 22.4 | 3.7 | 0.0 | 0.1 | 43.1 | 11.9 | 31.1 | 7.7 | 16.0 | 15.8 | 96.9 | 87.8 | 3.87 / 4.11 |
    | after | 623a96d | 1177 | 880c6a5ea298 | a7e292b778cb | 1c1331e0c1df | True | 54.1 | 25.4 | 17.0 | 1.9 | 18.7 | 25.6 | 3.3 | 0.0 | 0.1 | 40.7 | 11.9 | 28.2 | 7.8 | 14.0 | 15.7 | 94.8 | 84.4 | 4.11 / 4.72 |

At load 2-3 the assembly stage went from 40.5 to 29.7 s (its paths from 14.7 to 7.5 s); at
load 3.4-4.7 the differences drown in the machine's noise. Less noisy, each piece alone in
one process, before and after taking turns (``nice -n 5``, load 2.4-4.4), CPU seconds:

    | piece | before | after |
    |---|---|---|
    | fin system (FinSystem of the support structure) | 13.0, 14.0 | 11.1, 13.2 |
    | unrolling the 1,177 parts | 1.76, 1.79 | 1.26, 1.34 |
    | solids and their 3DM Breps, one process | 13.1, 13.6 | 13.1, 13.7 |
    | fins.step re-read | 6.4, 6.4 | 6.3, 5.9 |
    | assembly check, one process | 25.4, 23.5 | 21.3, 21.1 |
    | its exact booleans | 1,166 | 370 |

Where the rest goes (after): the fin system is five builds of the joinery (each panel left
out or joint changed builds it again) and two path checks, single-threaded; the solid
workers spend a third of their time on the 3DM's Breps (rhino3dm's encode and decode twice a
part); the STEP re-read is OpenCascade's reader (5.3 s in its transfer and healing, which is
what turned 7c's plate round, so it stays); the check's 370 remaining booleans are pairs that
truly touch (90, common volumes up to 6e-4 mm^3) and path prisms sliding along a face. End to
end (``examples/run_all.py --only 9``, 13:25, load 3.0-3.6, after 623a96d): 166 s, of which
congruence 72.8 s, fabrication 46.8 s, assembly 40.2 s, everything else 6 s.

Issue 25's 90 s, 2026-11-26 15:38-15:48 (the congruence of main fcdeee4's augmented
Lagrangian: 1,409 parts, 54 sheets, 63 panels left out), before = main 18e008f, after =
a6383f5 and 410ba6a (build branch; 410ba6a: the workers make the 3DM's Breps after the
solids, so ``STEP s`` no longer waits for them and ``3DM s`` does). One core was busy with the
lead's optimizer benchmark throughout (load 2.5-4), so the wall seconds are close to the CPU
seconds. The same parts, joints and verdicts in every row, and the same fins.3dm (1,409 valid
Brep solids, the same vertices, faces, edges and boxes; the assembly stage's ``STEP re-read
s`` is now its wait for the background read: the reader's own 8 s are not in ``both stages
CPU s``)::

    | run | commit | parts | parts hash | joints hash | verdicts hash | buildable | fabrication s | fabrication CPU s | solid workers CPU s | nester CPU s | fin system s | STEP s | 3DM s | wait for nester s | parts list s | assembly s | assembly CPU s | assembly workers CPU s | STEP re-read s | pairs s | paths s | both stages s | both stages CPU s (all processes) | load |
    |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|
    | before | 18e008f | 1409 | f108a7dc327f | 2857921d7a8f | a426eec31c3c | True | 51.5 | 26.1 | 15.2 | 2.0 | 18.1 | 23.7 | 3.6 | 0.0 | 0.1 | 40.4 | 12.7 | 27.2 | 8.1 | 13.9 | 15.0 | 91.9 | 83.1 | 2.55 / 3.26 |
    | after | a6383f5 | 1409 | f108a7dc327f | 2857921d7a8f | a426eec31c3c | True | 57.9 | 27.5 | 15.7 | 2.0 | 20.0 | 24.1 | 7.5 | 0.0 | 0.2 | 30.9 | 4.0 | 23.4 | 4.2 | 12.3 | 11.7 | 88.9 | 72.6 | 3.26 / 3.23 |
    | after | 410ba6a | 1409 | f108a7dc327f | 2857921d7a8f | a426eec31c3c | True | 53.9 | 23.2 | 15.0 | 2.1 | 14.6 | 18.5 | 14.8 | 0.0 | 0.1 | 27.7 | 3.7 | 21.4 | 2.0 | 11.6 | 11.1 | 81.7 | 65.3 | 3.18 / 3.92 |

Each piece alone in one process, before and after taking turns (load 2.5-4), CPU seconds:

    | piece | before (18e008f) | after (a6383f5) |
    |---|---|---|
    | fin system (two checks of the paths; the second looks up what the first measured) | 16.1, 17.3 | 12.8, 12.8 |
    | assembly check, one process (the inside test skips solids outside the other's box) | 22.8 | 21.1 |
    | assembly check, two workers: this process + workers (one pool for pairs and paths, 679f2e9) | 2.7 + 24.9 | 2.7 + 23.4 |

End to end (example 9, the congruence from the stage cache; stage seconds, load 2.7-4.2):

    | stage | before (18e008f) | after |
    |---|---|---|
    | support | 7.4 | 9.0 |
    | fabrication (fin system, solids, STEP, 3DM, sheets, parts list) | 54.1 | 54.0 |
    | devices + light | 1.3 | 2.3 |
    | assembly (its wait for the STEP read; pairs; paths; picture) | 40.8 (7.7 read; 14.2; 14.9; 1.7) | 29.2 (2.5; 11.8; 11.8; 1.5) |
    | report | 2.6 | 2.1 |
    | after the congruence, wall | 106.6 | 97.5 |

A third run (410ba6a, 15:57, load 4.1-4.4: two of the lead's optimizer jobs) took 110.3 s
after the congruence: support 17.6 s (IPOPT alone, 7.4 s at load 2.7), fabrication 57.7 s
(fin system 16.4, the solids 9.5, STEP 9.1, 3DM 14.9), assembly 28.8 s (its wait for the read
0.3 s): with both cores taken by others the stages only trade places; the seconds that leave
the critical path show on a quiet machine.

Back to back at 16:12-16:16 (load 3.0-3.8, one of the lead's jobs running), after the
congruence: after (410ba6a) 100.2 s = support 8.2, fabrication 57.5 (fin system 17.6, solids
9.1, STEP 9.2, 3DM 14.9), devices + light 2.4, assembly 28.3 (read wait 0.9, pairs 12.8, paths
11.5), report 3.0; before (18e008f) 103.8 s = support 9.1, fabrication 53.4 (fin system 20.4,
solids 18.8, STEP 4.3, 3DM 3.7), devices + light 1.1, assembly 37.1 (read 7.4, pairs 12.8,
paths 13.9), report 2.2; this process's CPU 51.6 -> 41.8 s. Under such load the STEP write and
the 3DM's wait share the cores with the Breps and the background read (the work moved, it did
not go away).

Where the rest goes (after, CPU seconds alone): the support stage is IPOPT (eq. 8, 11 solves,
7.4-9 s); the fin system 12.8 s, single-threaded: 8.4 s in its 7 builds of the joinery
(strips 2.4, ends 3.5, fixings 1.2, butt directions 0.7) and 4.0 s in the two checks of the
paths; the solid workers 15-19 s, of which the 3DM's Breps 8 s (meshing 1.8, rhino3dm's mesh
1.9, CreateFromMesh 0.5, the edge-tolerance repair's encode and decode 3.0, the encoding 1.0);
STEP write 3.5 s and its re-read 8.3 s (parse 2-2.7, transfer and healing 5-6), one after the
other on the critical path; the check's meshing 1.9 s and paths' plans 1 s in one process,
its pairs 12 s and paths 9-11 s in two workers. On a quiet machine the stages after the
congruence add up to about 60 s by these numbers (support 8, fin system 13, solids 11.5, STEP
3.5, the read 8.5 beside the 3DM and light, check 15).

Issue 40 (``make demo`` <= 45 s, 7a at full size <= 30 s), 2026-11-29: work taken out of the
fabrication, assembly and report stages, the same outputs. Before = the working tree of 07:03
(main 9d4e06a and the plates package being split), after = the same tree with adb0f7e (the
seams' local checks without build123d in the workers), b9e572d (the pairs' first cheap proof
one vectorized pass per solid), c2f9b54 (pictures without savefig's extra draw), 7c6067b (the
paths' prisms proved clear from the face's triangles before OpenCascade builds them) and
2200d67 (solids meshed by the reading process not meshed again). Whole runs, before and after
taking turns, in a cpuacct cgroup (CPU of every process: the fork server's workers, the STEP
reader, the check's workers); the machine at load 18-29 throughout (about 6 engineers on 2
cores), so the wall seconds say little, the CPU seconds are what to compare, and even they
swell under such load::

    | run                                    | before wall s | before CPU s | after wall s | after CPU s | load      |
    |----------------------------------------|---------------|--------------|--------------|-------------|-----------|
    | 7a full size, all stages (1st pair)    | 179.9         | 71.6         | 179.1        | 71.4        | 25 -> 28  |
    | 7a full size, all stages (2nd pair)    | 119.5         | 68.0         | 123.6        | 56.2        | 26 -> 20  |
    | make demo's three commands (1st pair)  | 183.6         | 84.2         | 132.4        | 68.3        | 28 -> 26  |
    | make demo's three commands (2nd pair)  | 194.9         | 78.2         | 165.8        | 70.3        | 20 -> 19  |

parts.csv (2e328af7dee5), assembly.csv (b0085b1bccfc), the 40 DXF sheets (52094f258a4c),
fins.step, fins.ifc, the PNGs and report.json (but its seconds) identical in all eight runs;
fins.3dm differs between any two runs of the same code (rhino3dm's time stamp and the length
of what follows it: 14,884,847-14,884,865 bytes over six runs of either).

Each piece alone, old and new taking turns in one process (CPU s, load 15-25), every result
identical: the check's 1,478 pairs 4.11/4.20/4.55 -> 3.07/3.15/2.88; its 188 first tries of the
paths 3.87/3.73 -> 2.87/2.57; its meshing of the re-read solids before the workers fork 0.70 ->
0.01; a picture like sheets.png 3.53/3.13 -> 2.78/2.32; and build123d's import (2.0 s in each of
the two workers that ran the seams' local checks) gone. What is left, by a py-spy profile of
7a (load 15, samples swollen about 2.6 times): the main process about 35 s (report pictures,
fin system, IFC, STEP write and collecting the solids, nesting and the DXF written and read
back), the seams' 69 local checks about 5 s (their slotted solids 40 %, the check 60 %), the
solids 7 s, the STEP re-read 8 s (its transfer and healing 4 s), the check's workers 7 s (6.7 s in
this benchmark's cold row after the changes, 11.2 before the pairs and paths changes).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import resource
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fabrication_bench import _timed_steps, load_average  # noqa: E402

HERE = Path(__file__).resolve().parent.parent
COLUMNS = [("label", "run"), ("commit", "commit"), ("parts_n", "parts"), ("parts", "parts hash"),
           ("joints", "joints hash"), ("verdicts", "verdicts hash"), ("buildable", "buildable"),
           ("fabrication_s", "fabrication s"), ("fabrication_cpu", "fabrication CPU s"),
           ("solids_cpu", "solid workers CPU s"), ("nest_cpu", "nester CPU s"),
           ("fin_system_s", "fin system s"), ("step_s", "STEP s"), ("rhino_s", "3DM s"),
           ("join_s", "wait for nester s"), ("bom_s", "parts list s"),
           ("assembly_s", "assembly s"), ("assembly_cpu", "assembly CPU s"),
           ("assembly_children_cpu", "assembly workers CPU s"), ("read_step_s", "STEP re-read s"),
           ("pairs_s", "pairs s"), ("paths_s", "paths s"), ("both_s", "both stages s"),
           ("both_cpu", "both stages CPU s (all processes)"), ("load", "load")]


def _digest(items) -> str:
    h = hashlib.sha256()
    for x in items:
        if isinstance(x, np.ndarray):
            h.update(str(x.dtype).encode() + str(x.shape).encode())
            h.update(np.ascontiguousarray(x).tobytes())
        else:
            h.update(repr(x).encode())
    return h.hexdigest()[:12]


def parts_hash(fs) -> str:
    """Every part of a fin system, bit for bit: name, panels, mitres, nodes, edges, ends,
    trimmed ends, slots and holes."""
    items = []
    for p in sorted(fs.parts, key=lambda p: p.name):
        items += [p.name, np.asarray(p.panels), np.asarray(p.miters), np.asarray(p.nodes),
                  np.asarray(p.edges), tuple(p.ends), tuple(p.trimmed)]
        for s in p.slots:
            items += [repr(s)]
        for h in p.holes:
            items += [np.asarray(h.center), h.diameter, h.panel, h.fastener, h.shared]
    return _digest(items)


def joints_hash(fs) -> str:
    """Every joint of a fin system, bit for bit (directions included)."""
    items = []
    for j in fs.joints:
        items += [str(j.kind), j.node, tuple(j.parts), j.connector, j.angle, j.depth,
                  None if j.insert_direction is None else np.asarray(j.insert_direction),
                  None if j.connector_direction is None else np.asarray(j.connector_direction)]
    return _digest(items)


def verdicts_hash(report: dict, csv: Path) -> str:
    """The assembly check's findings: its report section without the seconds, and its CSV
    (the assembly order: part, direction, travel, partners, collisions)."""
    r = {k: v for k, v in report.items() if k not in ("seconds", "picture", "csv")}
    return _digest([json.dumps(r, sort_keys=True, default=str), csv.read_bytes()])


def _pipeline(congruence: Path | None):
    from torsal.pipeline import DEFAULT_PIPELINE, Stage

    pipe = DEFAULT_PIPELINE.until("assembly")
    keep = [s for s in pipe if s.name not in ("devices", "light", "substructure")]
    if congruence is not None:
        z = np.load(congruence)
        digest = hashlib.sha256(Path(congruence).read_bytes()).hexdigest()

        def saved(inp):
            if not np.allclose(inp["orient"]["vertices"], z["vertices"]):
                raise SystemExit(f"{congruence} is not this design's congruence")
            return {"directions": z["directions"], "report": {}}
        keep = [Stage("congruence", saved, inputs=("orient", "sun"), key=lambda spec: (digest,))
                if s.name == "congruence" else s for s in keep]
    return keep


def save_congruence(design: Path, out: Path, path: Path) -> None:
    """Solve the design's congruence once and keep its directions (and mesh A) in ``path``."""
    from torsal.design import Design
    from torsal.pipeline import Pipeline, StageCache
    from torsal.pipeline.stage import StageRun, run_stages

    spec = Design.from_toml(design).spec
    stages = Pipeline(tuple(s for s in _pipeline(None) if s.name in
                            ("surface", "estimate", "sun", "orient", "congruence")))
    run = run_stages(stages, spec, out, StageCache(out / "cache"), run=StageRun(report={}))
    o = run.values["orient"]
    np.savez(path, vertices=o["vertices"], faces=o["faces"],
             directions=run.values["congruence"]["directions"])


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def stage_row(design: Path, out: Path, congruence: Path | None, label: str) -> dict:
    """One run of the fabrication and assembly stages (upstream from the cache)."""
    from torsal.design import Design
    from torsal.pipeline import Pipeline, Stage, StageCache, fins
    from torsal.pipeline.stage import StageRun, run_stages

    timing: dict = {}

    def timed(stage):
        def run(inp):
            t0, c0, k0 = time.perf_counter(), time.process_time(), _children_cpu()
            try:
                return stage.run(inp)
            finally:
                timing[f"{stage.name}_s"] = time.perf_counter() - t0
                timing[f"{stage.name}_cpu"] = time.process_time() - c0
                timing[f"{stage.name}_children_cpu"] = _children_cpu() - k0
        return Stage(stage.name, run, inputs=stage.inputs, key=stage.key, cache=False,
                     section=stage.section)

    stages = [timed(s) if s.name in ("fabrication", "assembly") else s for s in _pipeline(congruence)]
    spec = Design.from_toml(design).spec
    cache = StageCache(out / "cache", prune=False)
    load0 = load_average()
    fins.forget_fin_system()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with _timed_steps(timing):
            run = run_stages(Pipeline(tuple(stages)), spec, out / "run", cache,
                             run=StageRun(report={"name": spec.name, "units": spec.units}))
    fs = fins.last_fin_system()
    fab = run.report["fabrication"]
    asm = fab["assembly"]
    solids_cpu = getattr(fs, "solids_cpu_seconds", None) or 0.0
    nest_cpu = (fab.get("nesting") or {}).get("cpu_seconds") or 0.0
    commit = subprocess.run(["git", "-C", str(Path(sys.modules["torsal"].__file__).parent),
                             "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    return {"label": label, "commit": commit, "parts_n": len(fs.parts), "parts": parts_hash(fs),
            "joints": joints_hash(fs), "verdicts": verdicts_hash(asm, out / "run" / asm["csv"]),
            "buildable": asm["buildable"], **timing, "solids_cpu": solids_cpu, "nest_cpu": nest_cpu,
            "both_s": timing["fabrication_s"] + timing["assembly_s"],
            "both_cpu": (timing["fabrication_cpu"] + timing["assembly_cpu"] + solids_cpu + nest_cpu
                         + timing["assembly_children_cpu"]),
            "load": f"{load0} / {load_average()}"}


def _cell(v) -> str:
    return f"{v:.1f}" if isinstance(v, float) else str(v)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--design", type=Path, default=HERE / "examples" / "9_selective_shading.toml")
    ap.add_argument("--congruence", type=Path, help="optimized directions (.npz of --save-congruence)")
    ap.add_argument("--save-congruence", type=Path, help="solve the congruence and keep it here")
    ap.add_argument("--out", type=Path, default=Path("/tmp/design_fabrication_bench"))
    ap.add_argument("--label", default=os.environ.get("BENCH_LABEL", "this checkout"))
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    out = args.out / args.design.stem
    out.mkdir(parents=True, exist_ok=True)
    if args.save_congruence:
        save_congruence(args.design, out, args.save_congruence)
        return
    print("| " + " | ".join(h for _, h in COLUMNS) + " |")
    print("|" + "---|" * len(COLUMNS))
    for _ in range(args.repeat):
        row = stage_row(args.design, out, args.congruence, args.label)
        print("| " + " | ".join(_cell(row.get(k, "-")) for k, _ in COLUMNS) + " |", flush=True)


if __name__ == "__main__":
    main()
