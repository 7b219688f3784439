"""Speech energy envelope sampled at the motion frame rate."""

from __future__ import annotations

import numpy as np

from blendvoca.errors import UserError


def speech_envelope(samples, rate: int = 16000, fps: float = 60.0, num_frames: int | None = None,
                    window: float = 0.04, floor_db: float = -60.0) -> np.ndarray:
    """Log RMS energy of speech around each motion frame time.

    Frame t is centred at ``t / fps`` seconds; its energy is the RMS of a
    ``window``-second Hann-weighted span of samples around that time, in dB,
    clipped at ``floor_db`` below the loudest frame (silence does not dominate).

    Parameters
    ----------
    samples : (N,) array_like
        Mono audio.
    rate : int
        Sample rate (Hz).
    fps : float
        Motion frame rate.
    num_frames : int, optional
        Number of frames; default ``floor(N / rate * fps)``.
    window : float
        Analysis window (s).
    floor_db : float

    Returns
    -------
    (num_frames,) float64 ndarray, dB
    """
    x = np.asarray(samples, dtype=np.float64)
    if x.ndim != 1 or x.size == 0:
        raise UserError(f"speech_envelope: expected mono samples (N,), got shape {x.shape}")
    if rate <= 0 or fps <= 0:
        raise UserError(f"speech_envelope: rate and fps must be positive, got {rate}, {fps}")
    if num_frames is None:
        num_frames = int(np.floor(len(x) / rate * fps))
    half = max(1, round(window * rate / 2))
    taper = np.hanning(2 * half + 1)
    taper /= taper.sum()
    energy = np.convolve(x**2, taper, mode="same")
    centres = np.clip(np.round(np.arange(num_frames) * rate / fps).astype(np.int64), 0, len(x) - 1)
    db = 10.0 * np.log10(energy[centres] + 1e-12)
    return np.maximum(db, db.max() + floor_db)
