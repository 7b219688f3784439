"""The HTK mel scale and its triangular filter bank, for the baselines' log-mel features."""

from __future__ import annotations

import numpy as np

__all__ = ["hz_to_mel", "mel_filterbank", "mel_to_hz"]


def hz_to_mel(hz):
    """HTK mel scale: ``2595 log10(1 + f / 700)`` (float64)."""
    return 2595.0 * np.log10(1.0 + np.asarray(hz, dtype=np.float64) / 700.0)


def mel_to_hz(mel):
    """Inverse of :func:`hz_to_mel` (float64)."""
    return 700.0 * (10.0 ** (np.asarray(mel, dtype=np.float64) / 2595.0) - 1.0)


def mel_filterbank(
    n_fft: int = 400,
    n_mels: int = 80,
    sample_rate: int = 16000,
    fmin: float = 0.0,
    fmax: float | None = None,
) -> np.ndarray:
    """Return triangular HTK-mel filters over the bins of a one-sided FFT.

    Filter ``m`` rises linearly from mel point ``m`` to ``m + 1`` and falls to ``m + 2``
    (``n_mels + 2`` points equally spaced in mel from ``fmin`` to ``fmax``); peak 1,
    no area normalisation.

    Parameters
    ----------
    n_fft : int, default 400
    n_mels : int, default 80
    sample_rate : int, default 16000
    fmin : float, default 0.0
    fmax : float, optional
        Defaults to ``sample_rate / 2``.

    Returns
    -------
    filters : (n_mels, n_fft // 2 + 1) float64 ndarray
    """
    fmax = sample_rate / 2 if fmax is None else fmax
    if not 0 <= fmin < fmax <= sample_rate / 2:
        raise ValueError(f"mel_filterbank: expected 0 <= fmin < fmax <= {sample_rate / 2}, got {fmin}, {fmax}")
    freqs = np.linspace(0.0, sample_rate / 2, n_fft // 2 + 1)
    points = mel_to_hz(np.linspace(hz_to_mel(fmin), hz_to_mel(fmax), n_mels + 2))
    lower, centre, upper = points[:-2, None], points[1:-1, None], points[2:, None]
    rising = (freqs[None, :] - lower) / (centre - lower)
    falling = (upper - freqs[None, :]) / (upper - centre)
    return np.maximum(0.0, np.minimum(rising, falling))
