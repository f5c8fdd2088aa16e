"""Run every example design at full size and write the results table of examples/README.md.

    python examples/run_all.py [--out out/examples] [--only 7a 9 ...]

Each example writes its outputs to OUT/<example>/; the table compares the measured numbers
with the paper's Fig. 12 row (Wang et al. 2013). Times are wall-clock seconds on the machine
that ran this script.
"""
import argparse
import os
import subprocess
import time
from datetime import datetime, timezone
from pathlib import Path

from torsal.core.atomic import atomic_path, write_json
from torsal.design import Design

HERE = Path(__file__).resolve().parent
#: Fig. 12 of the paper: |V|, |F|, T (s), delta_pl after extraction, after optimization
PAPER = {
    "7a": (1073, 2048, 0.4, 0.0004, 0.0004),
    "7b": (1073, 2048, 1.4, 0.0003, 0.0003),
    "7c": (1073, 2048, 3.7, 0.01, 0.006),
    "7d": (561, 1024, 1.0, 0.001, 0.001),
    "9": (2633, 5120, 29.0, 0.03, 0.017),
    "10": None,
    "11": (5087, 9182, 11.0, 0.01, 0.01),
    "13": (4290, 8282, 17.0, 0.002, 0.002),
}
BEGIN, END = "<!-- results:begin -->", "<!-- results:end -->"


def run(path: Path, out: Path) -> dict:
    t0 = time.perf_counter()
    # an unbuildable example is measured and reported (interfering pairs column), not aborted
    res = Design.from_toml(path).run(out / path.stem, use_cache=False, accept_unbuildable=True)
    r = res.report
    r["wall_s"] = time.perf_counter() - t0
    r["stage_s"] = res.stage_seconds
    r["final_cut"] = final_cut(Design.from_toml(path).spec)
    return r


def final_cut(spec) -> dict:
    """The final cut of the run's parts (``torsal design --final-cut``:
    :func:`~torsal.fabrication.nesting.final_cut.final_cut`, the search, then plates split at
    crossing slots where the bill of quantities says a sheet saved pays), from the fin system
    the run built: sheets, yield, cuts kept, processor seconds, and where plates were split,
    the split design's assembly check (interfering pairs, blocked parts) and load path (parts
    not held)."""
    from torsal.fabrication import verify_assembly
    from torsal.fabrication.nesting import final_cut as fc
    from torsal.pipeline.fins import last_fin_system
    from torsal.pipeline.stages import nest_options

    fs = last_fin_system()
    c0 = time.process_time()
    rates = None if spec.costs is None else spec.costs.rates()
    fs2, lay, split = fc.final_cut(fs, nest_options(spec, fs.unit), rates=rates,
                                   density=spec.material.density)
    out = {"sheets": lay.n_sheets, "utilization": lay.utilization, "bound": lay.area_bound,
           "cpu_s": time.process_time() - c0, "method": lay.stats.method,
           "split": split.as_report()}
    if fs2 is not fs:
        from torsal.fabrication.assembly.load_path import load_path

        # buildable as the design run judges it: in place, and held by its load path
        check, held = verify_assembly(fs2), load_path(fs2)
        out["buildable"] = bool(check.buildable and held.supported)
        out["interfering"], out["blocked"] = check.interfering_pairs, len(check.blocked)
        out["unsupported"] = len(held.unsupported_parts)
    return out


def final_cut_cell(r: dict) -> str:
    """Sheets / yield of the final cut, its plates cut (seams in their slots) and processor
    seconds; "not buildable" where the split design's assembly check refuses it."""
    f = r.get("final_cut")
    if not f:
        return "-"
    sp = f.get("split") or {}
    cuts = f"{sp['cuts']} cuts" if sp.get("kept") else "no cut"
    ok = "" if f.get("buildable", True) else (
        f", NOT buildable: {f['interfering']} interfering, {f['blocked']} blocked, "
        f"{f.get('unsupported', 0)} not held")
    return (f"{f['sheets']} / {100 * f['utilization']:.1f}% ({cuts}{ok}; "
            f"{f['cpu_s']:.0f} s CPU)")


def row(key: str, r: dict | None, err: str | None) -> str:
    p = PAPER.get(key)
    paper = (f"{p[0]} / {p[1]} / {p[2]:g} s / {p[3]:g} / {p[4]:g}" if p else "(no row)")
    if r is None:
        return f"| {key} | failed: {err} |" + " |" * 18 + f" {paper} |"
    c, s, li = r["congruence"], r["support"], r["light"]
    fa = r.get("fabrication", {})
    return (f"| {key} | {c['vertices']} | {c['faces']} | {c['build_s'] + c['solve_s']:.1f} | "
            f"{r['wall_s']:.0f} | {s['delta_pl_extracted']:.1e} | {s['delta_pl_optimized']:.1e} | "
            f"{100 * li['blocked_share']:.0f}% ({louvers(li, 'blocked_share')}) | "
            f"{100 * li['transparency']:.0f}% ({louvers(li, 'transparency')}) | "
            f"{s['edges']} / {fa.get('parts', '-')} / {fa.get('sheets', '-')} | {sheets_cell(fa)} | "
            f"{final_cut_cell(r)} | "
            f"{min_torsal_angle(c)} | "
            f"{interfering_cell(fa.get('assembly'))} | {connector_cell(fa)} | {seams_cell(fa)} | "
            f"{fastener_cell(fa)} | {quantities_cell(fa)} | "
            f"{left_out_cell(fa, s['edges'])} | {paper} |")


def quantities_cell(fa: dict) -> str:
    """The bill of quantities' totals (report.json ``fabrication.quantities``): net / gross
    kg of sheet, metres of cut, pierces, bends; and its price at the design file's
    ``[costs]`` rates (``fabrication.costs``: total, per m² of the design surface), where
    it has them."""
    q = fa.get("quantities")
    if not q:
        return "-"
    cell = (f"{q['net_kg']:,.0f} / {q['gross_kg']:,.0f} kg; {q['cut_m']:,.0f} m cut; "
            f"{q['pierces']:,} pierces; {q['bends']:,} bends")
    c = fa.get("costs")
    if c:
        cur = f" {c['currency']}" if c.get("currency") else ""
        cell += f"; price {c['total']:,.0f}{cur}"
        if c.get("per_m2"):
            cell += f", {c['per_m2']:,.0f}{cur}/m²"
    return cell


def louvers(li: dict, key: str) -> str:
    """Horizontal louvers' figure, or "n/a" where they cannot be made (a canopy)."""
    b = li["baseline_louvers"]
    return f"{100 * b[key]:.0f}%" if b.get("applicable", True) else "n/a"


def sheets_cell(fa: dict) -> str:
    """Sheets used against the area bound (parts' area / sheet area), and the utilization of
    the sheets as the DXF files read back give it, with the nester's seconds."""
    n = fa.get("nesting")
    if not n:
        return "- | -"
    util = n.get("utilization_dxf")
    util = n["utilization"] if util is None else util
    nester = n["nester"].split(" (")[0] + (" kept" if "(" in n["nester"] else "")
    return (f"{n['sheets']} / {n['area_bound_sheets']:.1f} | {100 * util:.0f}% "
            f"({nester}, {n['seconds']:.0f} s)")


def min_torsal_angle(c: dict) -> str:
    """Measured minimum torsal angles (degrees) of the optimized congruence, the torsal planes'
    crossing angle and the torsal directions' angle in the face (``planes / directions``), the
    bound of a ``min_torsal_angle`` constraint on the one it bounds, and the faces that have
    no torsal directions."""
    m = (c.get("constraints") or {}).get("min_torsal_angle")
    bounded = m.get("angle", "planes") if m else None
    cells = []
    for between, key in (("planes", "min_torsal_plane_angle_deg"), ("directions", "min_torsal_direction_angle_deg")):
        ang = c.get(key, c.get("min_torsal_angle_deg") if between == "planes" else None)
        cell = "-" if ang is None else f"{ang:.1f}"
        if bounded == between:
            cell += f" (>= {m['bound']:g}{', ' + str(m['n_missing']) + ' faces miss it' if m['n_missing'] else ''})"
        cells.append(cell)
    text = " / ".join(cells)
    none = c.get("faces_without_torsal_directions")
    if none:
        text += f"; {none} faces without"
    return text


def interfering_cell(a: dict | None) -> str:
    """Interfering pairs found by the assembly stage (exact booleans on fins.step), the worst
    overlap, parts that cannot be inserted, and parts not held to the building."""
    if a is None:
        return "-"
    cell = str(a["interfering_pairs"])
    if a["interfering_pairs"]:
        cell += f" (worst {a['worst_overlap_mm3']:,.0f} mm³, {len(a['interfering_parts'])} parts)"
    if a["blocked_parts"]:
        cell += f", {len(a['blocked_parts'])} blocked"
    if a.get("unsupported_parts"):        # the load path: parts not held to the building
        cell += f", {len(a['unsupported_parts'])} not held"
    return cell


def left_out_cell(fa: dict, fins: int) -> str:
    """Fin panels the fabrication left out (not built, not in the light measurement), as a share
    of the structure's fins."""
    n = fa.get("panels_left_out", 0)
    share = fa.get("panels_left_out_share", n / fins if fins else 0.0)
    return f"{n} ({100 * share:.1f}%)"


def connector_cell(fa: dict) -> str:
    """Separate connectors (brackets, splice plates) and their share of all parts; fixings."""
    if "connectors" not in fa:
        return "-"
    return (f"{fa['connectors']} ({100 * fa['connector_share']:.0f}%); "
            f"{fa['fixings']} fixings")


def fastener_cell(fa: dict) -> str:
    """Bolts (through connectors and fins) and anchors (fixings into the building), and the
    bolts per m² of the design surface (the bill of quantities' ``surface_m2``)."""
    if "bolts" not in fa:
        return "-"
    cell = f"{fa['bolts']} bolts + {fa['anchors']} anchors"
    area = (fa.get("quantities") or {}).get("surface_m2")
    if area:
        cell += f"; {fa['bolts'] / area:.1f} bolts/m²"
    return cell


def seams_cell(fa: dict) -> str:
    """Seams held in crossing slots without a connector, and the seams that fell back to
    brackets (the assembly check on the parts around them refused, or the slide plan)."""
    j = fa.get("joinery")
    if not j:
        return "-"
    why = ", ".join(f"{n} {r}" for r, n in j["fallbacks_by_reason"].items())
    return f"{j['seams_in_slot']}; {len(j['fallbacks'])} fallbacks" + (f" ({why})" if why else "")


def _pad(line: str, bars: int) -> str:
    """A kept row of an older table with fewer columns: "not run" cells before the paper's."""
    cells = line.strip().strip("|").split("|")
    missing = bars - 1 - len(cells)
    if missing > 0:
        cells = cells[:-1] + [" not run "] * missing + cells[-1:]
    return "|" + "|".join(cells) + "|"


def provenance(started: datetime, seconds: float, loads: list[float], keys: list[str]) -> str:
    """The line under the table: when, on which commit, how long and at what load the rows
    were measured (the times depend on all three)."""
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=HERE, text=True,
                                capture_output=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        commit = "unknown commit"
    return (f"Rows {', '.join(keys)} measured in one run of `examples/run_all.py`, "
            f"{started:%Y-%m-%d %H:%M} UTC, commit {commit}, {seconds / 60:.0f} min, "
            f"load average {min(loads):.0f} to {max(loads):.0f} on {os.cpu_count()} cores.")


def _figure_key(key: str):
    """Figure order: 7a < 7b < ... < 9 < 10 < 11 < 13."""
    return int("".join(ch for ch in key if ch.isdigit())), key


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="out/examples")
    ap.add_argument("--only", nargs="*")
    args = ap.parse_args()
    out = Path(args.out)
    lines = ["| example | \\|V\\| | \\|F\\| | T congruence (s) | all stages (s) | delta_pl extracted | "
             "delta_pl optimized | sun blocked (louvers) | view clear (louvers) | fins / parts / sheets | "
             "sheets / area bound | utilization (DXF) | final cut: sheets / yield (plates cut; s) | "
             "min torsal angle, measured (deg): planes / directions in the face | interfering pairs | connectors (share of parts); fixings | "
             "seams in slots; fallbacks | fasteners; bolts per m² | "
             "bill of quantities: net / gross sheet, cut, pierces, bends; price at the rates | fin panels left out | "
             "paper: \\|V\\| / \\|F\\| / T / delta_pl extr. / opt. |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    started, t0, loads, keys = datetime.now(timezone.utc), time.perf_counter(), [os.getloadavg()[0]], []
    for path in sorted(HERE.glob("*.toml"), key=lambda p: _figure_key(p.stem.split("_")[0])):
        key = path.stem.split("_")[0]
        if args.only and key not in args.only:
            continue
        keys.append(key)
        try:
            r, err = run(path, out), None
        except Exception as exc:  # report and go on with the other examples
            r, err = None, f"{type(exc).__name__}: {exc}".replace("|", "/")[:200]
        lines.append(row(key, r, err))
        loads.append(os.getloadavg()[0])
        print(lines[-1], flush=True)
        if r is not None:
            write_json(out / path.stem / "timings.json", {"wall_s": r["wall_s"], "stage_s": r["stage_s"]})
    readme = HERE / "README.md"
    text = readme.read_text()
    if BEGIN in text:
        head, rest = text.split(BEGIN, 1)
        old, tail = rest.split(END, 1)
        if args.only:  # keep the rows of the examples not re-run
            new = {ln.split("|")[1].strip(): ln for ln in lines[2:]}
            kept = [_pad(ln, lines[0].replace("\\|", "").count("|")) for ln in old.strip().splitlines()[2:]
                    if ln.startswith("|") and ln.split("|")[1].strip() not in new]
            rows = sorted(kept + list(new.values()), key=lambda ln: _figure_key(ln.split("|")[1].strip()))
            lines = lines[:2] + rows
        # the provenance lines of earlier runs are kept while a row they measured is kept
        notes = [ln for ln in old.strip().splitlines() if ln.startswith("Rows ")
                 and set(ln[5:].split(" measured")[0].split(", ")) - set(keys)] if args.only else []
        notes.append(provenance(started, time.perf_counter() - t0, loads, keys))
        table = "\n".join(lines) + "\n\n" + "\n".join(notes)
        with atomic_path(readme) as tmp:
            tmp.write_text(head + BEGIN + "\n" + table + "\n" + END + tail)
    print("\n".join(lines))


if __name__ == "__main__":
    main()
