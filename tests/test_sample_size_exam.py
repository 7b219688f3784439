"""perf/sample_size_exam.py's drawing and deciding, on planted features whose order is known:
the sampler drawn from the data's own distribution, the "mean" a shrunk copy of it."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

SCRIPT = Path(__file__).resolve().parents[1] / "perf" / "sample_size_exam.py"


def _script():
    spec = importlib.util.spec_from_file_location("perf_sample_size_exam", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _scored(sentences=12, windows=30, dim=4, seed=0):
    rng = np.random.default_rng(seed)
    owner = np.repeat(np.arange(sentences), windows)
    real = rng.normal(size=(len(owner), dim))
    sample = rng.normal(size=(2 * len(owner), dim))  # two draws of the same distribution
    mean = 0.2 * rng.normal(size=(len(owner), dim))  # damped: far from the data in FD
    energy = {"oracle-sample": np.full(sentences, 1.0), "oracle-mean": np.full(sentences, 2.0)}
    return {"keys": [("s", f"t{i}") for i in range(sentences)], "real": real, "real_owner": owner,
            "fake": {"oracle-sample": sample, "oracle-mean": mean},
            "fake_owner": {"oracle-sample": np.tile(owner, 2), "oracle-mean": owner},
            "sentence": {row: {"energy_rig": values} for row, values in energy.items()}, "seconds": 0.0}


def test_the_exam_finds_the_planted_order_and_reports_the_whole_split_apart():
    exam = _script()
    results = exam.exam(_scored(), [4, 12], subsets=30, wind_subsets=2, seed=0, fd_inf_draws=3)
    four, whole = results["sizes"][4], results["sizes"][12]
    assert four["splits"] == 30 and whole["splits"] == 1
    assert four["metrics"]["energy_rig"]["probability"] == 1.0  # planted on every sentence
    assert four["metrics"]["fd"]["probability"] == 1.0 and four["metrics"]["wind"]["draws"] == 2
    assert four["metrics"]["fd"]["mean"]["oracle-sample"] < four["metrics"]["fd"]["mean"]["oracle-mean"]
    # the whole split is one draw: reported, not decided on (the smallest size comes from 4 alone)
    assert results["smallest"]["energy_rig"] == 4 and results["smallest"]["fd"] == 4
    table = exam.markdown(results, [4, 12], 12)
    assert "| energy_rig | 1.00 (30) | right (whole split) | 4 |" in table


def test_the_splits_are_the_same_for_every_metric_and_seeded():
    exam = _script()
    a, b = exam.split_draws(12, [4, 12], 5, seed=3), exam.split_draws(12, [4, 12], 5, seed=3)
    assert all(np.array_equal(x, y) for x, y in zip(a[4], b[4]))
    assert all(len(set(split.tolist())) == 4 for split in a[4]) and np.array_equal(a[12][0], np.arange(12))
