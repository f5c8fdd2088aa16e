"""torsal: discrete line congruences for shading and lighting (Wang et al. 2013).

From a design surface and the path of the sun to buildable planar fins.

The package root only re-exports the public names; nothing inside the package imports it
(the version lives in :mod:`torsal._version`).
"""
from ._version import __version__
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
from .pipeline import Design, DesignError
from .session import Session, SessionAnswer
from .hosts import show
from .study import Study, StudyFileError


__all__ = ["Congruence", "CongruenceProblem", "OptimizationResult", "OptimizationError",
           "MeshError", "SupportStructure", "TorsalCurve", "load_mesh", "trace_torsal_curve",
           "remesh_torsal", "optimize_support", "Design", "DesignError", "Study", "StudyFileError", "Session", "SessionAnswer", "show",
           "__version__"]
