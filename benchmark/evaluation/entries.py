"""Result entries from metric values: :class:`Scores` (what :func:`benchmark.evaluation.evaluate_split`
returns) and the entries of per-sentence metrics with their bootstrap intervals."""

from __future__ import annotations

import zlib
from collections.abc import Mapping

import numpy as np

from benchmark.metrics.bootstrap import interval, mean_replicates
from benchmark.metrics.info import MetricInfo

__all__ = ["Scores", "replicates_and_interval", "sentence_entries"]


class Scores(dict):
    """``{metric: entry}`` in table order, with :attr:`per_sentence` rows
    (``{"subject", "sentence", metric: value, ...}`` for the per-sentence metrics),
    :attr:`replicates` (``{metric: (B,) bootstrap replicates}``, from which the
    intervals are read and runs of several seeds are combined) and :attr:`protocol`
    (facts of the split a result records beside its metrics: ``fd_floor_probe``, and
    ``evaluation``, the settings that differ from the protocol's defaults)."""

    def __init__(self, metrics=(), per_sentence=None, replicates=None, protocol=None):
        super().__init__(metrics)
        self.per_sentence = list(per_sentence or [])
        self.replicates = dict(replicates or {})
        self.protocol = dict(protocol or {})


def replicates_and_interval(point: float, replicates) -> tuple[np.ndarray, list]:
    """``(replicates as float64, their percentile interval around point)``; ``[point, point]`` without any."""
    replicates = np.asarray(replicates, dtype=np.float64)
    return replicates, (interval(replicates, point) if replicates.size else [point, point])


def sentence_entries(values: dict, infos: Mapping[str, MetricInfo], *, seed: int,
                     resamples: int) -> tuple[dict, dict, dict]:
    """Entries of per-sentence metrics from ``values[name][key] = (S,) per-sample values (or a scalar)``.

    Returns ``(entries, {key: {name: sentence value}}, {name: bootstrap replicates})``;
    ``infos[name]`` gives each entry's metadata. ``sample_std`` is the std over sample
    indices of the per-sample means over sentences (stochastic methods). The replicates
    are the means of the resampled sentences whose percentiles are the interval
    (:func:`benchmark.metrics.bootstrap.mean_ci`'s); metric ``name`` resamples with the
    seed ``seed + crc32(name)``.
    """
    entries, rows, replicates = {}, {}, {}
    for name, per_key in values.items():
        if not per_key:
            continue
        keys = list(per_key)
        arrays = [np.atleast_1d(np.asarray(per_key[k], dtype=np.float64)) for k in keys]
        sentence = np.array([a.mean() for a in arrays])
        for k, v in zip(keys, sentence):
            rows.setdefault(k, {})[name] = float(v)
        std = float(sentence.std(ddof=1)) if len(sentence) > 1 else None
        sample_std = None
        lengths = {len(a) for a in arrays}
        if len(lengths) == 1 and lengths.pop() >= 2:
            sample_std = float(np.stack(arrays).mean(axis=0).std(ddof=1))
        point = float(sentence.mean())
        reps = (mean_replicates(sentence, resamples=resamples, seed=seed + zlib.crc32(name.encode()))
                if len(sentence) >= 2 else np.empty(0))
        replicates[name], ci = replicates_and_interval(point, reps)
        entries[name] = infos[name].entry(point, std, n=len(sentence), sample_std=sample_std, ci95=ci)
    return entries, rows, replicates
