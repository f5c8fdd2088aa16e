"""The pipeline's public names where they have always been; the code lives in
:mod:`torsal.pipeline` (stages as functions, the stage cache, :class:`Design`, the design file)."""
from .pipeline.design_file import DesignFileError
from .pipeline import (
    DEFAULT_PIPELINE,
    JIT_MIN_VERTICES,
    STAGES,
    AnalysisResult,
    Design,
    DesignError,
    DesignResult,
    Pipeline,
    Progress,
    Stage,
    StageCache,
    DirectionsError,
    UnbuildableDesignError,
    analyze,
    dominant_light_direction,
    load_directions,
    read_directions,
    select_faces,
    select_vertices,
)

__all__ = ["AnalysisResult", "analyze", "load_directions", "read_directions", "DirectionsError", "Design", "DesignError",
           "DesignFileError", "DesignResult", "STAGES", "DEFAULT_PIPELINE", "Pipeline", "Stage",
           "StageCache", "Progress", "JIT_MIN_VERTICES", "select_vertices", "select_faces",
           "dominant_light_direction", "UnbuildableDesignError"]
