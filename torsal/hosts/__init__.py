"""The hosts users design in: FreeCAD (a parametric fins object, :mod:`torsal.hosts.freecad`)
and the OCP CAD viewer (:func:`show`). Rhino and CadQuery read torsal's files (README).

At the pipeline layer: may import the pipeline and everything below; nothing below imports it.
"""
from .results import PartGroup, fins_folder, read_parts

__all__ = ["PartGroup", "fins_folder", "read_parts"]
