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
from build123d import Box, Pos
from torsal.fabrication.exports import write_step


def write(path):
    write_step([(f"P{k:02d}", (Pos(3 * k, 0, 0) * Box(1, 2, 3)).wrapped,
                 (0.9, 0.5, 0.1) if k % 2 else (0.2, 0.4, 0.8)) for k in range(40)], path)
"""


def test_the_same_solids_write_the_same_step_bytes_in_two_processes(tmp_path):
    import build123d as bd

    # this process, then another with another hash seed (and other memory addresses): one
    # process started, not two (each imports build123d and torsal: 8 s of a fresh clone's make test)
    here, there = tmp_path / "here.step", tmp_path / "there.step"
    scope: dict = {}
    exec(WRITE, scope)
    scope["write"](here)
    seed = os.environ.get("PYTHONHASHSEED", "")
    other = str(int(seed) + 1) if seed.isdigit() else "1"    # unset: this process's is random
    subprocess.run([sys.executable, "-c", WRITE + "\nimport sys\nwrite(sys.argv[1])\n", str(there)],
                   check=True, env={**os.environ, "PYTHONHASHSEED": other}, timeout=120)
    assert here.read_bytes() == there.read_bytes()
    # a second file of the same process (a notebook's second run): OpenCascade labels the
    # parts' occurrences from a counter of the process's life, relabelled 1, 2, ...
    again = tmp_path / "again.step"
    scope["write"](again)
    assert again.read_bytes() == here.read_bytes()
    comp = bd.import_step(here)
    colours = {c.label: tuple(round(x, 3) for x in tuple(c.color)[:3]) for c in comp.children}
    assert colours == {f"P{k:02d}": (0.9, 0.5, 0.1) if k % 2 else (0.2, 0.4, 0.8)
                       for k in range(40)}
    assert len(comp.solids()) == 40
