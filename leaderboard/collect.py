"""Reading result files and arranging them into per-dataset tables.

Columns are the metrics of the results, grouped and ordered by the metric registry
(:mod:`benchmark.evaluation.registry`: lip sync, distribution, vertex, energy, diversity,
as in the SAiD paper's Table 1); rows are the methods, and the reference rows (ground
truth, corpus meshes, mean, static, random) apart, never ranked.

Whether a trained row is settled is judged here too, as the statements are the table's
(:mod:`leaderboard.settled`: its half-budget values put in place of its full-budget ones
would change an order, the bold or its side of a reference row).

Ordering statements come from resampling (:mod:`benchmark.metrics.bootstrap`): a
method is marked best in a column only where it beats the runner-up in at least 95 %
of paired resamples (:func:`best_mark`), and :func:`pairwise_probabilities` gives the
probability of improvement between any two rows. What is read for that:

- sentence-level metrics: the rows' ``per_sentence`` values on their common
  sentences, or each training seed's ``per_seed[k].per_sentence`` for rows trained
  with several seeds (two-level: seeds, then sentences within each);
- set-level metrics (FD, WInD, multimodality): each seed's
  ``per_seed[k].replicates[metric]``, else the metric's ``replicates``;
- neither stored (files from before protocol v3): the non-overlap of the two 95 %
  intervals, as before, and the tables say so.
"""

from __future__ import annotations

import math
import os
import unicodedata
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmark.evaluation.latent import METRICS as LATENT_METRICS
from benchmark.evaluation.registry import METRICS, ordered_metrics
from benchmark.metrics.bootstrap import (
    probability_of_improvement,
    two_level_mean_replicates,
    two_level_replicates,
)
from benchmark.results import Convergence, MetricEntry, Result, read
from blendvoca.errors import DataError, UserError

__all__ = [
    "BEST_PROBABILITY",
    "DEFAULT_RESULTS_DIR",
    "MIN_PAIRED_SENTENCES",
    "unpaired_reason",
    "ORDER_RESAMPLES",
    "BestMark",
    "Column",
    "Row",
    "Table",
    "best_mark",
    "check_corpora",
    "check_latent_models",
    "check_records",
    "check_scoring_models",
    "column_decimals",
    "load_results",
    "pair_replicates",
    "pairwise_probabilities",
    "ranks",
    "result_files",
    "tables_by_manifest",
]

#: The committed result files (the default of the commands that read them).
DEFAULT_RESULTS_DIR = Path(__file__).resolve().parent / "results"

#: A method is marked best only where it beats the runner-up in at least this fraction of the resamples.
BEST_PROBABILITY = 0.95
#: Resamples behind the best marks and the probabilities of improvement.
ORDER_RESAMPLES = 2000
#: Fewest sentences resampled for an ordering: with 4, a difference of one sign on every
#: sentence wins every resample although a sign test gives it p = 1/16; from 5 on a
#: difference that consistent is significant (1/32).
MIN_PAIRED_SENTENCES = 5

#: Group of metrics the registry does not know.
OTHER_GROUP = "other"


@dataclass(frozen=True)
class Column:
    """One metric column."""

    name: str
    label: str
    unit: str
    higher_is_better: bool | None
    group: str


@dataclass
class Row:
    """One method's line: ``metrics[name] = (mean, std or None, ci95 [lo, hi] or None)``."""

    label: str
    reference: bool
    samples: int
    metrics: dict = field(default_factory=dict)
    output: str = "coefficients"
    #: Position of the row's result in the list given to :func:`tables_by_manifest`.
    source: int | None = None
    #: ``{metric: (lowest, highest)}`` of the per-seed means, for rows trained with several seeds.
    seed_ranges: dict = field(default_factory=dict)
    #: Training seeds of a row trained with several (the result's ``seeds``), else empty.
    seeds: tuple = ()
    #: The result's ``convergence`` record (None for rows that do not train).
    convergence: Convergence | None = None
    #: The result record (its per-sentence rows and replicates feed the resampling).
    result: Result | None = field(default=None, repr=False, compare=False)
    #: The table's statements its half-budget values would change (:mod:`leaderboard.settled`,
    #: filled when the table is built); None: not judged (no half-budget record of its own).
    statements: list | None = field(default=None, compare=False)

    @property
    def settled(self) -> bool | None:
        """Settled by ranking: False when its half-budget values would change a statement of
        the table (:attr:`statements`), True when none; for a row not judged, its record's
        ``convergence.settled``; None when not checked."""
        if self.convergence is None:
            return None
        if self.statements is not None:
            return not self.statements
        return self.convergence.settled

    def unsettled_metrics(self) -> list:
        """``[(metric, half_budget, full_budget, half_width)]`` of the checked metrics that moved
        by more than their interval's half-width between the half and the full budget."""
        return [] if self.convergence is None else self.convergence.unsettled()

    def unsettled_seeds(self, name: str) -> list:
        """``[(seed, half_budget, full_budget, half_width)]`` of the seeds whose own check of
        ``name`` failed (the result's ``per_seed[k].convergence``), in the result's seed order;
        empty for a row without per-seed checks."""
        out = []
        for record in (self.result.per_seed if self.result is not None else None) or ():
            for metric, *values in (record.convergence.unsettled() if record.convergence else ()):
                if metric == name and values[0] is not None and values[1] is not None:
                    out.append((record.seed, *values))
        return out


@dataclass
class Table:
    """All results on one dataset (one recipe id, :attr:`benchmark.results.Result.key`)."""

    #: The section's key: the dataset's recipe id (a result without one: its content hash).
    #: The field keeps the name it had when sections were keyed by the content hash.
    manifest_hash: str
    split: str
    num_sentences: int | None
    columns: list  # [Column] in registry order
    rows: list  # [Row] methods, sorted by label
    references: list  # [Row] reference rows, sorted by label
    #: The dataset's display name (its results' ``dataset.title`` or ``dataset.name``; "" for results without one).
    name: str = ""
    #: Latent metrics computed with a VAE trained on another dataset (a result's ``latent_out_of_domain``).
    latent_out_of_domain: bool = False
    #: The sha256 of the VAE given to the runs (``protocol.vae``) that scored the latent metrics; "": the published one.
    vae: str = ""

    @property
    def recipe_id(self) -> str:
        """The section's dataset identity (the same value as :attr:`manifest_hash`)."""
        return self.manifest_hash

    @property
    def groups(self) -> list:
        """``[(group, [Column])]`` in table order."""
        out = []
        for column in self.columns:
            if not out or out[-1][0] != column.group:
                out.append((column.group, []))
            out[-1][1].append(column)
        return out


def load_results(results_dir) -> list[Result]:
    """Every ``*.json`` result in ``results_dir`` (str or os.PathLike; sorted by file name),
    read by :func:`benchmark.results.read`.

    Raises
    ------
    UserError
        ``results_dir`` is not a folder.
    DataError
        A file that is not a result (not JSON, off the schema); the message names the
        file. Results of one dataset scored by different lip-sync models
        (:func:`check_scoring_models`).
    """
    results_dir = Path(results_dir)
    if not results_dir.is_dir():
        raise UserError(f"results directory {results_dir} does not exist")
    paths = result_files(results_dir)
    results = [read(path) for path in paths]
    check_records(results, paths)
    check_corpora(results, paths)
    check_scoring_models(results, paths)
    return results


def result_files(results_dir) -> list[Path]:
    """The ``*.json`` files of ``results_dir``, sorted by name.

    Raises
    ------
    DataError
        A file name that is not UTF-8 text or holds control characters (named by its
        bytes): the tables and the site name rows and pages after their files.
    """
    results_dir = Path(results_dir)
    paths = sorted(results_dir.glob("*.json"))
    for path in paths:
        raw = os.fsencode(path.name)
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError:
            text = None
        if text is None or any(unicodedata.category(c) == "Cc" for c in text):
            raise DataError(f"{results_dir}: the file name {raw!r} is not plain UTF-8 text; rename it (result files "
                            "are named <label>__<dataset>__s<S>__seed<k>.json) or move it out of the folder")
    return paths


def check_records(results: list, paths: list) -> None:
    """Refuse a result whose numbers were edited since its run wrote them
    (:meth:`benchmark.results.Result.edited`: they no longer match its
    ``protocol.record_sha256``), and the same result stored under two file names.

    Raises
    ------
    DataError
        Naming the edited file, or the files that hold one result.
    """
    for result, path in zip(results, paths):
        if result.edited():
            raise DataError(f"{path}: its numbers no longer match the digest its run stored "
                            "(protocol.record_sha256): the file was edited after the run wrote it; restore it, "
                            "or rerun the run (python -m benchmark.run)")
    seen: dict = {}
    for result, path in zip(results, paths):
        digest = result.record_digest()
        if digest in seen:
            raise DataError(f"{seen[digest]} and {path} hold the same result (same settings, same numbers) under two "
                            "file names: a row would be counted twice; remove one of them")
        seen[digest] = path


def check_scoring_models(results: list, paths: list) -> None:
    """Refuse results on one dataset manifest (one table) scored by different learned
    models of the same name (``protocol.lipsync_models``: the lip-sync expert, SyncNet).

    The expert is trained on the build and cached; one trained by other code, or with
    another budget under the same name, scores every row differently (its AV columns
    are not comparable), so the rows of one table must name one digest: the weights'
    (``weights_sha256``) where recorded, else the checkpoint file's.

    Raises
    ------
    DataError
        Naming, for each digest of a model, the files scored with it.
    """
    found: dict = {}  # {(dataset key, model): {digest: [files]}}
    for result, path in zip(results, paths):
        for name, record in (result.protocol.lipsync_models or {}).items():
            # the weights' digest where recorded (a file's also covers its path and training time)
            digest = (record.get("weights_sha256") or record.get("sha256")) if isinstance(record, dict) else None
            if digest:
                found.setdefault((result.key, name), {}).setdefault(digest, []).append(str(path))
    problems = ["dataset {}, {}: {}".format(manifest[:12], name, "; ".join(f"{digest[:12]}: {', '.join(files)}"
                                                                          for digest, files in sorted(digests.items())))
                for (manifest, name), digests in sorted(found.items()) if len(digests) > 1]
    if problems:
        raise DataError("results scored by different lip-sync models cannot share a table (rescore the rows of "
                        "the other checkpoint with one model, or keep them in another --results folder): "
                        + " | ".join(problems))
    check_latent_models(results, paths)


#: What a result without ``protocol.vae`` scored its latent metrics with.
PUBLISHED_VAE = "the published VAE (said-vae)"


def _table_clashes(results: list, paths: list, label, shown=str) -> list:
    """``["dataset <key>: <label>: <files>; <label>: <files>", ...]`` for every table (one
    dataset key) whose results carry more than one ``label(result)`` (None: not read)."""
    found: dict = {}  # {dataset key: {label: [files]}}
    for result, path in zip(results, paths):
        value = label(result)
        if value is not None:
            found.setdefault(result.key, {}).setdefault(value, []).append(str(path))
    return ["dataset {}: {}".format(key[:12], "; ".join(f"{shown(value)}: {', '.join(files)}"
                                                        for value, files in sorted(labels.items())))
            for key, labels in sorted(found.items()) if len(labels) > 1]


def check_latent_models(results: list, paths: list) -> None:
    """Refuse results on one dataset (one table) whose latent metrics (FD, WInD, ...) were
    scored by different VAEs (``protocol.vae``'s sha256; none: :data:`PUBLISHED_VAE`):
    each VAE has its own latent space, so their numbers are not comparable. Results
    without latent metrics are not read.

    Raises
    ------
    DataError
        Naming, for each VAE of a table, the files scored with it.
    """
    latent = set(LATENT_METRICS)

    def vae_of(result):
        if not latent & set(result.metrics):
            return None
        vae = result.protocol.get("vae")
        return (vae.get("sha256") if isinstance(vae, dict) else None) or PUBLISHED_VAE

    problems = _table_clashes(results, paths, vae_of, lambda vae: vae if vae == PUBLISHED_VAE else vae[:12])
    if problems:
        raise DataError("results whose latent metrics were scored by different VAEs cannot share a table (rescore "
                        "them with one --vae, or keep them in another --results folder): " + " | ".join(problems))


def check_corpora(results: list, paths: list) -> None:
    """Refuse results on one dataset identity (one table) that name different corpora
    (``dataset.name``; none: VOCASET's layout): a table holds the rows of one corpus.

    Raises
    ------
    DataError
        Naming, for each corpus, the files that name it.
    """
    problems = _table_clashes(results, paths, lambda result: result.dataset.name or "vocaset")
    if problems:
        raise DataError("results of different corpora cannot share a table (their dataset identities clash: "
                        "rebuild one corpus, or keep its results in another --results folder): " + " | ".join(problems))


def _column(name: str, entry: MetricEntry) -> Column:
    info = METRICS.get(name)
    if info is not None:
        return Column(name, info.label, info.unit, info.higher_is_better, info.group)
    return Column(name, entry.label or name, entry.unit or "", entry.higher_is_better, OTHER_GROUP)


def tables_by_manifest(results: list[Result]) -> list[Table]:
    """One :class:`Table` per dataset manifest hash, so that numbers from different
    data never share a table. Tables are sorted by manifest hash.

    Raises
    ------
    DataError
        Two results on one manifest disagree on a metric's direction or unit.
    """
    groups: dict[str, list[tuple[int, Result]]] = {}
    for index, result in enumerate(results):
        groups.setdefault(result.key, []).append((index, result))
    tables = []
    for manifest_hash in sorted(groups):
        sources = [index for index, _ in groups[manifest_hash]]
        group = [result for _, result in groups[manifest_hash]]
        specs: dict[str, tuple] = {}
        columns: dict[str, Column] = {}
        for result in group:
            for name, entry in result.metrics.items():
                spec = (entry.higher_is_better, entry.unit or "")
                if specs.setdefault(name, spec) != spec:
                    raise DataError(
                        f"manifest {manifest_hash}: metric {name!r} has direction/unit {specs[name]} in one result "
                        f"and {spec} in {result.method.label!r}"
                    )
                columns.setdefault(name, _column(name, entry))
        labels = [r.label for r in group]
        rows = []
        for source, result, label in zip(sources, group, labels):
            protocol = result.protocol
            seeds = tuple(result.training_seeds())
            if labels.count(label) > 1:
                which = f"seeds {','.join(map(str, seeds))}" if len(seeds) > 1 else f"seed {protocol.seed}"
                label = f"{label} (S={protocol.samples}, {which})"
            rows.append(Row(
                label=label,
                reference=bool(result.method.reference),
                samples=int(protocol.samples or 1),
                metrics={k: (v.mean, v.std, v.ci95) for k, v in result.metrics.items()},
                output=result.method.output or "coefficients",
                source=source,
                seed_ranges=_seed_ranges(result),
                seeds=seeds if len(seeds) > 1 else (),
                convergence=result.convergence,
                result=result,
            ))
        rows.sort(key=lambda r: (r.label.lower(), r.label))
        splits = sorted({r.dataset.split or "test" for r in group})
        counts = sorted({r.dataset.num_sentences for r in group if r.dataset.num_sentences})
        known = ordered_metrics([n for n in columns if n in METRICS])
        other = sorted(n for n in columns if n not in METRICS)
        table = Table(
            manifest_hash=manifest_hash,
            split="/".join(splits),
            num_sentences=counts[0] if len(counts) == 1 else None,
            columns=[columns[n] for n in known + other],
            rows=[r for r in rows if not r.reference],
            references=[r for r in rows if r.reference],
            name=" / ".join(sorted({r.dataset.display_name for r in group} - {""})),
            latent_out_of_domain=any(r.dataset.latent_out_of_domain or r.protocol.latent_out_of_domain
                                     for r in group),
            vae=" / ".join(sorted({str((r.protocol.get("vae") or {}).get("sha256") or "") for r in group} - {""})),
        )
        tables.append(table)
    return tables


def _seed_ranges(result: Result) -> dict:
    """``{metric: (lowest, highest)}`` of the per-seed means: the metric's ``seed_range``,
    else the range of ``per_seed[k].metrics`` when there are several seeds."""
    out = {}
    per_seed = result.per_seed or ()
    for name, entry in result.metrics.items():
        if entry.seed_range is not None:
            out[name] = (float(entry.seed_range[0]), float(entry.seed_range[1]))
            continue
        means = [e.metrics[name] for e in per_seed if e.metrics and e.metrics.get(name) is not None]
        if len(per_seed) > 1 and len(means) == len(per_seed):
            out[name] = (float(min(means)), float(max(means)))
    return out


def column_decimals(values) -> int:
    """Decimals shown for a metric column (1 to 4): three significant digits of its
    largest value, and at least two of its smallest non-zero one (numerical zeros, below
    1e-6 of the largest, are ignored)."""
    finite = [abs(v) for v in values if v is not None and math.isfinite(v) and v != 0]
    if finite:  # values below 1e-6 of the column's largest are numerical zeros (e.g. FD -5e-7)
        finite = [v for v in finite if v >= 1e-6 * max(finite)]
    if not finite:
        return 2
    largest = 2 - math.floor(math.log10(max(finite)))
    smallest = 1 - math.floor(math.log10(min(finite)))
    return int(min(4, max(1, largest, smallest)))


def ranks(values, higher_is_better, decimals: int) -> list:
    """Rank (1 = best) of each value among the non-None ones, compared at the shown
    precision so that equal-looking numbers share a rank; None where unranked.

    Parameters
    ----------
    values : list of float or None
    higher_is_better : bool or None
        None: the metric has no direction, nothing is ranked.
    decimals : int
    """
    if higher_is_better is None:
        return [None] * len(values)
    shown = [None if v is None else round(v, decimals) for v in values]
    distinct = sorted({v for v in shown if v is not None}, reverse=bool(higher_is_better))
    return [None if v is None else distinct.index(v) + 1 for v in shown]


def _by_sentence(rows, name: str) -> dict:
    """``{(subject, sentence): value}`` of the finite values of ``name`` in per-sentence rows
    (``{"subject", "sentence", name: value}``, or the values under ``"metrics"``)."""
    out = {}
    for row in rows or []:
        value = (row["metrics"] if isinstance(row.get("metrics"), dict) else row).get(name)
        if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
            out[(row["subject"], row["sentence"])] = float(value)
    return out


def _seed_sentence_values(result: Result, name: str) -> list | None:
    """Per training seed, ``{(subject, sentence): value}`` of a sentence-level metric: each
    ``per_seed[k].per_sentence``; the row's ``per_sentence`` for a row with one seed; None
    when a row with several seeds did not store each seed's rows."""
    per_seed = result.per_seed or ()
    if per_seed and all(entry.per_sentence for entry in per_seed):
        seeds = [_by_sentence(entry.per_sentence, name) for entry in per_seed]
        return seeds if all(seeds) else None
    if len(per_seed) > 1 or len(result.training_seeds()) > 1:
        return None
    values = _by_sentence(result.per_sentence, name)
    return [values] if values else None


def pair_replicates(a: Row, b: Row, name: str, *, streams=(0, 1), resamples: int = ORDER_RESAMPLES,
                    cache: dict | None = None):
    """Paired bootstrap replicates of two rows' ``name``, or None when not stored.

    Sentence-level metrics: the two rows' per-sentence values on their common sentences
    (each seed's rows for rows trained with several), through
    :func:`benchmark.metrics.bootstrap.two_level_mean_replicates` with one seed per metric
    for both rows (same resampled sentences at the same index; one seed per row is the
    one-level bootstrap), when they share at least :data:`MIN_PAIRED_SENTENCES`.
    Set-level metrics: their stored replicates (of at least that many sentences, the
    entry's ``n``) through
    :func:`benchmark.metrics.bootstrap.two_level_replicates`. ``streams`` separate the
    two rows' seed draws (their training seeds are unrelated). ``cache``: a dict kept
    across calls on the same rows with the same streams (each row's replicates are
    computed once per set of common sentences).

    Returns
    -------
    (ndarray, ndarray) or None
        ``(resamples,)`` replicates of ``a`` and of ``b``.
    """
    if a.result is None or b.result is None:
        return None
    cache = {} if cache is None else cache
    info = METRICS.get(name)
    # one seed per metric (as benchmark.evaluation: seed 0 + crc32 of the name), the same
    # for every row, so rows scored on the same sentences are paired
    seed = zlib.crc32(name.encode())

    def cached(key, compute):
        if key not in cache:
            cache[key] = compute()
        return cache[key]

    if info is None or info.level == "sentence":
        va = cached(("values", streams[0], name), lambda: _seed_sentence_values(a.result, name))
        vb = cached(("values", streams[1], name), lambda: _seed_sentence_values(b.result, name))
        if va and vb:
            common = tuple(sorted(set.intersection(*(set(d) for d in va + vb))))
            if len(common) >= MIN_PAIRED_SENTENCES:
                return tuple(
                    cached(("sentence", stream, name, common, resamples), lambda values=values, stream=stream:
                           two_level_mean_replicates(np.array([[d[k] for k in common] for d in values]),
                                                     resamples=resamples, seed=seed, stream=stream))
                    for values, stream in ((va, streams[0]), (vb, streams[1])))
        if info is not None:
            return None
    ra, rb = a.result.seed_replicates(name), b.result.seed_replicates(name)
    too_few = any(name in r.result.metrics and r.result.metrics[name].n is not None
                  and r.result.metrics[name].n < MIN_PAIRED_SENTENCES for r in (a, b))
    if ra and rb and not too_few:
        return tuple(cached(("set", stream, name, resamples), lambda reps=reps, stream=stream:
                            two_level_replicates(reps, resamples=resamples, seed=seed, stream=stream))
                     for reps, stream in ((ra, streams[0]), (rb, streams[1])))
    return None


@dataclass(frozen=True)
class BestMark:
    """The best mark of one column.

    Attributes
    ----------
    rows : frozenset of int
        Indices of the marked rows (at most one).
    rule : str or None
        ``"resampling"`` (the best method beats the runner-up in at least
        :data:`BEST_PROBABILITY` of the paired resamples), ``"intervals"`` (no resamples
        stored: the best method's 95 % interval is disjoint from the runner-up's), or None
        (nothing to compare: fewer than two methods, no direction).
    probability : float or None
        Under ``"resampling"``: the probability that the best method beats the runner-up.
    best, runner_up : int or None
        Indices of the two rows compared.
    reason : str or None
        Under ``"intervals"``: why the two rows could not be resampled
        (:func:`unpaired_reason`).
    """

    rows: frozenset = frozenset()
    rule: str | None = None
    probability: float | None = None
    best: int | None = None
    runner_up: int | None = None
    reason: str | None = None


def unpaired_reason(a: Row, b: Row, name: str) -> str:
    """Why :func:`pair_replicates` found nothing to resample for two rows' ``name``, in words:
    too few sentences (naming the count and :data:`MIN_PAIRED_SENTENCES`), or no
    per-sentence values and no bootstrap replicates stored."""
    if a.result is None or b.result is None:
        return "no result files behind these rows"
    info = METRICS.get(name)
    if info is None or info.level == "sentence":
        va, vb = _seed_sentence_values(a.result, name), _seed_sentence_values(b.result, name)
        if va and vb:
            common = set.intersection(*(set(d) for d in va + vb))
            return (f"only {len(common)} sentence(s) scored in common (fewer than {MIN_PAIRED_SENTENCES} sentences "
                    "cannot be resampled)")
    counts = [r.result.metrics[name].n for r in (a, b)
              if name in r.result.metrics and r.result.metrics[name].n is not None]
    if a.result.seed_replicates(name) and b.result.seed_replicates(name) and counts:
        return (f"only {min(counts)} sentence(s) scored (fewer than {MIN_PAIRED_SENTENCES} sentences cannot be "
                "resampled)")
    return "the result files store neither per-sentence values nor bootstrap replicates"


def best_mark(rows: list, column: Column, *, resamples: int = ORDER_RESAMPLES) -> BestMark:
    """The best mark of ``column`` among ``rows`` (the methods; reference rows are never passed).

    The method with the best mean is marked when it beats the runner-up (second-best
    mean) in at least :data:`BEST_PROBABILITY` of the paired bootstrap resamples
    (:func:`pair_replicates`: sentences, and training seeds for rows trained with
    several). Where the two rows stored nothing to resample (result files from before
    protocol v3 without replicates of set-level metrics, or fewer than
    :data:`MIN_PAIRED_SENTENCES` sentences) the rule is the one those tables used: the
    best method's 95 % interval does not overlap the runner-up's, a conservative test
    (it implies p < 0.05 for independent estimates). Nothing is marked with fewer than
    two methods, without a direction, or when neither is available.
    """
    if column.higher_is_better is None:
        return BestMark()
    scored = [(i, row.metrics[column.name]) for i, row in enumerate(rows) if column.name in row.metrics]
    if len(scored) < 2:
        return BestMark()
    sign = -1.0 if column.higher_is_better else 1.0
    scored.sort(key=lambda item: sign * item[1][0])
    (best, (_, _, ci_best)), (runner_up, (_, _, ci_next)) = scored[0], scored[1]
    pair = pair_replicates(rows[best], rows[runner_up], column.name, streams=(best, runner_up), resamples=resamples)
    if pair is not None:
        p = probability_of_improvement(*pair, higher_is_better=column.higher_is_better)
        return BestMark(frozenset({best}) if p >= BEST_PROBABILITY else frozenset(), "resampling", p, best, runner_up)
    if ci_best is None or ci_next is None:
        return BestMark(best=best, runner_up=runner_up)
    separated = ci_best[0] > ci_next[1] if column.higher_is_better else ci_best[1] < ci_next[0]
    return BestMark(frozenset({best}) if separated else frozenset(), "intervals", None, best, runner_up,
                    unpaired_reason(rows[best], rows[runner_up], column.name))


def pairwise_probabilities(rows: list, column: Column, *, resamples: int = ORDER_RESAMPLES) -> list:
    """Probability of improvement between any two rows in ``column``.

    Returns
    -------
    list of list of (float or None)
        ``out[i][j]``: the fraction of paired resamples in which row ``i`` is better than
        row ``j`` (ties half; :func:`pair_replicates` with streams ``i`` and ``j``, as
        :func:`best_mark` for the same list of rows); None on the diagonal, for a metric
        without a direction, and where either row stored nothing to resample or lacks
        the metric.
    """
    n = len(rows)
    out = [[None] * n for _ in range(n)]
    if column.higher_is_better is None:
        return out
    cache: dict = {}
    for i in range(n):
        for j in range(i + 1, n):
            if column.name not in rows[i].metrics or column.name not in rows[j].metrics:
                continue
            pair = pair_replicates(rows[i], rows[j], column.name, streams=(i, j), resamples=resamples, cache=cache)
            if pair is None:
                continue
            p = probability_of_improvement(*pair, higher_is_better=column.higher_is_better)
            out[i][j], out[j][i] = p, 1.0 - p
    return out
