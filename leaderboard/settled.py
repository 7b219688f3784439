"""Settled by ranking: would a row's half-budget values change what the table says?

A trained row records its learning curve (:mod:`benchmark.protocol.convergence`): the
check metrics (``lve_rig``, ``fd``) at a quarter and half of its step budget, with the
per-sentence values and bootstrap replicates the paired resampling reads. A row is *not
settled on a metric* when its values at the half budget, put in place of its full-budget
ones, would change a statement the table makes about it in that metric's column:

- an order between it and another ranked row that the paired resampling decides (the
  row beats the other, or loses to it, in at least :data:`~leaderboard.collect.BEST_PROBABILITY`
  of the paired resamples; or neither): :func:`~leaderboard.collect.pair_replicates`;
- the column's bold mark (:func:`~leaderboard.collect.best_mark`);
- its side of a reference row (better or worse than the ground truth, an oracle, the mean ...).

A move larger than the interval's half-width that changes none of these leaves the row
settled (the move and half-width stay in the record as information). The table decides,
as the statements are the table's: :func:`changed_statements` is called when the table is
built from all rows (:func:`leaderboard.collect.tables_by_manifest`).

What the substitution reads, per training seed: the checkpoint's per-sentence values and
replicates when the record keeps them (exact); files that keep only the half-budget mean
(before the learning curve, protocol v3) have their per-sentence values and replicates
shifted by the seed's move (half minus full budget), a location shift that keeps each
sentence's deviation; and where nothing was resampled at all, orders are read from the
value against the other row's 95 % interval (the tables' older rule). The tables' note
says which.

For a row that is not settled, :func:`needed_budget` extrapolates the learning curve to
the budget at which its half-budget values would no longer cross any statement's
threshold (:func:`statement_thresholds`), or says that the curve is not monotone.
``python -m leaderboard.settled --page docs/results/settled-by-ranking.md`` writes that
judgement for the committed rows; ``--store`` writes each row's statements into its
result's ``convergence.statements`` (the Interface's record; outside the record digest).
"""

from __future__ import annotations

import dataclasses
import datetime
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchmark.evaluation.registry import METRICS
from benchmark.metrics.bootstrap import probability_of_improvement
from blendvoca import cli

from .collect import BEST_PROBABILITY, Row, best_mark, pair_replicates, tables_by_manifest

__all__ = ["BudgetNeed", "Statement", "changed_statements", "half_budget_row", "main", "needed_budget",
           "order_verdict", "settled_page", "statement_thresholds", "store_statements", "tables_with_statements"]

#: The verdict words of an order: the row beats the other, loses to it, or neither is decided.
_VERDICTS = {1: ("beat", "beats"), -1: ("lose to", "loses to"), 0: ("tie with", "ties with")}


def order_verdict(probability: float) -> int:
    """+1 when the row beats the other in at least :data:`BEST_PROBABILITY` of the paired
    resamples, -1 when the other beats it that often, 0 when the order is not decided."""
    if probability >= BEST_PROBABILITY:
        return 1
    return -1 if probability <= 1.0 - BEST_PROBABILITY else 0


def _interval_verdict(value: float, interval, higher_is_better: bool) -> int:
    """The older rule, where nothing is resampled: +1 when ``value`` is better than the
    whole of the other row's 95 % ``interval``, -1 when worse, 0 inside it."""
    lo, hi = float(interval[0]), float(interval[1])
    if higher_is_better:
        return 1 if value > hi else (-1 if value < lo else 0)
    return 1 if value < lo else (-1 if value > hi else 0)


@dataclass(frozen=True)
class Statement:
    """One statement of the table that a row's half-budget values would change.

    Attributes
    ----------
    row, metric : str
        The row's label and the metric (a column of the table).
    kind : str
        ``"order"`` (a paired order against ``other``), ``"bold"`` (the column's bold mark),
        ``"reference"`` (its side of the reference row ``other``) or ``"shared"`` (a row
        scoring ``other``'s training, which is not settled).
    other : str or None
        The other row (the bold: the row bold now, None when none is).
    now, at_half
        The verdict at the full budget and with the half-budget values: an order's +1 / -1 /
        0 (:func:`order_verdict`), a reference side's +1 (better) / -1 (worse), the bold's
        label of the bold row (None: none).
    probability : float or None
        An order's probability that the row beats ``other`` at the full budget (None under
        the interval rule).
    full_value, half_value : float or None
        The row's value at the full and at the half budget.
    step, total_steps : int or None
        The half-budget checkpoint and the full budget.
    exact : bool
        The checkpoint's own per-sentence values / replicates were resampled (False: shifted
        by the move, or the interval rule).
    """

    row: str
    metric: str
    kind: str
    other: str | None = None
    now: object = None
    at_half: object = None
    probability: float | None = None
    full_value: float | None = None
    half_value: float | None = None
    step: int | None = None
    total_steps: int | None = None
    exact: bool = True

    def change_text(self, label=str) -> str:
        """What would change, in words (``would tie with X (now beats it, P = 0.98)``)."""
        if self.kind == "shared":
            return f"row {label(self.other)}'s training, not settled there"
        if self.kind == "order":
            other = label(self.other)
            if self.at_half == 0:
                change = f"would no longer {_VERDICTS[self.now][0]} {other}"
            else:
                change = f"would {_VERDICTS[self.at_half][0]} {other}"
            if self.probability is None:
                now = {1: "beats it", -1: "loses to it", 0: "undecided"}[self.now] + ", by the 95 % intervals"
            elif self.now == 0:
                now = f"undecided: it beats {other} in {100 * self.probability:.0f} % of the resamples"
            else:
                now = f"{_VERDICTS[self.now][1]} it, P = {self.probability if self.now > 0 else 1 - self.probability:.2f}"
            return f"{change} (now {now})"
        if self.kind == "reference":
            side = {1: "better than", -1: "worse than", 0: "level with"}
            return (f"would be {side[self.at_half]} {label(self.other)} "
                    f"(now {side[self.now].split()[0]})")
        now = "no row is" if self.now is None else f"{label(self.now)} is"
        if self.at_half is None:
            return f"would leave no row bold (now {now})"
        return f"would make {label(self.at_half)} bold (now {now})"

    def text(self, label=str) -> str:
        """The statement as the tables' note and ``convergence.statements`` say it."""
        if self.kind == "shared":
            return f"{label(self.row)}: {self.change_text(label)}"
        name = METRICS[self.metric].label if self.metric in METRICS else self.metric
        shifted = "" if self.exact else " (resamples shifted by the move)"
        return f"{label(self.row)}: at step {self.step} of {self.total_steps}{shifted}, {name} " \
               f"{self.half_value:.3g} (now {self.full_value:.3g}) {self.change_text(label)}"


# --- the half-budget row ------------------------------------------------------------------


def _point(convergence, step):
    """The curve point of ``convergence`` at ``step``, or None."""
    for point in (convergence.curve if convergence is not None else None) or ():
        if point.step == step:
            return point
    return None


def _with_values(rows, name: str, value_of) -> tuple:
    """Per-sentence rows with ``name`` replaced by ``value_of(subject, sentence, value)``
    (dropped where that is None)."""
    out = []
    for row in rows or ():
        row = dict(row)
        nested = isinstance(row.get("metrics"), dict)
        target = dict(row["metrics"]) if nested else row
        value = value_of(row["subject"], row["sentence"], target.get(name))
        if value is None:
            target.pop(name, None)
        else:
            target[name] = float(value)
        if nested:
            row["metrics"] = target
        out.append(row)
    return tuple(out)


def _substituted(rows, replicates, convergence, name: str, sentence_level: bool):
    """``(rows, replicates, exact)`` of one training seed (or a one-seed result) with
    ``name`` at the half-budget checkpoint of ``convergence``; None when its record
    holds nothing to put in place of them."""
    if convergence is None or not convergence.metrics or name not in convergence.metrics:
        return None
    check = convergence.metrics[name]
    point = _point(convergence, convergence.checked_at_step)
    if sentence_level:
        if point is not None and point.per_sentence and name in point.per_sentence and convergence.sentences:
            values = dict(zip(convergence.sentences, point.per_sentence[name]))
            return _with_values(rows, name, lambda s, t, _v: values.get((s, t))), replicates, True
        if check.half_budget is None or check.full_budget is None:
            return None
        delta = check.half_budget - check.full_budget
        return _with_values(rows, name, lambda s, t, v: None if v is None else v + delta), replicates, False
    reps = dict(replicates or {})
    if point is not None and point.replicates and name in point.replicates:
        reps[name] = list(point.replicates[name])
        return rows, reps, True
    if name not in reps or check.half_budget is None or check.full_budget is None:
        return None
    reps[name] = list(np.asarray(reps[name], dtype=float) + (check.half_budget - check.full_budget))
    return rows, reps, False


def half_budget_row(row: Row, name: str):
    """``(row, exact)``: ``row`` with its values of ``name`` at its half-budget checkpoint in
    place of the full-budget ones (its mean, interval shifted by the move, per-sentence values
    and replicates of each training seed); None when its record has no half-budget value.

    ``exact`` is True when every seed's checkpoint kept its own per-sentence values or
    replicates, False when some were shifted by the move (files before the learning curve)."""
    convergence = row.convergence
    if convergence is None or convergence.shared_with or name not in (convergence.metrics or {}) \
            or name not in row.metrics:
        return None
    check = convergence.metrics[name]
    if check.half_budget is None or check.full_budget is None:
        return None
    delta = float(check.half_budget) - float(check.full_budget)
    mean, std, ci = row.metrics[name]
    metrics = {**row.metrics, name: (float(mean) + delta, std,
                                     None if ci is None else [float(ci[0]) + delta, float(ci[1]) + delta])}
    result, exact = row.result, True
    if result is not None:
        info = METRICS.get(name)
        sentence_level = info is None or info.level == "sentence"
        per_seed = list(result.per_seed or ())
        if per_seed:
            seeds = []
            for record in per_seed:
                done = _substituted(record.per_sentence, record.replicates, record.convergence, name, sentence_level)
                if done is None:  # this seed's record holds no checkpoint of its own: the row's move
                    done = _substituted(record.per_sentence, record.replicates, convergence, name, sentence_level)
                    done = None if done is None else (done[0], done[1], False)
                if done is None:
                    seeds.append(record)
                    exact = False
                    continue
                rows, reps, seed_exact = done
                exact &= seed_exact
                seeds.append(dataclasses.replace(record, per_sentence=rows, replicates=reps))
            result = dataclasses.replace(result, per_seed=tuple(seeds))
        else:
            own = {name: list(result.metrics[name].replicates)} if result.metrics[name].replicates else {}
            done = _substituted(result.per_sentence, own, convergence, name, sentence_level)
            if done is not None:
                rows, reps, exact = done
                entry = result.metrics[name]
                if name in reps and entry.replicates is not None:
                    entry = dataclasses.replace(entry, replicates=tuple(reps[name]))
                result = dataclasses.replace(result, per_sentence=rows, metrics={**result.metrics, name: entry})
            else:
                exact = False
        if per_seed and not sentence_level and result.metrics[name].replicates is not None:
            # the row's own two-level replicates: read only when some seed lacks its own
            entry = result.metrics[name]
            shifted = tuple(np.asarray(entry.replicates, dtype=float) + delta)
            result = dataclasses.replace(result, metrics={**result.metrics,
                                                          name: dataclasses.replace(entry, replicates=shifted)})
    return dataclasses.replace(row, metrics=metrics, result=result), exact


# --- the statements -----------------------------------------------------------------------


def _order(a: Row, b: Row, column, streams):
    """(verdict of ``a`` against ``b``, probability or None): the paired resampling, else the
    value of ``a`` against ``b``'s interval; None when neither can be read."""
    pair = pair_replicates(a, b, column.name, streams=streams)
    if pair is not None:
        p = probability_of_improvement(*pair, higher_is_better=column.higher_is_better)
        return order_verdict(p), p
    ci = b.metrics[column.name][2]
    if ci is None:
        return None
    return _interval_verdict(a.metrics[column.name][0], ci, column.higher_is_better), None


def _side(value: float, reference: float, higher_is_better: bool) -> int:
    if value == reference:
        return 0
    return 1 if (value > reference) == bool(higher_is_better) else -1


def row_statements(table, index: int, column) -> list:
    """The statements of ``column`` that row ``table.rows[index]``'s half-budget values
    would change (:class:`Statement`); empty when none would, or the row has no half-budget
    value of the column's metric."""
    row = table.rows[index]
    if column.higher_is_better is None or column.name not in row.metrics:
        return []
    substituted = half_budget_row(row, column.name)
    if substituted is None:
        return []
    half, exact = substituted
    conv = row.convergence
    common = dict(row=row.label, metric=column.name, full_value=float(row.metrics[column.name][0]),
                  half_value=float(half.metrics[column.name][0]), step=conv.checked_at_step,
                  total_steps=conv.total_steps)
    out = []
    rows_half = list(table.rows)
    rows_half[index] = half
    now, then = best_mark(table.rows, column), best_mark(rows_half, column)
    if set(now.rows) != set(then.rows):
        who = (lambda mark, rows: rows[next(iter(mark.rows))].label if mark.rows else None)
        out.append(Statement(kind="bold", now=who(now, table.rows), at_half=who(then, rows_half),
                             exact=exact and now.rule != "intervals", **common))
    for j, other in enumerate(table.rows):
        if j == index or column.name not in other.metrics:
            continue
        full, at_half = _order(row, other, column, (index, j)), _order(half, other, column, (index, j))
        if full is None or at_half is None or full[0] == at_half[0]:
            continue
        out.append(Statement(kind="order", other=other.label, now=full[0], at_half=at_half[0],
                             probability=full[1], exact=exact and full[1] is not None, **common))
    for reference in table.references:
        if column.name not in reference.metrics:
            continue
        value = float(reference.metrics[column.name][0])
        now_side = _side(common["full_value"], value, column.higher_is_better)
        half_side = _side(common["half_value"], value, column.higher_is_better)
        if now_side != half_side:
            out.append(Statement(kind="reference", other=reference.label, now=now_side, at_half=half_side,
                                 **common))
    return out


def tables_with_statements(results: list) -> list:
    """The tables of ``results`` (:func:`leaderboard.collect.tables_by_manifest`), each ranked
    row's ``statements`` filled by :func:`changed_statements`: what the tables, the site and
    ``--store`` read the settled mark from."""
    tables = tables_by_manifest(results)
    for table in tables:
        for row_label, statements in changed_statements(table).items():
            next(r for r in table.rows if r.label == row_label).statements = statements
    return tables


def changed_statements(table) -> dict:
    """``{row label: [Statement]}`` for every ranked row of ``table`` that has a half-budget
    record (an empty list: settled by ranking), in the table's column order. A row that
    scores another row's training (``convergence.shared_with``) carries one ``"shared"``
    statement when that row is not settled, none when it is; rows without a record of
    their own and without a judged owner are left out (their record's verdict stands)."""
    out = {}
    for index, row in enumerate(table.rows):
        conv = row.convergence
        if conv is None or conv.shared_with or not conv.metrics:
            continue
        out[row.label] = [s for column in table.columns for s in row_statements(table, index, column)]
    for row in table.rows:
        conv = row.convergence
        if conv is not None and conv.shared_with and conv.shared_with in out:
            owner = out[conv.shared_with]
            out[row.label] = [Statement(row=row.label, metric="", kind="shared", other=conv.shared_with)] \
                if owner else []
    return out


# --- what budget a row would need -----------------------------------------------------------


@dataclass(frozen=True)
class BudgetNeed:
    """:func:`needed_budget`'s judgement of one learning curve.

    Attributes
    ----------
    verdict : str
        ``"settled"`` (from the half budget on the curve crosses no threshold),
        ``"budget"`` (``multiple`` of the current budget would settle it),
        ``"not monotone"``, ``"not flattening"`` (the moves do not shrink: no limit to
        extrapolate to), or ``"too few points"``.
    multiple : float or None
        The budget that would settle the row, as a multiple of the current one.
    limit : float or None
        The value the fitted curve tends to.
    exponent : float or None
        ``c`` of the fitted ``a + b * steps**-c``.
    assumed : bool
        Two points only: the exponent was assumed (1), not fitted.
    """

    verdict: str
    multiple: float | None = None
    limit: float | None = None
    exponent: float | None = None
    assumed: bool = False

    def text(self) -> str:
        if self.verdict == "budget":
            fit = "two points: a 1/steps trend assumed" if self.assumed else f"trend a + b·steps^-{self.exponent:.2g}"
            return f"about {self.multiple:.3g}x its budget ({fit}; tending to {self.limit:.3g})"
        if self.verdict == "settled":
            return "settled from its half budget on, by its curve's trend"
        if self.verdict == "not monotone":
            return "the curve is not monotone: no budget can be read from it"
        if self.verdict == "not flattening":
            return "the curve does not flatten (its moves do not shrink): no budget can be read from it"
        return "too few points on the curve"


def _fit_exponent(steps, values) -> float | None:
    """``c`` of ``a + b * s**-c`` through three points (s increasing, values monotone with
    shrinking moves); None when the moves do not shrink."""
    from scipy.optimize import brentq

    (s1, s2, s3), (v1, v2, v3) = steps, values
    ratio = (v2 - v3) / (v1 - v2)  # in (0, 1) for a decelerating monotone curve

    def gap(c):
        return (s2 ** -c - s3 ** -c) / (s1 ** -c - s2 ** -c) - ratio

    lo, hi = 1e-6, 50.0
    if not (gap(lo) > 0 > gap(hi)):  # at c -> 0 the ratio is log(s3/s2)/log(s2/s1)
        return None
    return float(brentq(gap, lo, hi))


def needed_budget(steps, values, thresholds) -> BudgetNeed:
    """The budget at which a row's half-budget value would cross no threshold, from its curve.

    The curve ``values`` at ``steps`` (increasing, the last the full budget) is fitted by
    ``v(s) = a + b * s**-c`` through its last three points (with two, ``c = 1`` is
    assumed), the power-law decay of a training loss. A statement changes when the row's
    value crosses its ``threshold`` (:func:`statement_thresholds`); from the half budget on,
    the curve still crosses every threshold between ``v(s_half)`` and the limit ``a``; once
    the last of them is crossed (at ``s*``) a budget of ``2 s*`` has its half past every
    one: that budget settles the row (as a multiple of the current one).

    Parameters
    ----------
    steps : sequence of float
    values : sequence of float
    thresholds : iterable of float

    Returns
    -------
    BudgetNeed
    """
    steps = [float(s) for s in steps]
    values = [float(v) for v in values]
    if len(steps) != len(values) or len(steps) < 2:
        return BudgetNeed("too few points")
    if any(b <= a for a, b in zip(steps, steps[1:])):
        raise ValueError(f"needed_budget: expected increasing steps, got {steps}")
    moves = np.diff(values)
    if np.any(moves > 0) and np.any(moves < 0):
        return BudgetNeed("not monotone")
    total = steps[-1]
    half = total / 2.0
    if len(steps) >= 3:
        s, v = steps[-3:], values[-3:]
        if v[0] == v[1] or v[1] == v[2]:
            return BudgetNeed("not flattening" if v[0] == v[1] != v[2] else "settled")
        c = _fit_exponent(s, v)
        if c is None:
            return BudgetNeed("not flattening")
        assumed = False
    else:
        s, v, c, assumed = steps[-2:], values[-2:], 1.0, True
        if v[0] == v[1]:
            return BudgetNeed("settled", limit=v[1], exponent=c, assumed=True)
    b = (v[-2] - v[-1]) / (s[-2] ** -c - s[-1] ** -c)
    a = v[-1] - b * s[-1] ** -c
    at_half = a + b * half ** -c
    lo, hi = sorted((at_half, a))
    crossed = [float(t) for t in thresholds if lo < float(t) < hi]
    if not crossed:
        return BudgetNeed("settled", limit=a, exponent=c, assumed=assumed)
    # the last threshold the curve crosses (nearest its limit): b / (t - a) = s**c
    last = min(crossed, key=lambda t: abs(t - a))
    crossing = (b / (last - a)) ** (1.0 / c)
    return BudgetNeed("budget", multiple=2.0 * crossing / total, limit=a, exponent=c, assumed=assumed)


def statement_thresholds(table, index: int, column) -> list:
    """The values of row ``table.rows[index]``'s ``column.name`` at which a statement of the
    column would change, as if its resamples moved with its mean (a location shift): per
    other ranked row, its mean and the shifts at which the paired probability crosses 0.95
    and 0.05 (else its interval's ends); per reference row, its mean."""
    row = table.rows[index]
    if column.name not in row.metrics or column.higher_is_better is None:
        return []
    value = float(row.metrics[column.name][0])
    out = []
    for j, other in enumerate(table.rows):
        if j == index or column.name not in other.metrics:
            continue
        out.append(float(other.metrics[column.name][0]))
        pair = pair_replicates(row, other, column.name, streams=(index, j))
        if pair is not None:
            diff = np.asarray(pair[1], dtype=float) - np.asarray(pair[0], dtype=float)
            out += [value + float(q) for q in np.quantile(diff, [1.0 - BEST_PROBABILITY, BEST_PROBABILITY])]
        elif other.metrics[column.name][2] is not None:
            out += [float(x) for x in other.metrics[column.name][2]]
    out += [float(r.metrics[column.name][0]) for r in table.references if column.name in r.metrics]
    return out


def _curve(row: Row, name: str):
    """``(steps, values)`` of ``name`` on the row's learning curve, the full budget last
    (the half-budget value where the record holds no curve)."""
    conv = row.convergence
    check = conv.metrics[name]
    points = [(p.step, p.metrics[name]) for p in conv.curve or () if name in p.metrics]
    if not points and conv.checked_at_step is not None and check.half_budget is not None:
        points = [(conv.checked_at_step, check.half_budget)]
    return [s for s, _ in points] + [conv.total_steps], [v for _, v in points] + [check.full_budget]


# --- the record and the page ---------------------------------------------------------------


def store_statements(results_dir) -> list:
    """Write each ranked row's changed statements (:func:`changed_statements`, as
    :meth:`Statement.text` says them) into its result's ``convergence.statements``: the
    table's verdict, kept beside the row's curve (outside ``protocol.record_sha256``).

    Returns
    -------
    list of Path
        The files rewritten (a file whose statements are already those is left as it is).
    """
    from benchmark.results import check, write
    from .collect import load_results, result_files

    results_dir = Path(results_dir)
    paths = result_files(results_dir)
    results = load_results(results_dir)
    written = []
    for table in tables_with_statements(results):
        for row in table.rows:
            if row.statements is None or row.source is None:
                continue
            result = results[row.source]
            record = result.to_json()
            texts = [s.text() for s in row.statements]
            if record["convergence"].get("statements") == texts:
                continue
            record["convergence"] = {**record["convergence"], "statements": texts}
            write(paths[row.source], check(record))
            written.append(paths[row.source])
    return written


def settled_page(results_dir, command: str) -> str:
    """``docs/results/settled-by-ranking.md``: per ranked row with a half-budget record and
    per check metric, its curve, move and half-width, the statements that would change, and
    (rows not settled) the budget its curve says it would need (:func:`needed_budget`)."""
    from .collect import load_results

    today = datetime.date.today().isoformat()
    lines = ["# Settled by ranking: the committed rows", "",
             f"Made by `{command}` (no training: read from the result files). The rule: "
             "[leaderboard.md](../leaderboard.md#reading-the-tables), \"Reading the tables\"; "
             "[methods.md](../methods.md#settled-or-not-the-learning-curve), \"Settled or not\".", "",
             "A row is not settled on a metric when its half-budget values, put in place of its full-budget "
             "ones, would change a statement of the table (a resampled order against another ranked row, the "
             "bold, its side of a reference row). For such a row the budget it would need is read from its "
             "learning curve, `v(s) = a + b s^-c` through its last three points (two points: c = 1 assumed): "
             "the budget whose half lies past the last statement threshold the curve still crosses "
             "(`leaderboard.settled.needed_budget`). A threshold is a value of the row at which a statement would "
             "change were its resamples to move with its mean: another row's mean, the shifts at which the paired "
             "probability crosses 0.95 or 0.05 (else the other row's interval ends), a reference row's mean "
             "(`leaderboard.settled.statement_thresholds`).", ""]
    for table in tables_with_statements(load_results(results_dir)):
        lines += [f"## Dataset `{table.recipe_id[:12]}`", "",
                  f"Recorded {today} by `{command}` on the 2-core shared CPU machine, from the result files.", "",
                  "| Row | Metric | Curve (step: value) | Move / half-width | Statements that would change | "
                  "Budget it would need |", "|:---|:---|:---|:---|:---|:---|"]
        for index, row in enumerate(table.rows):
            conv = row.convergence
            if conv is None or row.statements is None:
                continue
            if conv.shared_with:
                lines.append(f"| {row.label} | – | row {conv.shared_with}'s training | – | "
                             f"{'not settled there' if row.statements else 'none'} | – |")
                continue
            for column in table.columns:
                if column.name not in (conv.metrics or {}):
                    continue
                check = conv.metrics[column.name]
                steps, values = _curve(row, column.name)
                curve = ", ".join(f"{s}: {v:.4g}" for s, v in zip(steps, values))
                move = abs(check.full_budget - check.half_budget)
                changed = [s for s in row.statements if s.metric == column.name]
                if changed:
                    need = needed_budget(steps, values, statement_thresholds(table, index, column)).text()
                else:
                    need = "settled"
                lines.append(f"| {row.label} | {column.label} | {curve} | {move:.3g} / {check.half_width:.3g} | "
                             f"{'; '.join(s.change_text() for s in changed) or 'none'} | {need} |")
        lines.append("")
    lines += ["Rows whose files keep no per-sentence values at the checkpoint (protocol v3, before the learning "
              "curve) are judged with their resamples shifted by their move (each sentence keeps its deviation "
              "from the seed's mean); their curves have two points, so their budgets assume a 1/steps trend.", ""]
    return "\n".join(lines)


@cli.command
def main(argv=None) -> int:
    from blendvoca.io.atomic import atomic_write

    from .collect import DEFAULT_RESULTS_DIR

    parser = cli.parser("leaderboard.settled", __doc__.split("\n\n")[0])
    cli.add_results_option(parser, default=str(DEFAULT_RESULTS_DIR),
                           help="directory of result JSON files (default: the committed leaderboard/results)")
    parser.add_argument("--page", help="write the settled-by-ranking page here (docs/results/settled-by-ranking.md)")
    parser.add_argument("--store", action="store_true",
                        help="write each row's changed statements into its result's convergence.statements")
    args = parser.parse_args(argv)
    if args.page:
        command = "python -m leaderboard.settled --page " + args.page
        text = settled_page(args.results, command)
        with atomic_write(Path(args.page), "w", encoding="utf-8") as handle:
            handle.write(text)
        print(args.page)
    if args.store:
        for path in store_statements(args.results):
            print(path)
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
