"""Audio features on the 60 fps motion clock."""

from __future__ import annotations

import numpy as np

from .mel import log_mel_spectrogram

__all__ = ["motion_rate_features", "resampled_features"]


def resampled_features(features, num_frames: int, *, feature_fps: float, fps: float = 60.0) -> np.ndarray:
    """Features linearly interpolated in time onto ``num_frames`` frames at ``fps``.

    Parameters
    ----------
    features : (F, D) ndarray
        Frame ``i`` at time ``i / feature_fps``.
    num_frames : int
        Output frames; frame ``t`` at time ``t / fps`` (held at the edges).

    Returns
    -------
    (num_frames, D) float32 ndarray
    """
    features = np.asarray(features)
    if features.ndim != 2 or features.shape[0] == 0:
        raise ValueError(f"resampled_features: expected (F, D) with F >= 1, got {features.shape}")
    src = np.arange(features.shape[0]) / feature_fps
    dst = np.arange(int(num_frames)) / fps
    idx = np.clip(np.searchsorted(src, dst, side="right") - 1, 0, features.shape[0] - 1)
    nxt = np.minimum(idx + 1, features.shape[0] - 1)
    span = np.where(nxt > idx, src[nxt] - src[idx], 1.0)
    w = np.clip((dst - src[idx]) / span, 0.0, 1.0)[:, None]
    return ((1 - w) * features[idx] + w * features[nxt]).astype(np.float32)


def motion_rate_features(audio, num_frames: int, *, rate: int = 16000, n_mels: int = 40,
                         hop_length: int = 160) -> np.ndarray:
    """Log-mel spectrogram of ``audio`` on the 60 fps clock.

    Returns
    -------
    (num_frames, n_mels) float32 ndarray
    """
    logmel = log_mel_spectrogram(audio, rate=rate, n_mels=n_mels, hop_length=hop_length)
    return resampled_features(logmel, num_frames, feature_fps=rate / hop_length)
