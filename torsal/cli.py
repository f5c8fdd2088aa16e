"""The ``torsal`` command line: parses, shows progress, calls :mod:`torsal.design`.

No geometry here; this is the only module that prints to the terminal.
Exit status: 0 on success, 2 on bad input (a message names the problem), 1 on other failures,
3 when ``torsal design`` finished but the design is not buildable: the assembly check found
parts that interfere or cannot be inserted (the message names them; every output, report
included, is written). ``--accept-unbuildable`` accepts such a design: exit 0, and the
summary still says NOT BUILDABLE.
"""
from __future__ import annotations

import argparse
import sys
import time

__all__ = ["main"]


def _build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="torsal",
        description="Discrete line congruences for shading and lighting: from a design surface "
                    "and the sun to buildable planar fins.",
    )
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    a = sub.add_parser("analyze", help="analyze the line congruence of a mesh (torsal directions, "
                                       "focal points, hyperbolicity, normality)")
    a.add_argument("mesh", help="triangle mesh A (OBJ, PLY, STL or OFF) in model units")
    g = a.add_mutually_exclusive_group()
    g.add_argument("--normals", action="store_true",
                   help="use the normal congruence of A (the default)")
    g.add_argument("--directions", metavar="FILE",
                   help="per-vertex line directions: .npy or text with one 'x y z' row per vertex")
    a.add_argument("--out", metavar="DIR", default=None,
                   help="write analysis.json and torsal_field.png here")
    a.add_argument("--no-plot", action="store_true", help="skip the PNG")
    d = sub.add_parser("design", help="run a design file end to end: optimize the congruence, "
                                      "remesh, build the support structure, measure the light, "
                                      "write STEP / 3DM / DXF / parts list and a report")
    d.add_argument("file", help="TOML design file")
    d.add_argument("--out", metavar="DIR", required=True, help="output folder")
    d.add_argument("--no-cache", action="store_true", help="recompute every stage")
    d.add_argument("--accept-unbuildable", action="store_true",
                   help="finish with exit status 0 even if the assembly check finds interfering "
                        "parts (default: exit status 3, naming them)")
    return p


def _design(args, console) -> int:
    from rich.live import Live
    from rich.table import Table

    from .design import STAGES, Design, UnbuildableDesignError

    design = Design.from_toml(args.file)
    status = {s: ("waiting", "") for s in STAGES}
    if design.spec.substructure is None:
        status["substructure"] = ("skipped", "no \\[substructure] table in the design")
    t_start = time.perf_counter()

    def render():
        t = Table(title=f"{design.spec.name}  ({time.perf_counter() - t_start:.0f} s)")
        t.add_column("stage")
        t.add_column("state")
        t.add_column("detail")
        for s in STAGES:
            st, detail = status[s]
            colour = {"done": "green", "cached": "cyan", "running": "yellow",
                      "NOT BUILDABLE": "bold red"}.get(st, "dim")
            t.add_row(s, f"[{colour}]{st}[/]", detail)
        return t

    with Live(render(), console=console, refresh_per_second=4, transient=False) as live:
        def progress(stage, event, info):
            if event == "start":
                status[stage] = ("running", "")
            elif event == "iteration":
                status[stage] = ("running", f"iteration {info.get('iteration')}, energy "
                                            f"{info.get('objective', float('nan')):.4g}, "
                                            f"infeasibility {info.get('infeasibility', float('nan')):.2g}")
            elif event == "done":
                status[stage] = ("done", f"{info['seconds']:.1f} s")
            elif event == "cached":
                status[stage] = ("cached", "inputs unchanged")
            elif event == "progress":
                status[stage] = ("running", f"{info.get('phase')} {info.get('done')}/{info.get('total')}")
            live.update(render())

        try:
            res = design.run(args.out, progress=progress, use_cache=not args.no_cache,
                             accept_unbuildable=args.accept_unbuildable)
        except UnbuildableDesignError as exc:
            status["assembly"] = ("NOT BUILDABLE", ", ".join(exc.parts[:4]))
            live.update(render())
            console.print(f"[bold red]not buildable:[/] {exc}")
            console.print(f"outputs and report written to {args.out} (report: {args.out}/report.html, "
                          f"steps: {args.out}/assembly.csv); pass --accept-unbuildable to accept")
            return 3
    r = res.report
    s, li, fa = r["support"], r["light"], r["fabrication"]
    console.print(f"fins: {s['edges']}, delta_pl {s['delta_pl_extracted']:.2e} -> "
                  f"{s['delta_pl_optimized']:.2e}; sun blocked {100 * li['blocked_share']:.1f}% "
                  f"(louvers {100 * li['baseline_louvers']['blocked_share']:.1f}%); "
                  f"{fa['parts']} parts on {fa['sheets']} sheets")
    for gate in (r["congruence"].get("joinery"), s.get("joinery")):
        if gate and gate.get("message"):
            console.print(f"[yellow]joinery:[/] {gate['message']}")
    asm = fa.get("assembly")
    if asm is not None and not asm["buildable"]:
        from .pipeline.assembly import unbuildable_message

        console.print(f"[bold red]NOT BUILDABLE (accepted with --accept-unbuildable):[/] "
                      f"{unbuildable_message(asm)}")
    console.print(f"wrote {len(res.files)} outputs to {args.out} (report: {args.out}/report.html)")
    return 0


def _analyze(args, console) -> int:
    from .design import analyze

    t0 = time.perf_counter()
    with console.status(f"analyzing {args.mesh} ..."):
        res = analyze(args.mesh, directions=args.directions, out_dir=args.out,
                      plot=not args.no_plot)
    s = res.summary
    from rich.table import Table

    table = Table(title=f"congruence of {args.mesh} ({s['directions']})", show_header=False)
    table.add_row("vertices / faces", f"{s['vertices']} / {s['faces']}")
    table.add_row("average edge length", f"{s['average_edge_length']:.4g}")
    table.add_row("hyperbolic faces", f"{s['hyperbolic_faces']} ({100 * s['hyperbolic_share']:.1f}%)")
    table.add_row("line-bundle faces", str(s["bundle_faces"]))
    fd = s["focal_distance"]
    if fd:
        table.add_row("focal distance", f"{fd['min']:.4g} .. {fd['max']:.4g} (median {fd['median']:.4g})")
    table.add_row("focal points at infinity", str(s["focal_points_at_infinity"]))
    nr = s["normality_residual_relative"]
    if nr:
        table.add_row("normality residual (eq 7) / delta", f"median {nr['median']:.3g}, max {nr['max']:.3g}")
    ta = s["torsal_angle_deg"]
    if ta:
        table.add_row("torsal angle (deg)", f"min {ta['min']:.1f}, median {ta['median']:.1f}")
    console.print(table)
    for kind, path in res.files.items():
        console.print(f"wrote {kind}: {path}")
    console.print(f"done in {time.perf_counter() - t0:.2f} s")
    return 0


def main(argv: list[str] | None = None) -> int:
    from rich.console import Console

    args = _build_parser().parse_args(argv)
    console = Console(stderr=False)
    err = Console(stderr=True)
    from .design import DesignError

    try:
        if args.command == "analyze":
            return _analyze(args, console)
        if args.command == "design":
            return _design(args, console)
    except (FileNotFoundError, ValueError, DesignError) as exc:
        err.print(f"[bold red]error:[/] {exc}")
        return 2
    return 1


if __name__ == "__main__":
    sys.exit(main())
