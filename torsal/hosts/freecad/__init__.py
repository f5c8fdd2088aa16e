"""torsal inside FreeCAD: the parametric fins object and its workbench.

- :func:`make_fins` (also ``torsal.freecad.make_fins``): a ``Part::FeaturePython`` whose
  properties are the design file's main keys plus ``Surface`` and ``Strokes`` links; a
  recompute runs the stages whose inputs changed and sets ``Shape`` to the part solids.
- :func:`install_workbench` / :func:`uninstall_workbench` (``torsal freecad install``): the
  Mod folder that lets FreeCAD find torsal's environment.
- :mod:`~torsal.hosts.freecad.job`: the run itself, in torsal's Python, outside FreeCAD.

FreeCAD's modules are imported inside functions: importing this package needs no FreeCAD.
"""
from .feature import FinsError, FinsFeature, ViewProviderFins, make_fins
from .install import FreeCADInstallError, freecad_mod_folder, install_workbench, uninstall_workbench
from .job import FinsJob, FinsOutcome

__all__ = ["make_fins", "FinsFeature", "FinsError", "ViewProviderFins", "FinsJob", "FinsOutcome",
           "install_workbench", "uninstall_workbench", "freecad_mod_folder", "FreeCADInstallError"]
