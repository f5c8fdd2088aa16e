"""Size and build time of report.html's interactive 3D view, from test size to large designs.

    python benchmarks/report_3d_bench.py [--full] [--synthetic 2000 20000 45000]

Rows "7a test size" and (with --full) "7a full size" run example 7a through the pipeline
(no STEP/3dm/DXF: the view does not use them) and measure the report.html it writes; the
synthetic rows are flat quad grids with that many fins (and about as many surface
triangles) and 3000 sun directions. plotly.js (inlined once per page) is a fixed cost; the
"3D data" column is what the design adds (float32 binary arrays, base64).
"""
import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import torsal.pipeline.report  # noqa: E402
from torsal.design import Design  # noqa: E402
from torsal.geometry.support import SupportStructure  # noqa: E402
from torsal.pipeline.stages import sun_directions  # noqa: E402
from torsal.pipeline.report_3d import design_view_html  # noqa: E402


def plotlyjs_bytes() -> int:
    from plotly.offline import get_plotlyjs

    return len(get_plotlyjs().encode())


def grid(fins: int):
    """A flat m x m grid with about ``fins`` fins of depth 0.3 standing up."""
    m = max(2, int(round((1 + np.sqrt(1 + 2 * fins)) / 2)))
    x, y = np.meshgrid(np.arange(m, dtype=float), np.arange(m, dtype=float), indexing="ij")
    a = np.c_[x.ravel(), y.ravel(), np.zeros(m * m)]
    idx = np.arange(m * m).reshape(m, m)
    e = np.r_[np.c_[idx[:-1].ravel(), idx[1:].ravel()], np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()]]
    fam = np.r_[np.zeros((m - 1) * m), np.ones(m * (m - 1))]
    q = idx[:-1, :-1].ravel()
    tris = np.r_[np.c_[q, q + m, q + m + 1], np.c_[q, q + m + 1, q + 1]]
    return (a, tris), SupportStructure(a, a + [0, 0, 0.3], [], e, fam)


def row(name, surface, structure, sun, page_bytes=None):
    t0 = time.perf_counter()
    frag = design_view_html(surface, structure, sun, include_plotlyjs=False)
    dt = time.perf_counter() - t0
    page = f"{page_bytes / 1e6:.2f} MB" if page_bytes else f"~{(len(frag) + plotlyjs_bytes()) / 1e6:.2f} MB"
    print(f"| {name:<22} | {len(structure.edges):>6} | {len(surface[1]):>7} | {len(sun[0]):>5} | "
          f"{len(frag) / 1e3:>8.0f} kB | {page:>10} | {dt:>6.2f} s |")


def run_design(name: str, full: bool) -> None:
    from test_examples import EXAMPLES, small

    d = Design.from_toml(next(p for p in EXAMPLES if p.name.startswith("7a")))
    d = d if full else small(d)
    d = Design(d.spec.model_copy(update={"outputs": d.spec.outputs.model_copy(
        update={"step": False, "rhino_3dm": False, "dxf": False})}))
    seen = {}
    write = torsal.pipeline.report.write_design_report

    def capture(out, spec, report, congruence, structure, light_map, surface, layout, **kw):
        kw.setdefault("sun", sun_directions(spec))  # the pipeline does not pass it yet
        seen.update(surface=surface, structure=structure, sun=kw["sun"])
        return write(out, spec, report, congruence, structure, light_map, surface, layout, **kw)

    torsal.pipeline.report.write_design_report = capture
    try:
        with tempfile.TemporaryDirectory() as tmp:
            d.run(tmp)
            size = (Path(tmp) / "report.html").stat().st_size
    finally:
        torsal.pipeline.report.write_design_report = write
    row(name, seen["surface"], seen["structure"], seen["sun"], size)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--full", action="store_true", help="also run 7a at full size")
    ap.add_argument("--synthetic", type=int, nargs="*", default=[2000, 20000, 45000])
    args = ap.parse_args()
    print(f"plotly.js inlined: {plotlyjs_bytes() / 1e6:.2f} MB per page\n")
    print("| design                 |   fins | surface |   sun |  3D data    | report.html |  build  |")
    print("|------------------------|-------:|--------:|------:|------------:|-----------:|--------:|")
    run_design("7a test size", full=False)
    if args.full:
        run_design("7a full size", full=True)
    rng = np.random.default_rng(0)
    sun = (rng.normal(size=(3000, 3)) * [1, 1, 0.3] + [0, -1, 1], np.ones(3000))
    for n in args.synthetic:
        surface, structure = grid(n)
        row(f"grid, {n} fins", surface, structure, sun)


if __name__ == "__main__":
    main()
