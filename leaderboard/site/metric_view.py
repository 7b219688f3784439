"""How the site orders, groups and marks metrics (until the metric registry lands)."""

from __future__ import annotations

GROUP_ORDER = ["lip sync", "distribution", "vertex", "diversity", "other"]
_GROUP_OF = {"av_offset": "lip sync", "av_confidence": "lip sync", "multimodality": "distribution",
             "fd": "distribution", "wind": "distribution", "lve": "vertex", "mve": "vertex", "fdd": "vertex"}


def describe(name, fields):
    return {"label": fields.get("label") or name, "unit": fields.get("unit") or "",
            "higher_is_better": fields.get("higher_is_better"),
            "group": fields.get("group") or next((g for k, g in _GROUP_OF.items() if name.startswith(k)), "other")}


def metric_order(specs):
    return sorted(specs, key=lambda n: (GROUP_ORDER.index(specs[n]["group"]) if specs[n]["group"] in GROUP_ORDER
                                        else len(GROUP_ORDER), n))


def grouped(names, specs):
    out = []
    for name in names:
        g = specs[name]["group"]
        if not out or out[-1]["name"] != g:
            out.append({"name": g, "metrics": []})
        out[-1]["metrics"].append(name)
    return out


def best_rows(rows, specs):
    """For each row, the metrics where it is best and its interval does not overlap the runner-up's."""
    marks = [set() for _ in rows]
    for name, spec in specs.items():
        hib = spec["higher_is_better"]
        if hib is None:
            continue
        vals = [(i, r.get(name)) for i, r in enumerate(rows) if r.get(name) and r[name].get("mean") is not None]
        if len(vals) < 2:
            continue
        vals.sort(key=lambda iv: iv[1]["mean"], reverse=bool(hib))
        (i0, a), (_, b) = vals[0], vals[1]
        if a.get("ci95") and b.get("ci95") and None not in a["ci95"] + b["ci95"]:
            separated = a["ci95"][0] > b["ci95"][1] if hib else a["ci95"][1] < b["ci95"][0]
            if separated:
                marks[i0].add(name)
    return marks
