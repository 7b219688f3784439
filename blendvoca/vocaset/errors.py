"""Problems found in a VOCASET corpus, and the error raised for a bad item."""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass

from blendvoca.errors import DataError

PROBLEM_KINDS = (
    "missing_sentence",  # a sentence other subjects have, or audio without meshes
    "missing_audio",     # meshes without a WAV / raw audio entry
    "missing_template",  # subject without a template mesh
    "missing_frame",     # a gap in the frame numbering
    "vertex_count",      # a mesh that does not have the expected 5023 vertices
    "nan",               # NaN or infinite coordinates
    "truncated",         # a file shorter than its header says
    "empty_audio",       # a WAV / raw audio entry with no samples
    "unreadable",        # anything else that does not parse
)


@functools.total_ordering
@dataclass(frozen=True)
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

    def _order(self) -> tuple:
        # sentence and frame may be None (a subject-level or whole-item problem): those sort first,
        # instead of comparing None with a str or an int
        return (self.subject, self.sentence is not None, self.sentence or "",
                self.frame is not None, self.frame or 0, self.kind, self.message)

    def __lt__(self, other):
        if not isinstance(other, Problem):
            return NotImplemented
        return self._order() < other._order()

    def __str__(self) -> str:
        where = self.subject
        if self.sentence is not None:
            where += f"/{self.sentence}"
        if self.frame is not None:
            where += f" frame {self.frame}"
        return f"[{self.kind}] {where}: {self.message}"


#: Subject and sentence names that may become file names: letters, digits, ``_``, ``-``
#: and ``.``, not starting with ``.`` (no ``..``, no separators), at most 128 characters.
SAFE_NAME = re.compile(r"^[A-Za-z0-9_-][A-Za-z0-9_.-]{0,127}$")


class UnsafeNameError(DataError):
    """A subject or sentence name that cannot safely become part of a path."""


def check_safe_name(name, what: str, where) -> str:
    """Return ``name`` if it matches :data:`SAFE_NAME`, else raise :class:`UnsafeNameError`.

    Parameters
    ----------
    name : object
        The name read from the corpus (a folder name or a pickle key).
    what : str
        ``"subject"`` or ``"sentence"``.
    where : str or path
        The file or folder it came from (named in the error).
    """
    if not isinstance(name, str) or not SAFE_NAME.match(name):
        raise UnsafeNameError(f"{where}: {what} name {name!r} is not a safe file name; expected letters, digits, "
                              "'_', '-' or '.' (not starting with '.', at most 128 characters)")
    return name


class VocasetError(DataError):
    """A VOCASET item (template, frames or audio) that cannot be read.

    Carries the ``Problem``; ``subject``, ``sentence``, ``frame`` and ``kind`` are
    exposed as attributes.
    """

    def __init__(self, problem: Problem):
        super().__init__(str(problem))
        self.problem = problem
        self.subject, self.sentence, self.frame, self.kind = problem.subject, problem.sentence, problem.frame, problem.kind
