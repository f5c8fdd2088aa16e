"""Checks a design run makes before its expensive stages: is the surface one the optimizer
can work on, and how big will the run be (fins, optimizer variables, rays, parts, disk)?

A fin spacing typed in metres instead of millimetres, or an absurd light-sample count, used
to run for minutes and fill the disk; :func:`estimate_size` predicts the size from the
design file and mesh A alone (no stage runs), and :func:`check_size` stops above
:data:`SIZE_LIMITS` with the estimate and the key to change (``torsal design
--no-size-limit`` goes on anyway).

Examples
--------
>>> from torsal.geometry.surfaces import facade_patch
>>> from torsal.pipeline.design_file import DesignSpec
>>> spec = DesignSpec.model_validate({"surface": {"generator": "facade_patch"},
...     "sun": {"vectors": [[0, -1, 1]]}, "fins": {"spacing": 0.005, "depth": 0.3}})
>>> est = estimate_size(spec, *facade_patch(nu=9, nv=9))
>>> est.fins > SIZE_LIMITS["fins"]
True
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .design_file import DesignSpec
from ..geometry.mesh import edge_face_adjacency, face_areas
from .errors import DesignError

__all__ = ["SizeEstimate", "SIZE_LIMITS", "estimate_size", "check_size", "check_surface",
           "SizeLimitError", "sun_position_count"]

#: Above these the run stops (unless asked to go on). About ten times the largest example
#: (11_aligned_substructure: ~2,100 fins, 30,000 variables, 1.1 M rays estimated); a run at
#: the limits takes tens of minutes.
SIZE_LIMITS = {
    "fins": 20_000,                 # fin panels (support-structure edges)
    "variables": 300_000,           # optimizer unknowns (3 per vertex and congruence)
    "rays": 200_000_000,            # ray casts of the light measurements
    "parts": 20_000,                # fabricated parts
    "disk_bytes": 2_000_000_000,    # stage cache and output files
}

# per-fin constants measured on the examples (stage cache ~0.6 kB, DXF/SVG/CSV ~1.5 kB,
# STEP ~25 kB per fin panel); parts per fin from the egg-crate split
_FINS_PER_CELL = 2.5      # fin edges per (spacing x spacing) cell of the surface
_PARTS_PER_FIN = 0.7
_BYTES_PER_FIN = 2_500
_STEP_BYTES_PER_FIN = 25_000

# which design key changes each quantity most directly
_KEY_FOR = {
    "fins": "fins.spacing",
    "parts": "fins.spacing",
    "disk_bytes": "fins.spacing (or outputs.step = false)",
    "variables": "the mesh resolution (surface.mesh or surface.params nu, nv)",
    "rays": "outputs.light_samples (or fewer sun positions: sun.step, sun.hours, dates)",
}


class SizeLimitError(DesignError):
    """A design whose estimated size is above :data:`SIZE_LIMITS`."""


@dataclass(frozen=True)
class SizeEstimate:
    """How big a design run will be, before it runs (all counts approximate).

    Attributes
    ----------
    surface_area : float
        Area of mesh A, model units squared.
    fins : int
        Fin panels: about 2.5 per lattice cell (the two families' ``fins.spacing``
        multiplied) of surface.
    variables : int
        Optimizer unknowns: 3 per vertex (6 with a substructure).
    sun_positions : int
        Sun directions the light stage measures.
    rays : int
        Ray casts: samples times (2 x sun positions + 2) for fins and louvers.
    parts : int
        Fabricated parts.
    disk_bytes : int
        Stage cache and output files.
    """

    surface_area: float
    fins: int
    variables: int
    sun_positions: int
    rays: int
    parts: int
    disk_bytes: int

    def over(self, limits: dict | None = None) -> dict:
        """``{quantity: (estimate, limit)}`` for every quantity above its limit."""
        limits = SIZE_LIMITS if limits is None else limits
        d = asdict(self)
        return {k: (d[k], lim) for k, lim in limits.items() if d[k] > lim}

    def as_dict(self) -> dict:
        return {**asdict(self), "limits": dict(SIZE_LIMITS)}


def sun_position_count(spec: DesignSpec) -> int:
    """Sun positions a design asks for, counted from the design file (no solar positions):
    explicit vectors, at most 8784 hours of a weather file's year, or days x daily window /
    step."""
    s = spec.sun
    if s.vectors is not None:
        return len(s.vectors)
    if s.weather_file is not None:
        return 8784
    import pandas as pd

    days = (s.end - s.start).days + 1
    if s.months is not None:
        days = int(np.ceil(days * len(set(s.months)) / 12)) or 1
    step_h = pd.Timedelta(pd.tseries.frequencies.to_offset(s.step)) / pd.Timedelta("1h")
    return int(days * (np.floor((s.hours[1] - s.hours[0]) / step_h) + 1))


def estimate_size(spec: DesignSpec, vertices: np.ndarray, faces: np.ndarray) -> SizeEstimate:
    """Estimate a run's size from the design file and mesh A (see :class:`SizeEstimate`).

    Parameters
    ----------
    spec : DesignSpec
    vertices : (n, 3) float
        Mesh A, model units.
    faces : (m, 3) int
    """
    area = float(face_areas(vertices, faces).sum())
    s0, s1 = spec.fins.spacings          # a lattice cell is s0 by s1
    fins = int(np.ceil(_FINS_PER_CELL * area / (s0 * s1)))
    if spec.substructure is not None:
        fins *= 2
    congruences = 2 if spec.substructure is not None else 1
    variables = 3 * len(vertices) * congruences
    suns = sun_position_count(spec)
    n = spec.outputs.light_samples
    rays = int(n * (2 * suns + 2))
    parts = int(np.ceil(_PARTS_PER_FIN * fins))
    per_fin = _BYTES_PER_FIN + (_STEP_BYTES_PER_FIN if spec.outputs.step else 0)
    return SizeEstimate(surface_area=area, fins=fins, variables=variables, sun_positions=suns,
                        rays=rays, parts=parts, disk_bytes=int(fins * per_fin))


def check_size(estimate: SizeEstimate, *, stage: str = "estimate") -> None:
    """Raise :class:`SizeLimitError` naming every quantity above :data:`SIZE_LIMITS`, the
    estimate, and the design key to change."""
    over = estimate.over()
    if not over:
        return
    lines = [f"{k.replace('_bytes', '')} about {_amount(k, v)} (limit {_amount(k, lim)}): "
             f"change {_KEY_FOR[k]}" for k, (v, lim) in over.items()]
    unit_hint = (" A fin spacing typed in the wrong unit is the usual cause." if "fins" in over
                 else "")
    raise SizeLimitError(stage, "this design is too big to run by default: " + "; ".join(lines)
                         + f" (surface area {estimate.surface_area:.4g} model units^2).{unit_hint}"
                         " Pass --no-size-limit (Design.run(size_limit=False)) to run it anyway")


def _amount(key: str, value: float) -> str:
    if key == "disk_bytes":
        return f"{value / 1e6:,.0f} MB"
    return f"{value:,.0f}"


def check_surface(vertices: np.ndarray, faces: np.ndarray, *, key: str, value) -> None:
    """Raise :class:`DesignError` if mesh A is too small or in pieces for the optimizer and
    the remeshing: it needs at least two faces sharing an edge, all in one piece."""
    f = np.asarray(faces)
    edges, edge_faces = edge_face_adjacency(f)
    inner = edge_faces[:, 1] >= 0
    if len(f) < 2 or not inner.any():
        raise DesignError("surface", f"mesh A has {len(f)} face(s) and no edge shared by two "
                          "faces; torsal needs a surface of at least two triangles sharing an "
                          "edge (a few hundred for useful fins)", key=key, value=value)
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    a, b = edge_faces[inner, 0], edge_faces[inner, 1]
    n_parts, _ = connected_components(coo_matrix((np.ones(len(a)), (a, b)),
                                                 shape=(len(f), len(f))), directed=False)
    if n_parts > 1:
        raise DesignError("surface", f"mesh A is in {n_parts} pieces not joined by shared edges; "
                          "give one connected surface (vertices at the same position are merged "
                          "already; pieces that only touch at a corner count as separate)",
                          key=key, value=value)
