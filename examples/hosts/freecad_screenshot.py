"""FreeCAD macro: a fins object on a B-spline facade in FreeCAD's GUI, saved as a screenshot.

``make freecad-screenshot`` runs it under Xvfb (``xvfb-run freecad this-file``) and writes
``examples/hosts/freecad.png``; the torsal workbench must be installed (``torsal freecad
install``; the make target does it in a scratch HOME).
"""
import os
import sys
from pathlib import Path

import FreeCAD
import FreeCADGui

HERE = Path(os.environ.get("TORSAL_EXAMPLES", "examples/hosts")).resolve()
sys.path.insert(0, str(HERE))

from bspline_facade import facade_face  # noqa: E402
from torsal.freecad import make_fins  # noqa: E402


def main():
    from PySide import QtCore, QtGui

    doc = FreeCAD.newDocument("facade")
    face = doc.addObject("Part::Feature", "Facade")
    face.Shape = facade_face()
    fins = make_fins(doc, HERE / "facade.toml", surface=(face, ["Face1"]))
    doc.recompute()
    FreeCADGui.activateWorkbench("TorsalWorkbench")
    mw = FreeCADGui.getMainWindow()
    mw.resize(1600, 1000)
    mw.showMaximized()
    face.ViewObject.ShapeColor = (0.8, 0.8, 0.82)
    view = FreeCADGui.ActiveDocument.ActiveView
    view.setViewDirection((-0.75, 1.0, -0.45))    # from the south-east, above: the sun side
    view.fitAll()
    # the property editor shows the fins' properties; no selection highlight over the colours
    FreeCAD.ParamGet("User parameter:BaseApp/Preferences/View").SetBool("EnableSelection", False)
    FreeCADGui.Selection.addSelection(fins)
    out = Path(os.environ.get("TORSAL_SCREENSHOT", HERE / "freecad.png"))

    def grab():
        QtGui.QApplication.processEvents()
        QtGui.QApplication.primaryScreen().grabWindow(0).save(str(out))
        FreeCAD.Console.PrintMessage(f"wrote {out}: {len(fins.Shape.Solids)} solids, "
                                     f"buildable {fins.Buildable}\n")
        os._exit(0)

    QtCore.QTimer.singleShot(4000, grab)


main()
