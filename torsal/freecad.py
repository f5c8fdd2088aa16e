"""``from torsal.freecad import make_fins``: torsal's FreeCAD object (see :mod:`torsal.hosts.freecad`)."""
from .hosts.freecad import FinsFeature, install_workbench, make_fins, uninstall_workbench

__all__ = ["make_fins", "FinsFeature", "install_workbench", "uninstall_workbench"]
