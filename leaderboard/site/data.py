"""The data files of the results site, computed from stored runs.

Everything the pages show is written here as JSON next to copies of the audio and
one GLB rig per speaker, so the pages only fetch and draw:

    data/leaderboard.json                         tables (one per dataset), rows, intervals, seed ranges,
                                                  best marks and their rule, probabilities of improvement
    data/runs/<run>.json                          one run: provenance, per-sentence scores
    data/sentences/<subject>/<sentence>.json      ground truth: coefficients, lip motion, envelope (dB, scaled to [0, 1])
    data/tracks/<run>/<subject>/<sentence>-<k>.json   one generated sample: coefficients, lip motion
    data/audio/<subject>/<sentence>.wav           the sentence's speech
    data/rigs/<subject>.glb                       the speaker's rig, one morph target per shape
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import shutil
from pathlib import Path

import numpy as np

from benchmark.data import open_blendvoca
from benchmark.metrics.vertex import rig_vertices
from benchmark.results import Result, read
from benchmark.runs import read_run
from blendvoca.errors import DataError, UserError
from blendvoca.export.glb import write_glb
from blendvoca import format as fmt
from blendvoca.format import audio_path
from blendvoca.io.coeffs import read_coeffs_csv
from blendvoca.rig_regions import lip_vertices
from blendvoca.runtime.progress import bar
from leaderboard.collect import (
    MIN_PAIRED_SENTENCES,
    best_mark,
    check_corpora,
    check_records,
    check_scoring_models,
    pairwise_probabilities,
    result_files,
    tables_by_manifest,
)
from leaderboard.render import AV_OFFSET_NOTE, not_settled_text
from leaderboard.settled import tables_with_statements


__all__ = ["SiteRun", "load_site_runs", "with_dataset", "write_site_data"]

_DECIMALS = 4


class SiteRun:
    """One stored run as the site sees it: the result and the tracks it stored."""

    def __init__(self, path: Path, result: Result):
        self.path = Path(path)
        self.result = result
        self.id = self.path.stem

    @property
    def label(self) -> str:
        return self.result.label

    @property
    def dataset_root(self) -> Path | None:
        """The BlendVOCA build the run was scored on, if it is on this machine: the folder
        ``dataset.path`` names only when it is a BlendVOCA build of the run's dataset
        identity (a path such as ``/etc`` in a result file is not followed)."""
        path = self.result.dataset.path
        identity = _build_identity(str(path)) if path else None
        if identity is None or self.result.key not in identity:
            return None
        return Path(path)

    @property
    def recipe_id(self) -> str:
        """The identity of the dataset the run was scored on (:attr:`benchmark.results.Result.key`)."""
        return self.result.key

    def tracks(self) -> dict[tuple[str, str], list[Path]]:
        """``{(subject, sentence): [csv of sample 0, 1, ...]}`` stored with the run (empty if none)."""
        try:
            stored = read_run(self.path)
        except (DataError, FileNotFoundError):  # a run stored without tracks: nothing to play back
            return {}
        return {key: stored.track_paths(*key) for key in stored.keys}


@functools.lru_cache(maxsize=64)
def _build_identity(path: str) -> tuple | None:
    """``(recipe id, content hash)`` of the BlendVOCA build at ``path``; None when it is
    not one (no folder, no ``manifest.json``, an unreadable manifest)."""
    if not Path(path).is_dir() or not fmt.manifest_path(path).is_file():
        return None
    try:
        return fmt.dataset_id(path), fmt.manifest_hash(path)
    except (DataError, OSError, ValueError):
        return None


def load_site_runs(results_dir) -> list[SiteRun]:
    """Every result JSON in ``results_dir`` (:func:`benchmark.results.read`), sorted by file name.

    Raises
    ------
    UserError
        No such folder, or no result in it.
    DataError
        A file that is not a result, or results of different lip-sync models on one
        dataset (``leaderboard.collect.check_scoring_models``).
    """

    results_dir = Path(results_dir)
    if not results_dir.is_dir():
        raise UserError(f"leaderboard.site: results folder {results_dir} does not exist")
    paths = result_files(results_dir)
    runs = [SiteRun(path, read(path)) for path in paths]
    if not runs:
        raise UserError(f"leaderboard.site: {results_dir} holds no result *.json files")
    check_records([run.result for run in runs], paths)
    check_corpora([run.result for run in runs], paths)
    check_scoring_models([run.result for run in runs], paths)
    return runs


def _round(values) -> list:
    """Nested lists of floats at the site's precision (JSON has no NaN: None)."""
    arr = np.asarray(values, dtype=np.float64)
    return np.where(np.isfinite(arr), np.round(arr, _DECIMALS), None).tolist()


def _number(x):
    return None if x is None or not math.isfinite(float(x)) else float(x)


def _write_json(path: Path, data) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, separators=(",", ":"), sort_keys=True) + "\n")


def _column_spec(column) -> dict:
    return {"label": column.label, "unit": column.unit, "higher_is_better": column.higher_is_better,
            "group": column.group}


def _row_data(row, run: SiteRun) -> dict:
    return {
        "run": run.id,
        "label": row.label,
        "reference": row.reference,
        "output": row.output,
        "samples": row.samples,
        "seeds": list(row.seeds),
        "settled": row.settled,
        "not_settled": not_settled_text(row) if row.settled is False else None,
        "has_tracks": bool(run.tracks()) and run.dataset_root is not None,
        # the result's latency record (seconds), None for results written before it
        "latency": ({key: _number(value) for key, value in latency.to_json().items()
                     if key != "lookahead_probe"}  # the probe's record: in the result file
                    if (latency := run.result.latency) is not None else None),
        "metrics": {
            name: {"mean": _number(mean), "std": _number(std),
                   "ci95": [_number(v) for v in ci95] if ci95 else None,
                   "seed_range": ([_number(v) for v in row.seed_ranges[name]] if name in row.seed_ranges else None),
                   "n": run.result.metrics[name].n}
            for name, (mean, std, ci95) in row.metrics.items()
        },
    }


def _probability(p):
    return None if p is None else round(float(p), _DECIMALS)


def leaderboard_data(runs) -> dict:
    """The leaderboard page's tables, as ``leaderboard.collect`` arranges them: one per
    dataset manifest, columns grouped in the registry's order, methods and reference
    rows apart, best marks by ``leaderboard.collect.best_mark`` (with the rule that
    made each and its probability), and the probability of improvement between any two
    rows per metric (``leaderboard.collect.pairwise_probabilities``; rows in the order
    of ``improvement.runs``: the methods, then the reference rows)."""

    tables = []
    for table in tables_with_statements([run.result for run in runs]):
        methods = [_row_data(row, runs[row.source]) for row in table.rows]
        references = [_row_data(row, runs[row.source]) for row in table.references]
        for row in methods:
            row["best"] = []
        best_rule, best_probability = {}, {}
        for column in table.columns:
            mark = best_mark(table.rows, column)
            for index in mark.rows:
                methods[index]["best"].append(column.name)
            best_rule[column.name] = mark.rule
            best_probability[column.name] = _probability(mark.probability)
        every = table.rows + table.references
        improvement = {}
        for column in table.columns:
            matrix = pairwise_probabilities(every, column)
            if any(p is not None for line in matrix for p in line):
                improvement[column.name] = [[_probability(p) for p in line] for line in matrix]
        tables.append({
            "manifest_hash": table.manifest_hash,
            "name": table.name,
            "latent_out_of_domain": bool(table.latent_out_of_domain),
            "vae": table.vae,
            "split": table.split,
            "num_sentences": table.num_sentences,
            "metrics": {column.name: _column_spec(column) for column in table.columns},
            "groups": [{"name": group, "metrics": [c.name for c in columns]} for group, columns in table.groups],
            "methods": methods,
            "references": references,
            "best_rule": best_rule,
            "best_probability": best_probability,
            "improvement": {"runs": [r["run"] for r in methods + references], "metrics": improvement},
            "notes": {
                "av_offset": (AV_OFFSET_NOTE if any(c.name.startswith(("av_offset_", "av_lag_bias_"))
                                                    for c in table.columns) else None),
                "fallback": [name for name, rule in best_rule.items() if rule == "intervals"],
                "min_sentences": MIN_PAIRED_SENTENCES,
            },
        })
    return {"tables": tables}


def _per_sentence(result: Result) -> list[dict]:
    """Per-sentence rows as ``{subject, sentence, metrics: {name: value}}``."""
    rows = []
    for entry in result.per_sentence or ():
        values = entry.get("metrics")
        if values is None:
            values = {k: v for k, v in entry.items() if k not in ("subject", "sentence")}
        rows.append({"subject": entry["subject"], "sentence": entry["sentence"],
                     "metrics": {k: _number(v) if isinstance(v, (int, float)) else None for k, v in values.items()}})
    return rows


def run_page_data(run: SiteRun) -> dict:
    """The method page's data for one run (tracks only when its dataset is here)."""
    result = run.result
    record = result.to_json()
    tracks = run.tracks() if run.dataset_root is not None else {}
    specs = _run_metric_specs(run)
    return {
        "run": run.id,
        "label": run.label,
        "method": record["method"],
        "dataset": record["dataset"],
        "protocol": record["protocol"],
        "provenance": {k: record.get(k) for k in ("versions", "git", "hardware", "date", "timings") if k in record},
        "seeds": result.training_seeds(),
        "per_seed": [{"seed": entry.seed, "metrics": entry.metrics or {}} for entry in result.per_seed or ()],
        "convergence": record.get("convergence"),
        "metrics": specs,
        "metric_order": list(specs),  # the JSON object's keys are written sorted
        "per_sentence": _per_sentence(result),
        "sentences": [{"subject": s, "sentence": q, "samples": len(paths)} for (s, q), paths in tracks.items()],
        "tracks_note": _tracks_note(run),
    }


def _run_metric_specs(run: SiteRun) -> dict:
    """``{metric: {label, unit, higher_is_better, group}}`` of one run, in table order."""
    (table,) = tables_by_manifest([run.result])
    return {column.name: _column_spec(column) for column in table.columns}


def _tracks_note(run: SiteRun) -> str | None:
    """Why a run's tracks cannot be shown, or None."""
    if not run.result.tracks:
        return "This run stored no tracks."
    if not run.tracks():
        return ("This run's generated tracks are not next to its result file, so it has no plots or 3D playback "
                "(committed leaderboard results hold the scores only; python -m leaderboard.reproduce recreates "
                "their tracks).")
    if run.dataset_root is None:
        return (f"The dataset this run was scored on ({run.result.dataset.path}) is not on the machine "
                f"that made this site (or that folder is not a build of this run's dataset); rebuild the site "
                f"with --data DIR pointing at a copy to see its tracks.")
    return None


class _SentenceData:
    """Ground truth, rigs and lip vertex sets of one dataset, cached per subject."""

    def __init__(self, root: Path):
        self.dataset = open_blendvoca(root)
        self._rigs = {}

    def rig(self, subject):
        if subject not in self._rigs:
            rig = self.dataset.rig(subject)
            names = tuple(self.dataset.names)
            rig = rig.select(names) if tuple(rig.names) != names else rig
            self._rigs[subject] = (rig, lip_vertices(rig.deltas, rig.names))
        return self._rigs[subject]

    def lip_motion_mm(self, subject, coeffs) -> np.ndarray:
        """Mean lip-vertex displacement per frame (mm) of the rig driven by ``coeffs``."""
        from benchmark.lipsync.geometric import mouth_activity  # torch: loaded only for tracks

        rig, lips = self.rig(subject)
        vertices = rig_vertices(rig.neutral, rig.deltas, coeffs)
        return 1000.0 * mouth_activity(vertices, rig.neutral, lips)


def with_dataset(runs, data) -> list[SiteRun]:
    """``runs`` with ``dataset.path`` set to ``data`` for every run scored on that dataset
    (same recipe id: a build of the same corpus, tool and parameters, on any machine),
    so a site can be made where the data lives elsewhere.

    Raises
    ------
    UserError
        No run was scored on ``data``.
    """
    data = Path(data).expanduser().resolve()
    dataset = open_blendvoca(data)
    digest = dataset.recipe_id
    # A run that records no recipe id (written before they existed) matches its build's content hash.
    matched = [run for run in runs if run.recipe_id == digest
               or (not run.result.dataset.recipe_id and run.result.dataset.manifest_hash == dataset.manifest_hash)]
    if not matched:
        raise UserError(f"leaderboard.site: --data {data} (recipe {digest[:12]}) is not the dataset of any run "
                         f"(their recipes: {sorted({r.recipe_id[:12] for r in runs})})")
    for run in matched:
        run.result = dataclasses.replace(run.result, dataset=dataclasses.replace(run.result.dataset, path=str(data)))
    return runs


def write_site_data(runs, data_dir, *, max_samples: int = 3) -> dict:
    """Write every data file of the site into ``data_dir``.

    Parameters
    ----------
    runs : list of SiteRun
    data_dir : path-like
    max_samples : int
        Samples of a stochastic run offered for playback.

    Returns
    -------
    dict
        Counts of what was written (``runs``, ``sentences``, ``tracks``, ``rigs``).
    """
    from benchmark.lipsync.envelope import speech_envelope  # torch: loaded only for tracks

    data_dir = Path(data_dir)
    _write_json(data_dir / "leaderboard.json", leaderboard_data(runs))
    counts = {"runs": 0, "sentences": 0, "tracks": 0, "rigs": 0}
    datasets: dict[Path, _SentenceData] = {}
    done_sentences, done_rigs = set(), set()
    work = [(run, key, paths) for run in runs if run.dataset_root is not None for key, paths in run.tracks().items()]
    work = bar(work, desc="site: tracks", unit="sentence")
    for run in runs:
        _write_json(data_dir / "runs" / f"{run.id}.json", run_page_data(run))
        counts["runs"] += 1
    for run, (subject, sentence), paths in work:
        root = run.dataset_root
        data = datasets.get(root) or datasets.setdefault(root, _SentenceData(root))
        names = tuple(data.dataset.names)
        if (root, subject, sentence) not in done_sentences:
            gt = data.dataset.coeffs(subject, sentence)
            audio, rate = data.dataset.audio(subject, sentence)
            envelope = speech_envelope(audio, rate=rate, fps=60.0, num_frames=gt.shape[0])
            _write_json(data_dir / "sentences" / subject / f"{sentence}.json", {
                "subject": subject, "sentence": sentence, "fps": 60, "names": list(names),
                "coeffs": _round(gt), "lip_motion_mm": _round(data.lip_motion_mm(subject, gt)),
                "envelope": _round((envelope - envelope.min()) / max(float(np.ptp(envelope)), 1e-12)),
                "duration": audio.shape[0] / rate,
            })
            src = audio_path(root, subject, sentence)
            (data_dir / "audio" / subject).mkdir(parents=True, exist_ok=True)
            shutil.copyfile(src, data_dir / "audio" / subject / f"{sentence}.wav")
            done_sentences.add((root, subject, sentence))
            counts["sentences"] += 1
        if (root, subject) not in done_rigs:
            rig, _ = data.rig(subject)
            (data_dir / "rigs").mkdir(parents=True, exist_ok=True)
            write_glb(data_dir / "rigs" / f"{subject}.glb", rig, np.zeros((1, len(rig.names))), rig.names)
            done_rigs.add((root, subject))
            counts["rigs"] += 1
        for k, csv in enumerate(paths[:max_samples]):
            coeffs, _ = read_coeffs_csv(csv, names=names)
            coeffs = np.asarray(coeffs, dtype=np.float64)
            _write_json(data_dir / "tracks" / run.id / subject / f"{sentence}-{k}.json", {
                "coeffs": _round(coeffs), "lip_motion_mm": _round(data.lip_motion_mm(subject, coeffs)),
            })
            counts["tracks"] += 1
    return counts
