"""torsal: discrete line congruences for shading and lighting (Wang et al. 2013).

From a design surface and the path of the sun to buildable planar fins.
"""
from .geometry import (
    Congruence,
    MeshError,
    SupportStructure,
    TorsalCurve,
    load_mesh,
    trace_torsal_curve,
)

__version__ = "0.1.0"

__all__ = ["Congruence", "MeshError", "SupportStructure", "TorsalCurve", "load_mesh",
           "trace_torsal_curve", "__version__"]
