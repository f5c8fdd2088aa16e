"""The preview of a live session: the pipeline's own stages up to the light, without the
fabrication (solids, sheets) and the assembly check.

:func:`preview_pipeline` takes the design run's pipeline and keeps the stages a designer looks
at (:data:`~torsal.session.answer.PREVIEW_STAGES`), with four changes: the congruence stage
re-solves the session's kept problem from its last optimum (:class:`~.warm.WarmProblem`);
the support stage stops where eq. (8)'s soft planarity does not make the fins planar in a few
iterations (or does not try, where the fins are extracted far from planar), and makes them
planar by a projection instead, for the build to solve with
planarity as a hard constraint (:class:`PreviewSupport`); the devices stage takes the standard
devices from the stage cache, or while a change of spacing or depth waits for the build, the
last good design's (:class:`PreviewDevices`); and the light measures every fin (no
fabrication has left panels out yet). The stages keep their names and cache keys, so the
build finds the preview's congruence, remesh and (where it is the design run's) support in
the cache.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial
from typing import Callable

from ..geometry.support import SupportOptimizationResult, optimize_support
from ..pipeline.cache import MISSING, StageCache
from ..pipeline.measure import run_devices
from ..pipeline.stage import Pipeline, Stage, StageInputs, stage_keys
from ..pipeline.stages import run_congruence, run_support
from .answer import PREVIEW_STAGES
from .warm import WarmProblem

__all__ = ["PreviewDevices", "PreviewSupport", "preview_support", "preview_pipeline", "preview_light",
           "PREVIEW_SUPPORT_ITERATIONS", "PREVIEW_SOFT_REACH"]

#: IPOPT iterations per round of eq. (8)'s soft planarity in a preview. Every one-parameter
#: edit of 7a but a let-through region took 1 or 2 (full and test size); the region's fins needed
#: planarity as a hard constraint after 400 (full size: 12 s of processor time, then 2 s hard)
PREVIEW_SUPPORT_ITERATIONS = 8

#: extracted fins less planar than this many times ``planarity_tol`` go to the projection
#: without the soft solve. Every one-parameter edit of 7a but a let-through region extracts
#: fins within ``planarity_tol`` already (delta_pl 3e-7 .. 9.4e-5 against 1e-4, full size);
#: across a let-through region's edge the lines turn from blocking the sun to passing it within
#: a ring of faces and the extracted fins are 0.18-0.20 from planar. There eq. (8)'s soft
#: optimum itself keeps delta_pl 0.0148 (125 IPOPT iterations): the soft rounds cannot make
#: those fins planar, in a preview or in the design run (which then solves planarity as a hard
#: constraint), so a preview's 8 iterations of them (0.25-0.3 s of processor time with their
#: NLP's build) only moved the projection's start: from the extracted fins the projected
#: ones are as near the built ones (mean 2.4 cm both) and their light figures nearer
#: (blocked share 0.177 against 0.183, the built 0.166)
PREVIEW_SOFT_REACH = 100.0


def preview_support(structure, *, reference, planarity_tol: float,
                    iterations: int = PREVIEW_SUPPORT_ITERATIONS,
                    reach: float = PREVIEW_SOFT_REACH) -> tuple[SupportOptimizationResult, bool]:
    """The support structure of a preview and whether it is the design run's (``final``).

    Eq. (8) with soft planarity, ``iterations`` IPOPT iterations per round at most: where every
    round converges and the fins are planar to ``planarity_tol`` this is, bit for bit, what
    :func:`~torsal.geometry.support.optimize_support` gives the design run (the same solves; an
    iteration limit changes no iterate before it). Otherwise the run goes on for seconds (up to
    200 iterations a round, then planarity as a hard constraint): the preview instead makes
    those fins planar by the projection (``method="projection"``: a Gauss-Newton projection
    onto planar fins on A's tangent planes, milliseconds), and is not final: the build solves
    eq. (8) as the design run does. The first round that does not converge decides that, so
    the rounds after it are not run (``stop_unconverged``: 7a's let-through region at full
    size, the soft solve 0.55 -> 0.31 s of processor time; the projection starts from the
    first round's fins). Fins extracted more than ``reach`` times ``planarity_tol`` from
    planar (a let-through region's edge) are projected without the soft rounds: eq. (8)'s
    soft optimum does not make them planar (:data:`PREVIEW_SOFT_REACH`).

    Parameters
    ----------
    structure : SupportStructure
        The extracted fins (the remesh stage's), model units.
    reference : (vertices, faces)
        Mesh A.
    planarity_tol : float
        The planarity flat sheet parts need (``fins.planarity_tol``).
    iterations : int
    reach : float
        Extracted fins' ``delta_pl`` over ``reach * planarity_tol``: no soft rounds.

    Returns
    -------
    (SupportOptimizationResult, bool)

    Examples
    --------
    >>> import numpy as np
    >>> from torsal.geometry.support import SupportStructure
    >>> a = np.array([[0., 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    >>> b = a + [[0, 0, 1], [0, 0, 1], [0.3, 0, 1], [0, 0, 1]]     # one fin twisted
    >>> s = SupportStructure(a, b, [[0, 1, 2, 3]], np.array([[0, 1], [1, 2], [2, 3], [0, 3]]),
    ...                      np.array([0, 1, 0, 1]))
    >>> r, final = preview_support(s, reference=None, planarity_tol=1e-4)
    >>> final, r.structure.delta_pl <= 1e-4, r.status.startswith("preview: the extracted fins")
    (False, True, True)
    """
    if structure.delta_pl > reach * planarity_tol:
        planar = optimize_support(structure, reference, hard_tol=planarity_tol, method="projection")
        return replace(planar, status=(
            f"preview: the extracted fins' delta_pl {structure.delta_pl:.3g} is over {reach:g} times "
            f"{planarity_tol:.3g}, more than soft planarity makes planar; made planar by projection "
            f"({planar.status}); the built answer solves eq. (8) as torsal design does")), False
    # a round IPOPT does not converge in decides it (not final): the rounds after it are not run
    soft = optimize_support(structure, reference, planarity_tol=None, max_iter=iterations,
                            stop_unconverged=True)
    converged = all(h.get("status") == "Solve_Succeeded" for h in soft.history)
    if converged and soft.success and soft.delta_pl_after <= planarity_tol:
        return soft, True
    planar = optimize_support(soft.structure, reference, hard_tol=planarity_tol, method="projection")
    status = (f"preview: soft planarity left delta_pl {soft.delta_pl_after:.3g} after {soft.iterations} "
              f"iterations (> {planarity_tol:.3g} or not converged); made planar by projection "
              f"({planar.status}); the built answer solves eq. (8) as torsal design does")
    return replace(planar, status=status, iterations=soft.iterations + planar.iterations,
                   solve_seconds=soft.solve_seconds + planar.solve_seconds,
                   delta_pl_before=soft.delta_pl_before), False


@dataclass
class PreviewSupport:
    """The preview's support stage: the design run's support from the stage cache, else
    :func:`preview_support`; a final one is stored in the cache for the build, one made planar
    by projection is not (the build solves eq. (8) itself). Its value carries ``final``.

    Examples
    --------
    >>> PreviewSupport(cache, DEFAULT_PIPELINE)(inputs)["final"]     # doctest: +SKIP
    True
    """

    cache: StageCache
    pipeline: Pipeline

    def __call__(self, inp: StageInputs) -> dict:
        key = stage_keys(self.pipeline, inp.spec)["support"]
        value = self.cache.load("support", key)
        if value is not MISSING:
            return {**value, "final": True}
        final = []

        def optimize(structure, *, reference, planarity_tol):
            result, ok = preview_support(structure, reference=reference, planarity_tol=planarity_tol)
            final.append(ok)
            return result

        value = run_support(inp, optimize=optimize)
        if all(final):          # (fins.optimize false: no optimization, the design run's)
            self.cache.store("support", key, value)
        return {**value, "final": all(final)}


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


def preview_pipeline(pipeline: Pipeline, warm: WarmProblem, devices: PreviewDevices,
                     support: PreviewSupport) -> Pipeline:
    """The preview stages of ``pipeline`` (see the module notes).

    Parameters
    ----------
    pipeline : Pipeline
        The design run's (:data:`~torsal.pipeline.DEFAULT_PIPELINE`).
    warm : WarmProblem
        The session's kept congruence problem.
    devices : PreviewDevices
    support : PreviewSupport

    Returns
    -------
    Pipeline

    Examples
    --------
    >>> from torsal.pipeline import DEFAULT_PIPELINE, StageCache
    >>> cache = StageCache("/tmp/x")
    >>> p = preview_pipeline(DEFAULT_PIPELINE, WarmProblem(),
    ...                      PreviewDevices(cache, DEFAULT_PIPELINE, lambda: None),
    ...                      PreviewSupport(cache, DEFAULT_PIPELINE))
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
        elif s.name == "support":
            s = Stage(s.name, support, inputs=s.inputs, key=s.key, applies=s.applies, cache=False,
                      section=s.section)
        elif s.name == "devices":
            s = Stage(s.name, devices, inputs=s.inputs, key=s.key, applies=s.applies, cache=False,
                      section=s.section)
        elif s.name == "light":
            # every fin: the fins as built come with the fabrication, in the build
            s = Stage(s.name, s.run, inputs=tuple(i for i in s.inputs if i in PREVIEW_STAGES),
                      key=s.key, applies=s.applies, cache=False, section=s.section)
        stages.append(s)
    return Pipeline(tuple(stages))
