"""Markdown and LaTeX renderings of :class:`leaderboard.collect.Table` objects.

Columns are grouped (one table per metric group, in the paper's Table 1 order),
cells are ``mean [95 % interval]`` (and ``seeds [lowest, highest]`` of the per-seed
means for rows trained with several seeds), arrows give each metric's direction,
reference rows sit under the methods and are never ranked, and a method is in bold
only where it beats the runner-up in at least 95 % of the paired resamples
(:func:`leaderboard.collect.best_mark`). Under each table: the columns whose bold
mark fell back to the older interval rule, the rows that are not settled (†: the
statements their half-budget values would change, :mod:`leaderboard.settled`), and,
under the lip-sync table, how to read the AV offset against the ground truth.
"""

from __future__ import annotations

import re

from benchmark.evaluation.latent import METRICS as LATENT_METRICS
from benchmark.evaluation.registry import METRICS
from benchmark.evaluation.sample_size import LEVEL, SOURCE, below_minimum, min_test_sentences
from benchmark.results import Convergence

from .collect import Column, Row, Table, best_mark, column_decimals

__all__ = ["AV_OFFSET_NOTE", "DYNAMICS_NOTE", "HUMAN_PREFERENCE_NOTE", "NOT_SETTLED_MARK", "SMALL_SPLIT_MARK",
           "group_notes", "has_study", "small_split_columns",
           "human_preference_text", "latex_tables", "markdown_tables", "not_settled_text",
           "rtf_text"]

#: Mark after the label of a row whose training had not settled (``convergence.settled`` false).
NOT_SETTLED_MARK = "†"
#: Mark after the header of a metric whose test split has fewer sentences than the metric
#: needs to order the oracle rows (benchmark.evaluation.sample_size).
SMALL_SPLIT_MARK = "§"
_TEX_SMALL_SPLIT = r"$^\S$"
#: What the tables say beside the AV offset columns.
AV_OFFSET_NOTE = ("AV offset: on the synthetic corpus the ground truth carries a random per-sentence lag "
                  "(uniform over -2..2 frames), so methods can beat it on `av_offset_*` (mean |offset|, sync "
                  "quality); `av_lag_bias_*` is the row's systematic lead (-) or lag (+) against the data "
                  "(its mean signed offset minus the ground truth's on the same sentences; 0 for the ground truth).")

#: What the tables say under the dynamics columns (benchmark.evaluation.dynamics).
DYNAMICS_NOTE = ("Dynamics: motion ratio = the row's RMS velocity of the region over the ground truth's on the same "
                 "sentences (1 = the data's level; below 1 damped, above 1 livelier or noisy; not ranked); "
                 "closeness = 1 - abs(ratio - 1) (THEval; 0 for a static face, below 0 for more than twice the "
                 "data's motion); silent-lip ratio = jaw and lip motion in the audio's pauses over the ground "
                 "truth's.")
_ARROWS = {True: ("↑", r"$\uparrow$"), False: ("↓", r"$\downarrow$"), None: ("", "")}
_LATEX_SPECIAL = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_",
                  "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}", "^": r"\textasciicircum{}"}
_RULE = ("Best method in **bold** only where it beats the runner-up in at least 95 % of the paired bootstrap "
         "resamples (the same resampled sentences for both rows; training seeds resampled too for rows trained "
         "with several); reference rows are shown apart and never ranked; ↑ higher is better, ↓ lower is "
         "better; cells are mean [95 % bootstrap interval over sentences, and seeds where there are several] "
         "and, for rows trained with several seeds, seeds [lowest, highest] of the per-seed means; "
         f"{NOT_SETTLED_MARK}: not settled (the row's half-budget values, put in place of its full-budget ones, "
         "would change a statement of the table: a resampled order against another row, the bold, or its side of "
         "a reference row; the note under the table names them); RTF: real-time factor, wall seconds of generation per second "
         "of audio on the run's machine (below 1 is faster than the speech; - for results without a latency record).")


def _latex_escape(text: str) -> str:
    return "".join(_LATEX_SPECIAL.get(c, c) for c in str(text))


#: Characters of a name from a result file (a method label, a dataset title, a metric
#: label) that Markdown would read as table structure, HTML or formatting.
_MD_SPECIAL = {"\\": "\\\\", "|": "\\|", "<": "&lt;", ">": "&gt;", "&": "&amp;", "*": "\\*", "_": "\\_",
               "`": "\\`", "[": "\\[", "]": "\\]", "\n": " ", "\r": " "}
_TEX_LABEL = {"|": r"\textbar{}", "<": r"\textless{}", ">": r"\textgreater{}", "`": r"\textasciigrave{}",
              "\n": " ", "\r": " "}


def md_text(text) -> str:
    """A name from a result file as literal Markdown text: table bars, HTML and
    formatting characters escaped (a method named ``<script>`` or ``a | b`` stays one cell)."""
    return "".join(_MD_SPECIAL.get(c, c) for c in str(text))


def _latex_label(text) -> str:
    """A name from a result file as literal LaTeX text (:func:`_latex_escape`, and ``|``,
    ``<``, ``>``, backticks and line breaks, which the notes' markup would otherwise read)."""
    return "".join(_TEX_LABEL.get(c) or _LATEX_SPECIAL.get(c, c) for c in str(text))


def _latex_unit(unit: str) -> str:
    # "mm^2" -> "mm$^{2}$": units carry exponents, not literal carets
    parts = re.split(r"\^(-?\d+)", str(unit))
    return "".join(_latex_escape(p) if i % 2 == 0 else f"$^{{{p}}}$" for i, p in enumerate(parts))


def _number(value: float, decimals: int) -> str:
    """``value`` at ``decimals`` places; values that round to zero print as 0, never -0."""
    text = f"{value:.{decimals}f}"
    return text[1:] if text.startswith("-") and float(text) == 0 else text


def _cell_texts(rows: list, column: Column, decimals: int):
    """Per row: (mean text, interval text or None, seed range text or None) or None when
    the row lacks the metric."""
    out = []
    for row in rows:
        value = row.metrics.get(column.name)
        if value is None:
            out.append(None)
            continue
        mean, _std, ci = value
        interval, seeds = (None if pair is None else f"[{_number(pair[0], decimals)}, {_number(pair[1], decimals)}]"
                           for pair in (ci, row.seed_ranges.get(column.name)))
        out.append((_number(mean, decimals), interval, seeds))
    return out


def _group_cells(table: Table, columns: list):
    """(method cells, reference cells, bold sets, best marks) of a group of columns."""
    method_cells, reference_cells, bold, marks = [], [], [], []
    for column in columns:
        values = [r.metrics[column.name][0] for r in table.rows + table.references if column.name in r.metrics]
        decimals = column_decimals(values)
        method_cells.append(_cell_texts(table.rows, column, decimals))
        reference_cells.append(_cell_texts(table.references, column, decimals))
        mark = best_mark(table.rows, column)
        marks.append(mark)
        bold.append(set(mark.rows))
    return method_cells, reference_cells, bold, marks


def _label(row: Row, text: str, mark: str) -> str:
    return f"{text} {mark}" if row.settled is False else text


def _metric_label(name: str) -> str:
    return METRICS[name].label if name in METRICS else name


def not_settled_text(row: Row, label=str) -> str:
    """For a row not settled by ranking (:attr:`~leaderboard.collect.Row.statements`):
    ``"<label>: at step <B/2> of <B>, <metric> <at half> (now <at full>) would <change>, ..."``
    naming the statements of the table that would change. For a row the table could not
    judge (no half-budget values of its own):
    ``"<label>: <metric> <at half> → <at full> (half-width <w>) between steps <B/2> and <B>"``
    when its ``convergence.settled`` is false (for a row scoring another row's
    training, ``convergence.shared_with``: which row's training it is). A metric whose
    seed mean stayed within its half-width failed on some seeds: those are named instead,
    ``"<metric> on seed <k> <at half> → <at full> (half-width <w>)"``."""
    if row.statements:  # settled by ranking (leaderboard.settled): the statements that would change
        return _statements_text(row, label)
    conv = row.convergence or Convergence()
    if conv.shared_with:  # scored with another row's training: that training's verdict
        return f"{label(row.label)}: row {label(conv.shared_with)}'s training, not settled there"
    half, full = conv.checked_at_step, conv.total_steps
    steps = f"steps {half} and {full}" if half is not None and full is not None else "half and full budget"
    moved = []
    for name, at_half, at_full, half_width in row.unsettled_metrics():
        if at_half is None or at_full is None:
            moved.append(_metric_label(name))
            continue
        seeds = row.unsettled_seeds(name)
        if seeds and half_width is not None and abs(at_full - at_half) <= half_width:
            # the seed mean stayed within its half-width: the seeds that moved are the reason
            moved.append(f"{_metric_label(name)} on " + " and ".join(
                f"seed {seed} {_move_text(*values)}" for seed, *values in seeds))
        else:
            moved.append(f"{_metric_label(name)} {_move_text(at_half, at_full, half_width)}")
    return f"{label(row.label)}: " + (", ".join(moved) + f" between {steps}" if moved else f"moved between {steps}")


def _statements_text(row: Row, label=str) -> str:
    """``"<label>: at step <B/2> of <B>, <metric> <at half> (now <at full>) would <change>, ..."``,
    one clause per metric, from the row's :attr:`~leaderboard.collect.Row.statements`."""
    first = row.statements[0]
    if first.kind == "shared":
        return first.text(label)
    clauses, by_metric = [], {}
    for statement in row.statements:
        by_metric.setdefault(statement.metric, []).append(statement)
    for metric, statements in by_metric.items():
        s = statements[0]
        clauses.append(f"{_metric_label(metric)} {s.half_value:.3g} (now {s.full_value:.3g}) "
                       + ", ".join(x.change_text(label) for x in statements))
    shifted = "" if all(s.exact for s in row.statements) else " (resamples shifted by the move)"
    return f"{label(row.label)}: at step {first.step} of {first.total_steps}{shifted}, " + "; ".join(clauses)


def _move_text(at_half: float, at_full: float, half_width: float | None) -> str:
    return f"{at_half:.3g} → {at_full:.3g}" + (f" (half-width {half_width:.3g})" if half_width is not None else "")


def _split_sentences(table: Table, column: Column) -> int | None:
    """Test sentences behind ``column``: the smallest split of the rows that have the metric
    (the table's count where the results do not say)."""
    counts = [r.result.dataset.num_sentences for r in table.rows + table.references
              if column.name in r.metrics and r.result is not None and r.result.dataset.num_sentences]
    return min(counts) if counts else table.num_sentences


def small_split_columns(table: Table, columns: list) -> list:
    """``[(column, sentences, needed)]`` of the columns whose test split has fewer sentences
    than the metric needs (:data:`benchmark.evaluation.sample_size.MIN_TEST_SENTENCES`)."""
    out = []
    for column in columns:
        sentences = _split_sentences(table, column)
        if below_minimum(column.name, sentences):
            out.append((column, sentences, min_test_sentences(column.name)))
    return out


def _small_split_note(small: list, label=str) -> str:
    parts = [f"{label(column.label)} needs {needed} (this split has {sentences})"
             for column, sentences, needed in small]
    return (f"{SMALL_SPLIT_MARK} Test split below the metric's size: the order of the oracle rows (conditional draws "
            f"before their mean) holds with {100 * LEVEL:.0f} % probability from a size the oracle exam measured "
            f"({SOURCE}); " + "; ".join(parts) + ". Read these columns' orders with care.")


def group_notes(table: Table, columns: list, marks: list, label=str) -> list:
    """Plain-text lines under a group's table: the AV offset reading (lip-sync columns), the
    columns whose test split is below the metric's size (:data:`SMALL_SPLIT_MARK`), the
    rows not settled, and the columns whose best mark used the older interval rule; names
    from the result files through ``label`` (:func:`md_text` for Markdown)."""
    notes = []
    small = small_split_columns(table, columns)
    if small:
        notes.append(_small_split_note(small, label))
    if any(c.name.startswith(("av_offset_", "av_lag_bias_")) for c in columns):
        notes.append(AV_OFFSET_NOTE)
    if any(c.group == "dynamics" for c in columns):
        notes.append(DYNAMICS_NOTE)
    unsettled = [row for row in table.rows + table.references if row.settled is False]
    judged = [row for row in unsettled if row.statements]
    if judged:
        notes.append(f"{NOT_SETTLED_MARK} Not settled (its half-budget values in place of its full-budget ones would "
                     "change these statements of the table): " + "; ".join(not_settled_text(row, label)
                                                                            for row in judged) + ".")
    unsettled = [row for row in unsettled if not row.statements]
    if unsettled:
        notes.append(f"{NOT_SETTLED_MARK} Not settled (moved by more than the interval's half-width between half and "
                     "full training budget): " + "; ".join(not_settled_text(row, label) for row in unsettled) + ".")
    fallback: dict = {}
    for column, mark in zip(columns, marks):
        if mark.rule == "intervals":
            fallback.setdefault(mark.reason or "nothing to resample in these result files", []).append(
                label(column.label))
    if fallback:
        causes = "; ".join(f"{', '.join(labels)}: {reason}" if len(fallback) > 1 else reason
                           for reason, labels in fallback.items())
        labels = [name for group in fallback.values() for name in group]
        notes.append(f"Best in {', '.join(labels)} by the older rule (95 % interval disjoint from the runner-up's), "
                     f"as nothing could be resampled: {causes}.")
    return notes


#: Under a table whose latent metrics used a VAE trained on another dataset.
OUT_OF_DOMAIN_NOTE = ("Latent metrics (FD, WInD, multimodality, latent energy) use the published VAE, trained on "
                      "BlendVOCA: on this dataset they are out of domain (docs/datasets.md says how to train a "
                      "VAE on it).")


def vae_note(table: Table) -> str:
    """The line under a table whose latent metrics a VAE given to the runs scored (``--vae``;
    e.g. the real board's, trained on the corpus's training split): which one, by digest."""
    return (f"Latent metrics (FD, WInD, multimodality, latent energy) scored by the VAE of sha256 "
            f"{md_text(table.vae[:12])} (each result's `protocol.vae`), not the published one.")


def _latent_notes(table: Table, group: str) -> list:
    """The notes on which VAE scored the latent metrics, for the groups that show them."""
    if not any(c.name in LATENT_METRICS for c in dict(table.groups).get(group, [])):
        return []
    return ([OUT_OF_DOMAIN_NOTE] if table.latent_out_of_domain else []) + (
        [vae_note(table).replace("`", "'")] if table.vae else [])


def _caption(table: Table) -> str:
    n = f", {table.num_sentences} sentences" if table.num_sentences else ""
    named = f"{table.name}, " if table.name else ""
    return f"{named}dataset recipe {table.recipe_id[:12]} ({table.split} split{n})"


def rtf_text(row: Row, decimals: int = 3, mark: str | None = None) -> str:
    """The row's real-time factor (``latency.rtf`` of its result: wall seconds of generation per
    second of audio) to ``decimals`` significant digits, or ``"-"`` for a result without a latency record;
    followed by ``mark`` (default :data:`LOOKAHEAD_MARK`) when the row reads further ahead than it declares."""
    latency = row.result.latency if row.result is not None else None
    rtf = None if latency is None else latency.rtf
    text = "-" if rtf is None else f"{float(rtf):.{decimals}g}"
    return f"{text} {LOOKAHEAD_MARK if mark is None else mark}" if _reads_ahead(row) else text


#: Mark in the RTF cell of a row whose measured look-ahead exceeds its declared one by more than a frame.
LOOKAHEAD_MARK = "‡"


def _reads_ahead(row: Row) -> bool:
    latency = row.result.latency if row.result is not None else None
    return latency is not None and latency.exceeds_declaration()


def lookahead_notes(table: Table, label=str) -> list:
    """The line under a table naming the rows marked :data:`LOOKAHEAD_MARK`, with their
    measured and declared look-ahead; empty when no row is marked."""
    marked = [row for row in table.rows + table.references if _reads_ahead(row)]
    if not marked:
        return []

    def measured(latency) -> str:
        probe = latency.lookahead_probe
        whole = probe is not None and probe.whole_utterance
        return (f"the whole utterance ({latency.measured_lookahead_s:.3g} s)" if whole
                else f"{latency.measured_lookahead_s:.3g} s")

    rows = "; ".join(f"{label(row.label)}: measured {measured(row.result.latency)}, declared "
                     f"{row.result.latency.lookahead_s:.3g} s" for row in marked)
    return [f"{LOOKAHEAD_MARK} Reads further ahead than it declares: replacing the audio after a cut with silence "
            "or noise changed output frames more than one frame earlier than its declared look-ahead allows (the "
            f"look-ahead probe, docs/metrics.md): {rows}."]


#: Short names of a study's questions in the "human preference" column.
_QUESTION_NAMES = {"lipsync": "lip sync", "realism": "realism", "diversity": "diversity",
                   "expressiveness": "expressiveness"}
HUMAN_PREFERENCE_NOTE = ("Human pref.: a perceptual study of these rows (`python -m benchmark.study analyze --board "
                         "--store`): per question, the share of answers preferring the row to the study's reference "
                         "row [95 % interval, participants and sentences resampled], or its mean opinion score; "
                         "- for rows outside the study.")


def has_study(table: Table) -> bool:
    """Whether a row of ``table`` carries a perceptual study's verdict (``human_preference``)."""
    return any(row.result is not None and row.result.human_preference is not None
               for row in table.rows + table.references)


def human_preference_text(row: Row) -> str:
    """The row's "human preference" cell: per question the share of answers preferring it to the
    study's reference (``lip sync 38 % [27, 50]``) or its MOS, then ``vs. REFERENCE``; ``reference``
    for the reference row; ``-`` for a row without a study."""
    study = row.result.human_preference if row.result is not None else None
    if study is None:
        return "-"
    parts = []
    for question, entry in study.questions.items():
        name = _QUESTION_NAMES.get(question, question)
        if entry.share is not None:
            interval = f" [{100 * entry.ci95[0]:.0f}, {100 * entry.ci95[1]:.0f}]" if entry.ci95 else ""
            parts.append(f"{name} {100 * entry.share:.0f} %{interval}")
        elif entry.mos is not None:
            interval = f" [{entry.mos_ci95[0]:.2f}, {entry.mos_ci95[1]:.2f}]" if entry.mos_ci95 else ""
            parts.append(f"{name} MOS {entry.mos:.2f}{interval}")
    if not parts:
        return "reference" if study.reference == row.label else "-"
    vs = f" vs. {study.reference}" if study.reference and study.reference != row.label and study.design == "ab" else ""
    return "; ".join(parts) + vs


def _md_row(label: str, row: Row, cells, bold_flags, study: bool = False) -> str:
    out = [_label(row, label, NOT_SETTLED_MARK)]
    for cell, is_bold in zip(cells, bold_flags):
        if cell is None:
            out.append("–")
            continue
        mean, interval, seeds = cell
        mean = f"**{mean}**" if is_bold else mean
        text = mean if interval is None else f"{mean} {interval}"
        out.append(text if seeds is None else f"{text} seeds {seeds}")
    out += [str(row.samples), rtf_text(row)] + ([md_text(human_preference_text(row))] if study else [])
    return "| " + " | ".join(out) + " |"


def markdown_tables(tables: list[Table]) -> str:
    """All tables as one Markdown document."""
    lines = ["# BlendVOCA leaderboard", "",
             "Generated by `python -m leaderboard.build` from the result files; do not edit.", _RULE, ""]
    if not tables:
        lines += ["No results yet.", ""]
    for table in tables:
        lines += [f"## {md_text(table.name) + ': d' if table.name else 'D'}ataset `{table.recipe_id[:12]}`", "",
                  f"Full recipe id `{table.recipe_id}`, "
                  f"{table.split} split" + (f", {table.num_sentences} sentences." if table.num_sentences else "."), ""]
        if table.latent_out_of_domain:
            lines += [OUT_OF_DOMAIN_NOTE, ""]
        if table.vae:
            lines += [vae_note(table), ""]
        for group, columns in table.groups:
            method_cells, reference_cells, bold, marks = _group_cells(table, columns)
            small = {c.name for c, _, _ in small_split_columns(table, columns)}
            header = ["Method"] + [f"{md_text(c.label)}{f' ({md_text(c.unit)})' if c.unit else ''} "
                                   f"{_ARROWS[c.higher_is_better][0]}"
                                   f"{f' {SMALL_SPLIT_MARK}' if c.name in small else ''}"
                                   .rstrip() for c in columns] + ["S", "RTF"]
            study = has_study(table)
            header += ["Human pref."] if study else []
            lines += [f"### {group[:1].upper() + group[1:]}", "", "| " + " | ".join(header) + " |",
                      "|" + "|".join([":---"] + ["---:"] * (len(header) - 1)) + "|"]
            for i, row in enumerate(table.rows):
                lines.append(_md_row(md_text(row.label), row, [col[i] for col in method_cells],
                                     [i in b for b in bold], study))
            if table.references:
                lines.append("| *reference rows (not ranked)* |" + " |" * (len(header) - 1))
                for i, row in enumerate(table.references):
                    lines.append(_md_row(f"*{md_text(row.label)}*", row, [col[i] for col in reference_cells],
                                         [False] * len(columns), study))
            lines.append("")
            for note in (group_notes(table, columns, marks, md_text) + lookahead_notes(table, md_text)
                         + ([HUMAN_PREFERENCE_NOTE] if study else [])):
                lines += [note, ""]
    return "\n".join(lines)


def _tex_row(label: str, row: Row, cells, bold_flags, study: bool = False) -> str:
    out = [_label(row, label, r"$^\dagger$")]
    for cell, is_bold in zip(cells, bold_flags):
        if cell is None:
            out.append("--")
            continue
        mean, interval, seeds = cell
        mean = f"$\\mathbf{{{mean}}}$" if is_bold else f"${mean}$"
        small = " ".join(part for part in ([f"${interval}$"] if interval else []) + (
            [f"seeds ${seeds}$"] if seeds else []))
        out.append(f"{mean} {{\\scriptsize {small}}}" if small else mean)
    out += [str(row.samples), rtf_text(row, mark=r"$^\ddagger$")] + (
        [_latex_label(human_preference_text(row))] if study else [])
    return " & ".join(out) + r" \\"


def _tex_notes(notes: list) -> list:
    """Notes under a LaTeX table, small, one paragraph each."""
    out = []
    for note in notes:
        parts = note.split("`")  # `code` -> \texttt{code}
        text = "".join(_latex_escape(part) if i % 2 == 0 else f"\\texttt{{{_latex_escape(part)}}}"
                       for i, part in enumerate(parts))
        text = text.replace(NOT_SETTLED_MARK, r"$^\dagger$").replace(SMALL_SPLIT_MARK, _TEX_SMALL_SPLIT)
        text = text.replace(LOOKAHEAD_MARK, r"$^\ddagger$")
        text = text.replace("→", r"$\to$").replace("|", r"$|$")
        out.append(f"\\par\\smallskip{{\\footnotesize {text}}}")
    return out


def latex_tables(tables: list[Table]) -> str:
    """All tables as LaTeX ``table`` environments (booktabs), one per metric group, each
    scaled to the text width (``\\resizebox``) so that it fits a page."""
    parts = ["% Generated by `python -m leaderboard.build`; do not edit.",
             "% Requires \\usepackage{booktabs} and \\usepackage{graphicx}.", ""]
    for table in tables:
        for group, columns in table.groups:
            method_cells, reference_cells, bold, marks = _group_cells(table, columns)
            small = {c.name for c, _, _ in small_split_columns(table, columns)}
            header = ["Method"] + [
                f"{_latex_label(c.label)}{' (' + _latex_unit(c.unit) + ')' if c.unit else ''} "
                f"{_ARROWS[c.higher_is_better][1]}{_TEX_SMALL_SPLIT if c.name in small else ''}".rstrip()
                for c in columns] + ["$S$", "RTF"]
            study = has_study(table)
            header += ["Human pref."] if study else []
            body = [_tex_row(_latex_label(row.label), row, [col[i] for col in method_cells], [i in b for b in bold],
                             study) for i, row in enumerate(table.rows)]
            if table.references:
                body += [r"\midrule", f"\\multicolumn{{{len(header)}}}{{l}}{{\\textit{{Reference rows (not ranked)}}}} \\\\"]
                body += [_tex_row(f"\\textit{{{_latex_label(row.label)}}}", row, [col[i] for col in reference_cells],
                                  [False] * len(columns), study) for i, row in enumerate(table.references)]
            slug = re.sub(r"[^a-z0-9]+", "-", group.lower()).strip("-")
            parts += [
                r"\begin{table}[t]", r"\centering",
                f"\\caption{{BlendVOCA benchmark, {_latex_escape(group)} metrics, {_latex_escape(_caption(table))}. "
                "Mean [95\\,\\% bootstrap interval]; seeds [lowest, highest per-seed mean] for rows trained with "
                "several seeds; bold: best, beats the runner-up in at least 95\\,\\% of the paired resamples."
                + "".join(f" {_latex_escape(note)}" for note in _latent_notes(table, group)) + "}",
                f"\\label{{tab:blendvoca-{table.recipe_id[:12]}-{slug}}}",
                r"\resizebox{\linewidth}{!}{%",
                f"\\begin{{tabular}}{{l{'r' * len(columns)}rr{'l' if study else ''}}}", r"\toprule",
                " & ".join(header) + r" \\", r"\midrule", *body, r"\bottomrule", r"\end{tabular}}",
                *_tex_notes(group_notes(table, columns, marks, lambda name: str(name).replace("`", "'"))
                            + lookahead_notes(table, lambda name: str(name).replace("`", "'"))
                            + ([HUMAN_PREFERENCE_NOTE] if study else [])),
                r"\end{table}", "",
            ]
    if not tables:
        parts.append("% No results yet.")
    return "\n".join(parts) + "\n"
