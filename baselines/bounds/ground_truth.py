"""``ground-truth``: returns the dataset's own coefficient tracks (upper reference)."""

from __future__ import annotations

import numpy as np

from baselines.common.track_lookup import TrackLookupMethod

__all__ = ["GroundTruthMethod"]


class GroundTruthMethod(TrackLookupMethod):
    """Upper reference: the BlendVOCA coefficients of the very sentence being scored.

    ``train`` stores the tracks of ``split`` (default ``"test"``: it is an oracle);
    ``generate`` returns the utterance's own track, repeated over samples.

    Parameters
    ----------
    split : str
        Split whose sentences are indexed.
    """

    name = "ground-truth"
    stochastic = False
    reference = True

    def __init__(self, split: str = "test"):
        super().__init__(split=split)

    def read_tracks(self, dataset) -> dict:
        return {
            (subject, sentence): np.asarray(dataset.coeffs(subject, sentence), dtype=np.float64)
            for subject in dataset.split(self._config["split"])
            for sentence in dataset.sentences(subject)
        }
