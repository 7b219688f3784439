"""Problems found in a VOCASET corpus, and the error raised for a bad item."""

from __future__ import annotations

from dataclasses import dataclass

PROBLEM_KINDS = (
    "missing_sentence",  # a sentence other subjects have, or audio without meshes
    "missing_audio",     # meshes without a WAV / raw audio entry
    "missing_template",  # subject without a template mesh
    "missing_frame",     # a gap in the frame numbering
    "vertex_count",      # a mesh that does not have the expected 5023 vertices
    "nan",               # NaN or infinite coordinates
    "truncated",         # a file shorter than its header says
    "unreadable",        # anything else that does not parse
)


@dataclass(frozen=True, order=True)
class Problem:
    """One bad item of a corpus.

    Attributes
    ----------
    subject : str
    sentence : str or None
        ``sentenceNN``; None for subject-level problems (template).
    frame : int or None
        0-based index into ``frames(subject, sentence)`` (file ``NNNNNN`` numbering
        is in ``message``), None when the whole item is affected.
    kind : str
        One of ``PROBLEM_KINDS``.
    message : str
        Human-readable detail naming the file.
    """

    subject: str
    sentence: str | None
    frame: int | None
    kind: str
    message: str

    def __str__(self) -> str:
        where = self.subject
        if self.sentence is not None:
            where += f"/{self.sentence}"
        if self.frame is not None:
            where += f" frame {self.frame}"
        return f"[{self.kind}] {where}: {self.message}"


class VocasetError(ValueError):
    """A VOCASET item (template, frames or audio) that cannot be read.

    Carries the ``Problem``; ``subject``, ``sentence``, ``frame`` and ``kind`` are
    exposed as attributes.
    """

    def __init__(self, problem: Problem):
        super().__init__(str(problem))
        self.problem = problem

    @property
    def subject(self) -> str:
        return self.problem.subject

    @property
    def sentence(self) -> str | None:
        return self.problem.sentence

    @property
    def frame(self) -> int | None:
        return self.problem.frame

    @property
    def kind(self) -> str:
        return self.problem.kind
