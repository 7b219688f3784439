"""The ways into and out of a result file: :func:`check`, :func:`read`, :func:`write`
(and :func:`build_result`, which makes a new record from a run's parts)."""

from __future__ import annotations

import json
import os
from pathlib import Path

from benchmark.results.parts import Located
from benchmark.results.provenance import current_provenance
from benchmark.results.record import LATENCY_FIELDS, LOOKAHEAD_FIELDS, SCHEMA_VERSION, Result
from blendvoca.errors import DataError
from blendvoca.io.atomic import atomic_write
from blendvoca.io.json_file import read_json

__all__ = ["build_result", "check", "read", "upgrade_command", "write"]


def upgrade_command(where: str) -> str:
    """What to run for an older result file named ``where``."""
    return f"python -m benchmark.results upgrade {where}"


def _older_schema(version, where: str) -> str | None:
    """The one-line refusal of a result file of an older schema, or None."""
    if version == 2:
        return (f"{where}: a schema-2 result file; this BlendVOCA reads schema {SCHEMA_VERSION} (the same fields): "
                f"run `{upgrade_command(where)}`")
    if version == 1:
        return (f"{where}: a schema-1 result file (protocol v2, vertex metrics named without their reference "
                f"space); this BlendVOCA reads schema {SCHEMA_VERSION}: rescore the run with `python -m benchmark.run` "
                "(or read it with BlendVOCA 0.1.0 as released before the schema-3 change)")
    return None


def check(record, where: str = "result") -> Result:
    """The typed :class:`~benchmark.results.record.Result` of a parsed JSON ``record``,
    checked against the schema (the one validation of result files).

    Raises
    ------
    DataError
        One line naming ``where``, the field, what was expected and what arrived; for
        a file of an older schema, what to run.
    """
    if not isinstance(record, dict):
        raise DataError(f"{where}: expected a JSON object, got {type(record).__name__}")
    version = record.get("schema_version")
    older = None if isinstance(version, bool) else _older_schema(version, where)
    if older is not None:
        raise DataError(older)
    if isinstance(version, bool) or version != SCHEMA_VERSION:
        raise DataError(f"{where}: expected schema_version {SCHEMA_VERSION}, got {version!r}")
    try:
        result = Result.from_json(record, "result")
        json.dumps(record, allow_nan=False)
    except Located as exc:
        raise DataError(f"{where}: {str(exc).removeprefix('result: ').removeprefix('result.')}") from None
    except (TypeError, ValueError, OverflowError) as exc:
        raise DataError(f"{where}: not JSON-serialisable ({exc})") from None
    return result


def read(path) -> Result:
    """The checked result in the file ``path``.

    Raises
    ------
    DataError
        The file is not JSON or does not follow the schema (:func:`check`).
    OSError
        It cannot be read.
    """
    path = Path(os.fspath(path))
    return check(read_json(path, what="valid JSON"), str(path))


def write(path, result: Result) -> Path:
    """Check ``result`` and write it to the file ``path`` atomically
    (`blendvoca.io.atomic.atomic_write`: a crash never leaves a partial result file);
    keys sorted, two-space indent. Returns ``path``."""
    record = result.to_json()
    check(record)
    text = json.dumps(record, indent=2, sort_keys=True, allow_nan=False) + "\n"
    path = Path(os.fspath(path))
    with atomic_write(path, "w", encoding="utf-8") as handle:
        handle.write(text)
    return path


def _clean_metric(fields) -> dict:
    """A metric entry as written: ``mean`` and ``std`` floats, ``unit`` "" when none."""
    if not isinstance(fields, dict) or "mean" not in fields:
        return fields  # check() says what is wrong
    std = fields.get("std")
    try:
        mean = float(fields["mean"])
    except (TypeError, ValueError):
        mean = fields["mean"]
    return {**fields, "mean": mean, "std": None if std is None else float(std), "unit": fields.get("unit") or ""}


def build_result(*, method: dict, dataset: dict, protocol: dict, metrics: dict, timings: dict,
                 provenance: dict | None = None, tracks: str | None = None, per_sentence: list | None = None,
                 latency: dict | None = None, **parts) -> Result:
    """Assemble and check a new result record from a run's parts.

    Parameters
    ----------
    method, dataset, protocol : dict
        The JSON objects of those parts (:mod:`benchmark.results`); ``method.label``
        defaults to its ``name``.
    metrics : dict
        ``{metric: {"mean", "std", "higher_is_better", "unit", ...}}`` as returned by
        ``benchmark.evaluation.evaluate_split`` (means and stds as floats, a missing unit "").
    timings : dict
        Seconds per stage (rounded to ms).
    provenance : dict, optional
        Defaults to :func:`~benchmark.results.provenance.current_provenance` now.
    tracks : str, optional
        The stored tracks folder, relative to the JSON's folder (``benchmark.runs``).
    per_sentence : list of dict, optional
        One ``{"subject", "sentence", metric: value, ...}`` row per scored sentence.
    latency : dict, optional
        ``{"lookahead_s", "first_frame_s", "compute_per_audio_s", "rtf"}`` (seconds or None; rounded to 0.1 ms),
        and the look-ahead probe's ``measured_lookahead_s`` and ``lookahead_probe`` where given.
    **parts
        Further top-level parts as JSON (``seeds``, ``per_seed``, ``convergence``).

    Raises
    ------
    DataError
        A part off the schema (:func:`check`).
    """
    if not isinstance(metrics, dict) or not metrics:
        raise DataError(f"result metrics: expected a non-empty dict of metric -> fields, got {metrics!r}")
    record = {
        "schema_version": SCHEMA_VERSION,
        "method": {**method, "label": method.get("label") or method.get("name")},
        "dataset": dict(dataset),
        "protocol": dict(protocol),
        "metrics": {str(name): _clean_metric(fields) for name, fields in sorted(metrics.items())},
        "provenance": dict(current_provenance() if provenance is None else provenance),
        "timings": {k: (None if v is None else round(float(v), 3)) for k, v in timings.items()},
        **{k: v for k, v in parts.items() if v is not None},
    }
    if tracks is not None:
        record["tracks"] = str(tracks)
    if per_sentence is not None:
        record["per_sentence"] = list(per_sentence)
    if latency is not None:
        record["latency"] = {key: (None if latency.get(key) is None else round(float(latency[key]), 4))
                             for key in LATENCY_FIELDS}
        # the look-ahead probe's (benchmark.protocol.lookahead), where it ran
        record["latency"].update({key: latency[key] for key in LOOKAHEAD_FIELDS if key in latency})
    try:  # as JSON holds it (tuples as lists), as a file read back gives it
        record = json.loads(json.dumps(record))
    except (TypeError, ValueError) as exc:
        raise DataError(f"result: not JSON-serialisable ({exc})") from None
    return check(record)
