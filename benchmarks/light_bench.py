"""Ray-casting throughput of torsal.light.shading.rays_blocked (Embree via embreex),
and the conventional baselines measured on the example facade.

Casts 1e6 rays (1000 points on a facade x 1000 sun directions) against egg-crate fin
meshes of 10k and 100k triangles and prints rays per second; for comparison the same rays
through trimesh's own ``mesh.ray.intersects_any`` (also Embree, one call). Then measures
the baseline shades (louvers, vertical fins, egg-crate, unoptimized normal-congruence fins;
depth 0.4 m, spacing 0.5 m) on ``facade_patch`` under the hot hours of a synthetic Vienna
weather file, with :func:`torsal.light.shading.compare`. Not part of the
test suite. Run: ``.venv/bin/python benchmarks/light_bench.py [--repeat 3]``.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import trimesh

from torsal.light import shading
from torsal.light.shading import rays_blocked


def egg_crate(n_triangles: int, *, width=12.0, height=6.0, depth=0.5) -> trimesh.Trimesh:
    """Horizontal and vertical fins in front of the x-z facade (outside -y), wavy in depth,
    with exactly ``n_triangles`` triangles (rounded down to a multiple of 4 * cells)."""
    rows = cols = 12
    per_fin = max(1, n_triangles // (2 * 2 * (rows + cols)))  # quads along each fin
    verts, tris, count = [], [], 0

    def strip(a, b):  # quad strip from polyline a (on the facade) to b (tips)
        nonlocal count
        m = len(a)
        verts.append(np.concatenate([a, b]))
        i = np.arange(m - 1) + count
        tris.append(np.concatenate([np.c_[i, i + 1, i + 1 + m], np.c_[i, i + 1 + m, i + m]]))
        count += 2 * m

    t = np.linspace(0.0, 1.0, per_fin + 1)
    for r in range(rows):
        z = (r + 0.5) * height / rows
        a = np.c_[(t - 0.5) * width, np.zeros_like(t), np.full_like(t, z)]
        b = a + np.c_[np.zeros_like(t), -depth * (1 + 0.3 * np.sin(6 * t)), np.zeros_like(t)]
        strip(a, b)
        strip(a + [0, 0, 0.01], b + [0, -0.02, 0.01])  # a second skin (fin thickness)
    for c in range(cols):
        x = (c + 0.5 - cols / 2) * width / cols
        a = np.c_[np.full_like(t, x), np.zeros_like(t), t * height]
        b = a + np.c_[np.zeros_like(t), -depth * (1 + 0.3 * np.cos(5 * t)), np.zeros_like(t)]
        strip(a, b)
        strip(a + [0.01, 0, 0], b + [0.01, -0.02, 0])
    return trimesh.Trimesh(np.concatenate(verts), np.concatenate(tris), process=False)


def rays(n_points=1000, n_dirs=1000, seed=0):
    rng = np.random.default_rng(seed)
    pts = np.c_[rng.uniform(-5.5, 5.5, n_points), np.full(n_points, 1e-4),
                rng.uniform(0.2, 5.8, n_points)]
    az = rng.uniform(-80, 80, n_dirs)   # degrees from due south
    el = rng.uniform(5, 75, n_dirs)
    a, e = np.radians(az), np.radians(el)
    dirs = np.c_[np.sin(a) * np.cos(e), -np.cos(a) * np.cos(e), np.sin(e)]
    return pts, dirs


def best(fn, repeat):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--points", type=int, default=1000)
    ap.add_argument("--dirs", type=int, default=1000)
    args = ap.parse_args(argv)
    pts, dirs = rays(args.points, args.dirs)
    n_rays = len(pts) * len(dirs)
    print(f"embreex available: {shading.HAS_EMBREE}; trimesh {trimesh.__version__}; "
          f"{n_rays:.0e} rays = {len(pts)} points x {len(dirs)} directions; best of {args.repeat}")
    print(f"{'triangles':>10} {'build s':>8} {'cast s':>8} {'rays/s':>12} {'blocked':>8} "
          f"{'trimesh s':>10} {'trimesh rays/s':>15} {'agree':>6}")
    for target in (10_000, 100_000):
        fins = egg_crate(target)
        t0 = time.perf_counter()
        shading._scene(fins)  # build (and cache) the BVH
        build = time.perf_counter() - t0
        cast, hit = best(lambda: rays_blocked(fins, pts, dirs), args.repeat)
        # the same rays through trimesh's public API (one intersects_any call)
        o = (pts[:, None, :] + 1e-6 * dirs[None]).reshape(-1, 3)
        d = np.broadcast_to(dirs[None], (len(pts), len(dirs), 3)).reshape(-1, 3)
        fins.ray.intersects_any(o[:10], d[:10])  # build trimesh's own scene first
        tm, hit_tm = best(lambda: fins.ray.intersects_any(o, d), 1)
        agree = float((hit.ravel() == hit_tm).mean())
        print(f"{len(fins.faces):>10d} {build:>8.3f} {cast:>8.3f} {n_rays / cast:>12.3e} "
              f"{hit.mean():>8.3f} {tm:>10.3f} {n_rays / tm:>15.3e} {agree:>6.4f}")
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        baseline_table(tmp)


def baseline_table(tmpdir):
    from pathlib import Path

    from torsal.geometry.surfaces import facade_patch
    from torsal.light.baselines import baselines
    from torsal.light.shading import compare
    from torsal.light.sun import hot_hours, write_synthetic_epw

    epw = write_synthetic_epw(Path(tmpdir) / "vienna.epw", 48.21, 16.37, tz_hours=1.0,
                              elevation=170.0)
    sun = hot_hours(epw, min_temperature=26.0, min_dni=300.0)
    v, f = facade_patch(nu=33, nv=17)
    sets = baselines(v, f, 0.4, 0.5, grid_shape=(33, 17))
    t0 = time.perf_counter()
    table = compare(sets, (v, f), sun, samples=2000)
    dt = time.perf_counter() - t0
    print(f"\nbaselines on facade_patch (33 x 17), depth 0.4 m, spacing 0.5 m, {len(sun)} hot hours "
          f"(>= 26 degC, DNI >= 300 W/m^2) of a synthetic Vienna year, DNI-weighted, 2000 samples")
    print(f"{'design':<34} {'blocked':>8} {'clear normal':>13} {'clear cone60':>13} "
          f"{'fin m^2':>8} {'tris':>6}")
    for name, row in table.items():
        print(f"{name:<34} {row['blocked']:>8.3f} {row['transparent_normal']:>13.3f} "
              f"{row['transparent_cone']:>13.3f} {row['fin_area']:>8.1f} {row['triangles']:>6d}")
    print(f"(measured in {dt:.2f} s)")


if __name__ == "__main__":
    main()
