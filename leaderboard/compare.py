"""Do two boards order the same rows the same way? Per metric, one board's order against another's.

``python -m leaderboard.compare [--results DIR] [--sections A,B] [--page PAGE]``: for the two
sections of the tables (two datasets, e.g. the synthetic board and the real FACEGOOD one;
named by dataset name or a recipe-id prefix, default: the only two there are) and every
ranked metric both have, the rows both boards scored (the methods, and the reference rows
but the ground truth: mean, static, random are orders a reader uses as floors) in each
board's order, Kendall's tau between the two orders (:func:`scipy.stats.kendalltau`, tau-b),
and the pairs whose order flips, each with whether the board's paired resampling decides it
(:func:`leaderboard.collect.pairwise_probabilities`: the better row wins at least
:data:`~leaderboard.collect.BEST_PROBABILITY` of the resamples). A flip decided on both
boards is a disagreement; one decided on one board only, or on neither, is not evidence
either way. ``--page`` writes the comparison as a Markdown page (docs/results/).
"""

from __future__ import annotations

import datetime
import math
import shlex
import sys
from dataclasses import dataclass
from pathlib import Path

from scipy.stats import kendalltau

from blendvoca import cli
from blendvoca.errors import UserError

from .collect import BEST_PROBABILITY, DEFAULT_RESULTS_DIR, Table, load_results, pairwise_probabilities, tables_by_manifest

__all__ = ["MetricComparison", "PairFlip", "compared_metrics", "comparison_page", "main", "section_by_key"]

#: Reference rows left out of the comparison: the ground truth is first by construction on the rig-space metrics.
LEFT_OUT = ("ground-truth", "ground truth")


@dataclass(frozen=True)
class PairFlip:
    """Two rows whose order differs between the boards: ``first`` is better on board A.

    ``probability_a`` / ``probability_b``: the fraction of paired resamples in which
    ``first`` beats ``second`` on each board (None: nothing to resample)."""

    first: str
    second: str
    probability_a: float | None
    probability_b: float | None

    def decided_a(self) -> bool:
        return self.probability_a is not None and self.probability_a >= BEST_PROBABILITY

    def decided_b(self) -> bool:
        return self.probability_b is not None and self.probability_b <= 1.0 - BEST_PROBABILITY


@dataclass(frozen=True)
class MetricComparison:
    """One metric on both boards: the common rows best first on each, tau and the flipped pairs."""

    metric: str
    label: str
    order_a: tuple
    order_b: tuple
    tau: float | None
    flips: tuple

    @property
    def decided_flips(self) -> list:
        """The flips the resampling decides on both boards: the orders that disagree."""
        return [f for f in self.flips if f.decided_a() and f.decided_b()]


def section_by_key(tables: list, key: str) -> Table:
    """The table whose dataset name (case-insensitive) or recipe id (a prefix of 6 or more
    characters) is ``key``; UserError naming the sections there are when none or several match."""
    wanted = key.strip().lower()
    found = [t for t in tables if (t.name and t.name.lower() == wanted)
             or (len(wanted) >= 6 and t.recipe_id.lower().startswith(wanted))]
    if len(found) != 1:
        there = ", ".join(f"{t.name or '(unnamed)'} ({t.recipe_id[:12]})" for t in tables) or "none"
        raise UserError(f"--sections {key}: expected one section's dataset name or recipe-id prefix "
                         f"(6+ characters), {'several match' if found else 'none matches'}; the sections: {there}")
    return found[0]


def _compared_rows(table: Table, labels: set) -> list:
    return [r for r in table.rows + table.references if r.label in labels]


def _labels(table: Table) -> set:
    return {r.label for r in table.rows} | {r.label for r in table.references if r.label not in LEFT_OUT}


def compared_metrics(a: Table, b: Table) -> list[MetricComparison]:
    """Per ranked metric of both tables (a's column order), the comparison of the rows both scored."""
    common = _labels(a) & _labels(b)
    columns_b = {c.name: c for c in b.columns}
    out = []
    for column in a.columns:
        if column.higher_is_better is None or column.name not in columns_b:
            continue
        rows_a = [r for r in _compared_rows(a, common) if column.name in r.metrics]
        rows_b = {r.label: r for r in _compared_rows(b, common) if column.name in r.metrics}
        rows_a = [r for r in rows_a if r.label in rows_b]
        if len(rows_a) < 2:
            continue
        rows_b = [rows_b[r.label] for r in rows_a]  # the same row order on both boards
        sign = -1.0 if column.higher_is_better else 1.0
        means_a = [sign * r.metrics[column.name][0] for r in rows_a]
        means_b = [sign * r.metrics[column.name][0] for r in rows_b]
        tau = kendalltau(means_a, means_b).statistic
        probs_a = pairwise_probabilities(rows_a, column)
        probs_b = pairwise_probabilities(rows_b, columns_b[column.name])
        flips = []
        for i in range(len(rows_a)):
            for j in range(len(rows_a)):
                if means_a[i] < means_a[j] and means_b[i] > means_b[j]:  # i better on a, worse on b
                    flips.append(PairFlip(rows_a[i].label, rows_a[j].label, probs_a[i][j], probs_b[i][j]))
        order = lambda rows, means: tuple(r.label for _, r in sorted(zip(means, rows), key=lambda t: t[0]))
        out.append(MetricComparison(column.name, column.label, order(rows_a, means_a), order(rows_b, means_b),
                                    None if math.isnan(tau) else float(tau), tuple(flips)))
    return out


def _probability(p) -> str:
    return "–" if p is None else f"{p:.2f}"


def comparison_page(a: Table, b: Table, names: tuple, command: str) -> str:
    """The comparison of ``a`` and ``b`` as a Markdown page (``names``: how the page calls the two boards)."""
    today = datetime.date.today().isoformat()
    rows = compared_metrics(a, b)
    recorded = f"Recorded {today} by `{command}` from the result files (no scoring)."
    lines = [f"# The {names[0]} board against the {names[1]} board", "", "## Orders per metric", "",
             f"{recorded} "
             f"Sections: {names[0]} `{a.recipe_id[:12]}` ({a.num_sentences} {a.split} sentences), "
             f"{names[1]} `{b.recipe_id[:12]}` ({b.num_sentences} {b.split} sentences).", "",
             "Rows: those both boards scored, the ground truth left out (first by construction on the rig-space "
             "metrics). Order: best first by the row's mean. τ: Kendall's tau-b between the two orders (1: the "
             "same order, -1: reversed). A flip is a pair ordered one way on one board and the other way on the "
             f"other; it is *decided* on a board when that board's paired resampling puts the better row ahead in "
             f"at least {BEST_PROBABILITY:.0%} of the resamples. Only a flip decided on both boards is a "
             "disagreement.", "",
             f"| Metric | {names[0]} order | {names[1]} order | τ | Flips | Decided on both |",
             "|:---|:---|:---|---:|---:|---:|"]
    for m in rows:
        tau = "–" if m.tau is None else f"{m.tau:.2f}"
        lines.append(f"| {m.label} | {', '.join(m.order_a)} | {', '.join(m.order_b)} | {tau} | {len(m.flips)} | "
                     f"{len(m.decided_flips)} |")
    decided = [(m, f) for m in rows for f in m.decided_flips]
    lines += ["", "## The decided disagreements", "", f"{recorded} The flips above that both boards decide, with "
              "each board's probability that its better row is ahead.", ""]
    if not decided:
        lines.append("None: every flipped pair is undecided on at least one board.")
    else:
        lines += [f"| Metric | Better on {names[0]} | Better on {names[1]} | P ({names[0]}) | P ({names[1]}) |",
                  "|:---|:---|:---|---:|---:|"]
        lines += [f"| {m.label} | {f.first} | {f.second} | {_probability(f.probability_a)} | "
                  f"{_probability(None if f.probability_b is None else 1.0 - f.probability_b)} |" for m, f in decided]
    return "\n".join(lines) + "\n"


@cli.command
def main(argv=None) -> int:
    parser = cli.parser("leaderboard.compare", __doc__.split("\n\n")[0])
    cli.add_results_option(parser, default=str(DEFAULT_RESULTS_DIR),
                           help="directory of result JSON files (default: the committed leaderboard/results)")
    parser.add_argument("--sections", help="the two sections A,B to compare: dataset names or recipe-id prefixes "
                                           "(default: the only two sections there are)")
    parser.add_argument("--names", default="", help="what the page calls the two boards, A,B (default: the sections' "
                                                    "dataset names)")
    parser.add_argument("--page", help="write the comparison here (Markdown) instead of printing it")
    args = parser.parse_args(argv)
    tables = tables_by_manifest(load_results(args.results))
    if args.sections:
        keys = [k for k in args.sections.split(",") if k.strip()]
        if len(keys) != 2:
            raise UserError(f"--sections {args.sections}: expected two sections A,B, got {len(keys)}")
        a, b = (section_by_key(tables, k) for k in keys)
    elif len(tables) == 2:
        a, b = tables
    else:
        raise UserError(f"--sections: the results hold {len(tables)} section(s); name the two to compare")
    if args.names and not args.sections:
        raise UserError("--names: name the sections too (--sections A,B), so that each name goes to its board")
    names = tuple(n.strip() for n in args.names.split(",")) if args.names else (a.name or "first", b.name or "second")
    if len(names) != 2:
        raise UserError(f"--names {args.names}: expected two names A,B")
    command = " ".join(["python -m leaderboard.compare", *map(shlex.quote, sys.argv[1:] if argv is None else argv)])
    text = comparison_page(a, b, names, command)
    if args.page:
        from blendvoca.io.atomic import atomic_write

        with atomic_write(Path(args.page), "w", encoding="utf-8") as handle:
            handle.write(text)
        print(args.page)
    else:
        print(text, end="")
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
