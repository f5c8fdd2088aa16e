"""openNURBS bytes of a Brep of planar faces (:func:`_record` of a
:class:`~.topology.Topology`): the ``WriteObject`` record of an ``ON_Brep`` as a version 7 or 8
.3dm file holds it: ``ON_PlaneSurface`` faces trimmed by ``ON_LineCurve`` s (as rhino3dm's own
``Brep.CreateFromBox`` makes them), the tables of vertices, edges, trims, loops and faces, the
box, in a TCODE_OPENNURBS_CLASS chunk with its CRCs. The curves and surfaces are numpy
structured arrays whose elements are the objects' bytes (chunk heads included).

Units: those of the topology's points.
"""
from __future__ import annotations

import struct
import zlib

import numpy as np

from .topology import Topology

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


# ------------------------------------------------------------------------- the tables
def _trim_curves(topo: Topology) -> np.ndarray:
    """The 2d ``ON_LineCurve`` s (t elements, :func:`_objects`), one per trim: its ends (u, v)
    in its face's plane, domain [0, its edge's length]."""
    p, e = topo.planes, topo.edges
    c2 = _objects(_LINE, _LINE_ID, len(topo.trims.start))
    c2["version"] = 0x10
    c2["line"][:, 0], c2["line"][:, 1], c2["line"][:, 3], c2["line"][:, 4] = p.u0, p.v0, p.u1, p.v1
    c2["t"][:, 1] = e.length[e.of_trim]
    c2["dim"] = 2
    return c2


def _edge_curves(topo: Topology) -> np.ndarray:
    """The 3d ``ON_LineCurve`` s (e elements), one per edge: from its lower point to its
    higher one, domain [0, its length]."""
    e = topo.edges
    c3 = _objects(_LINE, _LINE_ID, len(e.lo))
    c3["version"] = 0x10
    c3["line"][:, :3], c3["line"][:, 3:] = topo.points[e.lo], topo.points[e.hi]
    c3["t"][:, 1] = e.length
    c3["dim"] = 3
    return c3


def _plane_surfaces(topo: Topology) -> np.ndarray:
    """The ``ON_PlaneSurface`` s (f elements), one per face: its plane (origin, x, y, z and
    the equation z . p + d = 0), its domain as extents too."""
    p = topo.planes
    c, z = p.centre, p.z
    srf = _objects(_PLANE, _PLANE_ID, len(c))
    srf["version"] = 0x11
    srf["plane"] = np.concatenate(
        [c, p.x, p.y, z, z, -(z[:, 0] * c[:, 0] + z[:, 1] * c[:, 1] + z[:, 2] * c[:, 2])[:, None]],
        axis=1)
    srf["domain"] = srf["extents"] = np.stack([p.s0, p.s1, p.w0, p.w1], axis=1)
    return srf


def _vertex_table(topo: Topology) -> bytes:
    """The ``ON_BrepVertexArray``: per vertex its index, point, edges (by index) and
    tolerance."""
    v, n_e = topo.vertices, len(topo.edges.lo)
    ends = np.concatenate([v.lo, v.hi])
    v_edges = np.lexsort((np.tile(np.arange(n_e), 2), ends)) % n_e    # by vertex, then edge
    v_count = np.bincount(ends, minlength=len(v.point))
    v_at = np.cumsum(v_count) - v_count
    vp = topo.points[v.point].tolist()
    ve = v_edges.tolist()
    out = [b"\x10", struct.pack("<i", len(v.point))]
    for k in range(len(v.point)):
        c, a = int(v_count[k]), int(v_at[k])
        out.append(struct.pack(f"<i3di{c}id", k, *vp[k], c, *ve[a:a + c], v.tolerance[k]))
    return b"".join(out)


def _edge_table(topo: Topology) -> bytes:
    """The ``ON_BrepEdgeArray``: per edge its curve, domain, vertices, two trims, tolerance."""
    e = topo.edges
    n_e = len(e.lo)
    E = np.zeros(n_e, _EDGE)
    E["index"] = E["c3i"] = np.arange(n_e)
    E["proxy"][:, 1] = E["domain"][:, 1] = e.length
    E["vi"] = np.stack([topo.vertices.lo, topo.vertices.hi], axis=1)
    E["n_trims"] = 2
    E["ti"] = e.trims
    E["tolerance"] = e.tolerance
    return b"\x10" + struct.pack("<i", n_e) + E.tobytes()


def _trim_table(topo: Topology) -> bytes:
    """The ``ON_BrepTrimArray``: per trim its curve, domain, edge, vertices, sense against the
    edge, type (mated), ``m_iso`` (:func:`_iso`) and loop."""
    t, e, p = topo.trims, topo.edges, topo.planes
    n_t = len(t.start)
    t_v0 = topo.vertices.of_trim
    T = np.zeros(n_t, _TRIM)
    T["index"] = T["c2i"] = np.arange(n_t)
    T["proxy"][:, 1] = T["domain"][:, 1] = e.length[e.of_trim]
    T["ei"] = e.of_trim
    T["vi"] = np.stack([t_v0, t_v0[t.next]], axis=1)
    T["rev3d"] = ~e.forward
    T["type"] = 2                                          # mated
    T["iso"] = _iso(p.u0, p.v0, p.u1, p.v1, p.s0[t.face], p.s1[t.face], p.w0[t.face], p.w1[t.face])
    T["li"] = t.loop
    T["legacy"] = _UNSET
    return b"\x10" + struct.pack("<i", n_t) + T.tobytes()


def _loop_table(topo: Topology) -> bytes:
    """The ``ON_BrepLoopArray``: per loop its trims, type (1 outer, 2 inner) and face."""
    lp = topo.loops
    out = [b"\x10", struct.pack("<i", len(lp.first))]
    for li in range(len(lp.first)):
        a, c = int(lp.first[li]), int(lp.size[li])
        out.append(struct.pack(f"<ii{c}iii", li, c, *range(a, a + c), 1 if lp.outer[li] else 2,
                               int(lp.face[li])))
    return b"".join(out)


def _face_table(topo: Topology) -> bytes:
    """The ``ON_BrepFaceArray`` (chunk version 1.2, as version 7 files have it): per face its
    loops, surface, not reversed, no material; then nil face ids and no face colours."""
    per_face = topo.loops.per_face
    out = [b"\x12", struct.pack("<i", len(per_face))]
    li = 0
    for fi, c in enumerate(per_face):
        out.append(struct.pack(f"<ii{c}iiii", fi, c, *range(li, li + c), fi, 0, 0))
        li += c
    out.append(bytes(16 * len(per_face) + 1))
    return b"".join(out)


def _bbox(topo: Topology) -> bytes:
    """The Brep's box as openNURBS computes it (and writes it again): that of the corners of
    its plane surfaces' domains (6 doubles: min x, y, z, max x, y, z)."""
    p = topo.planes
    corners = np.concatenate([p.centre + s[:, None] * p.x + t[:, None] * p.y
                              for s in (p.s0, p.s1) for t in (p.w0, p.w1)])
    return struct.pack("<6d", *corners.min(axis=0).tolist(), *corners.max(axis=0).tolist())


def _record(topo: Topology) -> bytes:
    """The ``WriteObject`` record of the ``ON_Brep`` of ``topo`` (version 3.3 of ``ON_Brep``'s
    chunk): its curves, surfaces and tables, box, no meshes, solidity not known (openNURBS
    finds it), no region topology; the CRC of its class data chunk covers only the bytes not
    in nested chunks."""
    n_faces = len(topo.loops.per_face)
    bbox = _bbox(topo)
    no_meshes = _array_chunk(bytes(n_faces))              # no render or analysis meshes
    is_solid = struct.pack("<i", 0)                       # not known: openNURBS finds it
    region = _array_chunk(struct.pack("<ii", 1, 1) + b"\x00")   # no region topology
    body = b"".join((b"\x33", _object_array(_trim_curves(topo)), _object_array(_edge_curves(topo)),
                     _object_array(_plane_surfaces(topo)), _array_chunk(_vertex_table(topo)),
                     _array_chunk(_edge_table(topo)), _array_chunk(_trim_table(topo)),
                     _array_chunk(_loop_table(topo)), _array_chunk(_face_table(topo)), bbox,
                     no_meshes, no_meshes, is_solid, region))
    return _class_chunk(_BREP_UUID_CHUNK, body, zlib.crc32(b"\x33" + bbox + is_solid))


def _class_chunk(uuid_chunk: bytes, body: bytes, crc: int) -> bytes:
    """A TCODE_OPENNURBS_CLASS chunk: the class id chunk, the data chunk (``body`` and its CRC
    ``crc``), the end chunk."""
    n = len(body) + 4
    return b"".join((_HEAD.pack(_TC_CLASS, len(uuid_chunk) + 12 + n + 12), uuid_chunk,
                     _HEAD.pack(_TC_CLASS_DATA, n), body, struct.pack("<I", crc),
                     _HEAD.pack(_TC_CLASS_END, 0)))
