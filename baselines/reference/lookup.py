"""Recognising which dataset sentence an audio clip is, for oracle-like methods.

The method contract gives ``generate`` only the audio and the subject. Methods whose
output is tied to a sentence (ground truth, vertex outputs of other methods) index
the sentences by a digest of their audio samples when trained and look the clip up
when asked to generate.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from benchmark.methods.base import Method

__all__ = ["TrackLookupMethod", "audio_key", "fit_track_length"]


def audio_key(audio) -> str:
    """Hex digest identifying an audio clip by its float32 samples.

    Parameters
    ----------
    audio : (N,) array-like
        Mono samples; converted to contiguous float32 before hashing, so the same
        clip loaded twice gives the same key.
    """
    samples = np.ascontiguousarray(np.asarray(audio, dtype=np.float32).ravel())
    return hashlib.sha1(samples.tobytes()).hexdigest()


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
    """
    track = np.asarray(track)
    diff = track.shape[0] - num_frames
    if abs(diff) > max_mismatch:
        raise ValueError(
            f"{where}: track has {track.shape[0]} frames, expected {num_frames} (at most {max_mismatch} "
            f"frame(s) difference is padded/cropped)"
        )
    if diff >= 0:
        return track[:num_frames]
    return np.concatenate([track, np.repeat(track[-1:], -diff, axis=0)], axis=0)


class TrackLookupMethod(Method):
    """A method whose output is one stored ``(T, 32)`` track per (subject, audio clip).

    Subclasses fill ``self._tracks[(subject, audio_key)] = (sentence, track)`` in
    :meth:`train`; save/load store them in ``tracks.npz``.
    """

    #: largest frame-count mismatch padded or cropped in :meth:`generate`
    max_frame_mismatch: int = 0

    def __init__(self, **config):
        super().__init__(**config)
        self._tracks: dict[tuple[str, str], tuple[str, np.ndarray]] = {}

    def generate(self, audio, subject, *, num_frames, samples=1, seed=0):
        key = (subject, audio_key(audio))
        if key not in self._tracks:
            known = sorted({s for s, _ in self._tracks})
            raise KeyError(
                f"{self.name}: no stored track for this audio clip of subject {subject!r} "
                f"({len(self._tracks)} tracks stored, subjects {known}); was the method trained on this dataset?"
            )
        sentence, track = self._tracks[key]
        track = fit_track_length(
            track, int(num_frames), max_mismatch=self.max_frame_mismatch,
            where=f"{self.name}: subject {subject!r}, sentence {sentence!r}",
        )
        return np.repeat(track[None], int(samples), axis=0)

    def save(self, directory) -> None:
        super().save(directory)
        directory = Path(directory)
        index = [[subject, key, sentence] for (subject, key), (sentence, _) in sorted(self._tracks.items())]
        arrays = {f"track_{i}": self._tracks[(s, k)][1] for i, (s, k, _) in enumerate(index)}
        np.savez_compressed(directory / "tracks.npz", **arrays)
        (directory / "tracks.json").write_text(json.dumps(index, indent=1) + "\n")

    @classmethod
    def load(cls, directory):
        method = super().load(directory)
        directory = Path(directory)
        index = json.loads((directory / "tracks.json").read_text())
        with np.load(directory / "tracks.npz") as arrays:
            method._tracks = {
                (subject, key): (sentence, arrays[f"track_{i}"]) for i, (subject, key, sentence) in enumerate(index)
            }
        return method
