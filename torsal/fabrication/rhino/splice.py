"""Records (:func:`~.brep.brep_record`) put into a .3dm file that rhino3dm wrote with
placeholder objects in their places (:func:`placeholder`, :func:`splice_records`): the file is
then the one rhino3dm writes with those Breps, but for the properties' time stamp.

Offsets and lengths in bytes.
"""
from __future__ import annotations

import struct
from typing import Callable, NamedTuple

from .records import _HEAD, _TC_CLASS

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
    with the objects of ``records`` {key: record (:func:`~.brep.brep_record`)} in the place of
    their placeholders (points added with ``File3dmObjectTable.AddPoint`` at
    :func:`placeholder` ``(key)``, keeping their attributes): in each such object record the
    object type becomes a Brep's and the point's ``TCODE_OPENNURBS_CLASS`` chunk the Brep's;
    the lengths of the object records, of the object table and of the file (its end mark)
    follow. The object records' CRC is unchanged (openNURBS leaves nested chunks out of it).
    ValueError if the file is not so made or a placeholder is missing."""
    done: set = set()

    def replace(c: "_Chunk") -> list | None:
        if c.tc != _TC_OBJECT_TABLE:
            return None
        table = _object_table(data, c.start, c.stop, records)
        done.update(table.keys)
        return [_HEAD.pack(c.tc, sum(map(len, table.pieces))), *table.pieces]

    out = rewritten(data, replace)
    if done != set(records):
        raise ValueError(f"{len(set(records) - done)} placeholders are not in the file")
    return out


def rewritten(data: bytes, replace: Callable[["_Chunk"], list | None]) -> bytes:
    """The bytes of the .3dm file ``data`` (version 5 or later: 8-byte chunk lengths) with each
    top-level chunk ``c`` for which ``replace(c)`` gives pieces (bytes-likes) replaced by them
    (None: kept as it is), and the file's end mark (its length) after them. ValueError if the
    file is not so made."""
    if not data.startswith(b"3D Geometry File Format ") or int(data[24:32]) < 50:
        raise ValueError("not a .3dm file of version 5 or later")
    mv = memoryview(data)
    out = [data[:32]]
    for c in _chunks(data, 32, len(data)):
        if c.tc == _TC_END_OF_FILE:
            if c.stop != len(data) or c.value != 8:
                raise ValueError("the file does not end with its end mark")
            out.append(_HEAD.pack(c.tc, 8) + struct.pack("<q", sum(map(len, out)) + 20))
            return b"".join(out)
        pieces = replace(c)
        out.extend([mv[c.start:c.stop]] if pieces is None else pieces)
    raise ValueError("the file has no end mark")


class _Chunk(NamedTuple):
    """A chunk of a .3dm file: ``data[start:stop]``."""
    tc: int         #: its type code
    value: int      #: its length, or its value (a short chunk: ``tc & _SHORT``)
    start: int      #: offset of its head
    stop: int       #: offset after it


def _chunks(data: bytes, a: int, b: int):
    """The chunks (:class:`_Chunk`) one after another in ``data[a:b]``, lazily; ValueError
    where one runs past ``b``."""
    while a < b:
        tc, value = _HEAD.unpack_from(data, a)
        n = 0 if tc & _SHORT else value
        if n < 0 or a + 12 + n > b:
            raise ValueError("not a .3dm file with 8-byte chunk lengths")
        yield _Chunk(tc, value, a, a + 12 + n)
        a += 12 + n


class _Table(NamedTuple):
    """An object table's new bytes (:func:`_object_table`)."""
    pieces: list    #: its object records (bytes or memoryviews), in order
    keys: set       #: the keys of the records put in


def _object_table(data: bytes, a: int, b: int, records: dict) -> _Table:
    """The object records of the object table ``data[a:b]`` (a chunk), each placeholder of a
    key of ``records`` replaced by :func:`_brep_object`."""
    mv = memoryview(data)
    pieces, keys = [], set()
    for rec in _chunks(data, a + 12, b):
        inner = rec.tc == _TC_OBJECT_RECORD
        parts = list(_chunks(data, rec.start + 12, rec.stop - 4)) if inner else []
        key = _placeholder_key(data, parts)
        if key is None or key not in records:
            pieces.append(mv[rec.start:rec.stop])
            continue
        keys.add(key)
        pieces.extend(_brep_object(mv, rec, parts, records[key]))
    return _Table(pieces, keys)


def _brep_object(mv: memoryview, rec: _Chunk, parts: list, record: bytes) -> list:
    """The pieces of object record ``rec`` (its chunks ``parts``) with the object type a
    Brep's and the class chunk ``record``; its length follows, its CRC (the last 4 bytes)
    stays."""
    body = []
    for ptc, _, pa, pb in parts:
        if ptc == _TC_OBJECT_RECORD_TYPE:
            body.append(_HEAD.pack(ptc, _BREP_OBJECT))
        elif ptc == _TC_CLASS:
            body.append(record)
        else:
            body.append(mv[pa:pb])
    crc = mv[rec.stop - 4:rec.stop]
    return [_HEAD.pack(rec.tc, sum(map(len, body)) + 4), *body, crc]


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
