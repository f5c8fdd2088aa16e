"""Fabrication benchmark: build and write solids, unroll, nest, write DXF for 100, 1,000 and
5,100 panels; prints a table with the times and the sheet utilization. Solids are built twice:
serially (``solids_1_s``) and by one process per core (``solids_par_s``, issue 15); the load
average (``uptime``) is printed next to the table, since other jobs may share the cores.
The assembly check (interference and assembly order, one process and two) is timed too.

The structure is a lat/long grid on a sphere of radius 10 m with node lines through the centre
(exactly planar fins), ~300 mm panels, 150 mm fins, 3 mm plate, parts of at most 8 panels (2.4 m),
sheets 2500 x 1250 mm. Not run by the test suite.

    .venv/bin/python benchmarks/fabrication_bench.py [--sizes 100 1000 5100] [--no-solids-above N]
"""
from __future__ import annotations

import argparse
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from torsal.fabrication import FinSystem
from torsal.geometry.support import SupportStructure


def sphere_grid(n_panels: int, radius: float = 10.0, panel: float = 0.3, depth: float = 0.15):
    """Square lat/long grid with about ``n_panels`` fins (edges)."""
    m = int(round((1 + np.sqrt(1 + 2 * n_panels)) / 2))     # 2 m (m - 1) ~ n_panels
    step = panel / radius
    th = (np.arange(m) - (m - 1) / 2) * step
    T, P = np.meshgrid(th, th)
    d = np.stack([np.cos(P) * np.cos(T), np.cos(P) * np.sin(T), np.sin(P)], axis=-1).reshape(-1, 3)
    idx = np.arange(m * m).reshape(m, m)
    e0 = np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()]
    e1 = np.c_[idx[:-1, :].ravel(), idx[1:, :].ravel()]
    faces = [[idx[r, c], idx[r, c + 1], idx[r + 1, c + 1], idx[r + 1, c]]
             for r in range(m - 1) for c in range(m - 1)]
    return SupportStructure(radius * d, (radius + depth) * d, faces, np.r_[e0, e1],
                            np.r_[np.zeros(len(e0), int), np.ones(len(e1), int)])


def run(n: int, out: Path, solids: bool = True, max_panels: int = 8, verify: bool = True) -> dict:
    s = sphere_grid(n)
    row = {"panels": len(s.edges)}
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fs = FinSystem(s, thickness=3.0, clearance=0.5, max_panels=max_panels)
    row["parts"] = len(fs.parts)
    row["parts_s"] = time.perf_counter() - t0
    row["connectors"] = len(fs.connectors)
    if solids:
        row.update(time_solids(fs, out / f"fins_{n}.step"))
        if verify:
            row.update(verification_times(fs, out / f"fins_{n}.step"))
    t0 = time.perf_counter()
    fs.unrolled()
    row["unroll_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    lay = fs.layout(sheet=(2500.0, 1250.0), gap=5.0, margin=10.0)
    row["nest_s"] = time.perf_counter() - t0
    row["sheets"] = lay.n_sheets
    row["util"] = lay.utilization
    t0 = time.perf_counter()
    lay.export_dxf(out / f"fins_{n}.dxf", svg=True)
    fs.bill_of_materials(out / f"bom_{n}.csv", layout=lay)
    row["dxf_s"] = time.perf_counter() - t0
    return row


def time_solids(fs, step_path: Path) -> dict:
    """Seconds to build the solids serially and in parallel (one process per core), and to
    write the STEP file once."""
    import build123d  # noqa: F401  (import time, ~5 s, is not part of the measurement)

    from torsal.fabrication.solids import default_workers

    row = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for key, workers in (("solids_1_s", 1), ("solids_par_s", max(2, default_workers(len(fs.parts))))):
            fs._solids = None
            t0 = time.perf_counter()
            fs.solids(workers=workers)
            row[key] = time.perf_counter() - t0
    t0 = time.perf_counter()
    fs.export_step(step_path)
    row["step_s"] = time.perf_counter() - t0
    return row


def load_average() -> str:
    """The 1-minute load average, as ``uptime`` shows it."""
    import os

    return f"{os.getloadavg()[0]:.2f}"


def verification_times(fs, step_file: Path, workers=(1, 2)) -> dict:
    """Seconds of the assembly check (``verify_assembly`` on the solids re-read from
    ``step_file``) with one process and with two, and what it found."""
    from torsal.fabrication import verify_assembly

    row = {}
    for w in workers:
        t0 = time.perf_counter()
        check = verify_assembly(fs, step_file=step_file, workers=w)
        row[f"verify_{w}p_s"] = time.perf_counter() - t0
    row["touching"] = check.pairs_checked
    row["interfering"] = check.interfering_pairs
    return row


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[100, 1000, 5100])
    ap.add_argument("--no-solids-above", type=int, default=10**9,
                    help="skip the OpenCascade solids/STEP above this many panels")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--no-verify-above", type=int, default=10**9,
                    help="skip the assembly check above this many panels")
    args = ap.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="torsal_fab_bench_"))
    out.mkdir(parents=True, exist_ok=True)
    cols = ["panels", "parts", "connectors", "parts_s", "solids_1_s", "solids_par_s", "step_s",
            "unroll_s", "nest_s", "dxf_s", "sheets", "util", "verify_1p_s", "verify_2p_s",
            "touching", "interfering", "load"]
    print("| " + " | ".join(cols) + " |")
    print("|" + "---|" * len(cols))
    for n in args.sizes:
        r = run(n, out, solids=n <= args.no_solids_above, verify=n <= args.no_verify_above)
        r["load"] = load_average()
        cells = []
        for c in cols:
            v = r.get(c, "-")
            cells.append(f"{v:.3f}" if c == "util" and v != "-" else
                         f"{v:.2f}" if isinstance(v, float) else str(v))
        print("| " + " | ".join(cells) + " |", flush=True)
    print(f"files in {out}")


if __name__ == "__main__":
    main()
