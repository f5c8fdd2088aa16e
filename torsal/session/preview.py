"""The preview of a live session: the pipeline's own stages up to the light, without the
fabrication (solids, sheets) and the assembly check.

:func:`preview_pipeline` takes the design run's pipeline and keeps the stages a designer looks
at (:data:`~torsal.session.answer.PREVIEW_STAGES`), with three changes: the congruence stage
re-solves the session's kept problem from its last optimum (:class:`~.warm.WarmProblem`);
the devices stage takes the standard devices from the stage cache, or while a change of
spacing or depth waits for the build, the last good design's (:class:`PreviewDevices`); and
the light measures every fin (no fabrication has left panels out yet). The stages keep their
names and cache keys, so the build finds the preview's congruence, remesh and support in the
cache.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Callable

from ..pipeline.cache import MISSING, StageCache
from ..pipeline.measure import run_devices
from ..pipeline.stage import Pipeline, Stage, StageInputs, stage_keys
from ..pipeline.stages import run_congruence
from .answer import PREVIEW_STAGES
from .warm import WarmProblem

__all__ = ["PreviewDevices", "preview_pipeline", "preview_light"]


@dataclass
class PreviewDevices:
    """The preview's devices stage: the standard devices of the design's depth and spacing
    from the stage cache; when they are not there (a new spacing or depth), the last good
    design's (``previous()``), marked ``current = False``, so the preview does not wait
    seconds for devices it only compares with; measured (and cached) when there are none.

    Examples
    --------
    >>> d = PreviewDevices(cache, DEFAULT_PIPELINE, previous=lambda: None)  # doctest: +SKIP
    >>> d(inputs)["current"]                                                # doctest: +SKIP
    True
    """

    cache: StageCache
    pipeline: Pipeline
    previous: Callable[[], dict | None]

    def __call__(self, inp: StageInputs) -> dict:
        key = stage_keys(self.pipeline, inp.spec)["devices"]
        value = self.cache.load("devices", key)
        if value is MISSING:
            earlier = self.previous()
            if earlier is not None:
                return {**earlier, "current": False}
            value = run_devices(inp)
            self.cache.store("devices", key, value)
        return {**value, "current": True}


def preview_light(report: dict, devices_current: bool) -> dict:
    """The preview's light section: without the comparison with the standard devices when
    those are the last design's (``devices_current`` False).

    >>> preview_light({"blocked_share": 0.8, "devices": {}, "baseline_louvers": {}}, False)
    {'blocked_share': 0.8}
    """
    if devices_current:
        return report
    return {k: v for k, v in report.items() if k not in ("devices", "baseline_louvers")}


def preview_pipeline(pipeline: Pipeline, warm: WarmProblem, devices: PreviewDevices) -> Pipeline:
    """The preview stages of ``pipeline`` (see the module notes).

    Parameters
    ----------
    pipeline : Pipeline
        The design run's (:data:`~torsal.pipeline.DEFAULT_PIPELINE`).
    warm : WarmProblem
        The session's kept congruence problem.
    devices : PreviewDevices

    Returns
    -------
    Pipeline

    Examples
    --------
    >>> from torsal.pipeline import DEFAULT_PIPELINE, StageCache
    >>> cache = StageCache("/tmp/x")
    >>> p = preview_pipeline(DEFAULT_PIPELINE, WarmProblem(),
    ...                      PreviewDevices(cache, DEFAULT_PIPELINE, lambda: None))
    >>> p.names[-3:]
    ('substructure', 'devices', 'light')
    """
    stages = []
    for s in pipeline:
        if s.name not in PREVIEW_STAGES:
            continue
        if s.name == "congruence":
            s = Stage(s.name, partial(run_congruence, make_problem=warm.make), inputs=s.inputs,
                      key=s.key, applies=s.applies, cache=s.cache, section=s.section)
        elif s.name == "devices":
            s = Stage(s.name, devices, inputs=s.inputs, key=s.key, applies=s.applies, cache=False,
                      section=s.section)
        elif s.name == "light":
            # every fin: the fins as built come with the fabrication, in the build
            s = Stage(s.name, s.run, inputs=tuple(i for i in s.inputs if i in PREVIEW_STAGES),
                      key=s.key, applies=s.applies, cache=False, section=s.section)
        stages.append(s)
    return Pipeline(tuple(stages))
