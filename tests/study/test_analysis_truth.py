"""The analysis recovers known truth (issue 55's acceptance): simulated participants with known
Bradley-Terry strengths give intervals that cover the truth in at least 90 % of 200 simulated
studies; MOS means are recovered; Krippendorff's alpha is 1 for unanimous raters and about 0
for random ones; a metric built to agree with the participants scores 1.0, a random one 0.5."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from benchmark.study.analysis.agreement import agreement
from benchmark.study.analysis.board import metrics_against_people
from benchmark.study.analysis.bootstrap import crossed_weights
from benchmark.study.analysis.bradley_terry import bradley_terry
from benchmark.study.analysis.mos import mos_scores
from benchmark.study.analysis.preference import preference_shares
from benchmark.study.analysis.simulate import simulate_ab, simulate_mos, true_share
from tests.study.board_results import fabricated_result

STUDIES = 200
REPLICATES = 150
# CodeTalker's design: 4 rows, "Ours" (row 0) against each of the three others, plus one more pair
# so that the Bradley-Terry model has a cycle; 30 sentences per comparison, 3 judges each, 24 people.
STRENGTHS = np.array([0.0, -1.0, -0.4, 0.3])
COMPARISONS = [(0, 1), (0, 2), (0, 3), (1, 2)]


def _weights(judgements, rng):
    return crossed_weights(judgements.participant, judgements.item, len(judgements.participants),
                           len(judgements.items), REPLICATES, rng)


def test_intervals_cover_the_known_shares_and_strengths():
    rng = np.random.default_rng(55)
    share_hits, share_widths, bt_hits, bt_widths = [], [], [], []
    for _ in range(STUDIES):
        judgements = simulate_ab(STRENGTHS, COMPARISONS, items=30, participants=24, judges=3, rng=rng)
        weights = _weights(judgements, rng)
        for entry in preference_shares(judgements, weights):
            truth = true_share(STRENGTHS, judgements.rows.index(entry["a"]), judgements.rows.index(entry["b"]))
            share_hits.append(entry["ci95"][0] <= truth <= entry["ci95"][1])
            share_widths.append(entry["ci95"][1] - entry["ci95"][0])
        strengths = bradley_terry(judgements, weights, "row0", progress=False)["q0"]["strengths"]
        for entry in strengths[1:]:
            truth = STRENGTHS[judgements.rows.index(entry["row"])] - STRENGTHS[0]
            bt_hits.append(entry["ci95"][0] <= truth <= entry["ci95"][1])
            bt_widths.append(entry["ci95"][1] - entry["ci95"][0])
    print(f"\nA/B shares: coverage {np.mean(share_hits):.3f}, mean width {np.mean(share_widths):.3f}; "
          f"Bradley-Terry: coverage {np.mean(bt_hits):.3f}, mean width {np.mean(bt_widths):.3f}")
    assert len(share_hits) == STUDIES * len(COMPARISONS) and len(bt_hits) == STUDIES * 3
    assert np.mean(share_hits) >= 0.90
    assert np.mean(bt_hits) >= 0.90
    # informative, not merely wide: 90 answers per comparison give about +-0.16 (conservative)
    assert np.mean(share_widths) < 0.40


def test_the_test_holds_its_level_and_finds_a_clear_preference():
    rng = np.random.default_rng(7)
    rejected_null, rejected_clear = [], []
    for strengths, sink in ((np.zeros(2), rejected_null), (np.array([1.5, 0.0]), rejected_clear)):
        for _ in range(STUDIES):
            judgements = simulate_ab(strengths, [(0, 1)], items=30, participants=24, judges=3, rng=rng)
            (entry,) = preference_shares(judgements, _weights(judgements, rng))
            sink.append(entry["p_value"] < 0.05)
    print(f"\nrejections at 5 %: {np.mean(rejected_null):.3f} with no preference, "
          f"{np.mean(rejected_clear):.3f} with an 82 % preference")
    assert np.mean(rejected_null) <= 0.10
    assert np.mean(rejected_clear) >= 0.90


def _expected_rating(mean: float, spread: float) -> float:
    """E[clip(round(mean + spread * z), 1, 5)] exactly."""
    edges = np.array([-np.inf, 1.5, 2.5, 3.5, 4.5, np.inf])
    probabilities = np.diff(stats.norm.cdf((edges - mean) / spread))
    return float(probabilities @ np.arange(1, 6))


def test_mos_means_are_recovered():
    rng = np.random.default_rng(3)
    means = np.array([2.2, 3.0, 3.9])
    truth = [_expected_rating(m, 1.0) for m in means]
    hits, widths, errors = [], [], []
    for _ in range(STUDIES):
        ratings = simulate_mos(means, items=24, participants=20, judges=3, rng=rng)
        for entry in mos_scores(ratings, _weights(ratings, rng)):
            k = ratings.rows.index(entry["row"])
            hits.append(entry["ci95"][0] <= truth[k] <= entry["ci95"][1])
            widths.append(entry["ci95"][1] - entry["ci95"][0])
            errors.append(entry["mean"] - truth[k])
    print(f"\nMOS: coverage {np.mean(hits):.3f}, mean width {np.mean(widths):.3f}, bias {np.mean(errors):+.4f}")
    assert np.mean(hits) >= 0.90
    assert abs(np.mean(errors)) < 0.02


def test_alpha_is_one_for_unanimous_raters_and_about_zero_for_random_ones():
    rng = np.random.default_rng(11)
    random_ab = simulate_ab(np.zeros(2), [(0, 1)], items=300, participants=30, judges=3, rng=rng)
    unanimous_ab = simulate_ab(np.zeros(2), [(0, 1)], items=300, participants=30, judges=3, rng=rng)
    unanimous_ab.value = unanimous_ab.unit % 2
    random_mos = simulate_mos(np.array([3.0]), items=300, participants=30, judges=3, spread=1.5, rng=rng)
    unanimous_mos = simulate_mos(np.array([3.0]), items=300, participants=30, judges=3, rng=rng)
    unanimous_mos.value = 1 + unanimous_mos.unit % 5
    alphas = {name: agreement(j, level)["q0"]["alpha"] for name, j, level in (
        ("random A/B", random_ab, "nominal"), ("unanimous A/B", unanimous_ab, "nominal"),
        ("random MOS", random_mos, "ordinal"), ("unanimous MOS", unanimous_mos, "ordinal"))}
    print("\n" + ", ".join(f"{name}: alpha {value:+.3f}" for name, value in alphas.items()))
    assert alphas["unanimous A/B"] == pytest.approx(1.0) and alphas["unanimous MOS"] == pytest.approx(1.0)
    # 900 random answers: alpha's spread is about 0.03
    assert abs(alphas["random A/B"]) < 0.1 and abs(alphas["random MOS"]) < 0.1


def _record(judgements, rng):
    weights = _weights(judgements, rng)
    return {"preference": preference_shares(judgements, weights),
            "bradley_terry": bradley_terry(judgements, weights, "row0", progress=False)}


def test_a_metric_built_to_agree_scores_one_and_a_random_metric_one_half():
    rng = np.random.default_rng(5)
    strengths = np.array([0.0, -0.3, 0.2, -0.9])
    star = [(0, 1), (0, 2), (0, 3)]
    judgements = simulate_ab(strengths, star, items=200, participants=40, judges=3, rng=rng)
    record = _record(judgements, rng)
    # per sentence, the majority of the three judges (no ties with three)
    majority = {}
    for a, b, i, v in zip(judgements.row_a, judgements.row_b, judgements.item, judgements.value):
        majority.setdefault((int(b), int(i)), []).append(int(v))
    shares = {p["b"]: p["share_a"] for p in record["preference"]}
    chosen = {}
    for k, row in enumerate(judgements.rows):
        per_sentence = []
        for i, (subject, sentence) in enumerate(judgements.items):
            agree = 0.0 if k == 0 else (-1.0 if np.mean(majority[k, i]) > 0.5 else 1.0)
            per_sentence.append({"subject": subject, "sentence": sentence, "agree": agree,
                                 "agree_lower": -agree, "random": float(rng.standard_normal())})
        mean = 0.0 if k == 0 else 0.5 - shares[row]
        result = fabricated_result(row, per_sentence, {"agree": mean, "agree_lower": -mean, "random": rng.random()},
                                   directions={"agree_lower": False})
        chosen[row] = (f"{row}.json", result)
    table = {e["metric"]: e for e in metrics_against_people(judgements, record, chosen)["questions"]["q0"]}
    print(f"\nagreement per sentence: built to agree {table['agree']['sentence_agreement']:.3f}, "
          f"random {table['random']['sentence_agreement']:.3f} over {table['random']['sentence_units']} sentences")
    for name in ("agree", "agree_lower"):
        assert table[name]["sentence_agreement"] == 1.0 and table[name]["sentence_units"] == 600
        assert table[name]["pair_agreement"] == 1.0 and table[name]["pairs"] == 3
        assert table[name]["spearman"] == pytest.approx(1.0) and table[name]["kendall"] == pytest.approx(1.0)
    # 600 sentence pairs judged: a coin agrees 0.5 +- 0.02; the tolerance is four of those
    assert table["random"]["sentence_agreement"] == pytest.approx(0.5, abs=0.08)
