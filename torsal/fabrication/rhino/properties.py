"""The properties table of a .3dm file made a function of the model: openNURBS writes the path
the file was written to and the clock's time (created, last edited) into it, so the same parts
gave a different fins.3dm on every run (and a different size: the path of the staging file is
in it). :func:`fixed_properties` puts the file's own name in the place of the path and a fixed
time (2000-01-01 00:00:00, the date ezdxf writes into the DXF sheets for the same reason) in
the place of both times, with their CRCs, the table's length and the file's end mark after.

Offsets and lengths in bytes.
"""
from __future__ import annotations

import struct
import zlib

from .records import _HEAD
from .splice import _chunks, rewritten

__all__ = ["fixed_properties"]

_TC_PROPERTIES_TABLE = 0x10000014
_TC_FILE_NAME = 0x20008027            # TCODE_PROPERTIES_AS_FILE_NAME: a string
_TC_REVISION_HISTORY = 0x20008021     # TCODE_PROPERTIES_REVISIONHISTORY
#: 2000-01-01 00:00:00 (a Saturday) as openNURBS writes a struct tm (WriteTime): eight int32,
#: seconds, minutes, hours, day of the month, month - 1, year - 1900, weekday, day of the year
FIXED_TIME = struct.pack("<8i", 0, 0, 0, 1, 0, 100, 6, 0)
_TM = len(FIXED_TIME)


def fixed_properties(data: bytes, name: str) -> bytes:
    """The bytes of the .3dm file ``data`` (version 5 or later, as rhino3dm writes it) with the
    file name in its properties ``name`` (e.g. ``"fins.3dm"``) and its created and
    last-edited times :data:`FIXED_TIME`. ValueError if the file is not so made.

    >>> import rhino3dm, tempfile, pathlib
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "a.3dm"
    >>> rhino3dm.File3dm().Write(str(path), 7)
    True
    >>> fixed = fixed_properties(path.read_bytes(), "a.3dm")
    >>> b"t\\x00m\\x00p" in fixed        # the folder it was written to is gone
    False
    """
    return rewritten(data, lambda c: [_properties_table(data, c.start, c.stop, name)]
                     if c.tc == _TC_PROPERTIES_TABLE else None)


def _properties_table(data: bytes, a: int, b: int, name: str) -> bytes:
    """The properties table chunk ``data[a:b]`` with the file name and times fixed."""
    pieces = []
    for c in _chunks(data, a + 12, b):
        body = data[c.start + 12:c.stop]
        if c.tc == _TC_FILE_NAME:
            body = _with_crc(_wstring(name))
        elif c.tc == _TC_REVISION_HISTORY:
            body = _with_crc(_fixed_times(_checked(body)))
        else:
            pieces.append(data[c.start:c.stop])
            continue
        pieces.append(_HEAD.pack(c.tc, len(body)) + body)
    return _HEAD.pack(_TC_PROPERTIES_TABLE, sum(map(len, pieces))) + b"".join(pieces)


def _fixed_times(content: bytes) -> bytes:
    """The revision history ``content`` (no CRC): a version byte, then created-by (a string),
    created (struct tm), last-edited-by, last edited, and the rest; both times fixed."""
    content = bytearray(content)
    at = 1
    for _ in range(2):
        at = _after_wstring(content, at)
        content[at:at + _TM] = FIXED_TIME
        at += _TM
    return bytes(content)


def _after_wstring(content: bytes, at: int) -> int:
    """The offset after the string (uint32 count of UTF-16 units, then the units) at ``at``."""
    (n,) = struct.unpack_from("<I", content, at)
    end = at + 4 + 2 * n
    if end + _TM > len(content):
        raise ValueError("the revision history is not as openNURBS writes it")
    return end


def _wstring(text: str) -> bytes:
    """A string as openNURBS writes one: the count of UTF-16 units with the closing 0, then
    the units."""
    units = (text + "\0").encode("utf-16-le")
    return struct.pack("<I", len(units) // 2) + units


def _checked(body: bytes) -> bytes:
    """The content of a chunk ``body`` whose last 4 bytes are its CRC-32; ValueError if not."""
    if len(body) < 4 or zlib.crc32(body[:-4]) != struct.unpack("<I", body[-4:])[0]:
        raise ValueError("a properties chunk's CRC does not match")
    return body[:-4]


def _with_crc(content: bytes) -> bytes:
    """``content`` and its CRC-32, as openNURBS closes a chunk."""
    return content + struct.pack("<I", zlib.crc32(content))

