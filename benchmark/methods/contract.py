"""The constants and the per-utterance value of the method contract (docs/methods.md).

Everything a plug-in needs to agree with the runner lives here: the audio rate and
frame rate, the coefficient names, the output kinds and :class:`Utterance`, the one
value ``Method.generate`` receives.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from blendvoca.names import BLENDVOCA_NAMES

__all__ = [
    "AUDIO_RATE",
    "COEFFICIENT_NAMES",
    "FPS",
    "NUM_COEFFS",
    "OUTPUT_COEFFICIENTS",
    "OUTPUT_KINDS",
    "OUTPUT_VERTICES",
    "Utterance",
]

#: Sample rate of the speech handed to ``generate`` (mono float32).
AUDIO_RATE = 16000
#: Frame rate of every track a method returns.
FPS = 60
#: Coefficient column order of ``output = "coefficients"`` methods.
COEFFICIENT_NAMES = tuple(BLENDVOCA_NAMES)
#: Number of coefficients per frame.
NUM_COEFFS = len(COEFFICIENT_NAMES)
#: ``Method.output`` of a method returning ``(S, T, 32)`` coefficient tracks in [0, 1].
OUTPUT_COEFFICIENTS = "coefficients"
#: ``Method.output`` of a method returning ``(S, T, V, 3)`` vertices in metres on the
#: speaker's topology (the runner fits them to coefficients with the speaker's rig).
OUTPUT_VERTICES = "vertices"
#: The declared outputs a method may have.
OUTPUT_KINDS = (OUTPUT_COEFFICIENTS, OUTPUT_VERTICES)


@dataclass(frozen=True)
class Utterance:
    """One sentence to animate: what ``Method.generate`` receives.

    Attributes
    ----------
    subject : str
        Speaker id (``FaceTalk_..._TA`` on VOCASET). Methods with a speaker style
        may use it; the vertex metrics use the speaker's rig.
    sentence : str
        ``sentenceNN``.
    split : str
        Split the sentence belongs to (``"test"`` when scored).
    audio : (N,) float32 ndarray
        Mono speech at :data:`AUDIO_RATE`.
    num_frames : int
        Number of :data:`FPS` frames ``T`` to return.
    """

    subject: str
    sentence: str
    split: str
    audio: np.ndarray = field(repr=False)
    num_frames: int

    def __post_init__(self):
        audio = np.asarray(self.audio, dtype=np.float32)
        if audio.ndim != 1:
            raise ValueError(f"Utterance {self.subject}/{self.sentence}: expected mono audio (N,), got shape {audio.shape}")
        object.__setattr__(self, "audio", audio)
        if isinstance(self.num_frames, bool) or int(self.num_frames) != self.num_frames or self.num_frames < 1:
            raise ValueError(f"Utterance {self.subject}/{self.sentence}: num_frames must be a positive int, "
                             f"got {self.num_frames!r}")
        object.__setattr__(self, "num_frames", int(self.num_frames))

    @property
    def key(self) -> tuple[str, str]:
        """``(subject, sentence)``."""
        return self.subject, self.sentence

    @property
    def duration(self) -> float:
        """Audio length in seconds."""
        return self.audio.shape[0] / AUDIO_RATE
