"""What the vertex corpora other than VOCASET share (BIWI, Multiface): units, rate, landmarks.

A reader here is a :class:`~blendvoca.vocaset.base.VocasetCorpus`: the build
reads it exactly as it reads VOCASET (speakers, sentences, templates, 60 fps
frames in metres, audio, splits, faces). What differs is declared on the reader:

- ``source_fps``: the corpus's own rate; ``frames`` resamples to 60 fps with the
  project's one resampler (:func:`blendvoca.fit.resample_sequence`);
- ``units``: the corpus's length unit (``auto``: the one that gives the template
  a head's size), converted to metres;
- ``posed = True``: the frames carry the head pose (the build fits pose and
  expression together, :mod:`blendvoca.fit.joint_pose`);
- ``landmarks()``: the 68 iBUG landmarks on the corpus's topology, read from a
  file the user supplies (no such file may be redistributed with BlendVOCA);
- ``head_index()``: every vertex (these meshes are faces, no back of the head).
"""

from __future__ import annotations

import functools
import os
import re
from pathlib import Path

import numpy as np

from blendvoca.assets import resolve
from blendvoca.builder.pipeline import build_dataset, open_corpus
from blendvoca.datasets import DatasetAdapter
from blendvoca.errors import DataError, UserError
from blendvoca.fit.resample import resample_sequence
from blendvoca.io.mesh import read_index_list
from blendvoca.vocaset.base import VocasetCorpus
from blendvoca.vocaset.checks import FLAME_RMS_RADIUS, rms_radius

#: Length units a corpus may be stored in, as metres per unit.
UNITS = {"m": 1.0, "cm": 0.01, "mm": 0.001}

#: How a landmark file is laid out (quoted by every error about one).
LANDMARK_FORMAT = ("a text file of 68 whitespace-separated 0-based vertex indices into the {topology} mesh "
                   "({vertices} vertices), in the order of the iBUG 300-W 68-point landmarks (jaw line 0-16, "
                   "brows 17-26, nose 27-35, eyes 36-47, outer lips 48-59, inner lips 60-67)")


def sentence_numbers(names) -> dict[str, str]:
    """``{source sentence name: "sentenceNN"}`` for a corpus's sentence names.

    A BlendVOCA folder names sentences ``sentenceNN``. When every name carries one
    number and no two share it (BIWI's ``e01`` ... ``e40``), that number is kept;
    otherwise the sorted names are numbered from 1 (Multiface's ``SEN_...``). The
    numbering is corpus-wide, so one sentence has one number for every speaker.
    """
    names = sorted(set(names))
    found = [re.findall(r"\d+", name) for name in names]
    if all(len(f) == 1 for f in found) and len({int(f[0]) for f in found}) == len(names):
        numbers = [int(f[0]) for f in found]
    else:
        numbers = list(range(1, len(names) + 1))
    width = max(2, len(str(max(numbers, default=1))))
    return {name: f"sentence{number:0{width}d}" for name, number in zip(names, numbers)}


class LayoutError(UserError):
    """A corpus root that is not in the layout its reader expects; the message names the expected files."""


def guess_unit(template: np.ndarray) -> str:
    """The unit (a key of :data:`UNITS`) that gives ``template`` the size of a head in metres."""
    radius = rms_radius(template)
    if not np.isfinite(radius) or radius <= 0:
        raise DataError(f"template has no extent (RMS radius {radius}); cannot tell its unit")
    return min(UNITS, key=lambda unit: abs(np.log(radius * UNITS[unit] / FLAME_RMS_RADIUS)))


def read_landmark_file(path, num_vertices: int, topology: str) -> np.ndarray:
    """The 68 landmark vertex indices of a user-supplied file, checked against the topology.

    Raises
    ------
    DataError
        Not 68 integers, or an index outside ``[0, num_vertices)``; the message
        names the file and the expected format.
    """
    expected = LANDMARK_FORMAT.format(topology=topology, vertices=num_vertices)
    try:
        indices = read_index_list(path)
    except ValueError as error:
        raise DataError(f"{path}: not a landmark file ({error}); expected {expected}") from None
    if indices.shape != (68,) or indices.min() < 0 or indices.max() >= num_vertices:
        raise DataError(f"{path}: holds {len(indices)} indices in [{indices.min() if len(indices) else '-'}, "
                        f"{indices.max() if len(indices) else '-'}]; expected {expected}")
    return indices


class VertexCorpus(VocasetCorpus):
    """Base of the non-FLAME vertex corpus readers (see the module docstring)."""

    #: Name of the topology in messages.
    topology: str = ""
    #: Vertices of the topology.
    vertex_count: int = 0
    #: The corpus's own frame rate.
    source_fps: float = 60.0
    #: The asset id (``data_manifest.yaml``) of the user-supplied landmark file.
    landmark_asset: str = ""
    posed = True

    def __init__(self, root, *, units: str = "auto", landmarks=None):
        super().__init__(root, num_vertices=self.vertex_count)
        if units != "auto" and units not in UNITS:
            raise UserError(f"units: expected auto or one of {', '.join(UNITS)}, got {units!r}")
        self._units = units
        self._scale: float | None = None if units == "auto" else UNITS[units]
        self._landmark_path = None if landmarks is None else Path(os.fspath(landmarks))
        self._templates: dict[str, np.ndarray] = {}
        #: BlendVOCA sentence name -> the corpus's (``sentence01`` -> BIWI's ``e01``); subclasses fill it
        self._source_names: dict[str, str] = {}

    def source_name(self, sentence: str) -> str:
        """The corpus's own name of a sentence (``sentence01`` -> BIWI's ``e01``, Multiface's ``SEN_...``)."""
        return self._source_names.get(sentence, sentence)

    # -- what subclasses provide --------------------------------------------
    def _raw_template(self, subject: str) -> np.ndarray:
        """The speaker's neutral in the corpus's own unit, ``(V, 3)``."""
        raise NotImplementedError

    def _raw_frames(self, subject: str, sentence: str) -> np.ndarray:
        """The sentence in the corpus's own unit and rate, ``(T, V, 3)``."""
        raise NotImplementedError

    def _wav(self, subject: str, sentence: str) -> Path:
        """The sentence's WAV file."""
        raise NotImplementedError

    # -- the shared interface -------------------------------------------------
    def audio(self, subject: str, sentence: str) -> tuple[np.ndarray, int]:
        """Speech of one sentence at its native rate: ``(samples (N,) float32 mono, rate)``."""
        self._check_subject(subject)
        return self._wav_audio(subject, sentence, self._wav(subject, sentence))

    @property
    def scale(self) -> float:
        """Metres per corpus unit (``units``, or guessed from the first readable template)."""
        if self._scale is None:
            for subject in self.subjects:
                try:
                    template = self._raw_template(subject)
                except Exception:  # that speaker reports its own problem
                    continue
                self._scale = UNITS[guess_unit(template)]
                break
            else:
                raise DataError(f"{self.root}: no speaker's template could be read to tell the corpus's unit")
        return self._scale

    def template(self, subject: str) -> np.ndarray:
        """The speaker's neutral ``(V, 3)`` in metres."""
        self._check_subject(subject)
        if subject not in self._templates:
            template = np.asarray(self._raw_template(subject), dtype=np.float64)
            if template.shape != (self.num_vertices, 3):
                self._fail("vertex_count", subject, None,
                           f"template has shape {template.shape}, expected ({self.num_vertices}, 3)")
            if not np.all(np.isfinite(template)):
                self._fail("nan", subject, None, "template has NaN or infinite coordinates")
            self._templates[subject] = template * self.scale
        return self._templates[subject].copy()

    def frames(self, subject: str, sentence: str, dtype=np.float64) -> np.ndarray:
        """The sentence ``(T, V, 3)`` in metres, resampled from ``source_fps`` to 60 fps.

        ``dtype=None`` gives float64 (the frames are interpolated, so no stored precision is kept).
        """
        self._check_subject(subject)
        raw = np.asarray(self._raw_frames(subject, sentence), dtype=np.float64)
        raw = self._check_frames(subject, sentence, raw, f"{subject}/{sentence}")
        frames = resample_sequence(raw * self.scale, self.source_fps, self.fps)
        return frames if dtype is None else frames.astype(dtype, copy=False)

    def landmarks(self) -> np.ndarray:
        """The 68 iBUG landmarks on this topology, ``(68,) int64``.

        From ``landmarks=`` given when opening, else the asset ``landmark_asset``
        (a file the user puts under the asset directory; see ``data_manifest.yaml``).

        Raises
        ------
        AssetError
            No landmark file: the message says what the file holds and where to put it.
        DataError
            A file that is not 68 indices into this topology.
        """
        if self._landmark_path is not None:
            if not self._landmark_path.is_file():
                raise UserError(f"{self._landmark_path}: landmark file not found; expected "
                                + LANDMARK_FORMAT.format(topology=self.topology, vertices=self.num_vertices))
            return read_landmark_file(self._landmark_path, self.num_vertices, self.topology)
        return read_landmark_file(resolve(self.landmark_asset), self.num_vertices, self.topology)

    def head_index(self) -> np.ndarray:
        """Vertices the fit uses: all of them (a face mesh has no back of the head or neck to drop)."""
        return np.arange(self.num_vertices, dtype=np.int64)


def build_vertex_corpus(reader: str, root, out, *, workers: int | None = None, shapes: str = "speech",
                        delta: float = 0.1, report: bool = True, pose_fit: str = "joint"):
    """Build BlendVOCA from a vertex corpus at ``root`` into ``out`` through ``reader``
    (``"module:open_function"``), the adapter of ``--dataset biwi`` and ``--dataset multiface``.

    The corpus is opened first, so a root in another layout is refused before
    anything is written (:class:`LayoutError`, naming the expected files); then the
    VOCASET build runs on this reader: rigs retargeted with the corpus's landmarks,
    sentences fitted with their head pose (``pose_fit``), the same layout, splits and
    manifest.
    """
    open_corpus(root, reader)
    return build_dataset(out, root, workers=workers, shapes=shapes, delta=delta, report=report,
                         reader=reader, pose_fit=pose_fit)


def vertex_adapter(reader: str) -> DatasetAdapter:
    """The adapter of the vertex corpus ``reader`` opens (``"module:open_function"``):
    :func:`build_vertex_corpus` with that reader, declaring ``pose_fit``."""
    return DatasetAdapter(functools.partial(build_vertex_corpus, reader), options=("pose_fit",))
