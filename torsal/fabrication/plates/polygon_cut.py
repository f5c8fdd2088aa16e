"""The direct slot cut of a closed polyhedron (:func:`_cut_polyhedron`), face by face in the
faces' planes with shapely: each face the boxes reach less their sections by its plane, each box
face within the polyhedron's section by its plane less the other boxes'; the faces then made
whole (:mod:`.whole_faces`)."""
from __future__ import annotations

import numpy as np

from .sections import (_BOX_FACES, _DIRECT_GAP, _Decline, _Edges, _box_geometry, _box_planes,
                       _box_sections, _plane_axes, _polyhedron_section, _rings)
from .whole_faces import _whole_faces


def _cut_polyhedron(points: np.ndarray, loops: list, normals: np.ndarray, centres: np.ndarray,
                    frames: list):
    """A closed polyhedron (``points`` (V, 3), ``loops`` of point ids oriented outwards, unit
    ``normals`` and ``centres`` of their planes) less the boxes of ``frames`` (arguments of
    :func:`_box`), computed face by face in the faces' planes: each face less the boxes'
    sections by its plane, and each box face (coplanar box faces together) within the
    polyhedron's section by its plane, less the other boxes'. Faces no box reaches are kept as
    they are; the result's faces are whole (no two adjacent faces on one plane, no vertex
    between two collinear edges of the same two faces), as OpenCascade's boolean cut followed
    by face unification leaves them. Returns ``(points, loops, normals, centres, volume)``;
    :class:`_Decline` where a corner lies on a plane it is cut by, faces are nearly coplanar
    or the result is not one closed shell."""
    corners, box_axes = _box_geometry(frames)
    edges = _Edges(loops)
    offsets, within, reach = _reached(points, edges, normals, centres, corners, box_axes)
    # the new faces: shapely regions, each with the face it replaces (plate faces: their
    # index; box planes: len(loops) + their number) and its plane (normal, origin, axes)
    regions, owners, planes = _cut_faces(points, edges, normals, centres, offsets, corners, reach)
    more, more_owners, more_planes = _box_faces(points, edges, normals, corners, box_axes, within,
                                                len(loops))
    regions += more
    owners += more_owners
    planes.update(more_planes)
    return _whole_faces(points, loops, normals, centres, regions, owners, planes)


def _reached(points: np.ndarray, edges: _Edges, normals: np.ndarray, centres: np.ndarray,
             corners: np.ndarray, box_axes: np.ndarray):
    """Which faces of the polyhedron (``points``, its ``edges``, the unit ``normals`` and
    ``centres`` of its faces) each box (``corners`` (B, 8, 3), unit axes ``box_axes``
    (B, 3, 3)) reaches: ``(offsets (F,) of the faces' planes, within (F, B), reach (F, B))``,
    ``within`` where the face lies within the box's extent along each of its axes, ``reach``
    where besides the box's corners lie on both sides of the face's plane.
    :class:`_Decline` where a corner of a box lies on the plane of a face within it."""
    # the faces a box reaches: its corners on both sides of the face's plane, and the face
    # within the box's extent along each of its axes (separating axes); the others are kept
    offsets = np.einsum("fi,fi->f", normals, centres)
    s = np.einsum("fi,bci->fbc", normals, corners) - offsets[:, None, None]          # (F, B, 8)
    extent = np.einsum("bki,bi->bk", box_axes, corners[:, 7] - corners[:, 0])
    local = np.einsum("bki,bvi->bvk", box_axes, points - corners[:, None, 0])         # (B, V, 3)
    f_lo = np.minimum.reduceat(local[:, edges.a], edges.starts, axis=1)              # (B, F, 3)
    f_hi = np.maximum.reduceat(local[:, edges.a], edges.starts, axis=1)
    within = ((f_lo < extent[:, None] + _DIRECT_GAP) & (f_hi > -_DIRECT_GAP)).all(axis=2).T  # (F, B)
    if (within & (np.abs(s) <= _DIRECT_GAP).any(axis=2)).any():
        raise _Decline("a box corner on a plane it cuts")
    reach = within & (s.min(axis=2) < 0) & (s.max(axis=2) > 0)
    return offsets, within, reach


def _cut_faces(points: np.ndarray, edges: _Edges, normals: np.ndarray, centres: np.ndarray,
               offsets: np.ndarray, corners: np.ndarray, reach: np.ndarray):
    """The faces of the polyhedron that boxes reach (``reach`` (F, B), :func:`_reached`), each
    less the sections of its boxes by its plane: ``(regions, owners, planes)``, the shapely
    regions in the faces' frames, the face each replaces, and ``{face: (normal, origin, axes)}``
    (a face its boxes' sections do not touch is kept as it is: left out)."""
    import shapely

    face_axes = _plane_axes(normals)                                                 # (F, 2, 3)
    regions, owners, planes = [], [], {}
    f_cut, b_cut = np.nonzero(reach)                # by face
    if len(f_cut):
        cuts = _box_sections(corners[b_cut], normals[f_cut], offsets[f_cut], centres[f_cut],
                             face_axes[f_cut])
        hit, first, count = np.unique(f_cut, return_index=True, return_counts=True)
        cut = cuts[first]
        for k in np.flatnonzero(count > 1):
            cut[k] = shapely.union_all(cuts[first[k]:first[k] + count[k]])
        uv = np.einsum("ei,eki->ek", points[edges.a] - centres[edges.face], face_axes[edges.face])
        faces = _rings(uv[np.isin(edges.face, hit)], edges.sizes[hit])
        touch = shapely.intersects(faces, cut)
        regions += list(shapely.difference(faces[touch], cut[touch]))
        owners += hit[touch].tolist()
        planes.update((int(f), (normals[f], centres[f], face_axes[f])) for f in hit[touch])
    return regions, owners, planes


def _box_faces(points: np.ndarray, edges: _Edges, normals: np.ndarray, corners: np.ndarray,
               box_axes: np.ndarray, within: np.ndarray, first: int):
    """The faces of the boxes by plane (:func:`_box_planes`), each within the polyhedron's
    section by its plane and outside the other boxes (:func:`_box_face`): ``(regions, owners,
    planes)`` as :func:`_cut_faces` gives them, the owner of plane ``g`` ``first + g``."""
    regions, owners, planes = [], [], {}
    for g, (gn, gd, members) in enumerate(_box_planes(box_axes, corners)):
        face = _box_face(points, edges, normals, corners, within, gn, gd, members)
        if face is None:
            continue
        region, plane = face
        regions.append(region)
        owners.append(first + g)
        planes[first + g] = plane
    return regions, owners, planes


def _box_face(points: np.ndarray, edges: _Edges, normals: np.ndarray, corners: np.ndarray,
              within: np.ndarray, gn: np.ndarray, gd: float, members: list):
    """The face of the boxes on the plane ``x.gn = gd`` (their faces ``members``, each
    ``(box, face)``), looking into the box: ``(shapely region, (normal, origin, axes) of its
    plane)``, the boxes' faces within the polyhedron's section by the plane, less the other
    boxes' sections (:func:`_less_other_boxes`); None where no face of the polyhedron crosses
    the plane within the boxes, or nothing is left."""
    import shapely

    s = points @ gn - gd
    crossing = np.unique(edges.face[s[edges.a] * s[edges.b] < 0])
    mine = np.zeros(len(corners), bool)
    mine[[bi for bi, _ in members]] = True
    if not within[crossing][:, mine].any():
        return None             # no face crosses the plane within the box
    if (np.abs(s) <= _DIRECT_GAP).any():
        raise _Decline("a corner of the plate on a box face's plane")
    n = -gn                                     # the result's face looks into the box
    c = gd * gn
    axes = _plane_axes(n)
    rect = corners[[bi for bi, _ in members]][np.arange(len(members))[:, None],
                                              _BOX_FACES[[fi for _, fi in members]]]
    rect = _rings(((rect - c) @ axes.T).reshape(-1, 2), [4] * len(members))
    section = _polyhedron_section(points, edges, normals, n, s, c, axes)
    if not section:
        return None
    region = shapely.intersection(rect[0] if len(rect) == 1 else shapely.union_all(rect),
                                  section[0] if len(section) == 1 else shapely.union_all(section))
    if region.is_empty:
        return None
    return _less_other_boxes(region, corners, mine, n, c, axes), (n, c, axes)


def _less_other_boxes(region, corners: np.ndarray, mine: np.ndarray, n: np.ndarray,
                      c: np.ndarray, axes: np.ndarray):
    """A box face's ``region`` (shapely, in its plane's frame: normal ``n``, origin ``c``,
    ``axes``) less the sections by its plane of the boxes not ``mine`` whose bounding boxes
    meet those of ``mine``."""
    import shapely

    box_lo, box_hi = corners.min(axis=1), corners.max(axis=1)
    others = np.flatnonzero(~mine & (box_lo <= box_hi[mine].max(axis=0)).all(axis=1)
                            & (box_hi >= box_lo[mine].min(axis=0)).all(axis=1))
    if len(others):
        k = len(others)
        x = _box_sections(corners[others], np.tile(n, (k, 1)), np.full(k, float(n @ c)),
                          np.tile(c, (k, 1)), np.tile(axes, (k, 1, 1)))
        x = [y for y in x if y is not None]
        if x:
            region = shapely.difference(region, x[0] if len(x) == 1 else shapely.union_all(x))
    return region
