"""Stored tracks looked up by (subject, sentence), for oracle-like methods.

Methods whose output is tied to a sentence (the ground truth, another method's
stored outputs) return the track stored for the utterance's subject and sentence.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from baselines.common.npz_file import read_npz_arrays
from benchmark.methods.base import Method
from blendvoca.errors import DataError

__all__ = ["TrackLookupMethod", "fit_track_length"]


def fit_track_length(track, num_frames: int, *, max_mismatch: int, where: str):
    """``track`` cropped or edge-padded to ``num_frames`` frames.

    Parameters
    ----------
    track : (T, K) ndarray
    num_frames : int
        Wanted number of frames.
    max_mismatch : int
        Largest ``|T - num_frames|`` accepted (a frame or two differ between
        methods that round the audio duration differently).
    where : str
        Named in the error message.

    Returns
    -------
    (num_frames, K) ndarray

    Raises
    ------
    DataError
        The frame counts differ by more than ``max_mismatch``.
    """
    track = np.asarray(track)
    diff = track.shape[0] - num_frames
    if abs(diff) > max_mismatch:
        raise DataError(
            f"{where}: track has {track.shape[0]} frames, expected {num_frames} (at most {max_mismatch} "
            f"frame(s) difference is padded/cropped)"
        )
    if diff >= 0:
        return track[:num_frames]
    return np.concatenate([track, np.repeat(track[-1:], -diff, axis=0)], axis=0)


class TrackLookupMethod(Method):
    """A method whose output is one stored ``(T, 32)`` track per (subject, sentence).

    Subclasses return the tracks from :meth:`read_tracks` (stored by :meth:`train`), or
    fill ``self._tracks[(subject, sentence)] = track`` themselves; save/load store them
    in ``tracks.npz``.
    """

    #: the output is the corpus's own track of the sentence: no new recording can be animated
    new_audio = False

    #: largest frame-count mismatch padded or cropped in :meth:`generate`
    max_frame_mismatch: int = 0
    contract = 3

    def __init__(self, **config):
        super().__init__(**config)
        self._tracks: dict[tuple[str, str], np.ndarray] = {}

    def train(self, dataset, request) -> None:
        """Store :meth:`read_tracks` of ``dataset`` (nothing is learned: seed and budget play no part)."""
        self._tracks = self.read_tracks(dataset)

    def read_tracks(self, dataset) -> dict:
        """``{(subject, sentence): track}`` of ``dataset`` this method returns."""
        raise NotImplementedError(f"{type(self).__name__} defines neither read_tracks nor train")

    def stored_track(self, utterance) -> np.ndarray:
        """The ``(T', 32)`` track stored for the utterance (KeyError naming it if none)."""
        if utterance.key not in self._tracks:
            known = sorted({s for s, _ in self._tracks})
            raise KeyError(
                f"{self.name}: no stored track for {utterance.subject}/{utterance.sentence} "
                f"({len(self._tracks)} tracks stored, subjects {known}); was the method trained on this dataset?"
            )
        return self._tracks[utterance.key]

    def generate(self, utterance, *, samples=1, seed=0):
        track = fit_track_length(
            self.stored_track(utterance), utterance.num_frames, max_mismatch=self.max_frame_mismatch,
            where=f"{self.name}: subject {utterance.subject!r}, sentence {utterance.sentence!r}",
        )
        return np.repeat(track[None], int(samples), axis=0)

    def save(self, directory) -> None:
        super().save(directory)
        directory = Path(directory)
        index = [[subject, sentence] for subject, sentence in sorted(self._tracks)]
        arrays = {f"track_{i}": self._tracks[(s, q)] for i, (s, q) in enumerate(index)}
        np.savez_compressed(directory / "tracks.npz", **arrays)
        (directory / "tracks.json").write_text(json.dumps(index, indent=1) + "\n")

    @classmethod
    def load(cls, directory):
        method = super().load(directory)
        directory = Path(directory)
        listed = directory / "tracks.json"
        if not listed.is_file():
            raise DataError(f"{cls.__name__}.load: {directory} is not a complete checkpoint: it lacks tracks.json")
        try:
            index = json.loads(listed.read_text(encoding="utf-8"))
            index = [(str(subject), str(sentence)) for subject, sentence in index]
        except (UnicodeDecodeError, json.JSONDecodeError, TypeError, ValueError) as exc:
            raise DataError(f"{cls.__name__}.load: {listed} is not a JSON list of [subject, sentence] pairs "
                            f"({exc})") from None
        path = directory / "tracks.npz"
        arrays = read_npz_arrays(path, where=f"{cls.__name__}.load")  # no pickles: a file cannot run code
        missing = [f"track_{i}" for i in range(len(index)) if f"track_{i}" not in arrays]
        if missing:
            raise DataError(f"{cls.__name__}.load: {path} lacks {missing[:3]} listed in tracks.json")
        method._tracks = {(subject, sentence): arrays[f"track_{i}"] for i, (subject, sentence) in enumerate(index)}
        return method
