"""Dump an example's fin system (pickled) and its final-cut options, so that the final cut's
nester can be studied on the real outlines in seconds, without running the design again.

    nice -n 19 .venv/bin/python benchmarks/final_cut_dump.py 7a 13 --out /tmp/fc

Writes OUT/<key>.pkl: what :func:`~torsal.fabrication.nesting.split.nest_split` takes for the
final cut (``{"outlines": [Unrolled], "cuts", "fixings", "options", "pays_args", "unit"}``,
:func:`~torsal.fabrication.nesting.final_cut.final_cut`'s split search);
``benchmarks/final_cut_replay.py`` reads it back. And OUT/<key>.fs.pkl, the fin system itself
(its cached OpenCascade solids left out: they are built again where needed), for the whole
final cut with its rebuild and verdict (``benchmarks/final_cut_run.py``).
"""
import argparse
import pickle
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "examples"))


def dump(key: str, out: Path) -> Path:
    from torsal.design import Design
    from torsal.fabrication.nesting.cut_costs import per_fixing, yield_cut_sites
    from torsal.pipeline.fins import last_fin_system
    from torsal.pipeline.stages import nest_options

    path = next((HERE.parent / "examples").glob(f"{key}_*.toml"))
    d = Design.from_toml(path)
    d.run(out / key, use_cache=False, accept_unbuildable=True)
    fs = last_fin_system()
    spec = d.spec
    options = nest_options(spec, fs.unit)
    rates = None if spec.costs is None else spec.costs.rates()
    kw = {k: options[k] for k in ("sheet", "gap", "margin", "cutting", "rotation_step", "tries")
          if k in options}
    kw["sheet"] = tuple(kw["sheet"])
    cuts, fixings = yield_cut_sites(fs, rates)
    cutting = kw.get("cutting")
    data = {"outlines": list(fs.unrolled().values()), "cuts": cuts, "fixings": fixings,
            "options": kw, "unit": fs.unit,
            "pays_args": dict(rates=rates, sheet=kw["sheet"], thickness=fs.thickness,
                              density=spec.material.density, unit=fs.unit,
                              process=None if cutting is None else cutting.process,
                              per_fixing=per_fixing(fs, rates, spec.material.density, cutting))}
    dest = out / f"{key}.pkl"
    with open(dest, "wb") as f:
        pickle.dump(data, f, protocol=pickle.HIGHEST_PROTOCOL)
    dump_fin_system(fs, out / f"{key}.fs.pkl")
    return dest


def dump_fin_system(fs, dest: Path) -> None:
    """Pickle the fin system ``fs`` to ``dest`` without what does not pickle (the cached
    OpenCascade solids, the build's memo): the final cut builds what it needs again."""
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 100000))
    state = dict(fs.__dict__)
    state.pop("_memo", None)
    for k, v in list(state.items()):
        try:
            pickle.dumps(v, protocol=pickle.HIGHEST_PROTOCOL)
        except (TypeError, pickle.PicklingError):
            state[k] = None
    copy = type(fs).__new__(type(fs))
    copy.__dict__.update(state)
    with open(dest, "wb") as f:
        pickle.dump(copy, f, protocol=pickle.HIGHEST_PROTOCOL)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("keys", nargs="+")
    ap.add_argument("--out", type=Path, default=Path("/tmp/final_cut_dump"))
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    for key in a.keys:
        c0 = time.process_time()
        dest = dump(key, a.out)
        print(f"{key}: {dest} ({time.process_time() - c0:.0f} s CPU)", flush=True)


if __name__ == "__main__":
    main()
