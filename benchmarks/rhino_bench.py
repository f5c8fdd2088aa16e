"""Rhino 3DM export benchmark (issue 40): CPU seconds of fins.3dm for a design file, the way
it was made before this round and now, phase by phase, and the files compared.

The design's stages up to the support structure run once (cached in ``--out``/cache: a second
run of this script reads them); then the design's fin system and its solids are built in this
process, each meshed as the solids' worker processes mesh them (not counted). Phases, CPU
seconds (``time.process_time``, best of ``--repeat``):

- ``worker: re-read solids`` (before only): the solids read again from the OpenCascade binary
  BReps the workers had sent (the workers made the Breps in a second pass, from those bytes);
- ``worker: Breps``: before, rhino3dm's ``Brep.CreateFromMesh`` of each solid's welded mesh,
  its edges' tolerance set by patching its encoding and decoding it again, and the encoding
  sent to the main process; now the record of :func:`torsal.fabrication.rhino.brep_record`
  (a face per plane face, built with numpy, no rhino3dm) made from the solid in hand, in the
  pass that builds it;
- ``main: file``: before, each encoding decoded, checked (``IsSolid``, ``IsValid``), added and
  the file written by rhino3dm; now :func:`~torsal.fabrication.exports.export_3dm` with the
  workers' records (rhino3dm writes the file with a placeholder per part, the records are put
  in their places).

Then the two files are read back with rhino3dm (``--check``): objects, names, layers, ids,
every Brep ``IsSolid`` and ``IsValid``, vertices, and each Brep's volume against the
OpenCascade solid's (planar faces: the divergence theorem over the faces' loops).

``--stage`` also runs the fabrication stage's way (worker processes prepared with
``mesh=True``, the solids started, STEP then 3DM written) and prints the CPU seconds of the
3DM in every process: the workers' records (``FinSystem.breps_cpu_seconds``, measured in the
workers) and ``export_3dm`` in this process.

Run::

    nice -n 10 .venv/bin/python benchmarks/rhino_bench.py examples/7a_facade_block.toml \\
        --out /tmp/rhino_bench --check

Measured 2026-11-29 04:13 UTC (commit d4ca522 + this change, rhino3dm 8.35.0, ``--repeat 2
--check --stage``), example 7a at full size, 314 parts, on the shared 2-core machine with other
sessions' designs running (load 6.6; at such loads CPU seconds vary from run to run: the
records took 0.69-1.13 s in this session's runs, and at load 11.4 the phases gave 8.60 ->
1.21 s)::

    | phase | parts | before CPU s | after CPU s |
    |---|---|---|---|
    | worker: re-read solids | 314 | 0.19 | - |
    | worker: Breps | 314 | 4.78 | 1.07 |
    | main: file | 314 | 2.65 | 0.08 |
    | total | 314 | 7.62 | 1.14 |

    fins.3dm 27.5 MB -> 14.9 MB; records made: 314 of 314
    check: 314 objects (before 314), names the same, all closed and valid: True, vertices
    the same: True, largest volume error 3.3e-12; Brep faces 13894 -> 6899
    stage (2 workers): 3DM records in the workers 1.25 s CPU, export_3dm here 0.06 s CPU,
    together 1.31 s

The records of every part of the eight examples at full size (4,259 parts) read back as
closed, valid Breps with their solids' volumes (within 3.2e-12).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_common import brep_volume, design_structure  # noqa: E402


def _best(fn, repeat: int):
    """(the result of ``fn()``, its best CPU seconds over ``repeat`` calls)."""
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t0)
    return out, best


def _old_encoding(shape, tol):
    """The worker's Brep before this round: CreateFromMesh, edge tolerances patched, encoded."""
    from torsal.fabrication.rhino import _mesh_brep

    brep = _mesh_brep(shape, tol)
    return brep.Encode() if brep is not None and brep.IsSolid and brep.IsValid else None


def _old_file(fs, encodings: dict, path: Path) -> None:
    """The main process's part before this round: decode, check, add, write (the objects
    named and given their ids; one layer: making the layers costs next to nothing)."""
    import rhino3dm

    from torsal.fabrication.exports import _rhino_id

    model = rhino3dm.File3dm()
    model.Settings.ModelUnitSystem = rhino3dm.UnitSystem.Millimeters
    layer = rhino3dm.Layer()
    layer.Name = "parts"
    index = model.Layers.Add(layer)
    for p in fs.parts:
        brep = rhino3dm.CommonObject.Decode(encodings[p.name])
        assert brep.IsSolid and brep.IsValid
        attr = rhino3dm.ObjectAttributes()
        attr.Name = p.name
        attr.Id = _rhino_id(f"part:{p.name}")
        attr.LayerIndex = index
        model.Objects.AddBrep(brep, attr)
    assert model.Write(str(path), 7)


def check(new: Path, old: Path, shapes: dict) -> str:
    """The two files read back: what agrees, and the largest volume error against the solids."""
    import rhino3dm

    from torsal.fabrication.solids import _volume

    def read(path):
        m = rhino3dm.File3dm.Read(str(path))
        layers = {i: m.Layers.FindIndex(i).FullPath for i in range(len(m.Layers))}
        return {o.Attributes.Name: (layers[o.Attributes.LayerIndex], o.Geometry) for o in m.Objects}

    a, b = read(new), read(old)
    ok = all(isinstance(g, rhino3dm.Brep) and g.IsSolid and g.IsValid for _, g in a.values())

    def verts(g):
        return sorted(tuple(np.round((v.Location.X, v.Location.Y, v.Location.Z), 7)) for v in g.Vertices)

    same_v = all(verts(a[n][1]) == verts(b[n][1]) for n in a)
    err = max(abs(brep_volume(g) / _volume(shapes[n]) - 1) for n, (_, g) in a.items())
    return (f"{len(a)} objects (before {len(b)}), names {'the same' if list(a) == list(b) else 'DIFFER'}, "
            f"all closed and valid: {ok}, vertices the same: {same_v}, "
            f"largest volume error {err:.1e}; Brep faces {sum(len(g.Faces) for _, g in b.values())} -> "
            f"{sum(len(g.Faces) for _, g in a.values())}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("design", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--check", action="store_true")
    ap.add_argument("--stage", action="store_true")
    args = ap.parse_args()

    from torsal.fabrication.plates import MESH_TOLERANCE, _build_one, _mesh
    from torsal.fabrication.rhino import brep_record
    from torsal.fabrication.workers import WorkerBreps, _from_bytes, _parts_key, _to_bytes
    from torsal.pipeline import fins

    spec, structure = design_structure(args.design, args.out)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fs = fins.fin_system(spec, structure)
    tol = MESH_TOLERANCE * fs.thickness
    shapes = {}
    for p in fs.parts:                     # as the workers build them (not counted)
        _, shape, _ = _build_one(p, fs.thickness, True)
        _mesh(shape, tol, threads=False)
        shapes[p.name] = shape
    fs._solid_shapes = (_parts_key(fs), shapes)
    data = {name: _to_bytes(s) for name, s in shapes.items()}
    n = len(shapes)
    # before
    reread, t_reread = _best(lambda: {k: _from_bytes(b) for k, b in data.items()}, args.repeat)
    old, t_old = _best(lambda: {k: _old_encoding(s, tol) for k, s in reread.items()}, args.repeat)
    _, t_old_file = _best(lambda: _old_file(fs, old, args.out / "before.3dm"), args.repeat)
    # after
    records, t_new = _best(lambda: {k: brep_record(s, tol, threads=False) for k, s in shapes.items()},
                           args.repeat)

    def export():
        fs._breps = WorkerBreps(_parts_key(fs), tol, records)
        return fs.export_3dm(args.out / "fins.3dm")

    _, t_new_file = _best(export, args.repeat)
    rows = [("worker: re-read solids", t_reread, None), ("worker: Breps", t_old, t_new),
            ("main: file", t_old_file, t_new_file),
            ("total", t_reread + t_old + t_old_file, t_new + t_new_file)]
    print("| phase | parts | before CPU s | after CPU s |")
    print("|---|---|---|---|")
    for name, before, after in rows:
        print(f"| {name} | {n} | {before:.2f} | {'-' if after is None else f'{after:.2f}'} |")
    mb = [os.path.getsize(args.out / f) / 1e6 for f in ("before.3dm", "fins.3dm")]
    print(f"\nfins.3dm {mb[0]:.1f} MB -> {mb[1]:.1f} MB; records made: "
          f"{sum(r is not None for r in records.values())} of {n}; load {os.getloadavg()[0]:.1f}")
    if args.check:
        print("check: " + check(args.out / "fins.3dm", args.out / "before.3dm", shapes))
    if args.stage:
        print(stage(spec, structure, args.out))


def stage(spec, structure, out: Path) -> str:
    """The 3DM's CPU seconds in the fabrication stage's processes (``--stage``)."""
    from torsal.fabrication.solids import prepare_workers, release_workers
    from torsal.pipeline import fins

    fins._LAST.set(None)            # a fresh fin system (not main()'s, whose solids are built)
    n = prepare_workers(len(structure.edges), mesh=True)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fs = fins.fin_system(spec, structure)
        fs.start_solids()
    finally:
        release_workers()
    fs.export_step(out / "stage.step")
    t0 = time.process_time()
    fs.export_3dm(out / "stage.3dm")
    main = time.process_time() - t0
    workers = getattr(fs, "breps_cpu_seconds", 0.0)
    return (f"stage ({n} workers): 3DM records in the workers {workers:.2f} s CPU, export_3dm here "
            f"{main:.2f} s CPU, together {workers + main:.2f} s (the solids' workers: "
            f"{fs.solids_cpu_seconds:.2f} s CPU in all)")


if __name__ == "__main__":
    main()
