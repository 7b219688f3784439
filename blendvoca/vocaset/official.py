"""The official VOCASET download layout.

::

    templates/<subject>.ply
    unposedcleaneddata/<subject>/sentenceNN/sentenceNN.NNNNNN.ply   (60 fps)
    registereddata/<subject>/sentenceNN/sentenceNN.NNNNNN.ply       (optional: with head pose)
    audio/<subject>/sentenceNN.wav

Frame files are numbered (1-based in the real data); they are sorted by number
and a gap in the numbering is reported. Frame PLYs may carry faces or be
vertex-only; only the vertex block is read (``read_ply_sequence``).
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

import numpy as np

from blendvoca.assets import resolve
from blendvoca.io.mesh import MeshFormatError, read_ply, read_ply_sequence, read_ply_vertices
from blendvoca.vocaset.checks import frame_gaps
from blendvoca.vocaset.base import VocasetCorpus
from blendvoca.vocaset.errors import Problem, VocasetError, check_safe_name

_FRAME = re.compile(r"^(?P<sentence>.+)\.(?P<number>\d+)\.ply$")


def _dirs(path: Path) -> list[str]:
    return sorted(p.name for p in path.iterdir() if p.is_dir()) if path.is_dir() else []


def frame_files(sentence_dir: Path) -> tuple[list[Path], np.ndarray]:
    """The frame PLYs of one sentence folder sorted by frame number, and the numbers ``(T,) int64``."""
    found = []
    if sentence_dir.is_dir():
        for p in sentence_dir.iterdir():
            m = _FRAME.match(p.name)
            if m:
                found.append((int(m["number"]), p))
    found.sort()
    return [p for _, p in found], np.array([n for n, _ in found], dtype=np.int64)


class OfficialVocaset(VocasetCorpus):
    """Reader of the official layout (see module docstring)."""

    layout = "official"

    def __init__(self, root, **kwargs):
        super().__init__(root, **kwargs)
        mesh_root, audio_root, template_root = (self.root / "unposedcleaneddata", self.root / "audio",
                                                self.root / "templates")
        templates = {p.stem for p in template_root.glob("*.ply")} if template_root.is_dir() else set()
        subjects = sorted(set(_dirs(mesh_root)) | set(_dirs(audio_root)) | templates)
        for subject in subjects:
            check_safe_name(subject, "subject", self.root)
        self._subjects = subjects
        self._frames: dict[tuple[str, str], tuple[list[Path], np.ndarray]] = {}
        self._sentences: dict[str, list[str]] = {}
        audio_names: dict[str, set[str]] = {}
        for subject in subjects:
            names = []
            for sentence in _dirs(mesh_root / subject):
                check_safe_name(sentence, "sentence", mesh_root / subject)
                paths, numbers = frame_files(mesh_root / subject / sentence)
                if not paths:
                    continue
                self._frames[subject, sentence] = (paths, numbers)
                names.append(sentence)
                gaps = frame_gaps(numbers)
                if gaps:
                    first = int(np.searchsorted(numbers, gaps[0]))
                    self._record(Problem(subject, sentence, first, "missing_frame",
                                         f"{mesh_root / subject / sentence}: frame files {gaps[:5]}"
                                         f"{'...' if len(gaps) > 5 else ''} missing ({len(gaps)} in all)"))
            self._sentences[subject] = names
            audio_names[subject] = ({p.stem for p in (audio_root / subject).glob("*.wav")}
                                    if (audio_root / subject).is_dir() else set())
            if subject not in templates:
                self._record(Problem(subject, None, None, "missing_template",
                                     f"{template_root / (subject + '.ply')} not found"))
        every = set().union(*self._sentences.values(), *audio_names.values()) if subjects else set()
        for subject in subjects:
            have = set(self._sentences[subject])
            for sentence in sorted(have - audio_names[subject]):
                self._record(Problem(subject, sentence, None, "missing_audio",
                                     f"{audio_root / subject / (sentence + '.wav')} not found"))
            for sentence in sorted(every - have):
                why = ("audio present but no mesh frames" if sentence in audio_names[subject]
                       else "present for other subjects")
                self._record(Problem(subject, sentence, None, "missing_sentence",
                                     f"{mesh_root / subject / sentence}: no frames ({why})"))

    def frame_paths(self, subject: str, sentence: str) -> list[Path]:
        """The PLY files of one sentence in frame order."""
        self._check_subject(subject)
        if (subject, sentence) not in self._frames:
            self._fail("missing_sentence", subject, sentence,
                       f"{self.root / 'unposedcleaneddata' / subject / sentence}: no frame files")
        return list(self._frames[subject, sentence][0])

    def num_frames(self, subject: str, sentence: str) -> int:
        return len(self.frame_paths(subject, sentence))

    def template(self, subject: str) -> np.ndarray:
        """Neutral mesh of ``subject``, ``(V, 3) float64``."""
        self._check_subject(subject)
        path = self.root / "templates" / f"{subject}.ply"
        if not path.is_file():
            self._fail("missing_template", subject, None, f"{path} not found")
        try:
            V = read_ply_vertices(path)
        except MeshFormatError as error:
            self._fail("truncated" if "truncated" in str(error) else "unreadable", subject, None, str(error))
        if V.shape != (self.num_vertices, 3):
            self._fail("vertex_count", subject, None, f"{path}: {len(V)} vertices, expected {self.num_vertices}")
        if not np.isfinite(V).all():
            self._fail("nan", subject, None, f"{path}: NaN or infinite coordinates")
        return V

    @functools.cached_property
    def faces(self) -> np.ndarray:
        """Triangles ``(F, 3) int64`` of the shared topology, from the first readable template."""
        for subject in self._subjects:
            try:
                V, F = read_ply(self.root / "templates" / f"{subject}.ply")
            except (OSError, MeshFormatError):
                continue
            if len(F) and len(V) == self.num_vertices:
                return F
        return read_ply(resolve("flame-sample"))[1]

    def frames(self, subject: str, sentence: str, dtype=np.float64) -> np.ndarray:
        """Mesh sequence ``(T, V, 3)`` at 60 fps in ``dtype`` (None: as read, float64).

        Raises
        ------
        VocasetError
            Missing sentence or frame files, a truncated or unreadable frame, a
            wrong vertex count, NaNs; naming subject, sentence and frame.
        """
        paths = self.frame_paths(subject, sentence)
        for p in self.problems:
            if (p.subject, p.sentence, p.kind) == (subject, sentence, "missing_frame"):
                raise VocasetError(p)
        frames = self._read_frames(subject, sentence, paths)
        if dtype is not None:
            frames = np.asarray(frames, dtype=dtype)
        return self._check_frames(subject, sentence, frames, str(paths[0].parent))

    def has_posed(self, subject: str, sentence: str) -> bool:
        """Whether ``registereddata/`` (VOCASET's data with head pose) holds this sentence."""
        return bool(frame_files(self.root / "registereddata" / subject / sentence)[0])

    def posed_frames(self, subject: str, sentence: str) -> np.ndarray:
        """The sentence with head pose, ``(T, V, 3) float64`` from ``registereddata/``.

        Raises
        ------
        VocasetError
            No posed frames for the sentence (``missing_sentence``), a gap in
            their numbering, or a bad frame.
        """
        self._check_subject(subject)
        folder = self.root / "registereddata" / subject / sentence
        paths, numbers = frame_files(folder)
        if not paths:
            self._fail("missing_sentence", subject, sentence, f"{folder}: no posed frame files")
        gaps = frame_gaps(numbers)
        if gaps:
            self._fail("missing_frame", subject, sentence, f"{folder}: frame files {gaps[:5]} missing",
                       frame=int(np.searchsorted(numbers, gaps[0])))
        return self._check_frames(subject, sentence, self._read_frames(subject, sentence, paths), str(folder))

    def _read_frames(self, subject: str, sentence: str, paths: list[Path]) -> np.ndarray:
        """The frame PLYs ``paths`` stacked ``(T, V, 3)``; the first bad one is recorded and raised."""
        try:
            return read_ply_sequence(paths, num_vertices=self.num_vertices)
        except (MeshFormatError, OSError):
            pass
        for t, path in enumerate(paths):
            try:
                V = read_ply_vertices(path)
            except MeshFormatError as error:
                kind = "truncated" if "truncated" in str(error) else "unreadable"
                self._fail(kind, subject, sentence, str(error), frame=t)
            except OSError as error:
                self._fail("unreadable", subject, sentence, f"{path}: {error}", frame=t)
            if len(V) != self.num_vertices:
                self._fail("vertex_count", subject, sentence,
                           f"{path}: {len(V)} vertices, expected {self.num_vertices}", frame=t)
        self._fail("unreadable", subject, sentence, f"{paths[0].parent}: frames do not stack")

    def audio(self, subject: str, sentence: str) -> tuple[np.ndarray, int]:
        """Speech of one sentence at its native rate: ``(samples (N,) float32 mono, rate)``."""
        self._check_subject(subject)
        return self._wav_audio(subject, sentence, self.root / "audio" / subject / f"{sentence}.wav")
