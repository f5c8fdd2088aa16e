"""``torsal freecad install``: the torsal workbench as a FreeCAD Mod folder.

The folder (``<FreeCAD user data>/Mod/Torsal``) holds:

- ``Init.py``, run by every FreeCAD (GUI and ``freecadcmd``) at start: it records torsal's
  Python (``TORSAL_PYTHON``, which runs the stages) and puts torsal's environment (its
  site-packages) in front of ``sys.path`` the first time ``torsal`` is imported, not before,
  so FreeCAD's other workbenches keep their own numpy and matplotlib until torsal is used.
- ``InitGui.py``: the torsal workbench (menu, toolbar, the "Fins from design file" command).
- ``torsal.svg``, its icon, and ``torsal-environment.json``, which says what was installed.

Nothing else is changed; removing the folder (``torsal freecad uninstall``) removes it all.
"""
from __future__ import annotations

import json
import shutil
import site
import subprocess
import sys
from pathlib import Path

from ...core.errors import TorsalError
from .feature import ICON

__all__ = ["MOD_NAME", "FreeCADInstallError", "freecad_mod_folder", "install_workbench",
           "uninstall_workbench"]

MOD_NAME = "Torsal"
_MARKER = "torsal-environment.json"
#: FreeCAD 0.20+ on Linux keeps user Mods here when it cannot be asked
_DEFAULT_MODS = Path.home() / ".local" / "share" / "FreeCAD" / "Mod"

_INIT = '''\
# The torsal workbench, written by `torsal freecad install` on {date}.
# Remove it with `torsal freecad uninstall`, or delete this folder: {folder}
import importlib.abc
import os
import sys

os.environ.setdefault("TORSAL_PYTHON", {python!r})


class _TorsalEnvironment(importlib.abc.MetaPathFinder):
    """On the first `import torsal`: torsal's site-packages go in front of sys.path.
    (FreeCAD runs this file in a namespace it discards: the method keeps what it needs.)"""

    sites = {sites!r}

    def find_spec(self, name, path=None, target=None):
        import importlib
        import importlib.util
        import site
        import sys

        if name != "torsal":
            return None
        sys.meta_path.remove(self)
        before = list(sys.path)
        for folder in self.sites:
            site.addsitedir(folder)          # runs its .pth files (an editable install's finder)
        added = [p for p in sys.path if p not in before]
        sys.path[:] = added + before
        importlib.invalidate_caches()
        return importlib.util.find_spec(name)


if not any(type(f).__name__ == "_TorsalEnvironment" for f in sys.meta_path):
    sys.meta_path.insert(0, _TorsalEnvironment())
'''

_INIT_GUI = '''\
# The torsal workbench's GUI, written by `torsal freecad install`.
import FreeCADGui


class TorsalWorkbench(FreeCADGui.Workbench):
    MenuText = "torsal"
    ToolTip = "Buildable shading and lighting fins from a design surface and the sun"
    Icon = {icon!r}

    def Initialize(self):
        from torsal.hosts.freecad.gui import COMMANDS, register

        register()
        self.appendToolbar("torsal", COMMANDS)
        self.appendMenu("torsal", COMMANDS)

    def GetClassName(self):
        return "Gui::PythonWorkbench"


FreeCADGui.addWorkbench(TorsalWorkbench())
'''


class FreeCADInstallError(TorsalError, ValueError):
    """The workbench cannot be installed or removed there; the message says why."""


def freecad_mod_folder(freecadcmd: str | None = None) -> Path:
    """FreeCAD's folder of user Mods: asked of ``freecadcmd`` (on PATH, or the one given)
    when it runs, else ``~/.local/share/FreeCAD/Mod``."""
    exe = freecadcmd or shutil.which("freecadcmd") or shutil.which("FreeCADCmd")
    if exe:
        code = "import FreeCAD; print('TORSAL-MODS=' + FreeCAD.getUserAppDataDir())"
        try:
            out = subprocess.run([exe, "-c", code], capture_output=True, text=True,
                                 timeout=120).stdout
            for line in out.splitlines():
                if line.startswith("TORSAL-MODS="):
                    return Path(line.removeprefix("TORSAL-MODS=")) / "Mod"
        except (OSError, subprocess.SubprocessError):
            pass
    return _DEFAULT_MODS


def _site_packages() -> list[str]:
    """This environment's site-packages (where torsal and its dependencies are)."""
    sites = [p for p in site.getsitepackages() if Path(p).is_dir()]
    return sites or [str(Path(__file__).resolve().parents[3])]


def install_workbench(mod_folder: str | Path | None = None, *,
                      python: str | None = None) -> Path:
    """Write the workbench into ``mod_folder`` (default :func:`freecad_mod_folder`) for the
    Python ``python`` (default this one); returns the workbench folder. An earlier torsal
    workbench there is replaced; any other folder of that name is left alone (error)."""
    import datetime

    mods = Path(mod_folder) if mod_folder else freecad_mod_folder()
    folder = mods / MOD_NAME
    if folder.exists() and not (folder / _MARKER).exists():
        raise FreeCADInstallError(f"{folder} exists and is not torsal's workbench; move it away "
                                  "or give another folder with --mod-dir")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise FreeCADInstallError(f"cannot create {folder}: {exc.strerror}") from None
    python = python or sys.executable
    sites = _site_packages()
    date = datetime.date.today().isoformat()
    (folder / "Init.py").write_text(_INIT.format(date=date, folder=str(folder), python=python,
                                                 sites=sites))
    shutil.copyfile(ICON, folder / "torsal.svg")
    (folder / "InitGui.py").write_text(_INIT_GUI.format(icon=str(folder / "torsal.svg")))
    (folder / _MARKER).write_text(json.dumps({"python": python, "site_packages": sites,
                                              "installed": date}, indent=2) + "\n")
    return folder


def uninstall_workbench(mod_folder: str | Path | None = None) -> Path | None:
    """Remove torsal's workbench from ``mod_folder`` (default :func:`freecad_mod_folder`);
    returns the removed folder, or None when there was none. A folder that is not torsal's
    is left alone (error)."""
    mods = Path(mod_folder) if mod_folder else freecad_mod_folder()
    folder = mods / MOD_NAME
    if not folder.exists():
        return None
    if not (folder / _MARKER).exists():
        raise FreeCADInstallError(f"{folder} is not torsal's workbench (no {_MARKER}); left alone")
    shutil.rmtree(folder)
    return folder
