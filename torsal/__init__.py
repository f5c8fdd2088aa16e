"""torsal: discrete line congruences for shading and lighting (Wang et al. 2013).

From a design surface and the path of the sun to buildable planar fins.
"""
__version__ = "0.1.0"   # before the imports: design.py keys its stage cache with it

from .design import Design, DesignError
from .pipeline import Study, StudyFileError
from .geometry import (
    Congruence,
    CongruenceProblem,
    MeshError,
    OptimizationError,
    OptimizationResult,
    SupportStructure,
    TorsalCurve,
    load_mesh,
    optimize_support,
    remesh_torsal,
    trace_torsal_curve,
)


__all__ = ["Congruence", "CongruenceProblem", "OptimizationResult", "OptimizationError",
           "MeshError", "SupportStructure", "TorsalCurve", "load_mesh", "trace_torsal_curve",
           "remesh_torsal", "optimize_support", "Design", "DesignError", "Study", "StudyFileError", "__version__"]
