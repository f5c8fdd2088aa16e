"""A sheet's DXF written as text: the bytes ezdxf writes, without building its document.

:meth:`~.layout.Layout.sheet_document` builds a sheet as an ezdxf document; writing 7a's 40
sheets that way took 2.2 CPU s, most of it ezdxf's generic per-attribute machinery (entity
objects, attribute validation, tag objects). A sheet is four kinds of entity on a fixed frame,
so :class:`DxfSkeleton` has ezdxf write the frame once (header, classes, tables, blocks,
objects: an empty sheet of the same size and unit) and :func:`sheet_text` puts the entities
into it as ezdxf writes them (``%3d\\n%s\\n`` group code and value, floats as ``repr``, the
optional tags only when they differ from their default): the same bytes, about fifteen times
faster. The handles follow ezdxf's: the entities take the handles after those of the empty
document in drawing order, and the entries ezdxf adds on saving (application ids, the
``WRITTEN_BY_EZDXF`` variable) and ``$HANDSEED`` come after them.

A drawing this writer does not cover as ezdxf does (a text ezdxf would change: a line break or
a trailing ``^``; a text height not above zero; an outline without points) is written by ezdxf
(:func:`plain`). ``tests/fabrication/test_sheet_dxf.py`` compares the bytes with ezdxf's.
"""
from __future__ import annotations

import io

__all__ = ["DxfSkeleton", "sheet_text", "plain"]

#: group codes whose values are handles (own handle, owner, soft/hard pointers)
_HANDLE_CODES = {"5", "105", "330", "340", "350", "360"}
#: TEXT alignment of a drawing's anchor: (horizontal 72, vertical 73), ezdxf's
#: ``MIDDLE_CENTER`` and ``BOTTOM_CENTER``
_ALIGN = {"middle": (1, 2), "bottom": (1, 1)}


class DxfSkeleton:
    """The frame of a sheet's DXF as ezdxf writes it for ``document`` (an ezdxf document
    without entities, the sheet's header and layers set; it is written here, with ezdxf's
    fixed metadata in force): the text before and after the entities, with the handles ezdxf
    allocates on saving left open (they follow the entities')."""

    def __init__(self, document):
        self.first = 1 + max(int(h, 16) for h in document.entitydb.keys())
        self.owner = document.modelspace().layout_key
        stream = io.StringIO()
        document.write(stream)
        lines = stream.getvalue().split("\n")
        #: str pieces and int offsets (a handle: first handle after the entities + offset)
        self._pieces: list = []
        text: list[str] = []
        for i in range(0, len(lines) - 1, 2):
            code, value = lines[i], lines[i + 1]
            text.append(code + "\n")
            if code.strip() in _HANDLE_CODES and _is_hex(value) and int(value, 16) >= self.first:
                self._pieces += ["".join(text), int(value, 16) - self.first]
                text = ["\n"]
            else:
                text.append(value + "\n")
            if code == "  2" and value == "ENTITIES":
                self._pieces.append("".join(text))
                self._pieces.append(None)           # the entities go here
                text = []
        self._pieces.append("".join(text))
        if self._pieces.count(None) != 1:
            raise ValueError("the ezdxf document written has no ENTITIES section")

    def text(self, entities: str, n: int) -> str:
        """The whole file with ``entities`` (the text of ``n`` entities, handles from
        :attr:`first`) in its ENTITIES section."""
        after = self.first + n
        return "".join(entities if p is None else p if isinstance(p, str) else f"{after + p:X}"
                       for p in self._pieces)


def _is_hex(value: str) -> bool:
    try:
        int(value, 16)
    except ValueError:
        return False
    return True


def plain(drawing: list[tuple]) -> bool:
    """Whether :func:`sheet_text` writes ``drawing`` (:meth:`~.layout.Layout.sheet_drawing`)
    as ezdxf does: texts on one line not ending in ``^`` (ezdxf would strip those), text
    heights above zero (ezdxf would put its default), outlines with points (ezdxf leaves
    those out but gives them a handle), texts UTF-8 can write."""
    for kind, _layer, *geo in drawing:
        if kind == "poly" and not len(geo[0]):
            return False
        if kind == "text":
            text, height = geo[0], geo[2]
            if "\n" in text or "\r" in text or text.endswith("^") or not float(height) > 0:
                return False
            try:
                text.encode("utf-8")
            except UnicodeEncodeError:      # a lone surrogate: ezdxf's error handler replaces it
                return False
    return True


def _xyz(p) -> tuple[float, float, float]:
    """A point as ezdxf's ``Vec3`` has it: ``(x, y)`` gets ``z = 0``."""
    p = tuple(p)
    return float(p[0]), float(p[1]), float(p[2]) if len(p) > 2 else 0.0


def sheet_text(skeleton: DxfSkeleton, drawing: list[tuple]) -> str:
    """The DXF of a sheet: ``drawing``'s items (:meth:`~.layout.Layout.sheet_drawing`, which
    :func:`plain` accepts) as the entities :meth:`~.layout.Layout.sheet_document` adds for
    them (closed LWPOLYLINE, CIRCLE, LINE, TEXT), in ``skeleton``."""
    out: list[str] = []
    w = out.append
    owner = skeleton.owner
    for i, (kind, layer, *geo) in enumerate(drawing):
        head = f"{skeleton.first + i:X}\n330\n{owner}\n100\nAcDbEntity\n  8\n{layer}\n100\n"
        if kind == "poly":
            pts = geo[0]
            w(f"  0\nLWPOLYLINE\n  5\n{head}AcDbPolyline\n 90\n{len(pts)}\n 70\n1\n")
            w("".join(f" 10\n{float(p[0])!r}\n 20\n{float(p[1])!r}\n" for p in pts))
        elif kind == "circle":
            x, y, z = _xyz(geo[0])
            w(f"  0\nCIRCLE\n  5\n{head}AcDbCircle\n 10\n{x!r}\n 20\n{y!r}\n 30\n{z!r}\n"
              f" 40\n{0.5 * geo[1]!r}\n")
        elif kind == "line":
            (x, y, z), (u, v, t) = _xyz(geo[0]), _xyz(geo[1])
            w(f"  0\nLINE\n  5\n{head}AcDbLine\n 10\n{x!r}\n 20\n{y!r}\n 30\n{z!r}\n"
              f" 11\n{u!r}\n 21\n{v!r}\n 31\n{t!r}\n")
        else:
            text, at, height, rot, anchor = geo
            x, y, z = _xyz(at)
            h, v = _ALIGN[anchor]
            rot = float(rot)
            w(f"  0\nTEXT\n  5\n{head}AcDbText\n 10\n{x!r}\n 20\n{y!r}\n 30\n{z!r}\n"
              f" 40\n{float(height)!r}\n  1\n{text}\n" + (f" 50\n{rot!r}\n" if rot != 0 else "")
              + f" 72\n{h}\n 11\n{x!r}\n 21\n{y!r}\n 31\n{z!r}\n100\nAcDbText\n 73\n{v}\n")
    return skeleton.text("".join(out), len(drawing))
