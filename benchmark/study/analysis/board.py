"""The board's metrics held against the participants (``analyze --board DIR``).

For every metric of the studied rows' result files, per question:

``sentence_agreement``
    Over every comparison and sentence the participants judged (their majority; a tie is left
    out), the share where the metric's per-sentence values (``per_sentence``) order the two rows
    the same way: 1 is a metric that always sides with people, 0.5 one that is no better than
    a coin, 0 one that always contradicts them. A tie of the metric counts one half.
``pair_agreement``
    The same over the compared pairs of rows, with the rows' means (``metrics[m].mean``) and
    the participants' overall share.
``spearman``, ``kendall``
    The rank correlation between the metric's order of the rows (best first, by its direction)
    and the Bradley-Terry strengths (more than two rows only; scipy.stats).

A metric without a direction (``higher_is_better`` null) orders nothing and is listed without numbers.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy import stats

from benchmark import results as result_files
from blendvoca.errors import DataError, UserError


def board_results(folder, study, rows: list[str]) -> dict:
    """``{row: (path, Result)}`` for every studied row, from the result files in ``folder``.

    A row is found by its result file's name as the study recorded it, else by its label, else
    by its method's name.
    Refused: a folder without a studied row's result, or rows scored on different builds.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise UserError(f"--board {folder}: not a folder of result files")
    found = {}
    for path in sorted(folder.glob("*.json")):
        found[path] = result_files.read(path)
    chosen = {}
    for row in rows:
        info = study.rows.get(row, {})
        by_name = [p for p in found if info.get("result") and p.name == Path(info["result"]).name]
        by_label = [p for p, r in found.items() if r.label in (row, info.get("label"))]
        by_method = [p for p, r in found.items() if r.method.name == row]
        matches = by_name or by_label or by_method
        if not matches:
            expected = Path(info["result"]).name if info.get("result") else f"a result labelled {row!r}"
            raise DataError(f"--board {folder}: no result file for the studied row {row!r} (expected {expected})")
        if len(matches) > 1:
            raise DataError(f"--board {folder}: several result files for the studied row {row!r}: "
                            f"{', '.join(p.name for p in matches)}; keep one")
        path = matches[0]
        result = found[path]
        if info.get("recipe_id") and result.key != info["recipe_id"]:
            raise DataError(f"{path}: scored on build {result.key[:12]}, but the study's row {row!r} was made "
                            f"from build {info['recipe_id'][:12]}")
        chosen[row] = (path, result)
    keys = {result.key for _, result in chosen.values()}
    if len(keys) > 1:
        raise DataError(f"--board {folder}: the studied rows were scored on different builds ("
                        + ", ".join(f"{row}: {result.key[:12]}" for row, (_, result) in chosen.items()) + ")")
    return chosen


def _sentence_values(result) -> dict:
    values = {}
    for entry in result.per_sentence or ():
        values.setdefault((entry["subject"], entry["sentence"]), []).append(entry)
    return {key: {m: float(np.mean([e[m] for e in entries if isinstance(e.get(m), (int, float))]))
                  for m in {k for e in entries for k in e} - {"subject", "sentence"}
                  if any(isinstance(e.get(m), (int, float)) for e in entries)}
            for key, entries in values.items()}


def _agree(people_prefers_a: bool, metric_a: float, metric_b: float, higher_is_better: bool) -> float:
    if metric_a == metric_b:
        return 0.5
    metric_prefers_a = (metric_a > metric_b) == bool(higher_is_better)
    return 1.0 if metric_prefers_a == people_prefers_a else 0.0


def _correlation(function, x, y):
    if len(x) < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return None
    value = function(x, y)[0]
    return None if not np.isfinite(value) else float(value)


def metrics_against_people(judgements, record: dict, chosen: dict) -> dict:
    """``{"results": {row: file}, "questions": {question: [one record per metric]}}`` (module docstring)."""
    rows = judgements.rows
    sentences = {row: _sentence_values(result) for row, (_, result) in chosen.items()}
    for row, values in sentences.items():
        if not values:
            continue
        missing = [f"{s}/{t}" for s, t in judgements.items if (s, t) not in values]
        if missing:
            raise DataError(f"{chosen[row][0]}: the row {row!r} was not scored on the studied sentences "
                            f"{', '.join(missing[:3])}: hold the study against the results it was made from")
    metric_names = sorted(set.intersection(*(set(result.metrics) for _, result in chosen.values())))
    out = {"results": {row: str(path) for row, (path, _) in chosen.items()}, "questions": {}}
    for q, question in enumerate(judgements.questions):
        mask_q = judgements.question == q
        if not np.any(mask_q):
            continue
        units = {}
        for a, b, i, v in zip(judgements.row_a[mask_q], judgements.row_b[mask_q], judgements.item[mask_q],
                              judgements.value[mask_q]):
            units.setdefault((int(a), int(b), int(i)), []).append(int(v))
        shares = {(p["a"], p["b"]): p["share_a"] for p in record["preference"] if p["question"] == question}
        strengths = {s["row"]: s["log_strength"]
                     for s in record["bradley_terry"].get(question, {}).get("strengths", [])}
        entries = []
        for metric in metric_names:
            first = next(iter(chosen.values()))[1].metrics[metric]
            higher = first.higher_is_better
            entry = {"metric": metric, "label": first.label or metric, "higher_is_better": higher,
                     "sentence_agreement": None, "sentence_units": 0, "pair_agreement": None, "pairs": 0,
                     "spearman": None, "kendall": None, "rows": len(strengths)}
            if higher is None:
                entry["note"] = "no direction"
                entries.append(entry)
                continue
            scores = []
            for (a, b, i), values in units.items():
                share = np.mean(values)
                if share == 0.5:
                    continue
                va = sentences[rows[a]].get(judgements.items[i], {}).get(metric)
                vb = sentences[rows[b]].get(judgements.items[i], {}).get(metric)
                if va is None or vb is None:
                    continue
                scores.append(_agree(share > 0.5, va, vb, higher))
            if scores:
                entry["sentence_agreement"], entry["sentence_units"] = float(np.mean(scores)), len(scores)
            means = {row: chosen[row][1].metrics[metric].mean for row in chosen}
            pair_scores = [_agree(share > 0.5, means[a], means[b], higher)
                           for (a, b), share in shares.items() if share != 0.5]
            if pair_scores:
                entry["pair_agreement"], entry["pairs"] = float(np.mean(pair_scores)), len(pair_scores)
            if len(strengths) >= 3:
                names = list(strengths)
                signed = np.array([means[n] if higher else -means[n] for n in names])
                bt = np.array([strengths[n] for n in names])
                entry["spearman"] = _correlation(stats.spearmanr, signed, bt)
                entry["kendall"] = _correlation(stats.kendalltau, signed, bt)
            entries.append(entry)
        out["questions"][question] = entries
    return out
