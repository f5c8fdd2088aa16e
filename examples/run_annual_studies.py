"""The examples judged in the annual units (issue 41): for every example, a study of its fins
with both families at one spacing and with a lighter second family (twice the spacing),
against the standard devices, on the cooling-season gains avoided (kWh/m2 of glazing) against
sDA (a facade's rooms) or the view out (a canopy); and the annual table of the uniform variant
(kWh/m2 bare / fins / best device per season, F_sh, sDA / ASE).

    python examples/run_annual_studies.py [--size full|full-design|reduced]
                                          [--out out/annual-studies] [--only 7a 9 ...]
    python examples/run_annual_studies.py --table-only     # the tables from the saved results

Both rewrite the tables of examples/README.md between the ``annual-studies`` markers.

``--size full`` (the default): each example's own mesh, fin spacing, depth, light samples and
iteration limit; Radiance at the ``[annual]`` defaults (300 glazing points, -ab 2 -ad 2048);
rooms 9 m deep (:data:`ROOM_DEPTH_M`; the first runs of 2026-11-29: 6 m) and 3 m high per
storey, glazed from a 0.9 m sill to a 2.7 m head, at LM-83's -ab 6 -ad 1024 (the ``[room]``
defaults). ``--size full-design`` (what a shared 2-core machine finishes in a session): the
same designs and rooms, Radiance at 150
glazing points, -ab 2 -ad 1024, rooms -ab 4 -ad 512. ``--size reduced`` (the run of
2026-11-28): mesh A at most 17 x 17 vertices, the fin spacing at least a twelfth of A's extent,
300 light samples, 100 glazing points at -ab 2 -ad 512, rooms glazed floor to ceiling at -ab 4
-ad 256. All: no fabrication; a design without a [site] (7d: explicit sun vectors) gets 7a's
(Vienna) for its weather year. Each study's table is saved to
``examples/studies/results/<key>_annual.csv``, its Pareto plot to
``examples/studies/<key>_annual_pareto.png`` and its timing (wall and processor seconds, load
average, date, commit, size) beside the table; the tables are computed from those files.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import time
import tomllib
from enum import Enum
from pathlib import Path

import dask
# loaded first: its config defaults would go with the value dask.config.set restores
# after the first study (KeyError: 'comm' in the second study's LocalCluster)
import distributed  # noqa: F401
import pandas as pd
import tomli_w

from torsal import Study
from torsal.geometry.surfaces import GENERATORS
from torsal.light.devices import surface_frame
from torsal.pipeline.cache import StageCache
from torsal.pipeline.errors import DesignError
from torsal.pipeline.stage import run_stages
from torsal.pipeline.stages import DEFAULT_PIPELINE
from torsal.study.study import SHARED_STAGE
from torsal.study.study_file import X_KEY, ParetoSpec
from torsal.study.study_report import verdict_on, write_pareto_png

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "studies" / "results"
KEYS = ("7a", "7b", "7c", "7d", "9", "10", "11", "13")
BEGIN, END = "<!-- annual-studies:begin -->", "<!-- annual-studies:end -->"
FILES = {k: next(HERE.glob(f"{k}_*.toml")) for k in KEYS}

AVOIDED = "light.annual.fins.shading_factor.cooling_gains_avoided_kwh_m2"
#: LM-83's sDA, with its operable blinds (since aa8c610; before, the room without blinds)
SDA = "light.annual.daylight.fins.sda_all"
#: the timing file's mark of a run whose sDA is LM-83's with blinds
BLINDS = "sda_lm83_blinds"
#: the rooms' prefixes in a study's table: bare, and behind the row's shading
DAYLIGHT = ("light.annual.daylight.bare.", "light.annual.daylight.fins.")


class Size(Enum):
    """How large the studies run (see the module docstring)."""
    FULL = "full"
    #: the examples' full-size designs, Radiance lighter than its defaults
    FULL_DESIGN = "full-design"
    REDUCED = "reduced"


#: the reduced size's mesh and spacing limits (see the module docstring)
MAX_GRID, EXTENT_PER_SPACING = 17, 12
#: [annual] per size; full: the design file's defaults
ANNUAL = {Size.FULL: {"enabled": True},
          Size.FULL_DESIGN: {"enabled": True, "points": 150, "ambient_divisions": 1024},
          Size.REDUCED: {"enabled": True, "points": 100, "ambient_divisions": 512}}
#: m: the full sizes' room depth, a deep-plan office. By the limiting-depth rule of BS 8206-2 /
#: BRE 209 (the back half gloomy if L/W + L/H > 2 / (1 - R_b)), a room 12 m wide with a 2.7 m
#: window head and LM-83's reflectances (R_b 0.47 over the back half) is daylit to 8.3 m: at
#: 6 m every design lights the whole room (sDA 100 %, examples/README), at 9 m the back of the
#: room is what the shading decides. Neither LM-83 nor EN 17037 fixes a depth.
ROOM_DEPTH_M = 9.0
#: [room] per size: rooms ROOM_DEPTH_M deep (reduced: 6 m) and 3 m high per storey; full:
#: windows with a sill and a head (a facade glazed floor to ceiling saturates sDA, see
#: examples/README) and the [room] defaults, LM-83's settings
ROOM = {Size.FULL: {"depth": ROOM_DEPTH_M, "height": 3.0, "sill": 0.9, "head": 2.7},
        Size.FULL_DESIGN: {"depth": ROOM_DEPTH_M, "height": 3.0, "sill": 0.9, "head": 2.7,
                           "ambient_bounces": 4, "ambient_divisions": 512},
        Size.REDUCED: {"depth": 6.0, "height": 3.0, "ambient_bounces": 4,
                       "ambient_divisions": 256}}
SITE = tomllib.loads(FILES["7a"].read_text())["site"]


def _reduce(d: dict) -> None:
    """Shrink the design ``d`` to the reduced size, in place."""
    params = dict(d["surface"].get("params", {}))
    params.update({n: min(int(params.get(n, 33)), MAX_GRID) for n in ("nu", "nv")})
    d["surface"]["params"] = params
    v, _ = GENERATORS[d["surface"]["generator"]](**params)
    extent = float((v.max(axis=0) - v.min(axis=0)).max())
    d["fins"]["spacing"] = round(max(float(d["fins"]["spacing"]), extent / EXTENT_PER_SPACING), 3)
    d["fins"]["developable_levels"] = min(d["fins"].get("developable_levels", 0), 1)
    d["outputs"]["light_samples"] = 300
    d.setdefault("constraints", {})["max_iter"] = 400


def study_base(key: str, size: Size = Size.FULL) -> tuple[dict, bool]:
    """The example's design at ``size`` with [annual] (and [room] on a facade), no exports,
    and whether it is a facade."""
    d = tomllib.loads(FILES[key].read_text())
    d["outputs"] = {**{k: v for k, v in d.get("outputs", {}).items() if k == "light_samples"},
                    "step": False, "rhino_3dm": False, "ifc": False, "renders": False}
    if size is Size.REDUCED:
        _reduce(d)
    d["annual"] = dict(ANNUAL[size])
    # a design of explicit sun vectors (7d) has no site: the year is 7a's (Vienna)
    d.setdefault("site", SITE)
    v, f = GENERATORS[d["surface"]["generator"]](**d["surface"].get("params", {}))
    facade = surface_frame(v, f).is_facade
    if facade:
        d["room"] = dict(ROOM[size])
    return d, facade


def write_study(key: str, folder: Path, size: Size = Size.FULL) -> Path:
    """The base design and the study file of ``key`` at ``size`` in ``folder``."""
    base, facade = study_base(key, size)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "base.toml").write_text(tomli_w.dumps(base))
    s = base["fins"]["spacing"]
    study = {"name": f"{key}: one spacing and a lighter second family, annual",
             "base": "base.toml", "axes": {"fins.spacing": [s, [s, 2 * s]]},
             "run": {"workers": 2, "fabrication": False},
             "pareto": {"x": SDA if facade else X_KEY, "y": AVOIDED}}
    path = folder / "study.toml"
    path.write_text(tomli_w.dumps(study))
    return path


def _commit() -> str:
    """HEAD of the checkout; in a copy without .git (a snapshot of a shared tree) the commit it
    was copied at, from ``TORSAL_COMMIT``."""
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE, text=True,
                          capture_output=True).stdout.strip()
    return head or os.environ.get("TORSAL_COMMIT", "unknown")


def _cpu_s() -> float:
    """Processor seconds of this process and its finished children (the study's workers and
    their Radiance processes)."""
    own, kids = (resource.getrusage(w) for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def _solve_shared(study: Study, out: Path) -> None:
    """Solve the variants' shared congruence into the study's cache first: a study runs a
    variant whose congruence another one is solving after that whole variant (its annual
    stage too), one it finds in the cache at once, so the two variants' remeshing, light and
    annual stages run side by side. A failed solve is left to the study to record."""
    spec = study.variants[0].spec
    try:
        run_stages(DEFAULT_PIPELINE.until(SHARED_STAGE), spec, out / "shared",
                   StageCache(out / ".torsal-cache", prune=False))
    except DesignError:
        pass


def keep_unshaded(key: str) -> None:
    """Before a new run replaces a saved study whose sDA had no blinds (a timing file without
    the :data:`BLINDS` mark), keep its sDA columns and timing as ``<key>_annual_unshaded.csv``
    / ``.json``: the sDA of the same rooms without blinds, which the study table of a run with
    LM-83's blinds does not carry (the pipeline reports LM-83's ``sda`` alone)."""
    csv, tm = RESULTS / f"{key}_annual.csv", RESULTS / f"{key}_annual.json"
    if not (csv.exists() and tm.exists()) or json.loads(tm.read_text()).get(BLINDS):
        return
    t = pd.read_csv(csv)
    cols = [p + "sda_all" for p in DAYLIGHT if p + "sda_all" in t]
    if cols:
        t[["kind", "device", "fins.spacing", *cols]].to_csv(
            RESULTS / f"{key}_annual_unshaded.csv", index=False, float_format="%.6g")
        shutil.copyfile(tm, RESULTS / f"{key}_annual_unshaded.json")


def run(key: str, out: Path, workers: int, size: Size = Size.FULL) -> dict:
    """Run one study at ``size``; save its table, plot and timing under examples/studies."""
    keep_unshaded(key)
    study = Study.from_toml(write_study(key, out / key, size))
    load0, t0, cpu0 = os.getloadavg()[0], time.perf_counter(), _cpu_s()
    _solve_shared(study, out / key / "out")
    # one task per worker at a time: at Dask's default (1.1 x 1 thread, so 2) a worker can be
    # handed both variants, the second waiting behind the first while another worker idles
    with dask.config.set({"distributed.scheduler.worker-saturation": 1.0}):
        res = study.run(out / key / "out", workers=workers)
    RESULTS.mkdir(parents=True, exist_ok=True)
    keep = [c for c in res.table.columns if c in ("id", "kind", "device", "status", "note",
            "fins.spacing", "fins.depth", "material_kg", "wall_s", "error", X_KEY,
            "stage_s.annual") or c.startswith(("light.annual.bare.", "light.annual.fins.",
                                               "light.annual.daylight.bare.",
                                               "light.annual.daylight.fins."))]
    res.table[keep].to_csv(RESULTS / f"{key}_annual.csv", index=False, float_format="%.6g")
    shutil.copyfile(res.files["png"], HERE / "studies" / f"{key}_annual_pareto.png")
    timing = {"wall_s": time.perf_counter() - t0, "cpu_s": _cpu_s() - cpu0,
              "size": size.value, "room_depth_m": ROOM[size]["depth"], "workers": workers,
              "load_start": load0,
              "load_end": os.getloadavg()[0], "date": time.strftime("%Y-%m-%d %H:%M UTC",
                                                                   time.gmtime()),
              "commit": _commit(), "verdict": res.verdict, "failed": res.failed, BLINDS: True}
    (RESULTS / f"{key}_annual.json").write_text(json.dumps(timing, indent=1))
    return timing


# ------------------------------------------------------------------ the README tables
def _studies(keys):
    """``(key, torsal rows, device rows with annual figures)`` of each saved study."""
    for key in keys:
        if not (RESULTS / f"{key}_annual.csv").exists():
            continue
        t = pd.read_csv(RESULTS / f"{key}_annual.csv")
        ok = t[t["status"] == "done"]
        devices = (ok[(ok["kind"] == "baseline") & ok[AVOIDED].notna()] if AVOIDED in ok
                   else ok[:0])
        yield key, ok[ok["kind"] == "torsal"], devices


def _kwh(r, source: str) -> str:
    p = f"light.annual.{source}."
    return f"{r[p + 'cooling_kwh_m2']:.0f} / {r[p + 'heating_kwh_m2']:.0f}"


def _share(x) -> str:
    return "-" if x is None or pd.isna(x) else f"{100 * x:.0f}%"


def _sda(key: str, tm: dict, row, prefix: str) -> tuple:
    """``(LM-83's sDA with blinds, sDA without blinds)`` of a study's ``row`` (bare or behind
    its shading, ``prefix`` of :data:`DAYLIGHT`), None where not measured: a run with the
    :data:`BLINDS` mark gives LM-83's and, where the pipeline reports it, the unshaded
    (``sda_unshaded_all``), else the one kept from the run before (:func:`keep_unshaded`); an
    older run gives the unshaded alone."""
    if row is None or pd.isna(row.get(prefix + "sda_all")):
        return None, None
    if not tm.get(BLINDS):
        return None, row[prefix + "sda_all"]
    if pd.notna(row.get(prefix + "sda_unshaded_all")):
        return row[prefix + "sda_all"], row[prefix + "sda_unshaded_all"]
    kept = RESULTS / f"{key}_annual_unshaded.csv"
    if not kept.exists():
        return row[prefix + "sda_all"], None
    k = pd.read_csv(kept)
    same = ((k["kind"] == row["kind"]) & (k["device"].fillna("") == ("" if pd.isna(
        row.get("device")) else row["device"])) & (k["fins.spacing"].astype(str)
                                                   == str(row["fins.spacing"])))
    old = k.loc[same, prefix + "sda_all"] if prefix + "sda_all" in k else k[:0]
    return row[prefix + "sda_all"], (old.iloc[0] if len(old) else None)


def annual_table(keys=KEYS) -> str:
    """Per example (and the size it ran at), its uniform variant: kWh/m2 on the glazing in
    the cooling / heating season, bare, behind the fins and behind the device that avoids the
    most cooling-season gains; F_sh (cooling); sDA with LM-83's blinds and without, and ASE,
    bare, fins, that device; the annual stage's and the whole variant's wall seconds."""
    lines = ["| example | bare kWh/m2 cooling / heating | fins | best device (cooling gains "
             "avoided) | F_sh cooling fins / device | sDA LM-83 (blinds) bare / fins / device "
             "| sDA without blinds bare / fins / device | ASE bare / fins / device | annual "
             "stage s / variant run s |", "|" + "---|" * 9]
    for key, torsal, devices in _studies(keys):
        uniform = torsal[~torsal["fins.spacing"].astype(str).str.startswith("[")]
        if uniform.empty:
            continue
        r = uniform.iloc[0]
        d = devices.loc[devices[AVOIDED].idxmax()] if not devices.empty else None
        fsh = "light.annual.fins.shading_factor.f_sh_cooling"
        tm = json.loads((RESULTS / f"{key}_annual.json").read_text())
        room = (f", {tm.get('room_depth_m', 6.0):g} m room"                 # a facade's
                if pd.notna(r.get(DAYLIGHT[0] + "sda_all")) else "")
        cells = [f"{key} ({tm.get('size', 'reduced')}{room})", _kwh(r, "bare"), _kwh(r, "fins"),
                 "-" if d is None else f"{d['device']}: {_kwh(d, 'fins')}",
                 f"{r[fsh]:.2f} / " + ("-" if d is None else f"{d[fsh]:.2f}")]
        sda = [_sda(key, tm, x, p) for x, p in ((r, DAYLIGHT[0]), (r, DAYLIGHT[1]),
                                                (d, DAYLIGHT[1]))]
        for j in (0, 1):
            cells.append(" / ".join(_share(s[j]) for s in sda))
        cells.append(" / ".join(_share(x.get(p + "ase_all")) for x, p in
                                ((r, DAYLIGHT[0]), (r, DAYLIGHT[1]),
                                 (d if d is not None else {}, DAYLIGHT[1]))))
        cells.append(f"{r['stage_s.annual']:.0f} / {r['wall_s']:.0f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _lead(key: str, x: str) -> str:
    """The verdict on the cooling-season gains avoided against ``x`` (both more is better),
    from the saved table, in short: variants beyond the devices' front, the best's lead (a
    share of the two figures' spans, :func:`~torsal.study.study_report.verdict_on`) and the
    device nearest to it."""
    t = pd.read_csv(RESULTS / f"{key}_annual.csv")
    text, n = verdict_on(t, [], ParetoSpec(x=x, y=AVOIDED))
    if not n:
        return text
    return (f"{n['beyond']} of {n['torsal']} beyond, best {n['best']} "
            f"{100 * n['lead']:+.1f}% of the spans from {n['nearest'].split('-', 2)[-1]}")


def failed(key: str, lighter: bool) -> str:
    """Why the study's variant (the lighter one or not) failed, from the saved table."""
    t = pd.read_csv(RESULTS / f"{key}_annual.csv")
    t = t[(t["kind"] == "torsal") & (t["status"] == "failed")]
    t = t[t["fins.spacing"].astype(str).str.startswith("[") == lighter]
    return str(t["error"].iloc[0]).split(" (e.g.")[0] if len(t) else "-"


def _time_cell(tm: dict) -> str:
    """A study's wall minutes, processor minutes where measured, load, date, commit, size."""
    cpu = f", {tm['cpu_s'] / 60:.1f} min CPU" if "cpu_s" in tm else ""
    return (f"{tm['wall_s'] / 60:.1f} min{cpu} (load {tm['load_start']:.0f}-"
            f"{tm['load_end']:.0f}, {tm['date']}, {tm['commit']}, {tm.get('size', 'reduced')})")


def studies_table(keys=KEYS) -> str:
    """Per example: each torsal variant's cooling-season gains avoided and sDA (or view out),
    the devices' best of each, the study's verdict and the verdict against the view out,
    with the study's time and load."""
    lines = ["| example | torsal s (both) | torsal [s, 2s] | best device on gains avoided | "
             "best device on sDA / view | gains avoided against sDA | gains avoided against "
             "view | study time |", "|" + "---|" * 8]
    for key, torsal, devices in _studies(keys):
        tm = json.loads((RESULTS / f"{key}_annual.json").read_text())
        x = SDA if SDA in torsal and torsal[SDA].notna().any() else X_KEY
        # LM-83's sDA with its blinds; a run before them measured the room without
        word = ("view" if x != SDA else "sDA LM-83" if tm.get(BLINDS) else "sDA w/o blinds")

        def cell(r):
            return (f"{r[AVOIDED]:.0f} kWh/m2, {word} {_share(r[x])}"
                    + (f", view {_share(r[X_KEY])}" if x != X_KEY else "")
                    + f" (s {r['fins.spacing']}, {r['material_kg']:.0f} kg)")
        sparse = torsal["fins.spacing"].astype(str).str.startswith("[")
        cells = [key] + [cell(rows.iloc[0]) if len(rows) else "failed: " + failed(key, lighter)
                         for lighter, rows in ((False, torsal[~sparse]), (True, torsal[sparse]))]
        for col in (AVOIDED, x):
            cells.append("-" if devices.empty else
                         f"{devices.loc[devices[col].idxmax(), 'device']}: "
                         + cell(devices.loc[devices[col].idxmax()]))
        cells += [_lead(key, x) if x != X_KEY else "-", _lead(key, X_KEY),
                  _time_cell(tm)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def view_plot(key: str) -> Path:
    """The saved study's Pareto plot of the cooling-season gains avoided against the view
    clear (``examples/studies/<key>_annual_view_pareto.png``): on a facade whose rooms' sDA
    saturates, the axis that separates the designs."""
    from types import SimpleNamespace

    t = pd.read_csv(RESULTS / f"{key}_annual.csv")
    study = SimpleNamespace(variants=[], spec=SimpleNamespace(
        name=f"{key}: cooling-season gains avoided against the view",
        pareto=ParetoSpec(x=X_KEY, y=AVOIDED)))
    return write_pareto_png(HERE / "studies" / f"{key}_annual_view_pareto.png", study, t)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=Path("out/annual-studies"))
    p.add_argument("--only", nargs="*", choices=KEYS, default=list(KEYS))
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--size", choices=[z.value for z in Size], default=Size.FULL.value,
                   help="full: each example's own size at Radiance's defaults; full-design: "
                   "the same designs, lighter Radiance; reduced: the quick run")
    p.add_argument("--table-only", action="store_true")
    args = p.parse_args(argv)
    if not args.table_only:
        for key in args.only:
            tm = run(key, args.out, args.workers, Size(args.size))
            print(f"{key}: {tm['wall_s']:.0f} s (load {tm['load_start']:.1f}-"
                  f"{tm['load_end']:.1f}); {tm['verdict']}", flush=True)
    for key in args.only:
        if (RESULTS / f"{key}_annual.csv").exists():
            view_plot(key)
    tables = annual_table() + "\n\n" + studies_table()
    readme = HERE / "README.md"
    text = readme.read_text()
    if BEGIN in text:
        start, end = text.index(BEGIN) + len(BEGIN), text.index(END)
        readme.write_text(text[:start] + "\n" + tables + "\n" + text[end:])
    print(tables)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
