"""A study's ``[search]``: optuna proposes designs over the axes (lists: choices, ranges:
intervals), variants run as tasks like a grid's, and the named report figures are the
objectives (maximized or minimized). Trials already finished in the output folder are told
to optuna again on a resumed run, so it continues instead of starting over."""
from __future__ import annotations

import json
from pathlib import Path


from ..core.atomic import write_json
from ..pipeline.stage import stage_keys
from ..pipeline.stages import DEFAULT_PIPELINE
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


class _Search:
    """One run of a study's [search]: optuna asks, variants run as tasks, optuna is told."""

    def __init__(self, study, out: Path):
        import optuna

        optuna.logging.set_verbosity(optuna.logging.WARNING)     # library calls stay quiet
        self.optuna, self.study, self.out = optuna, study, out
        self.search = s = study.spec.search
        self.dists = _distributions(study.spec.axes)
        directions = ["maximize" if d == "max" else "minimize" for d in s.objectives.values()]
        sampler = (optuna.samplers.NSGAIISampler(seed=s.seed) if s.sampler == "nsga2"
                   else optuna.samplers.TPESampler(seed=s.seed))
        self.opt = optuna.create_study(directions=directions, sampler=sampler)
        self.trials: dict[str, object] = {}          # variant id -> optuna trial being run

    def variant(self, i: int, params: dict) -> Variant:
        values = _axis_values(self.study.spec.axes, params)
        spec, text = design_with(self.study.base, self.study.base_dir, values)
        return Variant(f"t{i:03d}", values, spec, text)

    def tell(self, v: Variant, o: dict, params: dict | None = None) -> None:
        """Tell optuna a trial's result (a resumed one as a new finished trial)."""
        self.study.variants.append(v)
        T = self.optuna.trial
        state, values = T.TrialState.FAIL, None
        if o["status"] == "done":
            report = json.loads((self.out / "variants" / v.id / "report.json").read_text())
            try:
                values = objective_values(report, v.spec, self.search.objectives)
                state = T.TrialState.COMPLETE
            except (KeyError, TypeError, ValueError):
                pass
        trial = self.trials.pop(v.id, None)
        if trial is None:
            self.opt.add_trial(T.create_trial(params=params, distributions=self.dists,
                                              values=values, state=state))
        else:
            self.opt.tell(trial, values, state=state)

    def resume(self, outcomes: dict, counts: StudyProgress, retry_failed: bool) -> int:
        """Tell optuna the trials finished in an earlier run, in order; returns how many."""
        i = 0
        while i < self.search.trials:
            try:
                rec = json.loads((self.out / "variants" / f"t{i:03d}" / "variant.json").read_text())
                v = self.variant(i, rec["params"])
            except (OSError, ValueError, KeyError):
                break
            if self.study._finished(self.out, v, retry_failed) is None:
                break
            outcomes[v.id] = rec | {"resumed": True}
            self.tell(v, rec, rec["params"])
            counts.resumed += 1
            counts.done += rec["status"] == "done"
            counts.failed += rec["status"] == "failed"
            i += 1
        return i

    def submit(self, ex, i: int, n: int, cache_dir: str) -> dict:
        """Ask optuna for ``n`` trials and submit them; a trial whose congruence another
        of the batch solves waits for it, like a grid's variants."""
        jobs, leaders = {}, {}
        for k in range(i, i + n):
            trial = self.opt.ask(self.dists)
            v = self.variant(k, trial.params)
            self.trials[v.id] = trial
            key = stage_keys(DEFAULT_PIPELINE, v.spec)[SHARED_STAGE]
            h = ex.submit(_run_trial, v, str(self.out), cache_dir, trial.params,
                          getattr(ex, "queue_name", None), leaders.get(key),
                          *self.study.variant_run)
            leaders.setdefault(key, h)
            jobs[h] = v
        return jobs


def run_search(study, ex, out: Path, cache_dir: str, tell, retry_failed: bool):
    """Run a study's [search] on executor ``ex``; returns the outcomes and the counts."""
    search = _Search(study, out)
    study.variants = []          # the trials of this run, in order (a Study may run again)
    counts = StudyProgress(total=search.search.trials)
    outcomes: dict[str, dict] = {}
    i = search.resume(outcomes, counts, retry_failed)
    tell(counts)
    # one batch of trials per round, as many as the cluster runs at once
    workers = max(1, len(ex.client.scheduler_info()["workers"])) if hasattr(ex, "client") else 1
    while i < search.search.trials:
        n = min(workers, search.search.trials - i)
        jobs = search.submit(ex, i, n, cache_dir)
        study._collect(ex, jobs, outcomes, counts, tell, on_outcome=search.tell)
        i += n
    return outcomes, counts


def _run_trial(v: Variant, out_dir: str, cache_dir: str, params: dict, queue,
               leader: dict | None = None, fabrication: bool = True, assembly: bool = True,
               files=()) -> dict:
    """A grid variant's task, with the trial's optuna parameters kept in variant.json."""
    o = run_variant(v, out_dir, cache_dir, leader, queue, fabrication, assembly, files)
    o["params"] = params
    write_json(Path(out_dir) / "variants" / v.id / "variant.json", o)
    return o
