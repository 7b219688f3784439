"""Training sequences and frame-rate conversion shared by FaceFormer and CodeTalker.

Both methods model VOCASET at 30 fps (the authors take every second 60 fps frame);
the benchmark wants 60 fps, so predictions are resampled linearly in time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from baselines.common.dataset import sentence_audio
from baselines.common.encoders.wav2vec2 import normalize_waveform
from blendvoca.errors import DataError

__all__ = ["MotionSequence", "motion_frames", "motion_sequences", "sequence_tensors", "speaker_templates",
           "to_benchmark_rate"]

#: Motion frame rate of both methods on VOCASET.
MOTION_FPS = 30
@dataclass(frozen=True)
class MotionSequence:
    """One training sentence.

    Attributes
    ----------
    subject, sentence : str
    audio : (N,) float32 ndarray, 16 kHz
    vertices : (T, V*3) float32 ndarray
        Metres at :data:`MOTION_FPS`.
    template : (V*3,) float32 ndarray
    """

    subject: str
    sentence: str
    audio: np.ndarray
    vertices: np.ndarray
    template: np.ndarray


def motion_frames(num_frames_60: int) -> int:
    """Frames at 30 fps of a ``num_frames_60``-frame sentence: every second frame, as in training."""
    return (int(num_frames_60) + 1) // 2


def to_benchmark_rate(track: np.ndarray, num_frames_60: int) -> np.ndarray:
    """Resample a 30 fps track linearly in time to ``num_frames_60`` frames at 60 fps.

    Frame ``j`` of the result is at ``j / 60`` s, i.e. 30 fps position ``j / 2``:
    frame ``j / 2`` for even ``j``, the mean of its two neighbours for odd ``j``.
    Positions past the last frame hold it.

    Parameters
    ----------
    track : (T30, ...) ndarray
    num_frames_60 : int

    Returns
    -------
    (num_frames_60, ...) float64 ndarray
    """
    track = np.asarray(track, dtype=np.float64)
    position = np.arange(int(num_frames_60)) / 2.0
    lo = np.minimum(np.floor(position).astype(np.int64), track.shape[0] - 1)
    hi = np.minimum(lo + 1, track.shape[0] - 1)
    w = (position - lo).reshape((-1,) + (1,) * (track.ndim - 1))
    w = np.where((lo == hi).reshape(w.shape), 0.0, w)
    return (1.0 - w) * track[lo] + w * track[hi]


def speaker_templates(dataset) -> dict:
    """``{subject: (V*3,) float32 template}`` for every subject of every split."""
    out = {}
    for subjects in dataset.splits.values():
        for subject in subjects:
            if subject not in out:
                out[subject] = np.asarray(dataset.template(subject), dtype=np.float32).reshape(-1)
    return out


def motion_sequences(dataset, split: str) -> list[MotionSequence]:
    """Every sentence of ``split`` with its 16 kHz audio and 30 fps vertices (every second frame)."""
    out = []
    for subject in dataset.split(split):
        template = np.asarray(dataset.template(subject), dtype=np.float32).reshape(-1)
        for sentence in dataset.sentences(subject):
            audio = sentence_audio(dataset, subject, sentence, where="vertex sequences")
            verts = np.asarray(dataset.vertices(subject, sentence), dtype=np.float32)
            if verts.ndim != 3 or verts.shape[1:] != (template.size // 3, 3):
                raise DataError(f"{subject}/{sentence}: expected vertices (T, {template.size // 3}, 3), "
                                f"got {verts.shape}")
            out.append(MotionSequence(subject, sentence, audio, verts[::2].reshape(verts[::2].shape[0], -1), template))
    return out


def sequence_tensors(seq: MotionSequence, *, scale: float, normalise_audio: bool, device=None):
    """The network inputs of a sequence: ``(audio (1, N), template (1, V*3), vertices (1, T, V*3))`` float32 tensors.

    Parameters
    ----------
    seq : MotionSequence
    scale : float
        Multiplies the template and the vertices (a unit change, e.g. 100 for centimetres).
    normalise_audio : bool
        Zero mean and unit variance per waveform, as wav2vec 2.0 wants its input.
    device : torch.device, optional
        Where the tensors go (on the CPU: the same tensors, not copies).
    """
    audio = torch.from_numpy(seq.audio)[None]
    if normalise_audio:
        audio = normalize_waveform(audio)
    tensors = (audio, torch.from_numpy(seq.template)[None] * scale, torch.from_numpy(seq.vertices)[None] * scale)
    return tensors if device is None else tuple(x.to(device) for x in tensors)
