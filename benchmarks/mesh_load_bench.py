"""Mesh loading time: torsal's readers (file vertices kept, headers checked, merge, validation)
against trimesh's loaders (no checks), per format, on a 450 x 450 grid (202,500 vertices,
403,202 faces). Prints a table; run with `.venv/bin/python benchmarks/mesh_load_bench.py`.
"""
import os
import sys
import tempfile
import time
from pathlib import Path

import trimesh

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import mesh_cases as mc  # noqa: E402
from torsal.geometry.mesh import load_mesh  # noqa: E402


def best_of(fn, n=3) -> float:
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(n: int = 450) -> None:
    v, f = mc.grid(n, n)
    tmp = Path(tempfile.mkdtemp())
    files = {"obj": mc.obj_text(v, f).encode(), "ply (binary)": mc.ply_binary(v, f),
             "ply (ascii)": mc.ply_ascii(v, f).encode(), "off": mc.off_text(v, f).encode(),
             "stl (binary, split)": mc.stl_binary(v, f)}
    print(f"grid {n} x {n}: {len(v)} vertices, {len(f)} faces; load {os.getloadavg()[0]:.1f}")
    print(f"{'format':22s} {'MB':>6s} {'torsal s':>9s} {'trimesh s':>10s} {'vertices':>9s}")
    for name, data in files.items():
        ext = name.split()[0]
        path = tmp / f"m_{len(data)}.{ext}"
        path.write_bytes(data)
        m = load_mesh(path)
        t_torsal = best_of(lambda: load_mesh(path))
        t_trimesh = best_of(lambda: trimesh.load(path, process=False, force="mesh"))
        print(f"{name:22s} {len(data) / 1e6:6.1f} {t_torsal:9.2f} {t_trimesh:10.2f} "
              f"{len(m.vertices):9d}")


if __name__ == "__main__":
    main()
