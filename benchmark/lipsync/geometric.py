"""Weight-free lip sync: the lag that best aligns mouth motion with speech energy.

Mouth activity (mean lip-vertex displacement from the neutral, through the
speaker's rig) is correlated with the speech energy envelope at lags
``-max_lag..max_lag`` frames. The offset is the lag of the highest Pearson
correlation; positive means the motion comes *after* the audio. The confidence,
like SyncNet's ``median - min`` distance, is the best correlation minus the
median correlation over all lags, discounted by how visible the motion is
(:func:`visibility_weight`): a correlation does not change when the mouth moves
five times less, SyncNet's and the learned expert's confidences do.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from benchmark.lipsync.envelope import speech_envelope
from blendvoca.errors import UserError

#: Mouth-activity standard deviation at which the confidence is discounted by
#: 1/sqrt(2) (:func:`visibility_weight`): 1 mm, in metres as the evaluation passes the
#: activity, about one pixel of the 224 px face view that SyncNet is given.
VISIBILITY = 1e-3


def mouth_activity(vertices, neutral, lip_idx) -> np.ndarray:
    """Mean displacement of the lip vertices from the neutral per frame.

    Parameters
    ----------
    vertices : (T, V, 3), neutral : (V, 3), lip_idx : (L,) int

    Returns
    -------
    (T,) ndarray (units of the input)
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    neutral = np.asarray(neutral, dtype=np.float64)
    if vertices.ndim != 3 or vertices.shape[1:] != neutral.shape:
        raise UserError(f"mouth_activity: expected vertices (T, V, 3) and neutral (V, 3), got {vertices.shape}, {neutral.shape}")
    idx = np.asarray(lip_idx, dtype=np.int64)
    # Distances laid out (L, T) as vertices[:, idx] would leave them, so the mean
    # over the lip vertices adds in that order (np.take is several times faster).
    dist = np.ascontiguousarray(np.linalg.norm(np.take(vertices, idx, axis=1) - neutral[idx], axis=2).T)
    return dist.mean(axis=0)


def lagged_correlation(motion, audio, max_lag: int) -> np.ndarray:
    """Pearson correlation of ``motion[t]`` with ``audio[t - lag]`` for each lag.

    Parameters
    ----------
    motion, audio : (T,) array_like
        Same frame rate; truncated to the shorter.
    max_lag : int

    Returns
    -------
    (2 * max_lag + 1,) ndarray for lags ``-max_lag..max_lag`` (NaN where fewer than 3
    frames overlap or a side is constant).
    """
    m = np.asarray(motion, dtype=np.float64)
    a = np.asarray(audio, dtype=np.float64)
    t = min(len(m), len(a))
    m, a = m[:t], a[:t]
    out = np.full(2 * max_lag + 1, np.nan)
    for i, lag in enumerate(range(-max_lag, max_lag + 1)):
        if lag >= 0:
            x, y = m[lag:], a[: t - lag]
        else:
            x, y = m[: t + lag], a[-lag:]
        if len(x) < 3 or x.std() == 0 or y.std() == 0:
            continue
        out[i] = np.corrcoef(x, y)[0, 1]
    return out


@dataclass(frozen=True)
class SyncEstimate:
    """Offset (frames, positive = motion late), confidence and the per-lag scores."""

    offset: int
    confidence: float
    scores: np.ndarray


def offset_from_scores(scores, max_lag: int, higher_is_better: bool = True) -> SyncEstimate:
    """Best lag and ``|best - median|`` confidence from per-lag scores
    (lags ``-max_lag..max_lag``)."""
    scores = np.asarray(scores, dtype=np.float64)
    if scores.shape != (2 * max_lag + 1,) or np.all(np.isnan(scores)):
        raise UserError(f"offset_from_scores: expected {2 * max_lag + 1} scores with some finite, got {scores.shape}")
    best = np.nanargmax(scores) if higher_is_better else np.nanargmin(scores)
    conf = abs(scores[best] - np.nanmedian(scores))
    return SyncEstimate(offset=int(best) - max_lag, confidence=float(conf), scores=scores)


def visibility_weight(activity, visibility: float = VISIBILITY) -> float:
    """``s / sqrt(s**2 + visibility**2)`` with ``s`` the standard deviation of ``activity``.

    Near 1 for motion well above ``visibility`` (same units as ``activity``), ``s /
    visibility`` for motion well below it, 0 for a still mouth. It rises with the
    amount of motion and is the factor by which :func:`geometric_sync` discounts a
    correlation: up to the per-lag window statistics, its confidence is then the
    best-minus-median of ``cov(activity, envelope) / (std(envelope) sqrt(var(activity)
    + visibility**2))``, a correlation whose motion variance is floored at
    ``visibility**2`` (motion far below it cannot look synchronised).
    """
    activity = np.asarray(activity, dtype=np.float64)
    if visibility < 0:
        raise UserError(f"visibility_weight: visibility must be >= 0, got {visibility}")
    if activity.size == 0 or np.ptp(activity) == 0:
        return 0.0  # a still mouth (std would be round-off, not motion)
    s = float(activity.std())
    return s / float(np.hypot(s, visibility))


def geometric_sync(activity, samples, rate: int = 16000, fps: float = 60.0, max_lag: int = 15,
                   visibility: float = VISIBILITY) -> SyncEstimate:
    """Audio-motion offset and confidence from mouth activity and speech.

    Parameters
    ----------
    activity : (T,) array_like
        Mouth activity per motion frame (:func:`mouth_activity`).
    samples : (N,) array_like
        Mono speech at ``rate``.
    rate : int
    fps : float
        Frame rate of ``activity``.
    max_lag : int
        Lags searched, in frames at ``fps``.
    visibility : float
        Motion scale of :func:`visibility_weight`, in the units of ``activity``
        (default 1 mm for activity in metres, as the evaluation gives it).

    Returns
    -------
    SyncEstimate
        ``offset`` in frames at ``fps`` (positive: motion after audio), the lag of
        the highest Pearson correlation; ``confidence`` = (best - median correlation)
        x ``visibility_weight(activity, visibility)``; ``scores`` the per-lag
        Pearson correlations.
    """
    activity = np.asarray(activity, dtype=np.float64)
    if activity.ndim != 1:
        raise UserError(f"geometric_sync: expected activity (T,), got {activity.shape}")
    env = speech_envelope(samples, rate, fps, num_frames=len(activity))
    scores = lagged_correlation(activity, env, max_lag)
    if np.all(np.isnan(scores)):
        # A motionless mouth (or silent audio) correlates with nothing: zero
        # confidence, and the offset is the worst one searched, so a method that
        # does not move is never rewarded with a small mean offset.
        return SyncEstimate(offset=max_lag, confidence=0.0, scores=np.zeros_like(scores))
    est = offset_from_scores(scores, max_lag)
    return SyncEstimate(offset=est.offset, confidence=est.confidence * visibility_weight(activity, visibility),
                        scores=est.scores)
