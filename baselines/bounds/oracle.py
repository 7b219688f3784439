"""``oracle-sample`` and ``oracle-mean``: a synthetic corpus's own conditional samples (reference rows).

A synthetic corpus generated with ``--oracle-samples K`` knows p(motion | audio,
speaker): it writes K fresh draws of every sentence's motion (everything the
inputs do not fix drawn again, the per-sentence lag included; same plan and
audio), and the build fits them like the ground truth
(``oracle_coeffs/<subject>/<sentence>-<k>.csv``, read through
:meth:`benchmark.data.BlendVOCADataset.oracle_coeffs`).

- ``oracle-sample`` returns S of the K samples (a perfect sampler of the
  conditional distribution): distribution metrics and the energy score must
  prefer it to ``oracle-mean``.
- ``oracle-mean`` returns the mean of the K samples' fitted tracks (the
  Monte-Carlo conditional mean; the components are non-linear and bounded, so
  "random parts at their expectation" would not be it): LVE must prefer it.

Both read the tracks of ``split`` (default ``"test"``) in :meth:`train`. A build
without oracle tracks, or ``--samples S`` above K, is a ``UserError`` (one
``error:`` line, exit status 2 from ``python -m benchmark.run``).
"""

from __future__ import annotations

import numpy as np

from baselines.common.track_lookup import TrackLookupMethod, fit_track_length
from blendvoca.errors import UserError

__all__ = ["OracleMeanMethod", "OracleSampleMethod", "oracle_tracks"]

_HOW = "generate the corpus with `python -m blendvoca.synthetic --oracle-samples K` and build it"


def oracle_tracks(dataset, split: str, name: str) -> dict[tuple[str, str], np.ndarray]:
    """``{(subject, sentence): (K, T, 32)}`` of every sentence of ``split``.

    Raises
    ------
    UserError
        The dataset has no oracle tracks (for some sentence of the split); the message
        names what is missing and how to make it.
    """
    where = getattr(dataset, "root", "the dataset")
    has = getattr(dataset, "has_oracle", None)
    if has is None or not has():
        raise UserError(f"{name}: the build {where} has no oracle tracks (oracle_coeffs/); {_HOW}")
    tracks = {}
    for subject in dataset.split(split):
        for sentence in dataset.sentences(subject):
            if not has(subject, sentence):
                raise UserError(f"{name}: the build {where} has no oracle tracks for {subject}/{sentence} "
                                f"(oracle_coeffs/{subject}/{sentence}-<k>.csv); {_HOW}")
            tracks[(subject, sentence)] = np.asarray(dataset.oracle_coeffs(subject, sentence), dtype=np.float64)
    return tracks


class _OracleMethod(TrackLookupMethod):
    """The oracle references' shared part: a reference that learns nothing, reading the
    tracks of ``split``."""

    reference = True
    learns = False

    def __init__(self, split: str = "test"):
        super().__init__(split=split)


class OracleSampleMethod(_OracleMethod):
    """Reference: S of the K conditional samples the corpus drew for the sentence.

    ``generate(samples=S)`` returns S distinct samples; which ones depends on
    ``seed`` (all K, in order, when S == K).

    Parameters
    ----------
    split : str
        Split whose oracle tracks are read.
    """

    name = "oracle-sample"
    stochastic = True

    def read_tracks(self, dataset) -> dict:
        return oracle_tracks(dataset, self._config["split"], self.name)

    def generate(self, utterance, *, samples=1, seed=0):
        stored = self.stored_track(utterance)
        count, wanted = int(stored.shape[0]), int(samples)
        if wanted > count:
            raise UserError(f"{self.name}: --samples {wanted} but the build has {count} oracle tracks per sentence "
                            f"({utterance.subject}/{utterance.sentence}); use --samples {count} or fewer, or "
                            f"generate the corpus with --oracle-samples {wanted} or more")
        chosen = np.arange(count) if wanted == count else \
            np.sort(np.random.default_rng(int(seed)).choice(count, wanted, replace=False))
        where = f"{self.name}: subject {utterance.subject!r}, sentence {utterance.sentence!r}"
        return np.stack([fit_track_length(stored[k], utterance.num_frames, max_mismatch=self.max_frame_mismatch,
                                          where=where) for k in chosen])


class OracleMeanMethod(_OracleMethod):
    """Reference: the mean of the K conditional samples' fitted tracks (the Monte-Carlo conditional mean).

    Parameters
    ----------
    split : str
        Split whose oracle tracks are read.
    """

    name = "oracle-mean"
    stochastic = False

    def read_tracks(self, dataset) -> dict:
        return {key: samples.mean(axis=0)
                for key, samples in oracle_tracks(dataset, self._config["split"], self.name).items()}
