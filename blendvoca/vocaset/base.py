"""What both VOCASET layouts share: the :class:`VocasetCorpus` interface and its problem log.

The layout readers (:mod:`blendvoca.vocaset.official`, :mod:`blendvoca.vocaset.processed`)
subclass :class:`VocasetCorpus`; :func:`blendvoca.vocaset.corpus.open_vocaset` picks one.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError
from blendvoca.vocaset.checks import first_bad_frame
from blendvoca.vocaset.errors import Problem, VocasetError
from blendvoca.vocaset.splits import FPS, NUM_VERTICES, corpus_splits

__all__ = ["SIDECAR", "VocasetCorpus"]

SIDECAR = "synthetic.json"


class VocasetCorpus:
    """A VOCASET-like corpus: speakers, sentences, templates, 60 fps meshes, audio.

    Subclasses implement the layouts; this class holds what they share: the
    problem log, splits, scanning. Items that cannot be read raise
    ``VocasetError`` naming subject, sentence and frame, and are logged in
    ``problems``; everything else keeps reading.
    """

    layout: str = ""
    fps: int = FPS

    def __init__(self, root, *, num_vertices: int = NUM_VERTICES):
        self.root = Path(os.fspath(root))
        self.num_vertices = int(num_vertices)
        self._problems: dict[tuple, Problem] = {}
        self._sidecar = None
        sidecar = self.root / SIDECAR
        if sidecar.is_file():
            try:
                self._sidecar = json.loads(sidecar.read_text(encoding="utf-8"))
            except (json.JSONDecodeError, UnicodeDecodeError) as error:
                raise DataError(f"{sidecar}: not a readable synthetic-corpus sidecar ({error})") from None

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

    def scan(self, *, progress: bool = False) -> list[Problem]:
        """Read every template, frame sequence and audio clip; return all problems.

        Nothing raises: bad items are collected and the rest is read.
        """
        from tqdm.auto import tqdm

        items = [(s, q) for s in self.subjects for q in self.sentences(s)]
        for subject in self.subjects:
            try:
                self.template(subject)
            except VocasetError:
                pass
        for subject, sentence in tqdm(items, desc="scan VOCASET", disable=not progress):
            for read in (self.frames, self.audio):
                try:
                    read(subject, sentence)
                except VocasetError:
                    pass
        return self.problems

    # -- shared interface --------------------------------------------------
    @property
    def subjects(self) -> list[str]:
        raise NotImplementedError

    def sentences(self, subject: str) -> list[str]:
        raise NotImplementedError

    def template(self, subject: str) -> np.ndarray:
        raise NotImplementedError

    def frames(self, subject: str, sentence: str, dtype=np.float64) -> np.ndarray:
        """Mesh sequence ``(T, V, 3)`` at 60 fps in ``dtype`` (None: the precision it is stored in)."""
        raise NotImplementedError

    def audio(self, subject: str, sentence: str) -> tuple[np.ndarray, int]:
        raise NotImplementedError

    @property
    def faces(self) -> np.ndarray:
        raise NotImplementedError

    @property
    def splits(self) -> dict[str, list[str]]:
        """``{"train", "val", "test"}`` speaker lists: the synthetic sidecar's, else VOCASET's 8/2/2."""
        if self._sidecar is not None and "splits" in self._sidecar:
            return {k: list(v) for k, v in self._sidecar["splits"].items()}
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
