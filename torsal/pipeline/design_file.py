"""The design file: a small TOML that says what to build, validated with pydantic.

Every key is checked: an unknown key, a wrong type or a value out of range gives a
:class:`DesignFileError` whose message names the key (``fins.spacing``) and what is allowed.
Lengths are in the design's ``units`` (model units); sheet sizes and thickness in millimetres.

Example (``examples/7a_facade_block.toml``)::

    name = "7a facade blocking the afternoon sun"
    units = "m"

    [surface]
    generator = "facade_patch"
    params = { nu = 33, nv = 33 }

    [site]
    latitude = 48.21
    longitude = 16.37
    timezone = "Europe/Vienna"

    [sun]
    start = "2026-06-01"
    end = "2026-08-31"
    hours = [13, 17]

    [goals]
    block = true
    boundary_aligned = true

    [fins]
    spacing = 0.6
    depth = 0.35
"""
from __future__ import annotations

import datetime as _dt
import math
import tomllib
from enum import Enum
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from ..core.errors import TorsalError
from ..core.inputs import read_input
from ..core.units import UNIT_TO_M
from ..geometry.congruence import ZERO_DIRECTION_RTOL
from ..geometry.mesh import MAX_COORDINATE
from ..geometry.optimize import Solver, TorsalAngleBetween, TorsalAngleForm
from ..geometry.support import PLANARITY_TOL, per_family
from ..fabrication.cutting import Process as CuttingProcess, Relief
from ..fabrication.quantities import Rates, check_fastener_rates
from ..fabrication.nesting import (DEFAULT_SEED, DEFAULT_TIME_LIMIT, DEFAULT_TRIES,
                                   SECONDS_PER_SHEET, Nester)
from ..light.annual import (AMBIENT_BOUNCES, AMBIENT_DIVISIONS, BALANCE_TEMPERATURE_C,
                            FIN_REFLECTANCE, GROUND_REFLECTANCE, SeasonRule, SkySubdivision)
from ..light.annual.daylight import (GLAZING_TRANSMITTANCE, OCCUPIED_HOURS, ROOM_BOUNCES,
                                     ROOM_DIVISIONS, ROOM_REFLECTANCE, SHADE_TRANSMITTANCE)
from ..light.view import ViewField

__all__ = [
    "DesignFileError",
    "CostsSpec",
    "DesignSpec",
    "FILE_KEYS",
    "Region",
    "absolute_file_paths",
    "load_design_file",
    "rates_with_file",
    "validate_design",
]

_GENERATORS = ("facade_patch", "canopy", "sphere_patch", "cylinder_patch", "flat_facade")


class DesignFileError(TorsalError, ValueError):
    """A design file that cannot be used; the message names the key or stage and the fix."""


class _Spec(BaseModel):
    # nan and inf (valid TOML floats) are never a sensible length, angle or weight
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


Vec3 = tuple[float, float, float]


class Region(_Spec):
    """A part of the surface: an axis-aligned box (model units) and/or explicit indices.

    A vertex is inside if its position is in the box (each given axis range, ends included);
    a face if its barycenter is. ``vertices`` / ``faces`` list indices directly.
    """

    x: tuple[float, float] | None = None
    y: tuple[float, float] | None = None
    z: tuple[float, float] | None = None
    vertices: list[int] | None = None
    faces: list[int] | None = None

    @model_validator(mode="after")
    def _not_empty(self):
        if all(v is None for v in (self.x, self.y, self.z, self.vertices, self.faces)):
            raise ValueError("a region needs at least one of x, y, z (ranges) or vertices/faces (indices)")
        for name in ("x", "y", "z"):
            r = getattr(self, name)
            if r is not None and r[0] > r[1]:
                raise ValueError(f"range {name} = {list(r)} must be [min, max]")
        return self


class SurfaceSpec(_Spec):
    """Mesh A: a mesh file in model units, or a named generator with parameters."""

    mesh: Path | None = None
    generator: Literal["facade_patch", "canopy", "sphere_patch", "cylinder_patch", "flat_facade"] | None = None
    params: dict[str, float | int] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _generator_params(self):
        if self.generator is None:
            return self
        import inspect

        from ..geometry.surfaces import GENERATORS

        allowed = [n for n, p in inspect.signature(GENERATORS[self.generator]).parameters.items()
                   if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)]
        unknown = sorted(set(self.params) - set(allowed))
        if unknown:
            raise ValueError(f"surface.params {unknown} do not fit generator '{self.generator}'; "
                             f"it takes {', '.join(allowed)}")
        for name in ("nu", "nv"):
            if name in self.params:
                val = self.params[name]
                if val != int(val) or val < 3:
                    raise ValueError(f"surface.params.{name} = {val} must be a whole number of grid "
                                     "vertices, at least 3")
        return self

    @model_validator(mode="after")
    def _one_source(self):
        if (self.mesh is None) == (self.generator is None):
            raise ValueError("give exactly one of surface.mesh (a file) or surface.generator "
                             f"(one of {', '.join(_GENERATORS)})")
        if self.mesh is not None and self.params:
            raise ValueError("surface.params only apply to a generator")
        return self


class SiteSpec(_Spec):
    latitude: float = Field(ge=-90, le=90, description="degrees north")
    longitude: float = Field(ge=-180, le=180, description="degrees east")
    timezone: str = "UTC"
    elevation: float = Field(0.0, description="metres above sea level")
    north_angle: float = Field(0.0, description="degrees; rotates true north counter-clockwise from +y")

    @field_validator("timezone")
    @classmethod
    def _tz(cls, v):
        import zoneinfo

        try:
            zoneinfo.ZoneInfo(v)
        except Exception:
            raise ValueError(f"unknown time zone {v!r}; use an IANA name like 'Europe/Vienna'") from None
        return v


#: the shortest sun.step: a minute already gives 525 600 sun positions a year
MIN_SUN_STEP = "1min"


def _check_step(v: str) -> str:
    """A positive pandas time step of at least :data:`MIN_SUN_STEP` ("1h", "30min", "15min")."""
    import pandas as pd

    try:
        td = pd.Timedelta(pd.tseries.frequencies.to_offset(v))
    except (ValueError, TypeError):
        raise ValueError(f"sun.step = {v!r} is not a time step; write e.g. '1h', '30min' or "
                         "'15min'") from None
    if td < pd.Timedelta(MIN_SUN_STEP):
        raise ValueError(f"sun.step = {v!r} must be at least {MIN_SUN_STEP} (and not zero or "
                         "negative); '1h' is plenty for a sun path")
    return v


def _check_directions(v):
    """Sun directions (site -> sun, z up): at least one, each of non-zero length, none below
    the horizon."""
    if v is None:
        return v
    if len(v) == 0:
        raise ValueError("the list of sun vectors is empty; give at least one [x, y, z]")
    huge = [k for k, d in enumerate(v) if max(map(abs, d), default=0.0) > MAX_COORDINATE]
    if huge:  # squared they overflow: not a zero length, out of range
        raise ValueError(f"sun vectors {huge[:10]} have components beyond {MAX_COORDINATE:g}: "
                         "their squares overflow; give directions of ordinary size, e.g. unit "
                         "vectors (site -> sun)")
    length = [math.hypot(*d) for d in v]  # without squaring: 1e-300 is short, not zero
    zero = [k for k, n in enumerate(length) if n <= ZERO_DIRECTION_RTOL * max(1.0, max(length))]
    if zero:
        what = ("have zero length" if not any(length[k] for k in zero) else
                f"are zero to working precision (length {max(length[k] for k in zero):.3g})")
        raise ValueError(f"sun vectors {zero[:10]} {what}; a direction needs a non-zero "
                         "[x, y, z] (site -> sun)")
    below = [k for k, d in enumerate(v) if d[2] < 0]
    if below:
        # the model frame has z up: such a sun never shines; usually light directions were given
        raise ValueError(f"sun vectors {below[:10]} point below the horizon (z < 0); give "
                         "directions from the site towards the sun (the light travels the other way)")
    return v


#: how far (degrees of great circle) a weather file's place may lie from [site] before the
#: design is refused (unless sun.allow_distant_weather): about 110 km, a neighbouring station
WEATHER_SITE_TOLERANCE_DEG = 1.0


class SunSpec(_Spec):
    """When the sun matters: a date range with a daily window of local hours, a weather file
    (EPW, TMY3 or TMY2) with a hot-hour rule, or explicit sun vectors (site -> sun, model
    frame)."""

    start: _dt.date | None = None
    end: _dt.date | None = None
    hours: tuple[float, float] = (13.0, 17.0)
    step: str = "1h"
    months: list[int] | None = None
    epw: Path | None = None
    weather: Path | None = Field(None, description="weather file, relative to the design file: "
                                 "EPW (.epw), TMY3 (.csv) or TMY2 (.tm2), told by its content; "
                                 "as sun.epw, its hot, sunny hours are the design sun and its "
                                 "year the [annual] stage's weather")
    allow_distant_weather: bool = Field(False, description="use a weather file whose place is "
                                        f"more than {WEATHER_SITE_TOLERANCE_DEG:g} degree (great "
                                        "circle) from [site] anyway; false: such a file is refused")
    min_temperature: float = 26.0
    min_dni: float = 300.0
    vectors: list[Vec3] | None = Field(None, description="site -> sun, model frame (z up); "
                                        "any length but zero (components up to 1e30), z >= 0")

    @field_validator("step")
    @classmethod
    def _step(cls, v):
        return _check_step(v)

    @field_validator("vectors")
    @classmethod
    def _vectors(cls, v):
        return _check_directions(v)

    @property
    def weather_file(self) -> Path | None:
        """The weather file, ``sun.weather`` or ``sun.epw`` (None: a date range or vectors)."""
        return self.weather if self.weather is not None else self.epw

    @property
    def weather_key(self) -> str:
        """The key that names the weather file, for messages."""
        return "sun.weather" if self.weather is not None else "sun.epw"

    @model_validator(mode="after")
    def _one_source(self):
        if self.epw is not None and self.weather is not None:
            raise ValueError("give sun.weather or sun.epw, not both (sun.weather reads EPW, "
                             "TMY3 and TMY2 files)")
        sources = [self.start is not None or self.end is not None, self.weather_file is not None,
                   self.vectors is not None]
        if sum(sources) != 1:
            raise ValueError("give exactly one of: sun.start + sun.end (date range), sun.weather "
                             "or sun.epw (weather file), or sun.vectors (explicit directions)")
        if sources[0] and (self.start is None or self.end is None or self.start > self.end):
            raise ValueError("sun.start and sun.end must both be dates with start <= end")
        if not 0 <= self.hours[0] <= self.hours[1] <= 24:
            raise ValueError(f"sun.hours = {list(self.hours)} must be [h0, h1] with 0 <= h0 <= h1 <= 24")
        if self.months is not None and not all(1 <= m <= 12 for m in self.months):
            raise ValueError("sun.months must be numbers 1..12")
        return self


class SeeThrough(_Spec):
    """Lines over ``region`` pass through ``target`` (Fig. 7c): objects stay visible."""

    target: Vec3
    region: Region


class Stroke(_Spec):
    """A designer's stroke: torsal directions of the faces it crosses follow it (Fig. 7b)."""

    points: list[Vec3] = Field(min_length=2)
    width: float | None = Field(None, gt=0, description="faces within this distance follow it")


class Reflect(_Spec):
    """Reflect sunlight from the fins onto a target region on a ceiling (Fig. 13): a
    horizontal rectangle centred at ``target``, ``size = [w, h]`` along the model's x and y,
    lit from below (default: a square a third of the surface's extent)."""

    target: Vec3
    size: tuple[float, float] | None = Field(
        None, description="[w, h] of the target rectangle along x and y on the ceiling, lit "
        "from below (default: a square a third of the surface's extent)")
    region: Region | None = None

    @field_validator("size")
    @classmethod
    def _size(cls, v):
        if v is not None and not all(x > 0 for x in v):
            raise ValueError(f"goals.reflect.size = {list(v)} must be two positive lengths [w, h]")
        return v


class SunRegion(_Spec):
    """A region with its own sun directions (Fig. 7d)."""

    region: Region
    vectors: list[Vec3]

    @field_validator("vectors")
    @classmethod
    def _vectors(cls, v):
        return _check_directions(v)


class GoalsSpec(_Spec):
    block: bool = True
    let_through: Region | None = Field(None, description="lines parallel to the light here (Fig. 9)")
    see_through: list[SeeThrough] = Field(default_factory=list)
    reflect: Reflect | None = None
    strokes: list[Stroke] = Field(default_factory=list)
    boundary_aligned: bool = Field(False, description="torsal directions follow the boundary (Fig. 7a)")
    sun_regions: list[SunRegion] = Field(default_factory=list)


class WeightsSpec(_Spec):
    """Energy weights of eq. (9); unset ones take the paper's Fig. 12 defaults."""

    norm: float | None = Field(None, ge=0)
    fair: float | None = Field(None, ge=0)
    fair_torsal: float | None = Field(None, ge=0)
    perp: float | None = Field(None, ge=0)
    par: float | None = Field(None, ge=0)
    plane: float | None = Field(None, ge=0)
    dir: float | None = Field(None, ge=0)
    through: float | None = Field(None, ge=0)
    closeness: float | None = Field(None, ge=0)


class ConstraintsSpec(_Spec):
    hyperbolic: bool = True
    hyperbolic_margin: float = Field(0.0, ge=0)
    min_torsal_angle: float | None = Field(None, gt=0, lt=90, description="degrees; the torsal "
                                           "planes (the fins of the two families) cross at this "
                                           "angle or more, or with torsal_angle_between = "
                                           "\"directions\" the torsal directions in the face are "
                                           "this far apart (c_ang, paper 4.1)")
    torsal_angle_form: TorsalAngleForm | None = Field(
        None, description="how min_torsal_angle enters the NLP: split (the optimizer's default) "
        "or lift (half the iterations, rougher lines), see CongruenceProblem.min_torsal_angle")
    torsal_angle_between: TorsalAngleBetween = Field(
        TorsalAngleBetween.PLANES, description="which angle min_torsal_angle bounds: planes (the "
        "angle the torsal planes, and so the fins of the two families, cross at) or directions "
        "(the angle between the torsal directions in the face, c_ang as the paper states it); "
        "report.json gives both, measured")
    solver: Solver = Field(Solver.AUTO, description="the congruence optimizer: auto (the augmented "
                           "Lagrangian for a design with min_torsal_angle or another bound that binds, IPOPT "
                           "where hyperbolic is the only inequality or there is none, the "
                           "augmented Lagrangian continuing where IPOPT's pass without the "
                           "inequalities misses hyperbolicity), alm, "
                           "ipopt (the solver of record) or lbfgs (the paper's baseline); report.json "
                           "says which one produced the design")
    certify: bool = Field(False, description="IPOPT certifies the augmented Lagrangian's answer as a "
                          "KKT point (all constraints, warm start from its answer and multipliers)")
    max_iter: int = Field(500, gt=0, description="iteration limit: Newton steps of the augmented "
                          "Lagrangian, IPOPT iterations; counts, not time, decide the result; a "
                          "feasible iterate at the limit is kept (its status says so)")
    jit: bool | None = Field(None, description="compile the optimizer's kernels with the C compiler "
                             "(once per machine, cached); default: for surfaces of 500 vertices or more")
    max_seconds: float | None = Field(None, gt=0, description="a safety net only: wall-time limit "
                                      "of the congruence solve; at the limit the best iterate whose "
                                      "constraints hold as measured is kept and report.json says the "
                                      "result depends on the machine's load (congruence.time_limited)")


#: what fins.spacing and fins.depth take: one length for both torsal families, or
#: [family 0, family 1]
FamilyLength = float | tuple[float, float]


def _family_lengths(v, key: str):
    """``v`` as given when it is one positive length or a list of two (family 0, family 1);
    a ValueError naming ``key`` and the two forms otherwise."""
    forms = (f"give one positive length (both families) or a list of two [family 0, family 1], "
             f"e.g. {key} = [0.6, 1.2]")
    if isinstance(v, (list, tuple)):
        if len(v) != 2:
            raise ValueError(f"{key} is a list of {len(v)}; {forms}")
        values = list(v)
    else:
        values = [v]
    for x in values:
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            raise ValueError(f"Input should be a valid number, not {x!r}; {forms}")
        if not math.isfinite(x) or x <= 0:
            raise ValueError(f"Input should be greater than 0, not {x!r}; {forms}")
    return tuple(float(x) for x in values) if isinstance(v, (list, tuple)) else float(v)


class FinsSpec(_Spec):
    """The support structure: each torsal family's fin spacing and depth (paper 4.2: the
    spacing of the torsal-line families; eq. 8: the fin depth along the lines), and how
    the fins are planarized. A single number means both families; ``[s0, s1]`` lets the
    second family become a sparser (or shallower) structure."""

    spacing: FamilyLength = Field(description="model units; distance of neighbouring fins of "
                                  "one family: one length for both, or [family 0, family 1] "
                                  "(e.g. [0.6, 1.2]: a sparse second family); the standard "
                                  "devices take family 0's, an egg-crate's crossing family "
                                  "family 1's")
    depth: FamilyLength = Field(description="model units; fin depth along the lines: one "
                                "length for both families, or [family 0, family 1]; the parts "
                                "of each family are as deep as its fins")
    optimize: bool = True
    planarity_tol: float = Field(PLANARITY_TOL, gt=0)
    max_fold_at_crossing: float | None = Field(
        None, gt=0, lt=180, description="degrees: a strip folding more than this where a strip "
        "of the other family crosses it is named in report.json (support.joinery) and split "
        "there with a connector instead of slotted; default: the joinery's limit "
        "(MAX_CROSSING_FOLD, 10 degrees)")
    developable_levels: int = Field(0, ge=0, le=3)

    @field_validator("spacing", mode="before")
    @classmethod
    def _spacing(cls, v):
        return _family_lengths(v, "fins.spacing")

    @field_validator("depth", mode="before")
    @classmethod
    def _depth(cls, v):
        return _family_lengths(v, "fins.depth")

    @property
    def spacings(self) -> tuple[float, float]:
        """``(s0, s1)``: the fin spacing of family 0 and of family 1, model units.

        >>> FinsSpec(spacing=[0.6, 1.2], depth=0.3).spacings
        (0.6, 1.2)
        """
        return per_family(self.spacing, "fins.spacing")

    @property
    def depths(self) -> tuple[float, float]:
        """``(d0, d1)``: the fin depth of family 0 and of family 1, model units.

        >>> FinsSpec(spacing=0.6, depth=0.3).depths
        (0.3, 0.3)
        """
        return per_family(self.depth, "fins.depth")


class FamilySplitName(str, Enum):
    egg_crate = "egg-crate"
    family0_continuous = "family0-continuous"


class MaterialSpec(_Spec):
    name: str = "aluminium"
    thickness_mm: float = Field(3.0, gt=0)
    density: float = Field(2700.0, gt=0, description="kg/m^3")
    sheet_mm: tuple[float, float] = (2500.0, 1250.0)
    gap_mm: float = Field(5.0, ge=0)
    clearance_mm: float = Field(0.5, ge=0)
    family_split: FamilySplitName = FamilySplitName.egg_crate

    @field_validator("sheet_mm")
    @classmethod
    def _sheet(cls, v):
        if min(v) <= 0:
            raise ValueError("sheet_mm must be two positive lengths [width, height]")
        return v


class CuttingSpec(_Spec):
    """How the sheets are cut: the DXF's CUT layer is the toolpath for this process
    (defaults per process in :mod:`torsal.fabrication.cutting`)."""

    process: CuttingProcess = CuttingProcess.LASER
    kerf_mm: float | None = Field(None, ge=0, description="width of the cut; unset: the "
                                  "process's (laser 0.2, waterjet 1.0, router the tool diameter)")
    tool_diameter_mm: float | None = Field(None, gt=0, description="diameter of the beam, jet or "
                                           "bit; unset: the process's (laser 0.2, waterjet 1.0, "
                                           "router 3.175)")
    relief: Relief | None = Field(None, description="relief at inner slot corners; unset: "
                                  "dogbone for a router, none otherwise")


class NestingSpec(_Spec):
    """How the parts are nested on the sheets."""

    # unset: the rows (deterministic, seconds) on every run, the search for the final cut
    nester: Nester | None = None
    final_cut: bool = Field(False, description="nest for yield with the deterministic search "
                            "(counted tries, never the clock; a minute at most for a thousand "
                            "parts, kept in the design's cache) instead of the rows; the command "
                            "line's --final-cut does the same")
    tries: int = Field(DEFAULT_TRIES, ge=0, description="repacks the final cut's search may make")
    time_limit_s: float | None = Field(None, ge=3, description="a safety net only: wall clock the "
                                       "search or the sparrow nester may take; a result it cuts "
                                       "says so (fabrication.nesting.time_limited); sparrow "
                                       f"unset: {SECONDS_PER_SHEET:g} s per sheet the parts' "
                                       f"area needs, at most {DEFAULT_TIME_LIMIT:g} s")
    seed: int = Field(DEFAULT_SEED, ge=0, description="the sparrow nester's seed")
    rotation_step_deg: float | None = Field(None, gt=0, le=360, description="degrees; parts "
                                            "turn in steps of this; unset: any rotation")
    margin_mm: float = Field(10.0, ge=0, description="sheet left between the cuts and the "
                             "sheet edge")


class OutputsSpec(_Spec):
    step: bool = True
    rhino_3dm: bool = True
    ifc: bool = True
    dxf: bool = True
    bom: bool = True
    renders: bool = True
    light_samples: int = Field(1500, ge=2, description="sample points of the light measurement "
                               "(half of them for the view)")


class ViewMeasure(str, Enum):
    occupant = "occupant"
    normal = "normal"


_VIEW = ViewField()     # the view measure's defaults: one source (torsal.light.view)


class ViewSpec(_Spec):
    """How the view out is measured: the report's ``light.view_clear`` and a study's x axis
    (both measures are always reported; see torsal.light.view for the definitions)."""

    measure: ViewMeasure = Field(ViewMeasure.occupant, description="occupant: share of the "
                                 "sight lines from occupant eye points behind A that pass the "
                                 "fins (view out); normal: share of points on A with a free "
                                 "line along the normal")
    eye_height_m: float = Field(_VIEW.eye_height, gt=0, description="metres; eye height above "
                                "the foot of a facade and of each storey (seated)")
    storey_height_m: float = Field(_VIEW.storey_height, gt=0, description="metres; floor to "
                                   "floor: a row of eye points per storey of a facade")
    distances_m: list[float] = Field(list(_VIEW.distances), min_length=1, description="metres; "
                                     "how far behind A the eye points are (below a canopy)")
    grid_m: float = Field(_VIEW.grid, gt=0, description="metres; eye points every this far "
                          "across A")
    azimuth_deg: float = Field(_VIEW.azimuth, gt=0, le=90, description="degrees; half width "
                               "of the field of sight lines about the view axis")
    elevation_deg: tuple[float, float] = Field(_VIEW.elevation, description="degrees; "
                                               "[low, high] of the field, from the horizon")
    step_deg: float = Field(_VIEW.step, gt=0, le=30, description="degrees; cell size of the "
                            "field of sight lines")

    @field_validator("distances_m")
    @classmethod
    def _distances(cls, v):
        if not all(d > 0 for d in v):
            raise ValueError(f"view.distances_m = {v} must all be positive")
        return v

    @model_validator(mode="after")
    def _elevation(self):
        lo, hi = self.elevation_deg
        if not -90 <= lo < hi <= 90:
            raise ValueError(f"view.elevation_deg = {list(self.elevation_deg)} must be [low, high] "
                             "with -90 <= low < high <= 90")
        return self

    def field(self, metres_per_unit: float) -> ViewField:
        """The :class:`~torsal.light.view.ViewField` in model units."""
        return ViewField(self.eye_height_m, self.storey_height_m, tuple(self.distances_m),
                         self.grid_m, self.azimuth_deg, tuple(self.elevation_deg),
                         self.step_deg).in_units(metres_per_unit)


class SubstructureSpec(_Spec):
    """A second, aligned congruence (Fig. 11): a steel substructure on a surface offset
    behind A whose torsal directions coincide with the fins' (f_extra)."""

    offset: float = Field(0.3, gt=0, description="distance behind A along -normal, model units")
    weight: float | None = Field(None, ge=0, description="w_extra; unset: the optimizer's "
                                 "default (torsal.geometry.optimize.DEFAULT_WEIGHTS['align'])")
    depth: float = Field(0.15, gt=0, description="beam depth along its lines, model units")


class CostsSpec(_Spec):
    """The user's rates (issue 42): with them report.json prices the design's bill of
    quantities (``fabrication.costs``); without this table there is no price. Every rate is
    in ``currency`` per unit of its quantity (see :mod:`torsal.fabrication.quantities.price`).

    ``file = "rates.toml"`` reads the rates from the ``[costs]`` table of that TOML file
    (relative to the design file): one workshop's rates shared by many designs; a key given
    beside ``file`` is taken over the file's (in ``cut_per_m`` and ``fasteners`` key by key)."""

    @model_validator(mode="before")
    @classmethod
    def _rates_file(cls, data):
        if isinstance(data, dict) and "file" in data:
            data = rates_with_file(data)
        return data

    currency: str = Field("", description="label of the rates' currency in the report, e.g. EUR")
    material_per_kg: float | None = Field(None, ge=0, description="per kg of the sheets used "
                                          "(gross); give this or material_per_sheet")
    material_per_sheet: float | None = Field(None, ge=0, description="per sheet used; give "
                                             "this or material_per_kg")
    cut_per_m: dict[CuttingProcess, float] = Field(
        min_length=1, description="per metre of contour cut, by process, e.g. { laser = 1.5 }; "
        "the design's cutting.process needs a rate")
    per_pierce: float = Field(ge=0, description="per closed contour cut (outline, inner "
                              "cut-out, hole cut)")
    per_bend: float = Field(ge=0, description="per bend (fold of a part)")
    fasteners: dict[str, float] = Field(description="per fastener, by kind (bolt and anchor "
                                        "both needed) and by size and kind where a size costs "
                                        "otherwise, e.g. { bolt = 0.3, anchor = 2.5, "
                                        "\"M8 anchor\" = 2.8 }")
    per_minute: float = Field(ge=0, description="per minute of assembly (placing, fastening, "
                              "drilling)")
    minutes_per_part: float = Field(ge=0, description="minutes to place a part")
    minutes_per_fastener: float = Field(ge=0, description="minutes to set a bolt or anchor")
    minutes_per_hole_drilled: float = Field(ge=0, description="minutes to drill a hole the "
                                            "cutting process does not cut (no wider than the tool)")

    @field_validator("fasteners")
    @classmethod
    def _fasteners(cls, v):
        check_fastener_rates(v)
        return v

    @model_validator(mode="after")
    def _rates_hold(self):
        self.rates()      # its rules: one material rate, every rate a number >= 0
        return self

    def rates(self) -> Rates:
        """The :class:`~torsal.fabrication.quantities.Rates` of this table."""
        return Rates(**self.model_dump(exclude_none=True))


#: the design file's keys that name a file, ``(table, key)``: relative to the design file
FILE_KEYS = (("surface", "mesh"), ("sun", "epw"), ("sun", "weather"), ("costs", "file"))


def absolute_file_paths(data: dict, base: Path) -> dict:
    """``data`` (a design file's tables) with its relative file paths (:data:`FILE_KEYS`) made
    absolute against the folder ``base``, in place: for a design written to another folder
    (a study's variant, the FreeCAD object's job). Values that are not strings are left for
    validation to report.

    >>> absolute_file_paths({"sun": {"epw": "site.epw"}}, Path("/d"))["sun"]["epw"]
    '/d/site.epw'
    """
    for table, key in FILE_KEYS:
        p = data.get(table, {}).get(key)
        if isinstance(p, str) and not Path(p).is_absolute():
            data[table][key] = str((base / p).resolve())
    return data


def rates_with_file(costs: dict) -> dict:
    """The ``[costs]`` table ``costs`` with its ``file`` read (see :class:`CostsSpec`): the
    ``[costs]`` table of that TOML file, the keys given beside ``file`` over its own. A
    relative path is taken from the working folder (:func:`load_design_file` makes it the
    design file's).

    Raises
    ------
    ValueError
        The file is missing, not TOML, or has no ``[costs]`` table (or one with a ``file``).
    """
    costs = dict(costs)
    given = costs.pop("file")
    if not isinstance(given, str):
        raise ValueError(f"costs.file must be the path of a TOML file with a [costs] table "
                         f"(got {given!r})")
    path = Path(given)
    try:
        table = tomllib.loads(path.read_text())
    except OSError as exc:
        raise ValueError(f"costs.file: cannot read {path} ({exc.strerror or exc}); give the "
                         "path of a TOML file with a [costs] table, relative to the design "
                         "file") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"costs.file: {path} is not valid TOML ({exc})") from None
    shared = table.get("costs")
    if not isinstance(shared, dict) or "file" in shared:
        raise ValueError(f"costs.file: {path} needs a [costs] table of rates (without a "
                         "file key of its own)")
    out = {**shared, **costs}
    for key in ("cut_per_m", "fasteners"):
        if isinstance(shared.get(key), dict) and isinstance(costs.get(key), dict):
            out[key] = {**shared[key], **costs[key]}
    return out


class AnnualSpec(_Spec):
    """Annual solar irradiance on the glazing by Radiance (report ``light.annual``): the bare
    surface, the fins as built and each standard device, over the weather year of
    ``sun.weather`` (or ``sun.epw``) or, without one, the site's clear-sky year (see
    torsal.light.annual)."""

    enabled: bool = Field(False, description="compute it (Radiance, from the pyradiance "
                          "package; seconds to a minute)")
    points: int = Field(300, ge=1, description="sample points on the surface (area-uniform, "
                        "seeded), each moved just behind it and facing out")
    ambient_bounces: int = Field(AMBIENT_BOUNCES, ge=1, le=8, description="Radiance -ab: 1 "
                                 "counts the sky and the ground seen directly (black fins), "
                                 "each more one diffuse reflection off the fins")
    ambient_divisions: int = Field(AMBIENT_DIVISIONS, ge=16, description="Radiance -ad: "
                                   "hemisphere samples per point")
    sky: SkySubdivision = Field(SkySubdivision.TREGENZA, description="sky patches of the sky "
                                "matrix: tregenza (145), reinhart (577) or reinhart4 (2305); the "
                                "sun is a source of its own every hour whichever is chosen")
    fin_reflectance: float = Field(FIN_REFLECTANCE, ge=0, lt=1, description="diffuse solar "
                                   "reflectance of the fins and devices (both sides)")
    ground_reflectance: float = Field(GROUND_REFLECTANCE, ge=0, le=1, description="the "
                                      "ground's solar reflectance (albedo)")
    season: SeasonRule = Field(SeasonRule.AUTO, description="which hours are the cooling "
                               "season: months (May-September north of the equator, "
                               "November-March south), temperature (days whose mean outdoor "
                               "temperature is above balance_temperature_c; needs a weather "
                               "file, sun.weather or sun.epw) or auto (temperature with a "
                               "weather file, else months)")
    balance_temperature_c: float = Field(BALANCE_TEMPERATURE_C, description="degC; the "
                                         "temperature rule's threshold on a day's mean")
    devices: bool = Field(True, description="also behind each standard device the light "
                          "stage compares the fins with (louvers, vertical fins, egg-crates)")


class RoomSpec(_Spec):
    """The rooms behind a facade, one per storey, for daylight (report
    ``light.annual.daylight``, with ``[annual] enabled``): sDA 300/50% and ASE 1000/250 as IES
    LM-83 defines them, for the bare facade, behind the fins and behind each device (see
    torsal.light.annual.daylight). Each room is a box behind the facade's innermost point, as
    wide as the facade, glazed from sill to head across its width."""

    depth: float = Field(gt=0, description="model units; from the window wall to the back wall")
    height: float = Field(gt=0, description="model units; floor to ceiling")
    storey_height: float | None = Field(None, gt=0, description="model units; floor to floor, "
                                       "the first floor at the facade's foot; unset: "
                                       "view.storey_height_m")
    sill: float = Field(0.0, ge=0, description="model units; the glazing's bottom above the floor")
    head: float | None = Field(None, gt=0, description="model units; the glazing's top above "
                               "the floor; unset: the ceiling")
    reflectance: tuple[float, float, float] = Field(ROOM_REFLECTANCE, description="floor, walls, "
                                                    "ceiling (visible; LM-83's 0.2, 0.5, 0.7)")
    transmittance: float = Field(GLAZING_TRANSMITTANCE, gt=0, le=1, description="the glazing's "
                                 "visible transmittance at normal incidence")
    shade_transmittance: float = Field(SHADE_TRANSMITTANCE, ge=0, lt=1, description="the "
                                       "closed blinds' visible transmittance, a share of all "
                                       "the light the window lets in (LM-83's sDA draws them; "
                                       "the standard asks for the real product's; default "
                                       "Ladybug Tools' 5 %)")
    occupied_hours: tuple[float, float] = Field(OCCUPIED_HOURS, description="h; the occupied "
                                                "hours of every day, local standard time "
                                                "(LM-83's 8 to 18)")
    ambient_bounces: int = Field(ROOM_BOUNCES, ge=1, le=12, description="Radiance -ab in the "
                                 "room (LM-83's 6)")
    ambient_divisions: int = Field(ROOM_DIVISIONS, ge=16, description="Radiance -ad in the room "
                                   "(LM-83's 1000)")

    @model_validator(mode="after")
    def _room(self):
        if not all(0 <= r < 1 for r in self.reflectance):
            raise ValueError(f"room.reflectance = {list(self.reflectance)} must be three "
                             "values in [0, 1)")
        lo, hi = self.occupied_hours
        if not 0 <= lo < hi <= 24:
            raise ValueError(f"room.occupied_hours = {list(self.occupied_hours)} must be [h0, h1] "
                             "with 0 <= h0 < h1 <= 24")
        head = self.height if self.head is None else self.head
        if not self.sill < head <= self.height:
            raise ValueError("the glazing must be within the room: room.sill < room.head "
                             "<= room.height")
        return self


class DesignSpec(_Spec):
    """A whole design file."""

    name: str = "torsal design"
    units: Literal["m", "cm", "mm", "ft", "in"] = "m"
    surface: SurfaceSpec
    site: SiteSpec | None = None
    sun: SunSpec
    goals: GoalsSpec = Field(default_factory=GoalsSpec)
    weights: WeightsSpec = Field(default_factory=WeightsSpec)
    constraints: ConstraintsSpec = Field(default_factory=ConstraintsSpec)
    fins: FinsSpec
    material: MaterialSpec = Field(default_factory=MaterialSpec)
    cutting: CuttingSpec = Field(default_factory=CuttingSpec)
    nesting: NestingSpec = Field(default_factory=NestingSpec)
    outputs: OutputsSpec = Field(default_factory=OutputsSpec)
    view: ViewSpec = Field(default_factory=ViewSpec, description="how the view out is measured "
                           "(report light.view_clear, a study's x axis)")
    substructure: SubstructureSpec | None = None
    annual: AnnualSpec = Field(default_factory=AnnualSpec, description="annual solar "
                               "irradiance on the glazing in kWh/m2 by Radiance (report "
                               "light.annual)")
    room: RoomSpec | None = Field(None, description="rooms behind the facade for daylight "
                                  "(sDA, ASE) in the annual stage; unset: none")
    costs: CostsSpec | None = Field(None, description="the user's rates: a price of the design "
                                    "from its bill of quantities; unset: no price")

    @model_validator(mode="after")
    def _site_for_dates(self):
        if self.sun.start is not None and self.site is None:
            raise ValueError("a [site] (latitude, longitude, timezone) is needed to place the sun "
                             "for sun.start/sun.end")
        return self

    @model_validator(mode="after")
    def _cut_rate_for_the_process(self):
        if self.costs is not None and self.cutting.process not in self.costs.cut_per_m:
            raise ValueError(f"costs.cut_per_m has no rate for the design's cutting.process "
                             f"{self.cutting.process.value!r}; give e.g. "
                             f"cut_per_m = {{ {self.cutting.process.value} = 1.5 }}")
        return self

    @property
    def metres_per_unit(self) -> float:
        return UNIT_TO_M[self.units]


def _format_errors(exc: ValidationError, source: str) -> str:
    lines = [f"{source}: {exc.error_count()} problem(s) in the design file"]
    for err in exc.errors():
        key = ".".join(str(p) for p in err["loc"]) or "(top level)"
        msg = err["msg"].removeprefix("Value error, ")
        if err["type"] == "extra_forbidden":
            msg = "unknown key (check the spelling; the README lists every key)"
        if err["type"] == "missing":
            lines.append(f"  {key}: missing (required)")
        elif isinstance(err.get("input"), dict):  # a table-level rule: the message names the keys
            lines.append(f"  {key}: {msg}")
        else:
            lines.append(f"  {key}: {msg} (got {err.get('input')!r})")
    return "\n".join(lines)


def validate_design(data: dict, *, source: str = "design") -> DesignSpec:
    """A design from its data (the TOML's tables as dicts), checked as a design file is:
    an unknown key, a wrong type or a value out of range raises :class:`DesignFileError`
    naming each key; ``source`` starts the message (a file's path, ``"edit"``).

    >>> validate_design({"surface": {"generator": "facade_patch"}, "sun": {"vectors": [[0, -1, 1]]},
    ...                  "fins": {"spacing": 0.6, "depth": 0.3}}).fins.spacing
    0.6
    >>> validate_design({"surface": {"generator": "facade_patch"}, "sun": {"vectors": [[0, -1, 1]]},
    ...                  "fins": {"spacing": -1, "depth": 0.3}}, source="edit")
    Traceback (most recent call last):
    ...
    torsal.pipeline.design_file.DesignFileError: edit: 1 problem(s) in the design file
      fins.spacing: Input should be greater than 0, not -1; give one positive length (both families) or a list of two [family 0, family 1], e.g. fins.spacing = [0.6, 1.2] (got -1)
    """
    try:
        return DesignSpec.model_validate(data)
    except ValidationError as exc:
        raise DesignFileError(_format_errors(exc, source)) from None


def load_design_file(path: str | Path) -> DesignSpec:
    """Read and validate a TOML design file; relative file paths in it are resolved against
    the file's folder.

    Raises
    ------
    FileNotFoundError
        The file does not exist (a :class:`~torsal.core.inputs.MissingInputError`).
    InputFileError
        The path is a folder or cannot be read.
    DesignFileError
        Invalid TOML or an invalid key/value; the message names each offending key.
    """
    path = Path(path)
    text = read_input(path, "design file", text=True)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise DesignFileError(f"{path}: not valid TOML ({exc})") from None
    costs = data.get("costs")
    if isinstance(costs, dict) and isinstance(costs.get("file"), str):
        data["costs"] = {**costs, "file": str(path.resolve().parent / costs["file"])}
    try:
        spec = DesignSpec.model_validate(data)
    except ValidationError as exc:
        raise DesignFileError(_format_errors(exc, str(path))) from None
    base = path.resolve().parent

    def resolve(p):
        return p if p is None or p.is_absolute() else (base / p)

    surface = spec.surface.model_copy(update={"mesh": resolve(spec.surface.mesh)})
    sun = spec.sun.model_copy(update={"epw": resolve(spec.sun.epw),
                                      "weather": resolve(spec.sun.weather)})
    spec = spec.model_copy(update={"surface": surface, "sun": sun})
    if spec.surface.mesh is not None and not spec.surface.mesh.exists():
        raise DesignFileError(f"{path}: surface.mesh: file not found: {spec.surface.mesh}")
    if spec.sun.weather_file is not None and not spec.sun.weather_file.exists():
        raise DesignFileError(f"{path}: {spec.sun.weather_key}: file not found: "
                              f"{spec.sun.weather_file}")
    return spec
