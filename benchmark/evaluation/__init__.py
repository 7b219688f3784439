"""Evaluation protocol: every metric of a method's generated tracks on a split.

``evaluate_split(generated, dataset, split, settings)`` where
``generated[(subject, sentence)]`` is an ``(S, T, 32)`` array (S samples, 60 fps,
BlendVOCA column order) returns :class:`Scores`: a dict ``{metric: entry}`` with
``entry = {"mean", "std", "ci95": [lo, hi], "n", "higher_is_better", "unit",
"label", "group"}`` (plus ``"sample_std"`` for S >= 2), and ``Scores.per_sentence``,
one row per scored sentence. ``settings`` is one frozen :class:`EvaluationSettings`.

The metrics come in families, each a module that computes them and declares their
metadata (:class:`benchmark.metrics.info.MetricInfo`, gathered by
:mod:`benchmark.evaluation.registry`): :mod:`~benchmark.evaluation.latent` (FD, WInD,
multimodality, latent energy), :mod:`~benchmark.evaluation.vertex` (vertex errors,
energy and diversity in the two reference spaces),
:mod:`~benchmark.evaluation.lipsync` (AV offset, lag bias and confidence) and
:mod:`~benchmark.evaluation.dynamics` (each region's motion against the ground
truth's level, the mouth's in the silences). Intervals:
:mod:`benchmark.metrics.bootstrap`. See docs/metrics.md for the definitions and the
window protocol.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping

import numpy as np

from benchmark.evaluation.dynamics import METRICS as DYNAMICS_METRICS
from benchmark.evaluation.dynamics import dynamics_metrics
from benchmark.evaluation.entries import Scores, sentence_entries
from benchmark.evaluation.latent import METRICS as LATENT_METRICS
from benchmark.evaluation.latent import fd_floor_probe, latent_metrics, latent_results, resolve_extractor
from benchmark.evaluation.lipsync import METRICS as LIPSYNC_METRICS
from benchmark.evaluation.lipsync import lipsync_metrics, lipsync_values, load_lipsync_models
from benchmark.evaluation.registry import METRICS, ordered_metrics
from benchmark.evaluation.settings import FD_RESAMPLES, WIND_RESAMPLES, EvaluationSettings
from benchmark.evaluation.vertex import own_vertex_metrics, sentence_vertex_values, vertex_metrics, vertex_values
from benchmark.metrics.windows import GT_DROP_LAST, window_starts
from blendvoca.errors import out_of_resources, ran_out_of

__all__ = [
    "FD_RESAMPLES",
    "EvaluationSettings",
    "Scores",
    "WIND_RESAMPLES",
    "evaluate_split",
    "latent_metrics",
    "lipsync_metrics",
    "own_vertex_metrics",
    "sentence_vertex_values",
    "vertex_metrics",
]


def _requested(metrics) -> frozenset | None:
    if metrics is None:
        return None
    names = frozenset([metrics] if isinstance(metrics, str) else metrics)
    unknown = sorted(names - set(METRICS))
    if unknown:
        raise ValueError(f"evaluate_split: unknown metric(s) {unknown}; registered: {sorted(METRICS)}")
    return names


def _tracks_and_vertices(generated):
    """``(tracks, own vertices or None)`` of a mapping or of a record with ``tracks`` and ``vertices``."""
    if isinstance(generated, Mapping):
        return generated, None
    if hasattr(generated, "tracks") and hasattr(generated, "vertices"):
        return generated.tracks, generated.vertices
    raise TypeError("evaluate_split: generated must map (subject, sentence) -> (S, T, K) tracks or have .tracks and "
                    f".vertices (benchmark.protocol.Generated), got {type(generated).__name__}")


def _check_generated(generated: Mapping, keys: list, channels: int) -> dict:
    if not isinstance(generated, Mapping):
        raise TypeError(f"evaluate_split: generated must map (subject, sentence) -> (S, T, {channels}), "
                        f"got {type(generated).__name__}")
    out = {}
    for key in keys:
        if key not in generated:
            continue
        tracks = np.asarray(generated[key], dtype=np.float64)
        if tracks.ndim == 2:
            tracks = tracks[None]
        if tracks.ndim != 3 or tracks.shape[2] != channels or tracks.shape[0] < 1:
            raise ValueError(f"evaluate_split: generated[{key!r}] must be (S, T, {channels}), got {tracks.shape}")
        if not np.all(np.isfinite(tracks)):
            raise ValueError(f"evaluate_split: generated[{key!r}] contains NaN or inf")
        out[key] = tracks
    if not out:
        raise ValueError(f"evaluate_split: no generated track matches the split's {len(keys)} (subject, sentence) keys")
    return out


def _has_source_meshes(dataset) -> bool:
    """Whether ``dataset.vertices`` are source meshes (``vertex_space`` ``"mesh"``, the default)."""
    return getattr(dataset, "vertex_space", "mesh") == "mesh"


def _source_meshes(dataset, keys, mesh):
    """``dataset.vertices`` when the mesh space is scored, else None (``mesh=None``: when the
    dataset can give its source meshes, with a warning when it cannot). A dataset whose
    ``vertex_space`` is ``"rig"`` has no source meshes (its vertices are the rig's
    reconstruction of the ground truth, the rig space's reference): None, with the warning."""
    if mesh is False:
        return None
    if not _has_source_meshes(dataset):
        why = (f"{dataset!r} has no source meshes: its vertices are the rig's reconstruction of the ground truth, "
               "vertex_space 'rig'")
        if mesh:
            raise ValueError(f"evaluate_split: {why}")
        warnings.warn(f"evaluate_split: the source meshes cannot be read ({why}); the mesh-space metrics (*_mesh) "
                      "are not computed", stacklevel=3)
        return None
    vertices = getattr(dataset, "vertices", None)
    try:
        if vertices is None:
            raise AttributeError(f"{type(dataset).__name__} has no vertices()")
        vertices(*keys[0])
    except (AttributeError, NotImplementedError, OSError, KeyError, ValueError) as exc:
        if ran_out_of(exc) is not None:  # the meshes are there, the memory is not: never a smaller result
            raise out_of_resources(exc, "evaluate_split: reading the source meshes for the mesh-space metrics") \
                from exc
        if mesh:
            raise
        warnings.warn(f"evaluate_split: the source meshes cannot be read ({type(exc).__name__}: {exc}); "
                      "the mesh-space metrics (*_mesh) are not computed", stacklevel=3)
        return None
    return vertices


def evaluate_split(generated, dataset, split: str = "test", settings: EvaluationSettings = EvaluationSettings(),
                   metrics=None) -> Scores:
    """Score generated tracks against a split's ground truth.

    Parameters
    ----------
    generated : mapping (subject, sentence) -> (S, T, 32) array_like, or a record with
        ``tracks`` (that mapping) and ``vertices`` (such as ``benchmark.protocol.Generated``)
        S samples per sentence (S = 1 for deterministic methods), 60 fps, columns
        ``dataset.names``. Keys outside the split are ignored; split sentences without an
        entry are not scored. ``vertices``, a mapping (subject, sentence) -> (S, T, V, 3)
        or None: the own vertices of an ``output = "vertices"`` method (the tracks then
        hold their rig fits): its mesh-space metrics compare them with the source meshes;
        its rig-space metrics compare the rig reconstructions of the fits with that of
        the ground-truth coefficients.
    dataset : benchmark.data.BlendVOCADataset (or any object with ``split``,
        ``sentences``, ``coeffs``, ``audio``, ``rig``, ``names`` and, for the mesh
        space, ``vertices``)
    split : str
    settings : EvaluationSettings
        Every option (models, bootstrap resamples, WInD fits, workers, spaces); default
        the protocol's. What differs from the defaults is recorded in
        ``Scores.protocol["evaluation"]`` (:meth:`EvaluationSettings.to_dict`).
    metrics : iterable of str, optional
        Compute only these registered metrics (e.g. ``("lve_rig", "fd")``); default all.

    Returns
    -------
    Scores
        ``{name: {"mean", "std", "ci95", "n", "higher_is_better", "unit", "label",
        "group"[, "sample_std"][, "replicates"]}}`` in table order: ``fd``, ``wind``,
        ``multimodality`` (S >= 2), ``energy_latent``; per reference space
        (``_rig``, ``_mesh``) ``lve``, ``lve_squared``, ``mve``, ``fdd``, ``energy``
        and ``apd``/``upd``/``lpd``/``mpd`` (S >= 2); ``av_offset_*``,
        ``av_offset_signed_*``, ``av_lag_bias_*`` and ``av_confidence_*`` of the
        geometric estimator and the SyncNet and expert ones when given;
        ``motion_ratio_*``, ``motion_closeness_*`` (lips, jaw, upper face) and
        ``silent_lip_ratio``. Set-level
        metrics carry their bootstrap ``replicates`` (paired across rows scored on the
        same split with the same seed). ``Scores.per_sentence`` rows,
        ``Scores.replicates`` (every metric's bootstrap replicates) and
        ``Scores.protocol`` (``fd_floor_probe``; ``evaluation``, the settings that
        differ from the defaults). The latent metrics are left out (with a warning)
        when the split's ground truth has fewer than 2 windows of 120 frames.
    """
    if not isinstance(settings, EvaluationSettings):
        raise TypeError(f"evaluate_split: settings must be an EvaluationSettings, got {type(settings).__name__}")
    generated, vertices = _tracks_and_vertices(generated)
    names = tuple(dataset.names)
    keys = [(subject, sentence) for subject in dataset.split(split) for sentence in dataset.sentences(subject)]
    if not keys:
        raise ValueError(f"evaluate_split: split {split!r} of {dataset!r} has no sentences")
    wanted = _requested(metrics)

    def want(*candidates) -> bool:
        return wanted is None or any(c in wanted for c in candidates)

    def want_suffix(suffix) -> bool:
        return wanted is None or any(name.endswith(suffix) for name in wanted)

    generated = _check_generated(generated, keys, len(names))
    ground_truth = {k: dataset.coeffs(*k) for k in keys}
    n_real = sum(len(window_starts(len(v), drop_last=GT_DROP_LAST)) for v in ground_truth.values())
    results, values, replicates, protocol = {}, {}, {}, {}
    if want(*LATENT_METRICS):
        if n_real >= 2:
            extractor = resolve_extractor(settings.extractor)
            found = latent_results(ground_truth, generated, extractor, settings, wind=want("wind"))
            results.update(found.entries)
            replicates.update(found.replicates)
            values.update(found.sentence_values())
            protocol["fd_floor_probe"] = fd_floor_probe(found.real, ground_truth, extractor)
        else:
            # sentences shorter than 122 frames give no 120-frame window: no latent metric
            warnings.warn(f"evaluate_split: split {split!r} has {n_real} ground-truth windows of 120 frames; "
                          "FD, WInD, multimodality and the latent energy score are not computed", stacklevel=2)
    spaces = tuple(space for space in ("mesh", "rig") if want_suffix(f"_{space}"))
    vertex = settings.vertex and bool(spaces)
    lipsync = settings.lipsync and any(want(n) for n in LIPSYNC_METRICS)
    if vertex or lipsync:
        rigs = {s: dataset.rig(s) for s in {k[0] for k in generated}}
    if vertex:
        mesh_vertices = None
        if "mesh" in spaces:
            if vertices is not None and _has_source_meshes(dataset):
                mesh_vertices = dataset.vertices
            else:
                mesh_vertices = _source_meshes(dataset, keys, settings.mesh)
            if mesh_vertices is None:
                spaces = tuple(s for s in spaces if s != "mesh")
        if spaces:
            values.update(vertex_values(ground_truth, generated, rigs, names, settings.workers,
                                        mesh_vertices=mesh_vertices, own_vertices=vertices, spaces=spaces))
    if lipsync:
        syncnet, sync_expert = load_lipsync_models(settings.syncnet, settings.sync_expert)
        audio = {k: dataset.audio(*k) for k in generated}
        values.update(lipsync_values(generated, rigs, audio, names, syncnet=syncnet, sync_expert=sync_expert,
                                     workers=settings.workers, ground_truth=ground_truth))
    if want(*DYNAMICS_METRICS):
        silent = want("silent_lip_ratio") and hasattr(dataset, "audio")
        audio = {k: dataset.audio(*k) for k in generated} if silent else None
        found, found_replicates = dynamics_metrics(ground_truth, generated, names, audio, seed=settings.seed,
                                                   resamples=settings.resamples, wanted=wanted)
        results.update(found)
        replicates.update(found_replicates)
    entries, rows, sentence_replicates = sentence_entries(values, METRICS, seed=settings.seed,
                                                          resamples=settings.resamples)
    results.update(entries)
    replicates.update(sentence_replicates)
    if wanted is not None:
        results = {name: entry for name, entry in results.items() if name in wanted}
    for name, entry in results.items():
        if METRICS[name].level == "set" and name in replicates:
            entry["replicates"] = [float(f"{v:.7g}") for v in replicates[name]]
    per_sentence = [{"subject": k[0], "sentence": k[1],
                     **{n: v for n, v in rows.get(k, {}).items() if wanted is None or n in wanted}}
                    for k in keys if k in generated]
    scores = Scores({name: results[name] for name in ordered_metrics(list(results))}, per_sentence)
    scores.replicates = {name: replicates[name] for name in scores if name in replicates}
    recorded = settings.to_dict()
    scores.protocol = {**protocol, **({"evaluation": recorded} if recorded else {})}
    return scores
