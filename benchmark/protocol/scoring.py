"""The protocol's third step: the metrics of what was generated
(:func:`benchmark.evaluation.evaluate_split` unless a run brings its own evaluation)."""

from __future__ import annotations

import os
import pickle
import time
import zipfile
from dataclasses import dataclass

from benchmark.evaluation import EvaluationSettings, evaluate_split
from benchmark.evaluation.entries import sentence_entries
from benchmark.evaluation.lipsync import lipsync_values, load_lipsync_models
from benchmark.metrics.bootstrap import BOOTSTRAP_RESAMPLES
from benchmark.evaluation.registry import METRICS
from blendvoca.errors import BlendVOCAError, UserError

__all__ = ["MODEL_LIPSYNC_METRICS", "Scored", "loaded_lipsync_models", "run_settings", "score", "score_lipsync_models"]

#: The lip-sync metrics that need a model file: SyncNet weights or a learned sync expert.
MODEL_LIPSYNC_METRICS = tuple(f"av_{kind}_{model}" for model in ("expert", "syncnet")
                              for kind in ("offset", "confidence", "offset_signed", "lag_bias"))

#: What loading a file that holds no such model raises (torch's readers included; a
#: state_dict of other shapes is torch's RuntimeError).
_NOT_A_MODEL = (ValueError, KeyError, TypeError, RuntimeError, EOFError, pickle.UnpicklingError, zipfile.BadZipFile)


@dataclass(frozen=True)
class Scored:
    """The metrics of a run.

    Attributes
    ----------
    metrics : dict
        ``{metric: {"mean", "std", "higher_is_better", "unit", ...}}`` as the
        evaluation returned them (``benchmark.evaluation.Scores`` by default).
    per_sentence : list of dict
        One ``{"subject", "sentence", metric: value, ...}`` row per generated sentence,
        in the generated order (subject and sentence only where the evaluation gives
        no rows).
    seconds : float
        Wall time of the scoring.
    """

    metrics: dict
    per_sentence: list
    seconds: float = 0.0


def loaded_lipsync_models(syncnet=None, sync_expert=None):
    """SyncNet and the sync expert loaded where they are given as paths (models, None and
    ``syncnet=True``, the manifest's asset, as :class:`benchmark.evaluation.EvaluationSettings` takes them).

    Returns
    -------
    syncnet, sync_expert : model or None

    Raises
    ------
    UserError
        A file that holds no such model, naming ``--syncnet-weights`` or ``--sync-expert``.
    """
    return (_loaded(lambda: load_lipsync_models(syncnet, None)[0], "--syncnet-weights", syncnet),
            _loaded(lambda: load_lipsync_models(None, sync_expert)[1], "--sync-expert", sync_expert))


def _loaded(load, flag: str, value):
    """``load()``; a file that holds no such model is a UserError naming ``flag``."""
    try:
        return load()
    except BlendVOCAError:
        raise
    except _NOT_A_MODEL as exc:  # the file is the user's: one line naming it, not a traceback
        where = os.fspath(value) if isinstance(value, os.PathLike) else value
        raise UserError(f"{flag} {where}: {type(exc).__name__}: {exc}") from exc


def _per_sentence_rows(metrics, generated) -> list:
    """One row per scored sentence: the evaluation's rows (``Scores.per_sentence``) or, for an
    evaluation that gives none, the sentence's subject and name."""
    rows = {(r["subject"], r["sentence"]): r for r in getattr(metrics, "per_sentence", None) or []}
    return [dict(rows.get(key, {"subject": key[0], "sentence": key[1]})) for key in generated]


def score(spec, dataset, generated, *, evaluate=None) -> Scored:
    """Score ``generated`` on ``spec.split``.

    Parameters
    ----------
    spec : RunSpec
    dataset : benchmark.data dataset
    generated : Generated
    evaluate : callable, optional
        ``evaluate(tracks, dataset, split=..., [vertices=...]) -> {metric: {...}}``;
        default :func:`benchmark.evaluation.evaluate_split` with ``spec``'s lip-sync models
        and VAE (:func:`run_settings`).

    Returns
    -------
    Scored
    """
    start = time.perf_counter()
    if evaluate is None:
        metrics = evaluate_split(generated, dataset, spec.split, run_settings(spec))
    else:
        extra = {} if generated.vertices is None else {"vertices": generated.vertices}
        metrics = evaluate(generated.tracks, dataset, split=spec.split, **extra)
    seconds = time.perf_counter() - start
    return Scored(metrics=metrics, per_sentence=_per_sentence_rows(metrics, generated.tracks), seconds=seconds)


def run_settings(spec, *, lipsync: bool = True) -> EvaluationSettings:
    """The evaluation settings of the run ``spec``: the protocol's, with its lip-sync models
    (loaded: a file that holds none is a UserError) and its VAE (``spec.vae``, a VAE
    trained on this dataset by ``benchmark.features.train``) where it names them.
    ``lipsync=False``: without the lip-sync models (the learning curve's check metrics)."""
    models = {}
    if lipsync and spec.evaluates_lipsync_models:
        models["syncnet"], models["sync_expert"] = loaded_lipsync_models(spec.syncnet, spec.sync_expert)
    if getattr(spec, "vae", None) is not None:
        models["extractor"] = str(spec.vae)
    return EvaluationSettings(**models)


def score_lipsync_models(tracks, dataset, *, syncnet=None, sync_expert=None) -> Scored:
    """The model-based lip-sync metrics (:data:`MODEL_LIPSYNC_METRICS`) of ``tracks``,
    computed as :func:`score` computes them in a whole evaluation (same values, same
    bootstrap seed and resamples).

    Parameters
    ----------
    tracks : mapping (subject, sentence) -> (S, T, K) array_like
    dataset : benchmark.data dataset
        Gives the rigs, the audio and the column names.
    syncnet, sync_expert : path-like or model, optional
        At least one.

    Returns
    -------
    Scored
        Only the metrics of the models given; rows in the order of ``tracks``.
    """
    if syncnet is None and sync_expert is None:
        raise UserError("expected --sync-expert and/or --syncnet-weights, got neither")
    keys = list(tracks)
    start = time.perf_counter()
    rigs = {s: dataset.rig(s) for s in {k[0] for k in keys}}
    audio = {k: dataset.audio(*k) for k in keys}
    ground_truth = {k: dataset.coeffs(*k) for k in keys}
    syncnet_model, expert_model = loaded_lipsync_models(syncnet, sync_expert)
    values = lipsync_values(tracks, rigs, audio, dataset.names, syncnet=syncnet_model, sync_expert=expert_model,
                            ground_truth=ground_truth)
    values = {name: v for name, v in values.items() if name in MODEL_LIPSYNC_METRICS}
    # evaluate_split's own bootstrap seed (0), as a run scores: same tracks, same intervals
    metrics, rows, _replicates = sentence_entries(values, METRICS, seed=0, resamples=BOOTSTRAP_RESAMPLES)
    per_sentence = [{"subject": k[0], "sentence": k[1], **rows.get(k, {})} for k in keys]
    return Scored(metrics=metrics, per_sentence=per_sentence, seconds=time.perf_counter() - start)
