"""The same STEP bytes for the same solids: the colours' entities in a canonical order.

OpenCascade's STEP writer numbers the geometry of an assembly in a fixed order, but writes
the colours (one ``MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION`` per coloured
solid, with its ``STYLED_ITEM`` and style chain, at the end of the DATA section) in the order
of a map hashed by memory address: two runs of the same design gave files that differ in
thousands of lines, the solids and their colours the same. :func:`canonical_styles` renumbers
that section: the representations sorted by the geometry they colour, each followed by the
entities it refers to in the order the writer itself numbers them (depth first, in the
order of reference; a colour shared by several solids where first used).
"""
from __future__ import annotations

import re
from pathlib import Path

__all__ = ["canonical_styles", "canonical_styles_file", "canonical_occurrence_ids"]

_PRESENTATION = "MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION"
#: one instance ``#id = text;`` (text without quotes containing ';' : the writer's style
#: entities have empty or plain names)
_INSTANCE = re.compile(r"#(\d+)\s*=\s*((?:[^;']|'[^']*')*);\s*", re.S)
_REF = re.compile(r"#(\d+)")
#: the id (a label, not a reference) of an assembly's occurrence of a part
_OCCURRENCE_ID = re.compile(r"(NEXT_ASSEMBLY_USAGE_OCCURRENCE\(')(\d+)(')")


def canonical_occurrence_ids(text: str) -> str:
    """``text`` of a STEP file with its parts' occurrences (``NEXT_ASSEMBLY_USAGE_OCCURRENCE``)
    labelled 1, 2, ... in file order. OpenCascade's writer takes the labels from a counter
    that lives as long as the process: the second file a process writes (a notebook's or a
    host's second run) labelled its 40 parts 169-208 where the first had 1-40. The labels are
    names only: no entity refers to them.

    >>> canonical_occurrence_ids("#9 = NEXT_ASSEMBLY_USAGE_OCCURRENCE('169','P00','',#5,#1,$);")
    "#9 = NEXT_ASSEMBLY_USAGE_OCCURRENCE('1','P00','',#5,#1,$);"
    """
    count = iter(range(1, text.count("NEXT_ASSEMBLY_USAGE_OCCURRENCE(") + 1))
    return _OCCURRENCE_ID.sub(lambda m: f"{m.group(1)}{next(count)}{m.group(3)}", text)


def canonical_styles(text: str) -> str:
    """``text`` of a STEP file (Part 21) with its presentation section (from the first
    colour representation to the end of the DATA section) renumbered in canonical order;
    the text as it is when it has no such section, or when an entity before the section
    refers into it (then the order cannot be changed without rewriting the rest).

    >>> step = ("DATA;\\n#1 = SOLID('a');\\n#2 = SOLID('b');\\n"
    ...         f"#3 = {_PRESENTATION}('',(#4),#2);\\n#4 = STYLED_ITEM('c',(#5),#2);\\n"
    ...         "#5 = COLOUR_RGB('',1.,0.,0.);\\n"
    ...         f"#6 = {_PRESENTATION}('',(#7),#1);\\n#7 = STYLED_ITEM('c',(#5),#1);\\n"
    ...         "ENDSEC;\\n")
    >>> print(canonical_styles(step).split("#2 = SOLID('b');\\n")[1], end="")
    #3 = MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION('',(#4),#1);
    #4 = STYLED_ITEM('c',(#5),#1);
    #5 = COLOUR_RGB('',1.,0.,0.);
    #6 = MECHANICAL_DESIGN_GEOMETRIC_PRESENTATION_REPRESENTATION('',(#7),#2);
    #7 = STYLED_ITEM('c',(#5),#2);
    ENDSEC;
    """
    at = text.find(f"= {_PRESENTATION}(")         # (str.find: the file is megabytes long)
    start = text.rfind("\n", 0, at) + 1
    end = text.find("ENDSEC;", at) if at >= 0 else -1
    if end < 0 or not text.startswith("#", start):
        return text
    head, section, tail = text[:start], text[start:end], text[end:]
    body = {int(m.group(1)): m.group(2) for m in _INSTANCE.finditer(section)}
    # (the head's hundreds of thousands of references looked up without a Python loop)
    if not body or not body.keys().isdisjoint(map(int, _REF.findall(head))):
        return text
    new = _numbering(body)
    lines = []
    for old in sorted(body, key=new.get):
        entity = _REF.sub(lambda m: f"#{new.get(int(m.group(1)), int(m.group(1)))}", body[old])
        # one line per entity: the writer's wrapping depends on the numbers it wrote
        lines.append(f"#{new[old]} = {' '.join(entity.split())};\n")
    return head + "".join(lines) + tail


def _numbering(body: dict[int, str]) -> dict[int, int]:
    """Old id -> new id of the section's entities: each colour representation (sorted by the
    ids outside the section it refers to, the geometry it colours) then what it refers to,
    depth first; entities no representation reaches last, in their order."""
    refs = {k: [int(r) for r in _REF.findall(v)] for k, v in body.items()}
    roots = [k for k, v in body.items() if v.startswith(_PRESENTATION)]

    def outside(k, seen):
        seen.add(k)
        out = []
        for r in refs[k]:
            if r not in body:
                out.append(r)
            elif r not in seen:
                out += outside(r, seen)
        return out

    roots.sort(key=lambda k: (outside(k, set()), k))
    new: dict[int, int] = {}
    first = min(body)

    def visit(k):
        new[k] = first + len(new)
        for r in refs[k]:
            if r in body and r not in new:
                visit(r)

    for k in roots:
        if k not in new:
            visit(k)
    for k in sorted(body):
        if k not in new:
            new[k] = first + len(new)
    return new


def canonical_styles_file(path) -> None:
    """:func:`canonical_styles` and :func:`canonical_occurrence_ids` of the STEP file
    ``path``, in place."""
    path = Path(path)
    text = path.read_text(encoding="latin-1")
    out = canonical_occurrence_ids(canonical_styles(text))
    if out != text:
        path.write_text(out, encoding="latin-1")
