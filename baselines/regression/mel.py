"""Log-mel spectrogram in numpy (HTK mel scale, triangular filters, Hann window)."""

from __future__ import annotations

import numpy as np

from baselines.common import mel as common_mel
from baselines.common.mel import hz_to_mel, mel_to_hz

__all__ = ["hz_to_mel", "log_mel_spectrogram", "mel_filterbank", "mel_to_hz"]


def mel_filterbank(n_mels: int, n_fft: int, rate: int, fmin: float = 0.0, fmax: float | None = None) -> np.ndarray:
    """Triangular filters equally spaced on the mel scale, peak value 1 (no area norm), one column per filter.

    The filters of :func:`baselines.common.mel.mel_filterbank`, transposed for ``power @ filters``.

    Parameters
    ----------
    n_mels : int
        Number of filters.
    n_fft : int
        FFT size; the filters act on its ``n_fft // 2 + 1`` frequency bins.
    rate : int
        Sample rate in Hz.
    fmin, fmax : float
        Band edges in Hz (``fmax`` defaults to ``rate / 2``).

    Returns
    -------
    (n_fft // 2 + 1, n_mels) float64 ndarray
    """
    # C order, as the filters were built here before: ``power @ filters`` takes the same BLAS path
    return np.ascontiguousarray(common_mel.mel_filterbank(n_fft, n_mels, rate, fmin, fmax).T)


def log_mel_spectrogram(audio, *, rate: int = 16000, n_fft: int = 512, win_length: int = 400,
                        hop_length: int = 160, n_mels: int = 40, eps: float = 1e-6) -> np.ndarray:
    """``log(eps + mel power)`` of centred, Hann-windowed frames.

    Parameters
    ----------
    audio : (N,) array-like
        Mono samples.
    rate : int
        Sample rate (16 kHz: 25 ms windows and 10 ms hops by default).

    Returns
    -------
    (1 + N // hop_length, n_mels) float32 ndarray
        Frame ``i`` is centred on sample ``i * hop_length``.
    """
    audio = np.asarray(audio, dtype=np.float64)
    if audio.ndim != 1:
        raise ValueError(f"log_mel_spectrogram: expected mono audio of shape (N,), got {audio.shape}")
    if win_length > n_fft:
        raise ValueError(f"log_mel_spectrogram: win_length {win_length} must be <= n_fft {n_fft}")
    padded = np.pad(audio, (n_fft // 2, n_fft // 2), mode="constant")
    n_frames = 1 + audio.shape[0] // hop_length
    frames = np.lib.stride_tricks.sliding_window_view(padded, n_fft)[::hop_length][:n_frames]
    window = np.zeros(n_fft)
    start = (n_fft - win_length) // 2
    window[start:start + win_length] = np.hanning(win_length + 1)[:-1]  # periodic Hann
    power = np.abs(np.fft.rfft(frames * window, axis=1)) ** 2
    mel = power @ mel_filterbank(n_mels, n_fft, rate)
    return np.log(eps + mel).astype(np.float32)
