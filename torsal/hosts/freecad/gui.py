"""The workbench's command, for FreeCAD with a display: "Fins from design file" asks for a
design file and makes a fins object on the selected face (and the selected wires as strokes).

Loaded by the workbench's ``Initialize`` only (FreeCADGui exists then)."""
from __future__ import annotations

from .feature import ICON, make_fins

__all__ = ["COMMANDS", "FinsCommand", "register"]

COMMANDS = ["Torsal_Fins"]


class FinsCommand:
    """Make fins from a design file; a selected face becomes the ``Surface``, selected
    wires the ``Strokes``."""

    def GetResources(self):
        return {"Pixmap": str(ICON), "MenuText": "Fins from design file",
                "ToolTip": "Buildable shading fins (torsal) from a design file, on the selected "
                           "face if any, following the selected wires"}

    def IsActive(self):
        import FreeCAD

        return FreeCAD.ActiveDocument is not None

    def Activated(self):
        import FreeCAD
        import FreeCADGui
        from PySide import QtGui

        path, _ = QtGui.QFileDialog.getOpenFileName(None, "torsal design file", "",
                                                    "torsal design (*.toml)")
        if not path:
            return
        surface, strokes = None, []
        for sel in FreeCADGui.Selection.getSelectionEx():
            faces = [n for n in sel.SubElementNames if n.startswith("Face")]
            if faces and surface is None:
                surface = (sel.Object, faces[:1])
            elif sel.Object.Shape.Wires and not sel.Object.Shape.Faces:
                strokes.append(sel.Object)
        doc = FreeCAD.ActiveDocument
        try:
            make_fins(doc, path, surface=surface, strokes=strokes)
        except Exception as exc:   # the design file's message, in a dialog
            QtGui.QMessageBox.critical(None, "torsal", str(exc))
            return
        doc.recompute()


def register() -> None:
    import FreeCADGui

    FreeCADGui.addCommand("Torsal_Fins", FinsCommand())
