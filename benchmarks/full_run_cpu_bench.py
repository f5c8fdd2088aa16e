"""CPU seconds of every process of one full ``torsal design`` run (issue 40: 7a at full size,
all stages, in 30 s on 2 cores), and the wall seconds with the load average.

    nice -n 5 .venv/bin/python benchmarks/full_run_cpu_bench.py [--design examples/7a_facade_block.toml]
        [--torsal DIR] [--label after] [--out DIR]

Runs ``python -m torsal.cli design DESIGN --out OUT --no-cache`` with ``--torsal`` (a checkout;
default this one) on ``PYTHONPATH``, as a child subreaper (every process the run starts is
waited for here, so ``getrusage(RUSAGE_CHILDREN)`` holds the CPU seconds of all of them: the
fork server, the solids' workers, the nester, the IFC, the concurrent stages, the assembly
check's workers; ``/usr/bin/time`` misses the fork server's children). A ``sitecustomize`` put
first on ``PYTHONPATH`` makes every Python process of the run write its own CPU seconds as it
ends, named by its multiprocessing name and target (a pool worker also by the functions it
ran): one row per kind of process. A process ended by a signal writes none (``unlogged`` is
the difference). ``digest`` hashes what must not change: parts.csv, assembly.csv, the DXF
sheets and report.json without its seconds.

7a (examples/7a_facade_block.toml, 318 parts, 40 sheets), 2026-11-30 01:56-02:31 UTC, the
shared 2-core machine busy with others' work (a pytest run on two workers and designs of
example 13; load 6-10, 2-4 for the last two pairs), so the wall seconds say little and even
the CPU seconds swell with the load; before = main e005042 (the assembly check on fins.step
read again in a process of its own), after = h60-cpu 65566e4 (runs 1, 2), b38605c and
ca58d6a (3-7): the check on the solids the files are written from, the solids' workers make
its copies (:func:`torsal.fabrication.workers.check_solids`). Before and after
taking turns; CPU seconds of all processes; every "before" digest 1baba4a30ffd, every
"after" ff18dd76674f: the same parts.csv, assembly.csv, DXF sheets and report.json but its
seconds and ``pairs_checked`` (1316 -> 1315: F1-S010-P00 / A-E0078-0, 34.4 mm apart, was
counted touching on the solids read back from STEP only; the check proved it clear)::

    | run | wall s | CPU s, all processes | load (1 / 5 min, start -> end) |
    |---|---|---|---|
    | before 1 | 125.9 | 85.3 | 8.03 / 6.61 -> 7.83 / 7.26 |
    | after 1 | 120.3 | 88.1 | 7.83 / 7.26 -> 7.23 / 7.14 |
    | before 2 | 207.9 | 99.0 | 7.23 / 7.14 -> 7.48 / 7.25 |
    | after 2 | 189.8 | 81.1 | 7.48 / 7.25 -> 8.02 / 7.45 |
    | after 3 | 145.2 | 95.7 | 5.98 / 6.97 -> 7.01 / 7.17 |
    | before 3 | 172.3 | 103.4 | 7.01 / 7.17 -> 6.94 / 7.00 |
    | after 4 | 236.6 | 93.5 | 6.94 / 7.00 -> 10.25 / 8.33 |
    | before 4 | 181.4 | 100.9 | 10.25 / 8.33 -> 9.49 / 9.51 |
    | after 5 | 122.1 | 96.0 | 9.49 / 9.51 -> 7.06 / 8.59 |
    | before 5 | 122.3 | 107.0 | 7.06 / 8.59 -> 5.19 / 7.47 |
    | after 6 | 46.8 | 82.0 | 2.25 / 6.31 -> 2.32 / 5.71 |
    | before 6 | 75.3 | 89.3 | 2.32 / 5.71 -> 3.98 / 5.45 |
    | before 7 | 58.8 | 88.4 | 3.74 / 5.38 -> 3.52 / 5.06 |
    | after 7 | 65.0 | 77.1 | 3.52 / 5.06 -> 3.57 / 4.78 |

    mean of the 7 runs: before 96.2 CPU s, after 87.6: -8.6 s (-9 %); at load 2-4 (runs 6, 7)
    before 88.9, after 79.6: -9.3 s (-10 %). A third less (issue 40's 30 s) is not reached.

Per process, CPU s (runs 3-5 of each, load 6-10)::

    | process | before | after |
    |---|---|---|
    | main (the pipeline: fin system, STEP and 3DM written, the check's pairs and paths planned) | 22.9, 24.3, 26.1 | 23.5, 24.1, 24.9 |
    | solids' workers (fork server's pool): build + 3DM records | 12.7, 10.7, 12.2 | 19.9, 18.3, 18.7 (+ the check's copies) |
    | solids' workers: the seams' local checks | 10.4, 11.3, 10.9 | 11.4, 9.7, 10.9 |
    | fins.step re-read (its process + its fork) | 16.9, 15.0, 16.3 | - |
    | the check's forked workers (one ended by a signal writes no row) | 8.9, 9.1 | 4.7, 9.6, 9.5 |
    | nester (rows, DXF written and read back) | 6.8, 6.5, 7.1 | 7.4, 6.9, 7.1 |
    | fork server + resource tracker (imports: OpenCascade, the pipeline) | 5.8, 6.5, 7.1 | 5.6, 5.7, 6.0 |
    | pictures | 5.7, 5.2, 5.5 | 5.9, 5.5, 5.8 |
    | IFC | 5.2, 4.9, 5.6 | 5.6, 5.7, 4.9 |
    | devices | 2.9, 3.1, 3.0 | 3.0, 3.0, 2.9 |

The piece replaced, alone in one process taking turns (load 7.5), CPU s: fins.step read,
meshed for the check and its records made (``_read_meshed``) 13.60, 15.93; the check's copies
of the same solids made from their binary BReps (``check_record``) 5.71, 6.81. The re-read's
parse and transfer go; the meshing and the records (most of what the reading process did
after its transfer) stay, now in the solids' workers.

2026-11-30 on a quiet machine (load 1.8-2.4), one run each: 705dae3 71.0 and 71.5 CPU s of
all processes (wall 40.1, 40.2 s); a369949 (the sheets' DXF as text and not read back, the
assembly check's kernels vectorized, lazy imports and a cheaper exit, cheaper solids and IFC,
the IFC and the assembly picture deferred while the run goes on) **55.1 CPU s, wall 30.0 s**,
the same digest ff18dd76674f. Per process, a369949::

    | process | CPU s |
    |---|---|
    | solids' workers (build 12.4, seams' local checks 5.7, tabs' 1.2) | 19.6 |
    | main | 15.1 |
    | the check's forked workers | 4.3 |
    | fork server + resource tracker | 3.4 |
    | pictures | 3.4 |
    | IFC | 2.7 |
    | devices | 2.6 |
    | nester (rows, DXF written) | 1.8 |
    | the assembly picture (forked) | 1.3 |
"""
from __future__ import annotations

import argparse
import collections
import ctypes
import hashlib
import json
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent

#: written to a temporary folder put first on the run's PYTHONPATH: each process appends
#: {pid, label, cpu, fns} to $TORSAL_CPU_LOG when it ends (atexit, or os._exit for forked
#: and multiprocessing children)
HOOK = r'''
import os
_LOG = os.environ.get("TORSAL_CPU_LOG")
if _LOG:
    import atexit, json, sys, time
    # (while site runs, sys.argv[0] is "-m" or "-c": the run, or multiprocessing's fork
    # server and resource tracker)
    _state = {"label": {"-m": "main", "-c": "fork server, resource tracker"}.get(
        sys.argv[0] if sys.argv else "", "python"), "done": False, "fns": {}}

    def _write():
        if _state["done"]:
            return
        _state["done"] = True
        t = os.times()
        with open(_LOG, "a") as f:
            f.write(json.dumps({"pid": os.getpid(), "label": _state["label"],
                                "cpu": t.user + t.system, "fns": _state["fns"]}) + "\n")

    atexit.register(_write)
    _exit, _fork = os._exit, os.fork

    def _exit_logged(code):
        try:
            _write()
        finally:
            _exit(code)

    def _fork_logged():
        pid = _fork()
        if pid == 0:
            _state.update(done=False, fns={}, label="fork of " + _state["label"])
        return pid

    os._exit, os.fork = _exit_logged, _fork_logged
    import multiprocessing.process as _mpp
    _boot = _mpp.BaseProcess._bootstrap

    def _bootstrap(self, *a, **k):
        target = getattr(self._target, "__qualname__", str(self._target))
        _state["label"] = re.sub(r"-\d+$", "", self.name) + ": " + target
        return _boot(self, *a, **k)

    import re
    _mpp.BaseProcess._bootstrap = _bootstrap
    import concurrent.futures.process as _cfp
    _worker = _cfp._process_worker

    class _Timed:
        def __init__(self, q):
            self.q = q

        def get(self, *a, **k):
            item = self.q.get(*a, **k)
            if item is not None and hasattr(item, "fn"):
                fn = item.fn
                key = getattr(fn, "__qualname__", str(fn))
                if key == "_call_chunk":
                    key += ": " + getattr(item.args[0][0], "__qualname__", "?")

                def timed(*aa, **kk):
                    t0 = time.process_time()
                    try:
                        return fn(*aa, **kk)
                    finally:
                        _state["fns"][key] = _state["fns"].get(key, 0.0) + time.process_time() - t0
                item.fn = timed
            return item

        def __getattr__(self, name):
            return getattr(self.q, name)

    def _process_worker(call_queue, *a, **k):
        return _worker(_Timed(call_queue), *a, **k)

    _cfp._process_worker = _process_worker
'''


def load_average() -> str:
    one, five, _ = os.getloadavg()
    return f"{one:.2f} / {five:.2f}"


def digest(out: Path) -> str:
    """What must not change, hashed: parts.csv, assembly.csv, the DXF sheets, report.json
    without the seconds (keys ending in ``seconds``, ``_s`` or named ``build``/``ipopt``/
    ``total`` under timings)."""
    h = hashlib.sha256()
    for name in ["parts.csv", "assembly.csv"] + sorted(
            str(p.relative_to(out)) for p in (out / "sheets").glob("*.dxf")):
        h.update(name.encode() + (out / name).read_bytes())

    def clean(x):
        if isinstance(x, dict):
            return {k: clean(v) for k, v in x.items() if not re.search(
                r"(seconds|_s|^build|^ipopt|^total|^time|cpu)$", k)}
        if isinstance(x, list):
            return [clean(v) for v in x]
        return x
    h.update(json.dumps(clean(json.loads((out / "report.json").read_text())),
                        sort_keys=True).encode())
    return h.hexdigest()[:12]


def run(design: Path, torsal: Path, out: Path) -> dict:
    """One run of ``torsal design`` as this process's child subreaper: its wall seconds, the
    CPU seconds of all its processes and per kind of process."""
    libc = ctypes.CDLL(None)
    libc.prctl(36, 1, 0, 0, 0)                       # PR_SET_CHILD_SUBREAPER
    hook = Path(tempfile.mkdtemp(prefix="torsal_cpu_"))
    (hook / "sitecustomize.py").write_text(HOOK)
    log = hook / "cpu.jsonl"
    env = dict(os.environ, PYTHONPATH=f"{hook}{os.pathsep}{torsal}", TORSAL_CPU_LOG=str(log))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    load0 = load_average()
    t0 = time.perf_counter()
    with open(out.with_suffix(".log"), "w") as f:
        code = subprocess.call([sys.executable, "-m", "torsal.cli", "design", str(design.resolve()),
                                "--out", str(out), "--no-cache"], cwd=torsal, env=env,
                               stdout=f, stderr=subprocess.STDOUT)
    wall = time.perf_counter() - t0
    while True:                 # the orphans (the fork server's last children) end too
        try:
            os.wait()
        except ChildProcessError:
            break
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    rows, fns = collections.Counter(), collections.Counter()
    for line in log.read_text().splitlines():
        r = json.loads(line)
        rows[r["label"]] += r["cpu"]
        for k, v in r["fns"].items():
            fns[k] += v
    return {"exit": code, "wall": wall, "cpu": cpu, "rows": rows, "fns": fns,
            "load": f"{load0} -> {load_average()}", "digest": digest(out) if code == 0 else "-"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--design", type=Path, default=HERE / "examples" / "7a_facade_block.toml")
    ap.add_argument("--torsal", type=Path, default=HERE, help="checkout whose torsal runs")
    ap.add_argument("--label", default="run")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args()
    out = a.out or Path(tempfile.mkdtemp(prefix="torsal_full_run_")) / "out"
    r = run(a.design, a.torsal.resolve(), out)
    print(f"| {a.label} | exit {r['exit']} | wall {r['wall']:.1f} s | CPU {r['cpu']:.1f} s "
          f"(unlogged {r['cpu'] - sum(r['rows'].values()):.1f}) | load {r['load']} | "
          f"digest {r['digest']} |")
    for label, s in r["rows"].most_common():
        print(f"|   {label} | {s:.1f} |")
    for fn, s in r["fns"].most_common():
        print(f"|     pool task {fn} | {s:.1f} |")


if __name__ == "__main__":
    main()
