"""Edits of a live session: changes to a design, checked as a design file is.

:func:`apply_edit` takes keyword changes, ``spacing=0.7`` or a design-file table
``weights={"perp": 12}`` (merged into the table: the keys it leaves out keep their values)
and returns the edited design, validated by :class:`~torsal.pipeline.design_file.DesignSpec`:
an unknown key or a bad value raises the design file's error naming the key.
:func:`moved_point_surface` writes mesh A with one vertex moved.
"""
from __future__ import annotations

import difflib
import hashlib
from enum import Enum
from pathlib import Path

import numpy as np

from ..core.atomic import atomic_path
from ..core.errors import TorsalError
from ..pipeline.design_file import DesignSpec, validate_design

__all__ = ["SessionEditError", "RegionGoal", "EDIT_SHORTCUTS", "edit_keys", "apply_edit",
           "region_edit", "moved_point_surface"]

#: edit keys that name one design-file key: key -> (table, key in the table)
EDIT_SHORTCUTS = {"spacing": ("fins", "spacing"), "depth": ("fins", "depth"),
                  "min_torsal_angle": ("constraints", "min_torsal_angle")}


class SessionEditError(TorsalError, TypeError):
    """An edit key the session does not know; the message lists the keys it takes."""


class RegionGoal(str, Enum):
    """Which goal's region an edit moves (:meth:`torsal.session.Session.set_region`)."""

    LET_THROUGH = "let_through"      # goals.let_through (Fig. 9)
    SEE_THROUGH = "see_through"      # goals.see_through[index].region
    SUN_REGION = "sun_region"        # goals.sun_regions[index].region (Fig. 7d)
    REFLECT = "reflect"              # goals.reflect.region (Fig. 13)


def edit_keys() -> tuple[str, ...]:
    """Every key :func:`apply_edit` takes: the shortcuts, then the design file's tables.

    >>> edit_keys()[:3]
    ('spacing', 'depth', 'min_torsal_angle')
    """
    return tuple(EDIT_SHORTCUTS) + tuple(DesignSpec.model_fields)


def _unknown(key: str) -> SessionEditError:
    known = edit_keys()
    near = difflib.get_close_matches(key, known, n=1)
    hint = f" (did you mean {near[0]!r}?)" if near else ""
    return SessionEditError(f"unknown edit key {key!r}{hint}; an edit takes {', '.join(known)}")


def apply_edit(spec: DesignSpec, **changes) -> DesignSpec:
    """``spec`` with ``changes`` applied, validated as a design file.

    Parameters
    ----------
    spec : DesignSpec
    **changes
        ``spacing``, ``depth`` (model units), ``min_torsal_angle`` (degrees; None: no
        bound), or a design-file table by name (``weights``, ``sun``, ``goals``,
        ``constraints``, ``fins``, ``surface``, ``material``, ...) as a dict merged into the
        table; ``site``, ``substructure`` and ``costs`` take None to remove the table.

    Returns
    -------
    DesignSpec

    Raises
    ------
    SessionEditError
        An unknown edit key (the message lists the known ones).
    DesignFileError
        A bad value or key inside a table, named as the design file's errors are
        (``edit: fins.spacing: Input should be greater than 0 (got -1)``).

    Examples
    --------
    >>> spec = validate_design({"surface": {"generator": "facade_patch"},
    ...                         "sun": {"vectors": [[0, -1, 1]]}, "fins": {"spacing": 0.6, "depth": 0.3}})
    >>> apply_edit(spec, spacing=0.8, weights={"perp": 12}).fins.spacing
    0.8
    >>> apply_edit(spec, spcing=0.8)
    Traceback (most recent call last):
    ...
    torsal.session.edits.SessionEditError: unknown edit key 'spcing' (did you mean 'spacing'?); ...
    """
    data = spec.model_dump(mode="json")
    for key, value in changes.items():
        if key in EDIT_SHORTCUTS:
            table, name = EDIT_SHORTCUTS[key]
            data[table] = {**(data.get(table) or {}), name: value}
        elif key in DesignSpec.model_fields:
            old = data.get(key)
            data[key] = {**old, **value} if isinstance(old, dict) and isinstance(value, dict) \
                else value
        else:
            raise _unknown(key)
    return validate_design(data, source="edit")


def region_edit(spec: DesignSpec, goal: RegionGoal, region, *, index: int = 0) -> dict:
    """The ``goals`` change that puts ``region`` (a dict of the design file's region keys,
    or a :class:`~torsal.pipeline.design_file.Region`) as ``goal``'s region; ``index``
    picks the see-through or sun region.

    >>> spec = validate_design({"surface": {"generator": "facade_patch"},
    ...                         "sun": {"vectors": [[0, -1, 1]]}, "fins": {"spacing": 0.6, "depth": 0.3}})
    >>> region_edit(spec, RegionGoal.LET_THROUGH, {"x": [0, 2]})
    {'let_through': {'x': [0, 2]}}
    """
    goal = RegionGoal(goal)
    r = region.model_dump(mode="json", exclude_none=True) if hasattr(region, "model_dump") else region
    g = spec.goals.model_dump(mode="json")
    if goal is RegionGoal.LET_THROUGH:
        return {"let_through": r}
    if goal is RegionGoal.REFLECT:
        if g["reflect"] is None:
            raise SessionEditError("the design has no goals.reflect whose region to move")
        return {"reflect": {**g["reflect"], "region": r}}
    table = "see_through" if goal is RegionGoal.SEE_THROUGH else "sun_regions"
    rows = list(g[table])
    if not 0 <= index < len(rows):
        raise SessionEditError(f"goals.{table} has {len(rows)} entries; index {index} is not one")
    rows[index] = {**rows[index], "region": r}
    return {table: rows}


def moved_point_surface(vertices: np.ndarray, faces: np.ndarray, vertex: int, to,
                        folder: Path) -> Path:
    """Mesh A with ``vertices[vertex]`` moved to ``to`` (3,) (model units), written as an OBJ
    in ``folder``, named by its content (the stage cache keys a mesh file by its content).

    >>> import tempfile
    >>> v, f = np.eye(3), np.array([[0, 1, 2]])
    >>> moved_point_surface(v, f, 0, [2, 0, 0], Path(tempfile.mkdtemp())).suffix
    '.obj'
    """
    v = np.array(vertices, float)
    if not 0 <= int(vertex) < len(v):
        raise SessionEditError(f"vertex {vertex} is not a vertex of mesh A (0 .. {len(v) - 1})")
    to = np.asarray(to, float)
    if to.shape != (3,) or not np.isfinite(to).all():
        raise SessionEditError(f"a moved point needs three finite coordinates, got {to.tolist()}")
    v[int(vertex)] = to
    lines = ["# torsal session: mesh A with a moved point, model units"]
    lines += [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in v]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in np.asarray(faces, np.int64)]
    text = "\n".join(lines) + "\n"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"surface-{hashlib.sha256(text.encode()).hexdigest()[:12]}.obj"
    if not path.exists():
        with atomic_path(path) as tmp:
            tmp.write_text(text)
    return path
