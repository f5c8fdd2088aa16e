"""Annual solar irradiance on the glazing behind the fins, by Radiance.

What reaches a sample point on the glazing over a weather year, in kWh/m^2, from four sources:

- ``sun``: the direct sun. Every hour's sun is a distant source of its own (0.533 degrees,
  the sun's disc) in an ``rcontrib`` run without interreflection (``-ab 0``): the coefficient
  of sun ``j`` at a point is ``cos(incidence) * visible``, and the hour's direct irradiance
  ``DNI * coefficient``. (``rcontrib`` drops sources of zero radiance and, unless ``-V+`` is
  set and each sun's radiance is a large constant, suns within about a degree of the horizon:
  every sun has radiance :data:`SUN_RADIANCE`, and the coefficients are divided by it and by
  the sun's solid angle.)
- ``sky`` and ``ground``: daylight coefficients. ``rcontrib -I+`` counts, for every point,
  what each sky patch (``reinhartb.cal``) and the ground (a modifier of its own: the bin
  file gives everything below the horizon the bin -1) of unit radiance contributes, seen
  directly (``-ab 1``) and after ``ambient_bounces - 1`` diffuse reflections off the fins (of
  reflectance ``fin_reflectance``); the hourly product with the sky matrix
  (:attr:`SkyYear.sky`, ``gendaymtx -s``) gives the irradiance.
- ``sun reflected``: sunlight the fins reflect onto the glazing (with ``ambient_bounces`` of 2
  or more). As the five-phase method has it (Subramaniam and Mistrick): the daylight
  coefficients with the bounces, minus those of the patches seen directly, times the sun
  spread over its patches (:attr:`SkyYear.sun_patches`). The difference of two sampled
  coefficients: a point's value can be slightly negative; the mean over many points is not.

The hourly products are summed straight into groups of hours (:func:`hourly_sums`: a sparse
(T, K) indicator, numpy): months and seasons here, each occupied hour for daylight
(:mod:`torsal.light.annual.daylight`). Sampling is quasi-random (``-u-``): a run repeats
exactly. Suns behind every point are not traced. The building itself is not in the scene: a
point sees the half-space
in front of its glazing, the ground an infinite plane of radiance
``ground_reflectance * GHI / pi`` (the ground the fins shade is not darker), as
``pvlib.irradiance.get_ground_diffuse`` assumes.

Shading factor (:class:`ShadingFactor`): the reduction factor for external shading
``F_sh,ob`` of EN ISO 13790:2008, 11.4.4 (carried on by EN ISO 52016-1), the solar irradiation
on the glazing with the permanent shading over that without, for a season: here the fins'
over the bare glazing's, same points, same weather, same engine.
"""
from __future__ import annotations

import tempfile
from dataclasses import dataclass
from enum import Enum
from pathlib import Path

import numpy as np

from torsal.light.annual.radiance import Program, Radiance, polygons_text
from torsal.light.annual.sky import Seasons, SkyYear

__all__ = ["Source", "RadianceSettings", "AnnualIrradiance", "ShadingFactor",
           "annual_irradiance", "shading_factor", "sky_coefficients", "sun_coefficients",
           "hourly_sums", "fins_text",
           "FIN_REFLECTANCE", "AMBIENT_BOUNCES", "AMBIENT_DIVISIONS", "SUN_RADIANCE",
           "SUN_ANGLE_DEG", "SHADING_FACTOR_STANDARD"]

#: diffuse solar reflectance of the fins: mid-grey paint or weathered anodized aluminium
FIN_REFLECTANCE = 0.5
#: rcontrib -ab: 1 counts the sky and the ground seen directly, each more one diffuse
#: reflection off the fins (2: the fins reflect once)
AMBIENT_BOUNCES = 2
#: rcontrib -ad: hemisphere samples per point (and per reflection, scaled by its weight)
AMBIENT_DIVISIONS = 2048
#: W/(m^2 sr) of every sun in the sun run (any large constant; the coefficients divide it out)
SUN_RADIANCE = 1.0e6
#: the sun's apparent diameter, degrees
SUN_ANGLE_DEG = 0.533
#: the solid angle of the sun's disc, sr
SUN_SOLID_ANGLE = 2.0 * np.pi * (1.0 - np.cos(np.radians(SUN_ANGLE_DEG / 2.0)))
#: suns per rcontrib run (one modifier each): bounds the memory of one run's output
SUN_CHUNK = 2048
#: what :class:`ShadingFactor` is
SHADING_FACTOR_STANDARD = ("F_sh,ob, the reduction factor for external shading of EN ISO "
                           "13790:2008 11.4.4 (EN ISO 52016-1): the solar irradiation on the "
                           "glazing with the fins over that on the bare glazing, per season")


class Source(str, Enum):
    """Where the irradiance on the glazing comes from (the last axis of
    :attr:`AnnualIrradiance.kwh`, in this order)."""

    SUN = "sun"
    SKY = "sky"
    GROUND = "ground"
    SUN_REFLECTED = "sun reflected"


@dataclass(frozen=True)
class RadianceSettings:
    """How ``rcontrib`` computes the coefficients.

    Attributes
    ----------
    ambient_bounces : int, default :data:`AMBIENT_BOUNCES`
        ``-ab``, at least 1.
    ambient_divisions : int, default :data:`AMBIENT_DIVISIONS`
        ``-ad``, at least 16.
    fin_reflectance : float, default :data:`FIN_REFLECTANCE`
        The fins' diffuse reflectance (Radiance ``plastic``, both sides), in [0, 1).
    processes : int, default 1
        ``rcontrib -n``.
    """

    ambient_bounces: int = AMBIENT_BOUNCES
    ambient_divisions: int = AMBIENT_DIVISIONS
    fin_reflectance: float = FIN_REFLECTANCE
    processes: int = 1

    def __post_init__(self):
        if int(self.ambient_bounces) < 1:
            raise ValueError(f"ambient_bounces must be at least 1 (the sky seen directly), got "
                             f"{self.ambient_bounces}")
        if int(self.ambient_divisions) < 16:
            raise ValueError(f"ambient_divisions must be at least 16, got {self.ambient_divisions}")
        if not 0.0 <= self.fin_reflectance < 1.0:
            raise ValueError(f"fin_reflectance must be in [0, 1), got {self.fin_reflectance}")
        if int(self.processes) < 1:
            raise ValueError(f"processes must be at least 1, got {self.processes}")

    def options(self, bounces: int) -> list:
        """rcontrib's ambient options for ``bounces``: correlated (quasi-random) sampling
        ``-u-``, so that a run is repeatable (rcontrib seeds its uncorrelated sampling by the
        clock) and the runs with and without the bounces sample the same first directions."""
        ad = int(self.ambient_divisions)
        return ["-u-", "-ab", int(bounces), "-ad", ad, "-lw", f"{0.5 / ad:.3g}",
                "-n", int(self.processes)]


@dataclass(frozen=True)
class AnnualIrradiance:
    """Solar irradiation on the glazing over a weather year.

    Attributes
    ----------
    points, normals : (n, 3) float
        The sample points on the glazing and their outward unit normals.
    kwh : (n, 12, 2, 4) float
        kWh/m^2 per point, month (January first), season (0 heating, 1 cooling: see
        :class:`~torsal.light.annual.sky.Seasons`) and :class:`Source` (in its order).
    """

    points: np.ndarray
    normals: np.ndarray
    kwh: np.ndarray

    @property
    def per_point(self) -> np.ndarray:
        """(n,) kWh/m^2 over the year at each point."""
        return self.kwh.sum(axis=(1, 2, 3))

    @property
    def annual(self) -> float:
        """kWh/m^2 over the year, the mean over the points (area-weighted for area-uniform
        points)."""
        return float(self.per_point.mean())

    @property
    def monthly(self) -> np.ndarray:
        """(12,) kWh/m^2 per month, the mean over the points."""
        return self.kwh.sum(axis=(2, 3)).mean(axis=0)

    @property
    def heating(self) -> float:
        """kWh/m^2 in the heating season, the mean over the points."""
        return float(self.kwh[:, :, 0].sum(axis=(1, 2)).mean())

    @property
    def cooling(self) -> float:
        """kWh/m^2 in the cooling season, the mean over the points."""
        return float(self.kwh[:, :, 1].sum(axis=(1, 2)).mean())

    def by_source(self) -> dict[str, float]:
        """kWh/m^2 over the year from each :class:`Source`, the mean over the points."""
        per = self.kwh.sum(axis=(1, 2)).mean(axis=0)
        return {s.value: float(x) for s, x in zip(Source, per)}

    def as_dict(self) -> dict:
        """The means, JSON-ready: ``annual_kwh_m2``, ``monthly_kwh_m2`` (12), ``heating_kwh_m2``,
        ``cooling_kwh_m2``, ``by_source_kwh_m2`` and ``points``."""
        return {"annual_kwh_m2": self.annual,
                "monthly_kwh_m2": [float(x) for x in self.monthly],
                "heating_kwh_m2": self.heating, "cooling_kwh_m2": self.cooling,
                "by_source_kwh_m2": self.by_source(), "points": int(len(self.points))}


@dataclass(frozen=True)
class ShadingFactor:
    """What shading does to the gains through the glazing (see :data:`SHADING_FACTOR_STANDARD`).

    Attributes
    ----------
    cooling, heating, year : float
        ``F_sh,ob`` of the cooling season, the heating season and the year: shaded over bare
        irradiation (NaN where the bare glazing gets none).
    cooling_avoided_kwh_m2 : float
        Bare minus shaded irradiation in the cooling season, kWh/m^2: the gains avoided.
    heating_kept_kwh_m2 : float
        Shaded irradiation in the heating season, kWh/m^2: the gains kept (``heating`` is
        their share of the bare glazing's).
    """

    cooling: float
    heating: float
    year: float
    cooling_avoided_kwh_m2: float
    heating_kept_kwh_m2: float

    def as_dict(self) -> dict:
        """JSON-ready (NaN as None), with ``standard``."""
        def num(x):
            return float(x) if np.isfinite(x) else None

        return {"f_sh_cooling": num(self.cooling), "f_sh_heating": num(self.heating),
                "f_sh_year": num(self.year),
                "cooling_gains_avoided_kwh_m2": num(self.cooling_avoided_kwh_m2),
                "heating_gains_kept_kwh_m2": num(self.heating_kept_kwh_m2),
                "standard": SHADING_FACTOR_STANDARD}


def shading_factor(bare: AnnualIrradiance, shaded: AnnualIrradiance) -> ShadingFactor:
    """The shading factor of ``shaded`` against ``bare`` (the same points).

    Parameters
    ----------
    bare, shaded : AnnualIrradiance

    Returns
    -------
    ShadingFactor
    """
    if bare.kwh.shape != shaded.kwh.shape or not np.allclose(bare.points, shaded.points):
        raise ValueError("bare and shaded must be computed on the same points")

    def ratio(a, b):
        return a / b if b > 0 else float("nan")

    return ShadingFactor(ratio(shaded.cooling, bare.cooling), ratio(shaded.heating, bare.heating),
                         ratio(shaded.annual, bare.annual), bare.cooling - shaded.cooling,
                         shaded.heating)


# ------------------------------------------------------------------ rcontrib runs
def _sensors(points, normals, offset: float | None) -> tuple[np.ndarray, np.ndarray, bytes]:
    """Checked points (n, 3), unit normals (n, 3) and rcontrib's input: each point moved
    ``offset`` behind the glazing (default 1e-4 of the points' extent), facing out."""
    p = np.asarray(points, float).reshape(-1, 3)
    n = np.asarray(normals, float).reshape(-1, 3)
    if len(p) == 0 or p.shape != n.shape:
        raise ValueError(f"points and normals must be (n, 3) with n > 0, got {p.shape} and {n.shape}")
    length = np.linalg.norm(n, axis=1, keepdims=True)
    if not (np.isfinite(p).all() and np.isfinite(n).all() and (length > 0).all()):
        raise ValueError("points must be finite and normals finite and of non-zero length")
    n = n / length
    if offset is None:
        offset = 1e-4 * max(float(np.ptp(p, axis=0).max()), 1e-9)
    rows = np.c_[p - offset * n, n]
    return p, n, "".join(f"{a:.9g} {b:.9g} {c:.9g} {d:.9g} {e:.9g} {f:.9g}\n"
                         for a, b, c, d, e, f in rows).encode()


def fins_text(fins, reflectance: float) -> str:
    """The fins as Radiance text: a diffuse ``plastic`` of ``reflectance`` and one polygon per
    triangle ("" for None or no triangles)."""
    if fins is None or len(fins.faces) == 0:
        return ""
    r = f"{reflectance:.6g}"
    return (f"void plastic fin_material 0 0 5 {r} {r} {r} 0 0\n"
            + polygons_text(fins.vertices, fins.faces, "fin_material"))


_SKY_SOURCES = ("void glow sky_glow 0 0 4 1 1 1 0\nsky_glow source sky 0 0 4 0 0 1 180\n"
                "void glow ground_glow 0 0 4 1 1 1 0\nground_glow source ground 0 0 4 0 0 -1 180\n")


def sky_coefficients(sensors: bytes, scene: str, *, subdivision, bounces: int,
                     settings: RadianceSettings, radiance: Radiance, folder: Path) -> np.ndarray:
    """Daylight coefficients: irradiance at each point from unit radiance of the ground and of
    each sky patch.

    Parameters
    ----------
    sensors : bytes
        rcontrib input, one ``x y z dx dy dz`` line per point (n lines).
    scene : str
        Radiance text of the geometry (fins, a room; "" for none), without sources.
    subdivision : SkySubdivision
    bounces : int
        ``-ab``.
    settings : RadianceSettings
    radiance : Radiance
    folder : Path
        Where the scene files go.

    Returns
    -------
    (n, P + 1) float
        sr (W/m^2 per W/(m^2 sr)); column 0 the ground, then the P patches.
    """
    octree = radiance.octree(folder, f"sky{bounces}", scene + _SKY_SOURCES)
    args = ["-h", "-I+", "-faf", *settings.options(bounces), "-f", "reinhartb.cal",
            "-p", f"MF={subdivision.mf}", "-bn", "Nrbins", "-b", "rbin", "-m", "sky_glow",
            "-bn", 1, "-b", 0, "-m", "ground_glow", octree.name]
    raw = radiance.run(Program.RCONTRIB, args, cwd=folder, stdin=sensors)
    out = np.frombuffer(raw, np.float32).reshape(-1, subdivision.patches + 1, 3)[:, :, 0]
    return np.c_[out[:, -1], out[:, :-1]].astype(float)


def sun_coefficients(sensors: bytes, scene: str, sun_vectors, *, radiance: Radiance,
                     folder: Path) -> np.ndarray:
    """Direct-sun coefficients: ``cos(incidence) * transmitted`` of each sun at each point
    (1 where nothing is in the way, 0 behind an opaque surface, the glazing's transmittance
    through glass).

    Parameters
    ----------
    sensors : bytes
        As :func:`sky_coefficients`, n lines.
    scene : str
        Radiance text of the geometry, without sources.
    sun_vectors : (J, 3) float
        Unit vectors site -> sun (at most :data:`SUN_CHUNK`).
    radiance : Radiance
    folder : Path

    Returns
    -------
    (n, J) float
        In [0, 1].
    """
    s = np.asarray(sun_vectors, float).reshape(-1, 3)
    r = f"{SUN_RADIANCE:g}"
    suns = "".join(f"void light sun_{j} 0 0 3 {r} {r} {r}\nsun_{j} source sun_disc_{j} 0 0 4 "
                   f"{x:.9f} {y:.9f} {z:.9f} {SUN_ANGLE_DEG}\n" for j, (x, y, z) in enumerate(s))
    octree = radiance.octree(folder, "suns", scene + suns)
    (folder / "suns.txt").write_text("".join(f"sun_{j}\n" for j in range(len(s))))
    args = ["-h", "-I+", "-faf", "-V+", "-ab", 0, "-dc", 1, "-dt", 0, "-dj", 0, "-ds", 0,
            "-M", "suns.txt", octree.name]
    raw = radiance.run(Program.RCONTRIB, args, cwd=folder, stdin=sensors)
    out = np.frombuffer(raw, np.float32).reshape(-1, len(s), 3)[:, :, 0]
    return out.astype(float) / (SUN_RADIANCE * SUN_SOLID_ANGLE)


def _normals(sensors: bytes) -> np.ndarray:
    """(n, 3) the directions of rcontrib's input lines."""
    return np.loadtxt(sensors.decode().splitlines(), ndmin=2)[:, 3:6]


def _indicator(group_of_hour, groups: int):
    """(T, K) sparse 0/1 matrix of each hour's group (hours of group -1 left out)."""
    from scipy.sparse import csr_matrix

    g = np.asarray(group_of_hour, np.int64)
    hours = np.flatnonzero(g >= 0)
    return csr_matrix((np.ones(len(hours)), (hours, g[hours])), shape=(len(g), groups))


def hourly_sums(sensors: bytes, scene: str, sky: SkyYear, group_of_hour, groups: int, *,
                bounces: int, settings: RadianceSettings, radiance: Radiance) -> np.ndarray:
    """What reaches the sensors from each :class:`Source`, summed over groups of hours.

    Parameters
    ----------
    sensors : bytes
        n lines of rcontrib input.
    scene : str
        Radiance text of the geometry, without sources.
    sky : SkyYear
        T hours.
    group_of_hour : (T,) int
        Each hour's group in [0, K), or -1 to leave it out.
    groups : int
        K.
    bounces : int
        ``-ab`` of the sky run; above 1 the sun's reflections come by the five-phase correction.
    settings : RadianceSettings
    radiance : Radiance

    Returns
    -------
    (n, K, 4) float
        The sky matrix's unit times hours per group (Wh/m^2 for a solar sky), by source.
    """
    g = _indicator(group_of_hour, groups)                       # (T, K) sparse
    sky_g = np.asarray((g.T @ sky.sky.T).T)                     # (P + 1, K)
    sun_patches_g = np.asarray((g.T @ sky.sun_patches.T).T)
    sun_g = g[sky.sun_hours].multiply(sky.sun_dni[:, None]).tocsr()   # (J, K) sparse
    n = sensors.count(b"\n")
    out = np.zeros((n, groups, len(Source)))
    with tempfile.TemporaryDirectory(prefix="torsal-annual-") as tmp:
        kw = dict(subdivision=sky.subdivision, settings=settings, radiance=radiance,
                  folder=Path(tmp))
        dc = sky_coefficients(sensors, scene, bounces=bounces, **kw)
        out[:, :, 2] = dc[:, :1] @ sky_g[:1]
        out[:, :, 1] = dc[:, 1:] @ sky_g[1:]
        if bounces > 1:
            direct = sky_coefficients(sensors, scene, bounces=1, **kw)
            out[:, :, 3] = (dc - direct)[:, 1:] @ sun_patches_g[1:]
        # the suns of some group in front of some point (the others give every point 0)
        used = np.flatnonzero(sun_g.getnnz(axis=1) & (_normals(sensors) @ sky.sun_vectors.T
                                                        > 0).any(axis=0))
        for k in range(0, len(used), SUN_CHUNK):
            part = used[k:k + SUN_CHUNK]
            coef = sun_coefficients(sensors, scene, sky.sun_vectors[part], radiance=radiance,
                                    folder=Path(tmp))
            out[:, :, 0] += np.asarray((sun_g[part].T @ coef.T).T)
    return out


def annual_irradiance(points, normals, sky: SkyYear, seasons: Seasons, *, fins=None,
                      settings: RadianceSettings | None = None, offset: float | None = None,
                      radiance: Radiance | None = None) -> AnnualIrradiance:
    """Solar irradiation on the glazing over the weather year, by source, month and season.

    Parameters
    ----------
    points : (n, 3) float
        Sample points on the glazing (model units).
    normals : (n, 3) float
        Their outward normals (towards the fins and the sky).
    sky : SkyYear
        The weather year's sky and suns (:func:`~torsal.light.annual.sky.sky_year`).
    seasons : Seasons
        The same year's hours by month and season (:func:`~torsal.light.annual.sky.seasons`).
    fins : trimesh.Trimesh, optional
        The shading (thin surfaces); None for the bare glazing.
    settings : RadianceSettings, optional
    offset : float, optional
        How far behind the glazing the points are moved, model units (default 1e-4 of the
        points' extent).
    radiance : Radiance, optional
        Default :meth:`~torsal.light.annual.radiance.Radiance.bundled`.

    Returns
    -------
    AnnualIrradiance
    """
    settings = settings or RadianceSettings()
    radiance = radiance or Radiance.bundled()
    if len(seasons.month) != len(sky.weather):
        raise ValueError(f"seasons cover {len(seasons.month)} hours, the sky {len(sky.weather)}")
    p, n, sensors = _sensors(points, normals, offset)
    scene = fins_text(fins, settings.fin_reflectance)
    out = hourly_sums(sensors, scene, sky, seasons.group(), 24,
                      bounces=int(settings.ambient_bounces) if scene else 1,
                      settings=settings, radiance=radiance)
    # group 2 (month - 1) + season: month-major, so (n, 24, S) is (n, 12, 2, S); Wh -> kWh
    return AnnualIrradiance(p, n, out.reshape(len(p), 12, 2, len(Source)) / 1000.0)
