"""The sample-size exam's decision: the probability of the oracle order on random test
splits and the smallest split size from which it holds, on synthetic score samples whose
answer is known."""

from __future__ import annotations

import numpy as np
import pytest

from benchmark.evaluation.registry import METRICS
from benchmark.evaluation.sample_size import (
    LEVEL,
    MIN_TEST_SENTENCES,
    below_minimum,
    ordering_probability,
    smallest_reliable_size,
)


def test_ordering_probability_counts_strict_wins_in_the_metric_direction():
    better, worse = np.array([1.0, 2.0, 3.0, 4.0]), np.array([2.0, 1.0, 3.0, 5.0])
    assert ordering_probability(better, worse, higher_is_better=False) == 0.5  # 1<2, 4<5; a tie is no win
    assert ordering_probability(better, worse, higher_is_better=True) == 0.25


def test_a_biased_metric_whose_bias_shrinks_as_1_over_n_is_reliable_from_the_planted_size():
    """Scores ``truth + bias / n + noise / sqrt(n)``: the sampler's true value is lower by 1,
    its bias 40 higher. The order is right in expectation once 40 / n < 1 (n > 40), and
    with 95 % probability from a size the normal law gives: the exam must find that size."""
    rng = np.random.default_rng(0)
    sizes = (4, 8, 16, 32, 64, 128, 256)
    draws = 4000
    probabilities = {}
    for n in sizes:
        sampler = 1.0 + 50.0 / n + rng.normal(0, 2.0, draws) / np.sqrt(n)
        mean = 2.0 + 10.0 / n + rng.normal(0, 2.0, draws) / np.sqrt(n)
        probabilities[n] = ordering_probability(sampler, mean, higher_is_better=False)
    # expected difference 1 - 40/n, its std 2 sqrt(2/n): P(right) = Phi((1 - 40/n) / (2 sqrt(2 / n)))
    assert probabilities[4] < 0.01 and probabilities[32] < 0.5
    assert probabilities[64] < LEVEL <= probabilities[128]
    assert smallest_reliable_size(probabilities) == 128


def test_a_size_that_reaches_the_level_below_one_that_does_not_is_not_reliable():
    assert smallest_reliable_size({4: 0.97, 8: 0.6, 16: 0.96, 32: 0.99}) == 16
    assert smallest_reliable_size({4: 0.99, 8: 0.99}) == 4
    assert smallest_reliable_size({4: 0.2, 80: 0.9}) is None


@pytest.mark.parametrize("call", [
    lambda: ordering_probability([1.0, 2.0], [1.0], higher_is_better=False),
    lambda: ordering_probability([], [], higher_is_better=False),
    lambda: smallest_reliable_size({}),
])
def test_bad_input_is_refused(call):
    with pytest.raises(ValueError, match="expected"):
        call()


def test_the_stored_sizes_name_registered_metrics_and_mark_the_bundled_default():
    """The exam's sizes are data beside the registry: registered names; the bundled
    default's 4 test sentences are below FD's and WInD's, the committed board's 80 below none."""
    assert MIN_TEST_SENTENCES, "no size stored (perf/sample_size_exam.py)"
    for name, needed in MIN_TEST_SENTENCES.items():
        assert name in METRICS and 2 <= needed <= 80
        assert not below_minimum(name, 80)
    assert below_minimum("fd", 4) and below_minimum("wind", 4)
    assert not below_minimum("fd", None) and not below_minimum("not-a-metric", 4)
