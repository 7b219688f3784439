"""Disturbances of ground-truth coefficient tracks, each at a graded strength.

Every disturbance is a pure function of a track ``(T, K)`` in [0, 1] (or of the whole
set, for sentence swaps) and a *level*: level 0 leaves the ground truth unchanged and
larger levels disturb it more. Random disturbances draw one fixed pattern per sentence
(seeded by the sentence) and scale it by the level, so that the levels differ only in
strength, not in which noise was drawn (common random numbers: a metric's values are
then a smooth function of the level and its trend can be read from few levels).

=================  ======================================  ============================
kind               what it does                            level
=================  ======================================  ============================
time_shift         motion delayed by k frames (edge held)  k, frames at 60 fps
time_advance       motion advanced by k frames             k, frames (lag of -k)
smoothing          Gaussian low-pass along time            sigma, frames
noise              i.i.d. Gaussian noise, clipped to [0,1] std (coefficient units)
damping            every coefficient scaled by 1 - level   1 - factor
mouth_damping      jaw/mouth coefficients scaled, rest     1 - factor of the mouth
                   kept                                    shapes
sentence_swap      a share of the sentences replaced by    share of the sentences
                   other sentences' tracks (cut / wrapped
                   to length)
noisy_samples      S samples (2; 4 in the full set), each  std of each sample's noise
                   the truth plus its own i.i.d. noise
                   (clipped)
constant_offset    truth + c, clipped to [0, 1]            c
=================  ======================================  ============================
"""

from __future__ import annotations

import zlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from blendvoca.rig_regions import mouth_shape_indices

__all__ = [
    "DISTURBANCES",
    "Disturbance",
    "constant_offset",
    "damping",
    "disturb",
    "iid_noise",
    "mouth_damping",
    "noisy_samples",
    "sentence_swap",
    "temporal_smoothing",
    "time_shift",
]


def _track(track) -> np.ndarray:
    track = np.asarray(track, dtype=np.float64)
    if track.ndim != 2 or len(track) < 1:
        raise ValueError(f"expected a coefficient track (T, K), got shape {track.shape}")
    return track


def time_shift(track, k: int) -> np.ndarray:
    """The track delayed by ``k`` frames (``k < 0``: advanced), edges held.

    ``out[t] = track[t - k]`` where that frame exists, else the first (``k > 0``) or
    last (``k < 0``) frame: the motion comes ``k`` frames after the audio, the lag
    convention of every AV offset (positive: motion late).
    """
    track = _track(track)
    k = int(k)
    if k == 0:
        return track.copy()
    t = len(track)
    idx = np.clip(np.arange(t) - k, 0, t - 1)
    return track[idx]


def temporal_smoothing(track, sigma: float) -> np.ndarray:
    """Gaussian low-pass along time with standard deviation ``sigma`` frames
    (``sigma = 0``: unchanged; edges reflected). Stays in [0, 1] (a convex average)."""
    track = _track(track)
    if sigma < 0:
        raise ValueError(f"temporal_smoothing: sigma must be >= 0, got {sigma}")
    if sigma == 0:
        return track.copy()
    return gaussian_filter1d(track, float(sigma), axis=0, mode="reflect")


def _pattern(key, salt: str, shape) -> np.ndarray:
    """Standard normal draw fixed by (key, salt): the same for every level."""
    seed = zlib.crc32(repr((key, salt)).encode())
    return np.random.default_rng(seed).standard_normal(shape)


def iid_noise(track, std: float, pattern=None, *, key=None) -> np.ndarray:
    """``clip(track + std * z, 0, 1)`` with ``z`` standard normal i.i.d. per frame and shape.

    ``pattern`` is ``z`` (``(T, K)``); by default it is drawn from ``key`` (the same ``z``
    for every ``std``).
    """
    track = _track(track)
    if std < 0:
        raise ValueError(f"iid_noise: std must be >= 0, got {std}")
    z = _pattern(key, "noise", track.shape) if pattern is None else np.asarray(pattern, dtype=np.float64)
    return np.clip(track + std * z, 0.0, 1.0)


def damping(track, level: float) -> np.ndarray:
    """Every coefficient scaled toward the neutral: ``(1 - level) * track``."""
    track = _track(track)
    if not 0 <= level <= 1:
        raise ValueError(f"damping: level must be in [0, 1], got {level}")
    return (1.0 - level) * track


def mouth_damping(track, names: Sequence[str], level: float) -> np.ndarray:
    """The jaw and mouth coefficients (:func:`blendvoca.rig_regions.mouth_shape_indices`)
    scaled by ``1 - level``; the other shapes (cheeks, nose) kept."""
    track = _track(track)
    if not 0 <= level <= 1:
        raise ValueError(f"mouth_damping: level must be in [0, 1], got {level}")
    if len(names) != track.shape[1]:
        raise ValueError(f"mouth_damping: {len(names)} names for {track.shape[1]} columns")
    out = track.copy()
    cols = mouth_shape_indices(names)
    out[:, cols] *= 1.0 - level
    return out


def constant_offset(track, c: float) -> np.ndarray:
    """``clip(track + c, 0, 1)``: every coefficient lifted by ``c`` (off the floor at 0)."""
    return np.clip(_track(track) + float(c), 0.0, 1.0)


def noisy_samples(track, std: float, samples: int = 4, *, key=None) -> np.ndarray:
    """``(S, T, K)``: S samples, sample ``s`` = ``clip(track + std * z_s, 0, 1)`` with its
    own fixed standard normal ``z_s`` (drawn from ``key``). ``std = 0``: S copies of the truth."""
    track = _track(track)
    if samples < 2:
        raise ValueError(f"noisy_samples: need >= 2 samples, got {samples}")
    z = _pattern(key, "samples", (samples, *track.shape))
    return np.stack([iid_noise(track, std, z[s]) for s in range(samples)])


def sentence_swap(tracks: Mapping, share: float) -> dict:
    """A ``share`` of the sentences replaced by other sentences' tracks.

    The sentences are taken in a fixed (seeded) order and the first
    ``round(share * n)`` of them are replaced, so a larger share swaps a superset. A
    replaced sentence gets the track of the next sentence in that order (cyclically),
    cut or wrapped to its own length: the swapped set keeps the marginal motion
    statistics of the truth but none of its alignment with the audio.
    """
    if not 0 <= share <= 1:
        raise ValueError(f"sentence_swap: share must be in [0, 1], got {share}")
    keys = list(tracks)
    out = {k: _track(v).copy() for k, v in tracks.items()}
    if len(keys) < 2:
        if share > 0:
            raise ValueError("sentence_swap: needs >= 2 sentences")
        return out
    order = [keys[i] for i in np.random.default_rng(0x5A9).permutation(len(keys))]
    for i in range(int(round(share * len(keys)))):
        key, donor = order[i], order[(i + 1) % len(order)]
        track = _track(tracks[donor])
        out[key] = track[np.arange(len(out[key])) % len(track)]  # cut, or wrapped around when shorter
    return out


@dataclass(frozen=True)
class Disturbance:
    """One kind of disturbance: its levels and how it applies to the whole set.

    ``apply(tracks, level, names, samples)`` maps ``{key: (T, K)}`` to ``{key: (S, T, K)}``
    (``samples``: S of a disturbance that makes several samples, else ignored). Level 0
    is the undisturbed truth (every ``levels`` starts with it). ``samples`` is S for
    the small and the full set of levels (1 for a single-sample disturbance).
    """

    name: str
    label: str
    unit: str
    small: tuple
    full: tuple
    apply: Callable
    samples: tuple = (1, 1)

    def levels(self, which: str = "small") -> tuple:
        """The levels of the ``"small"`` (CI) or ``"full"`` set."""
        return self.small if _which(which) == "small" else self.full

    def sample_count(self, which: str = "small") -> int:
        """S of the ``"small"`` or ``"full"`` set."""
        return self.samples[0] if _which(which) == "small" else self.samples[1]


def _which(which: str) -> str:
    if which not in ("small", "full"):
        raise ValueError(f"levels: expected 'small' or 'full', got {which!r}")
    return which


def _per_track(fn):
    def apply(tracks, level, names, samples=1):
        return {k: fn(np.asarray(v, dtype=np.float64), level, names, k)[None] for k, v in tracks.items()}
    return apply


def _swap(tracks, level, names, samples=1):
    return {k: v[None] for k, v in sentence_swap(tracks, level).items()}


def _samples(tracks, level, names, samples=2):
    return {k: noisy_samples(v, level, samples, key=k) for k, v in tracks.items()}


#: Every disturbance the suite applies, in report order.
DISTURBANCES = {d.name: d for d in (
    Disturbance("time_shift", "time shift (delay)", "frames", (0, 1, 2, 4, 8), (0, 1, 2, 3, 4, 6, 8, 12),
                _per_track(lambda t, lv, n, k: time_shift(t, lv))),
    Disturbance("time_advance", "time shift (advance)", "frames", (0, 1, 2, 4, 8), (0, 1, 2, 3, 4, 6, 8, 12),
                _per_track(lambda t, lv, n, k: time_shift(t, -lv))),
    Disturbance("smoothing", "temporal smoothing", "sigma (frames)", (0, 1, 2, 4, 8), (0, 0.5, 1, 2, 3, 4, 6, 8),
                _per_track(lambda t, lv, n, k: temporal_smoothing(t, lv))),
    Disturbance("noise", "i.i.d. noise", "std", (0, 0.01, 0.02, 0.05, 0.1),
                (0, 0.005, 0.01, 0.02, 0.03, 0.05, 0.07, 0.1),
                _per_track(lambda t, lv, n, k: iid_noise(t, lv, key=k))),
    Disturbance("damping", "damping (scale)", "1 - factor", (0, 0.2, 0.4, 0.6, 0.8),
                (0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8),
                _per_track(lambda t, lv, n, k: damping(t, lv))),
    Disturbance("mouth_damping", "mouth-only damping", "1 - factor", (0, 0.2, 0.4, 0.6, 0.8),
                (0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.8),
                _per_track(lambda t, lv, n, k: mouth_damping(t, n, lv))),
    Disturbance("sentence_swap", "sentence swaps", "share swapped", (0, 0.25, 0.5, 0.75, 1.0),
                (0, 0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 1.0), _swap),
    Disturbance("noisy_samples", "noisy samples", "std", (0, 0.01, 0.02, 0.05, 0.1),
                (0, 0.005, 0.01, 0.02, 0.03, 0.05, 0.07, 0.1), _samples, samples=(2, 4)),
    Disturbance("constant_offset", "constant offset", "c", (0, 0.002, 0.005, 0.01, 0.02),
                (0, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1),
                _per_track(lambda t, lv, n, k: constant_offset(t, lv))),
)}


def disturb(kind: str, tracks: Mapping, level, names: Sequence[str], samples: int | None = None) -> dict:
    """``{key: (S, T, K)}``: the disturbance ``kind`` at ``level`` applied to ``{key: (T, K)}``
    (``samples``: S of ``noisy_samples``, default its small-set count)."""
    if kind not in DISTURBANCES:
        raise ValueError(f"disturb: unknown disturbance {kind!r}; known: {', '.join(DISTURBANCES)}")
    d = DISTURBANCES[kind]
    return d.apply(tracks, level, tuple(names), d.sample_count("small") if samples is None else int(samples))
