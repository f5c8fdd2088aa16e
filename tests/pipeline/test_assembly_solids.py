"""Which solids the assembly stage checks (issue 40): those the fabrication stage of the run
built its files from (the solids' workers' copies, no STEP file read), or, where the
fabrication stage came from the cache, the solids of its ``fins.step`` read again: the same
verdicts either way."""
from __future__ import annotations

import sys
from pathlib import Path

from torsal.design import Design
from torsal.pipeline import DEFAULT_PIPELINE
from torsal.pipeline import assembly as stage
from torsal.pipeline.fins import forget_fin_system

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from test_cli import tiny_design  # noqa: E402


def test_the_check_takes_the_built_solids_and_a_cached_fabrications_step(tmp_path, monkeypatch):
    design = tmp_path / "d.toml"
    design.write_text(tiny_design(spacing=1.0).replace("step = false", "step = true"))
    read = []
    real = stage._step_solids

    def spy(path):
        read.append(path.name)
        return real(path)

    monkeypatch.setattr(stage, "_step_solids", spy)
    out = tmp_path / "o"
    forget_fin_system()
    until = DEFAULT_PIPELINE.until("assembly")           # (no report: its section is read)
    first = Design.from_toml(design).run(out, accept_unbuildable=True, pipeline=until
                                         ).report["fabrication"]["assembly"]
    assert read == []                      # the solids the files were written from
    assert (out / "fins.step").exists() and first["pairs_checked"] > 0
    # the fabrication stage from the cache, the assembly stage's result not: its fins.step
    for kept in (out / ".torsal-cache").glob("assembly-*.pkl"):
        kept.unlink()
    forget_fin_system()
    again = Design.from_toml(design).run(out, accept_unbuildable=True, pipeline=until
                                         ).report["fabrication"]["assembly"]
    assert read == ["fins.step"]
    for key in ("pairs_checked", "interfering_pairs", "buildable", "blocked_parts", "parts",
                "steps", "unsupported_parts"):
        assert again[key] == first[key], key
