"""``random``: smooth random coefficient tracks that ignore the audio (stochastic lower reference)."""

from __future__ import annotations

import numpy as np

from benchmark.methods.base import Method

__all__ = ["RandomWalkMethod", "random_tracks"]


def random_tracks(rng: np.random.Generator, samples: int, num_frames: int, num_coeffs: int, *,
                  scale: float = 0.3, smoothing: int = 15) -> np.ndarray:
    """Smoothed uniform noise in [0, scale].

    Parameters
    ----------
    rng : numpy Generator
    samples, num_frames, num_coeffs : int
        Output shape ``(S, T, K)``.
    scale : float
        Upper bound of the values (in [0, 1]).
    smoothing : int
        Width in frames of the moving average applied along time.

    Returns
    -------
    (S, T, K) float64 ndarray in [0, scale]
    """
    pad = smoothing - 1
    noise = rng.uniform(0.0, scale, size=(samples, num_frames + pad, num_coeffs))
    kernel = np.ones(smoothing) / smoothing
    # moving average along time: a mean of values in [0, scale] stays in [0, scale]
    cs = np.cumsum(np.concatenate([np.zeros((samples, 1, num_coeffs)), noise], axis=1), axis=1)
    out = (cs[:, smoothing:] - cs[:, :-smoothing]) * kernel[0]
    return np.clip(out, 0.0, scale)


class RandomWalkMethod(Method):
    """Stochastic lower reference: smooth noise, independent of the audio.

    Parameters
    ----------
    scale : float
        Largest coefficient value.
    smoothing : int
        Moving-average width in frames.
    """

    name = "random"
    stochastic = True
    reference = True

    def __init__(self, scale: float = 0.3, smoothing: int = 15):
        super().__init__(scale=scale, smoothing=smoothing)

    def generate(self, utterance, *, samples=1, seed=0):
        rng = np.random.default_rng(seed)
        return random_tracks(rng, int(samples), utterance.num_frames, 32, scale=self._config["scale"],
                             smoothing=self._config["smoothing"])
