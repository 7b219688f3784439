"""The resampling behind every interval and best mark: one-level (sentences) and two-level
(training seeds, then sentences) bootstrap, checked against brute-force enumeration."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from benchmark.metrics.bootstrap import (
    bootstrap_indices,
    interval,
    mean_ci,
    mean_replicates,
    probability_of_improvement,
    two_level_mean_replicates,
    two_level_replicates,
)

#: 2 seeds x 3 sentences whose seeds differ (seed 1 is higher and wider).
SMALL = np.array([[0.0, 1.0, 3.0],
                  [2.0, 2.5, 7.0]])
MC_RESAMPLES = 100_000


def _one_level_exact(values) -> np.ndarray:
    """Every ordered draw of len(values) sentences with replacement (equally likely): their means."""
    n = len(values)
    return np.array([np.mean([values[j] for j in draw]) for draw in itertools.product(range(n), repeat=n)])


def _two_level_exact(values) -> np.ndarray:
    """Every ordered seed draw, then every sentence draw within each drawn seed (all equally
    likely): the exact distribution of the two-level mean of means, one atom per outcome."""
    per_seed = [_one_level_exact(row) for row in values]
    k = len(values)
    atoms = []
    for seeds in itertools.product(range(k), repeat=k):
        for means in itertools.product(*(per_seed[s] for s in seeds)):
            atoms.append(np.mean(means))
    return np.array(atoms)


def _assert_matches(sample: np.ndarray, exact: np.ndarray):
    """Monte-Carlo ``sample`` against the exact equally-weighted ``atoms``.

    Tolerances (MC_RESAMPLES = 100,000 draws): the mean within 5 standard errors; the
    variance within 3 % (5 standard errors of a sample variance at this kurtosis is
    about 2.5 %); the 2.5 % and 97.5 % quantiles: the exact CDF at the Monte-Carlo
    quantile is within 0.005 of the level (the standard error of an empirical 2.5 %
    point is 0.0005 in probability), read on both sides of the atom it lands on.
    """
    se = exact.std() / np.sqrt(sample.size)
    assert abs(sample.mean() - exact.mean()) < 5 * se, (sample.mean(), exact.mean())
    assert sample.var() == pytest.approx(exact.var(), rel=0.03)
    atoms = np.sort(exact)
    for level in (0.025, 0.975):
        q = np.quantile(sample, level)
        below = np.searchsorted(atoms, q - 1e-12, side="left") / atoms.size  # P(X < q)
        at_or_below = np.searchsorted(atoms, q + 1e-12, side="right") / atoms.size  # P(X <= q)
        assert below - 0.005 <= level <= at_or_below + 0.005, (level, q, below, at_or_below)
        exact_q = np.quantile(exact, level)
        assert abs(q - exact_q) <= 0.05 * (exact.max() - exact.min()), (level, q, exact_q)


def test_enumeration_is_what_it_claims():
    exact = _two_level_exact(SMALL)
    assert exact.size == 2 ** 2 * 27 * 27  # 4 seed draws x 27 sentence draws for each of 2 drawn seeds
    # the exact two-level mean is the grand mean; its variance the law of total variance
    assert exact.mean() == pytest.approx(SMALL.mean())
    one = [_one_level_exact(row) for row in SMALL]
    seed_means = SMALL.mean(axis=1)
    within = np.mean([o.var() for o in one]) / 2  # mean of 2 independent sentence draws
    between = seed_means.var() / 2  # 2 seeds drawn with replacement
    assert exact.var() == pytest.approx(within + between)


def test_two_level_mean_replicates_matches_enumeration():
    sample = two_level_mean_replicates(SMALL, resamples=MC_RESAMPLES, seed=11)
    assert sample.shape == (MC_RESAMPLES,)
    _assert_matches(sample, _two_level_exact(SMALL))


def test_two_level_replicates_from_exact_one_level_distributions_matches_enumeration():
    per_seed = [_one_level_exact(row) for row in SMALL]  # 27 equally likely replicates per seed
    sample = two_level_replicates(per_seed, resamples=MC_RESAMPLES, seed=5)
    _assert_matches(sample, _two_level_exact(SMALL))
    # seeds with different numbers of replicates: each seed still drawn uniformly, then one of its own
    uneven = [per_seed[0], np.repeat(per_seed[1], 3)]  # the same distribution, 81 replicates
    _assert_matches(two_level_replicates(uneven, resamples=MC_RESAMPLES, seed=6), _two_level_exact(SMALL))


def test_three_seeds_match_enumeration_too():
    values = np.array([[0.0, 4.0], [1.0, 1.5], [3.0, 8.0]])  # 27 seed draws x 4^3 sentence draws
    sample = two_level_mean_replicates(values, resamples=MC_RESAMPLES, seed=2)
    _assert_matches(sample, _two_level_exact(values))
    sample = two_level_replicates([_one_level_exact(r) for r in values], resamples=MC_RESAMPLES, seed=3)
    _assert_matches(sample, _two_level_exact(values))


def test_one_seed_is_the_one_level_bootstrap():
    values = np.random.default_rng(0).normal(size=(1, 25))
    np.testing.assert_array_equal(two_level_mean_replicates(values, resamples=300, seed=4),
                                  mean_replicates(values[0], resamples=300, seed=4))
    # one seed's replicates, resampled: only values it had
    reps = np.arange(10.0)
    out = two_level_replicates([reps], resamples=5000, seed=0)
    assert set(out.tolist()) <= set(reps.tolist()) and len(set(out.tolist())) == 10


def test_mean_replicates_are_the_rows_of_bootstrap_indices_and_mean_ci_unchanged():
    values = np.random.default_rng(1).gamma(2.0, size=37)
    idx = bootstrap_indices(37, 400, 9)
    np.testing.assert_array_equal(mean_replicates(values, resamples=400, seed=9), values[idx].mean(axis=1))
    # mean_ci as before (the percentile interval of those means, extended to the mean), bit for bit
    reps = values[idx].mean(axis=1)
    lo, hi = np.quantile(reps, [0.025, 0.975])
    point = float(values.mean())
    assert mean_ci(values, resamples=400, seed=9) == [float(min(lo, point)), float(max(hi, point))]
    assert mean_ci(values, resamples=400, seed=9) == interval(mean_replicates(values, resamples=400, seed=9), point)
    assert interval([1.0, 2.0, 3.0], 10.0) == [pytest.approx(1.05), 10.0]  # extended to contain the point
    with pytest.raises(ValueError):
        mean_replicates([], resamples=10, seed=0)


def test_one_level_interval_agrees_with_scipy_bootstrap():
    from scipy.stats import bootstrap

    values = np.random.default_rng(2).lognormal(size=60)
    ours = mean_ci(values, resamples=20_000, seed=0)
    theirs = bootstrap((values,), np.mean, n_resamples=20_000, method="percentile", confidence_level=0.95,
                       rng=np.random.default_rng(123)).confidence_interval
    width = ours[1] - ours[0]
    assert ours[0] == pytest.approx(theirs.low, abs=0.03 * width)
    assert ours[1] == pytest.approx(theirs.high, abs=0.03 * width)


def test_two_seed_interval_is_at_least_as_wide_as_the_sentence_only_interval_of_its_seed_mean():
    rng = np.random.default_rng(3)
    sentences = rng.normal(size=40)
    values = np.stack([sentences + 0.0 + 0.3 * rng.normal(size=40),  # seed 0
                       sentences + 1.0 + 0.3 * rng.normal(size=40)])  # seed 1 trained to a higher level
    point = float(values.mean())
    two_level = interval(two_level_mean_replicates(values, resamples=4000, seed=0), point)
    sentence_only = mean_ci(values.mean(axis=0), resamples=4000, seed=0)
    assert two_level[1] - two_level[0] >= sentence_only[1] - sentence_only[0]
    # the seeds' difference is most of it: the two-level interval reaches both seeds' means
    assert two_level[0] <= values[0].mean() + 0.1 and two_level[1] >= values[1].mean() - 0.1
    # the same from each seed's sentence-level replicates (set-level statistics' route)
    per_seed = [mean_replicates(row, resamples=4000, seed=0) for row in values]
    from_replicates = interval(two_level_replicates(per_seed, resamples=4000, seed=0), point)
    assert from_replicates[1] - from_replicates[0] >= sentence_only[1] - sentence_only[0]
    assert from_replicates == pytest.approx(two_level, abs=0.1 * (two_level[1] - two_level[0]))


def test_probability_of_improvement_closed_forms():
    a, b = [1.0, 2.0, 3.0, 5.0], [0.0, 2.0, 4.0, 6.0]
    # lower is better: a wins at 3 < 4 and 5 < 6, ties at 2 = 2 (half), loses at 1 > 0
    assert probability_of_improvement(a, b, higher_is_better=False) == pytest.approx(2.5 / 4)
    assert probability_of_improvement(a, b, higher_is_better=True) == pytest.approx(1.5 / 4)
    assert probability_of_improvement(b, a, higher_is_better=False) == pytest.approx(1 - 2.5 / 4)
    assert probability_of_improvement(a, a, higher_is_better=True) == 0.5
    assert probability_of_improvement([2.0] * 7, [1.0] * 7, higher_is_better=True) == 1.0
    # independent normal replicates: P(a > b) = Phi((mu_a - mu_b) / sqrt(2))
    from scipy.stats import norm

    rng = np.random.default_rng(4)
    x, y = rng.normal(0.5, 1.0, 200_000), rng.normal(0.0, 1.0, 200_000)
    assert probability_of_improvement(x, y, higher_is_better=True) == pytest.approx(norm.cdf(0.5 / np.sqrt(2)),
                                                                                     abs=0.005)
    with pytest.raises(ValueError):
        probability_of_improvement([1.0, 2.0], [1.0], higher_is_better=True)
    with pytest.raises(ValueError):
        probability_of_improvement([1.0], [1.0], higher_is_better=None)


def test_rows_on_the_same_sentences_are_paired():
    # sentences differ a lot, the second row is worse by 0.05 on every sentence: paired
    # replicates see it every time, an unpaired comparison would not
    rng = np.random.default_rng(5)
    a = rng.normal(scale=3.0, size=50)
    b = a + 0.05
    ra, rb = mean_replicates(a, resamples=2000, seed=7), mean_replicates(b, resamples=2000, seed=7)
    assert probability_of_improvement(ra, rb, higher_is_better=False) == 1.0
    unpaired = mean_replicates(b, resamples=2000, seed=8)
    assert probability_of_improvement(ra, unpaired, higher_is_better=False) < 0.9
    # two-level: the sentences at each drawn position are shared by rows with the same seed
    va = rng.normal(scale=3.0, size=(3, 50))
    same_stream = (two_level_mean_replicates(va + 0.05, resamples=2000, seed=7)
                   - two_level_mean_replicates(va, resamples=2000, seed=7))
    np.testing.assert_allclose(same_stream, 0.05, atol=1e-9)
    # different streams: independent seed draws (unrelated training seeds), the same sentence rows
    other = two_level_mean_replicates(va + 0.05, resamples=2000, seed=7, stream=1)
    assert not np.allclose(other - two_level_mean_replicates(va, resamples=2000, seed=7), 0.05)
    pa = two_level_replicates([np.arange(100.0)] * 2, resamples=500, seed=1)
    pb = two_level_replicates([np.arange(100.0) + 1] * 2, resamples=500, seed=1)
    np.testing.assert_allclose(pb - pa, 1.0)


def test_bad_input_is_refused():
    for bad in (np.zeros((0, 3)), np.zeros((2, 0)), np.zeros(3)):
        with pytest.raises(ValueError):
            two_level_mean_replicates(bad, resamples=10, seed=0)
    with pytest.raises(ValueError):
        two_level_replicates([], resamples=10, seed=0)
    with pytest.raises(ValueError):
        two_level_replicates([np.ones(3), np.ones(0)], resamples=10, seed=0)
    with pytest.raises(ValueError):
        two_level_replicates([np.ones(3)], resamples=0, seed=0)
