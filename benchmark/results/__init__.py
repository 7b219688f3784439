"""Result files: one JSON per benchmark run, with its provenance; the one owner of the format.

:func:`read`, :func:`write` and :func:`check` are the only ways in and out: a file is
read into a typed, frozen :class:`Result` (its parts in :mod:`benchmark.results.record`)
and checked once, here; :func:`build_result` makes a new one from a run's parts.

Schema (``schema_version`` 3)::

    {
      "schema_version": 3,
      "method":   {"name", "label", "class", "stochastic", "reference", "output", "config"},
      "dataset":  {"recipe_id", "manifest_hash", "path", "split", "num_sentences", "num_subjects",
                   "name"?, "title"?, "latent_out_of_domain"?},
      "protocol": {"samples", "seed", "seeds"?, "budget", "clip", "n_clipped", "deterministic",
                   "generate_time_limit", "checkpoint", "checkpoint_sha256"?, "verified",
                   "sentence_batch"?, "lipsync_models"?: {model: {"path", "sha256", ...}},
                   "convergence_check"?, "seed_bootstrap"?, "threads"?: {"torch": n},
                   "motionless_sentences"?, "record_sha256"?, the evaluation's settings ...},
      "metrics":  {metric: {"mean", "std", "ci95", "n", "higher_is_better", "unit", "label", "group",
                            "replicates"? (set-level metrics), "seed_range"?, "n_seeds"? (several seeds)}},
      "per_sentence": [{"subject", "sentence", metric: value, ...}],
      "seeds"?:    [seed, ...],
      "per_seed"?: [{"seed", "metrics": {metric: mean}, "per_sentence", "replicates", "convergence"?,
                     "tracks", "n_clipped", "timings"}],
      "convergence"?: {"settled", "checked_at_step", "total_steps", "shared_with"?,
                       "metrics": {metric: {"half_budget", "full_budget", "half_width", "settled"}},
                       "sentences"?: [[subject, sentence], ...],
                       "curve"?: [{"step", "metrics": {metric: value}, "per_sentence"?: {metric: [...]},
                                   "replicates"?: {metric: [...]}}],
                       "statements"?: [the table's statements the half-budget values would change]},
      "tracks":   "<run>"   (stored tracks folder, relative to the JSON; benchmark.runs)
      "provenance": {"date", "git_revision", "git_dirty", "python", "platform",
                     "versions": {package: version}, "hardware": {...}},
      "timings":  {"train_s", "load_s", "generate_s", "evaluate_s", "total_s"},
      "latency"?: {"lookahead_s", "first_frame_s", "compute_per_audio_s", "rtf", "measured_lookahead_s"?,
                   "lookahead_probe"?: {"probes": [{"subject", "sentence", "duration_s", "cut_s",
                                                    "changed_from_s", "lookahead_s", "whole_utterance"}],
                                        "whole_utterance", "generate_calls", "wall_s", "tolerance",
                                        "frame_s", "note"}},
      "human_preference"?: {"study", "reference", "design", "participants", "date",
                            "questions": {question: {"share", "ci95", "answers", "log_strength",
                                                     "strength_ci95", "mos", "mos_ci95"}}}
    }

Fields marked ``?`` are optional; a part keeps the fields it does not type as
written. ``latency`` (:func:`benchmark.protocol.generation.measure_latency`; seconds,
null where not known; ``measured_lookahead_s``: the look-ahead the causality probe saw the
method use, :mod:`benchmark.protocol.lookahead`) and ``timings`` depend on the machine: they are not part of what
a rerun must reproduce (the metrics and per-sentence values). Nor is ``human_preference``,
a perceptual study's verdict on the row (``python -m benchmark.study analyze --board DIR
--store``; each question's share of answers preferring this row to the study's reference,
Bradley-Terry strength and MOS with their intervals), which the leaderboard shows as a column.

``dataset.recipe_id`` is the dataset's identity (:func:`blendvoca.format.dataset_id`);
it names the file and keys the leaderboard section (:attr:`Result.key`). A run with
other settings than a plain one adds their digest to the name (``__c<digest>``,
:meth:`Result.settings_digest`); ``protocol.record_sha256`` (:meth:`Result.record_digest`)
lets the leaderboard refuse a file whose numbers were edited by hand (details:
:mod:`benchmark.results.record`).
``dataset.manifest_hash`` is the content hash of the files scored, for information.

Schema 3 holds the fields schema 2 held; ``python -m benchmark.results upgrade FILE...``
rewrites a schema-2 file as schema 3 (:mod:`benchmark.results.__main__`). Schema-1 files
(protocol v2) are refused: their numbers come from an older protocol. Adding an optional
part: see :mod:`benchmark.results.record`. Tables are only ever rendered from these
files (``python -m leaderboard.build``).
"""

from benchmark.results.files import build_result, check, read, write
from benchmark.results.provenance import (
    OUTPUT_FOLDERS,
    VERSIONED_PACKAGES,
    current_provenance,
    git_revision,
    hardware_info,
    package_versions,
)
from benchmark.results.record import (
    LATENCY_FIELDS,
    LOOKAHEAD_FIELDS,
    METRIC_FIELDS,
    SCHEMA_VERSION,
    Convergence,
    DatasetInfo,
    HumanPreference,
    Latency,
    MethodInfo,
    MetricCheck,
    MetricEntry,
    PreferenceEntry,
    Protocol,
    Provenance,
    Result,
    SeedRecord,
    replicates_array,
    result_filename,
    seed_replicates,
)

__all__ = [
    "LATENCY_FIELDS", "LOOKAHEAD_FIELDS", "METRIC_FIELDS", "OUTPUT_FOLDERS", "SCHEMA_VERSION", "VERSIONED_PACKAGES", "Convergence",
    "DatasetInfo", "HumanPreference", "Latency", "MethodInfo", "MetricCheck", "MetricEntry", "PreferenceEntry",
    "Protocol", "Provenance", "Result",
    "SeedRecord", "build_result", "check", "current_provenance", "git_revision", "hardware_info",
    "package_versions", "read", "replicates_array", "result_filename", "seed_replicates", "write",
]
