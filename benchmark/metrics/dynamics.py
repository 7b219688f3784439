"""Motion energy of face regions against the ground truth's own level, and the silences
of an utterance in which the lips should rest.

A row can be far from the data because it moves too little, too much or wrongly; the
distances (FD, LVE) do not say which. These functions measure how much a region
moves, so that a row's level can be read against the ground truth's level on the same
sentences (THEval, CVPR 2026, scores each dynamics measure as
``1 - |m - m_GT| / m_GT``).

Regions are sets of ARKit coefficients (:data:`REGIONS`), read in coefficient space:
the one representation that coefficient rows and vertex rows share (a vertex row is
scored through its rig fit, like the ``*_rig`` vertex metrics). The jaw is
``jaw*``, the lips ``mouth*``, the upper face ``brow*``, ``eye*``, ``cheek*`` and
``nose*`` (BlendVOCA's 32 shapes have no brow or eye shape: there it is the cheeks and
the nose).

Motion energy is the **RMS velocity**: ``fps * sqrt(mean_t ||x[t+1] - x[t]||^2)`` over
the region's coefficients (coefficient units per second). RMS rather than the mean
absolute velocity because it is the square root of the kinetic energy of the track
(its velocity's power), so an energy adds over frames and sentences (pooling is a sum
of squares), and because it scales exactly with the amplitude (a track scaled by ``a``
has ``a`` times the energy) and has a closed form for a sine: ``a sin(2 pi f t)``
sampled at ``fps`` over whole periods has ``fps * sqrt(2) * a * sin(pi f / fps)``.
"""

from __future__ import annotations

import numpy as np

from blendvoca.errors import UserError

__all__ = [
    "MIN_SILENCE_S",
    "REGIONS",
    "SILENCE_DB",
    "closeness",
    "energy_ratio",
    "motion_energy",
    "mouth_columns",
    "ratio_replicates",
    "region_columns",
    "silent_frames",
    "silent_velocity_frames",
    "squared_speed_sum",
]

#: Region -> the name prefixes of its ARKit coefficients.
REGIONS = {"lips": ("mouth",), "jaw": ("jaw",), "upper": ("brow", "eye", "cheek", "nose")}
#: A frame is silent when the speech envelope is this many dB below the utterance's loudest frame.
SILENCE_DB = 40.0
#: Shortest silence that counts (seconds): shorter gaps are closures inside speech (stops).
MIN_SILENCE_S = 0.2


def region_columns(names) -> dict:
    """``{region: int array of the columns of names in it}`` (:data:`REGIONS`); a region without
    a column of ``names`` is left out."""
    names = tuple(names)
    out = {}
    for region, prefixes in REGIONS.items():
        cols = np.array([i for i, n in enumerate(names) if n.startswith(prefixes)], dtype=np.int64)
        if cols.size:
            out[region] = cols
    return out


def mouth_columns(names) -> np.ndarray:
    """The jaw and lip columns of ``names`` (the mouth of the silent-lip measure)."""
    regions = region_columns(names)
    return np.sort(np.concatenate([regions.get("jaw", np.empty(0, np.int64)),
                                   regions.get("lips", np.empty(0, np.int64))]))


def _track(track, where: str) -> np.ndarray:
    track = np.asarray(track, dtype=np.float64)
    if track.ndim != 2 or len(track) < 2:
        raise ValueError(f"{where}: expected a coefficient track (T >= 2, K), got shape {track.shape}")
    return track


def squared_speed_sum(track, columns, frames=None) -> float:
    """``sum_t ||x[t+1] - x[t]||^2`` over the region's ``columns`` (per frame, no fps), over
    the velocity frames ``t`` where ``frames[t]`` (``(T - 1,)`` bool; default all).

    The unit of pooling: a split's RMS velocity is ``fps * sqrt(sum of these / frames)``,
    and the ratio of two rows on the same frames is the square root of the ratio of their sums.
    """
    track = _track(track, "squared_speed_sum")
    velocity = np.diff(track[:, np.asarray(columns, dtype=np.int64)], axis=0)
    speed = np.einsum("tk,tk->t", velocity, velocity)
    if frames is not None:
        frames = np.asarray(frames, dtype=bool)
        if frames.shape != speed.shape:
            raise ValueError(f"squared_speed_sum: expected {speed.shape[0]} velocity frames, got {frames.shape}")
        speed = speed[frames]
    return float(speed.sum())


def motion_energy(track, columns, fps: float = 60.0) -> float:
    """RMS velocity of the region ``columns`` of one track, coefficient units per second:
    ``fps * sqrt(mean_t ||x[t+1] - x[t]||^2)``."""
    track = _track(track, "motion_energy")
    return float(fps * np.sqrt(squared_speed_sum(track, columns) / (len(track) - 1)))


def energy_ratio(generated_sums, truth_sums) -> float:
    """``m / m_GT`` pooled over sentences: ``sqrt(sum generated / sum truth)`` of
    :func:`squared_speed_sum` values on the same frames (NaN when the truth does not move)."""
    g = float(np.sum(generated_sums))
    r = float(np.sum(truth_sums))
    return float(np.sqrt(g / r)) if r > 0 else float("nan")


def closeness(ratio):
    """THEval's closeness ``1 - |m - m_GT| / m_GT = 1 - |ratio - 1|``: 1 at the ground
    truth's level, 0 for a static region, not clipped (a region moving 3x the truth's
    scores -1, below a static one: it is as far off, by twice as much)."""
    return 1.0 - np.abs(np.asarray(ratio, dtype=np.float64) - 1.0)


def ratio_replicates(generated_sums, truth_sums, rows) -> np.ndarray:
    """Bootstrap replicates of :func:`energy_ratio`: replicate ``i`` pools the sentences
    ``rows[i]`` (:func:`benchmark.metrics.bootstrap.bootstrap_indices`; rows scored on
    the same split with the same seed share them: paired). A replicate whose resampled
    truth does not move (silences in none of its sentences) is NaN."""
    g = np.asarray(generated_sums, dtype=np.float64)[rows].sum(axis=1)
    r = np.asarray(truth_sums, dtype=np.float64)[rows].sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(r > 0, np.sqrt(g / np.where(r > 0, r, 1.0)), np.nan)


def silent_frames(envelope_db, fps: float = 60.0, *, threshold_db: float = SILENCE_DB,
                  min_duration: float = MIN_SILENCE_S) -> np.ndarray:
    """``(T,)`` bool: the motion frames inside an utterance's silences, from its speech
    envelope ``envelope_db`` (``(T,)``, dB per motion frame: the log RMS energy of a short
    window around each frame, :func:`benchmark.lipsync.envelope.speech_envelope`).

    A frame is silent when its envelope is more than ``threshold_db`` below the
    utterance's loudest frame; runs of silent frames shorter than ``min_duration``
    seconds are dropped (a stop closure inside a word is not a rest). The threshold is
    relative to the utterance, so a quiet recording is read like a loud one; an
    utterance without any level difference (all zeros) has no silence.
    """
    envelope = np.asarray(envelope_db, dtype=np.float64)
    if envelope.ndim != 1 or envelope.size == 0 or not np.all(np.isfinite(envelope)):
        raise UserError(f"silent_frames: expected a finite speech envelope (T,) in dB, got shape {envelope.shape}")
    if threshold_db <= 0 or min_duration < 0:
        raise UserError(f"silent_frames: expected threshold_db > 0 and min_duration >= 0, got {threshold_db}, "
                        f"{min_duration}")
    quiet = envelope < envelope.max() - threshold_db
    shortest = int(np.ceil(min_duration * fps - 1e-9))
    edges = np.flatnonzero(np.diff(np.concatenate([[0], quiet.astype(np.int8), [0]])))
    out = np.zeros(len(quiet), dtype=bool)
    for start, stop in zip(edges[::2], edges[1::2]):
        if stop - start >= shortest:
            out[start:stop] = True
    return out


def silent_velocity_frames(silent) -> np.ndarray:
    """``(T - 1,)`` bool: the velocity frames ``x[t+1] - x[t]`` with both frames silent."""
    silent = np.asarray(silent, dtype=bool)
    return silent[1:] & silent[:-1]
