"""How far the final cut's row plans (step B of ``nesting/split.py``, :class:`RowPlan`) hold
when the rows are laid out in two dimensions, on dumped outlines
(``benchmarks/final_cut_dump.py``'s OUT/<key>.pkl, with the design's rates and cut sites).

For every state of the plan (after each row emptied: its rows and the cuts so far) it prints
the rows' count, the cuts and the fixings they add, whether they pay for the sheets the plan
aims at, the sheets the rows' heights need (first fit decreasing of each row's tallest
plate as laid, into the sheet's height: what the plan's rows would take if every row were as
long as the plan counts it), how many rows' plates have bounding boxes that, end to end in
the orientation ``rows.planned_layout`` lays them, are longer than the sheet (an upper count:
head to tail the layout nests them closer), and the sheets ``planned_layout`` gives. Where
the last is above the heights' count, the plan's effective lengths (area over width:
parallelograms head to tail) promised more than the rows hold in two dimensions, and the
plates left over take sheets of their own.

    nice -n 19 .venv/bin/python benchmarks/row_plan_check.py 7a --dump /tmp/final_cut_dump
"""
import pickle

from final_cut_replay import dumped_args


def _ffd(heights, cap: float) -> int:
    bins: list[float] = []
    for x in sorted(heights, reverse=True):
        for i, b in enumerate(bins):
            if b + x <= cap + 1e-9:
                bins[i] += x
                break
        else:
            bins.append(x)
    return len(bins)


def check(path) -> list[dict]:
    from torsal.fabrication.nesting import rows as R
    from torsal.fabrication.nesting.cut_costs import cuts_pay
    from torsal.fabrication.nesting.pieces import Pieces, cut_outlines
    from torsal.fabrication.nesting.row_plan import RowPlan
    from torsal.fabrication.nesting.search import _Frame, _Search

    with open(path, "rb") as f:
        d = pickle.load(f)
    kw, unit = d["options"], d["unit"]
    pa = dict(d["pays_args"])
    pays = cuts_pay(pa.pop("rates"), **pa)

    def prepared(outlines):
        return R.prepare(outlines, kw["sheet"], kw["gap"], kw["margin"], kw.get("cutting"), unit)

    w, h, items, sep, edge = prepared(d["outlines"])
    frame = _Frame.of(w, h, sep, edge)
    names = [it.name for it in items]
    unrolled = {u.name: u for u in d["outlines"] if hasattr(u, "panels")}
    pieces = Pieces({it.name: it for it in items}, unrolled, d["cuts"], d["fixings"])
    plan = RowPlan(pieces, names, frame)
    plan.run(0)
    search = _Search(d["outlines"], unit=unit, time_limit=None, progress=None,
                     **{"rotation_step": None, **kw})
    search.run()
    n0 = search.layout().n_sheets            # the sheets the plan's cuts must save from
    out = []
    for rows, cuts, rows_names in plan.states:
        by_part: dict = {}
        for part, j in cuts:
            by_part.setdefault(part, set()).add(j)
        outs = cut_outlines(pieces, names, by_part)
        w2, h2, its, sep2, edge2 = prepared(outs)
        fr = R._RowFrame.of(its, w2, h2, sep2, edge2, kw.get("rotation_step"))
        long_rows, heights = 0, []
        for row in rows_names:
            ns = [n for n in row if n in fr.by and n not in fr.small]
            if ns:
                long_rows += sum(min(o.length for o in fr.by[n]) for n in ns) > fr.length
                heights.append(max(min(o.height for o in fr.by[n]) for n in ns) + sep2)
        lay = R.planned_layout(its, rows_names, w2, h2, sep2, edge2, kw.get("rotation_step"))
        costs = [pieces.cost(p, j) for p, j in cuts]
        by_heights = _ffd(heights, fr.height + sep2)
        out.append({"rows": rows, "cuts": len(cuts), "fixings": sum(c.fixings for c in costs),
                    "pays": bool(not cuts or pays(costs, n0 - by_heights)),
                    "by_heights": by_heights, "long_rows": long_rows,
                    "planned": len({v[0] for v in lay.values()})})
    return out


def main() -> None:
    a = dumped_args(__doc__)
    for key in a.keys:
        print(f"\n{key}\n| rows | cuts | fixings added | pays | sheets by the rows' heights "
              "| rows whose boxes end to end are longer than the sheet | sheets as planned_layout "
              "lays them |")
        print("|---|---|---|---|---|---|---|")
        for r in check(a.dump / f"{key}.pkl"):
            print(f"| {r['rows']} | {r['cuts']} | {r['fixings']} | {'yes' if r['pays'] else 'no'} "
                  f"| {r['by_heights']} | {r['long_rows']} | {r['planned']} |", flush=True)


if __name__ == "__main__":
    main()
