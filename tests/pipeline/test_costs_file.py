"""The design file's ``[costs] file``: one workshop's rates shared by many designs (issue 42),
and the examples priced with ``examples/workshop_rates.toml``."""
from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from torsal.fabrication.cutting import Process
from torsal.pipeline.design_file import DesignFileError, load_design_file

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
#: a small design (written with :func:`_toml`) and a workshop's rates
DESIGN = {"name": "test", "surface": {"generator": "facade_patch", "params": {"nu": 9, "nv": 5}},
          "sun": {"vectors": [[0, -1, 1]]}, "fins": {"spacing": 1.5, "depth": 0.4}}
SHOP = {"currency": "EUR", "material_per_kg": 5.0, "cut_per_m": {"laser": 1.45, "router": 2.0},
        "per_pierce": 0.15, "per_bend": 0.58, "fasteners": {"bolt": 0.35, "anchor": 2.8},
        "per_minute": 1.16, "minutes_per_part": 3.0, "minutes_per_fastener": 1.0,
        "minutes_per_hole_drilled": 0.5}


def _toml(**tables) -> str:
    import tomli_w

    return tomli_w.dumps({**DESIGN, **tables})


def _examples() -> list[Path]:
    return sorted(p for p in EXAMPLES.glob("*.toml"))


def test_every_example_is_priced_with_the_workshop_rates():
    shared = tomllib.loads((EXAMPLES / "rates" / "workshop_rates.toml").read_text())["costs"]
    assert len(_examples()) == 8
    for path in _examples():
        costs = load_design_file(path).costs
        assert costs is not None, path.name
        rates = costs.rates()
        assert rates.currency == "EUR"
        assert rates.cut_per_m == {Process.LASER: shared["cut_per_m"]["laser"]}
        assert rates.fasteners == shared["fasteners"]
        for key in ("per_pierce", "per_bend", "per_minute", "minutes_per_part",
                    "minutes_per_fastener", "minutes_per_hole_drilled"):
            assert getattr(rates, key) == shared[key], (path.name, key)
        # example 10 is plywood: its own material rate beside the file's
        own = tomllib.loads(path.read_text())["costs"].get("material_per_kg")
        assert rates.material_per_kg == (shared["material_per_kg"] if own is None else own)
    assert load_design_file(EXAMPLES / "10_developable_strips.toml").costs.material_per_kg != \
        shared["material_per_kg"]


def test_a_key_beside_the_file_is_taken_over_the_files(tmp_path, monkeypatch):
    (tmp_path / "rates").mkdir()
    (tmp_path / "rates" / "shop.toml").write_text(_toml(costs=SHOP))
    design = tmp_path / "d.toml"
    design.write_text(_toml(costs={"file": "rates/shop.toml", "per_pierce": 0.4,
                                   "fasteners": {"M8 anchor": 3.1}, "cut_per_m": {"laser": 2.5}}))
    monkeypatch.chdir("/")                   # the file is the design file's, not the cwd's
    rates = load_design_file(design).costs.rates()
    assert rates.per_pierce == 0.4 and rates.per_bend == 0.58
    assert rates.fasteners == {"bolt": 0.35, "anchor": 2.8, "M8 anchor": 3.1}
    assert rates.cut_per_m == {Process.LASER: 2.5, Process.ROUTER: 2.0}
    assert rates.fastener_rate("M8 anchor") == 3.1 and rates.fastener_rate("M6 bolt") == 0.35


def test_the_design_does_not_keep_the_files_path(tmp_path):
    (tmp_path / "shop.toml").write_text(_toml(costs=SHOP))
    design = tmp_path / "d.toml"
    design.write_text(_toml(costs={"file": "shop.toml"}))
    spec = load_design_file(design)
    inline = tmp_path / "e.toml"
    inline.write_text(_toml(costs=SHOP))
    # the same rates as written inline: the same design (and cache keys) wherever the file is
    assert spec.model_dump(mode="json") == load_design_file(inline).model_dump(mode="json")


@pytest.mark.parametrize("text, words", [
    (None, ["costs.file", "cannot read", "nowhere.toml"]),
    ("[rates]\nper_pierce = 0.1\n", ["needs a [costs] table"]),
    ("[costs]\nfile = 'other.toml'\n", ["without a file key"]),
    ("[costs\n", ["not valid TOML"]),
])
def test_a_bad_rates_file_is_named(tmp_path, text, words):
    name = "nowhere.toml" if text is None else "shop.toml"
    if text is not None:
        (tmp_path / name).write_text(text)
    design = tmp_path / "d.toml"
    design.write_text(_toml(costs={"file": name}))
    with pytest.raises(DesignFileError) as err:
        load_design_file(design)
    for w in words:
        assert w in str(err.value)


def test_a_study_variant_reads_the_rates_from_its_own_folder(tmp_path):
    from torsal.study.study_file import design_with

    (tmp_path / "shop.toml").write_text(_toml(costs=SHOP))
    base = tomllib.loads(_toml(costs={"file": "shop.toml"}))
    spec, text = design_with(base, tmp_path, {"fins.depth": 0.3})
    assert spec.costs.per_minute == 1.16 and spec.fins.depth == 0.3
    assert str(tmp_path / "shop.toml") in text
