""":class:`Session`: one design kept warm in a long-running process; edits answered with a
preview first, the built design after."""
from __future__ import annotations

import threading
import time
from dataclasses import replace
from typing import Callable, Sequence

from ..core.outputs import output_folder
from ..pipeline.design import Design, DesignResult
from ..pipeline.design_file import DesignSpec, load_design_file
from ..pipeline.errors import DesignError, Progress, quiet
from ..pipeline.stage import Pipeline, StageRun, run_stages
from ..pipeline.stages import DEFAULT_PIPELINE
from .answer import AnswerKind, SessionAnswer
from .build import Builder, BuildRequest
from .edits import RegionGoal, apply_edit, moved_point_surface, region_edit
from .preview import PreviewDevices, PreviewSupport, preview_light, preview_pipeline
from .warm import WarmCache, WarmProblem

__all__ = ["Session", "SESSION_FOLDER"]

#: the session's own files in the output folder (meshes with a moved point)
SESSION_FOLDER = ".torsal-session"


def _spec_of(design) -> DesignSpec:
    if isinstance(design, DesignSpec):
        return design
    if isinstance(design, Design):
        return design.spec
    return load_design_file(design)


class Session:
    """A design kept warm for live editing: compiled kernels, the last optimum with its
    multipliers, the remesh and the light scene's inputs stay in this process between edits.

    Each edit is answered first with a **preview** (:attr:`AnswerKind.PREVIEW`): the
    congruence re-solved from the last optimum, the support structure's fins as surfaces and
    the light figures (the pipeline's own stages and cache, :mod:`~torsal.session.preview`).
    The **built** design (solids, sheets, the assembly check, every file in ``out``) follows
    in a background thread (``build=True``) and comes to ``on_answer`` and
    :meth:`wait_built`; an edit that comes meanwhile cancels it, and a cancelled build leaves
    ``out`` as it was. An edit the design cannot take (an optimization that does not
    converge, a stroke on no face, ...) is answered :attr:`AnswerKind.INFEASIBLE`, saying
    why, and the session keeps the last good design.

    Parameters
    ----------
    design : DesignSpec, Design or path of a design file
    out : path
        The output folder: the built design's files and the stage cache (as ``torsal design
        OUT``), so ``torsal design`` of the same design there finds every stage cached.
    build : bool
        Build each good edit in the background (False: previews only).
    on_answer : callable(SessionAnswer), optional
        Called with each built (or failed build's) answer, in the build thread.
    progress : callable(stage, event, info), optional
        The stages' progress, as :meth:`torsal.Design.run`'s (the build's too, from its thread).
    pipeline : Pipeline
        The design run's stages; default :data:`~torsal.pipeline.DEFAULT_PIPELINE`.

    Examples
    --------
    >>> with Session("examples/7a_facade_block.toml", "out/7a") as s:   # doctest: +SKIP
    ...     first = s.start()                    # cold: seconds
    ...     a = s.set_weights(perp=12)           # a preview, under a second
    ...     a.kind, a.stages_run, a.light["blocked_share"]
    ...     built = s.wait_built()               # solids, sheets, assembly check
    (<AnswerKind.PREVIEW: 'preview'>, ('estimate', 'orient', 'congruence', ...), 0.93)
    """

    def __init__(self, design, out, *, build: bool = True,
                 on_answer: Callable[[SessionAnswer], None] | None = None,
                 progress: Progress | None = None, pipeline: Pipeline = DEFAULT_PIPELINE):
        self.out = output_folder(out, option="session output folder")
        self.pipeline = pipeline
        self.cache = WarmCache(self.out / ".torsal-cache")
        self.on_answer = on_answer
        self._progress = progress or quiet
        self._spec = _spec_of(design)
        self._warm = WarmProblem()
        self._preview_pipeline = preview_pipeline(pipeline, self._warm, PreviewDevices(
            self.cache, pipeline, self._previous_devices), PreviewSupport(self.cache, pipeline))
        self._edit_lock = threading.RLock()
        self._cond = threading.Condition()
        self._revision = -1
        self._good: SessionAnswer | None = None
        self._built: SessionAnswer | None = None
        self._builder = Builder(self.out, self.cache, pipeline, on_done=self._build_done,
                                progress=self._progress) if build else None

    # ------------------------------------------------------------------ state
    @property
    def design(self) -> DesignSpec:
        """The last good design (the one the next edit changes)."""
        return self._good.spec if self._good is not None else self._spec

    @property
    def preview(self) -> SessionAnswer | None:
        """The last good preview."""
        return self._good

    @property
    def built(self) -> SessionAnswer | None:
        """The last built answer (or failed build), None before one."""
        with self._cond:
            return self._built

    @property
    def builds_cancelled(self) -> int:
        """Background builds an edit cancelled so far."""
        return self._builder.cancelled if self._builder is not None else 0

    @property
    def problems_reused(self) -> int:
        """Congruence solves on the kept, built problem (no rebuild of its NLP) so far."""
        return self._warm.reused

    def _previous_devices(self) -> dict | None:
        if self._good is None or "devices" not in self._good.values:
            return None
        return {k: v for k, v in self._good.values["devices"].items() if k != "current"}

    # ------------------------------------------------------------------ edits
    def start(self) -> SessionAnswer:
        """The first answer: the design as given (cold: the kernels compile or load, every
        stage not in ``out``'s cache runs), then warms the congruence problem so the first
        edit re-solves without building it. Later calls return the last good preview."""
        with self._edit_lock:
            if self._good is not None:
                return self._good
            answer = self._answer(self._spec, time.perf_counter())
            if answer.ok and self._warm.problem is None:
                self._warm_up(answer)
            return answer

    def apply(self, spec: DesignSpec) -> SessionAnswer:
        """Answer a whole new design (a host that edits the design file's data; the stages
        whose inputs did not change are kept)."""
        t0 = time.perf_counter()
        with self._edit_lock:
            if self._good is None:
                first = self.start()
                if spec == self._spec:
                    return first
            if self._good is not None and spec == self._good.spec:
                return self._unchanged(t0)
            if self._builder is not None:
                self._builder.cancel()
            return self._answer(spec, t0)

    def _unchanged(self, t0: float) -> SessionAnswer:
        """The design as it is (a host recomputing without a change): the last preview again;
        its build goes on, or starts again if it was cancelled."""
        good = self._good
        if self._builder is not None and not self._builder.busy:
            built = self.built
            if built is None or built.revision != good.revision:
                self._builder.submit(BuildRequest(good.revision, good.spec, t0))
        return replace(good, stages_run=(), stage_seconds={},
                       stages_kept=good.stages_run + good.stages_kept,
                       seconds=time.perf_counter() - t0)

    def edit(self, **changes) -> SessionAnswer:
        """Apply ``changes`` and answer with a preview (see :func:`~torsal.session.edits.apply_edit`
        for the keys: ``spacing``, ``depth``, ``min_torsal_angle``, or a design-file table
        as a dict merged into it).

        Raises
        ------
        SessionEditError
            An unknown key (the session is unchanged).
        DesignFileError
            A bad value, named by its key as in a design file (the session is unchanged).

        Examples
        --------
        >>> s.edit(spacing=0.7, weights={"perp": 12}).kind   # doctest: +SKIP
        <AnswerKind.PREVIEW: 'preview'>
        """
        return self.apply(apply_edit(self.design, **changes))

    def set_weights(self, **weights: float) -> SessionAnswer:
        """Weights of the optimizer's terms by their design-file names (``perp=12``).

        >>> s.set_weights(perp=12, dir=0.2).stages_run   # doctest: +SKIP
        ('estimate', 'orient', 'congruence', 'remesh', 'support', 'devices', 'light')
        """
        return self.edit(weights=weights)

    def set_sun(self, **sun) -> SessionAnswer:
        """The sun period: ``start``, ``end`` (dates), ``hours`` ([h0, h1] local clock),
        ``months``, ``step`` (the design file's ``[sun]`` keys).

        >>> s.set_sun(hours=[12, 16]).kind   # doctest: +SKIP
        <AnswerKind.PREVIEW: 'preview'>
        """
        return self.edit(sun=sun)

    def set_strokes(self, strokes: Sequence, *, width: float | None = None) -> SessionAnswer:
        """The designer's strokes (``goals.strokes``): polylines of points (model units) the
        torsal directions follow; ``width`` (model units) how far from them faces follow.

        >>> s.set_strokes([[[0, 0, 0], [6, 0, 3]]]).kind   # doctest: +SKIP
        <AnswerKind.PREVIEW: 'preview'>
        """
        rows = [{"points": [list(map(float, p)) for p in pts],
                 **({} if width is None else {"width": width})} for pts in strokes]
        return self.edit(goals={"strokes": rows})

    def set_region(self, goal: RegionGoal, region, *, index: int = 0) -> SessionAnswer:
        """Move a goal's region (a dict of ``x``, ``y``, ``z`` ranges and/or ``vertices``,
        ``faces``, model units): ``goal`` :class:`~torsal.session.edits.RegionGoal`,
        ``index`` the see-through or sun region.

        >>> s.set_region(RegionGoal.LET_THROUGH, {"x": [0, 4]}).kind   # doctest: +SKIP
        <AnswerKind.PREVIEW: 'preview'>
        """
        return self.edit(goals=region_edit(self.design, goal, region, index=index))

    def set_bound(self, *, min_torsal_angle: float | None) -> SessionAnswer:
        """The bound on the torsal angle (degrees; None: no bound).

        >>> s.set_bound(min_torsal_angle=30).kind   # doctest: +SKIP
        <AnswerKind.PREVIEW: 'preview'>
        """
        return self.edit(min_torsal_angle=min_torsal_angle)

    def set_fins(self, *, spacing: float | None = None, depth: float | None = None) -> SessionAnswer:
        """Fin spacing and depth (model units); None keeps one.

        >>> s.set_fins(spacing=0.7).stages_kept   # doctest: +SKIP
        ('surface', 'sun', 'congruence')
        """
        changes = {k: v for k, v in (("spacing", spacing), ("depth", depth)) if v is not None}
        return self.edit(**changes)

    def move_point(self, vertex: int, to) -> SessionAnswer:
        """Move one vertex of mesh A to ``to`` (3,), model units: the design's surface becomes
        a mesh file in ``out/.torsal-session``.

        >>> s.move_point(500, s.preview.values["surface"]["vertices"][500] + [0, -0.1, 0]).kind
        ... # doctest: +SKIP
        <AnswerKind.PREVIEW: 'preview'>
        """
        with self._edit_lock:
            answer = self.start()
            surface = answer.values["surface"]
            path = moved_point_surface(surface["vertices"], surface["faces"], vertex, to,
                                       self.out / SESSION_FOLDER)
            return self.edit(surface={"mesh": str(path), "generator": None, "params": {}})

    # ------------------------------------------------------------------ answers
    def _answer(self, spec: DesignSpec, t0: float) -> SessionAnswer:
        """Run the preview of ``spec``: a good one becomes the session's design (and is built
        in the background), a rejected one leaves the last good design."""
        self._revision += 1
        revision = self._revision
        try:
            run = run_stages(self._preview_pipeline, spec, self.out, self.cache,
                             progress=self._progress,
                             run=StageRun(report={"name": spec.name, "units": spec.units}))
        except DesignError as exc:
            self._warm.rollback()
            return self._rejected(revision, t0, exc)
        except BaseException:
            self._warm.rollback()
            raise
        v = run.values
        origin = ((spec, v["orient"]["vertices"], v["orient"]["faces"], v["sun"]["vectors"], v["sun"]["weights"])
                  if "congruence" in v and "orient" in v and "sun" in v else None)
        self._warm.commit(v.get("congruence", {}).get("optimum"), origin)
        current = bool(run.values.get("devices", {}).get("current", True))
        final = bool(run.values.get("support", {}).get("final", True))
        report = {**run.report, "light": preview_light(run.report.get("light", {}), current)}
        answer = SessionAnswer(
            kind=AnswerKind.PREVIEW, revision=revision, spec=spec,
            stages_run=tuple(s for s in self._preview_pipeline.names if s in run.stage_seconds),
            stages_kept=tuple(run.cached), seconds=time.perf_counter() - t0,
            stage_seconds=dict(run.stage_seconds), values=run.values, report=report, devices_current=current,
            support_final=final)
        self._good = answer
        if self._builder is not None:
            self._builder.submit(BuildRequest(revision, spec, t0))
        return answer

    def _rejected(self, revision: int, t0: float, exc: BaseException) -> SessionAnswer:
        good = self._good
        return SessionAnswer(
            kind=AnswerKind.INFEASIBLE, revision=revision, spec=self.design,
            seconds=time.perf_counter() - t0, values=good.values if good else {},
            report=good.report if good else {}, message=str(exc), error=exc)

    def _warm_up(self, answer: SessionAnswer) -> None:
        """Build the congruence problem of a design whose congruence came from the cache, by a
        re-solve from its optimum (no iteration): the first edit then finds it built."""
        from ..pipeline.stage import StageInputs
        from ..pipeline.stages import run_congruence

        self._warm.optimum = answer.values["congruence"]["optimum"]
        inputs = StageInputs(spec=answer.spec, out=self.out, stage="congruence",
                             results={k: answer.values[k] for k in ("orient", "sun")},
                             report={})
        try:
            result = run_congruence(inputs, make_problem=self._warm.make)
        except (DesignError, ValueError):
            self._warm.rollback()     # the next edit builds it
            return
        self._warm.commit(result["optimum"])

    def _build_done(self, req: BuildRequest, result: DesignResult | None,
                    error: BaseException | None) -> None:
        good = self._good
        if good is None or req.revision != good.revision:
            return                     # an older design, finished as an edit came: not shown
        seconds = time.perf_counter() - req.edited_at
        if result is not None:
            answer = SessionAnswer(
                kind=AnswerKind.BUILT, revision=req.revision, spec=req.spec,
                stages_run=tuple(s for s in self.pipeline.names if s in result.stage_seconds),
                stages_kept=tuple(result.cached), seconds=seconds,
                stage_seconds=dict(result.stage_seconds), values=good.values,
                report=result.report, folder=result.folder, files=dict(result.files))
        else:
            kind = AnswerKind.INFEASIBLE if isinstance(error, DesignError) else AnswerKind.ERROR
            answer = SessionAnswer(kind=kind, revision=req.revision, spec=req.spec,
                                   seconds=seconds, values=good.values, report=good.report,
                                   message=str(error), error=error)
        with self._cond:
            self._built = answer
            self._cond.notify_all()
        if self.on_answer is not None:
            self.on_answer(answer)

    def wait_built(self, timeout: float | None = None) -> SessionAnswer | None:
        """The built answer of the last good design, waiting up to ``timeout`` seconds for it
        (None when it did not come in time, or the session does not build).

        >>> s.wait_built(timeout=120).kind   # doctest: +SKIP
        <AnswerKind.BUILT: 'built'>
        """
        if self._builder is None:
            return None
        end = None if timeout is None else time.monotonic() + timeout
        with self._cond:
            while True:
                good, built = self._good, self._built
                if built is not None and good is not None and built.revision == good.revision:
                    return built
                if not self._builder.busy:       # cancelled, or never started: none will come
                    return None
                left = None if end is None else end - time.monotonic()
                if left is not None and left <= 0:
                    return None
                self._cond.wait(0.1 if left is None else min(left, 0.1))

    def cancel_build(self, *, wait: float | None = 0.0) -> bool:
        """Cancel the background build (the output folder stays as it was), waiting up to
        ``wait`` seconds (None: as long as it takes) for it to stop at its next stage boundary
        or progress event. True when no build runs.

        >>> s.cancel_build(wait=60)   # doctest: +SKIP
        True
        """
        if self._builder is None:
            return True
        self._builder.cancel()
        return self._builder.wait_idle(wait) if wait is None or wait > 0 else not self._builder.busy

    def close(self, timeout: float | None = 60.0) -> None:
        """Cancel the background build and end its thread."""
        if self._builder is not None:
            self._builder.close(timeout)

    def __enter__(self) -> "Session":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
