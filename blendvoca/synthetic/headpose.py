"""Rigid head motion of a synthetic sentence (the pose VOCASET's registered data carries).

Small, smooth rotations about a neck pivot and translations, as a seated
speaker's head moves: per axis a Gaussian-smoothed random walk scaled to a
peak drawn per sentence. Convention (as :func:`blendvoca.fit.remove_head_pose`):
``posed[t] = unposed[t] @ rotations[t].T + translations[t]``.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.spatial.transform import Rotation

from blendvoca.synthetic.signals import FPS


def _smooth_track(num_frames: int, rng: np.random.Generator, peak: float, sigma_s: float) -> np.ndarray:
    noise = rng.standard_normal(num_frames + 2 * int(3 * sigma_s * FPS))
    track = gaussian_filter1d(noise, sigma_s * FPS, mode="nearest")
    pad = (len(noise) - num_frames) // 2
    track = track[pad:pad + num_frames]
    track = track - track.mean()
    return peak * track / max(np.abs(track).max(), 1e-12)


def head_motion(num_frames: int, pivot: np.ndarray, rng: np.random.Generator, *, max_angle_deg: float = 3.0,
                max_translation: float = 0.003, sigma_s: float = 0.35) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame head pose of one sentence.

    Parameters
    ----------
    num_frames : int
        T at 60 fps.
    pivot : (3,) array_like
        Point the head turns about (the top of the neck), metres.
    rng : numpy.random.Generator
    max_angle_deg : float
        Upper bound of the peak angle per axis (pitch, yaw, roll); each peak is
        uniform in ``[max/3, max]``.
    max_translation : float
        Same for the translation per axis (metres).
    sigma_s : float
        Smoothing of the random walks (seconds).

    Returns
    -------
    rotations : (T, 3, 3) ndarray
    translations : (T, 3) ndarray
        ``posed = x @ R.T + t`` (the pivot folded into ``t``).
    """
    pivot = np.asarray(pivot, dtype=np.float64)
    angles = np.stack([_smooth_track(num_frames, rng, np.radians(rng.uniform(max_angle_deg / 3, max_angle_deg)),
                                     sigma_s) for _ in range(3)], axis=1)
    shift = np.stack([_smooth_track(num_frames, rng, rng.uniform(max_translation / 3, max_translation), sigma_s)
                      for _ in range(3)], axis=1)
    rotations = Rotation.from_euler("xyz", angles).as_matrix()
    translations = pivot - rotations @ pivot + shift
    return rotations, translations


def apply_pose(frames: np.ndarray, rotations: np.ndarray, translations: np.ndarray) -> np.ndarray:
    """Posed frames ``(T, V, 3)``: ``frames[t] @ rotations[t].T + translations[t]``."""
    return np.einsum("tvj,tij->tvi", np.asarray(frames, dtype=np.float64), rotations) + translations[:, None]
