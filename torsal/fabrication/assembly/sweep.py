"""The volume a part sweeps on its way into place that lies inside the parts already placed
(:func:`swept_overlap`): the prisms its faces sweep, proved apart cheaply where they are
(:mod:`.separation`), else intersected exactly (:mod:`.occ`).

Units: those of the solids (unit^3).
"""
from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from .occ import _Face, _bbox, _boundary_triangles, _face_prism, _face_records, _near, _shape, common_volume
from .separation import prisms_clear

__all__ = ["swept_overlap"]


def swept_overlap(moving, vector, others: Sequence, *, stop_above: float = np.inf,
                  faces: list[_Face] | None = None,
                  triangles: Callable[[int], np.ndarray] | None = None) -> list[float]:
    """Volume that ``moving`` sweeps on its way from ``position - vector`` to its place and that
    lies inside each of ``others`` (unit^3, one per other; an upper bound: the sum over the
    prisms every face of ``moving`` sweeps along ``vector``, each intersected exactly). With
    ``stop_above`` the sum for one other stops once it exceeds that (a collision is known).

    A prism that :func:`prism_clear` proves apart from an other adds 0 without a boolean.
    ``faces``: the face records of ``moving`` (``_face_records``), if made already;
    ``triangles(i)``: the boundary triangles of ``others[i]`` (``_boundary_triangles``), if kept.

    >>> from build123d import Box, Pos
    >>> [round(v, 6) for v in swept_overlap(Box(1, 1, 1), (0, 0, 3), [Pos(0, 0, -2) * Box(1, 1, 1)])]
    [2.0]
    """
    v = np.asarray(vector, float)
    faces = _face_records(_shape(moving)) if faces is None else faces
    fboxes = [(np.minimum(f.points.min(axis=0), (f.points - v).min(axis=0)),
               np.maximum(f.points.max(axis=0), (f.points - v).max(axis=0))) for f in faces]
    prisms: dict[int, object] = {}           # face index -> oriented prism (None: no volume)
    out = []
    for i, o in enumerate(others):
        oshape = _shape(o)
        ob = _bbox(oshape)
        total = 0.0
        meets = [n for n, (plo, phi) in enumerate(fboxes)
                 if not ((plo > ob[1]).any() or (ob[0] > phi).any())]     # else apart
        if meets:
            clear = prisms_clear([faces[n] for n in meets], v,
                                 _boundary_triangles(oshape) if triangles is None else triangles(i), ob)
            meets = [n for n, c in zip(meets, clear) if not c]            # else proved apart
        for n in meets:
            face = faces[n]
            if n not in prisms:
                prisms[n] = _face_prism(face.face, v)
            pr = prisms[n]
            if pr is None or (_bbox(pr)[0] > ob[1]).any() or (ob[0] > _bbox(pr)[1]).any() \
                    or not _near(pr, oshape, 1e-3):
                continue
            try:
                total += common_volume(pr, o)
            except RuntimeError:
                total = float("inf")
            if total > stop_above:
                break
        out.append(total)
    return out
