"""Score the disturbed ground truth through the normal evaluation and judge every metric.

:func:`sanity_scores` applies each disturbance of :data:`~benchmark.sanity.disturbances.DISTURBANCES`
at its levels to the ground-truth tracks of a split and scores each disturbed set with
:func:`benchmark.evaluation.evaluate_split` (fewer bootstrap resamples than a run: the
suite reads means, not intervals; the metric definitions are the run's).
:func:`sanity_table` turns the scores into ``{metric: {disturbance: entry}}`` judged
against :data:`~benchmark.sanity.expectations.EXPECTATIONS`; :func:`write_report`
writes ``sanity.json`` and ``sanity.png``.
"""

from __future__ import annotations

import json
import time
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from benchmark.evaluation import EvaluationSettings, evaluate_split
from benchmark.evaluation.registry import ordered_metrics
from benchmark.sanity.disturbances import DISTURBANCES, disturb
from benchmark.sanity.expectations import EXPECTATIONS, REFERENCE_CLAIMS, REFERENCE_ROWS, declared, \
    reference_verdict, verdict
from blendvoca.errors import UserError
from blendvoca.runtime.progress import bar, progress_bars

__all__ = ["REFERENCE_SETTINGS", "SANITY_SETTINGS", "failures", "ground_truth", "plot_table", "reference_table",
           "reference_tracks", "run_sanity", "sanity_scores", "sanity_table", "status_counts", "write_report"]

#: The evaluation settings of the sanity run: the suite compares means across levels,
#: so the bootstrap intervals get a handful of resamples and WInD two seeded fits (the same
#: seeds at every level: the fit noise is common to all levels).
SANITY_SETTINGS = EvaluationSettings(wind_repeats=2, resamples=10, fd_resamples=5, wind_resamples=1, workers=2)


#: The reference rows' claims read intervals ("the oracle sample's interval contains 1"):
#: the run's 1000 bootstrap resamples (only the claimed metrics are scored; they are cheap).
REFERENCE_SETTINGS = SANITY_SETTINGS.replace(resamples=1000)


def _evaluate(generated, dataset, split, settings):
    """``{metric: mean}`` of ``generated`` (without the evaluation's own progress bars and warnings)."""
    with warnings.catch_warnings(), progress_bars(False):
        warnings.simplefilter("ignore")  # the same warnings at every level (e.g. no mesh space)
        scores = evaluate_split(generated, dataset, split, settings)
    return {name: float(entry["mean"]) for name, entry in scores.items()
            if isinstance(entry, Mapping) and entry.get("mean") is not None}


def _settings_record(settings) -> dict:
    """What the report records of ``settings``: :meth:`EvaluationSettings.to_dict`, the sync
    expert's path and the VAE's (``--vae``; none recorded: the published one)."""
    expert = {} if settings.sync_expert is None else {"sync_expert": str(settings.sync_expert)}
    vae = {"vae": str(settings.extractor)} if isinstance(settings.extractor, str) else {}
    return {**settings.to_dict(), **expert, **vae}


def ground_truth(dataset, split: str = "test") -> dict:
    """``{(subject, sentence): (T, K)}`` of a split; UserError when it has no sentence."""
    subjects = dataset.split(split)
    keys = [(s, t) for s in subjects for t in dataset.sentences(s)]
    if not keys:
        raise UserError(f"benchmark.sanity: the build {getattr(dataset, 'root', dataset)} has no sentences in its "
                        f"{split!r} split; the suite disturbs that split's ground truth")
    return {k: np.asarray(dataset.coeffs(*k), dtype=np.float64) for k in keys}


def sanity_scores(dataset, *, levels: str = "small", split: str = "test", kinds=None,
                  settings: EvaluationSettings = SANITY_SETTINGS) -> dict:
    """``{kind: [(level, {metric: mean})]}``: every disturbance at every level, scored.

    Parameters
    ----------
    dataset : a BlendVOCA dataset (``split``, ``sentences``, ``coeffs``, ``names`` and
        what ``evaluate_split`` reads)
    levels : "small" or "full"
    kinds : iterable of disturbance names, optional (default all)
    settings : EvaluationSettings
        Default :data:`SANITY_SETTINGS` (e.g. ``SANITY_SETTINGS.replace(sync_expert=PATH)``).
    """
    truth = ground_truth(dataset, split)
    names = tuple(dataset.names)
    kinds = list(DISTURBANCES) if kinds is None else list(kinds)
    for kind in kinds:
        if kind not in DISTURBANCES:
            raise ValueError(f"sanity_scores: unknown disturbance {kind!r}; known: {', '.join(DISTURBANCES)}")
    jobs = [(kind, level) for kind in kinds for level in DISTURBANCES[kind].levels(levels)]
    out, undisturbed = {}, None
    for kind, level in bar(jobs, desc="sanity", unit="score"):
        count = DISTURBANCES[kind].sample_count(levels)
        single = count == 1
        if level == 0 and single and undisturbed is not None:
            values = undisturbed  # level 0 of every single-sample disturbance is the truth itself
        else:
            values = _evaluate(disturb(kind, truth, level, names, count), dataset, split, settings)
            if level == 0 and single:
                undisturbed = values
        out.setdefault(kind, []).append((level, values))
    return out


def reference_tracks(dataset, split: str = "test") -> dict:
    """``{row: {key: (S, T, K)}}`` of the reference rows (:data:`~benchmark.sanity.expectations.REFERENCE_ROWS`):
    ``static`` (zeros: the neutral face), ``ground_truth`` and, where every sentence of the
    split has fitted oracle samples (a one-to-many synthetic build), ``oracle_sample``
    (all K of them as K samples) and ``oracle_mean`` (their mean), cut to the truth's length."""
    truth = ground_truth(dataset, split)
    rows = {"static": {k: np.zeros((1, *v.shape)) for k, v in truth.items()},
            "ground_truth": {k: v[None] for k, v in truth.items()}}
    has = getattr(dataset, "has_oracle", None)
    if has is not None and all(has(*k) for k in truth):
        oracle = {}
        for k, v in truth.items():
            samples = np.asarray(dataset.oracle_coeffs(*k), dtype=np.float64)
            t = min(samples.shape[1], len(v))
            oracle[k] = samples[:, :t]
        rows["oracle_sample"] = oracle
        rows["oracle_mean"] = {k: v.mean(axis=0, keepdims=True) for k, v in oracle.items()}
    return rows


def reference_table(dataset, split: str = "test", *, settings: EvaluationSettings = REFERENCE_SETTINGS,
                    claims=None) -> dict:
    """``{metric: {row: entry}}``: each claim of ``claims`` (default
    :data:`~benchmark.sanity.expectations.REFERENCE_CLAIMS`) judged on its reference row
    (:func:`~benchmark.sanity.expectations.reference_verdict` entries plus ``status``:
    ``held``, ``failed`` or ``not scored``, the last for a row the build does not have, such
    as the oracle rows of a build without oracle samples, or a metric the evaluation did not return)."""
    claims = REFERENCE_CLAIMS if claims is None else claims
    tracks = reference_tracks(dataset, split)
    metrics = sorted({c.metric for c in claims.values()})
    scored = {}
    for row in REFERENCE_ROWS:
        if row in tracks and any(c.row == row for c in claims.values()):
            with warnings.catch_warnings(), progress_bars(False):
                warnings.simplefilter("ignore")
                scored[row] = evaluate_split(tracks[row], dataset, split, settings, metrics=metrics)
    out = {}
    for (metric, row), claim in claims.items():
        entry = scored.get(row, {}).get(metric)
        if entry is None:
            judged = {"mean": None, "ci95": None, "expected": claim.expected, "target": claim.target, "ok": True,
                      "reason": claim.reason, "status": "not scored"}
        else:
            judged = reference_verdict(claim, entry)
            judged["status"] = "held" if judged["ok"] else "failed"
        out.setdefault(metric, {})[row] = judged
    return {m: out[m] for m in ordered_metrics(list(out))}


def sanity_table(scores: Mapping, table=None) -> dict:
    """``{metric: {disturbance: entry}}`` (:func:`~benchmark.sanity.expectations.verdict`
    entries plus ``status``: ``held``, ``failed``, ``no claim`` or ``not scored``).

    Every metric the evaluation returned gets every disturbance it was scored under;
    every declaration of ``table`` (default :data:`EXPECTATIONS`) on a disturbance that
    was run but a metric that was not returned is kept as ``not scored``.
    """
    table = EXPECTATIONS if table is None else table
    scored = {m for rows in scores.values() for _level, values in rows for m in values}
    result = {}
    for metric in ordered_metrics(list(scored)):
        for kind, rows in scores.items():
            pairs = [(level, values[metric]) for level, values in rows if metric in values]
            if len(pairs) < len(rows):
                continue  # e.g. multimodality: only where samples are several
            reference = None
            e = declared(metric, kind, table)
            if e.relative_to is not None and e.relative_to in scores:
                ref_rows = scores[e.relative_to]
                if all(metric in v for _l, v in ref_rows):
                    reference = [v[metric] for _l, v in ref_rows]
            entry = verdict(e, [p[0] for p in pairs], [p[1] for p in pairs], reference)
            entry["status"] = ("no claim" if e.expected == "any" else "held" if entry["ok"] else "failed")
            result.setdefault(metric, {})[kind] = entry
    for (metric, kind), e in table.items():
        if kind in scores and metric not in scored:
            entry = {"levels": [float(level) for level, _v in scores[kind]], "values": None, "rho": None,
                     "expected": e.expected, "ok": True, "reason": e.reason, "status": "not scored"}
            result.setdefault(metric, {})[kind] = entry
    return result


def status_counts(table: Mapping) -> dict:
    """``{status: count}`` of the table's entries: ``held``, ``failed``, ``no claim``, ``not scored``."""
    return {s: sum(e["status"] == s for row in table.values() for e in row.values())
            for s in ("held", "failed", "no claim", "not scored")}


def failures(table: Mapping) -> list:
    """``[(metric, disturbance, entry)]`` of the declarations that did not hold."""
    return [(m, d, e) for m, row in table.items() for d, e in row.items() if not e.get("ok", True)]


_COLOURS = {"held": "#d8f0d0", "failed": "#f7c8c4", "no claim": "#eeeeee", "limitation": "#fbe6b8"}
_MARKS = {"rises": "\u2191", "falls": "\u2193", "must not react": "\u2248", "equals level": "=k", "any": "\u00b7"}


def table_figure(table: Mapping, *, title: str = ""):
    """The metric x disturbance grid as a matplotlib figure (see :func:`plot_table`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    metrics = [m for m, row in table.items() if any(e["status"] != "not scored" for e in row.values())]
    kinds = [k for k in DISTURBANCES if any(k in table[m] for m in metrics)]
    kinds += sorted({k for m in metrics for k in table[m]} - set(kinds))
    cw, ch = 1.0, 1.0
    fig_w = 2.2 + 1.45 * len(kinds)
    fig_h = 1.2 + 0.5 * len(metrics)
    fig, ax = plt.subplots(figsize=(fig_w, fig_h), dpi=90)
    ax.set_xlim(0, len(kinds) * cw)
    ax.set_ylim(len(metrics) * ch, 0)
    ax.set_axis_off()
    for j, kind in enumerate(kinds):
        label = DISTURBANCES[kind].label if kind in DISTURBANCES else kind
        ax.text((j + 0.5) * cw, -0.15, label, ha="center", va="bottom", fontsize=7, rotation=0, wrap=True)
    for i, metric in enumerate(metrics):
        ax.text(-0.05, (i + 0.5) * ch, metric, ha="right", va="center", fontsize=7, family="monospace")
        for j, kind in enumerate(kinds):
            e = table[metric].get(kind)
            x0, y0 = j * cw, i * ch
            if e is None or e["status"] == "not scored":
                ax.add_patch(Rectangle((x0, y0), cw, ch, facecolor="white", edgecolor="#cccccc", lw=0.4))
                continue
            status = "limitation" if e.get("known_limitation") and e["status"] == "held" else e["status"]
            ax.add_patch(Rectangle((x0, y0), cw, ch, facecolor=_COLOURS[status], edgecolor="#999999", lw=0.4))
            v = np.asarray(e["values"], dtype=np.float64)
            lo, hi = float(np.nanmin(v)), float(np.nanmax(v))
            span = hi - lo
            y = np.full_like(v, 0.5) if not span > 1e-12 * max(1.0, abs(hi)) else (v - lo) / span
            xs = x0 + 0.08 * cw + 0.84 * cw * np.linspace(0, 1, len(v))
            ys = y0 + 0.82 * ch - 0.5 * ch * y
            ax.plot(xs, ys, "-", color="#333333", lw=0.8)
            ax.plot(xs, ys, "o", color="#333333", ms=1.6)
            rho = "n/a" if e["rho"] is None else f"{e['rho']:+.2f}"
            ax.text(x0 + 0.04 * cw, y0 + 0.2 * ch, _MARKS.get(e["expected"], "?"), fontsize=6.5, va="center")
            ax.text(x0 + 0.96 * cw, y0 + 0.2 * ch, f"\u03c1 {rho}", fontsize=5.5, ha="right", va="center")
            ax.text(x0 + 0.5 * cw, y0 + 0.95 * ch, f"{lo:.3g}..{hi:.3g}", fontsize=4.5, ha="center",
                    va="bottom", color="#555555")
    legend = ("\u2191 rises  \u2193 falls  \u2248 must not react  =k equals the level  \u00b7 no claim\n"
              "green held, red failed, amber known limitation (as declared), grey no claim; "
              "line: the metric's mean over the levels (scaled per cell; range below)")
    fig.text(0.01, 0.005, legend, fontsize=6.5, ha="left", va="bottom")
    if title:
        fig.suptitle(title, fontsize=9)
    fig.subplots_adjust(left=2.0 / fig_w, right=0.99, top=1 - 0.75 / fig_h, bottom=0.35 / fig_h)
    return fig


def plot_table(table: Mapping, path, *, title: str = "") -> Path:
    """The metric x disturbance grid as a PNG: one cell per pair, the values over the
    levels as a line (scaled to the cell; the range is printed), the declaration
    (arrow), Spearman rho and the verdict as the cell colour (green held, red failed,
    amber a known limitation as declared, grey no claim). The image is cropped or grown
    to its content (``bbox_inches="tight"``): the title, the row labels and the legend
    are never clipped, however long."""
    import matplotlib.pyplot as plt

    fig = table_figure(table, title=title)
    path = Path(path)
    fig.savefig(path, bbox_inches="tight", pad_inches=0.1)
    plt.close(fig)
    return path


def build_label(dataset) -> str:
    """A short name of the build for titles: its folder's name and the manifest hash's first 8
    characters (not the absolute path: the figure is shared and the path says nothing to others)."""
    root = getattr(dataset, "root", None)
    digest = getattr(dataset, "manifest_hash", None)
    name = "build" if root is None else Path(str(root)).name
    return name if digest is None else f"{name} ({str(digest)[:8]})"


def _json_safe(x):
    if isinstance(x, float) and not np.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json_safe(v) for v in x]
    return x


def write_report(table: Mapping, out, *, title: str = "", meta: Mapping | None = None) -> tuple[Path, Path]:
    """Write ``out/sanity.json`` (the table) and ``out/sanity.png`` (:func:`plot_table`);
    with ``meta``, also ``out/sanity_meta.json`` (how the suite was run)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    json_path = out / "sanity.json"
    json_path.write_text(json.dumps(_json_safe(dict(table)), indent=1) + "\n")
    if meta is not None:
        (out / "sanity_meta.json").write_text(json.dumps(_json_safe(dict(meta)), indent=1) + "\n")
    return json_path, plot_table(table, out / "sanity.png", title=title)


def run_sanity(dataset, out, *, levels: str = "small", split: str = "test", kinds=None,
               settings: EvaluationSettings = SANITY_SETTINGS, table=None,
               references: bool = True) -> tuple[dict, list]:
    """Score, judge and write the report; returns ``(table, failures)``. With
    ``references``, the reference rows' claims too (:func:`reference_table`, written to
    ``out/sanity_references.json``; a failed claim is a failure ``(metric, "reference row
    <row>", entry)``)."""
    start = time.perf_counter()
    scores = sanity_scores(dataset, levels=levels, split=split, kinds=kinds, settings=settings)
    result = sanity_table(scores, table)
    failed = failures(result)
    reference = (reference_table(dataset, split, settings=REFERENCE_SETTINGS.replace(extractor=settings.extractor))
                 if references else None)  # the same VAE as the disturbances (benchmark.sanity --vae)
    if reference is not None:
        failed += [(m, f"reference row {r}", e) for m, rows in reference.items() for r, e in rows.items()
                   if not e["ok"]]
    seconds = time.perf_counter() - start
    counts = status_counts(result)
    root = getattr(dataset, "root", None)
    title = (f"metric sanity: {build_label(dataset)} ({split} split, levels {levels}) - {counts['held']} held, "
             f"{counts['failed']} failed, {counts['no claim']} without a claim, {counts['not scored']} not scored")
    meta = {"data": None if root is None else str(root), "manifest_hash": getattr(dataset, "manifest_hash", None),
            "split": split, "levels": levels, "evaluation": _settings_record(settings), "seconds": round(seconds, 1),
            "counts": counts, "failed": [f"{m} / {d}" for m, d, _e in failed]}
    if meta["manifest_hash"] is not None:
        meta["manifest_hash"] = str(meta["manifest_hash"])
    if reference is not None:
        meta["references"] = {s: sum(e["status"] == s for rows in reference.values() for e in rows.values())
                              for s in ("held", "failed", "not scored")}
    write_report(result, out, title=title, meta=meta)
    if reference is not None:
        (Path(out) / "sanity_references.json").write_text(json.dumps(_json_safe(reference), indent=1) + "\n")
    return result, failed
