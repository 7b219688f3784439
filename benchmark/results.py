"""Result files: one JSON per benchmark run, with its provenance.

Schema (``schema_version`` 2)::

    {
      "schema_version": 2,
      "method":   {"name", "label", "class", "stochastic", "reference", "config"},
      "dataset":  {"recipe_id", "manifest_hash", "path", "split", "num_sentences", "num_subjects"},
      "protocol": {"samples", "seed", "budget", "clip", "n_clipped", "deterministic",
                   "generate_time_limit", "checkpoint", "checkpoint_sha256"?,
                   "sentence_batch"?, "lipsync_models"?: {model: {"path", "sha256", ...}}},
      "metrics":  {metric: {"mean", "std", "ci95", "n", "higher_is_better", "unit", "label", "group",
                            "replicates"? (set-level metrics), "seed_range"? (several seeds)}},
      "per_sentence": [{"subject", "sentence", metric: value, ...}],
      "tracks":   "<run>"   (stored tracks folder, relative to the JSON; benchmark.runs)
      "provenance": {"date", "git_revision", "git_dirty", "python", "platform",
                     "versions": {package: version}, "hardware": {...}},
      "timings":  {"train_s", "load_s", "generate_s", "evaluate_s", "total_s"},
      "latency"?: {"lookahead_s", "first_frame_s", "compute_per_audio_s", "rtf"}
    }

``latency`` (:func:`benchmark.protocol.generation.measure_latency`; seconds, null where
not known) depends on the machine like ``timings``: it is not part of what a rerun must
reproduce (the metrics and per-sentence values), and results written before it have none.

Tables are only ever rendered from these files (``python -m leaderboard.build``).

``dataset.recipe_id`` is the dataset's identity (:func:`blendvoca.format.dataset_id`: the
build's inputs, tool format version and parameters, the same on every machine); it names
the file and keys the leaderboard section (:func:`dataset_key`). ``dataset.manifest_hash``
is the content hash of the files scored, for information (it differs between BLAS
kernels). A result without a ``recipe_id`` (written before it existed) is keyed by its
``manifest_hash``; the committed results were re-keyed (``leaderboard/rekey.py``).

Schema 1 (protocol v2) named the vertex metrics without their reference space:
vertex rows were scored against the source meshes, coefficient rows against the rig
reconstruction of the ground truth. :func:`read_result` reads such files with those
names mapped (``lve`` -> ``lve_mesh`` for ``method.output == "vertices"``, ``lve_rig``
otherwise; :data:`benchmark.metrics.registry.LEGACY_NAMES`) and ``schema_version``
left at 1: it says under which protocol the numbers were made, and the leaderboard
does not mix the two in one table.
"""

from __future__ import annotations

import datetime as _dt
import importlib.metadata
import json
import math
import os
import platform
import re
import subprocess
from pathlib import Path

from blendvoca.errors import DataError
from blendvoca.io.json_file import read_json
from blendvoca.format import blas_kernels
from blendvoca.io.atomic import atomic_write

__all__ = [
    "LATENCY_FIELDS",
    "METRIC_FIELDS",
    "READABLE_SCHEMAS",
    "SCHEMA_VERSION",
    "build_result",
    "check_result",
    "current_provenance",
    "dataset_key",
    "git_revision",
    "hardware_info",
    "package_versions",
    "read_result",
    "result_filename",
    "write_result",
]

SCHEMA_VERSION = 2
#: Versions :func:`read_result` and :func:`check_result` accept (1: read with its names mapped).
READABLE_SCHEMAS = (1, 2)
METRIC_FIELDS = ("mean", "std", "higher_is_better", "unit")
#: Fields of a result's optional ``latency`` section, seconds or null.
LATENCY_FIELDS = ("lookahead_s", "first_frame_s", "compute_per_audio_s", "rtf")
_SECTIONS = ("method", "dataset", "protocol", "metrics", "provenance", "timings")

#: Distributions whose versions are recorded when installed.
VERSIONED_PACKAGES = (
    "blendvoca", "numpy", "scipy", "torch", "transformers", "scikit-learn", "trimesh", "libigl",
    "piqp", "clarabel", "osqp", "qpsolvers", "soundfile", "soxr", "pot",
)


def package_versions(packages=VERSIONED_PACKAGES) -> dict:
    """``{distribution: version}`` for those of ``packages`` that are installed."""
    versions = {}
    for name in packages:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            continue
    if "blendvoca" not in versions:
        try:  # running from a source checkout
            import blendvoca

            versions["blendvoca"] = getattr(blendvoca, "__version__", "unknown") + "+source"
        except ImportError:
            pass
    return dict(sorted(versions.items()))


#: Folders of the checkout that hold outputs (the committed results, their archive and the
#: tables), not code: changes there do not make a run's code dirty (rows of one reproduce
#: run are written in turn, after ``--archive`` moved the old ones).
OUTPUT_FOLDERS = ("leaderboard/results", "leaderboard/results-archive", "leaderboard/tables")


def git_revision(directory=None) -> dict:
    """``{"revision": sha or None, "dirty": bool or None}`` of the git checkout at ``directory``;
    ``dirty``: uncommitted changes outside :data:`OUTPUT_FOLDERS`."""
    directory = Path(directory) if directory is not None else Path(__file__).resolve().parent
    try:
        sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=directory, capture_output=True, text=True,
                             timeout=10, check=False)
        if sha.returncode != 0:
            return {"revision": None, "dirty": None}
        outputs = [f":(top,exclude){folder}" for folder in OUTPUT_FOLDERS]
        status = subprocess.run(["git", "status", "--porcelain", "--", ":/", *outputs], cwd=directory,
                                capture_output=True, text=True, timeout=30, check=False)
        return {"revision": sha.stdout.strip(), "dirty": bool(status.stdout.strip())}
    except (OSError, subprocess.SubprocessError):
        return {"revision": None, "dirty": None}


def _cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def hardware_info() -> dict:
    """CPU model, usable cores, the BLAS kernels in use, and the GPU when torch sees one."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:
        cores = os.cpu_count()
    info = {"cpu": _cpu_name(), "cores": cores, "blas": blas_kernels(), "gpu": None}
    try:
        import torch

        if torch.cuda.is_available():
            info["gpu"] = torch.cuda.get_device_name(0)
        info["torch_threads"] = torch.get_num_threads()
    except ImportError:
        pass
    return info


def _clean_metrics(metrics) -> dict:
    if not isinstance(metrics, dict) or not metrics:
        raise TypeError(f"result metrics: expected a non-empty dict of metric -> fields, got {metrics!r}")
    out = {}
    for name, fields in sorted(metrics.items()):
        if not isinstance(fields, dict):
            raise TypeError(f"result metric {name!r}: expected a dict with {METRIC_FIELDS}, got {fields!r}")
        missing = [f for f in ("mean", "higher_is_better") if f not in fields]
        if missing:
            raise ValueError(f"result metric {name!r}: missing field(s) {missing}, got {sorted(fields)}")
        mean = float(fields["mean"])
        std = fields.get("std")
        std = None if std is None else float(std)
        if not math.isfinite(mean) or (std is not None and not math.isfinite(std)):
            raise ValueError(f"result metric {name!r}: expected finite mean/std, got mean={mean}, std={std}")
        hib = fields["higher_is_better"]
        if hib is not None and not isinstance(hib, bool):
            raise ValueError(f"result metric {name!r}: higher_is_better must be true, false or null, got {hib!r}")
        ci95 = fields.get("ci95")
        if ci95 is not None:
            if (not isinstance(ci95, (list, tuple)) or len(ci95) != 2
                    or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in ci95)):
                raise ValueError(f"result metric {name!r}: ci95 must be [low, high] of finite numbers, got {ci95!r}")
            if not ci95[0] <= mean <= ci95[1]:
                raise ValueError(f"result metric {name!r}: ci95 {list(ci95)} does not bracket the mean {mean}")
        extra = {k: v for k, v in fields.items() if k not in METRIC_FIELDS}
        out[str(name)] = {"mean": mean, "std": std, "higher_is_better": hib, "unit": fields.get("unit") or "",
                          **extra}
    return out


def current_provenance() -> dict:
    """The date, git revision and state, Python, platform, package versions and hardware now
    (a run takes it when it starts: the code that runs is the code of that moment)."""
    git = git_revision()
    return {
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "git_revision": git["revision"],
        "git_dirty": git["dirty"],
        "python": platform.python_version(),
        "platform": platform.platform(),
        "versions": package_versions(),
        "hardware": hardware_info(),
    }


def build_result(*, method: dict, dataset: dict, protocol: dict, metrics: dict, timings: dict,
                 provenance: dict | None = None, tracks: str | None = None,
                 per_sentence: list | None = None, latency: dict | None = None) -> dict:
    """Assemble and check a result record.

    Parameters
    ----------
    method : dict
        ``name``, ``label``, ``class``, ``stochastic``, ``reference``, ``config``.
    dataset : dict
        ``recipe_id``, ``manifest_hash``, ``path``, ``split`` ...
    protocol : dict
        ``samples``, ``seed``, ``budget`` ...
    metrics : dict
        ``{metric: {"mean", "std", "higher_is_better", "unit"}}`` as returned by
        ``benchmark.evaluate.evaluate_split``.
    timings : dict
        Seconds per stage.
    provenance : dict, optional
        Defaults to the current date, git revision, versions and hardware.
    tracks : str, optional
        The stored tracks folder, relative to the JSON's folder (``benchmark.runs``).
    per_sentence : list of dict, optional
        One ``{"subject", "sentence", metric: value, ...}`` row per scored sentence.
    latency : dict, optional
        ``{"lookahead_s", "first_frame_s", "compute_per_audio_s", "rtf"}`` (seconds or None).

    Returns
    -------
    dict
        JSON-serialisable record that passes :func:`check_result`.
    """
    if provenance is None:
        provenance = current_provenance()
    result = {
        "schema_version": SCHEMA_VERSION,
        "method": dict(method),
        "dataset": dict(dataset),
        "protocol": dict(protocol),
        "metrics": _clean_metrics(metrics),
        "provenance": dict(provenance),
        "timings": {k: (None if v is None else round(float(v), 3)) for k, v in timings.items()},
    }
    if tracks is not None:
        result["tracks"] = str(tracks)
    if per_sentence is not None:
        result["per_sentence"] = list(per_sentence)
    if latency is not None:
        result["latency"] = {key: (None if latency.get(key) is None else round(float(latency[key]), 4))
                             for key in LATENCY_FIELDS}
    result["method"].setdefault("label", result["method"].get("name"))
    check_result(result)
    return result


def check_result(result, where: str = "result") -> dict:
    """Raise ValueError (TypeError for non-objects) unless ``result`` follows the schema; returns it unchanged."""
    if not isinstance(result, dict):
        raise TypeError(f"{where}: expected a JSON object, got {type(result).__name__}")
    version = result.get("schema_version")
    if isinstance(version, bool) or version not in READABLE_SCHEMAS:
        raise ValueError(f"{where}: expected schema_version {SCHEMA_VERSION} (or {READABLE_SCHEMAS[0]}), got "
                         f"{version!r}")
    missing = [s for s in _SECTIONS if not isinstance(result.get(s), dict)]
    if missing:
        raise ValueError(f"{where}: missing or non-object section(s) {missing}")
    for key in ("name", "config"):
        if key not in result["method"]:
            raise ValueError(f"{where}: method section lacks {key!r}")
    for section, key in (("method", "name"), ("method", "label"), ("dataset", "manifest_hash"),
                         ("dataset", "recipe_id")):
        value = result[section].get(key)
        if value is not None and not isinstance(value, str):  # tables key and sort on these
            raise ValueError(f"{where}: {section}.{key}: expected a string, got {type(value).__name__}")
    if not result["dataset"].get("manifest_hash") and not result["dataset"].get("recipe_id"):
        raise ValueError(f"{where}: dataset section lacks 'recipe_id' (and 'manifest_hash')")
    _clean_metrics(result["metrics"])
    latency = result.get("latency")
    if latency is not None:
        if not isinstance(latency, dict):
            raise ValueError(f"{where}: latency: expected an object, got {type(latency).__name__}")
        for key, value in latency.items():
            if key not in LATENCY_FIELDS:
                raise ValueError(f"{where}: latency.{key}: unknown field; expected some of {LATENCY_FIELDS}")
            if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float))
                                      or not math.isfinite(value) or value < 0):
                raise ValueError(f"{where}: latency.{key}: expected seconds >= 0 or null, got {value!r}")
    try:
        json.dumps(result, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{where}: not JSON-serialisable ({exc})") from exc
    return result


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9._-]+", "-", str(text).lower()).strip("-") or "method"


def dataset_key(result: dict) -> str:
    """The identity of the dataset a result was scored on: ``dataset.recipe_id``, or for a result
    written before recipe ids existed its ``dataset.manifest_hash`` (the content hash)."""
    dataset = result["dataset"]
    return str(dataset.get("recipe_id") or dataset["manifest_hash"])


def result_filename(result: dict) -> str:
    """``<label>__<recipe id[:12]>__s<samples>__seed<seed>.json`` (one file per run setting;
    :func:`dataset_key`); a run over several training seeds (``protocol.seeds``) ends
    ``__seeds0-1-2.json``."""
    label = _slug(result["method"].get("label") or result["method"]["name"])
    manifest = _slug(dataset_key(result))[:12]
    protocol = result["protocol"]
    seeds = protocol.get("seeds")
    seed = f"seeds{'-'.join(str(int(s)) for s in seeds)}" if seeds else f"seed{protocol.get('seed')}"
    return f"{label}__{manifest}__s{protocol.get('samples')}__{seed}.json"


def _with_current_names(result: dict) -> dict:
    """A schema-1 result with its metric names (in ``metrics`` and the per-sentence rows)
    mapped to the reference space its row was scored in; other results unchanged."""
    if result.get("schema_version") != 1:
        return result
    from benchmark.metrics.registry import current_name

    output = result["method"].get("output") or "coefficients"
    metrics = {current_name(name, output): fields for name, fields in result["metrics"].items()}
    out = {**result, "metrics": metrics}
    rows = result.get("per_sentence")
    if isinstance(rows, list):
        out["per_sentence"] = [{current_name(k, output): v for k, v in row.items()} if isinstance(row, dict) else row
                               for row in rows]
    return out


def write_result(result: dict, results_dir, filename: str | None = None) -> Path:
    """Check ``result`` and write it atomically into ``results_dir``
    (`blendvoca.io.atomic.atomic_write`: a crash never leaves a partial result file).

    Returns
    -------
    Path
        The written file.
    """
    check_result(result)
    text = json.dumps(result, indent=2, sort_keys=True, allow_nan=False) + "\n"
    path = Path(results_dir) / (filename or result_filename(result))
    with atomic_write(path, "w", encoding="utf-8") as handle:
        handle.write(text)
    return path


def read_result(path) -> dict:
    """Load and check one result file (a schema-1 file with its metric names mapped, see
    the module docstring).

    Raises
    ------
    DataError
        The file is not JSON or does not follow the schema (:func:`check_result`).
    OSError
        It cannot be read.
    """
    path = Path(os.fspath(path))
    result = read_json(path, what="valid JSON")
    try:
        return _with_current_names(check_result(result, where=str(path)))
    # check_result's word on a file's content; OverflowError: an integer too large for a float.
    except (TypeError, ValueError, OverflowError) as exc:
        message = str(exc)
        raise DataError(message if message.startswith(str(path)) else f"{path}: {message}") from None
