"""The metric registry is the one source of metric metadata: evaluate's entries and docs/metrics.md follow it."""

from pathlib import Path

import numpy as np
import pytest

from benchmark.evaluation.registry import GROUPS, METRICS, markdown_table, metric_entry, metric_info, ordered_metrics
from benchmark.metrics.bootstrap import bootstrap_indices, mean_ci

DOCS = Path(__file__).resolve().parents[2] / "docs" / "metrics.md"


def test_docs_table_is_the_registry():
    assert markdown_table() in DOCS.read_text(), "docs/metrics.md's metric table differs from the registry; " \
        "paste benchmark.evaluation.registry.markdown_table() into it"


def test_order_follows_the_papers_table_1():
    order = ordered_metrics(["wind", "lve_rig", "fd", "multimodality", "av_confidence_syncnet", "av_offset_syncnet",
                             "apd_mesh", "energy_rig", "lve_mesh", "custom"])
    assert order == ["av_offset_syncnet", "av_confidence_syncnet", "multimodality", "fd", "wind", "lve_mesh",
                     "lve_rig", "energy_rig", "apd_mesh", "custom"]
    assert [METRICS[n].group for n in ordered_metrics(list(METRICS))] == sorted(
        (METRICS[n].group for n in METRICS), key=GROUPS.index)
    with pytest.raises(KeyError, match="registered"):
        metric_info("nope")


def test_entries_carry_registry_metadata():
    entry = metric_entry("lve_rig", 1.5, 0.2, ci95=[1.2, 1.8], n=40)
    assert entry == {"mean": 1.5, "std": 0.2, "ci95": [1.2, 1.8], "n": 40, "higher_is_better": False, "unit": "mm",
                     "label": "LVE rig", "group": "vertex"}
    # a signed offset and a lag bias have no better direction
    assert metric_entry("av_lag_bias_geometric", 0.5)["higher_is_better"] is None


def test_every_vertex_metric_has_both_spaces():
    for old in ("lve", "lve_squared", "mve", "fdd", "apd", "upd", "lpd", "mpd"):
        assert old not in METRICS and f"{old}_mesh" in METRICS and f"{old}_rig" in METRICS
    for est in ("geometric", "expert", "syncnet"):
        assert {f"av_offset_signed_{est}", f"av_lag_bias_{est}"} <= set(METRICS)


def test_bootstrap_is_seeded_brackets_the_mean_and_covers_at_the_nominal_rate():
    rng = np.random.default_rng(0)
    values = rng.normal(size=40)
    assert mean_ci(values, seed=3) == mean_ci(values, seed=3)
    assert mean_ci(values, seed=3) != mean_ci(values, seed=4)
    lo, hi = mean_ci(values)
    assert lo <= values.mean() <= hi
    assert mean_ci([2.0]) == [2.0, 2.0]
    # coverage of the true mean (0) by the percentile interval, over independent test sets
    hits = [lo <= 0 <= hi for lo, hi in (mean_ci(rng.normal(size=40), resamples=400, seed=i) for i in range(300))]
    assert 0.88 <= np.mean(hits) <= 0.99
    idx = bootstrap_indices(10, 5, seed=1)
    assert idx.shape == (5, 10) and idx.min() >= 0 and idx.max() < 10
