"""Metric sanity suite: disturb the ground truth in known ways and check that every
metric reacts (or does not) as declared.

``python -m benchmark.sanity --data BUILD --out DIR [--levels small|full]``; the
pieces: :mod:`~benchmark.sanity.disturbances` (pure functions over coefficient
tracks), :mod:`~benchmark.sanity.expectations` (the declaration table and the
verdict), :mod:`~benchmark.sanity.report` (scoring through
``benchmark.evaluation.evaluate_split``, ``sanity.json`` and ``sanity.png``).
docs/metrics.md, "Metric sanity", gives the table and what it found.
"""

from benchmark.sanity.disturbances import DISTURBANCES, Disturbance, disturb
from benchmark.sanity.expectations import EXPECTATIONS, Expectation, declared, spearman, verdict
from benchmark.sanity.report import failures, plot_table, run_sanity, sanity_scores, sanity_table, write_report

__all__ = ["DISTURBANCES", "EXPECTATIONS", "Disturbance", "Expectation", "declared", "disturb", "failures",
           "plot_table", "run_sanity", "sanity_scores", "sanity_table", "spearman", "verdict", "write_report"]
