"""The dynamics family: how much the lips, the jaw and the upper face move against the
ground truth's own level on the same sentences, and how still the mouth is in the
audio's silences against the ground truth's, with their metadata (:data:`METRICS`).

For each region (:data:`benchmark.metrics.dynamics.REGIONS`):

``motion_ratio_<region>``
    ``m / m_GT``, the row's RMS velocity of the region over the ground truth's
    (:mod:`benchmark.metrics.dynamics`). 1 moves as much as the data, below 1 is
    damped, above 1 livelier (or noisy). No better direction: read it with the closeness.
``motion_closeness_<region>``
    THEval's ``1 - |m - m_GT| / m_GT = 1 - |ratio - 1|``: 1 at the ground truth's
    level, 0 for a static region, higher is better; not clipped at 0.

``silent_lip_ratio``
    The jaw and lip RMS velocity inside the test audio's silences
    (:func:`utterance_silences`) over the ground truth's in the
    same frames: above 1 the mouth keeps moving where the speaker rests.

Pooled, not per sentence: ``m`` is the RMS velocity over every frame of the split (and
every sample), ``sqrt(sum of squared speeds / frames)``, against the ground truth's on
the same frames, so a ratio is ``sqrt(sum generated / sum truth)``. A per-sentence
ratio divides by sentences whose region hardly moves (an upper face at rest, a
sentence without a pause) and the mean of per-sentence closenesses is below 1 for
any row whose level differs sentence by sentence, even one drawn from the true
distribution; the pooled ratio of an unbiased row tends to 1. The intervals are the
percentile bootstrap over sentences (set-level metrics, like FD), paired across rows
scored on the same split with the same seed; ``std`` is the std of those replicates.
"""

from __future__ import annotations

import warnings
import zlib

import numpy as np

from benchmark.evaluation.entries import replicates_and_interval
from benchmark.metrics.bootstrap import BOOTSTRAP_RESAMPLES, bootstrap_indices
from benchmark.metrics.dynamics import (REGIONS, SILENCE_DB, closeness, energy_ratio, mouth_columns,
                                        ratio_replicates, region_columns, silent_frames, silent_velocity_frames,
                                        squared_speed_sum)
from benchmark.metrics.info import MetricInfo, declared

__all__ = ["METRICS", "RATIOS", "dynamics_metrics", "dynamics_sums", "utterance_silences"]

_LABELS = {"lips": "lips", "jaw": "jaw", "upper": "upper face"}
_BOOT = "bootstrap std over sentences"

#: The family's metrics, in table order.
METRICS = declared(
    *(MetricInfo(f"motion_ratio_{r}", f"Motion ratio {_LABELS[r]}", "x GT", None, "dynamics",
                 _BOOT + "; 1 = the ground truth's level", level="set", ideal=1.0) for r in REGIONS),
    *(MetricInfo(f"motion_closeness_{r}", f"Closeness {_LABELS[r]}", "", True, "dynamics",
                 _BOOT + "; 1 - abs(ratio - 1)", level="set") for r in REGIONS),
    MetricInfo("silent_lip_ratio", "Silent-lip ratio", "x GT", None, "dynamics",
               _BOOT + "; mouth motion in the audio's silences over the ground truth's", level="set",
               ideal=1.0),
)
#: The ratio metrics and, for those with one, the closeness read from the same replicates.
RATIOS = {**{f"motion_ratio_{r}": f"motion_closeness_{r}" for r in REGIONS}, "silent_lip_ratio": None}


def utterance_silences(samples, rate: int, num_frames: int, fps: float = 60.0) -> np.ndarray:
    """``(num_frames,)`` bool: the frames in the utterance's silences
    (:func:`~benchmark.metrics.dynamics.silent_frames` of its speech envelope, the 40 ms
    log-energy that the geometric lip-sync estimator reads)."""
    from benchmark.lipsync.envelope import speech_envelope

    envelope = speech_envelope(samples, rate, fps, int(num_frames), floor_db=-(SILENCE_DB + 20.0))
    return silent_frames(envelope, fps)


def dynamics_sums(ground_truth, generated, names, audio=None) -> dict:
    """``{ratio metric: (generated sums (n,), truth sums (n,))}`` over the sentences of
    ``generated`` (in its order): per sentence the squared speeds of the region summed
    over its frames (:func:`~benchmark.metrics.dynamics.squared_speed_sum`; the generated
    side's mean over its samples). Tracks are cut to the shorter of the row's and the
    truth's length. ``silent_lip_ratio`` only with ``audio`` (key -> (samples, rate))."""
    regions = region_columns(names)
    mouth = mouth_columns(names)
    out = {f"motion_ratio_{r}": ([], []) for r in regions}
    if audio is not None and mouth.size:
        out["silent_lip_ratio"] = ([], [])
    for key, tracks in generated.items():
        truth = np.asarray(ground_truth[key], dtype=np.float64)
        tracks = np.asarray(tracks, dtype=np.float64)
        t = min(tracks.shape[1], len(truth))
        for region, cols in regions.items():
            gen, ref = out[f"motion_ratio_{region}"]
            gen.append(np.mean([squared_speed_sum(s[:t], cols) for s in tracks]))
            ref.append(squared_speed_sum(truth[:t], cols))
        if "silent_lip_ratio" in out:
            samples, rate = audio[key]
            frames = silent_velocity_frames(utterance_silences(samples, rate, len(truth))[:t])
            gen, ref = out["silent_lip_ratio"]
            gen.append(np.mean([squared_speed_sum(s[:t], mouth, frames) for s in tracks]))
            ref.append(squared_speed_sum(truth[:t], mouth, frames))
    return {name: (np.asarray(g), np.asarray(r)) for name, (g, r) in out.items()}


def _entry(info: MetricInfo, point: float, reps: np.ndarray, n: int) -> tuple[dict, np.ndarray]:
    reps, ci = replicates_and_interval(point, reps)
    std = float(reps.std(ddof=1)) if reps.size >= 2 else None
    return info.entry(point, std, n=n, ci95=ci), reps


def dynamics_metrics(ground_truth, generated, names, audio=None, *, seed: int = 0,
                     resamples: int = BOOTSTRAP_RESAMPLES, wanted=None) -> tuple[dict, dict]:
    """``(entries, {name: bootstrap replicates})`` of the dynamics metrics (:data:`METRICS`).

    Parameters
    ----------
    ground_truth : (subject, sentence) -> (T, C); generated : same keys -> (S, T, C)
    names : the columns' ARKit names
    audio : key -> (samples, rate), optional
        For ``silent_lip_ratio`` (left out without it).
    seed, resamples : the bootstrap's (metric ``name`` resamples with
        ``bootstrap_indices(n, resamples, seed + crc32(name))``; a closeness shares its
        ratio's resamples)
    wanted : collection of metric names, optional (default all)

    A ratio whose truth does not move on the split (no silence in any sentence, a
    region the truth never moves) is left out with a warning: it has no level to compare with.
    """
    keys = list(generated)
    n = len(keys)
    entries, replicates = {}, {}
    for name, (gen, ref) in dynamics_sums(ground_truth, generated, names, audio).items():
        partner = RATIOS[name]
        if wanted is not None and name not in wanted and partner not in wanted:
            continue
        point = energy_ratio(gen, ref)
        if not np.isfinite(point):
            what = "silences" if name == "silent_lip_ratio" else f"the {name.rsplit('_', 1)[1]} region"
            warnings.warn(f"dynamics: the ground truth does not move in {what} on these {n} sentences; "
                          f"{name} is not computed", stacklevel=3)
            continue
        if n >= 2:
            reps = ratio_replicates(gen, ref, bootstrap_indices(n, resamples, seed + zlib.crc32(name.encode())))
            reps = np.where(np.isfinite(reps), reps, point)  # a resample whose truth has no motion: no information
        else:
            reps = np.empty(0)
        entries[name], replicates[name] = _entry(METRICS[name], point, reps, n)
        if partner is not None:
            entries[partner], replicates[partner] = _entry(METRICS[partner], float(closeness(point)),
                                                           closeness(reps), n)
    if wanted is not None:
        entries = {k: v for k, v in entries.items() if k in wanted}
        replicates = {k: v for k, v in replicates.items() if k in wanted}
    return entries, replicates
