"""Training seeds in the protocol: one run per seed, stored as one result.

``benchmark.run --seeds 0,1,2`` (``RunSpec.seeds``, ``run(RunSpec(seeds=[...]))``)
trains, generates and scores the method once per seed, each run exactly what
``--seed k`` would give, and :func:`combined_seed_scores` makes one row of them:

* ``mean``: the mean over seeds of each seed's mean; ``seed_range``: ``[min, max]``
  of the seed means; ``n_seeds``.
* ``ci95``: a two-level bootstrap (resample the seeds, then the sentences within each
  drawn seed; :mod:`benchmark.metrics.bootstrap`): per-sentence metrics from the
  seeds' per-sentence values (``two_level_mean_replicates``), set-level metrics (FD,
  WInD, multimodality) from each seed's sentence-bootstrap replicates
  (``two_level_replicates``). A row's interval thus covers both what another
  training seed and what other sentences would change.
* ``per_sentence``: per sentence, the mean over seeds.
* ``per_seed``: ``[{"seed", "metrics": {name: mean}, "per_sentence": [rows],
  "replicates": {set-level name: [floats]}, "convergence"?, "tracks", "n_clipped",
  "timings"}]``, enough to recombine the seeds later.

The bootstrap draws the sentences of metric ``name`` with the seed
``zlib.crc32(name)``, as ``evaluate_split`` does for one seed (so one seed gives its
sentence-only interval back), and the seeds with a stream of the method's label
(``protocol.seed_bootstrap``): rows compared with each other draw their training
seeds independently.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmark.metrics.bootstrap import (
    BOOTSTRAP_RESAMPLES,
    interval,
    two_level_mean_replicates,
    two_level_replicates,
)
from benchmark.evaluation.registry import METRICS
from benchmark.protocol.convergence import (
    CHECKED,
    checked_convergence,
    combined_convergence,
    half_budget_check,
)
from benchmark.protocol.generation import generate
from benchmark.protocol.scoring import score
from benchmark.protocol.spec import UsageError, checked_seeds
from benchmark.protocol.storing import store_seeds, track_writer
from benchmark.protocol.training import train
from benchmark.results import replicates_array
from benchmark.runs import seed_folder_name

__all__ = ["CombinedScores", "SeedRun", "combined_seed_scores", "parse_seeds", "run_seeds", "seed_stream",
           "summed_timings"]


def parse_seeds(text: str) -> tuple:
    """``"0,1,2"`` -> ``(0, 1, 2)`` (``--seeds``; spaces allowed).

    Raises
    ------
    UsageError
        An entry that is not an integer >= 0, an empty entry, or a seed given twice.
    """
    parts = [p.strip() for p in str(text).split(",")]
    values = []
    for part in parts:
        if not part.isdigit():  # no sign, no decimal point, no exponent, not empty
            raise UsageError(f"--seeds: expected comma-separated integers >= 0 such as 0,1,2, got {text!r}")
        values.append(int(part))
    return checked_seeds(values)


def seed_stream(label: str) -> int:
    """The stream of a row's seed draws in the two-level bootstrap (from its label)."""
    return zlib.crc32(str(label).encode()) & 0x7FFFFFFF


@dataclass(frozen=True)
class SeedRun:
    """One training seed's run, as :func:`combined_seed_scores` takes it.

    Attributes
    ----------
    seed : int
    metrics : mapping
        ``{name: {"mean", "ci95", ...}}`` as the evaluation returned them.
    per_sentence : list of dict
        ``{"subject", "sentence", name: value, ...}`` rows.
    replicates : mapping
        ``{name: (B,) bootstrap replicates}`` over the sentences (``Scores.replicates``;
        the set-level ones are needed, the per-sentence ones are not used).
    convergence : dict or None
        The seed's :func:`~benchmark.protocol.convergence.convergence_record`.
    evaluation : dict
        What the evaluation attached for the protocol section (``Scores.protocol``).
    n_clipped, num_subjects, num_sentences : int
    timings : dict
        Seconds per step of this seed.
    latency : dict or None
        The seed's :func:`~benchmark.protocol.generation.measure_latency` record.
    """

    seed: int
    metrics: dict
    per_sentence: list
    replicates: dict = field(default_factory=dict)
    convergence: dict | None = None
    evaluation: dict = field(default_factory=dict)
    n_clipped: int = 0
    num_subjects: int = 0
    num_sentences: int = 0
    timings: dict = field(default_factory=dict)
    latency: dict | None = None

    @classmethod
    def scored(cls, seed: int, generated, scored, *, convergence, timings: dict) -> SeedRun:
        """A seed's run from its generation and scores (:func:`~benchmark.protocol.generate`,
        :func:`~benchmark.protocol.score`); ``timings``: its training's."""
        return cls(seed=int(seed), metrics=dict(scored.metrics), per_sentence=list(scored.per_sentence),
                   replicates=dict(getattr(scored.metrics, "replicates", {}) or {}), convergence=convergence,
                   evaluation=dict(getattr(scored.metrics, "protocol", {}) or {}), n_clipped=generated.n_clipped,
                   num_subjects=len({s for s, _ in generated.tracks}), num_sentences=len(generated.tracks),
                   timings={**timings, "generate_s": generated.seconds, "evaluate_s": scored.seconds},
                   latency=getattr(generated, "latency", None))

    def seed_replicates(self, name: str) -> np.ndarray | None:
        """This seed's bootstrap replicates of ``name`` (``Scores.replicates``, else the
        metric entry's own; :func:`benchmark.results.replicates_array`)."""
        reps = self.replicates.get(name) if self.replicates else None
        return replicates_array(self.metrics[name].get("replicates") if reps is None else reps)


@dataclass(frozen=True)
class CombinedScores:
    """The row of a run over several seeds.

    Attributes
    ----------
    metrics : dict
        ``{name: entry}``: each seed's entry fields, with ``mean`` (mean of the seed
        means), ``ci95`` (two-level bootstrap), ``seed_range``, ``n_seeds``, ``std``
        (per-sentence metrics: over the sentences of the seed-averaged values) and,
        for set-level metrics, the two-level ``replicates``.
    per_sentence : list of dict
        Per sentence, each metric's mean over the seeds.
    per_seed : list of dict
        ``{"seed", "metrics": {name: mean}, "per_sentence", "replicates"[, "convergence"]}``.
    convergence : dict or None
        From :func:`~benchmark.protocol.convergence.combined_convergence`.
    bootstrap : dict
        ``{"resamples", "stream"}`` of the two-level bootstrap.
    """

    metrics: dict
    per_sentence: list
    per_seed: list
    convergence: dict | None = None
    bootstrap: dict = field(default_factory=dict)


def _level(name: str, runs) -> str:
    """``"sentence"`` or ``"set"``: the registry's word, else whether every seed has the
    metric in every per-sentence row."""
    if name in METRICS:
        return METRICS[name].level
    rows = [row for run in runs for row in run.per_sentence]
    return "sentence" if rows and all(name in row for row in rows) else "set"


def _finite(value) -> bool:
    return isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool) \
        and math.isfinite(float(value))


def _row_key(row) -> tuple:
    return row.get("subject"), row.get("sentence")


def _sentence_matrix(name: str, runs, keys) -> np.ndarray | None:
    """``(n_seeds, n_sentences)`` values of ``name`` (sentences in ``keys`` order), or
    None when a seed lacks a finite value for a sentence."""
    matrix = []
    for run in runs:
        rows = {_row_key(r): r for r in run.per_sentence}
        values = [rows.get(key, {}).get(name) for key in keys]
        if not all(_finite(v) for v in values):
            return None
        matrix.append([float(v) for v in values])
    return np.asarray(matrix, dtype=np.float64)


def _rounded(values) -> list:
    return [float(f"{v:.7g}") for v in np.asarray(values, dtype=np.float64)]


def combined_seed_scores(runs, *, resamples: int = BOOTSTRAP_RESAMPLES, stream: int = 0,
                         level: float = 0.95) -> CombinedScores:
    """One row from the runs of several training seeds (see the module docstring).

    Parameters
    ----------
    runs : sequence of SeedRun
        One per seed, scored on the same sentences.
    resamples : int
        Two-level bootstrap replicates per metric.
    stream : int
        The row's stream of seed draws (:func:`seed_stream` of its label).
    level : float
        Interval level (0.95: ``ci95``).

    Returns
    -------
    CombinedScores
        Metrics are those every seed has, in the first seed's order. Where a seed
        lacks what the two-level bootstrap needs (a per-sentence value, or the
        replicates of a set-level metric, as from an evaluation that gives none), the
        interval is the envelope of the seeds' own intervals instead.
    """
    runs = list(runs)
    if not runs:
        raise ValueError("combined_seed_scores: expected at least one seed's run, got none")
    names = [n for n in runs[0].metrics if all(n in run.metrics for run in runs)]
    keys = [_row_key(r) for r in runs[0].per_sentence]
    metrics, set_replicates = {}, {run.seed: {} for run in runs}
    combined_values = {}
    for name in names:
        means = np.array([float(run.metrics[name]["mean"]) for run in runs])
        point = float(means.mean())
        kind = _level(name, runs)
        stat_seed = zlib.crc32(name.encode())
        reps = None
        entry = {k: v for k, v in runs[0].metrics[name].items() if k != "replicates"}
        if kind == "sentence":
            matrix = _sentence_matrix(name, runs, keys) if keys else None
            if matrix is not None:
                reps = two_level_mean_replicates(matrix, resamples=resamples, seed=stat_seed, stream=stream)
                per_key = matrix.mean(axis=0)
                combined_values[name] = per_key
                entry["std"] = float(per_key.std(ddof=1)) if per_key.size > 1 else None
        else:
            seed_reps = [run.seed_replicates(name) for run in runs]
            for run, r in zip(runs, seed_reps):
                if r is not None:
                    set_replicates[run.seed][name] = _rounded(r)
            if all(r is not None for r in seed_reps):
                reps = two_level_replicates(seed_reps, resamples=resamples, seed=stat_seed, stream=stream)
                entry["replicates"] = _rounded(reps)
            stds = [run.metrics[name].get("std") for run in runs]
            entry["std"] = float(np.mean(stds)) if all(_finite(s) for s in stds) else None
        if reps is not None:
            ci = interval(reps, point, level)
        else:  # nothing to resample: the envelope of the seeds' intervals (and means)
            cis = np.array([run.metrics[name].get("ci95") or [m, m] for run, m in zip(runs, means)], dtype=np.float64)
            ci = [min(float(cis[:, 0].min()), point), max(float(cis[:, 1].max()), point)]
        sample_stds = [run.metrics[name].get("sample_std") for run in runs]
        if all(_finite(s) for s in sample_stds):
            entry["sample_std"] = float(np.mean(sample_stds))
        entry.update(mean=point, ci95=[float(ci[0]), float(ci[1])],
                     seed_range=[float(means.min()), float(means.max())], n_seeds=len(runs))
        metrics[name] = entry

    rows_by_seed = [{_row_key(r): r for r in run.per_sentence} for run in runs]
    per_sentence = []
    for j, key in enumerate(keys):
        row = {"subject": key[0], "sentence": key[1]}
        for name, values in combined_values.items():
            row[name] = float(values[j])
        # per-sentence values of metrics outside the registry's sentence level (a custom evaluation's)
        for name in runs[0].per_sentence[j]:
            if name in row or name in ("subject", "sentence"):
                continue
            values = [rows.get(key, {}).get(name) for rows in rows_by_seed]
            if all(_finite(v) for v in values):
                row[name] = float(np.mean(values))
        per_sentence.append(row)

    per_seed = []
    for run in runs:
        record = {"seed": int(run.seed), "metrics": {n: float(run.metrics[n]["mean"]) for n in run.metrics},
                  "per_sentence": [dict(r) for r in run.per_sentence], "replicates": set_replicates[run.seed]}
        if run.convergence is not None:
            record["convergence"] = run.convergence
        per_seed.append(record)
    convergence = combined_convergence([run.convergence for run in runs], metrics)
    return CombinedScores(metrics=metrics, per_sentence=per_sentence, per_seed=per_seed, convergence=convergence,
                          bootstrap={"resamples": int(resamples), "stream": int(stream)})


def summed_timings(runs) -> dict:
    """The seeds' seconds per step added up (None for a step no seed timed)."""
    timings = {}
    for key in ("train_s", "load_s", "generate_s", "evaluate_s", "convergence_s"):
        values = [run.timings.get(key) for run in runs if run.timings.get(key) is not None]
        timings[key] = float(sum(values)) if values else None
    return timings


def _seed_checkpoint(checkpoint, seed: int):
    """Where seed ``seed``'s trained method is saved: ``<checkpoint>/seed<k>`` (None: nowhere)."""
    if checkpoint is None:
        return None
    return Path(os.fspath(checkpoint)).expanduser() / seed_folder_name(seed)


def run_seeds(spec, inputs, *, evaluate=None, provenance: dict, started: float | None = None) -> Path:
    """Train, generate and score ``spec.method`` once per seed of ``spec.seeds`` and store
    them as one result (:func:`benchmark.protocol.storing.store_seeds`); nothing is
    written when any seed fails.

    Parameters
    ----------
    spec : RunSpec
        With ``seeds``; each seed's run is ``spec`` with ``seed`` set to it.
    inputs : Inputs
        From ``check_inputs(spec)`` (which refused methods that do not train).
    evaluate : callable, optional
        As for :func:`benchmark.protocol.run`.
    provenance : dict
    started : float, optional
        ``time.perf_counter()`` when the run began (for ``timings.total_s``).

    Returns
    -------
    Path
        The result file.
    """
    started = time.perf_counter() if started is None else started
    if spec.seeds is None:
        raise UsageError("run_seeds: the run spec names no seeds (--seeds)")
    runs, writer, first_trained, reasons = [], None, None, []
    try:
        for seed in spec.seeds:
            seed_spec = dataclasses.replace(spec, seed=int(seed), seeds=None,
                                            checkpoint=_seed_checkpoint(spec.checkpoint, seed))
            check, reason = half_budget_check(seed_spec, inputs, evaluate=evaluate)
            trained = train(seed_spec, inputs.dataset, check=check)
            if writer is None:
                first_trained = trained
                writer = track_writer(spec, inputs, trained)
            generated = generate(seed_spec, inputs.dataset, trained, store=writer.for_seed(seed))
            scored = score(seed_spec, inputs.dataset, generated, evaluate=evaluate)
            convergence, reason = checked_convergence(check, reason, scored.metrics)
            reasons.append(reason)
            runs.append(SeedRun.scored(seed, generated, scored, convergence=convergence, timings=trained.timings))
            del generated, scored  # the tracks are on disk; keep one seed's in memory at a time
        combined = combined_seed_scores(runs, stream=seed_stream(first_trained.label))
        timings = {**summed_timings(runs), "total_s": time.perf_counter() - started}
        # checked only when every seed was; else the first seed's reason
        reason = next((r for r in reasons if r != CHECKED), CHECKED)
        return store_seeds(spec, inputs, first_trained, runs, combined, writer=writer, timings=timings,
                           provenance=provenance, convergence_check=reason)
    except BaseException:
        if writer is not None:
            writer.discard()
        raise
