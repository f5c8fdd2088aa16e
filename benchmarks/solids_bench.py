"""The parts' solids of a design, phase by phase, before and after issue 40's change to
:mod:`torsal.fabrication.plates` (issue 40: example 7a at full size in 30 s on 2 cores):

* ``before``: each slotted plate is built as a B-rep and its slots are cut with one
  OpenCascade boolean (``_cut``: ``BRepAlgoAPI_Cut`` of the plate and its slot boxes, then
  ``ShapeUpgrade_UnifySameDomain``), the faces' plane curves not stored (``pcurves=False``):
  the code before, which the module still runs where the direct cut declines;
* ``after``: the plate's faces less the slot boxes computed in the faces' planes
  (``_cut_polyhedron``, shapely), built as one B-rep (``_polyhedron_solid``) and probed on
  that polyhedron (``_check_slots_polyhedron``), no boolean; every plate B-rep keeps its
  edges' plane curves, which BRepCheck, the volume and the mesher otherwise project again.

    nice -n 5 .venv/bin/python benchmarks/solids_bench.py OUT [--design examples/7a_facade_block.toml]
        [--repeat 3] [--no-mesh]

``OUT`` is the folder of a ``torsal design`` run of the design (its stage cache holds the
support structure; the fin system is built again from it, about 15 s). Every part's solid is
built in this process, one part after the other, and meshed for the 3DM as a worker process
does it (``--no-mesh``: not), the two routes taking turns ``--repeat`` times; each cell is the
least CPU seconds of a phase over the turns (exclusive: a phase's seconds leave out the
phases it calls). Then both routes' solids are compared part by part: the same status,
volume within 1e-6 relative, the same numbers of faces, edges and vertices, BRepCheck valid.

The phases: ``plate faces`` (the plate's outlines as a vertex table and face loops),
``plate B-rep`` (built from them, or sewn), ``slot boxes``, ``boolean cut + unify``,
``polygon cut`` (the direct route's faces), ``cut B-rep``, ``BRepCheck``, ``volume``
(``BRepGProp``), ``slot probes`` (the point classifier of ``_check_slots``, or the winding
numbers of ``_check_slots_polyhedron``), ``mesh (3DM)`` (``_mesh`` at the preview
tolerance), ``other`` (the rest: the checks' arithmetic, the plate's sums).

Example 7a at full size (314 parts, 135 of them slotted, 455 slots), 2026-11-29 05:20 on the
shared 2-core machine at load 5.6 (other sessions' runs; CPU seconds swell with the load, so
compare within a table), ``nice -n -5``, ``--repeat 3``, main 09d1ff0 with this change::

    | phase | before CPU s | after CPU s |
    |---|---|---|
    | plate faces | 0.36 | 0.36 |
    | plate B-rep | 0.44 | 0.18 |
    | slot boxes | 0.08 | 0.04 |
    | boolean cut + unify | 3.27 | 0.00 |
    | polygon cut | 0.00 | 0.93 |
    | cut B-rep | 0.00 | 0.52 |
    | BRepCheck | 0.90 | 0.67 |
    | volume | 0.27 | 0.12 |
    | slot probes | 0.34 | 0.10 |
    | mesh (3DM) | 0.72 | 0.62 |
    | other | 0.09 | 0.05 |
    | all (least of 3 turns) | 6.47 | 3.59 |

    same solids: yes (314 parts: status, volume to 1e-6, faces/edges/vertices, BRepCheck)

All 135 slotted parts are cut without a boolean; their volumes agree with the boolean's to
4e-13 and their faces, edges and vertices in number. The workers' own function
(``workers._build_chunk`` of all 314 parts with their 3DM meshes, one process, same load):
7.4-7.9 s of CPU on main 09d1ff0, 4.2-4.9 s with the change (its binary BReps 8.06 -> 8.54 MB:
the stored plane curves). ``torsal design examples/7a_facade_block.toml`` on main and with the
change (the same stage cache): parts.csv, the DXF and SVG sheets, assembly.csv and report.json
(timings aside) the same bytes, the assembly check 0 of 1,478 touching pairs interfering in
both; fins.step re-read, every solid's volume within 8e-11 and the same faces, edges and
vertices, the 179 unslotted parts' vertices bit for bit (built as before; the slotted parts
are written from the new B-reps: other planes' placements, another face order, so fins.step
and fins.ifc differ in bytes; fins.3dm differs between two runs of the same code anyway).
"""
from __future__ import annotations

import argparse
import collections
import glob
import os
import pickle
import sys
import time
from pathlib import Path

#: the functions of plates timed, and their phase (a pair: outside and inside the direct route)
PHASES = {"_plate_polyhedron": "plate faces", "_polyhedron_solid": ("plate B-rep", "cut B-rep"),
          "_plate_sewn": "plate B-rep", "_slot_box_frames": "slot boxes", "_box": "slot boxes",
          "_cut": "boolean cut + unify", "_cut_polyhedron": "polygon cut",
          "_is_valid": "BRepCheck", "_volume": "volume", "_check_slots": "slot probes",
          "_check_slots_polyhedron": "slot probes"}
ORDER = ["plate faces", "plate B-rep", "slot boxes", "boolean cut + unify", "polygon cut",
         "cut B-rep", "BRepCheck", "volume", "slot probes", "mesh (3DM)", "other"]


def _set(module, name: str, fn) -> None:
    """``name`` bound to ``fn`` in a package and in each of its modules that holds it (where
    its callers look it up)."""
    prefix = module.__name__ + "."
    for m in [module, *(m for n, m in list(sys.modules.items()) if n.startswith(prefix))]:
        if hasattr(m, name):
            setattr(m, name, fn)


class Timers:
    """Exclusive CPU seconds per phase of the wrapped functions of a module (``names``: name
    -> phase, or -> (phase, phase inside ``_slotted_direct``))."""

    def __init__(self, module, names: dict):
        self.seconds = collections.Counter()
        self.stack: list = []
        self.direct = 0                            # depth inside _slotted_direct
        self.module = module
        self.original = {name: getattr(module, name) for name in [*names, "_slotted_direct"]}
        for name, phase in names.items():
            _set(module, name, self._wrap(self.original[name], phase))
        _set(module, "_slotted_direct", self._inside(self.original["_slotted_direct"]))

    def restore(self) -> None:
        for name, fn in self.original.items():
            _set(self.module, name, fn)

    def _inside(self, fn):
        def marked(*args, **kwargs):
            self.direct += 1
            try:
                return fn(*args, **kwargs)
            finally:
                self.direct -= 1
        return marked

    def _wrap(self, fn, phase):
        def timed(*args, **kwargs):
            self.stack.append(0.0)                 # seconds of the phases this one calls
            name = phase if isinstance(phase, str) else phase[self.direct > 0]
            start = time.process_time()
            try:
                return fn(*args, **kwargs)
            finally:
                spent = time.process_time() - start
                inner = self.stack.pop()
                self.seconds[name] += spent - inner
                if self.stack:
                    self.stack[-1] += spent
        return timed


def parts_of(out: Path, design: Path):
    """The fin system's parts and thickness of a design run folder (support from its cache)."""
    from torsal.pipeline.design_file import load_design_file
    from torsal.pipeline.fins import fin_system

    found = sorted(glob.glob(str(out / ".torsal-cache" / "support-*.pkl")))
    if not found:
        sys.exit(f"no support stage in {out}/.torsal-cache: run `torsal design {design} --out {out}`")
    with open(found[-1], "rb") as fh:
        structure = pickle.load(fh)["structure"]
    fs = fin_system(load_design_file(design), structure)
    return list(fs.parts), fs.thickness


def build(plates, parts, thickness, route: str, mesh: bool):
    """``(results, seconds per phase, total seconds, parts cut directly)`` of one route:
    ``before`` (the boolean route, plates without their stored plane curves: the code before
    issue 40's change) or ``after``; ``mesh``: each solid meshed as the workers mesh it for
    the 3DM."""
    direct, solid = plates._slotted_direct, plates._polyhedron_solid
    used = [0]

    def counted(*args, **kwargs):
        shape = direct(*args, **kwargs)
        used[0] += shape is not None
        return shape

    def bare(*args, **kwargs):
        return solid(*args, **{**kwargs, "pcurves": False})
    if route == "before":
        _set(plates, "_slotted_direct", lambda *a, **k: None)
        _set(plates, "_polyhedron_solid", bare)
    else:
        _set(plates, "_slotted_direct", counted)
    timers = Timers(plates, PHASES)
    meshing = 0.0
    try:
        start = time.process_time()
        results = []
        for p in parts:
            results.append(plates._build_one(p, thickness, True))
            if mesh and results[-1][1] is not None:
                t = time.process_time()
                plates._mesh(results[-1][1], plates.MESH_TOLERANCE * thickness, threads=False)
                meshing += time.process_time() - t
        total = time.process_time() - start
    finally:
        timers.restore()
        _set(plates, "_slotted_direct", direct)
        _set(plates, "_polyhedron_solid", solid)
    seconds = dict(timers.seconds)
    seconds["mesh (3DM)"] = meshing
    seconds["other"] = total - sum(seconds.values())
    return results, seconds, total, used[0]


def topology(shape) -> tuple:
    """Numbers of faces, edges and vertices of an OCC shape."""
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_VERTEX
    from OCP.TopExp import TopExp_Explorer

    out = []
    for kind in (TopAbs_FACE, TopAbs_EDGE, TopAbs_VERTEX):
        seen, exp = set(), TopExp_Explorer(shape, kind)
        while exp.More():
            seen.add(hash(exp.Current()))          # hashed without orientation
            exp.Next()
        out.append(len(seen))
    return tuple(out)


def compare(parts, before, after, plates) -> list[str]:
    """What differs between two routes' results, part by part."""
    bad = []
    for p, (s0, a, _), (s1, b, _) in zip(parts, before, after):
        if s0 != s1 or (a is None) != (b is None):
            bad.append(f"{p.name}: status {s0} / {s1}")
            continue
        if a is None:
            continue
        va, vb = plates._volume(a), plates._volume(b)
        if not abs(va - vb) <= 1e-6 * abs(va):
            bad.append(f"{p.name}: volume {va:.9g} / {vb:.9g}")
        if topology(a) != topology(b):
            bad.append(f"{p.name}: faces, edges, vertices {topology(a)} / {topology(b)}")
        if not plates._is_valid(b):
            bad.append(f"{p.name}: not valid")
    return bad


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path, help="folder of a torsal design run (its stage cache)")
    ap.add_argument("--design", type=Path, default=Path("examples/7a_facade_block.toml"))
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-mesh", action="store_true", help="leave out the 3DM's meshing")
    args = ap.parse_args(argv)
    from torsal.fabrication import plates

    parts, thickness = parts_of(args.out, args.design)
    slotted = [p for p in parts if p.slots]
    routes = ("before", "after")
    best: dict = {r: {} for r in routes}
    totals: dict = {r: [] for r in routes}
    results, direct_count = {}, 0
    for _ in range(args.repeat):
        for route in routes:
            res, seconds, total, used = build(plates, parts, thickness, route, not args.no_mesh)
            results[route] = res
            direct_count = used if route == "after" else direct_count
            totals[route].append(total)
            for phase, s in seconds.items():
                best[route][phase] = min(best[route].get(phase, s), s)
    bad = compare(parts, results["before"], results["after"], plates)
    load = " / ".join(f"{x:.1f}" for x in os.getloadavg()[:2])
    print(f"{args.design.stem}: {len(parts)} parts, {len(slotted)} slotted "
          f"({sum(len(p.slots) for p in slotted)} slots), {direct_count} cut without a boolean; "
          f"{thickness} thick; load {load}")
    print()
    print("| phase | before CPU s | after CPU s |")
    print("|---|---|---|")
    for phase in ORDER:
        a, b = best["before"].get(phase, 0.0), best["after"].get(phase, 0.0)
        if a or b:
            print(f"| {phase} | {a:.2f} | {b:.2f} |")
    print(f"| all (least of {args.repeat} turns) | {min(totals['before']):.2f} | "
          f"{min(totals['after']):.2f} |")
    print()
    print(f"same solids: {'yes' if not bad else 'NO'} ({len(parts)} parts: status, volume to "
          f"1e-6, faces/edges/vertices, BRepCheck)")
    for line in bad[:20]:
        print("  " + line)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
