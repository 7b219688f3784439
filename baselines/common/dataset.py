"""Reading a benchmark dataset's sentences the way every learned baseline needs them.

The dataset is the benchmark's (``benchmark.data``): ``split(name)``,
``sentences(subject)`` and ``audio(subject, sentence) -> (samples, rate)``. The
baselines' speech encoders run at 16 kHz, the rate the BlendVOCA build stores.
"""

from __future__ import annotations

import numpy as np

from blendvoca.errors import DataError

__all__ = ["AUDIO_RATE", "sentence_audio"]

#: Sample rate of the audio every baseline trains on.
AUDIO_RATE = 16000


def sentence_audio(dataset, subject: str, sentence: str, *, where: str) -> np.ndarray:
    """The sentence's mono audio ``(N,)`` float32 at :data:`AUDIO_RATE`.

    Parameters
    ----------
    dataset : benchmark dataset
    subject, sentence : str
    where : str
        Names the reader in the error (e.g. ``"SAiD"``).

    Raises
    ------
    DataError
        The dataset stores the sentence at another rate.
    """
    audio, rate = dataset.audio(subject, sentence)
    if rate != AUDIO_RATE:
        raise DataError(f"{where}: expected {AUDIO_RATE // 1000} kHz audio from the dataset, got {rate} Hz "
                        f"for {subject}/{sentence}")
    return np.asarray(audio, dtype=np.float32)
