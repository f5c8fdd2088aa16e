""":class:`Design`: a design file run end to end as a loop over the pipeline's stages."""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np

from ..core.outputs import output_folder
from ..fabrication.workers import start_fork_server
from .design_file import DesignSpec, load_design_file
from .assembly import UnbuildableDesignError, unbuildable_message
from .cache import StageCache
from .errors import Progress, quiet
from .stage import Pipeline, Stage, StageRun, concurrent_modules, run_stages
from .stages import DEFAULT_PIPELINE, run_estimate, sun_directions, surface_mesh
from .staging import Staging

__all__ = ["Design", "DesignResult"]


@dataclass
class DesignResult:
    """What a design run produced: the report (as in report.json) and the files written
    (names in ``folder``, the output folder)."""

    report: dict
    files: dict = field(default_factory=dict)
    stage_seconds: dict = field(default_factory=dict)
    cached: list = field(default_factory=list)
    folder: Path | None = None


class Design:
    """A design file and the pipeline that builds it.

    Congruence optimization (4.1), torsal remeshing (4.2), support optimization (eq. 8),
    optional developable refinement (Fig. 10), light measurement and fabrication, one
    :class:`~torsal.pipeline.Stage` each (:data:`~torsal.pipeline.DEFAULT_PIPELINE`). Each
    stage's result is cached by a hash of its inputs, so a changed material re-runs only
    fabrication. Result files appear together when the run succeeds; a failing stage raises
    :class:`~torsal.pipeline.DesignError` naming the stage, and leaves no result files.

    Examples
    --------
    >>> d = Design.from_toml("examples/7a_facade_block.toml")  # doctest: +SKIP
    >>> result = d.run("out/7a")                                # doctest: +SKIP
    >>> result.report["support"]["delta_pl_optimized"] <= 1e-4  # doctest: +SKIP
    True
    """

    def __init__(self, spec: DesignSpec, *, source: str | Path | None = None):
        self.spec = spec
        self.source = Path(source) if source else None

    @classmethod
    def from_toml(cls, path: str | Path) -> "Design":
        """Read and validate a design file (see :mod:`torsal.pipeline.design_file`)."""
        return cls(load_design_file(path), source=path)

    def _surface(self) -> tuple[np.ndarray, np.ndarray]:
        """Mesh A, (n, 3) vertices and (m, 3) faces (see :func:`~torsal.pipeline.stages.surface_mesh`)."""
        return surface_mesh(self.spec)

    def _sun(self) -> tuple[np.ndarray, np.ndarray]:
        return sun_directions(self.spec)

    def run(self, out_dir: str | Path, *, progress: Progress | None = None,
            use_cache: bool = True, cache: StageCache | None = None,
            pipeline: Pipeline = DEFAULT_PIPELINE, size_limit: bool = True,
            accept_unbuildable: bool = False) -> DesignResult:
        """Run every stage and write all outputs into ``out_dir``.

        Parameters
        ----------
        out_dir : path
        progress : callable(stage, event, info), optional
            Told ``("congruence", "start", {})``, ``("congruence", "iteration", {...})``,
            ``(stage, "done", {"seconds": ..})`` or ``(stage, "cached", {})``.
        use_cache : bool
            Reuse stage results whose inputs did not change.
        cache : StageCache, optional
            Where stage results are kept; default ``out_dir/.torsal-cache`` (one entry per
            stage). A study passes one cache shared by its variants.
        pipeline : Pipeline
            The stages to run; default :data:`~torsal.pipeline.DEFAULT_PIPELINE`.
        size_limit : bool
            Stop before the expensive stages when the estimated size is above
            :data:`~torsal.pipeline.checks.SIZE_LIMITS` (the ``estimate`` stage); False runs
            anyway (the estimate is still in the report).
        accept_unbuildable : bool
            Return normally although the assembly check found interfering parts (the report
            says so: ``report["fabrication"]["assembly"]["buildable"]`` is False).

        Result files appear in ``out_dir`` together, when every stage succeeded
        (:class:`~torsal.pipeline.staging.Staging`); a failed run leaves the folder as it found
        it, the earlier run's results included, and keeps the stage cache.

        Raises
        ------
        DesignError
            Naming the stage that failed (and the design key, when a value is the cause); a
            note says what the output folder holds.
        OutputFolderError
            ``out_dir`` is empty, a file, under a file or not writable.
        UnbuildableDesignError
            After every output is written, when the parts interfere or cannot be inserted
            (its message names them; ``.result`` is the finished run), unless
            ``accept_unbuildable``.
        """
        out = output_folder(out_dir, option="output folder")
        if cache is None:
            cache = StageCache(out / ".torsal-cache", enabled=use_cache)
        elif not use_cache:
            cache = StageCache(cache.folder, enabled=False, prune=cache.prune)
        if not size_limit and "estimate" in pipeline.names:
            pipeline = pipeline.replace(Stage("estimate", partial(run_estimate, enforce=False),
                                              inputs=pipeline["estimate"].inputs,
                                              key=pipeline["estimate"].key, cache=False))
        spec = self.spec
        if spec.outputs.step or spec.outputs.rhino_3dm or spec.outputs.ifc:
            # the solids' workers import OpenCascade while the congruence is optimized; the
            # concurrent stages' processes find their stages' modules imported there too
            start_fork_server(also=concurrent_modules(pipeline, spec))
        staging = Staging(out, kind="design")
        try:
            with staging:
                run = run_stages(pipeline, spec, staging.folder, cache,
                                 progress=progress or quiet,
                                 run=StageRun(report={"name": spec.name, "units": spec.units}))
                staging.keep_only(run.files)
        except Exception as exc:
            exc.add_note(staging.failure_note())
            raise
        result = DesignResult(report=run.report, files=run.files,
                              stage_seconds=run.stage_seconds, cached=run.cached, folder=out)
        # an unbuildable design's outputs are published (the report shows why), but the run
        # does not end as done unless the user accepts it
        assembly = run.report.get("fabrication", {}).get("assembly")
        if assembly is not None and not assembly["buildable"] and not accept_unbuildable:
            raise UnbuildableDesignError(
                unbuildable_message(assembly), result,
                parts=sorted(set(assembly["interfering_parts"]) | set(assembly["blocked_parts"])
                             | set(assembly.get("unsupported_parts", []))))
        return result
