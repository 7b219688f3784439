"""Simulated participants with known Bradley-Terry strengths: the known truth the analysis is
tested against (tests/study/test_analysis_truth.py) and the interval widths of perf/study_power.py.

Each comparison ``(a, b)`` is judged on the same ``items`` sentences (as CodeTalker's
30 samples x 4 comparisons), each pair by ``judges`` different participants out of
``participants`` (assigned in turn); a participant prefers A with probability
``1 / (1 + exp(-(strength[a] - strength[b])))``, independently.
"""

from __future__ import annotations

import numpy as np

from benchmark.study.analysis.judgements import Judgements


def true_share(strengths, a: int, b: int) -> float:
    """The probability that row ``a`` is preferred to row ``b``."""
    return float(1 / (1 + np.exp(-(strengths[a] - strengths[b]))))


def simulate_mos(means, *, items: int, participants: int, judges: int = 3, spread: float = 1.0,
                 rng: np.random.Generator) -> Judgements:
    """Coded MOS ratings: row r's rating of each item is its mean plus noise (``spread``),
    rounded and clipped to 1-5; ``means`` are chosen inside [2, 4] so that clipping is rare
    and the expected rating is close to the mean (the test measures it exactly)."""
    means = np.asarray(means, dtype=float)
    trial_row = np.repeat(np.arange(means.size), items)
    trial_item = np.tile(np.arange(items), means.size)
    trials = trial_row.size
    judge = (np.arange(trials)[:, None] * judges + np.arange(judges)[None, :]) % participants
    row = np.repeat(trial_row, judges)
    value = np.clip(np.rint(means[row] + spread * rng.standard_normal(row.size)), 1, 5).astype(np.int64)
    zeros = np.zeros(row.size, dtype=np.int64)
    return Judgements("mos", [f"row{k}" for k in range(means.size)], ["q0"], judge.reshape(-1),
                      np.repeat(trial_item, judges), zeros, row, zeros - 1, value, np.repeat(np.arange(trials), judges),
                      participants=list(range(participants)), items=[("Sim", f"sentence{k:03d}") for k in range(items)],
                      units=list(range(trials)))


def simulate_ab(strengths, comparisons, *, items: int, participants: int, judges: int = 3,
                questions: int = 1, rng: np.random.Generator) -> Judgements:
    """Coded A/B judgements of a simulated study (every question with the same strengths)."""
    strengths = np.asarray(strengths, dtype=float)
    if judges > participants:
        raise ValueError(f"judges ({judges}) must not exceed participants ({participants})")
    pairs = np.asarray(comparisons, dtype=np.int64)
    trial_pair = np.repeat(np.arange(len(pairs)), items)
    trial_item = np.tile(np.arange(items), len(pairs))
    trials = trial_pair.size
    judge = (np.arange(trials)[:, None] * judges + np.arange(judges)[None, :]) % participants
    n = trials * judges
    participant = np.tile(judge.reshape(-1), questions)
    pair = np.tile(np.repeat(trial_pair, judges), questions)
    item = np.tile(np.repeat(trial_item, judges), questions)
    question = np.repeat(np.arange(questions), n)
    unit = np.tile(np.repeat(np.arange(trials), judges), questions) + question * trials
    row_a, row_b = pairs[pair, 0], pairs[pair, 1]
    p_a = 1 / (1 + np.exp(-(strengths[row_a] - strengths[row_b])))
    value = (rng.random(p_a.size) < p_a).astype(np.int64)
    names = [f"row{k}" for k in range(strengths.size)]
    return Judgements("ab", names, [f"q{k}" for k in range(questions)], participant, item, question,
                      row_a, row_b, value, unit, participants=list(range(participants)),
                      items=[("Sim", f"sentence{k:03d}") for k in range(items)], units=list(range(trials * questions)))
