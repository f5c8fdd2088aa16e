"""The congruence optimization problem of a design file (4.1, eq. 9).

One source of defaults: a weight the design file leaves unset takes
:data:`torsal.geometry.optimize.DEFAULT_WEIGHTS` (the paper's Fig. 12). ``fair_torsal`` and
``closeness`` are terms a design switches on by giving their weight.
"""
from __future__ import annotations

import numpy as np

from .design_file import DesignSpec, WeightsSpec
from ..geometry.congruence import Congruence
from ..geometry.mesh import average_edge_length, edge_face_adjacency
from ..geometry.optimize import DEFAULT_WEIGHTS, CongruenceProblem
from ..light.shading import mirror_normals
from .regions import dominant_light_direction, select_faces, select_vertices

__all__ = ["JIT_MIN_VERTICES", "FILE_WEIGHT_NAMES", "term_weights", "stroke_faces",
           "congruence_problem"]

JIT_MIN_VERTICES = 500  # default for constraints.jit (tests run smaller designs interpreted)

#: design-file weight key -> optimizer term name
FILE_WEIGHT_NAMES = {"norm": "normal", "fair": "fair", "fair_torsal": "fair_torsal",
                     "perp": "perpendicular", "par": "parallel", "plane": "torsal_plane",
                     "dir": "torsal_direction", "through": "through_points",
                     "closeness": "closeness"}


def term_weights(weights: WeightsSpec) -> tuple[dict[str, float], set[str]]:
    """Weight per optimizer term: the design file's, else :data:`DEFAULT_WEIGHTS`; and the
    set of terms the file gave a weight for.

    >>> w, given = term_weights(WeightsSpec(perp=10))
    >>> w["perpendicular"], w["fair"], sorted(given)
    (10.0, 1.0, ['perpendicular'])
    """
    given = {FILE_WEIGHT_NAMES[k]: float(v) for k, v in weights.model_dump().items() if v is not None}
    return {**DEFAULT_WEIGHTS, **given}, set(given)


def stroke_faces(spec: DesignSpec, v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Faces (k,) and stroke directions (k, 3) for f_dir: designer strokes and, for
    ``boundary_aligned``, the boundary edges (Fig. 7a/7b)."""
    g = spec.goals
    bc = v[f].mean(axis=1)
    faces, dirs = [], []
    delta = average_edge_length(v, f)
    for k, st in enumerate(g.strokes):
        pts = np.asarray(st.points, float)
        width = st.width or 1.5 * delta
        seg_a, seg_b = pts[:-1], pts[1:]
        d = seg_b - seg_a
        L2 = (d * d).sum(1)
        t = np.clip(((bc[:, None, :] - seg_a[None]) * d[None]).sum(2) / L2[None], 0, 1)
        closest = seg_a[None] + t[..., None] * d[None]
        dist = np.linalg.norm(bc[:, None, :] - closest, axis=2)
        j = dist.argmin(axis=1)
        near = np.flatnonzero(dist[np.arange(len(bc)), j] <= width)
        if near.size == 0:
            raise ValueError(f"goals.strokes[{k}] passes no face of the surface (within {width:.3g})")
        faces.append(near)
        dirs.append(d[j[near]])
    if g.boundary_aligned:
        # the face on each boundary edge follows the edge
        edges, edge_faces = edge_face_adjacency(f)
        on_boundary = edge_faces[:, 1] < 0
        fe_dirs = np.zeros((len(f), 3))
        fe_dirs[edge_faces[on_boundary, 0]] = (v[edges[on_boundary, 1]]
                                               - v[edges[on_boundary, 0]])
        idx = np.unique(edge_faces[on_boundary, 0])
        faces.append(idx)
        dirs.append(fe_dirs[idx])
    if not faces:
        return np.zeros(0, np.int64), np.zeros((0, 3))
    fi = np.concatenate(faces)
    di = np.concatenate(dirs)
    fi, first = np.unique(fi, return_index=True)
    return fi, di[first]


def congruence_problem(spec: DesignSpec, v: np.ndarray, f: np.ndarray, sun: np.ndarray,
                       w_sun: np.ndarray) -> CongruenceProblem:
    """The eq. (9) problem of a design: mesh A (v (n, 3), f (m, 3)), sun directions
    (k, 3) site -> sun with weights (k,)."""
    W, given = term_weights(spec.weights)
    C = spec.constraints
    c0 = Congruence.from_normals((v, f))
    # compiled kernels pay back their one-off compile time (about a second each, cached
    # per machine) on paper-sized surfaces; small studies start faster interpreted
    jit = C.jit if C.jit is not None else len(v) >= JIT_MIN_VERTICES
    p = CongruenceProblem(c0, jit=jit)
    if W["normal"] > 0:
        p.normal(weight=W["normal"])
    if W["fair"] > 0:
        p.fair(weight=W["fair"])
    if "fair_torsal" in given and W["fair_torsal"]:
        p.fair_torsal(weight=W["fair_torsal"])
    g = spec.goals
    light = -sun  # light travels from the sun
    through = select_vertices(g.let_through, v) if g.let_through is not None else np.zeros(0, int)
    if g.let_through is not None and through.size == 0:
        raise ValueError(f"goals.let_through = {g.let_through.model_dump(exclude_none=True)} "
                         "contains no vertex of the surface; check its ranges against the mesh")
    blocked_v = np.setdiff1d(np.arange(len(v)), through)
    d_main = dominant_light_direction(light, w_sun)
    if g.block and blocked_v.size and not g.sun_regions:
        p.perpendicular(d_main, vertices=blocked_v, weight=W["perpendicular"])
    if through.size:
        p.parallel(d_main, vertices=through, weight=W["parallel"])
    for k, st in enumerate(g.see_through):
        idx = select_vertices(st.region, v)
        if idx.size == 0:
            raise ValueError(f"goals.see_through[{k}].region contains no vertex")
        p.through_points(np.tile(st.target, (idx.size, 1)), vertices=idx,
                         weight=W["through_points"], name=f"through_points_{k}")
    faces_dir, seg_dir = stroke_faces(spec, v, f)
    if faces_dir.size:
        p.torsal_direction(faces_dir, seg_dir, weight=W["torsal_direction"])
    for k, sr in enumerate(g.sun_regions):
        fi = select_faces(sr.region, v, f)
        if fi.size == 0:
            raise ValueError(f"goals.sun_regions[{k}].region contains no face")
        d = np.asarray(sr.vectors, float)
        d = -(d / np.linalg.norm(d, axis=1, keepdims=True)).mean(0)
        p.torsal_plane(fi, normals=d / np.linalg.norm(d), weight=W["torsal_plane"],
                       name=f"torsal_plane_{k}")
    if g.reflect is not None:
        fi = select_faces(g.reflect.region, v, f)
        if fi.size == 0:
            raise ValueError("goals.reflect.region contains no face of the surface; check its "
                             "ranges against the mesh")
        bc = v[f[fi]].mean(axis=1)
        out = np.asarray(g.reflect.target, float) - bc
        n = mirror_normals(np.tile(d_main, (len(fi), 1)), out / np.linalg.norm(out, axis=1, keepdims=True))
        p.torsal_plane(fi, normals=n, weight=W["torsal_plane"], name="reflect")
    if "closeness" in given and W["closeness"]:
        p.closeness(weight=W["closeness"])
    if C.hyperbolic:
        p.hyperbolic(margin=C.hyperbolic_margin)
    if C.min_torsal_angle is not None:
        form = {} if C.torsal_angle_form is None else {"form": C.torsal_angle_form}
        p.min_torsal_angle(C.min_torsal_angle, **form)
    if spec.substructure is not None:
        # Fig. 11: a second congruence behind A, optimized together with the first so that
        # their torsal directions coincide (f_extra)
        sub = spec.substructure
        v2 = v - sub.offset * c0.directions
        q = CongruenceProblem(Congruence.from_normals((v2, f)), jit=jit)
        q.normal(weight=W["normal"]).fair(weight=W["fair"])
        if C.hyperbolic:
            q.hyperbolic(margin=C.hyperbolic_margin)
        p.align_with(q, weight=W["align"] if sub.weight is None else sub.weight,
                     label="substructure")
    return p
