"""torsal: discrete line congruences for shading and lighting (Wang et al. 2013).

From a design surface and the path of the sun to buildable planar fins.

The package root only re-exports the public names; nothing inside the package imports it
(the version lives in :mod:`torsal._version`). The names are imported when first used
(PEP 562), so that a command or a script that needs one room (``torsal analyze``, a mesh
generator) does not pay for loading the others: OpenCascade, pvlib and matplotlib take
seconds.

>>> import torsal
>>> torsal.Congruence.__name__
'Congruence'
"""
from importlib import import_module

from ._version import __version__

#: public name -> the module it comes from
_EXPORTS = {
    **dict.fromkeys(["Congruence", "CongruenceProblem", "MeshError", "OptimizationError",
                     "OptimizationResult", "SupportStructure", "TorsalCurve", "load_mesh",
                     "optimize_support", "remesh_torsal", "trace_torsal_curve"], "torsal.geometry"),
    **dict.fromkeys(["Design", "DesignError"], "torsal.pipeline"),
    **dict.fromkeys(["Session", "SessionAnswer"], "torsal.session"),
    "show": "torsal.hosts",
    **dict.fromkeys(["Study", "StudyFileError"], "torsal.study"),
}
#: the package's rooms, importable as attributes of the root (``torsal.pipeline``)
_ROOMS = ("core", "geometry", "light", "fabrication", "pipeline", "session", "study", "hosts")

__all__ = ["Congruence", "CongruenceProblem", "OptimizationResult", "OptimizationError",
           "MeshError", "SupportStructure", "TorsalCurve", "load_mesh", "trace_torsal_curve",
           "remesh_torsal", "optimize_support", "Design", "DesignError", "Study", "StudyFileError",
           "Session", "SessionAnswer", "show", "__version__"]


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(import_module(_EXPORTS[name]), name)
    elif name in _ROOMS:
        value = import_module(f"{__name__}.{name}")
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value          # looked up once
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS) | set(_ROOMS))
