"""A study's table and its page: the Pareto front of sun blocked against view clear (or of the
two figures the study file's ``[pareto]`` names, e.g. the cooling-season gains avoided against
sDA), torsal variants against the standard devices of the same depths and spacings, and one
measured sentence saying which is ahead and by how much.

The view axis is the design's ``view.measure`` (``light.view_clear``): by default the view
out from occupant eye points (:mod:`torsal.light.view`), else the view along the normal. A
device that cannot be made on the surface is a row with status "not applicable" and its
reason in ``note``; it is in the table, never in the front or the verdict."""
from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np

from ..core.atomic import atomic_path
from .study_file import X_KEY, Y_KEY, ParetoSpec
from .study_tasks import flatten, material_kg

__all__ = ["results_table", "pareto_front", "lead_over", "verdict", "write_study_html",
           "write_pareto_png", "view_label", "X_KEY", "Y_KEY", "NOT_APPLICABLE", "figure_label"]

# X_KEY: view clear, the design's view measure (view.measure); Y_KEY: the sun as the design
# asks: blocked (weighted share of direct sun rays), and let through over goals.let_through;
# without that goal it is light.blocked_share exactly (both defined with the study file)
NOT_APPLICABLE = "not applicable"  # the status of a device that cannot be made on the surface
_FIRST = ["id", "kind", "device", "status", "note"]
_SYMBOLS = {"horizontal louvers": ("triangle-up", "^"), "vertical fins": ("triangle-right", ">"),
            "egg-crate": ("square", "s"), "optimized parallel fins": ("diamond", "D"),
            "optimized egg-crate": ("x", "X")}


def _asks(study) -> bool:
    """Does a design ask the sun for more than being blocked (let through, region suns)?"""
    return any(v.spec.goals.let_through is not None or v.spec.goals.sun_regions
               for v in study.variants)


def sun_label(study) -> str:
    """The sun axis's name: sun blocked, or the sun as asked where a design lets it through
    or gives regions their own sun."""
    if _asks(study):    # blocked; let through over goals.let_through; a region's own sun
        return "sun as the goals ask (weighted share of sun rays)"
    return "sun blocked (weighted share of design-hour sun rays)"


def view_label(study) -> str:
    """The view axis's name for the study's designs (their ``view.measure``)."""
    measures = {v.spec.view.measure.value for v in study.variants}
    if measures == {"normal"}:
        return "view clear (share of points on the surface with a free line along the normal)"
    if measures == {"occupant"}:
        return "view out (share of occupants' sight lines past the fins)"
    return "view clear (each design's view.measure)"


#: the Pareto axes' names of the annual stage's figures (with their unit)
_FIGURE_LABELS = {
    "light.annual.fins.annual_kwh_m2": "irradiance on the glazing over the year (kWh/m2)",
    "light.annual.fins.cooling_kwh_m2": "irradiance on the glazing, cooling season (kWh/m2)",
    "light.annual.fins.heating_kwh_m2": "irradiance on the glazing, heating season (kWh/m2)",
    "light.annual.fins.shading_factor.f_sh_cooling": "shading factor F_sh, cooling season",
    "light.annual.fins.shading_factor.f_sh_heating": "shading factor F_sh, heating season",
    "light.annual.fins.shading_factor.f_sh_year": "shading factor F_sh over the year",
    "light.annual.fins.shading_factor.cooling_gains_avoided_kwh_m2":
        "cooling-season gains avoided (kWh/m2 of glazing)",
    "light.annual.fins.shading_factor.heating_gains_kept_kwh_m2":
        "heating-season gains kept (kWh/m2 of glazing)",
    "light.annual.daylight.fins.sda_all": "sDA 300 lx / 50% (share of the rooms' floor)",
    "light.annual.daylight.fins.ase_all": "ASE 1000 lx / 250 h (share of the rooms' floor)",
    "material_kg": "sheet material (kg)",
    X_KEY: "view clear", Y_KEY: "sun as asked",
}
#: the figures' short names in a verdict's sentence
_SHORT_LABELS = {
    "light.annual.fins.shading_factor.cooling_gains_avoided_kwh_m2":
        "cooling-season gains avoided (kWh/m2)",
    "light.annual.fins.shading_factor.heating_gains_kept_kwh_m2":
        "heating-season gains kept (kWh/m2)",
    "light.annual.daylight.fins.sda_all": "sDA", "light.annual.daylight.fins.ase_all": "ASE",
    X_KEY: "view clear", Y_KEY: "sun as asked",
}
#: figures that are shares (shown in %)
_SHARES = {"light.view_clear", "light.goal_share", "light.blocked_share", "light.transparency",
           "light.transparency_cone", "light.view_out",
           "light.reflected_to_target", "light.annual.daylight.fins.sda_all",
           "light.annual.daylight.fins.ase_all", "fabrication.utilization"}


def figure_label(key: str, study=None) -> str:
    """What a Pareto axis shows, with its unit: the view and sun names of the study's designs
    for the default axes, the annual stage's figures by name, else the report key.

    >>> figure_label("light.annual.fins.shading_factor.cooling_gains_avoided_kwh_m2")
    'cooling-season gains avoided (kWh/m2 of glazing)'
    """
    if key == X_KEY and study is not None:
        return view_label(study)
    if key == Y_KEY and study is not None:
        return sun_label(study)
    return _FIGURE_LABELS.get(key, key)


def _pareto(study) -> ParetoSpec:
    spec = getattr(study, "spec", None)
    return getattr(spec, "pareto", None) or ParetoSpec()


def _signs(pareto: ParetoSpec) -> tuple[float, float]:
    """+1 for an axis where more is better, -1 where less is: the fronts maximize sign x."""
    return tuple(1.0 if pareto.better(a) == "max" else -1.0 for a in ("x", "y"))


def _value_text(key: str, x) -> str:
    return f"{100 * x:.1f}%" if key in _SHARES else f"{x:.3g}"


def _length_text(x) -> str:
    """A depth or spacing of a table row: one length, or [family 0, family 1]."""
    if isinstance(x, str):
        x = json.loads(x)
    if isinstance(x, (list, tuple)):
        return "[" + ", ".join(f"{v:.3g}" for v in x) + "]"
    return f"{x:.3g}"


def _family_value(x):
    """A depth or spacing as a table cell: a number, or [s0, s1] as JSON text."""
    return json.dumps(list(x)) if isinstance(x, (list, tuple)) else x


def _device_annual(report: dict, name: str) -> dict:
    """The annual stage's figures of device ``name`` in a variant's report, under the keys
    the fins' have (``light.annual.fins.*``, ``light.annual.daylight.fins.*``), so a device
    row stands on the same Pareto axes as the variants."""
    annual = report.get("light", {}).get("annual") or {}
    out = {}
    device = (annual.get("devices") or {}).get(name)
    if isinstance(device, dict) and device.get("applicable", True):
        out.update(flatten({k: x for k, x in device.items() if k != "seconds"},
                           "light.annual.fins."))
    daylight = (annual.get("daylight") or {}).get(name)
    if isinstance(daylight, dict):
        out.update(flatten(daylight, "light.annual.daylight.fins."))
    return out


def _buildable(report: dict):
    a = report.get("fabrication", {}).get("assembly")
    return a.get("buildable") if isinstance(a, dict) else None


def _bom_mass(folder: Path) -> float | None:
    """Sum of mass_kg in a variant's parts list, read back from the file."""
    import pandas as pd

    try:
        return float(pd.read_csv(folder / "parts.csv")["mass_kg"].sum())
    except (OSError, KeyError, ValueError):
        return None


def results_table(study, out: Path, outcomes: dict, devices: dict):
    """One row per torsal variant (axis values, every figure of its report.json, buildable,
    material, wall time) and per standard device of each depth and spacing."""
    import pandas as pd

    axes = list(study.spec.axes)
    rows = []
    for v in study.variants:
        o = outcomes.get(v.id)
        if o is None:
            continue
        folder = out / "variants" / v.id
        row = {"id": v.id, "kind": "torsal", "device": "torsal", "status": o["status"],
               **{k: v.axes[k] for k in axes},
               "fins.depth": _family_value(v.spec.fins.depth),
               "fins.spacing": _family_value(v.spec.fins.spacing),
               "failed_stage": o.get("stage"), "error": o.get("error"),
               "wall_s": float(o.get("wall_s", np.nan)),
               # report.html where the variant wrote one ([run] files = ["report"])
               "report": f"variants/{v.id}/report.html"
               if (folder / "report.html").exists() else f"variants/{v.id}/report.json",
               **{f"stage_s.{k}": float(x) for k, x in (o.get("stage_s") or {}).items()},
               "warnings": "; ".join(o.get("warnings") or []) or None}
        if o["status"] == "done":
            report = json.loads((folder / "report.json").read_text())   # the variant's own file
            row.update(flatten(report))
            row["buildable"] = _buildable(report)
            row["material_kg"] = material_kg(report["light"]["fin_area_m2"], v.spec)
            row["bom_mass_kg"] = _bom_mass(folder)
        rows.append(row)
    for key, (spec, rec) in devices.items():
        # the axis values the devices depend on: those shared by every variant they stand for
        same = [v for v in study.variants if v.id in outcomes
                and _device_key(v.spec) == key]
        # the devices' annual figures: the annual stage of a variant they stand for
        done = [v for v in same if outcomes[v.id]["status"] == "done"]
        annual = (json.loads((out / "variants" / done[0].id / "report.json").read_text())
                  if done and spec.annual.enabled else {})
        for name, m in rec["devices"].items():
            made = m.get("applicable", True)
            row = {"id": f"baseline-{key[:8]}-{name.replace(' ', '-')}", "kind": "baseline",
                   "device": name, "status": "done" if made else NOT_APPLICABLE,
                   "note": None if made else m["reason"],
                   "fins.depth": _family_value(spec.fins.depth),
                   "fins.spacing": _family_value(spec.fins.spacing),
                   "wall_s": float(rec["wall_s"]), "buildable": None,
                   "material_kg": material_kg(m["fin_area_m2"], spec) if made else None}
            for k in axes:
                values = {json.dumps(v.axes[k]) for v in same}
                row[k] = same[0].axes[k] if len(values) == 1 else None
            row.update(flatten({"light": {k: x for k, x in m.items()
                                          if k not in ("applicable", "reason")}}))
            if made:
                row.update(_device_annual(annual, name))
            rows.append(row)
    table = pd.DataFrame(rows)
    pareto = _pareto(study)
    first = _FIRST + [c for c in axes if c not in _FIRST] + [
        c for c in ("fins.depth", "fins.spacing", Y_KEY, X_KEY, pareto.y, pareto.x,
                    "material_kg", "buildable", "wall_s", "failed_stage", "error", "report")
        if c not in axes]
    first = list(dict.fromkeys(first))
    table = table[[c for c in first if c in table] + sorted(c for c in table if c not in first)]
    for c in table.columns:      # parquet wants one type per column
        kinds = {type(x) for x in table[c] if x is not None and not (isinstance(x, float) and np.isnan(x))}
        if len(kinds) > 1 and not kinds <= {int, float, bool, np.float64, np.int64, np.bool_}:
            table[c] = [None if x is None else str(x) for x in table[c]]
    return table


def _device_key(spec) -> str:
    from ..pipeline.devices import DEVICES_PIPELINE
    from ..pipeline.stage import stage_keys

    return stage_keys(DEVICES_PIPELINE, spec)["devices"]


def pareto_front(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Indices of the points not dominated when both x and y are maximized, by x ascending.

    >>> pareto_front(np.array([0.1, 0.5, 0.4, 0.9]), np.array([0.9, 0.6, 0.5, 0.2])).tolist()
    [0, 1, 3]
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    keep = [i for i in range(len(x))
            if not np.any((x >= x[i]) & (y >= y[i]) & ((x > x[i]) | (y > y[i])))]
    return np.array(sorted(keep, key=lambda i: (x[i], -y[i])), dtype=int)


def lead_over(x: float, y: float, bx: np.ndarray, by: np.ndarray) -> tuple[float, int]:
    """How far the point (x, y) lies beyond the points (bx, by) (both maximized): the
    additive epsilon indicator ``min_j max(x - bx_j, y - by_j)``, i.e. the smallest amount
    every baseline point lacks, in both shares at once, to reach (x, y); positive: beyond the
    baselines' front, negative: behind it. Returns it and the nearest baseline's index.

    >>> lead_over(0.6, 0.8, np.array([0.5, 0.7]), np.array([0.7, 0.5]))
    (0.1, 0)
    """
    gaps = np.maximum(x - np.asarray(bx, float), y - np.asarray(by, float))
    j = int(np.argmin(gaps))
    return round(float(gaps[j]), 12), j


def _axes_text(row, axes) -> str:
    return ", ".join(f"{k} {row[k]:.3g}" if isinstance(row[k], (int, float)) else f"{k} {row[k]}"
                     for k in axes if k in row and row[k] is not None)


def _sun_words(study) -> str:
    return "of the sun as asked" if _asks(study) else "of the sun blocked"


def _and(names) -> str:
    names = list(names)
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


def verdict(table, axes, *, sun_words: str = "of the sun blocked",
            pareto: ParetoSpec | None = None) -> tuple[str, dict]:
    """The sentence at the top of study.html, computed from the table, and its numbers
    (``sun_words`` names the sun axis: "of the sun blocked", or "of the sun as asked");
    with ``pareto`` naming other axes, :func:`verdict_on` them."""
    if pareto is not None and not pareto.is_default:
        return verdict_on(table, axes, pareto)
    ok = table[(table["status"] == "done")].dropna(subset=[X_KEY, Y_KEY])
    t = ok[ok["kind"] == "torsal"]
    b = ok[ok["kind"] == "baseline"]
    if t.empty or b.empty:
        return ("No comparison: " + ("no torsal variant finished." if t.empty
                                     else "no standard device was measured."), {})
    bx, by = b[X_KEY].to_numpy(), b[Y_KEY].to_numpy()
    leads = [lead_over(r[X_KEY], r[Y_KEY], bx, by) for _, r in t.iterrows()]
    eps = np.array([e for e, _ in leads])
    best, worst = int(np.argmax(eps)), int(np.argmin(eps))
    n_beyond = int((eps > 0).sum())

    def point(k):
        r = t.iloc[k]
        return (f"{r['id']} ({_axes_text(r, axes)}: {100 * r[Y_KEY]:.1f}% {sun_words}, "
                f"{100 * r[X_KEY]:.1f}% of the view clear, {r['material_kg']:.0f} kg)")

    def device(k):
        d = b.iloc[leads[k][1]]
        return (f"{d['device']} at depth {_length_text(d['fins.depth'])}, spacing "
                f"{_length_text(d['fins.spacing'])}: "
                f"{100 * d[Y_KEY]:.1f}% {sun_words.split()[-1]}, {100 * d[X_KEY]:.1f}% clear, "
                f"{d['material_kg']:.0f} kg")

    names = [n for n in _SYMBOLS if n in set(b["device"])] + sorted(
        set(b["device"]) - set(_SYMBOLS))
    devices = (f"the standard devices ({_and(names)} of the same depths and spacings)")
    missing = sorted(set(table.loc[table["status"] == NOT_APPLICABLE, "device"]) - set(names))
    if missing:
        devices += f"; {_and(missing)} cannot be made on this surface"
    behind = ""
    if len(t) - n_beyond:
        behind = (f"{len(t) - n_beyond} lie behind it, the furthest behind, {point(worst)}, by "
                  f"{100 * -eps[worst]:.1f} points (nearest device: {device(worst)})")
    if n_beyond:
        text = (f"{n_beyond} of {len(t)} torsal variants lie beyond the front of {devices}: "
                f"the furthest, {point(best)}, by {100 * eps[best]:.1f} percentage points "
                f"(every device blocks at least that much less sun or leaves at least that much "
                f"less view clear; nearest: {device(best)}; no device blocks more than "
                f"{100 * by.max():.1f}%)" + (f"; {behind}." if behind else "."))
    else:
        text = (f"No torsal variant lies beyond the front of {devices}: all {behind}, and even "
                f"the closest, {point(best)}, is {100 * -eps[best]:.1f} percentage points behind "
                f"(a device blocks at least that much more sun and leaves at least that much more "
                f"view clear: {device(best)}).")
    return text, {"beyond": n_beyond, "torsal": int(len(t)), "lead": float(eps[best]),
                  "lag": float(eps[worst]), "best": str(t.iloc[best]["id"]),
                  "nearest": str(b.iloc[leads[best][1]]["id"])}


def verdict_on(table, axes, pareto: ParetoSpec, *, labels: dict | None = None
               ) -> tuple[str, dict]:
    """The verdict on the two figures ``pareto`` names (each better the way it says): how
    many torsal variants lie beyond the devices' front, and the furthest against its nearest
    device, in each figure's own units. The lead is the additive epsilon indicator
    (:func:`lead_over`) on each figure scaled by its span over the table's points, so two
    figures of different units weigh alike; it is given as a share of those spans.

    >>> import pandas as pd
    >>> p = ParetoSpec(x="light.annual.daylight.fins.sda_all",
    ...                y="light.annual.fins.shading_factor.cooling_gains_avoided_kwh_m2")
    >>> t = pd.DataFrame([{"id": "000", "kind": "torsal", "device": "torsal", "status": "done",
    ...     p.x: 0.6, p.y: 150.0, "fins.depth": 0.4, "fins.spacing": 0.6},
    ...     {"id": "b-egg", "kind": "baseline", "device": "egg-crate", "status": "done",
    ...     p.x: 0.5, p.y: 160.0, "fins.depth": 0.4, "fins.spacing": 0.6}])
    >>> verdict_on(t, [], p)[1]["beyond"]
    1
    """
    x, y = pareto.x, pareto.y
    labels = labels or {}
    if not {x, y} <= set(table.columns):       # every variant failed before measuring them
        return f"No comparison: no design has {x} and {y}.", {}
    ok = table[(table["status"] == "done")].dropna(subset=[x, y])
    t, b = ok[ok["kind"] == "torsal"], ok[ok["kind"] == "baseline"]
    if t.empty or b.empty:
        return ("No comparison: " + ("no torsal variant has " if t.empty else
                                     "no standard device has ") + f"{x} and {y}.", {})
    sx, sy = _signs(pareto)
    span = [max(float(np.ptp(ok[k].astype(float))), 1e-12) for k in (x, y)]
    leads = [lead_over(sx * r[x] / span[0], sy * r[y] / span[1],
                       sx * b[x].to_numpy(float) / span[0], sy * b[y].to_numpy(float) / span[1])
             for _, r in t.iterrows()]
    eps = np.array([e for e, _ in leads])
    best = int(np.argmax(eps))
    n_beyond = int((eps > 0).sum())
    lx, ly = (labels.get(k, _SHORT_LABELS.get(k, figure_label(k))) for k in (x, y))

    def at(r) -> str:
        return f"{ly} {_value_text(y, r[y])}, {lx} {_value_text(x, r[x])}"

    r, d = t.iloc[best], b.iloc[leads[best][1]]
    pair = (f"{r['id']} ({_axes_text(r, axes) + ': ' if axes else ''}{at(r)}) against the "
            f"nearest device, {d['device']} at depth {_length_text(d['fins.depth'])}, spacing "
            f"{_length_text(d['fins.spacing'])} ({at(d)})")
    sense = (f"{'more' if sx > 0 else 'less'} {lx} and {'more' if sy > 0 else 'less'} {ly} "
             "are better")
    if n_beyond:
        text = (f"{n_beyond} of {len(t)} torsal variants lie beyond the standard devices' front "
                f"({sense}): the furthest, {pair}, by {100 * eps[best]:.1f}% of the figures' "
                "spans.")
    else:
        text = (f"No torsal variant lies beyond the standard devices' front ({sense}); the "
                f"closest, {pair}, is {100 * -eps[best]:.1f}% of the figures' spans behind.")
    return text, {"beyond": n_beyond, "torsal": int(len(t)), "lead": float(eps[best]),
                  "best": str(r["id"]), "nearest": str(d["id"])}


_PAGE = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>{title}</title>
<style>body{{font-family:system-ui,sans-serif;margin:2em;max-width:1100px}}
p.verdict{{font-size:1.15em;background:#f3f6fa;padding:.8em;border-left:4px solid #2a6}}
table{{border-collapse:collapse;font-size:.85em}}td,th{{border:1px solid #ccc;padding:2px 6px}}
</style></head><body>
<h1>{title}</h1>
<p class="verdict">{verdict}</p>
<p>Each point is one design, measured with the same seeded sample points on the surface, the
same sun hours and the same view rays. Up: {up}; right: {right}. Colour: sheet material (kg).
Click a torsal point to open its report.</p>
{plot}
<h2>Variants</h2>
{table}
</body></html>
"""


def _front(d, pareto: ParetoSpec):
    """The rows of ``d`` on its Pareto front (each axis better the way ``pareto`` says)."""
    sx, sy = _signs(pareto)
    k = pareto_front(sx * d[pareto.x].astype(float), sy * d[pareto.y].astype(float))
    return d.iloc[sorted(k, key=lambda i: float(d[pareto.x].iloc[i]))]


def _figure(table, axes, xlabel: str, ylabel: str, pareto: ParetoSpec | None = None):
    import plotly.graph_objects as go

    pareto = pareto or ParetoSpec()
    X, Y = pareto.x, pareto.y
    fig = go.Figure()
    ok = table[table["status"] == "done"].dropna(subset=[X, Y])
    t = ok[ok["kind"] == "torsal"]
    cmin, cmax = float(ok["material_kg"].min()), float(ok["material_kg"].max())
    from ..pipeline.devices import DEVICES

    fx, fy = (".1%" if k in _SHARES else ".3g" for k in (X, Y))
    hover = "%{text}<br>" + f"{Y} %{{y:{fy}}}, {X} %{{x:{fx}}}" + "<extra></extra>"
    if pareto.is_default:
        hover = "%{text}<br>blocked %{y:.1%}, clear %{x:.1%}<extra></extra>"
    for name in DEVICES:
        d = ok[ok["device"] == name]
        if d.empty:
            continue
        front = _front(d, pareto)
        fig.add_trace(go.Scatter(
            x=front[X], y=front[Y], mode="lines", line={"dash": "dot", "width": 1.5},
            name=f"{name}: front", legendgroup=name, hoverinfo="skip"))
        fig.add_trace(go.Scatter(
            x=d[X], y=d[Y], mode="markers", name=name, legendgroup=name,
            marker={"symbol": _SYMBOLS.get(name, ("circle",))[0], "size": 10, "color": d["material_kg"],
                    "cmin": cmin, "cmax": cmax, "colorscale": "Viridis",
                    "line": {"width": 1, "color": "#444"}},
            text=[f"{name}<br>depth {_length_text(r['fins.depth'])}, spacing "
                  f"{_length_text(r['fins.spacing'])}<br>{r['material_kg']:.0f} kg"
                  for _, r in d.iterrows()],
            hovertemplate=hover))
    if not t.empty:
        front = _front(t, pareto)
        fig.add_trace(go.Scatter(x=front[X], y=front[Y], mode="lines",
                                 line={"width": 2.5, "color": "#c0392b"}, name="torsal: front",
                                 hoverinfo="skip"))
        fig.add_trace(go.Scatter(
            x=t[X], y=t[Y], mode="markers", name="torsal variants",
            customdata=t["report"],
            marker={"symbol": "circle", "size": 14, "color": t["material_kg"], "cmin": cmin,
                    "cmax": cmax, "colorscale": "Viridis", "line": {"width": 2, "color": "#c0392b"},
                    "colorbar": {"title": "material (kg)"}},
            text=[f"torsal {r['id']}<br>{_axes_text(r, axes)}<br>{r['material_kg']:.0f} kg, "
                  f"{r.get('fabrication.parts', float('nan')):.0f} parts" for _, r in t.iterrows()],
            hovertemplate=hover))
    fig.update_layout(xaxis_title=xlabel,
                      yaxis_title=ylabel,
                      xaxis_tickformat=".0%" if X in _SHARES else None,
                      yaxis_tickformat=".0%" if Y in _SHARES else None, height=620,
                      legend={"orientation": "h", "y": -0.15}, margin={"t": 20})
    return fig


_CLICK = """var plot = document.getElementById('{plot_id}');
plot.on('plotly_click', function (ev) {
  var p = ev.points[0];
  if (p && p.customdata) { window.location.href = p.customdata; }
});"""


def _html_table(table, axes, pareto: ParetoSpec | None = None) -> str:
    pareto = pareto or ParetoSpec()
    cols = ["id", "kind", "device", "status", "note", *axes]
    cols += [c for c in ("fins.depth", "fins.spacing") if c not in cols]
    cols += [Y_KEY, X_KEY, pareto.y, pareto.x, "material_kg", "fabrication.parts", "buildable",
             "wall_s", "failed_stage", "error"]
    cols = [c for c in dict.fromkeys(cols) if c in table]
    head = "".join(f"<th>{html.escape(c)}</th>" for c in cols)
    body = []
    for _, r in table.iterrows():
        cells = []
        for c in cols:
            x = r[c]
            if c == "id" and r["kind"] == "torsal" and r["status"] == "done":
                cells.append(f'<td><a href="{html.escape(r["report"])}">{html.escape(str(x))}</a></td>')
                continue
            if isinstance(x, float):
                x = "" if np.isnan(x) else (f"{100 * x:.1f}%" if c in _SHARES else f"{x:.4g}")
            cells.append(f"<td>{html.escape('' if x is None else str(x))}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><tr>{head}</tr>{''.join(body)}</table>"


def write_study_html(path: Path, study, table) -> str:
    """Write study.html (plotly inlined: works offline); returns the verdict sentence."""
    axes = list(study.spec.axes)
    pareto = _pareto(study)
    text, _ = verdict(table, axes, sun_words=_sun_words(study), pareto=pareto)
    xlabel, ylabel = figure_label(pareto.x, study), figure_label(pareto.y, study)
    fig = _figure(table, axes, xlabel, ylabel, pareto)
    plot = fig.to_html(full_html=False, include_plotlyjs=True, div_id="pareto",
                       post_script=_CLICK.replace("{plot_id}", "pareto"))
    words = {"max": "more", "min": "less"}
    up, right = (("more of the design-hour sun blocked", "more of the view clear")
                 if pareto.is_default else
                 (f"{ylabel} ({words[pareto.better('y')]} is better)",
                  f"{xlabel} ({words[pareto.better('x')]} is better)"))
    page = _PAGE.format(title=html.escape(study.spec.name), verdict=html.escape(text),
                        plot=plot, table=_html_table(table, axes, pareto),
                        up=html.escape(up), right=html.escape(right))
    with atomic_path(path) as tmp:
        tmp.write_text(page)
    return text


def write_pareto_png(path: Path, study, table) -> Path:
    """The Pareto plot as a PNG (matplotlib, for documents): sun blocked against view clear
    (or the study's ``[pareto]`` figures), torsal variants (red circles, their front a solid
    line), each standard device (its own marker, its front dotted); marker colour: sheet
    material (kg)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from ..pipeline.devices import DEVICES

    pareto = _pareto(study)
    X, Y = pareto.x, pareto.y
    ok = table[table["status"] == "done"].dropna(subset=[X, Y])
    fig = Figure(figsize=(8, 6), dpi=110)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    kg = ok["material_kg"].astype(float)
    norm = {"vmin": float(kg.min()), "vmax": float(kg.max())} if len(kg) else {}
    sc = None
    for k, name in enumerate(DEVICES):
        d = ok[ok["device"] == name]
        if d.empty:
            continue
        front = _front(d, pareto)
        colour = f"C{k}"
        ax.plot(front[X], front[Y], ":", color=colour, lw=1.2)
        sc = ax.scatter(d[X], d[Y], c=d["material_kg"].astype(float), cmap="viridis",
                        marker=_SYMBOLS.get(name, (None, "o"))[1], s=55, edgecolors=colour,
                        linewidths=1.5, label=name, **norm)
    t = ok[ok["kind"] == "torsal"]
    if not t.empty:
        front = _front(t, pareto)
        ax.plot(front[X], front[Y], "-", color="#c0392b", lw=2.2)
        sc = ax.scatter(t[X], t[Y], c=t["material_kg"].astype(float), cmap="viridis",
                        marker="o", s=110, edgecolors="#c0392b", linewidths=2.2,
                        label="torsal variants", **norm)
    if sc is not None:
        fig.colorbar(sc, ax=ax).set_label("sheet material (kg)")
        ax.legend(loc="lower left", fontsize=8, framealpha=0.9)
    missing = sorted(set(table.loc[table["status"] == NOT_APPLICABLE, "device"]))
    if missing:
        ax.text(0.99, 0.01, "not applicable here: " + ", ".join(missing), transform=ax.transAxes,
                ha="right", va="bottom", fontsize=7, color="0.3")
    if X in _SHARES:
        ax.xaxis.set_major_formatter(lambda x, _: f"{100 * x:.0f}%")
    if Y in _SHARES:
        ax.yaxis.set_major_formatter(lambda y, _: f"{100 * y:.0f}%")
    ax.set_xlabel(figure_label(X, study), fontsize=9)
    ax.set_ylabel(figure_label(Y, study), fontsize=9)
    ax.set_title(study.spec.name, fontsize=10)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    return path
