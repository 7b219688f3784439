"""The processed VOCASET layout that VOCA and FaceFormer use.

::

    data_verts.npy        (N, 5023, 3) every frame of every sentence, 60 fps (memory-mapped)
    subj_seq_to_idx.pkl   {subject: {"sentenceNN": {frame (0-based int): row of data_verts}}}
    raw_audio_fixed.pkl   {subject: {"sentenceNN": {"audio": (n,) int16 or float, "sample_rate": int}}}
    templates.pkl         {subject: (5023, 3)}

VOCA's pickles were written by Python 2, so they are read with
``encoding="latin1"``, by a restricted unpickler (:func:`load_data_pickle`)
that builds only what these files hold (dicts, lists, numbers, strings, numpy
arrays and scalars): a pickle naming any other class or function is refused
with :class:`UnsafePickleError` instead of running its code. Integer sentence keys (some re-exports use them) are read
as ``sentenceNN``. A truncated ``data_verts.npy`` is mapped as far as it goes:
frames beyond the end are reported, the others still read.
"""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError
from blendvoca.io.mesh import read_ply
from blendvoca.vocaset.base import VocasetCorpus
from blendvoca.vocaset.checks import frame_gaps
from blendvoca.vocaset.errors import Problem, VocasetError, check_safe_name

FILES = ("data_verts.npy", "subj_seq_to_idx.pkl", "raw_audio_fixed.pkl", "templates.pkl")


def sentence_name(key) -> str:
    """``"sentence07"`` for ``7``, ``"7"`` or ``"sentence07"``."""
    if isinstance(key, (int, np.integer)) or (isinstance(key, str) and key.isdigit()):
        return f"sentence{int(key):02d}"
    return str(key)


def open_rows(path) -> tuple[np.ndarray, int]:
    """Memory-map a ``.npy`` file as far as its data goes.

    Returns
    -------
    rows : ndarray (memmap)
        The first ``available`` rows, shape ``(available, *shape[1:])``.
    declared : int
        The number of rows the header declares.
    """
    path = Path(path)
    with open(path, "rb") as f:
        try:
            version = np.lib.format.read_magic(f)
            read_header = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                           else np.lib.format.read_array_header_2_0)
            shape, fortran, dtype = read_header(f)
        except ValueError as error:  # numpy's own message for a bad magic string or header
            raise DataError(f"{path}: not a readable .npy file ({error})") from None
        offset = f.tell()
    if fortran:
        raise DataError(f"{path}: Fortran-ordered arrays are not supported; expected C order (N, V, 3)")
    row_shape = tuple(shape[1:])
    row_bytes = int(np.prod(row_shape, dtype=np.int64)) * dtype.itemsize
    available = min(shape[0], (path.stat().st_size - offset) // max(row_bytes, 1))
    if available == 0:
        return np.zeros((0, *row_shape), dtype=dtype), shape[0]
    rows = np.memmap(path, dtype=dtype, mode="r", offset=offset, shape=(available, *row_shape))
    return rows, shape[0]


class UnsafePickleError(DataError):
    """A pickle that is not plain data (names a class or function outside the allowed list) or does not parse."""


#: The only globals a processed-layout pickle may name: numpy's array and scalar
#: reconstruction (numpy 1 and 2 module paths), plain containers and the bytes codec.
_ALLOWED_GLOBALS = {
    ("numpy.core.multiarray", "_reconstruct"), ("numpy._core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "scalar"), ("numpy._core.multiarray", "scalar"),
    ("numpy", "ndarray"), ("numpy", "dtype"),
    ("collections", "OrderedDict"), ("builtins", "set"), ("builtins", "frozenset"), ("builtins", "complex"),
    ("copy_reg", "_reconstructor"), ("copyreg", "_reconstructor"),
    ("builtins", "object"), ("__builtin__", "object"),
    ("_codecs", "encode"),  # how protocol 2 stores bytes (an array's buffer)
}


class _DataUnpickler(pickle.Unpickler):
    def __init__(self, file, where):
        super().__init__(file, encoding="latin1")
        self._where = where

    def find_class(self, module, name):
        if (module, name) not in _ALLOWED_GLOBALS:
            raise UnsafePickleError(
                f"{self._where}: refusing to load {module}.{name}: the processed VOCASET pickles hold only dicts, "
                "lists, numbers, strings and numpy arrays (a pickle naming other classes or functions could run code)"
            )
        if module in ("copy_reg", "copyreg"):
            import copyreg

            return copyreg._reconstructor
        if module in ("builtins", "__builtin__"):
            import builtins

            return getattr(builtins, name)
        return super().find_class(module, name)


def load_data_pickle(path):
    """Load a processed-layout pickle allowing only plain data (see :data:`_ALLOWED_GLOBALS`).

    Raises
    ------
    UnsafePickleError
        The pickle names anything else, or is truncated or corrupted (naming the file).
    """
    path = Path(path)
    with open(path, "rb") as f:
        try:
            obj = _DataUnpickler(f, path).load()
        except UnsafePickleError:
            raise
        except Exception as error:  # truncated / corrupted: EOFError, UnpicklingError, ValueError, ...
            raise UnsafePickleError(f"{path}: not a readable pickle ({type(error).__name__}: {error})") from None
    return obj


def _load_pickle(path: Path, expected=dict):
    obj = load_data_pickle(path)
    if not isinstance(obj, expected):
        raise UnsafePickleError(f"{path}: expected a {expected.__name__} of subject -> ..., got {type(obj).__name__}")
    return obj


def _check_nested(mapping, path: Path) -> None:
    for subject, value in mapping.items():
        check_safe_name(subject, "subject", path)
        if not isinstance(value, dict):
            raise UnsafePickleError(f"{path}: entry of {subject!r} is a {type(value).__name__}, expected a dict "
                                    "of sentence -> ...")
        for key in value:
            check_safe_name(sentence_name(key), "sentence", path)


class ProcessedVocaset(VocasetCorpus):
    """Reader of the processed layout (see module docstring)."""

    layout = "processed"

    def __init__(self, root, **kwargs):
        super().__init__(root, **kwargs)
        missing = [name for name in FILES if not (self.root / name).is_file()]
        if missing:
            raise FileNotFoundError(f"{self.root}: processed VOCASET layout lacks {missing}; expected all of {list(FILES)}")
        verts_path = self.root / "data_verts.npy"
        self._rows, self._declared = open_rows(verts_path)
        if self._rows.ndim == 2 and self._rows.shape[1] == 3 * self.num_vertices:
            self._rows = self._rows.reshape(len(self._rows), self.num_vertices, 3)
        index = _load_pickle(self.root / "subj_seq_to_idx.pkl")
        _check_nested(index, self.root / "subj_seq_to_idx.pkl")
        raw_audio = _load_pickle(self.root / "raw_audio_fixed.pkl")
        _check_nested(raw_audio, self.root / "raw_audio_fixed.pkl")
        self._audio = {s: {sentence_name(k): v for k, v in d.items()} for s, d in raw_audio.items()}
        self._templates = _load_pickle(self.root / "templates.pkl")
        for subject in self._templates:
            check_safe_name(subject, "subject", self.root / "templates.pkl")
        self._index: dict[tuple[str, str], np.ndarray] = {}
        self._sentences: dict[str, list[str]] = {}
        subjects = sorted(set(index) | set(self._audio) | set(self._templates))
        self._subjects = subjects
        for subject in subjects:
            names = []
            for key, frames in sorted((index.get(subject) or {}).items(), key=lambda kv: sentence_name(kv[0])):
                sentence = sentence_name(key)
                if not frames:
                    continue
                if not isinstance(frames, dict) or not all(
                        isinstance(k, (int, np.integer)) and isinstance(v, (int, np.integer)) for k, v in frames.items()):
                    self._record(Problem(subject, sentence, None, "unreadable",
                                         "subj_seq_to_idx.pkl: expected {frame (int): row of data_verts (int)}, got "
                                         f"{type(frames).__name__}"))
                    continue
                numbers = np.array(sorted(frames), dtype=np.int64)
                self._index[subject, sentence] = np.array([frames[n] for n in numbers], dtype=np.int64)
                names.append(sentence)
                gaps = frame_gaps(numbers)
                if gaps or numbers[0] != 0:
                    self._record(Problem(subject, sentence, int(gaps[0]) if gaps else 0, "missing_frame",
                                         f"subj_seq_to_idx.pkl: frame keys {(gaps or list(range(numbers[0])))[:5]} missing"))
            self._sentences[subject] = names
            if subject not in self._templates:
                self._record(Problem(subject, None, None, "missing_template", "templates.pkl has no entry"))
        every = set().union(*self._sentences.values(), *(set(d) for d in self._audio.values())) if subjects else set()
        for subject in subjects:
            have = set(self._sentences[subject])
            audio = set(self._audio.get(subject, {}))
            for sentence in sorted(have - audio):
                self._record(Problem(subject, sentence, None, "missing_audio", "raw_audio_fixed.pkl has no entry"))
            for sentence in sorted(every - have):
                why = "audio present but no frames" if sentence in audio else "present for other subjects"
                self._record(Problem(subject, sentence, None, "missing_sentence",
                                     f"subj_seq_to_idx.pkl has no frames ({why})"))
        if self._declared > len(self._rows):
            # Name the affected sentences now: this is found without reading any frame.
            for (subject, sentence), rows in self._index.items():
                beyond = np.flatnonzero(rows >= len(self._rows))
                if len(beyond):
                    self._record(Problem(subject, sentence, int(beyond[0]), "truncated",
                                         f"{verts_path}: header declares {self._declared} frames, "
                                         f"the file holds {len(self._rows)}"))

    @property
    def subjects(self) -> list[str]:
        return list(self._subjects)

    def sentences(self, subject: str) -> list[str]:
        """Sentences of ``subject`` that have frames, sorted."""
        self._check_subject(subject)
        return list(self._sentences[subject])

    def frame_rows(self, subject: str, sentence: str) -> np.ndarray:
        """Rows of ``data_verts.npy`` holding the sentence's frames, ``(T,) int64`` in frame order."""
        self._check_subject(subject)
        if (subject, sentence) not in self._index:
            self._fail("missing_sentence", subject, sentence, "subj_seq_to_idx.pkl has no frames")
        return self._index[subject, sentence]

    def num_frames(self, subject: str, sentence: str) -> int:
        return len(self.frame_rows(subject, sentence))

    def template(self, subject: str) -> np.ndarray:
        """Neutral mesh of ``subject``, ``(V, 3) float64``."""
        self._check_subject(subject)
        if subject not in self._templates:
            self._fail("missing_template", subject, None, "templates.pkl has no entry")
        V = np.asarray(self._templates[subject], dtype=np.float64)
        if V.shape != (self.num_vertices, 3):
            self._fail("vertex_count", subject, None, f"templates.pkl: shape {V.shape}, expected ({self.num_vertices}, 3)")
        if not np.isfinite(V).all():
            self._fail("nan", subject, None, "templates.pkl: NaN or infinite coordinates")
        return V

    @property
    def faces(self) -> np.ndarray:
        """FLAME triangles ``(9976, 3) int64`` (the processed layout stores none: asset ``flame-sample``)."""
        if getattr(self, "_faces", None) is None:
            from blendvoca.assets import resolve

            self._faces = read_ply(resolve("flame-sample"))[1]
        return self._faces

    def frames(self, subject: str, sentence: str, dtype=np.float64) -> np.ndarray:
        """Mesh sequence ``(T, V, 3)`` at 60 fps in ``dtype`` (None: as stored, float32 in VOCASET; see
        ``VocasetError`` for bad items)."""
        rows = self.frame_rows(subject, sentence)
        for p in self.problems:
            if (p.subject, p.sentence) == (subject, sentence) and p.kind in ("missing_frame", "truncated"):
                raise VocasetError(p)
        if rows.min() < 0:
            self._fail("unreadable", subject, sentence, f"subj_seq_to_idx.pkl: negative row {rows.min()}")
        frames = np.asarray(self._rows[rows], dtype=dtype)
        return self._check_frames(subject, sentence, frames, "data_verts.npy")

    def audio(self, subject: str, sentence: str) -> tuple[np.ndarray, int]:
        """Speech at its native rate: ``(samples (N,) float32 mono, rate)``; int16 is scaled by 1/32768."""
        self._check_subject(subject)
        entry = self._audio.get(subject, {}).get(sentence)
        if entry is None:
            self._fail("missing_audio", subject, sentence, "raw_audio_fixed.pkl has no entry")
        try:
            samples, rate = np.asarray(entry["audio"]), int(entry["sample_rate"])
        except (KeyError, TypeError) as error:
            self._fail("unreadable", subject, sentence, f"raw_audio_fixed.pkl: entry lacks 'audio'/'sample_rate' ({error})")
        if not (np.issubdtype(samples.dtype, np.integer) or np.issubdtype(samples.dtype, np.floating)) \
                or samples.ndim not in (1, 2) or rate <= 0:
            self._fail("unreadable", subject, sentence, f"raw_audio_fixed.pkl: expected (N,) or (N, C) numeric samples "
                       f"and a positive sample_rate, got {samples.dtype} {samples.shape} at {rate} Hz")
        if samples.size == 0:
            self._fail("empty_audio", subject, sentence, "raw_audio_fixed.pkl: the entry holds no samples")
        if np.issubdtype(samples.dtype, np.integer):
            samples = samples.astype(np.float32) / float(np.iinfo(samples.dtype).max + 1)
        if samples.ndim == 2:
            samples = samples.mean(axis=1)
        return samples.astype(np.float32), rate
