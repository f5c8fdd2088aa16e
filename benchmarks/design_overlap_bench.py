"""How much of a design run overlaps on two cores (issue 40: 7a at full size in <= 30 s).

    .venv/bin/python benchmarks/design_overlap_bench.py [--design examples/7a_facade_block.toml]
        [--out DIR] [--label after]

Runs the design end to end (every stage, no cache) while a thread samples ``/proc`` every
0.1 s for this process and every process it started (solid workers, nester, STEP reader and
its fork, the report's pictures, the assembly check's workers). Prints one row: the wall
seconds, the CPU seconds of all those processes, and an estimate of the wall seconds of the
same run on a quiet 2-core machine: per sample interval, the larger of the busiest process's
CPU seconds and half the CPU seconds of all of them (the work of that interval on two cores,
each process on one), summed. On a loaded machine the wall seconds say little; the estimate,
the CPU seconds and "both cores" (the estimated seconds in which two cores are busy) are what
to compare. Then each stage's start and end on the estimated clock. Run it with another
checkout's ``torsal`` on ``PYTHONPATH`` for the row before a change, taking turns.

Measured 2026-11-29 10:39-10:48 UTC, before = af50f4a and after = 89d8551 (the concurrent
pictures stage, the sheets nested and written in a process of their own, the STEP reader's
meshing split with a fork), run side by side at load 16-19 (other engineers' jobs); the same
fins.step, fins.3dm, fins.ifc, parts.csv, 40 DXF sheets and assembly.csv, report.json the
same but for seconds:

    | run | wall s | est. quiet 2-core s | both cores s | CPU s, all processes | load |
    |---|---|---|---|---|---|
    | before af50f4a | 335.3 | 54.5 | 26.5 | 81.0 | 18.7 / 15.5 |
    | after 89d8551 | 317.3 | 51.1 | 34.4 | 85.6 | 18.7 / 16.9 |

    | stage | before: start, end (est. s) | after: start, end (est. s) |
    |---|---|---|
    | fabrication | 1.9, 35.5 | 1.9, 33.5 |
    | devices, light | 35.5, 39.1 | 33.5, 37.8 |
    | assembly | 39.1, 51.9 | 37.9, 50.9 |
    | pictures | (in the report) | 37.8, 50.9 (beside the assembly) |
    | report | 51.9, 54.5 | 50.9, 51.1 |

At that load the estimate runs high (quiet, 7a took 40.5 s wall before) and the CPU seconds
swell; plain ``torsal design`` at load 6-10 took 140.3 / 73.3 s before and 156.9 / 58.9 s
after, alternating: noise. The lead's quiet timing decides.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import threading
import time
from pathlib import Path

HZ = os.sysconf("SC_CLK_TCK")


def _descendants(root: int) -> dict[int, int]:
    """{pid: CPU ticks (user + system)} of ``root`` and every process under it."""
    table, children = {}, {}
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/stat") as f:
                s = f.read()
        except OSError:
            continue
        fields = s[s.rfind(")") + 2:].split()
        table[int(d)] = int(fields[11]) + int(fields[12])
        children.setdefault(int(fields[1]), []).append(int(d))
    out, todo = {}, [root]
    while todo:
        p = todo.pop()
        if p in table:
            out[p] = table[p]
        todo.extend(children.get(p, []))
    return out


class Sampler:
    """``/proc`` samples of this process tree every ``period`` seconds, in a thread."""

    def __init__(self, period: float = 0.1):
        self.period, self.samples, self._stop = period, [], threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()

    def _run(self):
        me = os.getpid()
        while not self._stop.is_set():
            self.samples.append((time.perf_counter(), _descendants(me)))
            time.sleep(self.period)

    def quiet_clock(self) -> list[tuple[float, float, float]]:
        """``[(time, estimated quiet seconds so far, CPU seconds so far)]`` per sample."""
        out, est, cpu = [], 0.0, 0.0
        for (t0, a), (t1, b) in zip(self.samples, self.samples[1:]):
            d = [(b[p] - a[p]) / HZ for p in b if p in a]
            est += max(max(d, default=0.0), sum(d) / 2)
            cpu += sum(d)
            out.append((t1, est, cpu))
        return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--design", type=Path, default=Path("examples/7a_facade_block.toml"))
    ap.add_argument("--out", type=Path, default=Path("out/overlap-bench"))
    ap.add_argument("--label", default="")
    args = ap.parse_args()
    from torsal.design import Design

    events = []

    def progress(stage, event, info):
        if event in ("start", "done"):
            events.append((time.perf_counter(), stage, event))

    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    with Sampler() as sampler:
        Design.from_toml(args.design).run(args.out, use_cache=False, progress=progress,
                                          accept_unbuildable=True)
    wall = time.perf_counter() - t0
    clock = sampler.quiet_clock()
    est, cpu = (clock[-1][1], clock[-1][2]) if clock else (0.0, 0.0)
    both = sum(max(0.0, min(b[1] - a[1], (b[2] - a[2]) - (b[1] - a[1])))
               for a, b in zip(clock, clock[1:]))
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True, cwd=Path(__import__("torsal").__file__).parent
                                ).stdout.strip()
    except OSError:
        commit = "?"

    def at(t):
        return next((e for tt, e, _ in clock if tt >= t), est)

    print("| run | wall s | est. quiet 2-core s | both cores s | CPU s, all processes | load |")
    print("|---|---|---|---|---|---|")
    print(f"| {args.label} {commit} | {wall:.1f} | {est:.1f} | {both:.1f} | {cpu:.1f} | "
          f"{load0:.1f} / {os.getloadavg()[0]:.1f} |")
    print("\n| stage | start (est. s) | end (est. s) | wall s |")
    print("|---|---|---|---|")
    starts = {}
    for t, stage, event in events:
        if event == "start":
            starts[stage] = t
        elif stage in starts:
            print(f"| {stage} | {at(starts[stage]):.1f} | {at(t):.1f} | {t - starts[stage]:.1f} |")


if __name__ == "__main__":
    main()
