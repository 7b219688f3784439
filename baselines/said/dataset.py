"""SAiD's training data from a benchmark dataset: (coefficients, audio) pairs and the mirror permutation.

Shared by the plug-in (:mod:`baselines.said.plugin`) and the command line
(:mod:`baselines.said.train`).
"""

from __future__ import annotations

import numpy as np

from baselines.common.dataset import sentence_audio
from blendvoca.names import mirror_permutation

__all__ = ["dataset_pairs", "mirror_for"]


def dataset_pairs(dataset, split: str) -> list[tuple[np.ndarray, np.ndarray]]:
    """Return ``(coeffs (T, K), audio (N,) float32 16 kHz)`` for every sentence of a split.

    Parameters
    ----------
    dataset : benchmark.data dataset
    split : {"train", "val", "test"}

    Raises
    ------
    DataError
        A sentence's audio is not at 16 kHz.
    """
    pairs = []
    for subject in dataset.split(split):
        for sentence in dataset.sentences(subject):
            audio = sentence_audio(dataset, subject, sentence, where="SAiD")
            pairs.append((np.asarray(dataset.coeffs(subject, sentence), dtype=np.float32), audio))
    return pairs


def mirror_for(names) -> np.ndarray:
    """Return the mirror permutation ``(K,)`` of the column ``names`` (``blendvoca.names.mirror_permutation``)."""
    return np.asarray(mirror_permutation(tuple(names)), dtype=np.int64)
