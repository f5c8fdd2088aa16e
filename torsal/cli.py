"""The ``torsal`` command line: parses, shows progress, calls :mod:`torsal.design`.

No geometry here; this is the only module that prints to the terminal.

Exit status (one place: :func:`_run_command`):

- 0: success.
- 1: an internal error (a bug): one line naming it; ``--debug`` (or ``TORSAL_DEBUG=1``) shows
  the traceback. Any exception other than those below, and a ``ValueError`` raised inside a
  library (numpy, scipy ...) rather than by torsal's own checks.
- 2: bad input: any :class:`~torsal.core.errors.TorsalError` (mesh, design file, directions,
  a stage rejecting its input, an output folder that cannot be used), a ``ValueError`` from
  torsal's own checks, or a file that cannot be read or written. The message names the problem
  and what to change; never a traceback.
- 3: ``torsal design`` finished but the design is not buildable: the assembly check found
  parts that interfere or cannot be inserted (the message names them; every output, report
  included, is written). ``--accept-unbuildable`` accepts such a design: exit 0, and the
  summary still says NOT BUILDABLE.
- 4: ``torsal study`` finished with failed variants (they are listed, the others' results are
  written).
- 130: interrupted.

Everything the user typed or a file held is printed literally (no rich markup), messages go
to stderr, results to stdout; progress streams line by line when stdout is not a terminal.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
import traceback
import warnings

__all__ = ["main", "EXIT_OK", "EXIT_INTERNAL", "EXIT_BAD_INPUT", "EXIT_NOT_BUILDABLE",
           "EXIT_VARIANTS_FAILED"]

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_BAD_INPUT = 2
EXIT_NOT_BUILDABLE = 3
EXIT_VARIANTS_FAILED = 4
EXIT_INTERRUPTED = 130


# ---------------------------------------------------------------------- terminal
class _Terminal:
    """The one place that prints: literal text, tables, and progress that streams when piped."""

    def __init__(self):
        from rich.console import Console

        # soft_wrap: long paths and messages are not broken into lines; markup off: user text
        # in brackets ("[0, 24]") is printed as it is
        self.out = Console(soft_wrap=True, markup=False, highlight=False, emoji=False)
        self.err = Console(stderr=True, soft_wrap=True, markup=False, highlight=False, emoji=False)

    @property
    def interactive(self) -> bool:
        return self.out.is_terminal

    def line(self, text: str) -> None:
        """A line of results on stdout, flushed at once (so ``| tee log`` shows it now)."""
        self.out.print(text)
        self.out.file.flush()

    def error(self, text: str) -> None:
        self.err.print(f"error: {text}")
        self.err.file.flush()

    def note(self, text: str) -> None:
        self.err.print(text)
        self.err.file.flush()

    def print(self, *objects, **kwargs) -> None:
        """rich ``Console.print`` on stdout, literal unless ``markup=True`` is passed (for a
        subcommand written against a rich Console)."""
        self.out.print(*objects, **kwargs)
        self.out.file.flush()

    def table(self, table) -> None:
        self.out.print(table)  # rich ends a printed table with a newline
        self.out.file.flush()


# ---------------------------------------------------------------------- parser
def _add_analyze(sub, common) -> None:
    a = sub.add_parser("analyze", parents=[common],
                       help="analyze the line congruence of a mesh (torsal directions, "
                            "focal points, hyperbolicity, normality)")
    a.add_argument("mesh", help="triangle mesh A (OBJ, PLY, STL or OFF) in model units; vertices "
                                "at the same position are merged (see README, mesh requirements)")
    g = a.add_mutually_exclusive_group()
    g.add_argument("--normals", action="store_true",
                   help="use the normal congruence of A (the default)")
    g.add_argument("--directions", metavar="FILE",
                   help="per-vertex line directions: .npy or text with one 'dx dy dz' row per "
                        "vertex of the file or per vertex after merging (not for STL, which has no "
                        "vertex order), or 'x y z dx dy dz' rows matched to vertices by "
                        "position (the output says which)")
    a.add_argument("--out", metavar="DIR", default=None,
                   help="write analysis.json and torsal_field.png here")
    a.add_argument("--no-plot", action="store_true", help="skip the PNG")


def _add_design(sub, common) -> None:
    d = sub.add_parser("design", parents=[common],
                       help="run a design file end to end: optimize the congruence, "
                            "remesh, build the support structure, measure the light, "
                            "write STEP / 3DM / DXF / parts list and a report")
    d.add_argument("file", help="TOML design file")
    d.add_argument("--out", metavar="DIR", required=True, help="output folder")
    d.add_argument("--no-cache", action="store_true", help="recompute every stage")
    d.add_argument("--accept-unbuildable", action="store_true",
                   help="finish with exit status 0 even if the assembly check finds interfering "
                        "parts (default: exit status 3, naming them)")
    d.add_argument("--final-cut", action="store_true",
                   help="nest the sheets for yield with the deterministic search (as [nesting] "
                        "final_cut = true): seconds to a minute, kept in the design's cache, the "
                        "same sheets on every run")
    d.add_argument("--no-size-limit", action="store_true",
                   help="run even when the size estimate (fins, optimizer variables, rays, parts, "
                        "disk) is above the limits in the README")


def _build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="torsal",
        description="Discrete line congruences for shading and lighting: from a design surface "
                    "and the sun to buildable planar fins.",
        epilog="exit status: 0 ok, 1 internal error (a bug; --debug shows the traceback), "
               "2 bad input (the message names it), 3 design not buildable, 4 study variants "
               "failed, 130 interrupted",
    )
    p.add_argument("--debug", action="store_true", help="show the traceback of internal errors")
    # accepted after the subcommand too; SUPPRESS keeps the top-level value when absent
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                        help="show the traceback of internal errors")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _add_analyze(sub, common)
    _add_design(sub, common)
    _add_study(sub, common)
    _add_freecad(sub, common)
    return p


def _add_study(sub, common) -> None:
    s = sub.add_parser("study", parents=[common],
                       help="run a design study: variants of a design over axes (a grid, "
                            "or an optuna [search]) as Dask tasks, compared with standard "
                            "shading devices; writes results.parquet/.csv and study.html")
    s.add_argument("file", help="TOML study file (name, base, [axes], [run], [search])")
    s.add_argument("--out", metavar="DIR", required=True, help="output folder (a study resumes here)")
    s.add_argument("--scheduler", metavar="ADDRESS", default=None,
                   help="a running Dask scheduler, e.g. tcp://host:8786 (default: a local cluster)")
    s.add_argument("--workers", metavar="N", type=int, default=None,
                   help="worker processes of the local cluster (default: the file's [run] workers)")
    s.add_argument("--retry-failed", action="store_true",
                   help="run variants again that failed in an earlier run of this folder")


def _add_freecad(sub, common) -> None:
    f = sub.add_parser("freecad", parents=[common],
                       help="install or remove the torsal workbench (a parametric fins object) "
                            "in FreeCAD")
    f.add_argument("action", choices=["install", "uninstall"])
    f.add_argument("--mod-dir", metavar="DIR", default=None,
                   help="FreeCAD's folder of user Mods (default: asked of freecadcmd, else "
                        "~/.local/share/FreeCAD/Mod)")


# ---------------------------------------------------------------------- commands
def _freecad(args, ui: _Terminal) -> int:
    from .hosts.freecad.install import install_workbench, uninstall_workbench

    if args.action == "uninstall":
        folder = uninstall_workbench(args.mod_dir)
        ui.line(f"removed the torsal workbench from {folder}" if folder else
                "no torsal workbench was installed there")
        return EXIT_OK
    folder = install_workbench(args.mod_dir)
    ui.line(f"installed the torsal workbench in {folder} (for torsal's Python {sys.executable})")
    ui.line("restart FreeCAD; then, in its Python console or a macro:")
    ui.line("    from torsal.freecad import make_fins")
    ui.line("    fins = make_fins(App.ActiveDocument, 'design.toml'); App.ActiveDocument.recompute()")
    ui.line(f"remove it with:  torsal freecad uninstall{' --mod-dir ' + args.mod_dir if args.mod_dir else ''}"
            f"   (or: rm -r {folder})")
    return EXIT_OK


def _start_fork_server_early(design_file) -> None:
    """Start the fork server the run's processes are forked from (the solids' workers, the
    concurrent stages; :func:`~torsal.fabrication.workers.start_fork_server`) before this
    process imports the pipeline: its imports (OpenCascade and the pipeline's stages, seconds)
    then run on the core that this process's own imports leave idle, instead of beside the
    congruence and the fin system later. It imports :mod:`torsal.pipeline.stages`, the module
    of the pipeline this command runs (its concurrent stages' functions and what they import).
    :meth:`~torsal.pipeline.design.Design.run` starts it where this did not (its start is a
    no-op once the server runs). Nothing where the file does not parse as TOML (the design's
    own check names the problem) or where its ``[outputs]`` turn off STEP, 3DM and IFC (no
    solids to build)."""
    import tomllib

    try:
        with open(design_file, "rb") as f:
            outputs = tomllib.load(f).get("outputs", {})
    except (OSError, ValueError):
        return
    if isinstance(outputs, dict) and all(outputs.get(k) is False
                                         for k in ("step", "rhino_3dm", "ifc")):
        return
    from .fabrication.workers import start_fork_server

    start_fork_server(also=("torsal.pipeline.stages",))


def _design(args, ui: _Terminal) -> int:
    _start_fork_server_early(args.file)
    from .core.outputs import new_output_folder
    from .pipeline.assembly import UnbuildableDesignError
    from .pipeline.design import Design
    from .pipeline.measure import devices_summary, light_summary
    from .pipeline.stages import STAGES

    design = Design.from_toml(args.file)
    if args.final_cut:
        spec = design.spec
        design = Design(spec.model_copy(update={"nesting": spec.nesting.model_copy(
            update={"final_cut": True})}), source=args.file)
    progress = _DesignProgress(ui, design, STAGES)
    try:
        with new_output_folder(args.out) as out, progress:
            res = design.run(out, progress=progress, use_cache=not args.no_cache,
                             size_limit=not args.no_size_limit,
                             accept_unbuildable=args.accept_unbuildable)
    except UnbuildableDesignError as exc:
        ui.error(f"not buildable: {exc}")
        ui.note(f"outputs and report written to {out} (report: {out / 'report.html'}, steps: "
                f"{out / 'assembly.csv'}); pass --accept-unbuildable to accept")
        return EXIT_NOT_BUILDABLE
    r = res.report
    mf = r.get("surface", {}).get("mesh_file")
    if mf and (mf["merged"] or mf["unused"] or mf["polygons_triangulated"]
               or mf.get("duplicate_faces_dropped")):
        ui.line(f"surface: {mf['vertices']} vertices from {mf['file_vertices']} in the file "
                f"({mf['merged']} merged at the same position, {mf['unused']} unused, "
                f"{mf['polygons_triangulated']} polygons triangulated, "
                f"{mf.get('duplicate_faces_dropped', 0)} duplicate faces dropped)")
    s, li, fa = r["support"], r["light"], r["fabrication"]
    ui.line(f"fins: {s['edges']}, delta_pl {s['delta_pl_extracted']:.2e} -> "
            f"{s['delta_pl_optimized']:.2e}; {light_summary(li)}; "
            f"{fa['parts']} parts on {fa['sheets']} sheets")
    ui.line(devices_summary(li))
    if li.get("annual"):
        from .pipeline.annual import annual_summary

        ui.line(annual_summary(li["annual"]))
    for gate in (r["congruence"].get("joinery"), s.get("joinery")):
        if gate and gate.get("message"):
            ui.note(f"joinery: {gate['message']}")
    asm = fa.get("assembly")
    if asm is not None and asm["buildable"]:
        ui.line(f"assembly: buildable, 0 of {asm['pairs_checked']} touching part pairs interfere; "
                f"{asm['steps']} assembly steps in {out / 'assembly.csv'}")
    if asm is not None and not asm["buildable"]:
        from .pipeline.assembly import unbuildable_message

        ui.note(f"NOT BUILDABLE (accepted with --accept-unbuildable): {unbuildable_message(asm)}")
    ui.line(f"wrote {len(res.files)} outputs to {out} (report: {out / 'report.html'})")
    return EXIT_OK


class _DesignProgress:
    """Stage progress: a live table on a terminal, one line per event when piped.

    Called as ``progress(stage, event, info)`` by :meth:`torsal.design.Design.run`.
    """

    _ITERATION_EVERY_S = 2.0  # piped: at most one iteration or progress line per this many seconds

    def __init__(self, ui: _Terminal, design, stages):
        self.ui, self.stages = ui, stages
        self.name = design.spec.name
        self.status = {s: ("waiting", "") for s in stages}
        if design.spec.substructure is None and "substructure" in self.status:
            self.status["substructure"] = ("skipped", "no [substructure] table in the design")
        self.t0 = time.perf_counter()
        self.live = None
        self._last_line = 0.0

    def __enter__(self):
        if self.ui.interactive:
            from rich.live import Live

            self.live = Live(self._render(), console=self.ui.out, refresh_per_second=4,
                             transient=False)
            self.live.__enter__()
        else:
            self.ui.line(f"{self.name}: {len(self.stages)} stages")
        return self

    def __exit__(self, *exc):
        if self.live is not None:
            self.live.update(self._render())
            self.live.__exit__(*exc)
        return False

    def _render(self):
        from rich.table import Table
        from rich.text import Text

        t = Table(title=Text(f"{self.name}  ({time.perf_counter() - self.t0:.0f} s)"))
        for col in ("stage", "state", "detail"):
            t.add_column(col)
        for s in self.stages:
            st, detail = self.status[s]
            colour = {"done": "green", "cached": "cyan", "running": "yellow"}.get(st, "dim")
            t.add_row(Text(s), Text(st, style=colour), Text(detail))
        return t

    def __call__(self, stage: str, event: str, info: dict) -> None:
        if event == "start":
            state = ("running", "")
        elif event == "iteration":
            state = ("running", f"iteration {info.get('iteration')}, energy "
                                f"{info.get('objective', float('nan')):.4g}, "
                                f"infeasibility {info.get('infeasibility', float('nan')):.2g}")
        elif event == "done":
            state = ("done", f"{info.get('seconds', float('nan')):.1f} s")
        elif event == "cached":
            state = ("cached", "inputs unchanged")
        elif event == "progress":
            state = ("running", f"{info.get('phase')} {info.get('done')}/{info.get('total')}")
        else:
            state = (event, ", ".join(f"{k} {v}" for k, v in info.items()))
        self.status[stage] = state
        if self.live is not None:
            self.live.update(self._render())
            return
        now = time.perf_counter()
        if event in ("iteration", "progress") and now - self._last_line < self._ITERATION_EVERY_S:
            return
        self._last_line = now
        self.ui.line(f"[{now - self.t0:7.1f} s] {stage}: {state[0]}"
                     + (f" ({state[1]})" if state[1] else ""))


def _analyze(args, ui: _Terminal) -> int:
    from rich.table import Table
    from rich.text import Text

    import contextlib

    from .core.outputs import new_output_folder
    from .pipeline.analyze import analyze

    with (new_output_folder(args.out) if args.out is not None
          else contextlib.nullcontext()) as out:
        t0 = time.perf_counter()
        if not ui.interactive:
            ui.line(f"analyzing {args.mesh} ...")
        res = analyze(args.mesh, directions=args.directions, out_dir=out, plot=not args.no_plot)
    s = res.summary
    table = Table(title=Text(f"congruence of {args.mesh} ({s['directions']})"), show_header=False)
    table.add_column()
    table.add_column()

    def row(key, value):
        table.add_row(Text(key), Text(value))

    mf = s.get("mesh_file")
    row("vertices / faces", f"{s['vertices']} / {s['faces']}")
    if mf and (mf["file_vertices"] != s["vertices"] or mf["polygons_triangulated"]
               or mf.get("duplicate_faces_dropped")):
        row("in the file", f"{mf['file_vertices']} vertices ({mf['merged']} merged, "
                           f"{mf['unused']} unused), {mf['polygons_triangulated']} polygons "
                           "triangulated"
                           + (f", {mf['duplicate_faces_dropped']} duplicate faces dropped"
                              if mf.get("duplicate_faces_dropped") else ""))
    if "directions_rows" in s:
        row("directions rows", s["directions_rows"])
        row("row order", s["directions_row_order"])
    row("average edge length", f"{s['average_edge_length']:.4g}")
    row("hyperbolic faces", f"{s['hyperbolic_faces']} ({100 * s['hyperbolic_share']:.1f}%)")
    row("line-bundle faces", str(s["bundle_faces"]))
    fd = s["focal_distance"]
    if fd:
        row("focal distance", f"{fd['min']:.4g} .. {fd['max']:.4g} (median {fd['median']:.4g})")
    row("focal points at infinity", str(s["focal_points_at_infinity"]))
    nr = s["normality_residual_relative"]
    if nr:
        row("normality residual (eq 7) / delta", f"median {nr['median']:.3g}, max {nr['max']:.3g}")
    ta = s["torsal_angle_deg"]
    if ta:
        row("torsal angle (deg)", f"min {ta['min']:.1f}, median {ta['median']:.1f}")
    ui.table(table)
    for kind, path in res.files.items():
        ui.line(f"wrote {kind}: {path}")
    ui.line(f"done in {time.perf_counter() - t0:.2f} s")
    return EXIT_OK


def _study(args, ui: _Terminal) -> int:
    from .study import Study

    if args.workers is not None and args.workers < 1:
        raise ValueError(f"--workers must be at least 1, got {args.workers}")
    study = Study.from_toml(args.file)       # every key and axis checked before anything runs
    n = len(study.variants) or study.spec.search.trials
    where = args.scheduler or (study.spec.run.scheduler if args.workers is None else None) or \
        f"a local cluster of {args.workers or study.spec.run.workers} workers"
    ui.line(f"{study.spec.name}: {n} variants on {where}")
    with _StudyProgress(ui, n) as progress:
        try:
            res = study.run(args.out, workers=args.workers, scheduler=args.scheduler,
                            progress=progress, retry_failed=args.retry_failed)
        except KeyboardInterrupt:
            ui.error(f"interrupted: finished variants are kept in {args.out}/variants; run "
                     "the same command again to resume")
            return EXIT_INTERRUPTED
    ui.line(res.verdict)
    ui.line(f"congruence solves: {res.solves} run, {res.solves_saved} saved by the shared "
            f"cache; {res.resumed} variants finished earlier")
    failed = res.table[(res.table["kind"] == "torsal") & (res.table["status"] == "failed")]
    for _, r in failed.iterrows():
        ui.error(f"variant {r['id']} failed at stage {r['failed_stage']}: {r['error']}")
    ui.line(f"wrote {args.out}/results.parquet, results.csv, study.html")
    return EXIT_VARIANTS_FAILED if len(failed) else EXIT_OK


class _StudyProgress:
    """Variants done / failed / running: a live bar on a terminal, one line per change when piped."""

    def __init__(self, ui: _Terminal, total: int):
        self.ui, self.total, self._bar, self._last = ui, total, None, None

    def __enter__(self):
        if self.ui.interactive:
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

            columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                       TextColumn("{task.fields[done]} done, {task.fields[failed]} failed, "
                                  "{task.fields[running]} running", markup=False),
                       TimeElapsedColumn())
            self._bar = Progress(*columns, console=self.ui.out)
            self._bar.__enter__()
            self._task = self._bar.add_task("variants", total=self.total, done=0, failed=0, running=0)
        return self

    def __exit__(self, *exc):
        if self._bar is not None:
            self._bar.__exit__(*exc)
        return False

    def __call__(self, p) -> None:
        if self._bar is not None:
            self._bar.update(self._task, completed=p.done + p.failed, done=p.done, failed=p.failed,
                             running=p.running)
            return
        state = (p.done, p.failed, p.running)
        if state != self._last:
            self._last = state
            self.ui.line(f"variants: {p.done + p.failed}/{self.total} ({p.done} done, {p.failed} "
                         f"failed, {p.running} running)")


#: subcommand name -> handler(args, ui) -> exit status
_COMMANDS = {"analyze": _analyze, "design": _design, "study": _study, "freecad": _freecad}


# ---------------------------------------------------------------------- errors
def _run_command(handler, args, ui: _Terminal, debug: bool) -> int:
    """Run one subcommand and turn every exception into an exit status and a message.

    The one error policy of the command line (see the module docstring).
    """
    from .core.errors import TorsalError, raised_in_torsal

    def show_warning(message, category, filename, lineno, file=None, line=None):
        ui.note(f"warning: {message}")  # the message, not the library's source line

    try:
        with warnings.catch_warnings():
            warnings.showwarning = show_warning
            return int(handler(args, ui) or EXIT_OK)
    except KeyboardInterrupt:
        ui.error("interrupted")
        return 130
    except TorsalError as exc:
        ui.error(str(exc))
        _notes(ui, exc)
        return int(getattr(exc, "exit_status", EXIT_BAD_INPUT))
    except OSError as exc:
        # a file the user named that vanished or cannot be read or written
        where = f" {exc.filename}" if exc.filename else ""
        ui.error(f"{exc.strerror or exc}:{where}" if exc.strerror else str(exc))
        if debug:
            ui.note("".join(traceback.format_exception(exc)).rstrip())
        return EXIT_BAD_INPUT
    except ValueError as exc:
        if not raised_in_torsal(exc):
            return _internal(ui, exc, debug)
        # torsal's own checks of a value it was given (the input, through the library)
        ui.error(str(exc))
        _notes(ui, exc)
        return EXIT_BAD_INPUT
    except Exception as exc:  # a bug: one line and how to see more
        return _internal(ui, exc, debug)


def _internal(ui: _Terminal, exc: BaseException, debug: bool) -> int:
    """A bug: one line naming it, and how to see the traceback."""
    first = (str(exc).strip().splitlines() or [""])[0]
    ui.error(f"internal error: {type(exc).__name__}: {first}")
    _notes(ui, exc)
    if debug:
        ui.note("".join(traceback.format_exception(exc)).rstrip())
    else:
        ui.note("this is a bug in torsal, not in your input; run again with --debug for the "
                "traceback and report it")
    return EXIT_INTERNAL


def _notes(ui: _Terminal, exc: BaseException) -> None:
    """Print what an error's notes add (which stage, what the output folder holds)."""
    for note in getattr(exc, "__notes__", ()):
        ui.note(f"  {note}")


def _freeze_at_exit() -> None:
    """At interpreter exit (atexit): the garbage collected once, then every object left
    frozen (:func:`gc.freeze`), so that the collections of the interpreter's shutdown do not
    walk them again. A design run ends holding hundreds of thousands of objects (OpenCascade,
    casadi, scipy, the fin system): the shutdown's full collections took about a second of
    CPU after the report was written. Nothing is skipped: the atexit functions registered
    before this one still run, unreachable objects are finalized by the collection here, and
    the modules are still cleared (their objects freed by reference counting)."""
    import gc

    gc.collect()
    gc.freeze()


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status (see the module docstring).

    Examples
    --------
    >>> main(["analyze", "no-such-mesh.obj"])  # doctest: +SKIP
    2
    """
    import atexit

    atexit.unregister(_freeze_at_exit)        # once per process, however often main runs
    atexit.register(_freeze_at_exit)
    try:
        args = _build_parser().parse_args(argv)
    except SystemExit as exc:  # argparse printed usage and the problem
        return int(exc.code) if isinstance(exc.code, int) else EXIT_BAD_INPUT
    debug = bool(getattr(args, "debug", False)) or os.environ.get("TORSAL_DEBUG") == "1"
    return _run_command(_COMMANDS[args.command], args, _Terminal(), debug)


if __name__ == "__main__":
    sys.exit(main())
