"""MFCC features as SyncNet's public evaluation computes them.

Parameters follow the common speech-features defaults that SyncNet was trained
with: 25 ms rectangular frames every 10 ms (100 frames/s), pre-emphasis 0.97,
512-point power spectrum, 26 triangular mel filters over 0..rate/2 on FFT bins
``floor((nfft + 1) * f / rate)``, log, orthonormal DCT-II keeping 13 cepstra,
sinusoidal liftering 22, and cepstrum 0 replaced by the log frame energy.
"""

from __future__ import annotations

import numpy as np
from scipy.fft import dct

from blendvoca.errors import UserError


def _hz_to_mel(hz):
    return 2595.0 * np.log10(1.0 + np.asarray(hz) / 700.0)


def _mel_to_hz(mel):
    return 700.0 * (10.0 ** (np.asarray(mel) / 2595.0) - 1.0)


def mel_filterbank(num_filters: int = 26, nfft: int = 512, rate: int = 16000) -> np.ndarray:
    """Triangular mel filters, (num_filters, nfft // 2 + 1)."""
    mels = np.linspace(_hz_to_mel(0.0), _hz_to_mel(rate / 2), num_filters + 2)
    bins = np.floor((nfft + 1) * _mel_to_hz(mels) / rate).astype(np.int64)
    bank = np.zeros((num_filters, nfft // 2 + 1))
    for j in range(num_filters):
        lo, mid, hi = bins[j], bins[j + 1], bins[j + 2]
        for i in range(lo, mid):
            bank[j, i] = (i - lo) / (mid - lo)
        for i in range(mid, hi):
            bank[j, i] = (hi - i) / (hi - mid)
    return bank


def frame_signal(x: np.ndarray, frame_len: int, step: int) -> np.ndarray:
    """Zero-padded frames of a signal, (F, frame_len); F = 1 + ceil((N - frame_len) / step)."""
    n = len(x)
    count = 1 if n <= frame_len else 1 + int(np.ceil((n - frame_len) / step))
    padded = np.concatenate([x, np.zeros((count - 1) * step + frame_len - n)])
    idx = np.arange(frame_len)[None, :] + step * np.arange(count)[:, None]
    return padded[idx]


def mfcc(samples, rate: int = 16000, num_ceps: int = 13, num_filters: int = 26, nfft: int = 512,
         win: float = 0.025, step: float = 0.01, preemph: float = 0.97, lifter: int = 22) -> np.ndarray:
    """MFCCs of mono audio.

    Parameters
    ----------
    samples : (N,) array_like
        Mono audio (SyncNet expects 16 kHz at int16 scale).
    rate : int

    Returns
    -------
    (F, num_ceps) float64 ndarray, 100 frames per second with the defaults.
    """
    x = np.asarray(samples, dtype=np.float64)
    if x.ndim != 1 or x.size == 0:
        raise UserError(f"mfcc: expected mono samples (N,), got shape {x.shape}")
    x = np.append(x[0], x[1:] - preemph * x[:-1])
    frames = frame_signal(x, round(win * rate), round(step * rate))
    power = np.abs(np.fft.rfft(frames, nfft)) ** 2 / nfft
    eps = np.finfo(float).eps
    energy = power.sum(axis=1)
    energy = np.where(energy == 0, eps, energy)
    feats = power @ mel_filterbank(num_filters, nfft, rate).T
    feats = np.log(np.where(feats == 0, eps, feats))
    ceps = dct(feats, type=2, axis=1, norm="ortho")[:, :num_ceps]
    if lifter > 0:
        ceps = ceps * (1 + (lifter / 2.0) * np.sin(np.pi * np.arange(num_ceps) / lifter))
    ceps[:, 0] = np.log(energy)
    return ceps
