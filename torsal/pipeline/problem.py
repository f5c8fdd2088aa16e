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
from .reflection import ReflectPlanes, reflect_planes
from .regions import dominant_light_direction, select_faces, select_vertices

__all__ = ["JIT_MIN_VERTICES", "FILE_WEIGHT_NAMES", "term_weights", "stroke_faces",
           "torsal_plane_params", "add_reflect_terms", "congruence_problem"]

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


def torsal_plane_params(congruence: Congruence, faces: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Per-face parameters (m, 7) of :func:`_torsal_plane_energy`: the plane normal ``n``,
    ``g_i = <grad lambda_i, t>`` (the derivative along ``t`` of the corners' barycentric
    coordinates, ``t = n x N`` the line where the plane meets the face) and ``1 / s0`` with
    ``s0 = |d_t e|`` (its part across ``e``) on the starting congruence.

    A plane through the face's line ``L_c`` (``<n, e_c> = 0``) is a torsal plane iff the
    lines along ``t`` stay in it to first order: ``<n, d_t e> = 0`` (eq. (1) in the direction
    ``t``; ``f_dir``'s ``[a_p2 - a_p1, e_p1, e_p2]`` is the same condition times ``|p2 -
    p1|^2 |t x e_c|``). Divided by ``s0``, the residual reads as the angle (radians) by which
    the torsal plane misses ``n``, on a coarse mesh as on a fine one; ``f_dir / delta``
    shrinks with the mesh's ``delta`` and the lines' curvature, so a paper-size mesh would
    meet the planes only to several degrees.

    >>> from torsal.geometry.surfaces import facade_patch
    >>> c = Congruence.from_normals(facade_patch(nu=5, nv=5))
    >>> torsal_plane_params(c, np.arange(4), np.tile([0.0, 0.1, 1.0], (4, 1))).shape
    (4, 7)
    """
    v, f = congruence.vertices, congruence.faces[faces]
    a = v[f]
    fn = np.cross(a[:, 1] - a[:, 0], a[:, 2] - a[:, 0])
    area2 = np.linalg.norm(fn, axis=1)
    nf = fn / area2[:, None]
    t = np.cross(normals, nf)
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
    grad = np.stack([np.cross(nf, a[:, (i + 2) % 3] - a[:, (i + 1) % 3]) / area2[:, None]
                     for i in range(3)], axis=1)                       # (m, 3 corners, 3)
    g = np.einsum("mij,mj->mi", grad, t)
    e = congruence.directions[f]
    ec = e.mean(axis=1)
    ec /= np.linalg.norm(ec, axis=1, keepdims=True)
    dte = np.einsum("mi,mij->mj", g, e)
    s0 = np.linalg.norm(dte - (dte * ec).sum(1, keepdims=True) * ec, axis=1)
    # a face whose lines hardly turn (near a bundle; everywhere on a flat surface's normals)
    # would weigh without bound: at least a tenth of the median, or of a turn of one radian
    # over the surface's extent
    extent = float(np.ptp(v, axis=0).max())
    floor = max(0.1 * float(np.median(s0)) if len(s0) else 0.0, 0.1 / max(extent, 1e-300))
    return np.c_[normals, g, 1.0 / np.maximum(s0, floor)]


def _torsal_plane_energy(e, a, q):
    """``<n, e_c>^2 + (<n, d_t e> / s0)^2`` (``q = [n, g, 1/s0]``, see
    :func:`torsal_plane_params`): the face's torsal plane is the plane of normal ``n``.
    Linear residuals in ``e``: both are sines of angles, so the weight means the same on any
    mesh."""
    n, g = q[0:3], q[3:6]
    ec = (e[0, :] + e[1, :] + e[2, :]) / 3.0
    dte = g[0] * e[0, :] + g[1] * e[1, :] + g[2] * e[2, :]
    return (ec @ n) ** 2 + ((dte @ n) * q[6]) ** 2


def add_reflect_terms(p: CongruenceProblem, planes: ReflectPlanes, weight: float) -> CongruenceProblem:
    """The reflection goal's two energies (paper 4.3, Fig. 13) over ``planes.faces``:
    ``reflect``, one family of torsal planes are the mirror planes, and ``reflect_incidence``,
    the other family's are the planes of incidence (edge-on to the light arriving and
    leaving), both with ``weight`` (``weights.plane``, Fig. 12's w_plane).

    >>> from torsal.geometry.surfaces import facade_patch
    >>> c = Congruence.from_normals(facade_patch(nu=5, nv=5))
    >>> planes = ReflectPlanes(np.arange(4), np.tile([0.0, 0.1, 1.0], (4, 1)) / np.sqrt(1.01),
    ...                        np.tile([1.0, 0, 0], (4, 1)), np.array([0.0, 0.7, -0.7]), np.ones(4))
    >>> sorted(add_reflect_terms(CongruenceProblem(c), planes, 5000.0).terms)
    ['reflect', 'reflect_incidence']
    """
    c = p.congruence
    p.add_term("reflect", weight, _torsal_plane_energy, over="faces", elements=planes.faces,
               params=torsal_plane_params(c, planes.faces, planes.mirror))
    ok = np.isfinite(planes.incidence).all(axis=1)
    if ok.any():
        p.add_term("reflect_incidence", weight, _torsal_plane_energy, over="faces",
                   elements=planes.faces[ok],
                   params=torsal_plane_params(c, planes.faces[ok], planes.incidence[ok]))
    return p


def congruence_problem(spec: DesignSpec, v: np.ndarray, f: np.ndarray, sun: np.ndarray,
                       w_sun: np.ndarray, *, into: CongruenceProblem | None = None,
                       weighted_subsets: bool = False) -> CongruenceProblem:
    """The eq. (9) problem of a design: mesh A (v (n, 3), f (m, 3)), sun directions
    (k, 3) site -> sun with weights (k,).

    ``into``: a problem made by this function for the same mesh A and the same terms (by
    name; a live session's, :class:`torsal.session.Session`): the design's terms are
    registered on it again, replacing those of the same name. A term whose elements are
    unchanged keeps the built NLP and its compiled kernels (a weight, a light direction, a
    bound is a parameter); the caller checks that the names match (``terms``). Not for a
    design with ``[substructure]`` (two aligned problems).

    ``weighted_subsets``: the let-through region (``goals.let_through``) and the strokes'
    faces (``goals.strokes``, the boundary's) as NLP parameters, not as the structure:
    ``f_perp`` and ``f_par`` over every vertex of mesh A with per-vertex weights
    (``vertex_weights``: 0 off their vertices, ``|V| / |V'|`` on them, so each is the same
    mean over its vertices as without), ``f_dir`` over every face with per-face weights
    (``face_weights``, likewise). A moved region or stroke then re-solves the built NLP (a
    live session's); without it the terms' subsets change, and the NLP and its Newton
    matrix's analysis are built again. The same energies, to rounding.

    >>> from torsal.pipeline.design_file import DesignSpec
    >>> from torsal.geometry.surfaces import facade_patch
    >>> spec = DesignSpec.model_validate({"surface": {"generator": "facade_patch"},
    ...     "sun": {"vectors": [[0.3, -0.8, 0.5]]}, "fins": {"spacing": 1, "depth": 0.3}})
    >>> v, f = facade_patch(nu=5, nv=5)
    >>> p = congruence_problem(spec, v, f, np.array([[0.3, -0.8, 0.5]]), np.ones(1))
    >>> congruence_problem(spec, v, f, np.array([[0.3, -0.7, 0.5]]), np.ones(1), into=p) is p
    True
    """
    if into is not None and spec.substructure is not None:
        raise ValueError("a design with [substructure] aligns two problems: make a new one")
    W, given = term_weights(spec.weights)
    C = spec.constraints
    c0 = Congruence.from_normals((v, f)) if into is None else into.congruence
    # compiled kernels pay back their one-off compile time (about a second each, cached
    # per machine) on paper-sized surfaces; small studies start faster interpreted
    jit = C.jit if C.jit is not None else len(v) >= JIT_MIN_VERTICES
    p = CongruenceProblem(c0, jit=jit) if into is None else into
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
    if weighted_subsets and through.size:
        # one term over every vertex each, the region as each vertex's weight (see above)
        n = len(v)
        inside = np.zeros(n)
        inside[through] = 1.0
        if g.block and blocked_v.size and not g.sun_regions:
            p.perpendicular(d_main, weight=W["perpendicular"],
                            vertex_weights=(1.0 - inside) * (n / blocked_v.size))
        p.parallel(d_main, weight=W["parallel"], vertex_weights=inside * (n / through.size))
    else:
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
    if faces_dir.size and weighted_subsets:
        fw, segments = np.zeros(len(f)), np.zeros((len(f), 3))
        fw[faces_dir], segments[faces_dir] = len(f) / faces_dir.size, seg_dir
        p.torsal_direction(None, segments, weight=W["torsal_direction"], face_weights=fw)
    elif faces_dir.size:
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
        add_reflect_terms(p, reflect_planes(spec, v, f, sun, w_sun), W["torsal_plane"])
    if "closeness" in given and W["closeness"]:
        p.closeness(weight=W["closeness"])
    if C.hyperbolic:
        p.hyperbolic(margin=C.hyperbolic_margin)
    if C.min_torsal_angle is not None:
        form = {} if C.torsal_angle_form is None else {"form": C.torsal_angle_form}
        p.min_torsal_angle(C.min_torsal_angle, **form, between=C.torsal_angle_between)
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
