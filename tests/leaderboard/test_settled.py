"""Settled by ranking (leaderboard.settled): closed-form tables whose rows' half-budget
values cross, or do not cross, the statements the table makes; the budget a learning
curve needs; the curve fractions' validation; the statements stored in the result."""

import json

import numpy as np
import pytest

from benchmark.protocol.spec import checked_fractions
from benchmark.results import check, read
from leaderboard.collect import pair_replicates
from leaderboard.render import NOT_SETTLED_MARK
from leaderboard.settled import (
    BudgetNeed,
    changed_statements,
    half_budget_row,
    needed_budget,
    order_verdict,
    settled_page,
    store_statements,
)
from tests.leaderboard.test_build import SENTENCES, _entry, _rows, _section, _sentence_result, rendered_tables, \
    tables_by_manifest, write_result

BASE = np.linspace(1.0, 2.0, len(SENTENCES))  # mean 1.5
KEYS = [list(k) for k in SENTENCES]


def _curve_convergence(full, half, quarter=None, *, name="lve_rig", steps=(750, 1500)):
    """A convergence record with the learning curve's per-sentence values of ``name``."""
    full, half = np.asarray(full, float), np.asarray(half, float)
    points = [] if quarter is None else [{"step": steps[0] // 2, "metrics": {name: float(np.mean(quarter))},
                                          "per_sentence": {name: [float(v) for v in quarter]}}]
    points.append({"step": steps[0], "metrics": {name: float(half.mean())},
                   "per_sentence": {name: [float(v) for v in half]}})
    return {"checked_at_step": steps[0], "total_steps": steps[1], "settled": False, "sentences": KEYS,
            "curve": points,
            "metrics": {name: {"half_budget": float(half.mean()), "full_budget": float(full.mean()),
                               "half_width": 0.01, "settled": False}}}


def _table(results):
    (table,) = tables_by_manifest(results)
    return table


def _row(table, label):
    return next(r for r in table.rows if r.label == label)


def test_a_half_budget_value_crossing_another_row_changes_its_order_and_is_named():
    # "a" is better than "b" (BASE + 0.3) on every sentence at the full budget; at half budget it is
    # BASE + 0.6 (worse than b on every sentence): the order reverses, and the bold moves to b
    results = [_sentence_result("a", BASE, convergence=_curve_convergence(BASE, BASE + 0.6)),
               _sentence_result("b", BASE + 0.3)]
    table = _table(results)
    a = _row(table, "a")
    kinds = {(s.kind, s.other, s.now, s.at_half) for s in a.statements}
    assert kinds == {("bold", None, "a", "b"), ("order", "b", 1, -1)}
    assert all(s.exact for s in a.statements) and a.settled is False
    vertex = _section(rendered_tables(results)["leaderboard.md"], "Vertex")
    assert f"| a {NOT_SETTLED_MARK} | **1.50** " in vertex
    assert ("a: at step 750 of 1500, LVE rig 2.1 (now 1.5) would make b bold (now a is), would lose to b "
            "(now beats it, P = 1.00).") in vertex
    # the half-budget row is the row as a result holding the half-budget values would be
    half, exact = half_budget_row(a, "lve_rig")
    direct = _table([_sentence_result("a", BASE + 0.6), _sentence_result("b", BASE + 0.3)])
    assert exact and half.metrics["lve_rig"][0] == pytest.approx(2.1)
    got = pair_replicates(half, table.rows[1], "lve_rig", streams=(0, 1))
    want = pair_replicates(direct.rows[0], direct.rows[1], "lve_rig", streams=(0, 1))
    assert np.allclose(got[0], want[0]) and np.allclose(got[1], want[1])


def test_a_move_beyond_the_half_width_on_the_same_side_of_every_row_is_settled():
    # a moves 2.1 -> 1.5 (60 times its half-width of 0.01) and stays better than b (BASE + 1) on every sentence
    results = [_sentence_result("a", BASE, convergence=_curve_convergence(BASE, BASE + 0.6)),
               _sentence_result("b", BASE + 1.0),
               _sentence_result("ground-truth", BASE - 1.0, reference=True)]
    table = _table(results)
    a = _row(table, "a")
    assert a.convergence.settled is False and a.statements == [] and a.settled is True
    assert NOT_SETTLED_MARK not in _section(rendered_tables(results)["leaderboard.md"], "Vertex")
    assert changed_statements(table) == {"a": []}


def test_crossing_a_reference_row_is_a_changed_statement():
    # alone among the methods, "a" moves from better than the mean row (BASE + 0.3) to worse; it stays worse
    # than the ground truth (BASE - 1)
    results = [_sentence_result("a", BASE, convergence=_curve_convergence(BASE, BASE + 0.6)),
               _sentence_result("mean", BASE + 0.3, reference=True),
               _sentence_result("ground-truth", BASE - 1.0, reference=True)]
    a = _row(_table(results), "a")
    assert [(s.kind, s.other, s.now, s.at_half) for s in a.statements] == [("reference", "mean", 1, -1)]
    assert "LVE rig 2.1 (now 1.5) would be worse than mean (now better)." in rendered_tables(results)["leaderboard.md"]


def test_an_undecided_order_that_the_half_budget_would_decide_is_named():
    rng = np.random.default_rng(0)
    noise = rng.normal(0.0, 0.5, size=BASE.size)
    b = BASE + noise - noise.mean()  # b ties with a (mean 1.5, +-0.5 per sentence)
    results = [_sentence_result("a", BASE, convergence=_curve_convergence(BASE, BASE + 1.0)),
               _sentence_result("b", b)]
    statements = _row(_table(results), "a").statements
    order = next(s for s in statements if s.kind == "order")
    assert order.now == 0 and order.at_half == -1 and 0.05 < order.probability < 0.95
    assert order_verdict(0.95) == 1 and order_verdict(0.05) == -1 and order_verdict(0.5) == 0
    assert f"would lose to b (now undecided: it beats b in {100 * order.probability:.0f} % of the resamples)" \
        in order.change_text()


def test_a_multi_seed_row_puts_each_seeds_checkpoint_in_place_of_its_values():
    # two seeds; each seed's curve holds its own half-budget values: seed 0 crosses b, seed 1 does not.
    seeds_full = [BASE, BASE + 0.02]
    seeds_half = [BASE + 1.0, BASE + 0.02]  # the seed mean moves by 0.5: a then loses to b in half the seed draws
    result = _sentence_result("a", np.mean(seeds_full, axis=0))
    result["seeds"] = [0, 1]
    result["per_seed"] = [{"seed": k, "metrics": {"lve_rig": float(full.mean())}, "per_sentence": _rows(full, "lve_rig"),
                           "convergence": _curve_convergence(full, half)}
                          for k, (full, half) in enumerate(zip(seeds_full, seeds_half))]
    result["convergence"] = _curve_convergence(np.mean(seeds_full, axis=0), np.mean(seeds_half, axis=0))
    del result["convergence"]["curve"], result["convergence"]["sentences"]  # the row's: seed means only
    b = _sentence_result("b", BASE + 0.3)
    table = _table([result, b])
    a = _row(table, "a")
    half, exact = half_budget_row(a, "lve_rig")
    assert exact and half.metrics["lve_rig"][0] == pytest.approx(np.mean(seeds_half))
    # each seed's values are its checkpoint's, not the row's move spread over both
    got = [[r["lve_rig"] for r in seed.per_sentence] for seed in half.result.per_seed]
    assert np.allclose(got, seeds_half)
    order = next(s for s in a.statements if s.kind == "order")
    assert (order.now, order.at_half) == (1, 0) and order.probability == 1.0  # beats b now; undecided at half
    # a file without the seeds' curves (protocol v3) shifts each seed by its own move: the same values here,
    # as each seed's half-budget values are its full-budget ones plus a constant
    for seed, half_values in zip(result["per_seed"], seeds_half):
        seed["convergence"] = {"checked_at_step": 750, "total_steps": 1500, "settled": False,
                               "metrics": {"lve_rig": {"half_budget": float(half_values.mean()),
                                                       "full_budget": seed["metrics"]["lve_rig"],
                                                       "half_width": 0.01, "settled": False}}}
    shifted, exact = half_budget_row(_row(_table([result, b]), "a"), "lve_rig")
    assert not exact
    assert np.allclose([[r["lve_rig"] for r in s.per_sentence] for s in shifted.result.per_seed], seeds_half)


def test_set_level_metrics_use_the_checkpoints_replicates():
    reps_full, reps_half = np.linspace(9.0, 11.0, 50), np.linspace(15.0, 17.0, 50)

    def fd_result(label, reps, **extra):
        result = _sentence_result(label, BASE, **extra)
        result["metrics"]["fd"] = {"mean": float(reps.mean()), "std": None, "higher_is_better": False,
                                   "unit": "latent^2", "ci95": [float(reps.min()), float(reps.max())],
                                   "n": len(SENTENCES), "replicates": [float(v) for v in reps]}
        return result

    convergence = {"checked_at_step": 5, "total_steps": 10, "settled": False,
                   "curve": [{"step": 5, "metrics": {"fd": 16.0}, "replicates": {"fd": list(reps_half)}}],
                   "metrics": {"fd": {"half_budget": 16.0, "full_budget": 10.0, "half_width": 1.0,
                                      "settled": False}}}
    results = [fd_result("a", reps_full, convergence=convergence), fd_result("b", reps_full + 3.0)]
    a = _row(_table(results), "a")
    order = next(s for s in a.statements if s.kind == "order")
    assert (order.now, order.at_half, order.exact) == (1, -1, True)


def test_needed_budget_recovers_the_power_law_of_a_synthetic_curve():
    a, b, c = 2.0, 400.0, 1.0  # v(s) = 2 + 400 / s
    steps = [250, 500, 1000]
    values = [a + b * s ** -c for s in steps]  # 3.6, 2.8, 2.4
    # a threshold at 2.1 is crossed at s* = 400 / 0.1 = 4000: a budget of 8000 (8x) has its half past it
    need = needed_budget(steps, values, [2.1, 5.0, 1.0])
    assert need.verdict == "budget" and need.multiple == pytest.approx(8.0, rel=1e-6)
    assert need.limit == pytest.approx(a) and need.exponent == pytest.approx(c, rel=1e-6)
    # thresholds the curve never reaches (below its limit) or has passed by half its budget: settled
    assert needed_budget(steps, values, [1.9, 3.0]).verdict == "settled"
    # another exponent: v(s) = 1 + 64 / sqrt(s); threshold 1.5 is crossed at s* = (64 / 0.5)^2 = 16384
    values = [1.0 + 64.0 * s ** -0.5 for s in steps]
    need = needed_budget(steps, values, [1.5])
    assert need.exponent == pytest.approx(0.5, rel=1e-6) and need.multiple == pytest.approx(2 * 16384 / 1000, rel=1e-6)
    # two points: c = 1 assumed, and said so
    need = needed_budget([500, 1000], [2.8, 2.4], [2.1])
    assert need.assumed and need.multiple == pytest.approx(8.0) and "a 1/steps trend assumed" in need.text()


def test_needed_budget_refuses_curves_it_cannot_extrapolate():
    assert needed_budget([250, 500, 1000], [3.0, 2.0, 2.5], [2.2]).verdict == "not monotone"
    assert "not monotone" in needed_budget([250, 500, 1000], [3.0, 2.0, 2.5], [2.2]).text()
    # moves that grow (1, then 2): no limit to tend to
    assert needed_budget([250, 500, 1000], [4.0, 3.0, 1.0], [0.5]).verdict == "not flattening"
    assert needed_budget([1000], [2.0], []) == BudgetNeed("too few points")
    with pytest.raises(ValueError, match="increasing steps"):
        needed_budget([500, 250, 1000], [3.0, 2.0, 1.5], [])


@pytest.mark.parametrize("value, message", [
    ("0.5,0.25", "increasing"), ("0.25,0.25", "increasing"), ("0,0.5", "in \\(0, 1\\], got 0"),
    ("0.5,1.5", "got 1.5"), ("-0.25", "got -0.25"), ("a,b", "expected increasing fractions"), ("", "at least one")])
def test_curve_fractions_must_increase_within_the_budget(value, message):
    with pytest.raises(ValueError, match=f"--checkpoint-fractions .*{message}"):
        checked_fractions(value)


def test_bad_curve_fractions_exit_2_with_one_line_and_store_nothing(tmp_path, capsys):
    from benchmark.run import main

    assert checked_fractions("0.25,0.5,1") == (0.25, 0.5, 1.0)
    code = main(["--method", "regression", "--checkpoint-fractions", "0.5,0.25", "--results", str(tmp_path),
                 "--max-steps", "4"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err == ["error: --checkpoint-fractions 0.5,0.25: expected increasing fractions (each larger "
                                 "than the one before)"]
    assert list(tmp_path.iterdir()) == []


def test_statements_are_stored_in_the_result_outside_its_digest(tmp_path):
    results = [_sentence_result("a", BASE, convergence=_curve_convergence(BASE, BASE + 0.6, BASE + 1.5)),
               _sentence_result("b", BASE + 0.3), _sentence_result("mean", BASE + 2.0, reference=True)]
    paths = []
    for result in results:
        typed = check(result)
        record = typed.to_json()
        record["protocol"]["record_sha256"] = typed.record_digest()  # as a run stores it
        paths.append(write_result(record, tmp_path))
    written = store_statements(tmp_path)
    assert written == [paths[0]]
    stored = read(paths[0])
    assert list(stored.convergence.statements) == [
        "a: at step 750 of 1500, LVE rig 2.1 (now 1.5) would make b bold (now a is)",
        "a: at step 750 of 1500, LVE rig 2.1 (now 1.5) would lose to b (now beats it, P = 1.00)"]
    assert not stored.edited()  # derived from the table: outside protocol.record_sha256
    assert store_statements(tmp_path) == []  # already written
    # the page: the curve (quarter, half, full) and the budget its trend needs
    page = settled_page(tmp_path, "python -m leaderboard.settled --results DIR --page PAGE")
    line = next(l for l in page.splitlines() if l.startswith("| a | LVE rig"))
    assert "375: 3, 750: 2.1, 1500: 1.5" in line and "would lose to b" in line and "x its budget (trend a + b·steps^-0.58" in line
    assert json.loads(paths[1].read_text()).get("convergence") is None


def test_rows_with_nothing_to_resample_compare_the_value_with_the_other_rows_interval():
    from tests.leaderboard.test_build import _result

    convergence = {"checked_at_step": 5, "total_steps": 10, "settled": False,
                   "metrics": {"fd": {"half_budget": 3.6, "full_budget": 2.0, "half_width": 0.1, "settled": False}}}
    a = _result("a", "h", {"fd": (2.0, 0.1, False, "latent^2", (1.9, 2.1))})
    a["convergence"] = convergence
    b = _result("b", "h", {"fd": (3.0, 0.3, False, "latent^2", (2.5, 3.5))})
    c = _result("c", "h", {"fd": (9.0, 0.3, False, "latent^2", (8.5, 9.5))})
    statements = _row(_table([a, b, c]), "a").statements
    # 2.0 is below b's interval [2.5, 3.5] (a beats b), 3.6 above it (a loses); c stays worse either way
    order = next(s for s in statements if s.kind == "order")
    assert (order.other, order.now, order.at_half, order.probability, order.exact) == ("b", 1, -1, None, False)
    assert order.change_text() == "would lose to b (now beats it, by the 95 % intervals)"
    assert [s.other for s in statements if s.kind == "order"] == ["b"]
