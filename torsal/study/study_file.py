"""The study file: a base design and the axes to vary, validated before anything runs.

Example (``examples/studies/7a_depth_spacing.toml``)::

    name = "7a: depth and spacing"
    base = "../7a_facade_block.toml"     # relative to the study file
    [axes]                               # full grid over these lists
    "fins.spacing" = [0.4, 0.6, 0.8]
    "fins.depth" = [0.2, 0.4]
    "weights.perp" = [1, 10]
    [run]
    workers = 2                          # a local Dask cluster; or scheduler = "tcp://host:8786"
    fabrication = true                   # false: measure the light only (no parts, STEP, DXF)

With a ``[search]`` table the axes are a search space instead of a grid (lists: choices;
``{ low = 0.2, high = 0.6 }``: a range) and optuna proposes ``trials`` designs, minimizing
or maximizing the named report figures::

    [search]
    trials = 24
    objectives = { "light.blocked_share" = "max", "light.transparency" = "max" }

A ``[pareto]`` table names the two figures the study's Pareto plot and verdict judge by
(default: the sun as the goals ask against the view clear), e.g. the annual stage's::

    [pareto]
    x = "light.annual.daylight.fins.sda_all"                              # sDA, more is better
    y = "light.annual.fins.shading_factor.cooling_gains_avoided_kwh_m2"   # kWh/m2 avoided

Axes are the design file's own dotted keys (``fins.depth``, ``weights.perp``,
``surface.params.nu``). An unknown key, a value of the wrong type or an axis that is not a
key of the design file is a :class:`StudyFileError` naming the key, raised before anything runs.
"""
from __future__ import annotations

import hashlib
import itertools
import json
import tomllib
import types
import typing
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..pipeline.design_file import (DesignFileError, DesignSpec, _format_errors,
                                    absolute_file_paths, load_design_file)

__all__ = ["StudyFileError", "StudySpec", "AxisRange", "RunSpec", "SearchSpec", "Variant",
           "load_study_file", "check_axis", "design_with", "grid_variants", "OBJECTIVE_KEYS",
           "VariantFile", "ParetoSpec", "ANNUAL_OBJECTIVE_KEYS", "LOWER_IS_BETTER"]


class StudyFileError(DesignFileError):
    """A study file that cannot be used; the message names the key and the fix."""


class _Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class AxisRange(_Spec):
    """A continuous axis for a search: ``low`` .. ``high`` (``log``: sampled on a log
    scale; ``step``: a grid step). Integers at both ends give an integer axis."""

    low: float | int
    high: float | int
    log: bool = False
    step: float | int | None = Field(None, gt=0)


class VariantFile(str, Enum):
    """A file a study's variants may write beside their report.json."""

    STEP = "step"
    RHINO_3DM = "3dm"
    IFC = "ifc"
    DXF = "dxf"
    BOM = "bom"
    #: report.html with its figures
    REPORT = "report"


class RunSpec(_Spec):
    workers: int = Field(2, ge=1, description="processes of the local Dask cluster")
    scheduler: str | None = Field(None, description="address of a running Dask scheduler, "
                                  "e.g. tcp://host:8786; default: a local cluster")
    fabrication: bool = Field(True, description="false: a light study; the variants skip the "
                              "fabrication and assembly stages and every fin of the support "
                              "structure is measured (no panel is left out)")
    assembly: bool = Field(True, description="check every variant's assembly (the table's "
                           "buildable column); false: the variants skip the assembly stage")
    files: list[VariantFile] = Field(default_factory=list, description="files each variant "
                                     "writes beside its report.json (step, 3dm, ifc, dxf, bom, "
                                     "report); the table reads none of them, so by default a "
                                     "variant writes none and pays for none")


#: the annual stage's figures a search may optimize (the base design needs [annual] enabled;
#: the daylight's, a [room] too): kWh/m2 on the glazing behind the fins, their shading factor
#: and cooling-season gains avoided, the rooms' sDA and ASE
ANNUAL_OBJECTIVE_KEYS = (
    "light.annual.fins.annual_kwh_m2", "light.annual.fins.cooling_kwh_m2",
    "light.annual.fins.heating_kwh_m2", "light.annual.fins.shading_factor.f_sh_cooling",
    "light.annual.fins.shading_factor.f_sh_heating", "light.annual.fins.shading_factor.f_sh_year",
    "light.annual.fins.shading_factor.cooling_gains_avoided_kwh_m2",
    "light.annual.fins.shading_factor.heating_gains_kept_kwh_m2",
    "light.annual.daylight.fins.sda_all", "light.annual.daylight.fins.ase_all",
)

#: figures of which less is better (a Pareto axis's default ``better``): material, cost,
#: time, irradiance let through in the cooling season, the cooling season's shading factor
#: and ASE's share of the floor with too much direct sun
LOWER_IS_BETTER = frozenset({
    "material_kg", "wall_s", "fabrication.parts", "fabrication.panels", "fabrication.sheets",
    "fabrication.costs.total", "fabrication.costs.per_m2", "fabrication.quantities.cut_m",
    "fabrication.quantities.net_kg", "fabrication.quantities.gross_kg",
    "support.delta_pl_optimized", "support.edges", "light.fin_area_m2",
    "light.annual.fins.cooling_kwh_m2", "light.annual.fins.shading_factor.f_sh_cooling",
    "light.annual.daylight.fins.ase_all",
})

#: report figures a search may optimize (flattened report.json keys), and the study's own
OBJECTIVE_KEYS = (
    "light.blocked_share", "light.transparency", "light.transparency_cone", "light.fin_area_m2",
    "light.view_out", "light.view_clear", "light.goal_share", "light.reflected_to_target", "fabrication.parts", "fabrication.panels", "fabrication.sheets",
    "fabrication.utilization", "support.delta_pl_optimized", "support.edges",
    "fabrication.costs.total", "fabrication.costs.per_m2", "fabrication.quantities.cut_m",
    "fabrication.quantities.net_kg", "fabrication.quantities.gross_kg",
    "congruence.min_torsal_angle_deg", "congruence.min_hyperbolicity", "congruence.line_spread_deg",
    "material_kg", "wall_s",
) + ANNUAL_OBJECTIVE_KEYS


class SearchSpec(_Spec):
    trials: int = Field(gt=0, description="designs to try")
    objectives: dict[str, Literal["max", "min"]] = Field(min_length=1)
    seed: int = 0
    sampler: Literal["nsga2", "tpe"] = "nsga2"


#: the Pareto plot's default axes: the view clear (the design's view.measure) across, the
#: sun as the goals ask (blocked; let through over goals.let_through) up
X_KEY = "light.view_clear"
Y_KEY = "light.goal_share"


class ParetoSpec(_Spec):
    """The two report figures the study's Pareto plot, fronts and verdict judge by
    (:data:`OBJECTIVE_KEYS`), and which way each is better (default: max, min for the
    figures of :data:`LOWER_IS_BETTER`). The standard devices' rows carry the annual stage's
    figures too (their own, from a variant of the same depths and spacings)."""

    x: str = Field(X_KEY, description="across")
    y: str = Field(Y_KEY, description="up")
    x_better: Literal["max", "min"] | None = None
    y_better: Literal["max", "min"] | None = None

    def better(self, axis: str) -> str:
        """``"max"`` or ``"min"`` for ``axis`` "x" or "y"."""
        given = getattr(self, f"{axis}_better")
        return given or ("min" if getattr(self, axis) in LOWER_IS_BETTER else "max")

    @property
    def is_default(self) -> bool:
        """The sun as asked against the view clear, both maximized."""
        return (self.x, self.y, self.better("x"), self.better("y")) == (X_KEY, Y_KEY, "max", "max")


class StudySpec(_Spec):
    name: str = "torsal study"
    base: Path
    axes: dict[str, list[Any] | AxisRange] = Field(min_length=1)
    run: RunSpec = Field(default_factory=RunSpec)
    search: SearchSpec | None = None
    pareto: ParetoSpec = Field(default_factory=ParetoSpec)


@dataclass(frozen=True)
class Variant:
    """One design of a study: its id, its axis values and the validated design."""

    id: str
    axes: dict
    spec: DesignSpec
    toml: str               # the variant's design file (absolute paths), as written

    @property
    def digest(self) -> str:
        """Identity of the variant's design (its file text), for resuming."""
        return hashlib.sha256(self.toml.encode()).hexdigest()[:16]


def _model_in(annotation) -> type[BaseModel] | str | None:
    """The pydantic model (or "dict") a field holds, looking through Optional/Union."""
    origin = typing.get_origin(annotation)
    if origin in (typing.Union, types.UnionType):
        for arg in typing.get_args(annotation):
            found = _model_in(arg)
            if found is not None:
                return found
        return None
    if origin is dict:
        return "dict"
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    return None


def check_axis(key: str) -> None:
    """Raise :class:`StudyFileError` unless ``key`` names a value in the design schema.

    >>> check_axis("fins.depth")
    >>> check_axis("fins.dpeth")
    Traceback (most recent call last):
    ...
    torsal.study.study_file.StudyFileError: axes."fins.dpeth": 'dpeth' is not a key of [fins] (keys: depth, developable_levels, max_fold_at_crossing, optimize, planarity_tol, spacing)
    """
    model: Any = DesignSpec
    parts = key.split(".")
    for k, part in enumerate(parts):
        where = "the design file" if k == 0 else f"[{'.'.join(parts[:k])}]"
        if model == "dict":
            return                       # e.g. surface.params.nu: any key of a free table
        if part not in model.model_fields:
            raise StudyFileError(f'axes."{key}": {part!r} is not a key of {where} '
                                 f"(keys: {', '.join(sorted(model.model_fields))})")
        model = _model_in(model.model_fields[part].annotation)
        if model is None and k < len(parts) - 1:
            raise StudyFileError(f'axes."{key}": {".".join(parts[:k + 1])} is a value, not a table')
    if isinstance(model, type):
        raise StudyFileError(f'axes."{key}" names the table [{key}]; give a key inside it '
                             f"(one of {', '.join(sorted(model.model_fields))})")


def _set(data: dict, key: str, value) -> None:
    *path, last = key.split(".")
    for p in path:
        data = data.setdefault(p, {})
    data[last] = value


def design_with(base: dict, base_dir: Path, axes: dict, *, label: str = "") -> tuple[DesignSpec, str]:
    """The base design (a TOML dict) with ``axes`` set, validated; and its TOML text.

    Raises :class:`StudyFileError` naming the axis whose value the design file rejects."""
    import tomli_w

    # file paths made absolute, so that the variant's design file works from its own folder
    data = absolute_file_paths(json.loads(json.dumps(base)), base_dir)
    for key, value in axes.items():
        _set(data, key, value)
    try:
        spec = DesignSpec.model_validate(data)
    except ValidationError as exc:
        setting = ", ".join(f"{k} = {json.dumps(v)}" for k, v in axes.items())
        raise StudyFileError(_format_errors(exc, f"axes{label} ({setting})")) from None
    return spec, tomli_w.dumps(data)


def grid_variants(spec: StudySpec, base: dict, base_dir: Path) -> list[Variant]:
    """Every combination of the axes' lists, in order (the last axis varies fastest)."""
    keys = list(spec.axes)
    out = []
    for i, values in enumerate(itertools.product(*(spec.axes[k] for k in keys))):
        axes = dict(zip(keys, values))
        design, text = design_with(base, base_dir, axes)
        out.append(Variant(f"{i:03d}", axes, design, text))
    return out


def _read_toml(path: Path, what: str) -> dict:
    if not path.exists():
        raise FileNotFoundError(f"{what} not found: {path}")
    try:
        return tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise StudyFileError(f"{path}: not valid TOML ({exc})") from None


def _check_figures(keys, where: str, base: dict, path) -> None:
    """Report figures a study judges by (``where``: the study-file key naming them) must be
    known (:data:`OBJECTIVE_KEYS`), and the annual stage's in every variant's report: the
    base design's ``[annual] enabled`` (and a ``[room]`` for the daylight's), not set by an
    axis."""
    unknown = [k for k in keys if k not in OBJECTIVE_KEYS]
    if unknown:
        raise StudyFileError(f"{path}: {where}: unknown report key(s) {unknown}; "
                             f"known: {', '.join(OBJECTIVE_KEYS)}")
    wanted = [k for k in keys if k in ANNUAL_OBJECTIVE_KEYS]
    if wanted and not base.get("annual", {}).get("enabled", False):
        raise StudyFileError(f"{path}: {where} {wanted} are the annual stage's: the "
                             "base design needs [annual] enabled = true")
    daylight = [k for k in wanted if ".daylight." in k]
    if daylight and "room" not in base:
        raise StudyFileError(f"{path}: {where} {daylight} are the rooms' daylight: "
                             "the base design needs a [room] table")


def load_study_file(path: str | Path) -> tuple[StudySpec, dict, Path]:
    """Read and validate a study file: its own keys, the base design, every axis name and
    (for a grid) every axis value. Returns the spec, the base design as a TOML dict and the
    base design's folder.

    Raises
    ------
    FileNotFoundError
        The study file or its base design does not exist.
    StudyFileError
        A key, type or value that cannot be used; the message names it.
    """
    path = Path(path)
    data = _read_toml(path, "study file")
    try:
        spec = StudySpec.model_validate(data)
    except ValidationError as exc:
        raise StudyFileError(_format_errors(exc, str(path)).replace(
            "the design file", "the study file")) from None
    base_path = spec.base if spec.base.is_absolute() else path.resolve().parent / spec.base
    try:
        load_design_file(base_path)      # the base alone must be a good design
    except DesignFileError as exc:
        raise StudyFileError(f"{path}: base = {str(spec.base)!r}: {exc}") from None
    spec = spec.model_copy(update={"base": base_path})
    base = _read_toml(base_path, "base design")
    for key, values in spec.axes.items():
        check_axis(key)
        if isinstance(values, list) and not values:
            raise StudyFileError(f'{path}: axes."{key}": an empty list; give at least one value')
        if isinstance(values, AxisRange):
            if spec.search is None:
                raise StudyFileError(f'{path}: axes."{key}": a range needs a [search] table; '
                                     "give a list of values for a grid")
            if not values.low < values.high:
                raise StudyFileError(f'{path}: axes."{key}": low must be below high')
            for end in (values.low, values.high):   # both ends must make a good design
                design_with(base, base_path.parent, {key: end}, label=f' "{key}"')
        elif spec.search is not None:
            for value in values:
                design_with(base, base_path.parent, {key: value}, label=f' "{key}"')
    if spec.search is not None:
        _check_figures(list(spec.search.objectives), "search.objectives", base, path)
    _check_figures([spec.pareto.x, spec.pareto.y], "pareto", base, path)
    return spec, base, base_path.parent
