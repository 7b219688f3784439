"""What both VOCASET layouts share: the :class:`VocasetCorpus` interface and its problem log.

The layout readers (:mod:`blendvoca.vocaset.official`, :mod:`blendvoca.vocaset.processed`)
subclass :class:`VocasetCorpus`; :func:`blendvoca.vocaset.corpus.open_vocaset` picks one.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from blendvoca.assets import load_index_list
from blendvoca.errors import DataError
from blendvoca.io.audio import read_wav, to_mono
from blendvoca.io.json_file import json_kind, read_json
from blendvoca.runtime.progress import bar
from blendvoca.vocaset.checks import first_bad_frame, wav_truncation
from blendvoca.vocaset.errors import Problem, VocasetError
from blendvoca.vocaset.splits import FPS, NUM_VERTICES, corpus_splits

__all__ = ["SIDECAR", "VocasetCorpus", "read_sidecar"]

SIDECAR = "synthetic.json"


def read_sidecar(path) -> dict:
    """The synthetic-corpus sidecar at ``path``: a JSON object whose ``splits``, if present, are lists of names.

    Parameters
    ----------
    path : str or os.PathLike
        The ``synthetic.json`` file.

    Returns
    -------
    dict
        The parsed document.

    Raises
    ------
    DataError
        The file is not UTF-8 JSON (numbers beyond Python's digit limit and nesting
        beyond its recursion limit included), is not an object, or its ``splits`` is
        not ``{split name: [speaker name, ...]}``; the message names the file.
    """
    path = Path(os.fspath(path))
    document = read_json(path, what="a readable synthetic-corpus sidecar")
    if not isinstance(document, dict):
        raise DataError(f"{path}: the synthetic-corpus sidecar is {json_kind(document)}, "
                        "expected a JSON object (seed, splits, ...)")
    splits = document.get("splits")
    if "splits" in document:
        if not isinstance(splits, dict):
            raise DataError(f"{path}: 'splits' is {json_kind(splits)}, expected an object "
                            '{"train": [speaker, ...], "val": [...], "test": [...]}')
        for name, speakers in splits.items():
            if not isinstance(speakers, list) or not all(isinstance(s, str) for s in speakers):
                raise DataError(f"{path}: split {name!r} is {_describe(speakers)}, expected a list of speaker names")
    return document


def _describe(value) -> str:
    """A split's value for a message: ``a number``, ``a list holding a number``..."""
    if isinstance(value, list):
        odd = next((v for v in value if not isinstance(v, str)), None)
        return f"a list holding {json_kind(odd)}"
    return json_kind(value)


class VocasetCorpus:
    """A VOCASET-like corpus: speakers, sentences, templates, 60 fps meshes, audio.

    Subclasses implement the layouts; this class holds what they share: the
    problem log, splits, scanning. Items that cannot be read raise
    ``VocasetError`` naming subject, sentence and frame, and are logged in
    ``problems``; everything else keeps reading.
    """

    layout: str = ""
    fps: int = FPS
    #: Whether ``frames`` carry the head pose (VOCASET's unposedcleaneddata does not; the
    #: build fits the pose of posed corpora together with the expression).
    posed: bool = False

    def __init__(self, root, *, num_vertices: int = NUM_VERTICES):
        self.root = Path(os.fspath(root))
        self.num_vertices = int(num_vertices)
        self._problems: dict[tuple, Problem] = {}
        self._sidecar = None
        sidecar = self.root / SIDECAR
        if sidecar.is_file():
            self._sidecar = read_sidecar(sidecar)

    # -- problems ----------------------------------------------------------
    def _record(self, problem: Problem) -> Problem:
        key = (problem.subject, problem.sentence, problem.kind)
        self._problems.setdefault(key, problem)
        return problem

    def _fail(self, kind: str, subject: str, sentence: str | None, message: str, frame: int | None = None):
        raise VocasetError(self._record(Problem(subject, sentence, frame, kind, message)))

    @property
    def problems(self) -> list[Problem]:
        """Every problem found so far (at open time, by reads, or by ``scan``), sorted."""
        return sorted(self._problems.values())

    def scan(self) -> list[Problem]:
        """Read every template, frame sequence and audio clip; return all problems.

        Nothing raises: bad items are collected and the rest is read.
        """
        items = [(s, q) for s in self.subjects for q in self.sentences(s)]
        for subject in self.subjects:
            try:
                self.template(subject)
            except VocasetError:
                pass
        for subject, sentence in bar(items, desc="scan VOCASET"):
            for read in (self.frames, self.audio):
                try:
                    read(subject, sentence)
                except VocasetError:
                    pass
        return self.problems

    # -- shared interface --------------------------------------------------
    # Subclasses fill ``_subjects`` (sorted names) and ``_sentences`` ({subject: sorted names}).
    @property
    def subjects(self) -> list[str]:
        """The corpus's speakers, sorted."""
        return list(self._subjects)

    def sentences(self, subject: str) -> list[str]:
        """Sentences of ``subject`` that have frames, sorted."""
        self._check_subject(subject)
        return list(self._sentences[subject])

    def template(self, subject: str) -> np.ndarray:
        raise NotImplementedError

    def frames(self, subject: str, sentence: str, dtype=np.float64) -> np.ndarray:
        """Mesh sequence ``(T, V, 3)`` at 60 fps in ``dtype`` (None: the precision it is stored in)."""
        raise NotImplementedError

    def audio(self, subject: str, sentence: str) -> tuple[np.ndarray, int]:
        raise NotImplementedError

    def _wav_audio(self, subject: str, sentence: str, path: Path) -> tuple[np.ndarray, int]:
        """The WAV file ``path`` of one sentence as :meth:`audio` returns it; a missing, truncated,
        unreadable or empty file is recorded and raised as that sentence's problem."""
        if not path.is_file():
            self._fail("missing_audio", subject, sentence, f"{path} not found")
        why = wav_truncation(path)
        if why is not None:
            self._fail("truncated", subject, sentence, f"{path}: {why}")
        try:
            samples, rate = read_wav(path)
        except (ValueError, OSError) as error:
            self._fail("unreadable", subject, sentence, str(error))
        if samples.size == 0:
            self._fail("empty_audio", subject, sentence, f"{path}: no samples")
        return to_mono(samples).astype(np.float32), rate

    @property
    def faces(self) -> np.ndarray:
        raise NotImplementedError

    def landmarks(self) -> np.ndarray:
        """The 68 iBUG landmark vertices of the corpus's topology (FLAME's: the asset ``flame-landmarks``)."""
        return load_index_list("flame-landmarks")

    def head_index(self) -> np.ndarray:
        """The vertices the rig transfer and the fit use (FLAME's head crop: the asset ``flame-head-idx``)."""
        return load_index_list("flame-head-idx")

    @property
    def splits(self) -> dict[str, list[str]]:
        """``{"train", "val", "test"}`` speaker lists: the synthetic sidecar's, else VOCASET's 8/2/2."""
        if self._sidecar is not None and "splits" in self._sidecar:
            # read_sidecar checked the shape: {split name: [speaker, ...]}
            splits = {k: list(v) for k, v in self._sidecar["splits"].items()}
            absent = sorted({s for names in splits.values() for s in names} - set(self.subjects))
            if absent:
                # a split naming a speaker the corpus lacks would be written into the dataset's splits.json
                raise DataError(f"{self.root / SIDECAR}: the splits name speaker(s) {absent} that the corpus does "
                                f"not have (it has {self.subjects}); restore them or regenerate the corpus")
            return splits
        return corpus_splits(self.subjects)

    @property
    def synthetic(self) -> dict | None:
        """The synthetic corpus sidecar (seed, lags, durations), None for real data."""
        return self._sidecar

    def items(self) -> list[tuple[str, str]]:
        """All ``(subject, sentence)`` pairs that have motion."""
        return [(s, q) for s in self.subjects for q in self.sentences(s)]

    def _check_subject(self, subject: str) -> None:
        if subject not in self.subjects:
            raise KeyError(f"{self.root}: unknown subject {subject!r}; expected one of {self.subjects}")

    def _check_frames(self, subject: str, sentence: str, frames: np.ndarray, where: str) -> np.ndarray:
        if frames.ndim != 3 or frames.shape[1:] != (self.num_vertices, 3):
            self._fail("vertex_count", subject, sentence,
                       f"{where}: frames have shape {frames.shape}, expected (T, {self.num_vertices}, 3)")
        bad = first_bad_frame(frames)
        if bad is not None:
            self._fail("nan", subject, sentence, f"{where}: NaN or infinite coordinates", frame=bad)
        return frames

    def __repr__(self) -> str:
        return f"{type(self).__name__}({str(self.root)!r}, subjects={len(self.subjects)})"
