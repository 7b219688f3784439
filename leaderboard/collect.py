"""Reading result files and arranging them into per-dataset tables.

Columns are the metrics of the results, grouped and ordered by the metric registry
(:mod:`benchmark.metrics.registry`: lip sync, distribution, vertex, energy, diversity,
as in the SAiD paper's Table 1); rows are the methods, and the reference rows (ground
truth, corpus meshes, mean, static, random) apart, never ranked.

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
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmark.metrics.bootstrap import (
    probability_of_improvement,
    two_level_mean_replicates,
    two_level_replicates,
)
from benchmark.metrics.registry import METRICS, ordered_metrics
from benchmark.results import dataset_key, read_result
from blendvoca.errors import DataError, UserError

__all__ = [
    "BEST_PROBABILITY",
    "MIN_PAIRED_SENTENCES",
    "ORDER_RESAMPLES",
    "BestMark",
    "Column",
    "Row",
    "Table",
    "best_mark",
    "check_schema_versions",
    "check_scoring_models",
    "column_decimals",
    "load_results",
    "pair_replicates",
    "pairwise_probabilities",
    "ranks",
    "result_seeds",
    "tabulable",
    "tables_by_manifest",
]

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
    convergence: dict | None = None
    #: The result record (its per-sentence rows and replicates feed the resampling).
    result: dict | None = field(default=None, repr=False, compare=False)

    @property
    def settled(self) -> bool | None:
        """``convergence.settled``: False marks the row "not settled"; None when not checked."""
        if not self.convergence:
            return None
        settled = self.convergence.get("settled")
        return None if settled is None else bool(settled)

    def unsettled_metrics(self) -> list:
        """``[(metric, half_budget, full_budget, half_width)]`` of the checked metrics that moved
        by more than their interval's half-width between the half and the full budget."""
        out = []
        for name, entry in ((self.convergence or {}).get("metrics") or {}).items():
            if isinstance(entry, dict) and entry.get("settled") is False:
                out.append((name, entry.get("half_budget"), entry.get("full_budget"), entry.get("half_width")))
        return out

    def unsettled_seeds(self, name: str) -> list:
        """``[(seed, half_budget, full_budget, half_width)]`` of the seeds whose own check of
        ``name`` failed (the result's ``per_seed[k].convergence``), in the result's seed order;
        empty for a row without per-seed checks."""
        records = self.result.get("per_seed") if isinstance(self.result, dict) else None
        out = []
        for record in records if isinstance(records, list) else []:
            convergence = record.get("convergence") if isinstance(record, dict) else None
            entry = ((convergence or {}).get("metrics") or {}).get(name)
            if isinstance(entry, dict) and entry.get("settled") is False \
                    and entry.get("half_budget") is not None and entry.get("full_budget") is not None:
                out.append((record.get("seed"), entry["half_budget"], entry["full_budget"], entry.get("half_width")))
        return out


@dataclass
class Table:
    """All results on one dataset (one recipe id, :func:`benchmark.results.dataset_key`)."""

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


def load_results(results_dir) -> list[dict]:
    """Every ``*.json`` result in ``results_dir`` (str or os.PathLike; sorted by file name), schema-checked.

    Raises
    ------
    UserError
        ``results_dir`` is not a folder.
    DataError
        A file that is not a result (not JSON, off the schema, or holding a field the
        tables read with the wrong type); the message names the file. Results of one
        dataset with different schema versions or lip-sync models
        (:func:`check_schema_versions`, :func:`check_scoring_models`).
    """
    results_dir = Path(results_dir)
    if not results_dir.is_dir():
        raise UserError(f"results directory {results_dir} does not exist")
    paths = sorted(results_dir.glob("*.json"))
    results = [tabulable(read_result(path), path) for path in paths]
    check_schema_versions(results, paths)
    check_scoring_models(results, paths)
    return results


def _disagreements(results: list, paths: list, values_of) -> list:
    """``(dataset key, name, {value: [files]})`` for every dataset whose results give
    more than one value under one name; ``values_of(result)`` yields ``(name, value)``
    pairs (a value of None is not compared). Sorted by dataset and name."""
    groups: dict = {}
    for result, path in zip(results, paths):
        for name, value in values_of(result):
            if value is not None:
                groups.setdefault((dataset_key(result), name), {}).setdefault(value, []).append(str(path))
    return [(manifest, name, values) for (manifest, name), values in sorted(groups.items()) if len(values) > 1]


def check_schema_versions(results: list, paths: list) -> None:
    """Refuse results of different ``schema_version`` on one dataset manifest (one table).

    A version-1 file is read with its metric names mapped (``lve`` -> ``lve_mesh`` or
    ``lve_rig``), but its numbers come from the older protocol (one reference space per
    kind of row, one seed, no stored replicates), so it does not share a table with
    version-2 rows.

    Raises
    ------
    DataError
        Naming, for each version, the files that have it.
    """
    # the version is compared as text, so a file without one ("None") still counts
    mixed = _disagreements(results, paths, lambda r: [("", str(r.get("schema_version")))])
    problems = ["dataset {}: {}".format(manifest[:12], "; ".join(f"version {v}: {', '.join(files)}"
                                                                  for v, files in sorted(versions.items())))
                for manifest, _, versions in mixed]
    if problems:
        raise DataError("results of different schema versions cannot share a table (rescore the older rows with "
                        "the current benchmark, or keep them in another --results folder): " + " | ".join(problems))


def _model_digests(result: dict):
    """``(model name, digest)`` of each lip-sync model a result names: the weights'
    digest where recorded (a file's also covers its path and training time), else the
    checkpoint file's."""
    models = (result.get("protocol") or {}).get("lipsync_models") or {}
    for name, record in models.items():
        if isinstance(record, dict):
            yield name, record.get("weights_sha256") or record.get("sha256") or None


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
    problems = ["dataset {}, {}: {}".format(manifest[:12], name, "; ".join(f"{digest[:12]}: {', '.join(files)}"
                                                                          for digest, files in sorted(digests.items())))
                for manifest, name, digests in _disagreements(results, paths, _model_digests)]
    if problems:
        raise DataError("results scored by different lip-sync models cannot share a table (rescore the rows of "
                        "the other checkpoint with one model, or keep them in another --results folder): "
                        + " | ".join(problems))


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _is_int(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _short(value) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _check_rows(rows, where: str, fail) -> None:
    """Per-sentence rows: a list of objects with string ``subject`` and ``sentence``."""
    if rows is None:
        return
    if not isinstance(rows, list):
        fail(where, "a list of per-sentence rows", rows)
    for i, row in enumerate(rows):
        if not isinstance(row, dict):
            fail(f"{where}[{i}]", "an object", row)
        for key in ("subject", "sentence"):
            if not isinstance(row.get(key), str):
                fail(f"{where}[{i}].{key}", "a string", row.get(key))
        if "metrics" in row and not isinstance(row["metrics"], dict):
            fail(f"{where}[{i}].metrics", "an object", row["metrics"])


def _check_replicates(value, where: str, fail) -> None:
    if not isinstance(value, list) or not value or not all(_is_number(v) for v in value):
        fail(where, "a non-empty list of finite numbers", value)


def _check_v3_fields(result: dict, path: Path) -> None:
    """Types of the optional protocol-v3 fields the tables read: ``seeds``, ``per_seed``,
    ``per_sentence``, the metrics' ``seed_range`` and ``replicates``, ``convergence``."""

    def fail(where, expected, value):
        raise DataError(f"{path}: {where}: expected {expected}, got {_short(value)}")

    for where, seeds in (("seeds", result.get("seeds")), ("protocol.seeds", result["protocol"].get("seeds"))):
        if seeds is not None and not (isinstance(seeds, list) and all(_is_int(v) for v in seeds)):
            fail(where, "a list of integers", seeds)
    _check_rows(result.get("per_sentence"), "per_sentence", fail)
    per_seed = result.get("per_seed")
    if per_seed is not None:
        if not isinstance(per_seed, list):
            fail("per_seed", "a list of objects", per_seed)
        for i, entry in enumerate(per_seed):
            if not isinstance(entry, dict):
                fail(f"per_seed[{i}]", "an object", entry)
            if "seed" in entry and not _is_int(entry["seed"]):
                fail(f"per_seed[{i}].seed", "an integer", entry["seed"])
            means = entry.get("metrics")
            if means is not None and not (isinstance(means, dict) and all(
                    v is None or _is_number(v) for v in means.values())):
                fail(f"per_seed[{i}].metrics", "an object of metric -> number", means)
            _check_rows(entry.get("per_sentence"), f"per_seed[{i}].per_sentence", fail)
            replicates = entry.get("replicates")
            if replicates is not None:
                if not isinstance(replicates, dict):
                    fail(f"per_seed[{i}].replicates", "an object of metric -> list", replicates)
                for name, values in replicates.items():
                    _check_replicates(values, f"per_seed[{i}].replicates.{name}", fail)
    for name, fields in result["metrics"].items():
        seed_range = fields.get("seed_range")
        if seed_range is not None and not (isinstance(seed_range, list) and len(seed_range) == 2
                                           and all(_is_number(v) for v in seed_range)
                                           and seed_range[0] <= seed_range[1]):
            fail(f"metrics.{name}.seed_range", "[low, high] of finite numbers", seed_range)
        if fields.get("replicates") is not None:
            _check_replicates(fields["replicates"], f"metrics.{name}.replicates", fail)
    convergence = result.get("convergence")
    if convergence is not None:
        if not isinstance(convergence, dict):
            fail("convergence", "an object", convergence)
        if convergence.get("settled") is not None and not isinstance(convergence["settled"], bool):
            fail("convergence.settled", "true or false", convergence["settled"])
        for key in ("checked_at_step", "total_steps"):
            if convergence.get(key) is not None and not _is_int(convergence[key]):
                fail(f"convergence.{key}", "an integer", convergence[key])
        checked = convergence.get("metrics")
        if checked is not None:
            if not isinstance(checked, dict):
                fail("convergence.metrics", "an object of metric -> check", checked)
            for name, entry in checked.items():
                if not isinstance(entry, dict):
                    fail(f"convergence.metrics.{name}", "an object", entry)
                for key in ("half_budget", "full_budget", "half_width"):
                    if entry.get(key) is not None and not _is_number(entry[key]):
                        fail(f"convergence.metrics.{name}.{key}", "a finite number", entry[key])
                if entry.get("settled") is not None and not isinstance(entry["settled"], bool):
                    fail(f"convergence.metrics.{name}.settled", "true or false", entry["settled"])


def tabulable(result: dict, path) -> dict:
    """``result`` unchanged when the fields the tables and the site read have their types
    (the schema check leaves some free); DataError naming ``path`` and the field otherwise."""
    path = Path(path)
    expected = (
        ("dataset", "manifest_hash", str, True),
        ("dataset", "recipe_id", str, True),
        ("dataset", "split", str, True),
        ("dataset", "num_sentences", int, True),
        ("method", "name", str, False),
        ("method", "label", str, True),
        ("method", "output", str, True),
        ("protocol", "samples", int, True),
        ("protocol", "seed", int, True),
    )
    for section, key, kind, optional in expected:
        value = result[section].get(key)
        if value is None and (optional or key not in result[section]):
            continue
        if isinstance(value, bool) or not isinstance(value, kind):
            raise DataError(f"{path}: {section}.{key}: expected {'an integer' if kind is int else 'a string'}, "
                            f"got {value!r}")
    _check_v3_fields(result, path)
    return result


_tabulable = tabulable


def _column(name: str, fields: dict) -> Column:
    info = METRICS.get(name)
    if info is not None:
        return Column(name, info.label, info.unit, info.higher_is_better, info.group)
    return Column(name, fields.get("label") or name, fields.get("unit") or "", fields["higher_is_better"],
                  OTHER_GROUP)


def tables_by_manifest(results: list[dict]) -> list[Table]:
    """One :class:`Table` per dataset manifest hash, so that numbers from different
    data never share a table. Tables are sorted by manifest hash.

    Raises
    ------
    DataError
        Two results on one manifest disagree on a metric's direction or unit.
    """
    groups: dict[str, list[tuple[int, dict]]] = {}
    for index, result in enumerate(results):
        groups.setdefault(dataset_key(result), []).append((index, result))
    tables = []
    for manifest_hash in sorted(groups):
        sources = [index for index, _ in groups[manifest_hash]]
        group = [result for _, result in groups[manifest_hash]]
        specs: dict[str, tuple] = {}
        columns: dict[str, Column] = {}
        for result in group:
            for name, fields in result["metrics"].items():
                spec = (fields["higher_is_better"], fields.get("unit") or "")
                if specs.setdefault(name, spec) != spec:
                    raise DataError(
                        f"manifest {manifest_hash}: metric {name!r} has direction/unit {specs[name]} in one result "
                        f"and {spec} in {result['method'].get('label')!r}"
                    )
                columns.setdefault(name, _column(name, fields))
        versions = sorted({str(r.get("schema_version")) for r in group})
        if len(versions) > 1:
            raise DataError(f"manifest {manifest_hash}: results of schema versions {', '.join(versions)} cannot share "
                            f"a table ({sorted(r['method'].get('label') or r['method']['name'] for r in group)})")
        labels = [r["method"].get("label") or r["method"]["name"] for r in group]
        rows = []
        for source, result, label in zip(sources, group, labels):
            protocol = result["protocol"]
            seeds = tuple(result_seeds(result))
            if labels.count(label) > 1:
                which = (f"seeds {','.join(map(str, seeds))}" if len(seeds) > 1 else f"seed {protocol.get('seed')}")
                label = f"{label} (S={protocol.get('samples')}, {which})"
            rows.append(Row(
                label=label,
                reference=bool(result["method"].get("reference", False)),
                samples=int(protocol.get("samples") or 1),
                metrics={k: (v["mean"], v.get("std"), v.get("ci95")) for k, v in result["metrics"].items()},
                output=result["method"].get("output", "coefficients"),
                source=source,
                seed_ranges=_seed_ranges(result),
                seeds=seeds if len(seeds) > 1 else (),
                convergence=result.get("convergence") if isinstance(result.get("convergence"), dict) else None,
                result=result,
            ))
        rows.sort(key=lambda r: (r.label.lower(), r.label))
        splits = sorted({r["dataset"].get("split", "test") for r in group})
        counts = sorted({r["dataset"].get("num_sentences") for r in group if r["dataset"].get("num_sentences")})
        known = ordered_metrics([n for n in columns if n in METRICS])
        other = sorted(n for n in columns if n not in METRICS)
        tables.append(Table(
            manifest_hash=manifest_hash,
            split="/".join(splits),
            num_sentences=counts[0] if len(counts) == 1 else None,
            columns=[columns[n] for n in known + other],
            rows=[r for r in rows if not r.reference],
            references=[r for r in rows if r.reference],
            name=" / ".join(sorted({dataset_name(r["dataset"]) for r in group} - {""})),
            latent_out_of_domain=any(_latent_out_of_domain(r) for r in group),
        ))
    return tables


def dataset_name(record: dict) -> str:
    """The display name of a result's ``dataset`` record: its ``title``, else its ``name``, else ""."""
    return str(record.get("title") or record.get("name") or "")


def _latent_out_of_domain(result: dict) -> bool:
    """Whether a result flags its latent metrics as out of domain (``dataset`` or ``protocol`` record)."""
    return bool(result["dataset"].get("latent_out_of_domain") or result["protocol"].get("latent_out_of_domain"))


def result_seeds(result: dict) -> list:
    """The training seeds of a result trained with several: its ``seeds`` (or
    ``protocol.seeds``); empty otherwise."""
    seeds = result.get("seeds")
    if seeds is None:
        seeds = result["protocol"].get("seeds")
    return list(seeds or [])


def _seed_ranges(result: dict) -> dict:
    """``{metric: (lowest, highest)}`` of the per-seed means: the metric's ``seed_range``,
    else the range of ``per_seed[k].metrics`` when there are several seeds."""
    out = {}
    per_seed = result.get("per_seed") or []
    for name, fields in result["metrics"].items():
        stored = fields.get("seed_range")
        if stored is not None:
            out[name] = (float(stored[0]), float(stored[1]))
            continue
        means = [e["metrics"][name] for e in per_seed
                 if isinstance(e.get("metrics"), dict) and _is_number(e["metrics"].get(name))]
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


def _metric_seed(name: str) -> int:
    """Seed of a metric's resamples (as ``benchmark.evaluate``: seed 0 + crc32 of the name),
    the same for every row, so rows scored on the same sentences are paired."""
    return zlib.crc32(name.encode())


def _sentence_value(row: dict, name: str):
    values = row.get("metrics") if isinstance(row.get("metrics"), dict) else row
    value = values.get(name)
    return float(value) if _is_number(value) else None


def _by_sentence(rows, name: str) -> dict:
    """``{(subject, sentence): value}`` of the finite values of ``name`` in per-sentence rows."""
    out = {}
    for row in rows or []:
        value = _sentence_value(row, name)
        if value is not None:
            out[(row["subject"], row["sentence"])] = value
    return out


def _seed_sentence_values(result: dict, name: str) -> list | None:
    """Per training seed, ``{(subject, sentence): value}`` of a sentence-level metric: each
    ``per_seed[k].per_sentence``; the row's ``per_sentence`` for a row with one seed; None
    when a row with several seeds did not store each seed's rows."""
    per_seed = result.get("per_seed") or []
    if per_seed and all(entry.get("per_sentence") for entry in per_seed):
        seeds = [_by_sentence(entry["per_sentence"], name) for entry in per_seed]
        return seeds if all(seeds) else None
    if len(per_seed) > 1 or len(result_seeds(result)) > 1:
        return None
    values = _by_sentence(result.get("per_sentence"), name)
    return [values] if values else None


def _seed_replicates(result: dict, name: str) -> list | None:
    """Per training seed, the stored bootstrap replicates of a set-level metric: each
    ``per_seed[k].replicates[name]``, else the metric's own ``replicates`` as one list."""
    per_seed = result.get("per_seed") or []
    stored = [(entry.get("replicates") or {}).get(name) for entry in per_seed]
    if per_seed and all(stored):
        return [np.asarray(r, dtype=np.float64) for r in stored]
    own = result["metrics"].get(name, {}).get("replicates")
    return [np.asarray(own, dtype=np.float64)] if own else None


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
    seed = _metric_seed(name)

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
    ra, rb = _seed_replicates(a.result, name), _seed_replicates(b.result, name)
    too_few = any(_is_number(r.result["metrics"].get(name, {}).get("n"))
                  and r.result["metrics"][name]["n"] < MIN_PAIRED_SENTENCES for r in (a, b))
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
    """

    rows: frozenset = frozenset()
    rule: str | None = None
    probability: float | None = None
    best: int | None = None
    runner_up: int | None = None


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
    return BestMark(frozenset({best}) if separated else frozenset(), "intervals", None, best, runner_up)


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
