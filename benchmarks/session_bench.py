"""Live design session latency: example 7a at full size, one change of each kind.

For each change (a weight, the sun period, a stroke, a region, a bound, spacing, depth, a moved
surface point) on a warm :class:`torsal.Session`: the preview's seconds (target <= 1 s: the
congruence re-solved from the last optimum, the fins as surfaces, the light figures) and the
built answer's (solids, sheets, assembly check, every file), both from the edit; against a
cold ``torsal design`` of the same edited design file in a new process and an empty folder.
Each change is made from the design as the file gives it (the previous change undone by
re-applying the file's design first, which the session answers from its warm results); a
stroke, a region and a bound are moved, so the design gets one first (not timed). No build
runs while a preview is timed (the one of the design before is cancelled): a build in the
background shares the processor and the interpreter with the preview.

Run:  .venv/bin/python benchmarks/session_bench.py [--no-built] [--no-cold] [--changes weight sun ...]

Timings on a shared machine vary: the script prints the load average, each preview's processor
seconds (``cpu s``, this process: what a quiet machine's wall time comes close to) and the
seconds of each stage it ran, wall / processor (``stage wall/cpu``; the light's rays are cast
from two threads, so its processor seconds can exceed its wall). Not run by the test suite.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from torsal.session import RegionGoal, Session

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
DESIGN = EXAMPLES / "7a_facade_block.toml"


def _stroke(s: Session, lift: float = 0.0) -> list:
    """A stroke across 7a's facade through two of its vertices (lower left to upper right),
    ``lift`` (m) higher."""
    v = s.preview.values["surface"]["vertices"]
    lo, hi = v.min(axis=0), v.max(axis=0)
    ends = [lo + (hi - lo) * [0.2, 0.5, 0.25], lo + (hi - lo) * [0.8, 0.5, 0.65]]
    points = [v[np.argmin(np.linalg.norm((v - e)[:, [0, 2]], axis=1))] for e in ends]
    return [[p + [0.0, 0.0, lift] for p in points]]


def _moved_point(s: Session):
    """The vertex nearest the middle of mesh A, 5 cm out along the surface normal."""
    surface = s.preview.values["surface"]
    v = surface["vertices"]
    k = int(np.argmin(np.linalg.norm(v - v.mean(axis=0), axis=1)))
    return s.move_point(k, v[k] + np.array([0.0, -0.05, 0.0]))


#: change name -> (what it is, the design the change starts from or None: the file's, the edit)
CHANGES = {
    "weight": ("weights.perp 10 -> 12", None, lambda s: s.set_weights(perp=12)),
    "sun": ("sun.hours [13, 17] -> [12, 17]", None, lambda s: s.set_sun(hours=[12, 17])),
    "stroke": ("a stroke moved 0.5 m", lambda s: s.set_strokes(_stroke(s), width=0.6),
               lambda s: s.set_strokes(_stroke(s, 0.5), width=0.6)),
    "region": ("goals.let_through x [4, 6] -> [3.5, 5.5]",
               lambda s: s.set_region(RegionGoal.LET_THROUGH, {"x": [4.0, 6.0]}),
               lambda s: s.set_region(RegionGoal.LET_THROUGH, {"x": [3.5, 5.5]})),
    "bound": ("min_torsal_angle 20 -> 22 deg", lambda s: s.set_bound(min_torsal_angle=20),
              lambda s: s.set_bound(min_torsal_angle=22)),
    "spacing": ("fins.spacing 0.6 -> 0.7", None, lambda s: s.set_fins(spacing=0.7)),
    "depth": ("fins.depth 0.4 -> 0.45", None, lambda s: s.set_fins(depth=0.45)),
    "point": ("a surface point moved 5 cm", None, _moved_point),
}


def cold_design(spec, folder: Path) -> float:
    """Seconds of ``torsal design`` of ``spec`` in a new process and an empty folder."""
    import tomli_w

    path = folder / "design.toml"
    data = spec.model_dump(mode="json", exclude_none=True)
    path.write_text(tomli_w.dumps(data))
    torsal = Path(sys.executable).with_name("torsal")
    t0 = time.perf_counter()
    run = subprocess.run([str(torsal), "design", str(path), "--out", str(folder / "out"),
                          "--accept-unbuildable"], capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if run.returncode not in (0,):
        return float("nan")
    return seconds


def machine() -> str:
    """The machine line: processor, cores, Python and the numeric libraries."""
    import platform

    import casadi

    model = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            model = next(line.split(":", 1)[1].strip() for line in fh if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return (f"{model}, {os.cpu_count()} cores; Python {platform.python_version()}, numpy "
            f"{np.__version__}, casadi {casadi.__version__}")


class StageClock:
    """Processor seconds of each stage the main thread runs (the session's ``progress``
    callback; a background build's events, from its own thread, are left out)."""

    def __init__(self):
        self.started: dict[str, float] = {}
        self.cpu: dict[str, float] = {}

    def __call__(self, stage: str, event: str, info: dict) -> None:
        if threading.current_thread() is not threading.main_thread():
            return
        if event == "start":
            self.started[stage] = time.process_time()
        elif event == "done" and stage in self.started:
            self.cpu[stage] = time.process_time() - self.started.pop(stage)

    def clear(self) -> None:
        self.started.clear()
        self.cpu.clear()


def load() -> str:
    """The 1-minute load average."""
    return f"{os.getloadavg()[0]:.1f}"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--no-built", action="store_true", help="previews only")
    ap.add_argument("--no-cold", action="store_true", help="skip the cold `torsal design` runs")
    ap.add_argument("--changes", nargs="*", default=list(CHANGES), choices=list(CHANGES))
    args = ap.parse_args(argv)
    a = os.getloadavg()
    print(f"Live session on {DESIGN.name} at full size; {machine()}; load average {a[0]:.2f} "
          f"{a[1]:.2f} {a[2]:.2f}")
    tmp = Path(tempfile.mkdtemp(prefix="session_bench-"))
    clock = StageClock()
    with Session(DESIGN, tmp / "session", build=not args.no_built, progress=clock) as s:
        t0 = time.perf_counter()
        first = s.start()
        print(f"start (cold preview, kernels compiled or loaded): {time.perf_counter() - t0:.2f} s; "
              f"{first.structure.edges.shape[0]} fins")
        if not args.no_built:
            b = s.wait_built()
            print(f"first build: {b.seconds:.1f} s ({b.kind.value})")
        base = s.design
        head = (f"{'change':>8} {'what':<40} | {'load':>4} | {'preview s':>9} {'cpu s':>5} {'<=1 s':>5} | "
                f"{'built s':>7} | {'cold s':>6} | stages the preview ran (wall/cpu s)")
        print(head)
        print("-" * len(head))
        for name in args.changes:
            what, setup, fn = CHANGES[name]
            s.apply(base)                       # back to the file's design (warm results)
            if setup is not None:
                setup(s)
            s.cancel_build(wait=None)           # nothing in the background while timed
            row_load = load()
            clock.clear()
            c0 = time.process_time()
            answer = fn(s)
            cpu = time.process_time() - c0
            built = None if args.no_built else s.wait_built()
            cold = float("nan") if args.no_cold else cold_design(answer.spec, Path(tempfile.mkdtemp(
                dir=tmp)))
            ok = "yes" if answer.seconds <= 1.0 else "NO"
            built_s = "-" if built is None else f"{built.seconds:7.1f}"
            note = "" if answer.ok else f" ({answer.kind.value}: {answer.message[:60]})"
            stages = ", ".join(f"{k} {v:.2f}/{clock.cpu.get(k, float('nan')):.2f}"
                               for k, v in answer.stage_seconds.items() if v >= 0.005)
            solve = answer.report.get("congruence", {}) if "congruence" in answer.stages_run else {}
            if solve:
                # counts, not seconds, decide the solve: the same on a loaded machine
                fact = solve.get("counts", {}).get("factorizations")
                stages += f" ({solve['solver']}, {solve['iterations']} steps" + (
                    f", {fact} factorizations)" if fact is not None else ")")
            if answer.ok and not answer.support_final:
                stages += " [support made planar by projection: the build solves eq. (8)]"
            print(f"{name:>8} {what:<40} | {row_load:>4} | {answer.seconds:9.2f} {cpu:5.2f} {ok:>5} | "
                  f"{built_s:>7} | {cold:6.1f} | {stages}{note}", flush=True)


if __name__ == "__main__":
    main()
