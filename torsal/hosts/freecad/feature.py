"""The parametric fins object: a FreeCAD ``Part::FeaturePython`` whose properties are the
design file's main keys.

>>> import FreeCAD                                          # doctest: +SKIP
>>> from torsal.freecad import make_fins                    # doctest: +SKIP
>>> doc = FreeCAD.newDocument("facade")                     # doctest: +SKIP
>>> fins = make_fins(doc, "examples/7a_facade_block.toml")  # doctest: +SKIP
>>> doc.recompute()                                         # doctest: +SKIP
>>> fins.Buildable, len(fins.Shape.Solids)                  # doctest: +SKIP
(True, 2129)

A recompute writes a :class:`~torsal.hosts.freecad.job.FinsJob` and runs it with the Python of
torsal's environment (:mod:`torsal.hosts.freecad.job` says why not inside FreeCAD); the stage
cache in the job folder re-runs only the stages whose inputs changed. The solids come back with
FreeCAD's ``Part.read`` (never ``Import.insert``: FreeCAD 0.20's crashes on a STEP with two or
more labelled shapes), one per part, in the order of ``PartNames``.

FreeCAD is imported inside the functions: this module is importable (and its doctests run)
outside FreeCAD too.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from ...core.errors import TorsalError
from ...core.units import scale
from ...pipeline.design_file import load_design_file
from .job import FinsJob, FinsOutcome
from .live import LiveClient, outcome_from
from .sampling import face_grid, linked_face, wire_polylines

__all__ = ["FinsFeature", "FinsError", "ViewProviderFins", "make_fins", "torsal_python",
           "job_folder", "run_in_torsal", "preview_shape", "PROPERTIES", "ICON"]

#: the workbench's and the object's icon
ICON = Path(__file__).with_name("torsal.svg")


class FinsError(TorsalError, RuntimeError):
    """The fins could not be made; FreeCAD marks the object invalid and shows this message."""


@dataclass(frozen=True)
class _Prop:
    type: str
    name: str
    group: str
    doc: str
    read_only: bool = False


def _family_props(name: str, key: str, what: str, example: str) -> tuple[_Prop, _Prop]:
    """A per-family length (``key = [family 0, family 1]``): ``name`` (family 0's, and
    family 1's while ``name1`` is 0) and ``name1`` (family 1's; 0 = ``name``, so a document
    of an older torsal, which lacks it, keeps one length for both)."""
    return (_Prop("App::PropertyLength", name, "Design", f"{key}: {what} of family 0, and of "
                  f"family 1 when {name}1 is 0"),
            _Prop("App::PropertyLength", f"{name}1", "Design", f"{key}'s second value: family "
                  f"1's {what} ({example}); 0 = {name}"))


#: The object's properties: design keys (editable) and results (read-only).
PROPERTIES: tuple[_Prop, ...] = (
    _Prop("App::PropertyFile", "DesignFile", "Design", "the torsal design file (TOML) the other "
          "properties override"),
    *_family_props("Spacing", "fins.spacing", "fin spacing", "e.g. twice Spacing: a sparse "
                   "second family"),
    *_family_props("Depth", "fins.depth", "fin depth along the lines", "e.g. a shallow second "
                   "family"),
    _Prop("App::PropertyLength", "Thickness", "Design", "material.thickness_mm: plate thickness"),
    _Prop("App::PropertyAngle", "MinTorsalAngle", "Design", "constraints.min_torsal_angle: "
          "smallest angle between the two torsal planes of a face; 0 = no constraint"),
    _Prop("App::PropertyLinkSub", "Surface", "Design", "the design surface: a face (or a shape of "
          "one face) tessellated by torsal; empty = the design file's surface"),
    _Prop("App::PropertyLength", "MeshEdge", "Design", "edge length of the Surface's "
          "tessellation; 0 = half the spacing"),
    _Prop("App::PropertyLinkList", "Strokes", "Design", "goals.strokes: wires the torsal "
          "directions follow (Fig. 7b); empty = the design file's strokes"),
    _Prop("App::PropertyLength", "StrokeWidth", "Design", "goals.strokes[].width: faces within "
          "this distance follow a stroke; 0 = torsal's default"),
    _Prop("App::PropertyString", "SunStart", "Sun", "sun.start (YYYY-MM-DD); empty with SunEnd "
          "= the design file's sun (dates, EPW or vectors)"),
    _Prop("App::PropertyString", "SunEnd", "Sun", "sun.end (YYYY-MM-DD), included"),
    _Prop("App::PropertyFloatList", "SunHours", "Sun", "sun.hours: [h0, h1] local clock hours"),
    _Prop("App::PropertyBool", "Live", "Design", "keep a warm torsal session for this object: a "
          "change shows the fins as surfaces at once (Answer = preview), the solids when they "
          "are built (Answer = built); false: each recompute runs the whole design anew"),
    _Prop("App::PropertyPath", "OutputFolder", "Result", "where torsal writes (design.toml, "
          "out/ with report.html, STEP, DXF and the stage cache); empty = beside the saved "
          "document, or the user cache"),
    _Prop("App::PropertyBool", "Buildable", "Result", "the assembly check: no parts interfere "
          "and each can be inserted", True),
    _Prop("App::PropertyFloat", "SunBlocked", "Result", "share of the design sun the fins block "
          "(report.json light.blocked_share), 0..1", True),
    _Prop("App::PropertyFile", "Report", "Result", "report.html of the last recompute", True),
    _Prop("App::PropertyFile", "DesignRun", "Result", "the design file the last recompute ran "
          "(the properties applied): `torsal design` runs it too", True),
    _Prop("App::PropertyStringList", "PartNames", "Result", "part names, one per solid of Shape, "
          "in order", True),
    _Prop("App::PropertyStringList", "PartGroups", "Result", "family 0, family 1, connector or "
          "interfering, one per solid", True),
    _Prop("App::PropertyStringList", "StagesRun", "Result", "stages the last recompute ran", True),
    _Prop("App::PropertyString", "Answer", "Result", "what Shape shows: preview (the fins as "
          "surfaces, one face per fin) or built (one solid per part)", True),
    _Prop("App::PropertyFloat", "AnswerSeconds", "Result", "seconds from the change to what "
          "Shape shows", True),
    _Prop("App::PropertyStringList", "StagesCached", "Result", "stages it took from the cache", True),
)


def _add_properties(obj) -> None:
    for p in PROPERTIES:
        if p.name not in obj.PropertiesList:
            obj.addProperty(p.type, p.name, p.group, p.doc)
            if p.read_only:
                obj.setEditorMode(p.name, 1)


def torsal_python() -> str:
    """The Python of torsal's environment, which runs the stages: ``$TORSAL_PYTHON`` (set by
    the workbench that ``torsal freecad install`` writes), else this Python when it is not
    FreeCAD's."""
    env = os.environ.get("TORSAL_PYTHON")
    if env:
        return env
    if Path(sys.executable).name.startswith("python"):
        return sys.executable
    raise FinsError("torsal's Python is unknown (TORSAL_PYTHON is not set): install the workbench "
                    "with `torsal freecad install` from torsal's environment and restart FreeCAD")


def job_folder(obj) -> Path:
    """Where ``obj``'s job runs: its ``OutputFolder``; else ``<document>.torsal/<name>`` beside
    a saved document; else ``~/.cache/torsal/freecad/<document id>/<name>``."""
    if obj.OutputFolder:
        return Path(obj.OutputFolder)
    doc = obj.Document
    if doc.FileName:
        return Path(doc.FileName).with_suffix(".torsal") / obj.Name
    cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return cache / "torsal" / "freecad" / doc.Uid / obj.Name


def run_in_torsal(job: FinsJob, *, log=None) -> FinsOutcome:
    """Run ``job`` with :func:`torsal_python` (``python -m torsal.hosts.freecad``); ``log``
    gets each progress line. Raises :class:`FinsError` with torsal's message on bad input."""
    folder = Path(job.folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = job.write(folder / "job.json")
    (folder / "result.json").unlink(missing_ok=True)
    # FreeCAD's own Python settings must not leak into torsal's Python
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONHOME", "PYTHONPATH")}
    proc = subprocess.Popen([torsal_python(), "-m", "torsal.hosts.freecad", str(path)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    for line in proc.stdout:
        if log is not None:
            log(line.rstrip("\n"))
    err = proc.stderr.read().strip()
    if proc.wait() != 0:
        what = "bad input" if proc.returncode == 2 else f"a bug in torsal (exit status {proc.returncode})"
        raise FinsError(f"torsal could not make the fins ({what}): {err or 'no message'}")
    data = json.loads((folder / "result.json").read_text())
    return FinsOutcome(**data)


def _mm(quantity) -> float | None:
    value = float(getattr(quantity, "Value", quantity))
    return value if value > 0 else None


class FinsFeature:
    """The proxy of a fins object (``obj.Proxy``): adds the :data:`PROPERTIES` and makes the
    fins on recompute. Its state is all in the properties, so documents save and reopen with
    the fins (the solids are stored in the document; torsal is imported again on reopen)."""

    def __init__(self, obj):
        _add_properties(obj)
        obj.Proxy = self

    # -------------------------------------------------------------- FreeCAD protocol
    def onDocumentRestored(self, obj):
        _add_properties(obj)   # a document of an older torsal gains the newer properties

    def dumps(self):           # FreeCAD >= 0.21
        return None

    def loads(self, state):
        return None

    def __getstate__(self):    # FreeCAD 0.20
        return None

    def __setstate__(self, state):
        return None

    def execute(self, obj):
        import FreeCAD

        def log(line):
            try:
                ev = json.loads(line)
            except ValueError:
                FreeCAD.Console.PrintMessage(f"torsal: {line}\n")
                return
            if ev.get("event") in ("done", "cached"):   # one line a stage; the rest to the log
                took = f" ({ev['seconds']:.1f} s)" if "seconds" in ev else ""
                FreeCAD.Console.PrintMessage(f"torsal: {ev['stage']} {ev['event']}{took}\n")
            else:
                FreeCAD.Console.PrintLog(f"torsal: {ev.get('stage')} {ev.get('event')}\n")

        if getattr(obj, "Live", False):
            self._execute_live(obj)
            return
        outcome = run_in_torsal(self.job(obj), log=log)
        self._show_outcome(obj, outcome)

    def _show_outcome(self, obj, outcome: FinsOutcome) -> None:
        """Shape = the built part solids (read from the STEP file) and the result properties."""
        import FreeCAD
        import Part

        shape = Part.read(outcome.step)
        if len(shape.Solids) != len(outcome.parts):
            raise FinsError(f"{outcome.step} holds {len(shape.Solids)} solids for "
                            f"{len(outcome.parts)} parts in parts.csv")
        obj.Shape = shape
        obj.Buildable = outcome.buildable
        obj.SunBlocked = float(outcome.sun_blocked or 0.0)
        obj.Report, obj.DesignRun = outcome.report, outcome.design
        obj.PartNames = list(outcome.parts)
        bad = set(outcome.interfering)
        obj.PartGroups = ["interfering" if n in bad else g
                          for n, g in zip(outcome.parts, outcome.families)]
        obj.StagesRun, obj.StagesCached = list(outcome.stages_run), list(outcome.stages_cached)
        if hasattr(obj, "Answer"):
            obj.Answer = "built"
        if not outcome.buildable:
            FreeCAD.Console.PrintWarning(f"torsal: {obj.Label} is NOT buildable: "
                                         f"{outcome.problems}\n")

    # -------------------------------------------------------------- the live session
    def _client(self) -> LiveClient:
        client = getattr(self, "_live", None)
        if client is None or not client.alive:
            client = self._live = LiveClient(torsal_python())
        return client

    def _execute_live(self, obj) -> None:
        """Shape = the preview's fins as surfaces (mm), at once; the solids follow
        (:meth:`poll`, :meth:`wait_built`)."""
        import FreeCAD

        message = self._client().ask(self.job(obj), timeout=900)
        if message["kind"] != "preview":
            what = "bad input" if message.get("bad_input") else message["kind"]
            raise FinsError(f"torsal could not make the fins ({what}): {message['message']}")
        shape, groups = preview_shape(message["fins"])
        obj.Shape = shape
        obj.PartNames, obj.PartGroups = [], groups
        obj.SunBlocked = float(message["sun_blocked"] or 0.0)
        obj.DesignRun = message["design"]
        obj.StagesRun, obj.StagesCached = message["stages_run"], message["stages_kept"]
        obj.Answer, obj.AnswerSeconds = "preview", float(message["seconds"])
        FreeCAD.Console.PrintMessage(f"torsal: {obj.Label} preview in {message['seconds']:.2f} s "
                                     f"({', '.join(message['stages_run']) or 'all kept'}); the "
                                     "solids follow\n")
        if FreeCAD.GuiUp:
            self._poll_later(obj)

    def _show_built(self, obj, message: dict) -> None:
        import FreeCAD

        if message["kind"] != "built":
            FreeCAD.Console.PrintError(f"torsal: {obj.Label}: the build failed: "
                                       f"{message['message']}\n")
            return
        self._show_outcome(obj, outcome_from(message))
        obj.AnswerSeconds = float(message["seconds"])
        obj.purgeTouched()           # results, not a change: no recompute for them

    def poll(self, obj) -> bool:
        """Show the built solids if they have come (True), without waiting."""
        client = getattr(self, "_live", None)
        message = client.take_built() if client is not None else None
        if message is not None:
            self._show_built(obj, message)
        return message is not None

    def wait_built(self, obj, timeout: float | None = 600.0) -> bool:
        """Wait up to ``timeout`` seconds for the built solids and show them (True), e.g. in
        ``freecadcmd``, which has no event loop to :meth:`poll` from."""
        client = getattr(self, "_live", None)
        if client is None:
            return False
        message = client.wait_built(timeout=timeout)
        if message is not None:
            self._show_built(obj, message)
        return message is not None

    def _poll_later(self, obj, tries: int = 4000) -> None:
        from PySide import QtCore

        def again():
            try:
                if not self.poll(obj) and tries > 0 and getattr(self, "_live", None) is not None:
                    self._poll_later(obj, tries - 1)
            except Exception:       # the object or its document is gone
                return

        QtCore.QTimer.singleShot(250, again)

    def close_session(self) -> None:
        """End this object's live session process (a later recompute starts another)."""
        client = getattr(self, "_live", None)
        if client is not None:
            client.close()
            self._live = None

    # -------------------------------------------------------------- the job
    def job(self, obj) -> FinsJob:
        """The :class:`~torsal.hosts.freecad.job.FinsJob` of ``obj``'s properties (the linked
        surface and strokes sampled here, in FreeCAD)."""
        if not obj.DesignFile:
            raise FinsError(f"{obj.Label}: DesignFile is empty: give a torsal design file (TOML)")
        spacing, spacing1 = _mm(obj.Spacing), _mm(getattr(obj, "Spacing1", 0.0))
        edge = _mm(obj.MeshEdge) or min(x for x in (spacing, spacing1, 1000.0) if x) / 2
        surface = face_grid(linked_face(obj.Surface), edge) if obj.Surface else None
        strokes = wire_polylines(obj.Strokes, edge / 2) if obj.Strokes else None
        hours = list(obj.SunHours)
        if hours and len(hours) != 2:
            raise FinsError(f"{obj.Label}: SunHours must be two numbers [h0, h1], got {hours}")
        return FinsJob(
            design=str(obj.DesignFile), folder=str(job_folder(obj)),
            spacing_mm=spacing, spacing1_mm=spacing1, depth_mm=_mm(obj.Depth),
            depth1_mm=_mm(getattr(obj, "Depth1", 0.0)), thickness_mm=_mm(obj.Thickness),
            min_torsal_angle=float(obj.MinTorsalAngle.Value), sun_start=obj.SunStart or None,
            sun_end=obj.SunEnd or None, sun_hours=hours or None, surface=surface,
            strokes=strokes, stroke_width_mm=_mm(obj.StrokeWidth))


class ViewProviderFins:
    """How the fins look in FreeCAD's 3D view: coloured by :class:`~torsal.hosts.results.PartGroup`
    (family 0 blue, family 1 orange, connectors grey, interfering parts red)."""

    def __init__(self, vobj):
        vobj.Proxy = self

    def attach(self, vobj):
        self.Object = vobj.Object

    def getIcon(self):
        return str(ICON)

    def updateData(self, obj, prop):
        if prop in ("Shape", "PartGroups") and obj.ViewObject is not None:
            colors = face_colors(obj)
            if colors:
                obj.ViewObject.DiffuseColor = colors

    def onChanged(self, vobj, prop):
        return None

    def dumps(self):
        return None

    def loads(self, state):
        return None

    def __getstate__(self):
        return None

    def __setstate__(self, state):
        return None


def preview_shape(fins: dict):
    """A preview's fins (:func:`~torsal.hosts.freecad.live.fins_message`, mm) as a compound of
    faces, one per fin (two triangles where a fin is not planar to OpenCascade's tolerance),
    and the family group of each face.

    >>> shape, groups = preview_shape(message["fins"])   # doctest: +SKIP
    >>> len(shape.Faces) == len(groups)                  # doctest: +SKIP
    True
    """
    import FreeCAD
    import Part

    a = [FreeCAD.Vector(*p) for p in fins["a"]]
    # each family's B side (a message of an older session has one for both)
    b = [[FreeCAD.Vector(*p) for p in fins[key]] for key in ("b", "b1" if "b1" in fins else "b")]
    faces, groups = [], []
    for (i, j), family in zip(fins["edges"], fins["families"]):
        quad = [a[i], a[j], b[family][j], b[family][i]]
        try:
            parts = [Part.Face(Part.makePolygon(quad + quad[:1]))]
        except Part.OCCError:
            parts = [Part.Face(Part.makePolygon([quad[0], quad[1], quad[2], quad[0]])),
                     Part.Face(Part.makePolygon([quad[0], quad[2], quad[3], quad[0]]))]
        faces += parts
        groups += [f"family {family}"] * len(parts)
    return Part.makeCompound(faces), groups


def face_colors(obj) -> list[tuple[float, float, float]]:
    """One colour per face of ``obj.Shape``, by the group of the solid it belongs to, or of
    the face itself in a preview (faces, no solids); [] when the groups do not match."""
    from ..results import GROUP_COLORS, PartGroup

    solids, groups = obj.Shape.Solids, list(obj.PartGroups)
    if not solids and len(obj.Shape.Faces) == len(groups):
        return [GROUP_COLORS[PartGroup(g)] for g in groups]
    if len(solids) != len(groups):
        return []
    return [GROUP_COLORS[PartGroup(g)] for s, g in zip(solids, groups) for _ in s.Faces]


def make_fins(doc, design_path, *, surface=None, strokes=(), name: str = "Fins",
              live: bool = True):
    """A fins object in ``doc`` for the design file ``design_path``: its properties take the
    file's values (lengths in mm), ``Surface`` and ``Strokes`` the given links. Call
    ``doc.recompute()`` to make the fins.

    Parameters
    ----------
    doc : FreeCAD document
    design_path : path
        A torsal design file; read and checked now (a bad file raises
        :class:`~torsal.pipeline.design_file.DesignFileError` naming the key).
    surface : (object, [face names]) or object, optional
        The design surface; default the design file's.
    strokes : sequence of objects with wires, optional
    name : str
        The object's name (FreeCAD makes it unique).
    live : bool
        Keep a warm session for the object (``Live``): a change shows the preview at once and
        the solids when built; False: each recompute runs the whole design in a new process.

    Returns
    -------
    the ``Part::FeaturePython`` object (``obj.Proxy`` is a :class:`FinsFeature`).
    """
    import FreeCAD

    path = Path(design_path).resolve()
    spec = load_design_file(path)
    to_mm = scale(spec.units, "mm")
    obj = doc.addObject("Part::FeaturePython", name)
    FinsFeature(obj)
    obj.DesignFile = str(path)
    for name, (first, second) in (("Spacing", spec.fins.spacings), ("Depth", spec.fins.depths)):
        setattr(obj, name, first * to_mm)
        setattr(obj, name + "1", second * to_mm if second != first else 0.0)   # 0: the same
    obj.Thickness = spec.material.thickness_mm
    obj.MinTorsalAngle = spec.constraints.min_torsal_angle or 0.0
    if spec.sun.start is not None:
        obj.SunStart, obj.SunEnd = str(spec.sun.start), str(spec.sun.end)
    obj.SunHours = [float(h) for h in spec.sun.hours]
    if surface is not None:
        obj.Surface = surface if isinstance(surface, tuple) else (surface, [])
    obj.Strokes = list(strokes)
    obj.Live = bool(live)
    if FreeCAD.GuiUp:
        ViewProviderFins(obj.ViewObject)
    return obj
