"""The analysis figure (matplotlib, Agg): preference shares with their intervals per comparison
and question; Bradley-Terry strengths and MOS with theirs when the study has them."""

from __future__ import annotations

import io

import numpy as np

from benchmark.study.analysis.tables import question_label


def _panel(axis, labels, questions, values, lows, highs, reference_line, xlabel, title):
    height = 0.8 / max(1, len(questions))
    for k, question in enumerate(questions):
        y = np.arange(len(labels)) + (k - (len(questions) - 1) / 2) * height
        v, lo, hi = (np.asarray(x[k], dtype=float) for x in (values, lows, highs))
        axis.errorbar(v, y, xerr=[np.maximum(v - lo, 0), np.maximum(hi - v, 0)], fmt="o", capsize=3,
                      label=question_label(question))
    if reference_line is not None:
        axis.axvline(reference_line, color="grey", linestyle="--", linewidth=1)
    if reference_line == 50:  # shares: the whole 0-100 % scale
        axis.set_xlim(0, 100)
    axis.set_yticks(np.arange(len(labels)), labels)
    axis.invert_yaxis()
    axis.set_xlabel(xlabel)
    axis.set_title(title, fontsize=10)
    axis.legend(fontsize=8, loc="best")


def _grid(entries, key_row, key_value, questions, scale=1.0):
    rows = list(dict.fromkeys(key_row(e) for e in entries))
    cells = {(key_row(e), e["question"]): e for e in entries}
    nan = float("nan")
    values = [[scale * cells[r, q][key_value] if (r, q) in cells else nan for r in rows] for q in questions]
    lows = [[scale * cells[r, q]["ci95"][0] if (r, q) in cells else nan for r in rows] for q in questions]
    highs = [[scale * cells[r, q]["ci95"][1] if (r, q) in cells else nan for r in rows] for q in questions]
    return rows, values, lows, highs


def figure_png(record: dict) -> bytes:
    """The figure as PNG bytes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = record.get("labels", {})
    panels = []
    if record["preference"]:
        questions = list(dict.fromkeys(p["question"] for p in record["preference"]))
        rows, v, lo, hi = _grid(record["preference"], lambda p: (p["a"], p["b"]), "share_a", questions, 100)
        names = [f"{labels.get(a, a)} vs. {labels.get(b, b)}" for a, b in rows]
        panels.append((names, questions, v, lo, hi, 50, "% preferring the first row", "Preference (95 % interval)"))
    if record["bradley_terry"]:
        entries = [{**s, "question": q} for q, bt in record["bradley_terry"].items() for s in bt["strengths"]]
        questions = list(record["bradley_terry"])
        rows, v, lo, hi = _grid(entries, lambda s: s["row"], "log_strength", questions)
        anchor_row = record["bradley_terry"][questions[0]]["reference"]
        anchor = labels.get(anchor_row, anchor_row)
        panels.append(([labels.get(r, r) for r in rows], questions, v, lo, hi, 0,
                       f"log-strength relative to {anchor}", "Bradley-Terry (95 % interval)"))
    if record["mos"]:
        questions = list(dict.fromkeys(m["question"] for m in record["mos"]))
        rows, v, lo, hi = _grid(record["mos"], lambda m: m["row"], "mean", questions)
        panels.append(([labels.get(r, r) for r in rows], questions, v, lo, hi, None, "mean opinion score (1-5)",
                       "MOS (95 % interval)"))
    figure, axes = plt.subplots(1, max(1, len(panels)), figsize=(5.5 * max(1, len(panels)), 0.6 * max(
        [len(p[0]) for p in panels] + [3]) + 1.8), squeeze=False)
    for axis, panel in zip(axes[0], panels):
        _panel(axis, *panel)
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=120)
    plt.close(figure)
    return buffer.getvalue()
