"""The pipeline: the only room that ties the stages together.

- :func:`analyze`: the analysis of one congruence (``torsal analyze``).
- :class:`Design`: a design file run end to end (``torsal design``) as a loop over
  :data:`DEFAULT_PIPELINE`, a :class:`Pipeline` of :class:`Stage` s (plain functions with
  declared inputs, see :mod:`torsal.pipeline.stage`), each result cached by a hash of its
  inputs (:mod:`torsal.pipeline.cache`).

Studies are a room above this one (:mod:`torsal.study`, ``torsal.Study``), and the command
line sits at the top (:mod:`torsal.cli`): the pipeline imports neither.
"""
from torsal.core.lazy import lazy_exports
from .analyze import AnalysisResult, DirectionsError, analyze, load_directions, read_directions
__getattr__, __dir__ = lazy_exports(__name__, {
    ".assembly": ("UnbuildableDesignError",),
    ".cache": ("StageCache", "stage_key"),
    ".design": ("Design", "DesignResult"),
    ".errors": ("DesignError", "Progress"),
    ".problem": ("JIT_MIN_VERTICES", "congruence_problem", "term_weights"),
    ".regions": ("dominant_light_direction", "select_faces", "select_vertices"),
    ".stage": ("Pipeline", "Stage", "StageInputs", "StageRun", "run_stages", "stage_keys"),
    ".stages": ("DEFAULT_PIPELINE", "STAGES"),
})

__all__ = ["AnalysisResult", "analyze", "load_directions", "read_directions", "DirectionsError", "Design", "DesignResult",
           "DesignError", "Progress", "StageCache", "stage_key", "Pipeline", "Stage",
           "StageInputs", "StageRun", "run_stages", "stage_keys", "DEFAULT_PIPELINE", "STAGES",
           "select_vertices", "select_faces", "dominant_light_direction", "congruence_problem",
           "term_weights", "JIT_MIN_VERTICES", "UnbuildableDesignError"]
