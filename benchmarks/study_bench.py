"""A 16-variant design study of Fig. 7a, serial (one process, no Dask) against 2 Dask
workers (an embedded LocalCluster), and the congruence solves the shared stage cache saves.

Both runs give a variant one core: a Dask worker is one single-threaded process (its stages
cannot fork process pools), and the serial run caps the stages' own pools (solids, assembly
check) to its one process (``Study.run(serial=True)``), so the speed-up measures the study's
parallelism, not the stages'. CPU seconds include finished child processes.

The study: 7a at the test size of tests/test_examples.py (15 x 11 vertices, 300 light
samples, no STEP/3DM) over fins.spacing [1.5, 1.75, 2.0, 2.25] x fins.depth [0.3, 0.5] x
weights.perp [1, 10]: 16 variants, 2 distinct congruences. ``--size full`` uses the
paper-size facade (33 x 33) and spacings [0.5, 0.6, 0.7, 0.8] instead (about 45 s per
variant; minutes). Each run starts in a fresh folder (nothing resumed). The Dask run is
timed without and with starting the cluster. Other programs on the machine change the
timings: the load average (``uptime``) and the CPU seconds each run got are printed next to
them (cores used = CPU seconds / wall seconds).

``--size issue40`` is issue 40's study: 7a on a 9 x 9 mesh, fabrication on, fins.spacing
[1.5, 2.0] x fins.depth [0.3, 0.5] (4 variants; target 60 s with 2 workers), and prints each
variant's stage seconds. Measured 2026-11-28 22:47 UTC (commit b327f26, load 2.0 before, other
jobs on the machine: the runs got 0.63-0.67 of its 2 cores)::

    run                               wall s   cpu s cores used  done solves  saved
    serial (1 process, 1 core)          32.6    21.7       0.67     4      1      3
    Dask, 2 workers                     42.1    26.7       0.63     4      1      3

    starting the cluster and importing on its workers (warm_up): 15.0 s

    | variant | spacing | depth | wall s | assembly | congruence | fabrication |
    | 000 | 1.5 | 0.3 | 15.5 | 7.9 | 0.3 | 6.9 |
    | 001 | 1.5 | 0.5 | 10.0 | 5.0 | cached | 4.6 |
    | 002 | 2 | 0.3 | 13.1 | 7.8 | cached | 4.9 |
    | 003 | 2 | 0.5 | 14.4 | 8.3 | cached | 5.6 |

Again 2026-11-29 17:19 UTC (commit d0af5b7, quiet, load 0.8-1.4): serial 23.7 s (1.01 cores),
Dask 2 workers 19.9 s (1.40 cores; 27.1 s with the cluster's 7.2 s start); the variants 7.3,
7.1, 4.0 and 5.6 s (assembly check 1.7-3.7 s, fabrication 2.1-3.5 s, congruence 0.2 s once,
cached for the three others).

Again 2026-11-30 06:41 UTC (commit a369949, quiet, load 2.0-2.1): Dask 2 workers 19.5 s (1.36
cores; 26.9 s with the cluster's 7.4 s start); the variants 6.1, 6.7, 3.8 and 5.1 s (assembly
check 1.7-3.2 s, fabrication 1.9-3.3 s, congruence 0.2 s once, cached for the three others).
The 7a example's ``costs.file`` is made absolute in the study's base (it was read relative to
the study's temporary folder, and the bench stopped with the design file's error).

(526 s on 2026-11-25's code: nesting 79 s and the assembly check 58 s per variant.)

Run: ``.venv/bin/python benchmarks/study_bench.py [--size test|full|issue40] [--workers 2]``.

Measured 2026-11-23 on the 2-core machine, quiet (load average 1.15 before, the serial run
alone on it; the other run's load comes from the run itself)::

    run                               wall s   cpu s cores used  done solves  saved
    serial (1 process, 1 core)         148.1   132.7       0.90    16      2     14
    Dask, 2 workers                     77.2   142.6       1.85    16      2     14

    starting the cluster and importing on its workers (warm_up): 7.7 s
    speed-up, 2 workers over serial: 1.92x (1.74x with the cluster's start)
"""
from __future__ import annotations

import argparse
import logging
import os
import resource
import tempfile
import time
import tomllib
from pathlib import Path

import tomli_w

from torsal import Study

ROOT = Path(__file__).resolve().parents[1]


def write_study(folder: Path, size: str) -> Path:
    d = tomllib.loads((ROOT / "examples" / "7a_facade_block.toml").read_text())
    if "file" in d.get("costs", {}):      # relative to the example, not to the study's folder
        d["costs"]["file"] = str((ROOT / "examples" / d["costs"]["file"]).resolve())
    if size == "issue40":
        # issue 40's study: 7a on a 9 x 9 mesh, fabrication on, 4 variants (depth x spacing),
        # what a variant writes by default (its report.json)
        d["surface"]["params"] = {"nu": 9, "nv": 9}
        d["outputs"] = {"light_samples": 300}
        d["material"]["sheet_mm"] = [4000, 2000]
        d["constraints"]["max_iter"] = 400
        axes = {"fins.spacing": [1.5, 2.0], "fins.depth": [0.3, 0.5]}
    elif size == "test":
        d["surface"]["params"] = {"nu": 15, "nv": 11}
        d["outputs"] = {"light_samples": 300, "step": False, "rhino_3dm": False}
        d["material"]["sheet_mm"] = [4000, 2000]
        d["constraints"]["max_iter"] = 400
        spacing = [1.5, 1.75, 2.0, 2.25]
    else:
        spacing = [0.5, 0.6, 0.7, 0.8]
    if size != "issue40":
        axes = {"fins.spacing": spacing, "fins.depth": [0.3, 0.5], "weights.perp": [1, 10]}
    (folder / "base.toml").write_text(tomli_w.dumps(d))
    study = {"name": f"7a bench ({size})", "base": "base.toml", "axes": axes,
             "run": {"workers": 2}}
    path = folder / "study.toml"
    path.write_text(tomli_w.dumps(study))
    return path


def load() -> str:
    return "load average " + ", ".join(f"{x:.2f}" for x in os.getloadavg())


def _cpu_seconds() -> float:
    """CPU seconds of this process and of its finished children (e.g. a process pool)."""
    return sum(r.ru_utime + r.ru_stime for r in (resource.getrusage(resource.RUSAGE_SELF),
                                                 resource.getrusage(resource.RUSAGE_CHILDREN)))


def warm_up() -> None:
    """Import what a variant uses, as a process does once (about 4 CPU-seconds): both runs
    are timed on warm processes, the Dask workers' start is timed on its own."""
    import build123d  # noqa: F401
    import ezdxf  # noqa: F401
    import matplotlib.pyplot  # noqa: F401
    import pvlib  # noqa: F401

    import torsal.fabrication  # noqa: F401
    import torsal.light  # noqa: F401
    import torsal.pipeline.report  # noqa: F401


def serial_run(study: Study, out: Path):
    warm_up()
    c0, t0 = _cpu_seconds(), time.perf_counter()
    res = study.run(out, serial=True)
    return time.perf_counter() - t0, _cpu_seconds() - c0, res


def dask_run(study: Study, out: Path, workers: int):
    """The study on a LocalCluster like the one Study.run starts, timed with and without
    the cluster's start; CPU seconds of the worker processes from the workers themselves."""
    from distributed import Client, LocalCluster

    t0 = time.perf_counter()
    cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR)
    client = Client(cluster)
    client.run(warm_up)
    t_start = time.perf_counter() - t0
    cpu0 = sum(client.run(_cpu_seconds).values())
    t1 = time.perf_counter()
    res = study.run(out, client=client)
    t_run = time.perf_counter() - t1
    cpu = sum(client.run(_cpu_seconds).values()) - cpu0
    client.close()
    cluster.close()
    return t_start, t_run, cpu, res


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", choices=("test", "full", "issue40"), default="test")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        study = Study.from_toml(write_study(tmp, args.size))
        n = len(study.variants)
        print(f"7a study, {args.size} size: {n} variants, {os.cpu_count()} cores; before: {load()}")
        t_serial, cpu_serial, r_serial = serial_run(study, tmp / "serial")
        ld_serial = load()
        t_start, t_dask, cpu_dask, r_dask = dask_run(study, tmp / "dask", args.workers)
        ld_dask = load()
        print(f"\n{'run':32s} {'wall s':>7s} {'cpu s':>7s} {'cores used':>10s} {'done':>5s} "
              f"{'solves':>6s} {'saved':>6s}  load after")
        for name, t, cpu, r, ld in (
                ("serial (1 process, 1 core)", t_serial, cpu_serial, r_serial, ld_serial),
                (f"Dask, {args.workers} workers", t_dask, cpu_dask, r_dask, ld_dask)):
            done = int(((r.table["kind"] == "torsal") & (r.table["status"] == "done")).sum())
            print(f"{name:32s} {t:7.1f} {cpu:7.1f} {cpu / t:10.2f} {done:5d} {r.solves:6d} "
                  f"{r.solves_saved:6d}  {ld}")
        print(f"\nstarting the cluster and importing on its workers (warm_up): {t_start:.1f} s")
        print(f"speed-up, {args.workers} workers over serial: {t_serial / t_dask:.2f}x "
              f"({t_serial / (t_dask + t_start):.2f}x with the cluster's start)")
        print(f"CPU the machine gave: serial {cpu_serial / t_serial:.2f} cores, Dask "
              f"{cpu_dask / t_dask:.2f} cores (other jobs share the {os.cpu_count()} cores)")
        print(f"congruence solves: {r_dask.solves} for {n} variants; the shared cache saved "
              f"{r_dask.solves_saved} (without it every variant solves its own)")
        secs = r_serial.table.loc[r_serial.table["kind"] == "torsal", "congruence.solve_s"]
        print(f"one congruence solve here: {secs.dropna().mean():.2f} s (IPOPT, from the reports)")
        stage_table(r_dask.table)


def stage_table(table) -> None:
    """Each variant's stage seconds (the results table's stage_s columns) of the Dask run."""
    t = table[table["kind"] == "torsal"]
    cols = sorted(c for c in t.columns if c.startswith("stage_s."))
    names = [c.split(".", 1)[1] for c in cols]
    print("\n| variant | spacing | depth | wall s | " + " | ".join(names) + " |")
    print("|" + "---|" * (4 + len(names)))
    for _, r in t.iterrows():
        cells = [f"{r[c]:.1f}" if r[c] == r[c] else "cached" for c in cols]
        print(f"| {r['id']} | {r['fins.spacing']:g} | {r['fins.depth']:g} | {r['wall_s']:.1f} | "
              + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
