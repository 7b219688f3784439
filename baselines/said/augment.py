"""Training windows and SAiD's augmentations: audio shift and mirror-pair swap."""

from __future__ import annotations

import numpy as np

FPS = 60
SAMPLE_RATE = 16000


def mirror_swapped(coeffs: np.ndarray, permutation: np.ndarray) -> np.ndarray:
    """Return the track with every left/right mirror pair of columns swapped.

    Parameters
    ----------
    coeffs : (..., T, K) ndarray
    permutation : (K,) int ndarray
        Index of each column's mirror partner (itself when unpaired), e.g.
        ``blendvoca.names.mirror_permutation(names)``; must be an involution.

    Returns
    -------
    swapped : (..., T, K) ndarray
    """
    permutation = np.asarray(permutation)
    k = coeffs.shape[-1]
    if permutation.shape != (k,) or not np.array_equal(np.sort(permutation), np.arange(k)):
        raise ValueError(f"mirror_swapped: expected a permutation of {k} columns, got {permutation.tolist()}")
    if not np.array_equal(permutation[permutation], np.arange(k)):
        raise ValueError("mirror_swapped: expected a mirror permutation that is its own inverse")
    return coeffs[..., permutation]


def audio_window(audio: np.ndarray, start_frame: int, num_frames: int, *, shift: int = 0, fps: int = FPS, sample_rate: int = SAMPLE_RATE) -> np.ndarray:
    """Return the audio samples under frames ``[start_frame, start_frame + num_frames)``, shifted.

    Samples outside the recording are zeros, so every window has the same length.

    Parameters
    ----------
    audio : (N,) ndarray
    start_frame, num_frames : int
    shift : int, default 0
        Offset in samples added to the window's start (the audio-shift augmentation).
    fps, sample_rate : int

    Returns
    -------
    window : (round(num_frames * sample_rate / fps),) float32 ndarray
    """
    length = round(num_frames * sample_rate / fps)
    begin = round(start_frame * sample_rate / fps) + int(shift)
    out = np.zeros(length, dtype=np.float32)
    lo, hi = max(begin, 0), min(begin + length, audio.shape[0])
    if hi > lo:
        out[lo - begin : hi - begin] = audio[lo:hi]
    return out


def training_batch(
    pairs: list[tuple[np.ndarray, np.ndarray]],
    batch_size: int,
    window: int,
    rng: np.random.Generator,
    *,
    mirror: np.ndarray | None = None,
    mirror_prob: float = 0.5,
    shift_prob: float = 0.5,
    max_shift: int = SAMPLE_RATE // FPS,
    fps: int = FPS,
    sample_rate: int = SAMPLE_RATE,
) -> tuple[np.ndarray, np.ndarray]:
    """Return a batch of random, augmented training windows.

    A sentence is drawn with probability proportional to its number of windows, a
    start frame uniformly; with ``shift_prob`` the audio is shifted by a uniform
    offset in ``[-max_shift, max_shift]`` samples (within 1/60 s), with
    ``mirror_prob`` the mirror-pair columns are swapped.  Sentences shorter than
    ``window`` are used whole only when no sentence is long enough (the window then
    shrinks to the shortest one).

    Parameters
    ----------
    pairs : list of (coeffs (T_i, K), audio (N_i,))
    batch_size, window : int
    rng : numpy.random.Generator
    mirror : (K,) int ndarray, optional
        Mirror permutation; None disables the swap.
    mirror_prob, shift_prob : float
    max_shift : int
    fps, sample_rate : int

    Returns
    -------
    coeffs : (B, W, K) float32 ndarray
    audio : (B, round(W * sample_rate / fps)) float32 ndarray
    """
    if not pairs:
        raise ValueError("training_batch: expected at least one (coeffs, audio) pair, got none")
    lengths = np.array([c.shape[0] for c, _ in pairs])
    usable = lengths >= window
    if not usable.any():
        window = int(lengths.min())
        usable = lengths >= window
    weights = np.where(usable, lengths - window + 1, 0).astype(np.float64)
    picks = rng.choice(len(pairs), size=batch_size, p=weights / weights.sum())
    coeffs_out, audio_out = [], []
    for i in picks:
        coeffs, audio = pairs[i]
        start = int(rng.integers(0, lengths[i] - window + 1))
        c = np.asarray(coeffs[start : start + window], dtype=np.float32)
        if mirror is not None and rng.random() < mirror_prob:
            c = mirror_swapped(c, mirror)
        shift = int(rng.integers(-max_shift, max_shift + 1)) if rng.random() < shift_prob else 0
        coeffs_out.append(c)
        audio_out.append(audio_window(audio, start, window, shift=shift, fps=fps, sample_rate=sample_rate))
    return np.stack(coeffs_out), np.stack(audio_out)


def validation_windows(pairs: list[tuple[np.ndarray, np.ndarray]], window: int, max_windows: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Return fixed, non-augmented windows (the start of each sentence) for the validation loss.

    Parameters
    ----------
    pairs : list of (coeffs (T_i, K), audio (N_i,))
    window : int
        Shrinks to the shortest sentence when needed.
    max_windows : int, default 64

    Returns
    -------
    coeffs : (M, W, K) float32 ndarray
    audio : (M, round(W * 16000 / 60)) float32 ndarray
    """
    if not pairs:
        raise ValueError("validation_windows: expected at least one pair, got none")
    window = min(window, min(c.shape[0] for c, _ in pairs))
    chosen = pairs[:max_windows]
    coeffs = np.stack([np.asarray(c[:window], dtype=np.float32) for c, _ in chosen])
    audio = np.stack([audio_window(a, 0, window) for _, a in chosen])
    return coeffs, audio
