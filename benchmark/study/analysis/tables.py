"""The analysis as tables, in markdown and LaTeX (booktabs), in the papers' format.

The preference table follows CodeTalker's Table 2 and CDFace's Table IV: a line per
comparison, "Ours vs. X", a column per question, the percentage of answers preferring the
first row with its 95 % interval and the test's p-value. Then MOS, Bradley-Terry strengths,
agreement, the exclusions and (``--board``) the metrics against people.
"""

from __future__ import annotations

QUESTION_LABELS = {"lipsync": "Lip Sync", "realism": "Realism", "diversity": "Diversity",
                   "expressiveness": "Expressiveness"}


def question_label(question: str) -> str:
    return QUESTION_LABELS.get(question, question)


def _number(value, digits=2, signed=False):
    if value is None:
        return "-"
    return f"{value:+.{digits}f}" if signed else f"{value:.{digits}f}"


def _p(value) -> str:
    if value is None or value != value:
        return "-"
    return "p < 0.001" if value < 0.001 else f"p = {value:.3f}"


def table_list(record: dict) -> list[tuple[str, list[str], list[list[str]]]]:
    """``[(title, header, lines)]``: every table of the analysis, as cells of text."""
    labels = record.get("labels", {})
    name = lambda row: labels.get(row, row)  # noqa: E731
    questions = record["questions"]
    tables = []
    if record["preference"]:
        pairs = list(dict.fromkeys((p["a"], p["b"]) for p in record["preference"]))
        asked = [q for q in questions if any(p["question"] == q for p in record["preference"])]
        cells = {(p["a"], p["b"], p["question"]): p for p in record["preference"]}
        lines = []
        for a, b in pairs:
            line = [f"{name(a)} vs. {name(b)}"]
            for q in asked:
                p = cells.get((a, b, q))
                line.append("-" if p is None else f"{100 * p['share_a']:.1f} % [{100 * p['ci95'][0]:.1f}, "
                                                  f"{100 * p['ci95'][1]:.1f}], {_p(p['p_value'])}, n = {p['answers']}")
            lines.append(line)
        tables.append(("Preference: the share of answers preferring the first row (95 % interval, test of 50 %)",
                       ["Comparison"] + [question_label(q) for q in asked], lines))
    if record["mos"]:
        rows = list(dict.fromkeys(m["row"] for m in record["mos"]))
        asked = [q for q in questions if any(m["question"] == q for m in record["mos"])]
        cells = {(m["row"], m["question"]): m for m in record["mos"]}
        lines = [[name(r)] + ["-" if (r, q) not in cells else
                              f"{cells[r, q]['mean']:.2f} [{cells[r, q]['ci95'][0]:.2f}, {cells[r, q]['ci95'][1]:.2f}]"
                              for q in asked] for r in rows]
        tables.append(("Mean opinion score, 1-5 (95 % interval)", ["Row"] + [question_label(q) for q in asked], lines))
    if record["bradley_terry"]:
        asked = list(record["bradley_terry"])
        rows = list(dict.fromkeys(s["row"] for q in asked for s in record["bradley_terry"][q]["strengths"]))
        cells = {(s["row"], q): s for q in asked for s in record["bradley_terry"][q]["strengths"]}
        anchor = record["bradley_terry"][asked[0]]["reference"]
        lines = [[name(r)] + ["-" if (r, q) not in cells else
                              f"{_number(cells[r, q]['log_strength'], signed=True)} "
                              f"[{_number(cells[r, q]['ci95'][0], signed=True)}, "
                              f"{_number(cells[r, q]['ci95'][1], signed=True)}]" for q in asked] for r in rows]
        tables.append((f"Bradley-Terry log-strength relative to {name(anchor)} (95 % interval)",
                       ["Row"] + [question_label(q) for q in asked], lines))
    if record["agreement"]:
        lines = [[question_label(q), _number(a["alpha"], 3), a["level"], str(a["raters"]), str(a["pairable_units"])]
                 for q, a in record["agreement"].items()]
        tables.append(("Agreement between participants (Krippendorff's alpha)",
                       ["Question", "alpha", "level", "participants", "units judged twice or more"], lines))
    ex = record["exclusions"]
    reasons = {"attention": "failed an attention check", "too_fast": f"finished in under {ex['min_seconds']:g} s",
               "incomplete": "did not finish", "sound_check": "failed the sound check"}
    lines = [[text, str(ex["by_reason"][key])] for key, text in reasons.items()]
    lines += [["excluded (any reason)", str(ex["excluded"])], ["kept", f"{ex['kept']} of {ex['participants']}"],
              ["answers analysed", f"{ex['answers_kept']} of {ex['answers']}"]]
    tables.append(("Exclusions (participants)", ["", "count"], lines))
    for q, entries in record.get("board", {}).get("questions", {}).items():
        direction = {True: "higher", False: "lower", None: "-"}
        lines = [[e["label"], direction[e["higher_is_better"]],
                  _number(e["sentence_agreement"]), str(e["sentence_units"]), _number(e["pair_agreement"]),
                  str(e["pairs"]), _number(e["spearman"], signed=True), _number(e["kendall"], signed=True)]
                 for e in entries]
        tables.append((f"The metrics against people: {question_label(q)}",
                       ["Metric", "better", "sentence agreement", "sentence pairs", "row-pair agreement", "row pairs",
                        "Spearman vs. BT", "Kendall vs. BT"], lines))
    return tables


def markdown_tables(record: dict) -> str:
    """Every table as GitHub markdown, each under a bold title."""
    parts = []
    for title, header, lines in table_list(record):
        text = [f"**{title}**", "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
        text += ["| " + " | ".join(cell.replace("|", "\\|") for cell in line) + " |" for line in lines]
        parts.append("\n".join(text))
    return "\n\n".join(parts) + "\n"


_LATEX = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_", "{": r"\{",
          "}": r"\}", "~": r"\textasciitilde{}", "^": r"\textasciicircum{}"}


def latex_escape(text: str) -> str:
    return "".join(_LATEX.get(c, c) for c in text)


def latex_tables(record: dict) -> str:
    """Every table as a LaTeX ``table`` with ``booktabs`` rules (``\\usepackage{booktabs}``)."""
    parts = []
    for title, header, lines in table_list(record):
        text = ["\\begin{table}[t]", "\\centering", f"\\caption{{{latex_escape(title)}}}",
                "\\begin{tabular}{l" + "c" * (len(header) - 1) + "}", "\\toprule",
                " & ".join(latex_escape(h) for h in header) + " \\\\", "\\midrule"]
        text += [" & ".join(latex_escape(cell) for cell in line) + " \\\\" for line in lines]
        text += ["\\bottomrule", "\\end{tabular}", "\\end{table}"]
        parts.append("\n".join(text))
    return "\n\n".join(parts) + "\n"
