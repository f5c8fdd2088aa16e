"""The Radiance programs torsal runs, and the scene files it gives them.

Radiance 6 comes with the ``pyradiance`` wheel (``pip install 'pyradiance>=1.3'``), whose
``bin`` folder holds the programs and whose ``lib`` folder holds the ``.cal`` files. torsal
finds that folder without importing the package (importing it changes ``PATH`` and
``RAYPATH`` of the whole process) and calls each program with its own environment:
``RAYPATH`` set to the run's folder and ``lib`` (a Radiance program called without it does not
find ``reinhartb.cal``). A missing package or program is a :class:`RadianceNotFound` naming
the package.

Scenes are plain text: each triangle a ``polygon``, every source a ``source`` (distant).

Examples
--------
>>> import numpy as np
>>> print(polygons_text(np.eye(3), np.array([[0, 1, 2]]), "fin"), end="")
fin polygon t0
0
0
9 1 0 0 0 1 0 0 0 1
"""
from __future__ import annotations

import importlib.util
import io
import os
import subprocess
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

import numpy as np

from torsal.core.errors import TorsalError

__all__ = ["Radiance", "Program", "RadianceNotFound", "RadianceError", "polygons_text",
           "PACKAGE", "REQUIREMENT"]

#: the package that ships the Radiance programs torsal runs
PACKAGE = "pyradiance"
#: what to install
REQUIREMENT = "pyradiance>=1.3"


class RadianceNotFound(TorsalError, FileNotFoundError):
    """The Radiance programs are not installed where torsal looks; the message names the
    package that provides them."""


class RadianceError(TorsalError, RuntimeError):
    """A Radiance program failed; the message carries its command line and its error output."""


class Program(str, Enum):
    """The Radiance programs torsal runs."""

    GENDAYMTX = "gendaymtx"   # the sky matrix of a weather year (Perez all-weather sky)
    RCONTRIB = "rcontrib"     # contribution coefficients of sources at sensor points
    OCONV = "oconv"           # the octree of a scene


@dataclass(frozen=True)
class Radiance:
    """Where the Radiance programs and their library files are.

    Attributes
    ----------
    bin_dir : Path
        The folder of the programs (``rcontrib``, ``gendaymtx``, ``oconv``).
    lib_dir : Path
        The folder of the ``.cal`` files (``reinhartb.cal``), put on ``RAYPATH``.
    """

    bin_dir: Path
    lib_dir: Path

    @classmethod
    def bundled(cls) -> "Radiance":
        """The programs of the installed ``pyradiance`` package (found, not imported).

        Raises
        ------
        RadianceNotFound
            The package is not installed.
        """
        spec = importlib.util.find_spec(PACKAGE)
        if spec is None or not spec.submodule_search_locations:
            raise RadianceNotFound(
                f"Radiance is not installed: torsal runs the Radiance programs that the "
                f"{PACKAGE} package bundles; install it with pip install '{REQUIREMENT}'")
        root = Path(next(iter(spec.submodule_search_locations)))
        return cls(root / "bin", root / "lib")

    def executable(self, program: Program) -> Path:
        """The program's path; :class:`RadianceNotFound` naming the package if it is missing."""
        exe = self.bin_dir / Program(program).value
        if not (exe.is_file() and os.access(exe, os.X_OK)):
            raise RadianceNotFound(
                f"Radiance's {Program(program).value} is not in {self.bin_dir}: torsal runs the "
                f"Radiance programs that the {PACKAGE} package bundles; install or repair it "
                f"with pip install --force-reinstall '{REQUIREMENT}'")
        return exe

    def run(self, program: Program, args, *, cwd, stdin: bytes | None = None) -> bytes:
        """Run ``program args`` in ``cwd`` and return its standard output.

        Parameters
        ----------
        program : Program
        args : sequence of str
        cwd : str or Path
            The run's folder (scene files are named relative to it; first on ``RAYPATH``).
        stdin : bytes, optional

        Returns
        -------
        bytes
            Standard output.

        Raises
        ------
        RadianceNotFound, RadianceError
        """
        exe = self.executable(program)
        env = {**os.environ, "RAYPATH": os.pathsep.join([str(cwd), str(self.lib_dir)]),
               "PATH": os.pathsep.join([str(self.bin_dir), os.environ.get("PATH", "")])}
        cmd = [str(exe), *map(str, args)]
        done = subprocess.run(cmd, input=stdin, capture_output=True, cwd=cwd, env=env)
        if done.returncode != 0:
            raise RadianceError(f"{Program(program).value} {' '.join(cmd[1:])} failed (exit "
                                f"{done.returncode}): "
                                f"{done.stderr.decode(errors='replace').strip()[:2000]}")
        return done.stdout

    def octree(self, folder: Path, name: str, scene: str) -> Path:
        """Write ``scene`` (Radiance text) as ``name.rad`` in ``folder`` and its frozen octree
        ``name.oct`` (``oconv -f``); returns the octree's path."""
        rad = folder / f"{name}.rad"
        rad.write_text(scene)
        oct_path = folder / f"{name}.oct"
        oct_path.write_bytes(self.run(Program.OCONV, ["-f", rad.name], cwd=folder))
        return oct_path


def polygons_text(vertices, faces, modifier: str) -> str:
    """Triangles as Radiance ``polygon`` primitives.

    Parameters
    ----------
    vertices : (v, 3) float
    faces : (f, 3) int
    modifier : str
        The material's name.

    Returns
    -------
    str
        One polygon ``t{k}`` per face, its corners in the face's order (Radiance's plastic is
        two-sided: the order only sets the normal).
    """
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64).reshape(-1, 3)
    if not len(f):
        return ""
    rows = np.c_[np.arange(len(f)), v[f].reshape(-1, 9)]
    buf = io.StringIO()
    np.savetxt(buf, rows, fmt=f"{modifier} polygon t%d\n0\n0\n9" + " %.10g" * 9)
    return buf.getvalue()
