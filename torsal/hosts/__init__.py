"""The hosts users design in: FreeCAD (a parametric fins object, :mod:`torsal.hosts.freecad`)
the OCP CAD viewer (:func:`show`) and notebooks (:func:`fins_figure`, plotly). Rhino and CadQuery read torsal's files (README).

At the pipeline layer: may import the pipeline and everything below; nothing below imports it.
"""
from .figure import fins_figure
from .results import GROUP_COLORS, FinsFolderError, PartGroup, fins_folder, read_parts
from .viewer import FinsScene, ViewerUnavailableError, fins_scene, show

__all__ = ["show", "fins_figure", "fins_scene", "FinsScene", "ViewerUnavailableError", "PartGroup",
           "GROUP_COLORS", "fins_folder", "read_parts", "FinsFolderError"]
