"""The same solids give the same STEP bytes in every process (the colours' entities, which
OpenCascade orders by memory address, in canonical order), and the file still reads back with
every name and colour."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

pytest.importorskip("build123d")

WRITE = """
import sys
from build123d import Box, Pos
from torsal.fabrication.exports import write_step
write_step([(f"P{k:02d}", (Pos(3 * k, 0, 0) * Box(1, 2, 3)).wrapped,
             (0.9, 0.5, 0.1) if k % 2 else (0.2, 0.4, 0.8)) for k in range(40)], sys.argv[1])
"""


def test_the_same_solids_write_the_same_step_bytes_in_two_processes(tmp_path):
    import build123d as bd

    paths = [tmp_path / f"run{k}.step" for k in range(2)]
    for k, path in enumerate(paths):
        # another hash seed and another process: other memory addresses
        subprocess.run([sys.executable, "-c", WRITE, str(path)], check=True,
                       env={**os.environ, "PYTHONHASHSEED": str(k + 1)}, timeout=120)
    assert paths[0].read_bytes() == paths[1].read_bytes()
    comp = bd.import_step(paths[0])
    colours = {c.label: tuple(round(x, 3) for x in tuple(c.color)[:3]) for c in comp.children}
    assert colours == {f"P{k:02d}": (0.9, 0.5, 0.1) if k % 2 else (0.2, 0.4, 0.8)
                       for k in range(40)}
    assert len(comp.solids()) == 40
