"""A study's ``[search]``: optuna proposes designs over the axes (lists: choices, ranges:
intervals), variants run as tasks like a grid's, and the named report figures are the
objectives (maximized or minimized). Trials already finished in the output folder are told
to optuna again on a resumed run, so it continues instead of starting over."""
from __future__ import annotations

import json
from pathlib import Path


from .._io import write_json
from .stage import stage_keys
from .stages import DEFAULT_PIPELINE
from .study_tasks import SHARED_STAGE, StudyProgress, flatten, material_kg, run_variant
from .study_file import AxisRange, Variant, design_with

__all__ = ["run_search", "objective_values"]


def _distributions(axes: dict) -> dict:
    import optuna

    out = {}
    for key, values in axes.items():
        if isinstance(values, AxisRange):
            if isinstance(values.low, int) and isinstance(values.high, int):
                out[key] = optuna.distributions.IntDistribution(
                    values.low, values.high, log=values.log, step=int(values.step or 1))
            else:
                out[key] = optuna.distributions.FloatDistribution(
                    values.low, values.high, log=values.log, step=values.step)
        else:   # choices by index: TOML values may be lists, which optuna cannot hold
            out[key] = optuna.distributions.CategoricalDistribution(list(range(len(values))))
    return out


def _axis_values(axes: dict, params: dict) -> dict:
    return {k: (params[k] if isinstance(v, AxisRange) else v[params[k]]) for k, v in axes.items()}


def objective_values(report: dict, spec, objectives: dict) -> list[float]:
    """The objectives' values of a finished variant, from its report (flattened keys) and
    the study's own figures (``material_kg``)."""
    flat = flatten(report)
    flat["material_kg"] = material_kg(report["light"]["fin_area_m2"], spec)
    out = []
    for key in objectives:
        x = flat.get(key)
        if x is None:
            raise KeyError(f"the report has no figure {key!r}")
        out.append(float(x))
    return out


def run_search(study, ex, out: Path, cache_dir: str, tell, retry_failed: bool):
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)     # library calls stay quiet
    s = study.spec.search
    axes = study.spec.axes
    dists = _distributions(axes)
    directions = ["maximize" if d == "max" else "minimize" for d in s.objectives.values()]
    sampler = (optuna.samplers.NSGAIISampler(seed=s.seed) if s.sampler == "nsga2"
               else optuna.samplers.TPESampler(seed=s.seed))
    opt = optuna.create_study(directions=directions, sampler=sampler)
    study.variants = []          # the trials of this run, in order (a Study may run again)
    counts = StudyProgress(total=s.trials)
    outcomes: dict[str, dict] = {}
    base_dir = study.base_dir

    def variant(i: int, params: dict) -> Variant:
        values = _axis_values(axes, params)
        spec, text = design_with(study.base, base_dir, values)
        return Variant(f"t{i:03d}", values, spec, text)

    def finish(v: Variant, params: dict, o: dict, trial=None):
        outcomes[v.id] = o
        study.variants.append(v)
        state, values = optuna.trial.TrialState.FAIL, None
        if o["status"] == "done":
            report = json.loads((out / "variants" / v.id / "report.json").read_text())
            try:
                values = objective_values(report, v.spec, s.objectives)
                state = optuna.trial.TrialState.COMPLETE
            except (KeyError, TypeError, ValueError):
                pass
        if trial is None:
            opt.add_trial(optuna.trial.create_trial(params=params, distributions=dists,
                                                    values=values, state=state))
        else:
            opt.tell(trial, values, state=state)

    # trials finished in an earlier run, in order
    i = 0
    while i < s.trials:
        rec_path = out / "variants" / f"t{i:03d}" / "variant.json"
        try:
            rec = json.loads(rec_path.read_text())
            params = rec["params"]
            v = variant(i, params)
        except (OSError, ValueError, KeyError):
            break
        if study._finished(out, v, retry_failed) is None:
            break
        finish(v, params, rec | {"resumed": True})
        counts.resumed += 1
        counts.done += rec["status"] == "done"
        counts.failed += rec["status"] == "failed"
        i += 1
    tell(counts)
    # one batch of trials per round, as many as the cluster runs at once
    workers = max(1, len(ex.client.scheduler_info()["workers"])) if hasattr(ex, "client") else 1
    while i < s.trials:
        batch, leaders = {}, {}
        for _ in range(min(workers, s.trials - i)):
            trial = opt.ask(dists)
            v = variant(i, trial.params)
            # a trial whose congruence another trial of the batch solves waits for it
            k = stage_keys(DEFAULT_PIPELINE, v.spec)[SHARED_STAGE]
            h = ex.submit(_run_trial, v, str(out), cache_dir, trial.params,
                          getattr(ex, "queue_name", None), leaders.get(k))
            leaders.setdefault(k, h)
            batch[h] = (v, trial)
            i += 1
        pending = dict(batch)

        def started():
            counts.running = len(ex.running)
            tell(counts)

        while pending:
            for h in ex.wait(list(pending), started):
                v, trial = pending.pop(h)
                o = ex.outcome(h, v)
                finish(v, trial.params, o, trial)
                ex.running.discard(v.id)
                counts.done += o["status"] == "done"
                counts.failed += o["status"] == "failed"
                counts.running = len(ex.running)
                counts.event = f"{v.id} {o['status']}"
                tell(counts)
    return outcomes, counts


def _run_trial(v: Variant, out_dir: str, cache_dir: str, params: dict, queue,
               leader: dict | None = None) -> dict:
    """A grid variant's task, with the trial's optuna parameters kept in variant.json."""
    o = run_variant(v, out_dir, cache_dir, leader, queue)
    o["params"] = params
    write_json(Path(out_dir) / "variants" / v.id / "variant.json", o)
    return o
