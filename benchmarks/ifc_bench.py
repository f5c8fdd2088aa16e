"""IFC export benchmark (issue 43): seconds and size of fins.ifc for a design file.

The design's stages up to the support structure run once (cached in ``--out``/cache: a second
run of this script reads them); then the design's fin system is built, its solids (as the
fabrication stage builds them for fins.step, not counted), and ``fins.ifc`` is written
``--repeat`` times. Printed: parts, fasteners, strips, how many elements are extruded
profiles and how many triangulated, the seconds of the export (wall and CPU: the first, which
also triangulates the solids, the best and the median of the repeats), the file's size and
the seconds of ifcopenshell's schema validation with its issues (``--validate``).

Run::

    nice -n 10 .venv/bin/python benchmarks/ifc_bench.py examples/7a_facade_block.toml \
        --out /tmp/ifc_bench --validate

Measured 2026-11-28 18:23 UTC (commit f6bb7d6, ifcopenshell 0.9.0.post1, the shared 2-core
machine at load 2.4; ``nice -n 10``), example 7a at full size: 509 parts (all folded or
bent: none is a flat plate), 1,039 fasteners, 42 strips; the first export 4.7 s wall, 3.2 s
CPU (the first also triangulates the solids), the next ones 1.8 s; fins.ifc 2.1 MB; the
validation (express rules too) 8.3 s, 0 issues::

    | design | parts | fasteners | strips | extruded | triangulated | export s first | export CPU s first | export s best | export s median | export CPU s best | MB |
    |---|---|---|---|---|---|---|---|---|---|---|---|
    | 7a_facade_block | 509 | 1039 | 42 | 0 | 509 | 4.73 | 3.22 | 1.78 | 2.40 | 1.78 | 2.08 |
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_common import design_structure  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("design", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--validate", action="store_true")
    args = ap.parse_args()

    import ifcopenshell
    import ifcopenshell.validate

    from torsal.fabrication.ifc import fastener_placements
    from torsal.fabrication.workers import solid_shapes
    from torsal.pipeline import fins

    t0 = time.perf_counter()
    spec, structure = design_structure(args.design, args.out)
    upstream = time.perf_counter() - t0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fs = fins.fin_system(spec, structure)
    t0 = time.perf_counter()
    solid_shapes(fs)
    solids = time.perf_counter() - t0
    site = spec.site
    options = dict(material=spec.material.name, density=spec.material.density)
    if site is not None:
        options.update(latitude=site.latitude, longitude=site.longitude, elevation=site.elevation,
                       north_angle=site.north_angle)
    walls, cpus = [], []
    path = args.out / "fins.ifc"
    for _ in range(args.repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        fs.export_ifc(path, **options)
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    f = ifcopenshell.open(str(path))
    bodies = [e.Representation.Representations[0].Items[0].is_a() for e in f.by_type("IfcPlate")]
    row = {"design": args.design.stem, "parts": len(fs.parts),
           "fasteners": len(fastener_placements(fs)), "strips": len(f.by_type("IfcElementAssembly")),
           "extruded": bodies.count("IfcExtrudedAreaSolid"),
           "triangulated": bodies.count("IfcTriangulatedFaceSet"),
           "export s first": walls[0], "export CPU s first": cpus[0],
           "export s best": min(walls), "export s median": statistics.median(walls),
           "export CPU s best": min(cpus), "MB": os.path.getsize(path) / 1e6,
           "upstream s": upstream, "solids s": solids, "load": os.getloadavg()[0]}
    if args.validate:
        t0 = time.perf_counter()
        log = ifcopenshell.validate.json_logger()
        ifcopenshell.validate.validate(f, log, express_rules=True)
        row["validate s"] = time.perf_counter() - t0
        row["issues"] = len(log.statements)
    print("| " + " | ".join(row) + " |")
    print("|" + "---|" * len(row))
    print("| " + " | ".join(f"{v:.2f}" if isinstance(v, float) else str(v) for v in row.values()) + " |")


if __name__ == "__main__":
    main()
