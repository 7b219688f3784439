"""Speech audio: any WAV in, 16 kHz mono float32 out.

soundfile reads every PCM/float WAV flavour; soxr does the band-limited resampling
(both are small wheels with no system dependency).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError, UserError
from blendvoca.io.arrays import float_array
from blendvoca.io.atomic import atomic_write

SAMPLE_RATE = 16000


class AudioFormatError(DataError):
    """An audio file that does not decode; the message names the file and the problem."""


def resample_audio(samples: np.ndarray, rate_in: int, rate_out: int = SAMPLE_RATE) -> np.ndarray:
    """Resample mono ``(N,)`` audio from ``rate_in`` to ``rate_out`` Hz (float32)."""
    if isinstance(samples, np.ndarray) and samples.dtype == np.float32:
        # already what the resampler takes: no float64 detour (a 10-minute take is 38 MB in float32);
        # a copy, as for any other input, so the caller's array is never returned
        samples = np.array(samples, order="C", copy=True)
    else:
        samples = float_array(samples, where="resample_audio", name="samples", shape="(N,)").astype(np.float32)
    if samples.ndim != 1:
        raise UserError(f"resample_audio expects mono (N,) samples, got shape {samples.shape}")
    if int(rate_in) == int(rate_out):
        return samples
    import soxr

    return soxr.resample(samples, int(rate_in), int(rate_out), quality="HQ").astype(np.float32)


def to_mono(samples: np.ndarray) -> np.ndarray:
    """Average the channels of ``(N, C)`` audio; ``(N,)`` passes through."""
    samples = np.asarray(samples, dtype=np.float32)
    return samples.mean(axis=1) if samples.ndim == 2 else samples


def read_wav(path) -> tuple[np.ndarray, int]:
    """Samples ``(N,)`` or ``(N, C)`` float32 in [-1, 1] and the native rate.

    Raises
    ------
    FileNotFoundError
        No such file.
    AudioFormatError
        Anything libsndfile cannot decode (naming the file).
    """
    import soundfile

    path = Path(os.fspath(path))
    if not path.is_file():
        raise FileNotFoundError(f"audio file not found: {path}")
    try:
        samples, rate = soundfile.read(str(path), dtype="float32", always_2d=False)
    except (RuntimeError, ValueError, TypeError, EOFError, OverflowError) as error:  # LibsndfileError is a RuntimeError
        raise AudioFormatError(f"{path}: not a readable audio file: {error}") from None
    if rate <= 0:
        raise AudioFormatError(f"{path}: sample rate {rate} Hz; expected a positive rate")
    return samples, int(rate)


def load_audio(path, rate: int = SAMPLE_RATE) -> np.ndarray:
    """Any WAV file as mono float32 at ``rate`` Hz (16 kHz by default), ``(N,)``.

    Raises
    ------
    FileNotFoundError
        No such file.
    AudioFormatError
        A file that does not decode, or holds no samples (naming the file): speech
        is what every caller needs, and an empty array would fail far from here.
    """
    samples, native = read_wav(path)
    if samples.shape[0] == 0:
        raise AudioFormatError(f"{path}: the audio holds no samples (a zero-length recording); expected speech")
    return resample_audio(to_mono(samples), native, rate)


def write_wav(path, samples: np.ndarray, rate: int = SAMPLE_RATE) -> None:
    """Write mono or ``(N, C)`` float audio in [-1, 1] (any real dtype) as 16-bit PCM WAV, atomically."""
    import soundfile

    samples = float_array(samples, where=str(path), name="samples", shape="(N,) or (N, C)").astype(np.float32)
    if samples.ndim not in (1, 2):
        raise UserError(f"{path}: expected audio samples (N,) or (N, C), got shape {samples.shape}")
    if not np.all(np.isfinite(samples)):
        raise UserError(f"{path}: audio contains NaN or infinite samples")
    with atomic_write(path, "wb") as f:
        soundfile.write(f, np.clip(samples, -1.0, 1.0), int(rate), subtype="PCM_16", format="WAV")


def energy_db(samples, rate: int, fps: float, frames: int, window_s: float = 0.03) -> np.ndarray:
    """``(frames,)`` energy of mono audio around each motion frame's time ``t / fps``, in dB.

    The mean square of the samples under a Hann window of ``window_s`` seconds centred at
    the frame (``1e-12`` added before the log, so digital silence reads -120 dB).

    Raises
    ------
    DataError
        Samples that are not a non-empty (N,) array.
    """
    x = np.asarray(samples, dtype=np.float64)
    if x.ndim != 1 or x.size == 0:
        raise DataError(f"energy_db: expected mono audio samples (N,), got shape {x.shape}")
    half = max(1, int(round(window_s * rate / 2)))
    taper = np.hanning(2 * half + 1)
    energy = np.convolve(x**2, taper / taper.sum(), mode="same")
    centres = np.clip(np.round(np.arange(frames) * rate / fps).astype(np.int64), 0, len(x) - 1)
    return 10.0 * np.log10(energy[centres] + 1e-12)
