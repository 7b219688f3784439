"""The lip-sync family: AV offset (absolute and signed), lag bias and confidence of the
geometric estimator and, with their models, of SyncNet and a learned sync expert, with
their metadata (:data:`METRICS`).

``benchmark.lipsync`` (torch) is imported only where a model or an estimate is needed,
so that reading the metric table does not load torch.
"""

from __future__ import annotations

from collections.abc import Mapping
from os import PathLike

import numpy as np

from benchmark.evaluation.entries import sentence_entries
from benchmark.evaluation.sentences import map_sentences, rig_regions
from benchmark.metrics import vertex
from benchmark.metrics.bootstrap import BOOTSTRAP_RESAMPLES
from benchmark.metrics.info import MetricInfo, declared
from blendvoca.runtime.progress import bar

__all__ = ["ESTIMATORS", "METRICS", "lipsync_metrics", "lipsync_values", "load_lipsync_models"]

_SENT = "std over sentences"
_FIRST = "std over sentences (first sample)"
#: Lip-sync estimators, in table order: the paper's SyncNet on renders, a learned
#: coefficient-space expert, and the weight-free geometric estimate.
ESTIMATORS = {"syncnet": ("SyncNet", "frames@25fps", _FIRST), "expert": ("expert", "frames@60fps", _SENT),
              "geometric": ("geom.", "frames@60fps", _SENT)}
_CONFIDENCE = {"syncnet": "distance", "expert": "distance", "geometric": "correlation"}


def _estimator_metrics(est):
    short, unit, spread = ESTIMATORS[est]
    return (MetricInfo(f"av_offset_{est}", f"AV offset ({short})", unit, False, "lip sync",
                       spread + "; mean of the absolute offsets"),
            MetricInfo(f"av_confidence_{est}", f"AV conf. ({short})", _CONFIDENCE[est], True, "lip sync", spread),
            MetricInfo(f"av_offset_signed_{est}", f"AV offset signed ({short})", unit, None, "lip sync",
                       spread + "; + = motion after audio"),
            MetricInfo(f"av_lag_bias_{est}", f"AV lag bias ({short})", unit, None, "lip sync",
                       spread + "; signed offset minus the ground truth's"))


#: The family's metrics, in table order.
METRICS = declared(*(info for est in ESTIMATORS for info in _estimator_metrics(est)))


def load_lipsync_models(syncnet, sync_expert):
    """``(syncnet, sync_expert)`` with paths (and ``syncnet=True``, the manifest's asset)
    loaded; models and None as given."""
    if syncnet is True or isinstance(syncnet, (str, PathLike)):
        from benchmark.lipsync import load_syncnet

        syncnet = load_syncnet(None if syncnet is True else syncnet)
    if isinstance(sync_expert, (str, PathLike)):
        from benchmark.lipsync.expert import load_expert

        sync_expert = load_expert(sync_expert)
    return syncnet, sync_expert


def _offset_values(values: dict, estimator: str, key, offsets, reference) -> None:
    """Add one sentence's offsets (a list, one per scored sample) of ``estimator`` to
    ``values``: mean |offset|, mean signed offset and, with the ground truth's signed
    offset ``reference`` on the same sentence, the lag bias."""
    offsets = [float(o) for o in offsets]
    values.setdefault(f"av_offset_{estimator}", {})[key] = [abs(o) for o in offsets]
    values.setdefault(f"av_offset_signed_{estimator}", {})[key] = offsets
    if reference is not None:
        values.setdefault(f"av_lag_bias_{estimator}", {})[key] = [o - float(reference) for o in offsets]


def _model_values(values, estimator, generated, ground_truth, estimate, *, first_only: bool) -> None:
    """Add the offsets and confidences of a model estimator (run in this process)."""
    for key in bar(list(generated), desc=f"lip sync ({estimator})", unit="sentence"):
        tracks = generated[key][:1] if first_only else generated[key]
        est = [estimate(key, track) for track in tracks]
        truth = estimate(key, ground_truth[key]).offset if ground_truth is not None else None
        _offset_values(values, estimator, key, [e.offset for e in est], truth)
        confidences = [e.confidence for e in est]
        values.setdefault(f"av_confidence_{estimator}", {})[key] = confidences[0] if first_only else confidences


def lipsync_values(generated, rigs, audio, names, *, syncnet=None, sync_expert=None, max_lag=15,
                   workers: int = 1, ground_truth=None) -> dict:
    """Per-sentence AV offsets (absolute and signed) and confidences of every estimator
    given, ``{name: {key: value}}``; with ``ground_truth`` (key -> (T, C) coefficients)
    also the lag bias: the signed offset minus the ground truth's on the same sentence,
    same estimator."""
    from benchmark.lipsync import geometric_sync, mouth_activity, syncnet_sync_track

    regions = rig_regions(rigs, names)
    reference = ground_truth is not None

    def geometric(key):
        neutral, deltas, lip, _upper = regions[key[0]]
        samples, rate = audio[key]

        def estimate(track):
            activity = mouth_activity(vertex.rig_vertices(neutral, deltas, track), neutral, lip)
            return geometric_sync(activity, samples, rate, 60.0, max_lag)

        est = [estimate(track) for track in generated[key]]
        truth = estimate(ground_truth[key]).offset if reference else None
        return [e.offset for e in est], [e.confidence for e in est], truth

    geo = map_sentences(geometric, generated, workers=workers, desc="lip sync (geometric)")
    values: dict = {}
    for key, (offsets, confidences, truth) in geo.items():
        _offset_values(values, "geometric", key, offsets, truth)
        values.setdefault("av_confidence_geometric", {})[key] = confidences
    # the torch models run in this process
    if syncnet is not None:
        def syncnet_estimate(key, track):
            neutral, deltas, _lip, _upper = regions[key[0]]
            verts = vertex.rig_vertices(neutral, deltas, track)
            return syncnet_sync_track(syncnet, verts, rigs[key[0]].faces, *audio[key])

        _model_values(values, "syncnet", generated, ground_truth, syncnet_estimate, first_only=True)
    if sync_expert is not None:
        def expert_estimate(key, track):
            return sync_expert.sync(np.asarray(track, dtype=np.float64), *audio[key])

        _model_values(values, "expert", generated, ground_truth, expert_estimate, first_only=False)
    return values


def lipsync_metrics(generated, rigs: Mapping, audio: Mapping, names, *, syncnet=None, sync_expert=None,
                    max_lag: int = 15, seed: int = 0, resamples: int = BOOTSTRAP_RESAMPLES,
                    ground_truth: Mapping | None = None) -> dict:
    """Geometric (weight-free) and, with the models, SyncNet and sync-expert AV offset/confidence.

    ``av_offset_*`` averages absolute offsets (opposite errors must not cancel: it
    measures sync quality), ``av_offset_signed_*`` the signed ones (positive: motion
    after audio), and with ``ground_truth`` ``av_lag_bias_*`` is the signed offset minus
    the ground truth's on the same sentence with the same estimator: the row's
    systematic lead or lag against the data. Geometric and expert in 60 fps frames
    over every sample, SyncNet in 25 fps frames over the first sample of each sentence.
    """
    values = lipsync_values(generated, rigs, audio, names, syncnet=syncnet, sync_expert=sync_expert,
                            max_lag=max_lag, ground_truth=ground_truth)
    return sentence_entries(values, METRICS, seed=seed, resamples=resamples)[0]
