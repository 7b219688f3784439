"""The constants and the values of the method contract (docs/methods.md).

Everything a plug-in needs to agree with the runner lives here: the audio rate and
frame rate, the coefficient names, the output kinds, :class:`Dataset`, what
``Method.train`` is given, and :class:`Utterance`, the one value ``Method.generate``
receives.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from blendvoca.names import BLENDVOCA_NAMES

__all__ = [
    "AUDIO_RATE",
    "COEFFICIENT_NAMES",
    "Dataset",
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


@runtime_checkable
class Dataset(Protocol):
    """What ``Method.train`` is given: the dataset a method may learn from.

    :class:`benchmark.data.BlendVOCADataset` (a BlendVOCA folder, from
    ``benchmark.data.open_blendvoca``) and :class:`benchmark.testing.FakeBlendVOCA`
    (a small in-memory one for tests) are datasets; ``isinstance(x, Dataset)``
    checks that an object has every member below.

    Attributes
    ----------
    names : tuple of str
        The coefficient column order (:data:`COEFFICIENT_NAMES`).
    subjects : list of str
        Every speaker of the dataset.
    manifest_hash : str
        The data's identity (the result files record it).
    splits : dict
        Split name -> list of subjects.
    """

    names: tuple[str, ...]
    subjects: list[str]
    manifest_hash: str

    @property
    def splits(self) -> dict[str, list[str]]:
        """Split name (``"train"``, ``"val"``, ``"test"``) -> list of subjects."""

    def split(self, name: str) -> list[str]:
        """The subjects of a split; an unknown split raises ``ValueError``."""

    def sentences(self, subject: str) -> list[str]:
        """The speaker's sentences (``sentenceNN``) with a ground-truth track, sorted."""

    def coeffs(self, subject: str, sentence: str) -> np.ndarray:
        """The ground-truth track, ``(T, K)`` float64 in ``names`` order at :data:`FPS`."""

    def samples(self, subject: str, sentence: str) -> np.ndarray:
        """Every stored track of a sentence, ``(S, T, K)`` (``S = 1``: the ground truth alone)."""

    def audio(self, subject: str, sentence: str) -> tuple[np.ndarray, int]:
        """The speech: ``((N,) float32 mono, AUDIO_RATE)``."""

    def utterance(self, subject: str, sentence: str, split: str | None = None) -> Utterance:
        """The :class:`Utterance` of a sentence, as ``generate`` receives it (``split``: the subject's)."""

    def rig(self, subject: str):
        """The speaker's rig (:class:`blendvoca.rig.Rig`: neutral, ``(K, V, 3)`` deltas, names, faces)."""

    def vertices(self, subject: str, sentence: str) -> np.ndarray:
        """The source mesh sequence, ``(T, V, 3)`` float64 metres at :data:`FPS` (vertex-trained methods)."""

    def template(self, subject: str) -> np.ndarray:
        """The speaker's neutral mesh on the source topology, ``(V, 3)`` float64 metres."""

    def faces(self) -> np.ndarray:
        """Triangles of the source topology, ``(F, 3)`` int64."""
