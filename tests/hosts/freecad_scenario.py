"""Run inside FreeCAD (``freecadcmd``) by test_freecad.py: the parametric fins object end to
end. Writes what it measured as JSON to ``$TORSAL_SCENARIO_OUT``. FreeCAD is imported inside
:func:`main`, so pytest can import this file outside FreeCAD."""
import json
import os
import time


def _solids(obj):
    s = obj.Shape
    return {"n": len(s.Solids), "valid": all(x.isValid() for x in s.Solids),
            "volumes": [x.Volume for x in s.Solids],
            "bbox": [s.BoundBox.XMin, s.BoundBox.YMin, s.BoundBox.ZMin, s.BoundBox.XMax, s.BoundBox.YMax,
             s.BoundBox.ZMax]}


def _files(obj):
    """What the run wrote, read with the standard library: report.json and parts.csv."""
    import csv

    out = os.path.join(os.path.dirname(obj.DesignRun), "out")
    with open(os.path.join(out, "report.json")) as fh:
        report = json.load(fh)
    with open(os.path.join(out, "parts.csv"), newline="") as fh:
        names = [r["part_id"] for r in csv.DictReader(fh)]
    return {"report_parts": report["fabrication"]["parts"], "csv_parts": names,
            "report_buildable": report["fabrication"]["assembly"]["buildable"],
            "report_blocked": report["light"]["blocked_share"]}


def _record(obj, seconds):
    return {**_solids(obj), **_files(obj), "state": list(obj.State), "parts": list(obj.PartNames),
            "groups": list(obj.PartGroups), "buildable": obj.Buildable,
            "sun_blocked": obj.SunBlocked, "report": obj.Report, "design_run": obj.DesignRun,
            "stages_run": list(obj.StagesRun), "stages_cached": list(obj.StagesCached),
            "seconds": seconds}


def _recompute(doc, obj):
    t = time.time()
    doc.recompute()
    return _record(obj, time.time() - t)


def _live_record(obj, **extra):
    s = obj.Shape
    return {"answer": obj.Answer, "seconds": obj.AnswerSeconds, "faces": len(s.Faces),
            "solids": len(s.Solids), "valid": all(x.isValid() for x in s.Solids),
            "volumes": [x.Volume for x in s.Solids], "groups": list(obj.PartGroups),
            "parts": list(obj.PartNames), "state": list(obj.State),
            "stages_run": list(obj.StagesRun), "stages_cached": list(obj.StagesCached),
            "sun_blocked": obj.SunBlocked, "design_run": obj.DesignRun,
            "bbox": [s.BoundBox.XMin, s.BoundBox.YMin, s.BoundBox.ZMin, s.BoundBox.XMax,
                     s.BoundBox.YMax, s.BoundBox.ZMax], **extra}


def _live(FreeCAD, make_fins, design, folder):
    """The fins object on a live session: a change shows the preview (faces) at once, the
    solids after; the recompute's and the solids' seconds measured here, in FreeCAD."""
    doc = FreeCAD.newDocument("live")
    fins = make_fins(doc, design)                  # Live by default
    fins.OutputFolder = os.path.join(folder, "live-job")
    out = {}

    def change(name, apply, built=True):
        apply()
        t = time.time()
        doc.recompute()
        out[name] = _live_record(fins, recompute=time.time() - t)
        if built:
            t = time.time()
            ok = fins.Proxy.wait_built(fins, timeout=600)
            out[name + "_built"] = _live_record(fins, wait=time.time() - t, ok=ok,
                                                touched="Touched" in fins.State)

    # the first design's build is cancelled by the next change, as a designer's would be
    change("first", lambda: None, built=False)
    change("spacing", lambda: setattr(fins, "Spacing", fins.Spacing.Value * 1.25))
    # a sparse, shallow second family (fins.spacing = [s, 2 s], depth = [d, 250 mm]): the
    # preview only (at 2 x 1.875 m this facade's family-0 panels outgrow the sheet, so the
    # build would fail for that reason); the next change keeps the shallow family in its build
    change("spacing1", lambda: (setattr(fins, "Spacing1", fins.Spacing.Value * 2),
                                setattr(fins, "Depth1", 250.0)), built=False)
    change("sun", lambda: (setattr(fins, "SunHours", [12.0, 17.0]),
                           setattr(fins, "Spacing1", 0.0)))
    # a bad value: invalid with torsal's message, the built solids stay
    fins.SunHours = [18.0, 9.0]
    doc.recompute()
    out["bad"] = _live_record(fins)
    fins.Proxy.close_session()
    return out


def _fins_properties(fins):
    return {n: fins.getPropertyByName(n).Value for n in ("Spacing", "Spacing1", "Depth", "Depth1")}


def families():
    """Seconds, no design run: the per-family properties of a design file with two spacings
    and depths, the job they give (as dict), the job with Spacing1 back at 0, and a document
    saved without Spacing1 / Depth1 (an older torsal's) reopened. Returns what it saw; run as
    ``runpy.run_path(this)["families"]()`` with ``$TORSAL_SCENARIO_DESIGN`` the per-family
    file, ``$TORSAL_SCENARIO_DESIGN_ONE`` one with one spacing."""
    from dataclasses import asdict

    import FreeCAD

    from torsal.freecad import make_fins

    folder = os.environ["TORSAL_SCENARIO_DIR"]
    out = {}
    doc = FreeCAD.newDocument("families")
    fins = make_fins(doc, os.environ["TORSAL_SCENARIO_DESIGN"], live=False)
    fins.OutputFolder = os.path.join(folder, "families-job")
    out["properties"] = _fins_properties(fins)
    out["job"] = asdict(fins.Proxy.job(fins))
    fins.Spacing1 = 0.0                           # one spacing for both again
    fins.Depth1 = 450.0
    out["job_one_spacing"] = asdict(fins.Proxy.job(fins))
    # an older torsal's document: no Spacing1 / Depth1 (made from a file with one spacing)
    old = make_fins(doc, os.environ["TORSAL_SCENARIO_DESIGN_ONE"], name="Old", live=False)
    old.OutputFolder = os.path.join(folder, "old-job")
    for name in ("Spacing1", "Depth1"):
        old.removeProperty(name)
    out["old_before"] = sorted(n for n in old.PropertiesList if n.startswith(("Spacing", "Depth")))
    path = os.path.join(folder, "families.FCStd")
    doc.saveAs(path)
    FreeCAD.closeDocument(doc.Name)
    doc = FreeCAD.openDocument(path)
    old = doc.getObject("Old")
    out["old_reopened"] = {"properties": _fins_properties(old), "job": asdict(old.Proxy.job(old)),
                           "state": list(old.State)}
    FreeCAD.closeDocument(doc.Name)
    with open(os.environ["TORSAL_SCENARIO_OUT"], "w") as fh:
        json.dump(out, fh)
    return out


def main():
    import sys

    import FreeCAD

    from torsal.freecad import make_fins
    from torsal.hosts.freecad.feature import FinsFeature

    sys.path.insert(0, os.environ["TORSAL_EXAMPLES"])
    from bspline_facade import facade_face     # the example's B-spline facade (12 m x 6 m)

    out = {}
    design, folder = os.environ["TORSAL_SCENARIO_DESIGN"], os.environ["TORSAL_SCENARIO_DIR"]
    doc = FreeCAD.newDocument("facade")
    fins = make_fins(doc, design, live=False)     # each recompute a whole run (the live one below)
    fins.OutputFolder = os.path.join(folder, "fins-job")
    out["properties"] = {"Spacing": fins.Spacing.Value, "Depth": fins.Depth.Value,
                         "Thickness": fins.Thickness.Value,
                         "MinTorsalAngle": fins.MinTorsalAngle.Value, "SunStart": fins.SunStart,
                         "SunEnd": fins.SunEnd, "SunHours": list(fins.SunHours),
                         "read_only": {n: fins.getEditorMode(n) for n in
                                       ("Buildable", "SunBlocked", "Report", "Spacing")}}
    out["first"] = _recompute(doc, fins)

    fins.Spacing = fins.Spacing.Value * 1.25
    out["spacing"] = _recompute(doc, fins)

    face = doc.addObject("Part::Feature", "Facade")
    face.Shape = facade_face()
    fins.Surface = (face, ["Face1"])
    out["surface"] = _recompute(doc, fins)
    f = face.Shape.Faces[0]
    # how far the fin plates stand from the face (connectors sit off it, in the corners)
    plates = [x for x, g in zip(fins.Shape.Solids, fins.PartGroups) if g != "connector"]
    out["surface"]["distances"] = [x.distToShape(f)[0] for x in plates[:: max(1, len(plates) // 30)]]
    out["surface"]["face_bbox"] = [f.BoundBox.XMin, f.BoundBox.YMin, f.BoundBox.ZMin,
                                   f.BoundBox.XMax, f.BoundBox.YMax, f.BoundBox.ZMax]
    out["surface"]["surface_type"] = type(f.Surface).__name__

    path = os.path.join(folder, "facade.FCStd")
    doc.saveAs(path)
    FreeCAD.closeDocument(doc.Name)
    doc = FreeCAD.openDocument(path)
    fins = doc.getObject("Fins")
    out["reopened"] = {**_record(fins, 0.0),
                       "proxy": type(fins.Proxy).__name__,
                       "is_fins_feature": isinstance(fins.Proxy, FinsFeature),
                       "surface_link": [fins.Surface[0].Name, list(fins.Surface[1])]}
    fins.touch()
    out["after_reopen"] = _recompute(doc, fins)

    # a bad value: the object is marked invalid with torsal's message, its solids stay
    fins.SunHours = [18.0, 9.0]
    doc.recompute()
    out["bad"] = {"state": list(fins.State), "n": len(fins.Shape.Solids)}
    out["live"] = _live(FreeCAD, make_fins, design, folder)
    with open(os.environ["TORSAL_SCENARIO_OUT"], "w") as fh:
        json.dump(out, fh)


if __name__ == "__main__":
    main()
