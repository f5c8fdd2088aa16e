"""Fabrication benchmark (issue 15): solids, STEP, unrolling, nesting and DXF for 100, 1,000 and
5,100 panels, and the fabrication stage of example designs.

Table 1, one row per size: solids built serially (``solids 1p``, with its CPU seconds) and by
one process per core (``solids Np``), the STEP file written once (``STEP``), the issue's target
``solids Np + STEP`` (< 60 s at 5,100 panels on 2 cores), unrolling, nesting, DXF/SVG sheets
and parts list (``DXF``), and the assembly check (interference and assembly order on the
solids re-read from the STEP file) with one process and two. Table 2 (``--design``), one row
per design file: the seconds (wall and CPU) of its ``fabrication`` and ``assembly`` stages, the
upstream stages run once before and taken from the cache (target: example 7a under 10 s), and
where they go: the fin system, STEP, 3DM, the nester (in a process of its own, overlapping STEP
and 3DM; it also writes the DXF sheets), the wait for it, the parts list; the STEP re-read,
touching pairs and paths of the assembly check (issue 25: example 9 end to end in <= 90 s).

Wall seconds depend on what else runs: the load average (``uptime``) is printed in every row;
CPU seconds are less sensitive to it. ``CPU`` columns are this process's; ``solids Np CPU`` and
``workers CPU`` are the worker processes' (``FinSystem.solids_cpu_seconds``; when the stage
builds the solids in this process, one worker, they are part of ``CPU s`` as well).

Measured 2026-11-23 19:31-19:35 (evening, commit 9c4bb54, nothing else running: load 0.1 to
1.7, ``nice -n 5``, ``--no-verify-above 1000 --no-sheets-above 1000``). Both targets met:
5,100 panels solids + STEP 25.6 s (< 60 s), 7a's fabrication stage 7.95 s (< 10 s)::

    | panels | parts | connectors | FinSystem s | solids 1p s | solids 1p CPU s | solids Np s | solids Np CPU s | N | STEP s | STEP CPU s | solids Np + STEP s | unroll s | nest s | DXF s | sheets | utilization | verify 1p s | verify 2p s | touching pairs | interfering | load |
    |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|
    | 112 | 98 | 64 | 0.43 | 0.50 | 0.49 | 2.36 | 0.63 | 2 | 0.25 | 0.23 | 2.61 | 0.05 | 0.21 | 0.38 | 3 | 0.555 | 1.52 | 1.33 | 270 | 0 | 0.31 |
    | 1012 | 934 | 620 | 4.39 | 5.49 | 5.48 | 4.55 | 6.02 | 2 | 2.42 | 2.39 | 6.98 | 0.49 | 16.59 | 0.56 | 21 | 0.711 | 18.64 | 14.99 | 3127 | 0 | 1.07 |
    | 5100 | 4820 | 3208 | 27.97 | 25.88 | 25.87 | 13.21 | 24.82 | 2 | 12.41 | 12.38 | 25.62 | - | - | - | - | - | - | - | - | - | 1.28 |

    | design | parts | sheets | fabrication stage s | CPU s | workers CPU s | load |
    |---|---|---|---|---|---|---|
    | 7a_facade_block | 453 | 50 | 7.95 | 5.72 | 4.42 | 1.72 |

The 5,100 row again with the assembly check (``--sizes 5100 --no-sheets-above 1000``, 19:56-20:01,
load 1.2): solids 2p 15.6 s + STEP 12.6 s = 28.2 s; verify 1p 145.8 s, 2p 122.8 s, 17,385
touching pairs, 0 interfering.

Measured 2026-11-23 18:40-18:44 on the shared 2-core machine, ``nice -n 19``, other sessions
running (load 4.3 to 5.4 at the rows; ``--no-verify-above 1000 --no-sheets-above 1000``)::

    | panels | parts | connectors | FinSystem s | solids 1p s | solids 1p CPU s | solids Np s | solids Np CPU s | N | STEP s | STEP CPU s | solids Np + STEP s | unroll s | nest s | DXF s | sheets | utilization | verify 1p s | verify 2p s | touching pairs | interfering | load |
    |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|
    | 112 | 98 | 64 | 0.25 | 0.53 | 0.51 | 3.03 | 0.60 | 2 | 0.24 | 0.22 | 3.27 | 0.06 | 0.21 | 0.39 | 3 | 0.555 | 2.30 | 2.71 | 270 | 0 | 4.54 |
    | 1012 | 934 | 620 | 3.17 | 5.43 | 5.33 | 6.96 | 5.88 | 2 | 2.79 | 2.39 | 9.75 | 0.51 | 17.57 | 0.58 | 21 | 0.711 | 25.66 | 28.17 | 3127 | 0 | 5.39 |
    | 5100 | 4820 | 3208 | 21.29 | 27.32 | 26.65 | 30.07 | 28.45 | 2 | 13.33 | 12.58 | 43.40 | - | - | - | - | - | - | - | - | - | 4.32 |

    | design | parts | sheets | fabrication stage s | CPU s | workers CPU s | load |
    |---|---|---|---|---|---|---|
    | 7a_facade_block | 453 | 50 | 10.52 | 5.18 | 4.56 | 4.35 |

Same day, before this round (commit 13e70fd: solids sewn face by face and labelled with
build123d, STEP through build123d, SVG through ezdxf's drawing add-on): 5,100 panels solids +
STEP 107 s (measured under load earlier that day, about 28 ms of OpenCascade per part, now
6 ms); 7a's stage 23.8 s wall, 9.2 s CPU in this process plus 6.6 s for the solids (measured
serially) at load 7.5, against 16.0 s wall, 5.4 + 5.2 s CPU after it at load 7.7 (one
commit before the table above).
At these loads the two workers get less than a core between them: ``solids Np`` is no faster
than ``solids 1p``, and wall seconds say more about the other sessions than about this code.

Table 3 (``--nest-sizes``, ``--nest-design``, issue 27): the same parts nested by today's
nester (bottom-left fill of the plates, the connectors in rows after them), by the rows alone
(:func:`~torsal.fabrication.nesting.nest_rows`: true shapes end to end, slanted ends head to
tail) and by the yield nester (:func:`~torsal.fabrication.nesting.nest_for_yield`: the rows,
then sparrow empties the emptiest sheets, free rotation, in its default budget of 4 s per sheet
of area, at most 120 s, or ``--nest-time``), all with the default laser cutting (kerf 0.2 mm,
gap 5 mm between cuts, margin 10 mm): sheets, utilization (parts' area / sheets' area, from
the DXF files re-read with ezdxf), the area bound (parts' area / sheet area), the seconds,
whether the budget cut the search, sparrow's solves and the sheets it emptied. Measured
2026-11-26 04:26-05:00 on the shared 2-core machine at load 10 to 20 (``nice -n 5``; sparrow got
about a third of a core: 7a's solves took 118 s of wall clock for 33 s of CPU)::

    | panels / design | parts | area bound (sheets) | today sheets | today utilization (DXF) | today s | today CPU s | rows sheets | rows utilization (DXF) | rows s | yield sheets | yield utilization (DXF) | yield s | yield CPU s | budget s | budget cut the search | sparrow solves | sheets emptied | load |
    |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|
    | 112 | 98 | 1.66 | 3 | 0.555 | 0.37 | 0.20 | 3 | 0.555 | 0.20 | 3 | 0.555 | 7.22 | 2.09 | 8.00 | yes | 1 | 0 | 13.45 |
    | 1012 | 934 | 14.94 | 21 | 0.711 | 25.65 | 16.46 | 22 | 0.679 | 1.73 | 21 | 0.711 | 60.86 | 37.14 | 64.00 | yes | 15 | 0 | 8.46 |
    | 5100 | 4820 | 72.57 | 103 | 0.705 | 778.18 | 120.35 | 100 | 0.726 | 86.33 | 100 | 0.726 | 122.98 | 22.71 | 120.00 | yes | 9 | 0 | 12.76 |
    | 7a | 432 | 30.41 | 49 | 0.621 | 3.54 | 0.49 | 44 | 0.691 | 8.02 | 40 | 0.760 | 118.84 | 31.15 | 120.00 | yes | 31 | 4 | 19.52 |

What caps 7a: 134 of its 172 plates are longer than half the sheet (strips too long for a sheet
are halved) and at most 7 pairs of them interlock end to end in one row, so along the sheet
they need 127 rows, 42.3 sheets; the rows make 44, sparrow's tilted placements 40 (76 %). The
same strips split at the sheet's length (``FinSystem(max_part_length=2400)``, 423 parts) take
39 sheets in rows alone and 38 (80.0 %) with sparrow in 120 s at load 12. On the 1,000-panel
grid (measured again 05:09-05:13 at load 8.5) the rows lose a sheet to bottom-left (its 150 mm
strips stack 7 rows a sheet, not 8) and the yield nester keeps bottom-left's layout; with the
bottom-left comparison limited to 600 parts (before) it gave 22 sheets.
For the lead: re-measure on a quiet machine with ``--sizes --nest-sizes 100 1000 5100
--nest-design examples/7a_facade_block.toml``.

The structure of table 1 is a lat/long grid on a sphere of radius 10 m with node lines through
the centre (exactly planar fins), ~300 mm panels, 150 mm fins, 3 mm plate, parts of at most 8
panels (2.4 m), sheets 2500 x 1250 mm. Not run by the test suite.

    .venv/bin/python benchmarks/fabrication_bench.py [--sizes 100 1000 5100]
        [--no-solids-above N] [--no-verify-above N] [--no-sheets-above N] [--design examples/7a_facade_block.toml ...]
        [--nest-sizes 100 1000 5100 --nest-time 30 120 600] [--nest-design examples/7a_facade_block.toml]
"""
from __future__ import annotations

import argparse
from contextlib import contextmanager
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


def run(n: int, out: Path, solids: bool = True, max_panels: int = 8, verify: bool = True,
        sheets: bool = True) -> dict:
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
    if not sheets:
        return row
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
    """Seconds to build the solids serially and in parallel (one process per core; the CPU
    column of the parallel build is the workers' CPU), and to write the STEP file once from
    them: the OCC shapes the fabrication stage writes (``solid_shapes``; the build123d
    ``Solid`` objects of ``FinSystem.solids()`` are not made)."""
    from torsal.fabrication.solids import _build_one, default_workers, solid_shapes

    _build_one(fs.parts[0], fs.thickness, True)      # imports OpenCascade: not measured
    row = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        row["workers"] = max(2, default_workers(len(fs.parts)))
        for key, workers in (("solids_1_s", 1), ("solids_par_s", row["workers"])):
            fs._solids = fs._solid_shapes = None
            t0 = time.perf_counter()
            solid_shapes(fs, workers=workers)
            row[key] = time.perf_counter() - t0
            row[key.replace("_s", "_cpu")] = fs.solids_cpu_seconds
    t0, c0 = time.perf_counter(), time.process_time()
    fs.export_step(step_path)
    row["step_s"] = time.perf_counter() - t0
    row["step_cpu"] = time.process_time() - c0
    row["target_s"] = row["solids_par_s"] + row["step_s"]
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


#: (key, header) of table 1
COLUMNS = [("panels", "panels"), ("parts", "parts"), ("connectors", "connectors"),
           ("parts_s", "FinSystem s"), ("solids_1_s", "solids 1p s"), ("solids_1_cpu", "solids 1p CPU s"),
           ("solids_par_s", "solids Np s"), ("solids_par_cpu", "solids Np CPU s"), ("workers", "N"),
           ("step_s", "STEP s"), ("step_cpu", "STEP CPU s"),
           ("target_s", "solids Np + STEP s"), ("unroll_s", "unroll s"), ("nest_s", "nest s"),
           ("dxf_s", "DXF s"), ("sheets", "sheets"), ("util", "utilization"),
           ("verify_1p_s", "verify 1p s"), ("verify_2p_s", "verify 2p s"), ("touching", "touching pairs"),
           ("interfering", "interfering"), ("load", "load")]


def _cell(key: str, v) -> str:
    if v == "-":
        return v
    return f"{v:.3f}" if "util" in key else f"{v:.2f}" if isinstance(v, float) else str(v)


def _print_row(row: dict, columns) -> None:
    print("| " + " | ".join(_cell(k, row.get(k, "-")) for k, _ in columns) + " |", flush=True)


def _print_header(columns) -> None:
    print("| " + " | ".join(h for _, h in columns) + " |")
    print("|" + "---|" * len(columns))


#: (module, object name, method or None, label) of the steps table 2 splits the stages into
_STEPS = [("torsal.pipeline.stages", "fin_system", None, "fin_system_s"),
          ("torsal.fabrication.parts", "FinSystem", "export_step", "step_s"),
          ("torsal.fabrication.parts", "FinSystem", "export_3dm", "rhino_s"),
          ("torsal.fabrication.nesting.background", "PendingNesting", "result", "join_s"),
          ("torsal.fabrication.parts", "FinSystem", "bill_of_materials", "bom_s"),
          ("torsal.pipeline.assembly", "_solids", None, "read_step_s"),
          ("torsal.fabrication.assembly.checker", "AssemblyChecker", "_touching_pairs", "pairs_s"),
          ("torsal.fabrication.assembly.checker", "AssemblyChecker", "_assembly_order", "paths_s")]


@contextmanager
def _timed_steps(timing: dict):
    """Add the wall seconds of each of :data:`_STEPS` to ``timing[label]`` while inside."""
    import importlib

    undo = []
    for mod, name, method, label in _STEPS:
        owner = importlib.import_module(mod)
        if method is not None:
            owner, name = getattr(owner, name), method
        f = getattr(owner, name)

        def wrapped(*a, _f=f, _label=label, **k):
            t0 = time.perf_counter()
            try:
                return _f(*a, **k)
            finally:
                timing[_label] = timing.get(_label, 0.0) + time.perf_counter() - t0
        setattr(owner, name, wrapped)
        undo.append((owner, name, f))
    try:
        yield
    finally:
        for owner, name, f in reversed(undo):
            setattr(owner, name, f)


def design_stage_times(toml: Path, out: Path) -> dict:
    """Wall and CPU seconds of the ``fabrication`` and ``assembly`` stages of a design file: the
    stages before them run once (cached), then both again from the cache, split into
    :data:`_STEPS` (the fin system, STEP, 3DM, the wait for the nesting process, the parts list;
    the STEP re-read, touching pairs and paths of the assembly check) and the nester's own
    seconds (in its process, overlapping STEP and 3DM). CPU: this process's, and the solid
    workers' (``FinSystem.solids_cpu_seconds``)."""
    from torsal.design import Design
    from torsal.pipeline import DEFAULT_PIPELINE, Stage, StageCache, fins

    timing = {}

    def timed(stage):
        def run(inp):
            t0, c0 = time.perf_counter(), time.process_time()
            try:
                return stage.run(inp)
            finally:
                timing[f"{stage.name}_s"] = time.perf_counter() - t0
                timing[f"{stage.name}_cpu"] = time.process_time() - c0
        return Stage(stage.name, run, inputs=stage.inputs, key=stage.key, cache=False,
                     section=stage.section)

    pipe = DEFAULT_PIPELINE.until("assembly")
    for name in ("fabrication", "assembly"):
        pipe = pipe.replace(timed(pipe[name]))
    design = Design.from_toml(toml)
    cache = StageCache(out / "cache", prune=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        design.run(out / "warm", cache=cache, pipeline=pipe, accept_unbuildable=True)
        fins.forget_fin_system()          # a new process: no fin system (with solids) of the warm run
        timing.clear()
        with _timed_steps(timing):
            run = design.run(out / "run", cache=cache, pipeline=pipe, accept_unbuildable=True)
    fabrication = run.report.get("fabrication", {})
    timing["workers_cpu"] = getattr(fins.last_fin_system(), "solids_cpu_seconds", None)
    nesting = fabrication.get("nesting") or {}
    return {"design": Path(toml).stem, "parts": fabrication.get("parts"),
            "sheets": fabrication.get("sheets"), "nester": nesting.get("nester", "-").split(" (")[0],
            "nest_s": nesting.get("seconds"), **timing,
            "buildable": fabrication.get("assembly", {}).get("buildable"), "load": load_average()}


def nesting_row(fs, out: Path, label, time_limit: float | None, seed: int = 0) -> dict:
    """Today's nester (bottom-left, connectors in rows after the plates), the rows alone and
    the yield nester (rows, then sparrow empties sheets in ``time_limit`` seconds; None: the
    default budget), all with the default laser cutting: sheets, utilization (parts' area /
    sheets' area of the DXF files re-read with ezdxf), the area bound (parts' area / sheet area)
    and the seconds (wall and CPU)."""
    from torsal.fabrication.cutting import Cutting
    from torsal.fabrication.layout import read_dxf_parts

    cut = Cutting.for_process("laser")
    fs.unrolled()
    row = {"case": label, "parts": len(fs.parts)}
    for key, options in (("bl", {"nester": "bottom-left"}), ("rows", {"nester": "rows"}),
                         ("sp", {"nester": "sparrow", "time_limit": time_limit, "seed": seed})):
        t0, c0 = time.perf_counter(), time.process_time()
        lay = fs.layout(sheet=(2500.0, 1250.0), gap=5.0, margin=10.0, cutting=cut, **options)
        row[f"{key}_s"] = time.perf_counter() - t0
        row[f"{key}_cpu"] = time.process_time() - c0
        row[f"{key}_sheets"] = lay.n_sheets
        paths = lay.export_dxf(out / f"nest_{label}_{key}" / "fins.dxf", svg=False)
        area = sum(p.area for f in paths for p in read_dxf_parts(f)[0])
        row[f"{key}_util_dxf"] = area / (len(paths) * 2500.0 * 1250.0)
        if key == "sp":
            st = lay.stats
            row["bound"] = lay.area_bound
            row["solves"] = st.solves
            row["emptied"] = st.sheets_emptied
            row["time_limit"] = st.time_limit
            row["cut"] = "yes" if st.time_limited else "no"
    row["load"] = load_average()
    return row


NEST_COLUMNS = [("case", "panels / design"), ("parts", "parts"), ("bound", "area bound (sheets)"),
                ("bl_sheets", "today sheets"), ("bl_util_dxf", "today utilization (DXF)"),
                ("bl_s", "today s"), ("bl_cpu", "today CPU s"),
                ("rows_sheets", "rows sheets"), ("rows_util_dxf", "rows utilization (DXF)"),
                ("rows_s", "rows s"),
                ("sp_sheets", "yield sheets"), ("sp_util_dxf", "yield utilization (DXF)"),
                ("sp_s", "yield s"), ("sp_cpu", "yield CPU s"), ("time_limit", "budget s"),
                ("cut", "budget cut the search"), ("solves", "sparrow solves"),
                ("emptied", "sheets emptied"), ("load", "load")]


def design_fin_system(toml: Path, out: Path):
    """The fin system of a design file (the stages up to fabrication run once, cached)."""
    from torsal.design import Design
    from torsal.pipeline import DEFAULT_PIPELINE, StageCache, fins

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        Design.from_toml(toml).run(out / "nest_run", cache=StageCache(out / "cache", prune=False),
                                   pipeline=DEFAULT_PIPELINE.until("fabrication"))
    return fins.last_fin_system()


DESIGN_COLUMNS = [("design", "design"), ("parts", "parts"), ("sheets", "sheets"),
                  ("fabrication_s", "fabrication stage s"), ("fabrication_cpu", "CPU s"),
                  ("workers_cpu", "workers CPU s"), ("fin_system_s", "fin system s"),
                  ("nester", "nester"), ("nest_s", "nester s (own process)"), ("step_s", "STEP s"),
                  ("rhino_s", "3DM s"), ("join_s", "wait for the nester s"), ("bom_s", "parts list s"),
                  ("assembly_s", "assembly stage s"), ("assembly_cpu", "assembly CPU s"),
                  ("read_step_s", "STEP re-read s"), ("pairs_s", "pairs s"), ("paths_s", "paths s"),
                  ("buildable", "buildable"), ("load", "load")]


def main():
    import os

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[100, 1000, 5100])
    ap.add_argument("--no-solids-above", type=int, default=10**9,
                    help="skip the OpenCascade solids/STEP above this many panels")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--no-verify-above", type=int, default=10**9,
                    help="skip the assembly check above this many panels")
    ap.add_argument("--no-sheets-above", type=int, default=10**9,
                    help="skip unrolling, nesting and DXF above this many panels")
    ap.add_argument("--design", type=Path, nargs="*", default=[],
                    help="design files whose fabrication and assembly stages to time (table 2)")
    ap.add_argument("--nest-sizes", type=int, nargs="*", default=[],
                    help="panels of the sphere grids whose nesting to compare (table 3)")
    ap.add_argument("--nest-time", type=float, nargs="*", default=[],
                    help="the yield nester's seconds, one per --nest-sizes (the last for designs); "
                    "default: its own budget (4 s per sheet of area, at most 120 s)")
    ap.add_argument("--nest-design", type=Path, nargs="*", default=[],
                    help="design files whose parts' nesting to compare (table 3)")
    args = ap.parse_args()
    args.nest_time = args.nest_time or [None]
    args.nest_time += [args.nest_time[-1]] * max(0, len(args.nest_sizes) - len(args.nest_time))
    out = args.out or Path(tempfile.mkdtemp(prefix="torsal_fab_bench_"))
    out.mkdir(parents=True, exist_ok=True)
    print(f"{len(os.sched_getaffinity(0))} cores; load average at start {load_average()}; "
          "seconds are wall clock unless CPU")
    if args.sizes:
        _print_header(COLUMNS)
        for n in args.sizes:
            r = run(n, out, solids=n <= args.no_solids_above, verify=n <= args.no_verify_above,
                    sheets=n <= args.no_sheets_above)
            r["load"] = load_average()
            _print_row(r, COLUMNS)
    if args.nest_sizes or args.nest_design:
        print()
        _print_header(NEST_COLUMNS)
        for n, budget in zip(args.nest_sizes, args.nest_time):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fs = FinSystem(sphere_grid(n), thickness=3.0, clearance=0.5, max_panels=8)
            _print_row(nesting_row(fs, out, fs.n_panels, budget), NEST_COLUMNS)
        for toml in args.nest_design:
            fs = design_fin_system(toml, out / Path(toml).stem)
            _print_row(nesting_row(fs, out, Path(toml).stem.split("_")[0], args.nest_time[-1]),
                       NEST_COLUMNS)
    if args.design:
        print()
        _print_header(DESIGN_COLUMNS)
        for toml in args.design:
            _print_row(design_stage_times(toml, out / Path(toml).stem), DESIGN_COLUMNS)
    print(f"files in {out}")


if __name__ == "__main__":
    main()
