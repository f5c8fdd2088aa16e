"""The Rhino 3DM form of a solid part: a closed, valid Brep of its OCC solid with one planar
face per plane face of the solid, as openNURBS writes it into a .3dm file
(:func:`brep_record`, bytes that a worker process makes without rhino3dm), the rhino3dm
``Brep`` of those bytes (:func:`brep_of`), and a .3dm file written by rhino3dm with such
records put in the place of placeholder objects (:func:`splice_records`).

Why bytes: rhino3dm (8.x) has no way to join faces into a Brep but ``Brep.CreateFromMesh``,
which makes a face of every triangle or quad of the mesh (twice as many faces as the solids
have on example 7a, each a NURBS surface with NURBS trims) and leaves the edges' tolerance
unset (the Brep is not valid until its encoding is patched and decoded again); that, and
decoding and writing those Breps, cost 7.6-8.6 s of CPU on 7a's 314 parts, 1.1-1.2 s now
(``benchmarks/rhino_bench.py``, on a loaded machine). The record here is what openNURBS writes for an ``ON_Brep``
of ``ON_PlaneSurface`` faces trimmed by ``ON_LineCurve`` s (as rhino3dm's own
``Brep.CreateFromBox`` makes them), built with numpy from the solid's faces, checked to be
closed (every edge on two faces, in opposite senses) with outward faces; rhino3dm reads it as
a valid solid and writes it again byte for byte (the tests check both on every part).

Units: those of the solid.
"""
from __future__ import annotations

import struct
import zlib

import numpy as np

from .plates import _face_triangles

__all__ = ["brep_of", "encoded_brep", "brep_record", "splice_records"]


def brep_record(shape, tolerance: float, *, threads: bool = True) -> bytes | None:
    """The 3DM record (openNURBS ``WriteObject`` bytes of an ``ON_Brep``, as in a version 7 or
    8 .3dm file) of the closed Brep of an OCC solid: one planar face per plane face of the
    solid (the outlines of its mesh's faces at ``tolerance``: plane faces are exact), a curved
    face (a bolt hole's wall) as its mesh's triangles, with the solid's vertices; None where
    the faces do not make one (an outline that touches itself, faces that do not close):
    :func:`brep_of` then joins the mesh. ``threads=False`` in forked processes (see
    :func:`~.plates._mesh`)."""
    faces = _polygon_faces(shape, tolerance, threads)
    return None if faces is None else _brep_bytes(*faces)


def encoded_brep(shape, tolerance: float) -> dict | None:
    """rhino3dm's encoding (as ``Brep.Encode()`` gives it, picklable; rhino3dm's
    ``CommonObject.Decode`` reads it) of the 3DM Brep of ``shape`` (:func:`brep_of`); None if
    it is not a valid closed solid (the 3DM takes the mesh)."""
    record = brep_record(shape, tolerance)
    if record is not None:
        return _encoding(record)
    brep = _mesh_brep(shape, tolerance)
    return brep.Encode() if brep is not None and brep.IsSolid and brep.IsValid else None


def brep_of(shape, tolerance: float):
    """A closed rhino3dm ``Brep`` of an OCC solid: one planar face per plane face of the solid
    (:func:`brep_record`, read by rhino3dm); where the solid's faces do not make one, its mesh's
    faces joined by rhino3dm (:func:`_mesh_brep`: a face per planar quad or triangle)."""
    import rhino3dm

    record = brep_record(shape, tolerance)
    if record is not None:
        brep = rhino3dm.CommonObject.Decode(_encoding(record))
        if brep is not None:
            return brep
    return _mesh_brep(shape, tolerance)


def _mesh_brep(shape, tolerance: float):
    """A closed rhino3dm ``Brep`` of an OCC solid's mesh: one Brep face per plane face of the
    solid with four corners (a planar quad, exact), the others as the planar triangles of
    their mesh, joined along shared edges (rhino3dm's ``Brep.CreateFromMesh`` on the welded
    faces). What the 3DM takes where :func:`brep_record` makes no Brep.

    rhino3dm leaves the edges' tolerance unset (openNURBS's ON_UNSET_VALUE), which makes
    ``IsValid`` false although each edge lies exactly on both of its faces (they are built
    from the same vertices): the tolerance is set to 0 in the Brep's openNURBS record (the only
    doubles with that value, one per edge) when that makes the Brep valid."""
    import rhino3dm

    brep = rhino3dm.Brep.CreateFromMesh(_rhino_mesh(shape, tolerance), True)
    if brep is None or brep.IsValid:
        return brep
    return _with_edge_tolerances(brep)


def _rhino_mesh(shape, tolerance: float, *, quads: bool = True):
    """The rhino3dm ``Mesh`` of an OCC solid's faces (:func:`brep_of`), welded: planar quads
    as quads (with ``quads``), the rest as triangles. Pairs of coincident triangles of
    opposite orientation (a membrane of zero thickness inside the solid, which a fuzzy slot
    cut can leave: :data:`~.plates.SLOT_CUT_FUZZY`) are dropped: they enclose no volume and
    make the mesh non-manifold."""
    import rhino3dm

    faces = _face_triangles(shape, tolerance)
    pts = np.concatenate([v for v, _ in faces]) if faces else np.zeros((0, 3))
    scale = max(1.0, float(np.abs(pts).max(initial=0.0)))
    _, first, ids = np.unique(np.round(pts / (1e-9 * scale)).astype(np.int64), axis=0,
                              return_index=True, return_inverse=True)
    ids = ids.ravel()
    offsets = np.cumsum([0] + [len(v) for v, _ in faces])
    welded = [ids[o:o + len(v)][t] for o, (v, t) in zip(offsets, faces)]
    membrane = _membrane(np.concatenate(welded) if welded else np.zeros((0, 3), int))
    mesh = rhino3dm.Mesh()
    for x in pts[first]:             # double precision (Add keeps single precision)
        mesh.Vertices.AddPoint3d(float(x[0]), float(x[1]), float(x[2]))
    for (v, t), g in zip(faces, welded):
        keep = [tuple(sorted(map(int, tri))) not in membrane for tri in g]
        quad = _quad(g) if quads and len(v) == 4 and len(t) == 2 and all(keep) else None
        if quad is not None:
            mesh.Faces.AddFace(*map(int, quad))
        else:
            for (a, b, c), k in zip(g, keep):
                if k:
                    mesh.Faces.AddFace(int(a), int(b), int(c))
    return mesh


def _membrane(tris: np.ndarray) -> set:
    """The vertex sets (sorted tuples) of triangles ``tris`` (n, 3) that occur twice with
    opposite orientations."""
    key = np.sort(tris, axis=1)
    # the orientation: the parity of the vertices' inversions (a cyclic turn keeps it)
    a, b, c = np.asarray(tris).T
    parity = ((a > b).astype(int) + (a > c) + (b > c)) % 2
    seen: dict = {}
    out = set()
    for k, par in zip(map(tuple, key.tolist()), parity.tolist()):
        if k in seen and seen[k] != par:
            out.add(k)
        seen.setdefault(k, par)
    return out


def _quad(tris: np.ndarray):
    """The quad (4,) of two triangles (2, 3) that share an edge (in opposite directions), in
    their order, or None."""
    a, b = [list(map(int, t)) for t in tris]
    for i in range(3):
        u, v, w = a[i], a[(i + 1) % 3], a[(i + 2) % 3]
        for j in range(3):
            if b[j] == v and b[(j + 1) % 3] == u:
                x = b[(j + 2) % 3]
                return (u, x, v, w)
    return None


def _with_edge_tolerances(brep):
    """The Brep with its unset edge tolerances set to 0 (see :func:`brep_of`), if that makes it
    valid; else the Brep as it was."""
    import base64
    import struct

    import rhino3dm

    unset = struct.pack("<d", -1.23432101234321e+308)       # openNURBS's ON_UNSET_VALUE
    enc = brep.Encode()
    data = base64.b64decode(enc["data"])
    if data.count(unset) != len(brep.Edges):
        return brep
    enc = dict(enc, data=base64.b64encode(data.replace(unset, struct.pack("<d", 0.0))).decode())
    fixed = rhino3dm.CommonObject.Decode(enc)
    return fixed if fixed is not None and fixed.IsValid and fixed.IsSolid else brep


# ----------------------------------------------------------------------------- the faces
def _polygon_faces(shape, tolerance: float, threads: bool = True):
    """``(points (n, 3), faces)`` of an OCC solid: its meshed faces (:func:`~.plates._face_triangles`)
    welded as :func:`_rhino_mesh` welds them, without membranes (:func:`_membrane`), each
    face as its loops of point indices (the outer loop first, counter-clockwise seen from
    outside, then its holes), taken from the boundary of its triangles; a face whose
    triangles' corners are not within :data:`PLANAR` x ``tolerance`` of one plane (a curved
    hole wall) as its triangles, a face each. None where a plane face's boundary passes a
    point twice or a hole lies in none of its outer loops."""
    faces = _face_triangles(shape, tolerance, threads=threads)
    if not faces:
        return None
    pts = np.concatenate([v for v, _ in faces])
    scale = max(1.0, float(np.abs(pts).max(initial=0.0)))
    _, first, ids = np.unique(np.round(pts / (1e-9 * scale)).astype(np.int64), axis=0,
                              return_index=True, return_inverse=True)
    ids = ids.ravel()
    offsets = np.cumsum([0] + [len(v) for v, _ in faces])
    welded = [w for w in (ids[o:o + len(v)][t] for o, (v, t) in zip(offsets, faces)) if len(w)]
    if not welded:
        return None
    tris = np.concatenate(welded)
    membrane = _membrane(tris)
    points = pts[first]
    # planar faces: all the corners of their triangles near the plane of their area vector
    n_tri = np.array([len(t) for t in welded])
    at = np.cumsum(n_tri) - n_tri
    corners = points[tris]                                          # (m, 3, 3)
    area = np.add.reduceat(_cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), at)
    norm = np.linalg.norm(area, axis=1)
    z = area / np.where(norm > 0, norm, 1.0)[:, None]
    face_of = np.repeat(np.arange(len(welded)), n_tri)
    dev = np.abs(np.einsum("mkj,mj->mk", corners - corners[at][face_of, :1], z[face_of])).max(axis=1)
    planar = (norm > 0) & (np.maximum.reduceat(dev, at) <= PLANAR * tolerance)
    out = []
    for g, flat in zip(welded, planar.tolist()):
        directed = {}                     # directed edges of the face's triangles, in order
        kept = []
        for a, b, c in g.tolist():
            if a == b or b == c or a == c or (membrane and tuple(sorted((a, b, c))) in membrane):
                continue
            kept.append([[a, b, c]])
            directed[(a, b)] = directed[(b, c)] = directed[(c, a)] = None
        if not flat:                      # a curved face: its triangles
            out.extend(kept)
            continue
        nxt = {}
        for a, b in directed:
            if (b, a) not in directed:    # on the boundary of the face
                if a in nxt:
                    return None           # the boundary passes a point twice
                nxt[a] = b
        loops = []
        while nxt:
            start = next(iter(nxt))
            loop, b = [start], nxt.pop(start)
            while b != start:
                loop.append(b)
                b = nxt.pop(b, None)
                if b is None:
                    return None
            loops.append(loop)
        if len(loops) == 1:
            out.append(loops)
        elif loops:
            split = _outer_and_holes(points, loops)
            if split is None:
                return None
            out.extend(split)
    return (points, out) if out else None


#: a face of a solid is a plane face in :func:`brep_record` if the corners of its triangles lie
#: within this fraction of the mesh's deflection of one plane (OpenCascade's plane faces:
#: 1e-11 mm and less on example 7a; a curved face's mesh: about the deflection)
PLANAR = 1e-4


def _outer_and_holes(points: np.ndarray, loops: list) -> list | None:
    """Faces ``[[outer, hole, ...], ...]`` of the boundary loops of one plane face: outer loops
    turn about the face's normal (the Newell vector of the largest loop), holes against it,
    each hole in the outer loop that holds its first point; None if one lies in none."""
    newell = [_newell(points[lp]) for lp in loops]
    normal = max(newell, key=lambda n: float(n @ n))
    outer = [i for i, n in enumerate(newell) if n @ normal > 0]
    faces = {i: [loops[i]] for i in outer}
    z = normal / np.linalg.norm(normal)
    x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    frame = np.stack([x / np.linalg.norm(x), np.cross(z, x / np.linalg.norm(x))], axis=1)
    for i, n in enumerate(newell):
        if i in faces:
            continue
        p = points[loops[i][0]] @ frame
        holder = [j for j in outer if _inside(p, points[loops[j]] @ frame)]
        if len(holder) != 1:
            return None
        faces[holder[0]].append(loops[i])
    return list(faces.values())


def _newell(p: np.ndarray) -> np.ndarray:
    """Newell vector (twice the vector area) of a closed polygon (k, 3)."""
    q = p - p.mean(axis=0)
    return np.cross(q, np.roll(q, -1, axis=0)).sum(axis=0)


def _inside(p: np.ndarray, poly: np.ndarray) -> bool:
    """Whether 2d point ``p`` lies inside polygon ``poly`` (k, 2) (crossing number)."""
    x, y = poly[:, 0], poly[:, 1]
    x1, y1 = np.roll(x, -1), np.roll(y, -1)
    cross = (y > p[1]) != (y1 > p[1])
    with np.errstate(divide="ignore", invalid="ignore"):
        xs = x + (p[1] - y) * (x1 - x) / (y1 - y)
    return bool(np.count_nonzero(cross & (p[0] < xs)) % 2)


# ------------------------------------------------------------------------- the record
# openNURBS chunk type codes (opennurbs_3dm.h) and class ids
_TC_CLASS, _TC_CLASS_UUID, _TC_CLASS_DATA, _TC_CLASS_END = 0x00027FFA, 0x0002FFFB, 0x0002FFFC, 0x80027FFF
_TC_ANONYMOUS = 0x40008000
_BREP_ID = "60b5dbc5-e660-11d3-bfe4-0010830122f0"          # ON_Brep
_LINE_ID = "4ed7d4db-e947-11d3-bfe5-0010830122f0"          # ON_LineCurve
_PLANE_ID = "4ed7d4df-e947-11d3-bfe5-0010830122f0"         # ON_PlaneSurface
_UNSET = -1.23432101234321e+308                             # ON_UNSET_VALUE
_SQRT_EPSILON = 1.490116119385000000e-8                     # ON_SQRT_EPSILON
_EPSILON = 2.2204460492503131e-16                           # ON_EPSILON
_HEAD = struct.Struct("<Iq")            # a chunk's type code and length (8 bytes: 3dm >= 5)


def _object_dtype(data_fields: list) -> np.dtype:
    """One element of an ON_CurveArray / ON_SurfaceArray: 1 (not null) and ``WriteObject``'s
    TCODE_OPENNURBS_CLASS chunk (class id chunk, data chunk ending in its CRC, end chunk)
    around the object's ``Write()``, ``data_fields``."""
    return np.dtype([("flag", "<i4"), ("class_tc", "<u4"), ("class_len", "<i8"),
                     ("uuid", "V32"), ("data_tc", "<u4"), ("data_len", "<i8")] + data_fields
                    + [("crc", "<u4"), ("end_tc", "<u4"), ("end_len", "<i8")])


_LINE = _object_dtype([("version", "u1"), ("line", "<f8", (6,)), ("t", "<f8", (2,)), ("dim", "<i4")])
_PLANE = _object_dtype([("version", "u1"), ("plane", "<f8", (16,)), ("domain", "<f8", (4,)),
                        ("extents", "<f8", (4,))])
_TRIM = np.dtype([("index", "<i4"), ("c2i", "<i4"), ("proxy", "<f8", (2,)), ("ei", "<i4"),
                  ("vi", "<i4", (2,)), ("rev3d", "<i4"), ("type", "<i4"), ("iso", "<i4"),
                  ("li", "<i4"), ("tolerance", "<f8", (2,)), ("domain", "<f8", (2,)),
                  ("proxy_flags", "V32"), ("legacy", "<f8", (2,))])
_EDGE = np.dtype([("index", "<i4"), ("c3i", "<i4"), ("reversed", "<i4"), ("proxy", "<f8", (2,)),
                  ("vi", "<i4", (2,)), ("n_trims", "<i4"), ("ti", "<i4", (2,)),
                  ("tolerance", "<f8"), ("domain", "<f8", (2,))])


def _class_uuid_chunk(class_id: str) -> bytes:
    """The TCODE_OPENNURBS_CLASS_UUID chunk of a class: its id and the id's CRC."""
    import uuid

    b = uuid.UUID(class_id).bytes_le
    return _HEAD.pack(_TC_CLASS_UUID, 20) + b + struct.pack("<I", zlib.crc32(b))


def _template(dtype: np.dtype, class_id: str) -> np.ndarray:
    """An array element of one class with its chunk heads filled in (:func:`_objects`)."""
    a = np.zeros(1, dtype)
    data = dtype.itemsize - 4 - 12 - 32 - 12 - 4 - 12        # the object's Write()
    a["flag"] = 1
    a["class_tc"], a["class_len"] = _TC_CLASS, 32 + 12 + data + 4 + 12
    a["uuid"] = np.void(_class_uuid_chunk(class_id))
    a["data_tc"], a["data_len"] = _TC_CLASS_DATA, data + 4
    a["end_tc"] = _TC_CLASS_END
    return a


_TEMPLATES = {(_LINE, _LINE_ID): _template(_LINE, _LINE_ID),
              (_PLANE, _PLANE_ID): _template(_PLANE, _PLANE_ID)}
_BREP_UUID_CHUNK = _class_uuid_chunk(_BREP_ID)


def _objects(dtype: np.dtype, class_id: str, n: int) -> np.ndarray:
    """``n`` array elements of one class with their chunk heads filled in."""
    return np.repeat(_TEMPLATES[dtype, class_id], n)


def _object_bytes(a: np.ndarray) -> bytes:
    """The elements' bytes, each object's data CRC filled in."""
    data = a.dtype.itemsize - 4 - 12 - 32 - 12 - 4 - 12
    start = 4 + 12 + 32 + 12
    buf = memoryview(a.tobytes())
    step = a.dtype.itemsize
    a["crc"] = [zlib.crc32(buf[i * step + start:i * step + start + data]) for i in range(len(a))]
    return a.tobytes()


def _array_chunk(direct: bytes, crc_direct: bytes | None = None) -> bytes:
    """A TCODE_ANONYMOUS_CHUNK (openNURBS's arrays): its bytes are ``direct`` and its CRC is
    that of ``crc_direct`` (default ``direct``): openNURBS leaves the bytes of chunks nested in
    a chunk out of its CRC."""
    crc = zlib.crc32(direct if crc_direct is None else crc_direct)
    return b"".join((_HEAD.pack(_TC_ANONYMOUS, len(direct) + 4), direct, struct.pack("<I", crc)))


def _object_array(a: np.ndarray) -> bytes:
    """ON_CurveArray / ON_SurfaceArray::Write of elements ``a`` (:func:`_objects`)."""
    head = b"\x10" + struct.pack("<i", len(a))
    body = head + _object_bytes(a)
    # the CRC: the version, the count and the flags (the objects are nested chunks)
    return _array_chunk(body, head + struct.pack("<i", 1) * len(a))


def _param_tolerance(t0, t1, t):
    """ON_GetParameterTolerance (opennurbs_math.cpp) on arrays: (t - dt, t + dt)."""
    t = np.minimum(np.maximum(t, t0), t1)
    dt = (t1 - t0) * 8.0 * _SQRT_EPSILON + (np.abs(t0) + np.abs(t1)) * _EPSILON
    dt = np.where(dt >= t1 - t0, 0.5 * (t1 - t0), dt)
    return t - dt, t + dt


def _iso(u0, v0, u1, v1, s0, s1, t0, t1) -> np.ndarray:
    """The trims' ``m_iso``: openNURBS's ``ON_Surface::IsIsoparametric`` (opennurbs_surface.cpp)
    of 2d lines (u0, v0)-(u1, v1) on plane surfaces with domains [s0, s1] x [t0, t1] (arrays),
    in the same floating point steps (``ON_Brep::IsValid`` requires the same value): 0 not_iso,
    1 x_iso, 2 y_iso, 3 W_iso, 4 S_iso, 5 E_iso, 6 N_iso. (A line's ``IsLinear`` test, the
    last step, is always true.)"""
    minx, maxx = np.minimum(u0, u1), np.maximum(u0, u1)
    miny, maxy = np.minimum(v0, v1), np.maximum(v0, v1)
    ds, dt = maxx - minx, maxy - miny
    stol, ttol = (s1 - s0) / 32.0, (t1 - t0) / 32.0
    iso = np.zeros(len(u0), np.int32)
    cand = (s0 < s1) & (t0 < t1) & ((ds <= stol) | (dt <= ttol))
    su = cand & (ds * (t1 - t0) <= dt * (s1 - s0))         # s = constant
    sv = cand & ~su                                       # t = constant
    a, b = _param_tolerance(s0, s1, s0)
    west = su & (maxx <= s0 + stol)
    iso[west & (a <= minx) & (maxx <= b)] = 3
    a, b = _param_tolerance(s0, s1, s1)
    east = su & ~west & (minx >= s1 - stol)
    iso[east & (a <= minx) & (maxx <= b)] = 5
    a, b = _param_tolerance(s0, s1, 0.5 * (minx + maxx))
    iso[su & (iso == 0) & ((s0 < maxx) | (minx < s1)) & (a <= minx) & (maxx <= b)] = 1
    a, b = _param_tolerance(t0, t1, t0)
    south = sv & (maxy <= t0 + ttol)
    iso[south & (a < miny) & (maxy <= b)] = 4
    a, b = _param_tolerance(t0, t1, t1)
    north = sv & ~south & (miny >= t1 - ttol)
    iso[north & (a < miny) & (maxy <= b)] = 6
    a, b = _param_tolerance(t0, t1, 0.5 * (miny + maxy))
    # (openNURBS compares t0, t1 with the x extent here: kept as it is)
    iso[sv & (iso == 0) & ((t0 < maxx) | (minx < t1)) & (a < miny) & (maxy <= b)] = 2
    return iso


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross products of (n, 3) arrays (np.cross costs more on small arrays)."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=1)


def _brep_bytes(points: np.ndarray, faces: list) -> bytes | None:
    """The record (:func:`brep_record`) of a Brep of planar ``faces`` (lists of loops of indices
    into ``points``, :func:`_polygon_faces`): per face an ``ON_PlaneSurface`` through the
    centroid of its outer loop, normal its Newell vector, x along its first side, domain
    the loops' extent; per edge a 3d ``ON_LineCurve`` between its vertices, per trim a 2d one
    (the edge's ends in the face's plane), the edge's tolerance the largest distance of its
    ends from the planes of its faces (a vertex's: from those of its faces). None if an edge
    is not on exactly two faces in opposite senses, a side or a face is degenerate, or the
    faces enclose no volume (they face inwards)."""
    pts = np.asarray(points, float)
    loops = [lp for face in faces for lp in face]
    n_loop = np.array([len(lp) for lp in loops])
    if len(loops) == 0 or n_loop.min() < 3:
        return None
    loop_face = np.repeat(np.arange(len(faces)), [len(f) for f in faces])
    outer = np.concatenate([[True] + [False] * (len(f) - 1) for f in faces])
    start = np.concatenate(loops)                          # each trim's first point
    n_t = len(start)
    first = np.cumsum(n_loop) - n_loop                     # each loop's first trim
    t_loop = np.repeat(np.arange(len(loops)), n_loop)
    nxt = np.arange(1, n_t + 1)
    nxt[first + n_loop - 1] = first                        # the next trim in the loop
    end = start[nxt]
    t_face = loop_face[t_loop]
    # the faces' planes: from their outer loops
    on_outer = outer[t_loop]
    face_first = first[outer]                              # each face's first trim
    count = np.bincount(t_face[on_outer], minlength=len(faces))
    at = np.cumsum(count) - count                          # (in the outer loops' trims)
    centre = np.add.reduceat(pts[start[on_outer]], at) / count[:, None]
    q0 = pts[start] - centre[t_face]
    q1 = pts[end] - centre[t_face]
    newell = np.add.reduceat(_cross(q0, q1)[on_outer], at)
    norm = np.linalg.norm(newell, axis=1)
    side = pts[end[face_first]] - pts[start[face_first]]
    if not np.all(norm > 0) or not np.all(np.isfinite(norm)):
        return None
    z = newell / norm[:, None]
    x = side - np.einsum("ij,ij->i", side, z)[:, None] * z
    xn = np.linalg.norm(x, axis=1)
    if not np.all(xn > 0):
        return None
    x /= xn[:, None]
    y = _cross(z, x)
    # the trims' ends in their face's frame: u, v and the distance from the plane
    u0, v0, d0 = (np.einsum("ij,ij->i", q0, w[t_face]) for w in (x, y, z))
    u1, v1 = u0[nxt], v0[nxt]
    # the faces' domains (the extent of all their loops)
    s0, s1 = np.minimum.reduceat(u0, face_first), np.maximum.reduceat(u0, face_first)
    w0, w1 = np.minimum.reduceat(v0, face_first), np.maximum.reduceat(v0, face_first)
    # edges: each pair of points, on exactly two trims in opposite senses
    lo, hi = np.minimum(start, end), np.maximum(start, end)
    if np.any(lo == hi):
        return None
    key = lo * len(pts) + hi
    _, e_first, t_edge, e_count = np.unique(key, return_index=True, return_inverse=True,
                                            return_counts=True)
    t_edge = t_edge.ravel()
    forward = start < end
    if np.any(e_count != 2) or np.any(np.bincount(t_edge, weights=forward) != 1):
        return None
    n_e = len(e_first)
    e_lo, e_hi = lo[e_first], hi[e_first]
    length = np.linalg.norm(pts[e_hi] - pts[e_lo], axis=1)
    if not np.all(length > 1e-9 * max(1.0, float(np.abs(pts).max()))):
        return None
    e_trims = np.argsort(t_edge, kind="stable").reshape(n_e, 2)
    # the solid's volume: the faces' fans (divergence theorem), > 0 when they face out
    volume = np.einsum("ij,ij->", pts[start], _cross(pts[end], centre[t_face])) / 6.0
    if not volume > 0:
        return None
    # tolerances: the distance of the ends from the faces' planes
    dev = np.abs(d0)
    t_tol = np.maximum(dev, dev[nxt])
    e_tol = np.maximum(t_tol[e_trims[:, 0]], t_tol[e_trims[:, 1]])
    used, vi = np.unique(np.concatenate([e_lo, e_hi]), return_inverse=True)
    vi = vi.ravel()
    v_lo, v_hi = vi[:n_e], vi[n_e:]
    v_tol = np.zeros(len(used))
    t_v0 = np.searchsorted(used, start)                    # each trim's first vertex
    np.maximum.at(v_tol, t_v0, dev)
    # 2d curves (one per trim) and 3d curves (one per edge)
    c2 = _objects(_LINE, _LINE_ID, n_t)
    c2["version"] = 0x10
    c2["line"][:, 0], c2["line"][:, 1], c2["line"][:, 3], c2["line"][:, 4] = u0, v0, u1, v1
    c2["t"][:, 1] = length[t_edge]
    c2["dim"] = 2
    c3 = _objects(_LINE, _LINE_ID, n_e)
    c3["version"] = 0x10
    c3["line"][:, :3], c3["line"][:, 3:] = pts[e_lo], pts[e_hi]
    c3["t"][:, 1] = length
    c3["dim"] = 3
    srf = _objects(_PLANE, _PLANE_ID, len(faces))
    srf["version"] = 0x11
    srf["plane"] = np.concatenate(
        [centre, x, y, z, z, -(z[:, 0] * centre[:, 0] + z[:, 1] * centre[:, 1] + z[:, 2] * centre[:, 2])[:, None]],
        axis=1)
    srf["domain"] = srf["extents"] = np.stack([s0, s1, w0, w1], axis=1)
    # vertices: index, point, edges, tolerance
    ends = np.concatenate([v_lo, v_hi])
    v_edges = np.lexsort((np.tile(np.arange(n_e), 2), ends)) % n_e    # by vertex, then edge
    v_count = np.bincount(ends, minlength=len(used))
    v_at = np.cumsum(v_count) - v_count
    vp = pts[used].tolist()
    ve = v_edges.tolist()
    V = [b"\x10", struct.pack("<i", len(used))]
    for k in range(len(used)):
        c, a = int(v_count[k]), int(v_at[k])
        V.append(struct.pack(f"<i3di{c}id", k, *vp[k], c, *ve[a:a + c], v_tol[k]))
    E = np.zeros(n_e, _EDGE)
    E["index"] = E["c3i"] = np.arange(n_e)
    E["proxy"][:, 1] = E["domain"][:, 1] = length
    E["vi"] = np.stack([v_lo, v_hi], axis=1)
    E["n_trims"] = 2
    E["ti"] = e_trims
    E["tolerance"] = e_tol
    T = np.zeros(n_t, _TRIM)
    T["index"] = T["c2i"] = np.arange(n_t)
    T["proxy"][:, 1] = T["domain"][:, 1] = length[t_edge]
    T["ei"] = t_edge
    T["vi"] = np.stack([t_v0, t_v0[nxt]], axis=1)
    T["rev3d"] = ~forward
    T["type"] = 2                                          # mated
    T["iso"] = _iso(u0, v0, u1, v1, s0[t_face], s1[t_face], w0[t_face], w1[t_face])
    T["li"] = t_loop
    T["legacy"] = _UNSET
    L = [b"\x10", struct.pack("<i", len(loops))]
    for li in range(len(loops)):
        a, c = int(first[li]), int(n_loop[li])
        L.append(struct.pack(f"<ii{c}iii", li, c, *range(a, a + c), 1 if outer[li] else 2,
                             int(loop_face[li])))
    F = [b"\x12", struct.pack("<i", len(faces))]          # chunk 1.2: version 7 files
    li = 0
    for fi, face in enumerate(faces):
        c = len(face)
        F.append(struct.pack(f"<ii{c}iiii", fi, c, *range(li, li + c), fi, 0, 0))
        li += c
    F.append(bytes(16 * len(faces) + 1))                  # nil face ids, no face colours
    e_bytes = b"\x10" + struct.pack("<i", n_e) + E.tobytes()
    t_bytes = b"\x10" + struct.pack("<i", n_t) + T.tobytes()
    # the Brep's box as openNURBS computes it (and writes it again): its plane surfaces'
    corners = np.concatenate([centre + s[:, None] * x + t[:, None] * y
                              for s in (s0, s1) for t in (w0, w1)])
    bbox = struct.pack("<6d", *corners.min(axis=0).tolist(), *corners.max(axis=0).tolist())
    no_meshes = _array_chunk(bytes(len(faces)))           # no render or analysis meshes
    is_solid = struct.pack("<i", 0)                       # not known: openNURBS finds it
    region = _array_chunk(struct.pack("<ii", 1, 1) + b"\x00")   # no region topology
    body = b"".join((b"\x33", _object_array(c2), _object_array(c3), _object_array(srf),
                     _array_chunk(b"".join(V)), _array_chunk(e_bytes), _array_chunk(t_bytes),
                     _array_chunk(b"".join(L)), _array_chunk(b"".join(F)), bbox, no_meshes,
                     no_meshes, is_solid, region))
    crc = zlib.crc32(b"\x33" + bbox + is_solid)
    head = _BREP_UUID_CHUNK
    n = len(body) + 4
    return b"".join((_HEAD.pack(_TC_CLASS, len(head) + 12 + n + 12), head,
                     _HEAD.pack(_TC_CLASS_DATA, n), body, struct.pack("<I", crc),
                     _HEAD.pack(_TC_CLASS_END, 0)))


def _encoding(record: bytes) -> dict:
    """rhino3dm's encoding (``CommonObject.Decode`` reads it) of a record (:func:`brep_record`)."""
    import base64

    return {"version": 10000, "archive3dm": 70, "opennurbs": _opennurbs_version(),
            "data": base64.b64encode(record).decode()}


def _opennurbs_version() -> int:
    """The openNURBS version of rhino3dm (what its encodings state)."""
    global _OPENNURBS
    if _OPENNURBS is None:
        import rhino3dm

        _OPENNURBS = rhino3dm.Point(rhino3dm.Point3d(0, 0, 0)).Encode()["opennurbs"]
    return _OPENNURBS


_OPENNURBS = None


# ------------------------------------------------------------------------ the 3dm file
_TC_OBJECT_TABLE, _TC_OBJECT_RECORD = 0x10000013, 0x20008070
_TC_OBJECT_RECORD_TYPE, _TC_END_OF_FILE = 0x82000071, 0x00007FFF
_POINT_CLASS = bytes.fromhex("1d1a10c357f1d311bfe70010830122f0")    # ON_Point, as written
_BREP_OBJECT = 0x10                                                  # ON::brep_object
_SHORT = 0x80000000


def placeholder(key: int):
    """The rhino3dm object to add to a ``File3dm`` in the place of record ``key`` of
    :func:`splice_records` (with the object's attributes): a point at x = ``key``."""
    import rhino3dm

    return rhino3dm.Point3d(float(key), 0.0, 0.0)


def splice_records(data: bytes, records: dict) -> bytes:
    """The bytes of a .3dm file (version 5 or later: 8-byte chunk lengths) written by rhino3dm
    with the objects of ``records`` {key: record (:func:`brep_record`)} in the place of their
    placeholders (points added with ``File3dmObjectTable.AddPoint`` at :func:`placeholder`
    ``(key)``, keeping their attributes): in each such object record the object type becomes a
    Brep's and the point's ``TCODE_OPENNURBS_CLASS`` chunk the Brep's; the lengths of the object
    records, of the object table and of the file (its end mark) follow. The object records'
    CRC is unchanged (openNURBS leaves nested chunks out of it). ValueError if the file is not
    so made or a placeholder is missing."""
    head = _HEAD
    mv = memoryview(data)

    def chunks(a: int, b: int):
        while a < b:
            tc, value = head.unpack_from(data, a)
            n = 0 if tc & _SHORT else value
            if n < 0 or a + 12 + n > b:
                raise ValueError("not a .3dm file with 8-byte chunk lengths")
            yield tc, value, a, a + 12 + n
            a += 12 + n

    if not data.startswith(b"3D Geometry File Format ") or int(data[24:32]) < 50:
        raise ValueError("not a .3dm file of version 5 or later")
    out, done = [data[:32]], set()
    for tc, value, a, b in chunks(32, len(data)):
        if tc == _TC_END_OF_FILE:
            out.append(head.pack(tc, 8) + struct.pack("<q", sum(map(len, out)) + 20))
            if b != len(data) or value != 8:
                raise ValueError("the file does not end with its end mark")
            break
        if tc != _TC_OBJECT_TABLE:
            out.append(mv[a:b])
            continue
        table = []
        for rtc, _, ra, rb in chunks(a + 12, b):
            parts = list(chunks(ra + 12, rb - 4)) if rtc == _TC_OBJECT_RECORD else []
            key = _placeholder_key(data, parts)
            if key is None or key not in records:
                table.append(mv[ra:rb])
                continue
            done.add(key)
            body = []
            for ptc, pvalue, pa, pb in parts:
                if ptc == _TC_OBJECT_RECORD_TYPE:
                    body.append(head.pack(ptc, _BREP_OBJECT))
                elif ptc == _TC_CLASS:
                    body.append(records[key])
                else:
                    body.append(mv[pa:pb])
            crc = mv[rb - 4:rb]
            n = sum(map(len, body)) + 4
            table.append(head.pack(rtc, n))
            table.extend(body)
            table.append(crc)
        out.append(head.pack(tc, sum(map(len, table))))
        out.extend(table)
    else:
        raise ValueError("the file has no end mark")
    if done != set(records):
        raise ValueError(f"{len(set(records) - done)} placeholders are not in the file")
    return b"".join(out)


def _placeholder_key(data: bytes, parts: list) -> int | None:
    """The key of an object record's placeholder point (:func:`placeholder`), or None."""
    for tc, _, a, b in parts:
        if tc != _TC_CLASS:
            continue
        # class chunk: the class id chunk (12 + 16 + 4 bytes), then the data chunk: version
        # byte and the point
        if data[a + 24:a + 40] != _POINT_CLASS or b - a < 44 + 12 + 25:
            return None
        x, y, z = struct.unpack_from("<3d", data, a + 44 + 12 + 1)
        return int(x) if y == 0.0 and z == 0.0 and x == int(x) else None
    return None
