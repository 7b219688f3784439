"""The typed parts of a result file (schema 3) and the record that holds them.

Each class is one JSON object of the file (:class:`~benchmark.results.parts.Part`);
its fields are the keys the code reads, checked when the file is read. Keys a part
does not declare are kept in its ``extra`` and written back unchanged.

**Adding an optional part** (a study's human-preference results, latency probes,
learning curves): declare a :class:`~benchmark.results.parts.Part` subclass here with
its fields (each an :func:`~benchmark.results.parts.item` with its check), add a field
``name: NewPart | None = item(part(NewPart))`` to :class:`Result`, document it in the
schema of :mod:`benchmark.results`, and give its round trip a test. Files without it
stay valid (None), so ``SCHEMA_VERSION`` does not change; a part's new field that
older files lack is optional in the same way.

**Settings and digests.** :meth:`Result.settings` is what of a result decides its
numbers (the method's config, the split, samples, seeds, budget, clipping, checkpoint,
VAE, lip-sync models, sentence batch, device); :meth:`Result.settings_digest` hashes it.
The file name carries that digest (``__c<digest>``, :func:`result_filename`) for every
run that is not a plain ``benchmark.run --method NAME`` (benchmark.protocol.storing), and
a writer refuses to replace a result of other settings (``--overwrite``).
:meth:`Result.record_digest` hashes the measured part (``metrics``, ``per_sentence``,
``per_seed``, ``convergence``); a run stores it in the optional ``protocol.record_sha256``,
so a file whose numbers were edited by hand (a mean and its interval together) no longer
matches it (:meth:`Result.edited`; the leaderboard refuses such a file).
"""

from __future__ import annotations

import hashlib
import json
import re
from dataclasses import dataclass

import numpy as np

from benchmark.results.parts import (
    Invalid,
    Located,
    Part,
    anything,
    integer,
    integers,
    item,
    list_of,
    mapping_of,
    number,
    numbers,
    obj,
    optional,
    pair,
    part,
    seconds,
    short,
    string,
    truth,
)

__all__ = ["LATENCY_FIELDS", "LOOKAHEAD_FIELDS", "METRIC_FIELDS", "SCHEMA_VERSION", "Convergence", "CurvePoint",
           "DatasetInfo", "Latency", "LookaheadCut", "LookaheadProbe", "HumanPreference", "MethodInfo", "MetricCheck",
           "MetricEntry", "PreferenceEntry", "Protocol", "Provenance", "Result", "SeedRecord",
           "SETTINGS_PROTOCOL_KEYS", "replicates_array", "result_filename", "seed_replicates", "settings_digest"]

SCHEMA_VERSION = 3
#: Fields every metric entry writes (``std`` and ``unit`` may be null / "").
METRIC_FIELDS = ("mean", "std", "higher_is_better", "unit")
#: Fields of a result's optional ``latency`` section, seconds or null.
LATENCY_FIELDS = ("lookahead_s", "first_frame_s", "compute_per_audio_s", "rtf")
#: Fields the look-ahead probe adds to ``latency`` (absent in files written before it).
LOOKAHEAD_FIELDS = ("measured_lookahead_s", "lookahead_probe")


def _sentence_row(value, where):
    """A per-sentence row: ``{"subject", "sentence", metric: value, ...}`` (kept as a dict)."""
    if not isinstance(value, dict):
        raise Invalid("an object", value)
    for key in ("subject", "sentence"):
        if not isinstance(value.get(key), str):
            raise Located(f"{where}.{key}: expected a string, got {short(value.get(key))}")
    if "metrics" in value and not isinstance(value["metrics"], dict):
        raise Located(f"{where}.metrics: expected an object, got {short(value['metrics'])}")
    return value


_rows = list_of(_sentence_row)


@dataclass(frozen=True, kw_only=True)
class MethodInfo(Part):
    """``method``: the plug-in that ran and how it was configured."""

    name: str = item(string, required=True)
    #: The row's label in the tables (its ``name`` when None: :attr:`display_label`).
    label: str | None = item(string)
    #: ``module:qualname`` of the method's class.
    class_path: str | None = item(string, key="class")
    stochastic: bool | None = item(truth)
    #: A reference row (ground truth, corpus meshes, mean ...): shown apart, never ranked.
    reference: bool | None = item(truth)
    #: ``"coefficients"`` or ``"vertices"``.
    output: str | None = item(string)
    #: The method's ``config()``.
    config: object = item(anything, required=True)

    @property
    def display_label(self) -> str:
        """``label``, else ``name``."""
        return self.label or self.name


@dataclass(frozen=True, kw_only=True)
class DatasetInfo(Part):
    """``dataset``: the build scored (its identity) and the split."""

    #: The dataset's identity (:func:`blendvoca.format.dataset_id`): names the file, keys the table.
    recipe_id: str | None = item(string)
    #: Content hash of the files scored (for information; differs between BLAS kernels).
    manifest_hash: str | None = item(string)
    #: The BlendVOCA root the run read (stored runs find their data here).
    path: str | None = item(string)
    #: The split scored (``"test"``).
    split: str | None = item(string)
    #: Speakers and sentences scored.
    num_subjects: int | None = item(integer)
    num_sentences: int | None = item(integer)
    #: Another corpus than VOCASET: its name and title.
    name: str | None = item(string)
    title: str | None = item(string)
    #: Latent metrics computed with a VAE trained on another corpus.
    latent_out_of_domain: bool | None = item(truth)

    def validate(self, value, where):
        if not self.recipe_id and not self.manifest_hash:
            raise Invalid("lacks 'recipe_id' (and 'manifest_hash')")

    @property
    def key(self) -> str:
        """The dataset's identity: ``recipe_id``, or for a result written before recipe ids
        existed its ``manifest_hash``."""
        return str(self.recipe_id or self.manifest_hash)

    @property
    def display_name(self) -> str:
        """Its ``title``, else its ``name``, else ""."""
        return str(self.title or self.name or "")


@dataclass(frozen=True, kw_only=True)
class Protocol(Part):
    """``protocol``: how the run was made. The typed fields are those the tables and
    file names read; the rest (``budget``, ``clip``, ``checkpoint``, the evaluation's
    settings ...) is kept in ``extra`` as the run wrote it."""

    samples: int | None = item(integer)
    seed: int | None = item(integer)
    #: Training seeds of a run over several.
    seeds: tuple | None = item(integers)
    #: ``{model: {"path", "sha256", "weights_sha256"?, ...}}`` of the lip-sync models that scored it.
    lipsync_models: dict | None = item(obj)
    latent_out_of_domain: bool | None = item(truth)
    #: ``"checked"``, or why the half-budget check did not run.
    convergence_check: str | None = item(string)

    def get(self, key: str, default=None):
        """A protocol field by its JSON name, typed or not."""
        value = getattr(self, key, None) if key in _PROTOCOL_FIELDS else self.extra.get(key)
        return default if value is None else value


_PROTOCOL_FIELDS = ("samples", "seed", "seeds", "lipsync_models", "latent_out_of_domain", "convergence_check")


@dataclass(frozen=True, kw_only=True)
class MetricEntry(Part):
    """One metric of ``metrics``: the row's value and what is needed to compare it."""

    mean: float = item(number, required=True)
    std: float | None = item(number, always=True)
    #: True, False, or None for a metric without a direction (written as null).
    higher_is_better: bool | None = item(truth, always=True, present=True)
    unit: str | None = item(string, always=True)
    ci95: list | None = item(pair)
    #: Sentences (the set-level metrics' resampling unit).
    n: float | None = item(number)
    label: str | None = item(string)
    group: str | None = item(string)
    #: Bootstrap replicates (set-level metrics).
    replicates: tuple | None = item(numbers)
    #: ``[lowest, highest]`` of the per-seed means (rows trained with several seeds).
    seed_range: list | None = item(pair)
    n_seeds: int | None = item(integer)
    sample_std: float | None = item(number)

    def validate(self, value, where):
        if self.ci95 is not None and not self.ci95[0] <= self.mean <= self.ci95[1]:
            raise Invalid(f"ci95 {list(self.ci95)} does not bracket the mean {self.mean}")


@dataclass(frozen=True, kw_only=True)
class MetricCheck(Part):
    """One metric of the half-budget check: its values at half and full budget."""

    half_budget: float | None = item(number)
    full_budget: float | None = item(number)
    half_width: float | None = item(number)
    settled: bool | None = item(truth)


@dataclass(frozen=True, kw_only=True)
class CurvePoint(Part):
    """One checkpoint of ``convergence.curve``: the check metrics as the method was after ``step``."""

    step: int = item(integer, required=True)
    #: ``{metric: value}``.
    metrics: dict = item(mapping_of(number, "an object of metric -> number"), required=True)
    #: ``{metric: [value per sentence of convergence.sentences]}`` (sentence-level metrics).
    per_sentence: dict | None = item(mapping_of(numbers, "an object of metric -> list"))
    #: ``{metric: bootstrap replicates}`` (set-level metrics).
    replicates: dict | None = item(mapping_of(numbers, "an object of metric -> list"))


def _sentence_keys(value, where):
    if not isinstance(value, list) or not all(isinstance(k, list) and len(k) == 2 and all(isinstance(x, str) for x in k)
                                              for k in value):
        raise Invalid("a list of [subject, sentence]", value)
    return tuple(tuple(k) for k in value)


@dataclass(frozen=True, kw_only=True)
class Convergence(Part):
    """``convergence``: the row's learning curve (:mod:`benchmark.protocol.convergence`) and
    the move between half and full budget; the statements of the table that the
    half-budget values would change (:mod:`leaderboard.settled`) once a table was built."""

    #: Every check metric moved by at most its interval's half-width (information; the
    #: tables' † is :mod:`leaderboard.settled`'s rule).
    settled: bool | None = item(truth)
    checked_at_step: int | None = item(integer)
    total_steps: int | None = item(integer)
    metrics: dict | None = item(mapping_of(part(MetricCheck), "an object of metric -> check"))
    #: The row whose training this row scores (its verdict).
    shared_with: str | None = item(anything)
    #: The order of every curve point's ``per_sentence`` values.
    sentences: tuple | None = item(_sentence_keys)
    #: The learning curve's checkpoints before the full budget, by step.
    curve: tuple | None = item(list_of(part(CurvePoint), "a list of objects"))
    #: The table's statements the half-budget values would change (written by
    #: ``python -m leaderboard.settled --store``; derived from the table, not measured:
    #: outside :meth:`Result.record_digest`).
    statements: tuple | None = item(list_of(string, "a list of strings"))

    def unsettled(self) -> list:
        """``[(metric, half_budget, full_budget, half_width)]`` of the checked metrics that failed."""
        return [(name, c.half_budget, c.full_budget, c.half_width) for name, c in (self.metrics or {}).items()
                if c.settled is False]


@dataclass(frozen=True, kw_only=True)
class SeedRecord(Part):
    """One training seed of ``per_seed``: enough to recombine the seeds later."""

    seed: int | None = item(integer)
    #: ``{metric: the seed's mean}``.
    metrics: dict | None = item(mapping_of(optional(number), "an object of metric -> number"))
    per_sentence: tuple | None = item(_rows)
    #: ``{set-level metric: bootstrap replicates}``.
    replicates: dict | None = item(mapping_of(numbers, "an object of metric -> list"))
    convergence: Convergence | None = item(part(Convergence))
    tracks: str | None = item(string)
    n_clipped: int | None = item(integer)
    timings: dict | None = item(obj)


@dataclass(frozen=True, kw_only=True)
class LookaheadCut(Part):
    """One cut of the look-ahead probe (:mod:`benchmark.protocol.lookahead`)."""

    subject: str | None = item(string)
    sentence: str | None = item(string)
    duration_s: float | None = item(seconds)
    #: Where the audio was replaced (silence, then noise), seconds from the start.
    cut_s: float | None = item(seconds)
    #: The earliest output frame that changed, seconds (null: none did).
    changed_from_s: float | None = item(optional(seconds), always=True)
    #: ``cut_s - changed_from_s`` (0 when nothing changed; the utterance's length for ``whole_utterance``).
    lookahead_s: float | None = item(seconds)
    #: The first frame changed: the output depends on audio as far as the probe sees.
    whole_utterance: bool | None = item(truth)


@dataclass(frozen=True, kw_only=True)
class LookaheadProbe(Part):
    """``latency.lookahead_probe``: how ``measured_lookahead_s`` was measured."""

    probes: tuple | None = item(list_of(part(LookaheadCut), "a list of objects"))
    #: The measured look-ahead is the whole utterance (a probe's first frame changed).
    whole_utterance: bool | None = item(truth)
    #: One frame: the probe's resolution and the tolerance of :meth:`Latency.exceeds_declaration`.
    frame_s: float | None = item(seconds)
    #: Its cost: ``generate`` calls (one sample each) and their wall seconds.
    generate_calls: int | None = item(integer)
    wall_s: float | None = item(seconds)
    #: What counted as a change (absolute, on the output's values).
    tolerance: float | None = item(number)
    #: Why nothing was measured (null when it was).
    note: str | None = item(string)


@dataclass(frozen=True, kw_only=True)
class Latency(Part):
    """``latency`` (:func:`benchmark.protocol.generation.measure_latency`; seconds, null
    where not known): depends on the machine, like ``timings``."""

    OPEN = False
    #: Audio the method needs before its first frame (None: the whole utterance).
    lookahead_s: float | None = item(seconds, always=True)
    #: Wall time to the first frame.
    first_frame_s: float | None = item(seconds, always=True)
    #: CPU time per second of audio.
    compute_per_audio_s: float | None = item(seconds, always=True)
    #: Real-time factor: wall seconds of generation per second of audio.
    rtf: float | None = item(seconds, always=True)
    #: The look-ahead the method was seen to use (the causality probe); absent in files
    #: written before it, null where it could not be measured.
    measured_lookahead_s: float | None = item(seconds)
    lookahead_probe: LookaheadProbe | None = item(part(LookaheadProbe))

    def exceeds_declaration(self) -> bool:
        """Whether ``measured_lookahead_s`` is more than one frame beyond ``lookahead_s``
        (a method declaring none, i.e. the whole utterance, never is)."""
        if self.measured_lookahead_s is None or self.lookahead_s is None:
            return False
        frame = (self.lookahead_probe.frame_s if self.lookahead_probe is not None else None) or 1.0 / 60
        return self.measured_lookahead_s > self.lookahead_s + frame + 1e-9


@dataclass(frozen=True, kw_only=True)
class PreferenceEntry(Part):
    """One question of ``human_preference``: this row against the study's reference row."""

    #: Share of the answers preferring this row to the reference, and its 95 % interval (crossed bootstrap).
    share: float | None = item(number)
    ci95: list | None = item(pair)
    #: Answers comparing the two rows.
    answers: int | None = item(integer)
    #: Bradley-Terry log-strength relative to the reference (studies of more than two rows).
    log_strength: float | None = item(number)
    strength_ci95: list | None = item(pair)
    #: Mean opinion score (1-5) and its interval (MOS studies).
    mos: float | None = item(number)
    mos_ci95: list | None = item(pair)


@dataclass(frozen=True, kw_only=True)
class HumanPreference(Part):
    """``human_preference``: a perceptual study's verdict on this row, stored by
    ``python -m benchmark.study analyze STUDY --board DIR --store`` (the leaderboard's
    "human preference" column reads it). Not part of what a rerun reproduces."""

    #: The study's name (its folder's name) and the row every row was compared with.
    study: str = item(string, required=True)
    reference: str | None = item(string)
    design: str | None = item(string)
    #: Participants kept after the exclusions.
    participants: int | None = item(integer)
    date: str | None = item(string)
    #: ``{question: PreferenceEntry}`` in the study's order (lipsync, realism, ...).
    questions: dict = item(mapping_of(part(PreferenceEntry)), required=True)


@dataclass(frozen=True, kw_only=True)
class Provenance(Part):
    """``provenance``: the code and machine when the run started."""

    #: ISO 8601, UTC.
    date: str | None = item(string)
    git_revision: str | None = item(string)
    #: Uncommitted changes outside the output folders.
    git_dirty: bool | None = item(truth)
    #: Python version and platform string.
    python: str | None = item(string)
    platform: str | None = item(string)
    #: ``{distribution: version}``.
    versions: dict | None = item(obj)
    #: CPU, cores, BLAS kernels, GPU.
    hardware: dict | None = item(obj)


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9._-]+", "-", str(text).lower()).strip("-") or "method"


#: Length of the settings digest in a file name (hex digits).
SETTINGS_DIGEST_CHARS = 10
#: The ``protocol`` keys that change a result's numbers (with ``method.config`` and
#: ``dataset.split``: :meth:`Result.settings`). Machine-dependent or informative keys
#: (timings, ``generate_time_limit``, ``n_clipped``, the evaluation's records) are not among them.
SETTINGS_PROTOCOL_KEYS = ("samples", "seed", "seeds", "budget", "clip", "checkpoint_sha256", "vae",
                          "lipsync_models", "sentence_batch", "device")


def _canonical_digest(value) -> str:
    text = json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def settings_digest(settings: dict) -> str:
    """The first :data:`SETTINGS_DIGEST_CHARS` hex digits of the sha256 of ``settings``
    (:meth:`Result.settings`) as canonical JSON."""
    return _canonical_digest(settings)[:SETTINGS_DIGEST_CHARS]


def result_filename(label: str, dataset_key: str, samples, seed, seeds=None, settings: str | None = None) -> str:
    """``<label>__<dataset key[:12]>__s<samples>__seed<seed>.json`` (one file per run
    setting; :attr:`Result.key`); a run over several training seeds ends ``__seeds0-1-2.json``;
    with ``settings`` (a :func:`settings_digest`), ``__c<settings>`` before ``.json``."""
    tail = f"seeds{'-'.join(str(int(s)) for s in seeds)}" if seeds else f"seed{seed}"
    digest = f"__c{_slug(settings)}" if settings else ""
    return f"{_slug(label)}__{_slug(dataset_key)[:12]}__s{samples}__{tail}{digest}.json"


def replicates_array(values) -> np.ndarray | None:
    """Bootstrap replicates as a flat float64 array; None when absent, empty or not all finite."""
    if values is None:
        return None
    values = np.asarray(values, dtype=np.float64).ravel()
    return values if values.size and np.all(np.isfinite(values)) else None


def seed_replicates(name: str, per_seed, own=None) -> list | None:
    """Per training seed, the bootstrap replicates of ``name``: each seed's
    ``replicates[name]`` (``per_seed``: one ``{metric: replicates}`` per seed) when every
    seed has them, else ``own`` (the metric's replicates, a one-seed row's) as one seed;
    None when neither."""
    arrays = [replicates_array((stored or {}).get(name)) for stored in per_seed]
    if arrays and all(a is not None for a in arrays):
        return arrays
    own = replicates_array(own)
    return None if own is None else [own]


@dataclass(frozen=True, kw_only=True)
class Result(Part):
    """One result file: a benchmark run with its provenance (the schema: :mod:`benchmark.results`)."""

    schema_version: int = item(integer, required=True)
    method: MethodInfo = item(part(MethodInfo), required=True)
    dataset: DatasetInfo = item(part(DatasetInfo), required=True)
    protocol: Protocol = item(part(Protocol), required=True)
    metrics: dict = item(mapping_of(part(MetricEntry)), required=True)
    provenance: Provenance = item(part(Provenance), required=True)
    #: Seconds per step (``train_s``, ``load_s``, ``generate_s``, ``evaluate_s``, ``total_s`` ...).
    timings: dict = item(obj, required=True)
    per_sentence: tuple | None = item(_rows)
    #: Training seeds of a run over several (``per_seed`` holds each).
    seeds: tuple | None = item(integers)
    per_seed: tuple | None = item(list_of(part(SeedRecord), "a list of objects"))
    convergence: Convergence | None = item(part(Convergence))
    latency: Latency | None = item(part(Latency))
    #: The stored tracks folder, relative to the JSON's folder (:mod:`benchmark.runs`).
    tracks: str | None = item(string)
    #: A perceptual study's verdict on this row (:class:`HumanPreference`).
    human_preference: HumanPreference | None = item(part(HumanPreference))

    def validate(self, value, where):
        if not self.metrics:
            raise Invalid("expected a non-empty 'metrics' object of metric -> fields")

    @property
    def key(self) -> str:
        """The dataset's identity (:attr:`DatasetInfo.key`): the table the result belongs to."""
        return self.dataset.key

    @property
    def label(self) -> str:
        """The row's label (``method.label``, else its name)."""
        return self.method.display_label

    def training_seeds(self) -> list:
        """The training seeds of a result trained with several: its ``seeds`` (or ``protocol.seeds``); else empty."""
        seeds = self.seeds if self.seeds is not None else self.protocol.seeds
        return list(seeds or [])

    def filename(self, *, with_settings: bool = False) -> str:
        """The file name of this result (:func:`result_filename`); ``with_settings``: with
        its :meth:`settings_digest` (what every run but a plain one is named with)."""
        return result_filename(self.label, self.key, self.protocol.samples, self.protocol.seed,
                               self.protocol.seeds, self.settings_digest() if with_settings else None)

    def settings(self) -> dict:
        """What decides this result's numbers: ``{"method", "config", "split", <protocol
        keys of SETTINGS_PROTOCOL_KEYS>}`` as the file holds them (a checkpoint by its
        content digest, else its path; the VAE and lip-sync models by their digests)."""
        record = self.protocol.to_json()
        out = {"method": self.method.name, "config": self.method.config, "split": self.dataset.split}
        for key in SETTINGS_PROTOCOL_KEYS:
            if record.get(key) is not None:
                out[key] = record[key]
        if record.get("checkpoint_sha256") is None and record.get("checkpoint") is not None:
            out["checkpoint"] = record["checkpoint"]
        if isinstance(out.get("vae"), dict):
            out["vae"] = out["vae"].get("sha256")
        if isinstance(out.get("lipsync_models"), dict):
            out["lipsync_models"] = {name: (model.get("weights_sha256") or model.get("sha256") or model.get("path"))
                                     if isinstance(model, dict) else model
                                     for name, model in out["lipsync_models"].items()}
        return out

    def settings_digest(self) -> str:
        """:func:`settings_digest` of :meth:`settings`."""
        return settings_digest(self.settings())

    def record_digest(self) -> str:
        """sha256 of the measured part of the record (``metrics``, ``per_sentence``,
        ``per_seed``, ``convergence``) and its :meth:`settings`, as canonical JSON:
        what ``protocol.record_sha256`` holds for a file as the run wrote it."""
        record = self.to_json()
        if isinstance(record.get("convergence"), dict):  # the table's verdict, not a measurement
            record["convergence"] = {k: v for k, v in record["convergence"].items() if k != "statements"}
        return _canonical_digest({"settings": self.settings(),
                                  **{key: record.get(key) for key in ("metrics", "per_sentence", "per_seed",
                                                                       "convergence")}})

    def edited(self) -> bool:
        """True when the file holds a ``protocol.record_sha256`` that its numbers no longer
        match (edited by hand since the run wrote it); False when it matches or holds none
        (a file written before the digest was stored)."""
        stored = self.protocol.get("record_sha256")
        return stored is not None and stored != self.record_digest()

    def seed_replicates(self, name: str) -> list | None:
        """Per training seed, the stored bootstrap replicates of ``name``
        (:func:`seed_replicates` of ``per_seed[k].replicates``, else the metric's own)."""
        entry = self.metrics.get(name)
        return seed_replicates(name, [s.replicates for s in self.per_seed or ()],
                               None if entry is None else entry.replicates)
