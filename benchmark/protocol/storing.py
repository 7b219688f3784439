"""The protocol's last step: the result JSON (:mod:`benchmark.results`) and, next to
it, the folder of the tracks that were scored (:mod:`benchmark.runs`)."""

from __future__ import annotations

import json
import os
from pathlib import Path

from benchmark.methods.contract import COEFFICIENT_NAMES
from benchmark.protocol.limits import generate_limit
from benchmark.results import build_result, result_filename, write_result
from benchmark.runs import TrackWriter, tracks_folder_name
from blendvoca.errors import MethodError
from blendvoca.format import content_digest

__all__ = ["lipsync_models_provenance", "result_name", "store", "track_writer", "write_run"]


def result_name(spec, dataset, trained) -> str:
    """The result file's name: one per method label, build, samples and seed
    (:func:`benchmark.results.result_filename`)."""
    return result_filename({"method": {"name": spec.method, "label": trained.label},
                            "dataset": {"manifest_hash": str(dataset.manifest_hash)},
                            "protocol": {"samples": spec.samples if trained.stochastic else 1, "seed": int(spec.seed)}})


def track_writer(spec, inputs, trained) -> TrackWriter:
    """A staging folder for the run's tracks, moved to its final name by :func:`store`
    (``discard()`` it when a step fails)."""
    names = tuple(getattr(inputs.dataset, "names", ()) or COEFFICIENT_NAMES)
    filename = result_name(spec, inputs.dataset, trained)
    return TrackWriter(Path(inputs.results_dir) / tracks_folder_name(filename), names)


def lipsync_models_provenance(syncnet=None, sync_expert=None) -> dict:
    """What a result records of the lip-sync models it was scored with: the files and,
    for the learned expert, the data it was trained on."""

    def model_file(model) -> dict:
        """``{"path", "sha256"}`` of a model given as a path; ``{"path": None}`` for a loaded one."""
        if not isinstance(model, (str, os.PathLike)):
            return {"path": None}
        return {"path": str(Path(model).resolve()), "sha256": content_digest(model)}

    out = {}
    if syncnet is not None:
        out["syncnet"] = model_file(syncnet)
    if sync_expert is not None:
        from benchmark.lipsync.expert import load_expert

        expert = load_expert(sync_expert) if isinstance(sync_expert, (str, os.PathLike)) else sync_expert
        out["sync_expert"] = {**model_file(sync_expert), "trained_on": dict(getattr(expert, "trained_on", {}) or {})}
    return out


def _limit_record(value) -> dict | None:
    """What a result records of a run's generation limit: ``{"base_s", "per_audio_second_s"}``,
    or None for a run without one."""
    limit = generate_limit(value)
    return None if limit is None else limit.to_dict()


def _method_config(trained) -> dict:
    """The method's ``config()``, which a result file must be able to hold."""
    try:
        config = trained.method.config()
        json.dumps(config)
    except Exception as exc:
        raise MethodError(f"method {trained.name!r}: config() must return a JSON-serialisable dict ({exc})") from exc
    return config


def store(spec, inputs, trained, generated, scored, *, writer: TrackWriter, timings: dict,
          provenance: dict) -> Path:
    """Write the run: its tracks folder (``writer`` committed) and its result JSON.

    Parameters
    ----------
    spec : RunSpec
    inputs : Inputs
    trained : Trained
    generated : Generated
    scored : Scored
    writer : benchmark.runs.TrackWriter
        From :func:`track_writer`, holding the generated tracks.
    timings : dict
        Seconds per step: ``train_s``, ``load_s``, ``generate_s``, ``evaluate_s``, ``total_s``.
    provenance : dict
        ``benchmark.results.current_provenance()`` taken when the run started.

    Returns
    -------
    Path
        The result file.

    Raises
    ------
    MethodError
        The method's ``config()`` is not a JSON-serialisable dict (nothing written).
    """
    method_config = _method_config(trained)
    cls = type(trained.method)
    checkpoint = spec.checkpoint
    filename = result_name(spec, inputs.dataset, trained)
    data_root = inputs.data_root
    result = build_result(
        method={
            "name": spec.method,
            "label": trained.label,
            "class": f"{cls.__module__}:{cls.__qualname__}",
            "stochastic": trained.stochastic,
            "reference": bool(getattr(trained.method, "reference", False)),
            "output": trained.output,
            "config": method_config,
        },
        dataset={
            "manifest_hash": str(inputs.dataset.manifest_hash),
            "path": str(Path(data_root).resolve()) if isinstance(data_root, (str, os.PathLike)) else str(data_root),
            "split": spec.split,
            "num_subjects": len({s for s, _ in generated.tracks}),
            "num_sentences": len(generated.tracks),
        },
        protocol={
            "samples": spec.samples if trained.stochastic else 1,
            "seed": int(spec.seed),
            "budget": spec.budget.to_dict(),
            "clip": bool(spec.clip),
            "n_clipped": int(generated.n_clipped),
            "checkpoint": None if checkpoint is None else str(checkpoint),
            **({"checkpoint_sha256": content_digest(checkpoint)}
               if checkpoint is not None and Path(checkpoint).exists() else {}),
            "deterministic": spec.budget.max_seconds is None,
            "generate_time_limit": _limit_record(spec.generate_time_limit),
            "verified": inputs.verified is not None,
            **({"sentence_batch": spec.sentence_batch} if spec.sentence_batch > 1 else {}),
            **({"lipsync_models": lipsync_models_provenance(spec.syncnet, spec.sync_expert)}
               if spec.evaluates_lipsync_models else {}),
        },
        metrics=dict(scored.metrics),
        timings=timings,
        tracks=tracks_folder_name(filename),
        per_sentence=scored.per_sentence,
        provenance=provenance,
    )
    return write_run(result, inputs.results_dir, filename, writer=writer)


def write_run(result: dict, results_dir, filename: str | None = None, *, writer: TrackWriter | None = None) -> Path:
    """Commit ``writer``'s tracks folder (when given), then write ``result`` atomically
    into ``results_dir`` (:func:`benchmark.results.write_result`).

    Returns
    -------
    Path
        The result file.
    """
    if writer is not None:
        writer.commit()
    return write_result(result, results_dir, filename)
