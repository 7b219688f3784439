"""``mean``: the train-split mean of every coefficient, constant in time (lower reference)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from benchmark.methods.base import Method

__all__ = ["MeanMethod", "mean_coefficients"]


def mean_coefficients(tracks) -> np.ndarray:
    """Frame-weighted mean of coefficient tracks.

    Parameters
    ----------
    tracks : iterable of (T_i, K) ndarray

    Returns
    -------
    (K,) float64 ndarray
        ``sum_i sum_t tracks[i][t] / sum_i T_i``.
    """
    total, count = None, 0
    for i, track in enumerate(tracks):
        track = np.asarray(track, dtype=np.float64)
        if track.ndim != 2:
            raise ValueError(f"mean_coefficients: track {i}: expected (T, K), got shape {track.shape}")
        total = track.sum(axis=0) if total is None else total + track.sum(axis=0)
        count += track.shape[0]
    if not count:
        raise ValueError("mean_coefficients: expected at least one non-empty track, got none")
    return total / count


class MeanMethod(Method):
    """Lower reference: every frame is the mean coefficient vector of ``split`` (train).

    Parameters
    ----------
    split : str
        Split the mean is taken over.
    """

    name = "mean"
    stochastic = False
    reference = True

    def __init__(self, split: str = "train"):
        super().__init__(split=split)
        self.mean_: np.ndarray | None = None

    contract = 3

    def train(self, dataset, request):
        self.mean_ = mean_coefficients(
            dataset.coeffs(subject, sentence)
            for subject in dataset.split(self._config["split"])
            for sentence in dataset.sentences(subject)
        )

    def generate(self, utterance, *, samples=1, seed=0):
        if self.mean_ is None:
            raise RuntimeError("mean: generate called before train/load")
        return np.broadcast_to(self.mean_, (int(samples), utterance.num_frames, self.mean_.shape[0])).copy()

    def save(self, directory):
        super().save(directory)
        (Path(directory) / "mean.json").write_text(json.dumps(self.mean_.tolist()) + "\n")

    @classmethod
    def load(cls, directory):
        method = super().load(directory)
        method.mean_ = np.asarray(json.loads((Path(directory) / "mean.json").read_text()), dtype=np.float64)
        return method
