"""The processed VOCASET layout that VOCA and FaceFormer use.

::

    data_verts.npy        (N, 5023, 3) every frame of every sentence, 60 fps (memory-mapped)
    subj_seq_to_idx.pkl   {subject: {"sentenceNN": {frame (0-based int): row of data_verts}}}
    raw_audio_fixed.pkl   {subject: {"sentenceNN": {"audio": (n,) int16 or float, "sample_rate": int}}}
    templates.pkl         {subject: (5023, 3)}
    data_verts_posed.npy  (optional) the same frames with head pose, in data_verts.npy's row order

VOCA's pickles were written by Python 2, so they are read with
``encoding="latin1"``, by a restricted unpickler (:func:`load_data_pickle`)
that builds only what these files hold (dicts, lists, numbers, strings, numpy
arrays and scalars): a pickle naming any other class or function is refused
with :class:`UnsafePickleError` instead of running its code. Integer sentence keys (some re-exports use them) are read
as ``sentenceNN``. A truncated ``data_verts.npy`` is mapped as far as it goes:
frames beyond the end are reported, the others still read.

What would fail every sentence alike (``data_verts.npy`` whose header does not
parse, of another dtype than plain numbers, or not ``(N, V, 3)`` / ``(N, 3V)``; a
pickle that is not a dict of subject -> dict) is a :class:`~blendvoca.errors.DataError`
at open time naming the file. What affects one item (an index entry naming a row
the file does not declare, a template or audio entry that is not numbers) is a
``VocasetError`` of that item, and the rest reads. Only the header of
``data_verts.npy`` and the index are checked at open time: the frames themselves
are read when asked for.
"""

from __future__ import annotations

import functools
import math
import tokenize
from pathlib import Path

import numpy as np

from blendvoca.assets import resolve
from blendvoca.errors import DataError
from blendvoca.io.mesh import read_ply
from blendvoca.io.pickle_file import UnsafePickleError, load_data_pickle
from blendvoca.vocaset.base import VocasetCorpus
from blendvoca.vocaset.checks import frame_gaps
from blendvoca.vocaset.errors import Problem, VocasetError, check_safe_name

FILES = ("data_verts.npy", "subj_seq_to_idx.pkl", "raw_audio_fixed.pkl", "templates.pkl")
#: Optional: the frames with head pose, row for row as ``data_verts.npy`` (the synthetic
#: corpus writes it with ``--head-motion``; VOCASET's own processed files have none).
POSED_FILE = "data_verts_posed.npy"


def sentence_name(key) -> str:
    """``"sentence07"`` for ``7``, ``"7"`` or ``"sentence07"``."""
    if isinstance(key, (int, np.integer)) or (isinstance(key, str) and key.isdigit()):
        return f"sentence{int(key):02d}"
    return str(key)


def open_rows(path, num_vertices: int | None = None) -> tuple[np.ndarray, int]:
    """Memory-map a ``.npy`` file as far as its data goes.

    Returns
    -------
    rows : ndarray (memmap)
        The first ``available`` rows, shape ``(available, *shape[1:])``; rows of
        ``3 * num_vertices`` numbers as ``(num_vertices, 3)`` vertices, when it is given.
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
        # ValueError: numpy's own message for a bad magic string or header; the header is a Python
        # literal that numpy tokenizes and parses, so a cut or garbled one raises the tokenizer's
        # and parser's errors too (TokenError, SyntaxError, RecursionError, MemoryError)
        except (ValueError, SyntaxError, tokenize.TokenError, RecursionError, MemoryError) as error:
            raise DataError(f"{path}: not a readable .npy file ({type(error).__name__}: {error})") from None
        offset = f.tell()
    if dtype.hasobject or dtype.kind not in "fiu":
        # an object array holds pointers (mapping its bytes would dereference whatever the file says)
        # and a pickle; only plain numbers are read
        raise DataError(f"{path}: holds an array of dtype {dtype} (e.g. one saved from Python objects); expected "
                        "plain floating-point vertices (N, V, 3), float32 as VOCASET ships them")
    if fortran:
        raise DataError(f"{path}: Fortran-ordered arrays are not supported; expected C order (N, V, 3)")
    if len(shape) == 0:
        raise DataError(f"{path}: holds a single number (shape ()); expected vertices (N, V, 3)")
    if min(shape) < 0:
        raise DataError(f"{path}: the header declares shape {shape}, with a negative dimension")
    row_shape = tuple(shape[1:])
    # Python integers: a hostile header's dimensions must not overflow int64 into a small size
    row_bytes = math.prod(row_shape) * dtype.itemsize
    available = min(shape[0], (path.stat().st_size - offset) // max(row_bytes, 1))
    try:
        if available == 0 or row_bytes == 0:  # nothing to map (np.memmap refuses an empty mapping)
            rows = np.zeros((0, *row_shape), dtype=dtype)
        else:
            rows = np.memmap(path, dtype=dtype, mode="r", offset=offset, shape=(available, *row_shape))
    except (ValueError, OverflowError) as error:  # a row larger than numpy can address
        raise DataError(f"{path}: the header declares shape {shape}, which numpy cannot map ({error})") from None
    if num_vertices is not None and row_shape == (3 * num_vertices,):
        rows = rows.reshape(len(rows), num_vertices, 3)
    return rows, shape[0]


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
        seen = {}
        for key in value:
            name = check_safe_name(sentence_name(key), "sentence", path)
            if name in seen:
                # 7, "7" and "sentence07" are one sentence: two of them would read it twice, from either entry
                raise DataError(f"{path}: keys {seen[name]!r} and {key!r} of {subject!r} both name {name}")
            seen[name] = key


def _index_rows(frames: dict, declared: int):
    """One sentence's index entry as ``(frame numbers, rows, problem)``.

    ``frames`` is ``{frame key (int): row of data_verts.npy (int)}`` and ``declared``
    the rows that file's header declares. ``numbers`` and ``rows`` are ``(T,) int64``
    in frame order; ``problem`` is None, or ``(position, message)`` for a key that is
    negative or too large to number a frame, or a row outside the file.
    """
    keys = sorted(frames)
    try:
        numbers = np.array(keys, dtype=np.int64)
        rows = np.array([frames[k] for k in keys], dtype=np.int64)
    except OverflowError:  # beyond int64: beyond any file; found one by one (the rare path)
        numbers = rows = None
    # 2 ** 62 keeps the differences of frame keys within int64
    if numbers is None or numbers[0] < 0 or numbers[-1] >= 2 ** 62:
        for at, key in enumerate(keys):
            if not 0 <= key < 2 ** 62:
                return None, None, (at, f"frame key {key} is outside 0 to {2 ** 62 - 1}")
    outside = np.flatnonzero((rows < 0) | (rows >= declared)) if rows is not None else None
    if outside is None or len(outside):
        at = int(outside[0]) if outside is not None else next(
            i for i, key in enumerate(keys) if not 0 <= frames[key] < declared)
        return None, None, (at, f"frame {keys[at]} is row {frames[keys[at]]} of data_verts.npy, "
                                f"which has {declared} rows")
    return numbers, rows, None


def _all_ints(frames: dict) -> bool:
    """Whether every key and value of ``frames`` is an integer (by their few distinct types: fast)."""
    types = set(map(type, frames)) | set(map(type, frames.values()))
    return all(issubclass(t, (int, np.integer)) and not issubclass(t, bool) for t in types)


def _is_int(value) -> bool:
    """An integer of the pickle (Python or numpy; not a bool)."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def _entry_kind(value) -> str:
    """A pickled value's type for a message: ``a str 'x'``, ``a float``, ``an ndarray of shape (3,)``."""
    if isinstance(value, np.ndarray):
        return f"an ndarray of shape {value.shape}"
    if isinstance(value, (str, bytes)):
        return f"a {type(value).__name__} {value[:20]!r}"
    if isinstance(value, (int, float, np.number)):
        return f"a {type(value).__name__} {value!r}"
    return f"a {type(value).__name__}"


class ProcessedVocaset(VocasetCorpus):
    """Reader of the processed layout (see module docstring)."""

    layout = "processed"

    def __init__(self, root, **kwargs):
        super().__init__(root, **kwargs)
        missing = [name for name in FILES if not (self.root / name).is_file()]
        if missing:
            raise FileNotFoundError(f"{self.root}: processed VOCASET layout lacks {missing}; expected all of {list(FILES)}")
        verts_path = self.root / "data_verts.npy"
        self._rows, self._declared = open_rows(verts_path, self.num_vertices)
        if self._rows.shape[1:] != (self.num_vertices, 3):
            # one array holds every frame: a wrong row shape would fail every sentence alike
            raise DataError(f"{verts_path}: holds an array of shape {(self._declared, *self._rows.shape[1:])}; "
                            f"expected vertices (N, {self.num_vertices}, 3) or (N, {3 * self.num_vertices})")
        index = _load_pickle(self.root / "subj_seq_to_idx.pkl")
        _check_nested(index, self.root / "subj_seq_to_idx.pkl")
        raw_audio = _load_pickle(self.root / "raw_audio_fixed.pkl")
        _check_nested(raw_audio, self.root / "raw_audio_fixed.pkl")
        self._audio = {s: {sentence_name(k): v for k, v in d.items()} for s, d in raw_audio.items()}
        self._templates = _load_pickle(self.root / "templates.pkl")
        for subject in self._templates:
            check_safe_name(subject, "subject", self.root / "templates.pkl")
        self._index: dict[tuple[str, str], np.ndarray] = {}
        #: Sentences whose index names rows that data_verts.npy does not declare: ``frames`` raises these.
        self._bad_rows: dict[tuple[str, str], Problem] = {}
        self._sentences: dict[str, list[str]] = {}
        subjects = sorted(set(index) | set(self._audio) | set(self._templates))
        self._subjects = subjects
        for subject in subjects:
            names = []
            for key, frames in sorted((index.get(subject) or {}).items(), key=lambda kv: sentence_name(kv[0])):
                sentence = sentence_name(key)
                if isinstance(frames, dict) and not frames:
                    continue
                if not isinstance(frames, dict) or not _all_ints(frames):
                    self._record(Problem(subject, sentence, None, "unreadable",
                                         "subj_seq_to_idx.pkl: expected {frame (int): row of data_verts (int)}, got "
                                         f"{_entry_kind(frames)}"))
                    continue
                numbers, rows, why = _index_rows(frames, self._declared)
                names.append(sentence)
                if why is not None:
                    at, message = why
                    self._bad_rows[subject, sentence] = self._record(Problem(
                        subject, sentence, at, "unreadable", f"subj_seq_to_idx.pkl: {message}"))
                    self._index[subject, sentence] = np.zeros(0, dtype=np.int64)  # frame_rows raises the problem
                    continue
                self._index[subject, sentence] = rows
                gaps = frame_gaps(numbers, limit=5)
                if gaps or numbers[0] != 0:
                    missing = gaps or list(range(min(int(numbers[0]), 5)))
                    self._record(Problem(subject, sentence, int(gaps[0]) if gaps else 0, "missing_frame",
                                         f"subj_seq_to_idx.pkl: frame keys {missing} missing"))
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
                if (subject, sentence) in self._bad_rows:
                    continue
                beyond = np.flatnonzero(rows >= len(self._rows))
                if len(beyond):
                    self._record(Problem(subject, sentence, int(beyond[0]), "truncated",
                                         f"{verts_path}: header declares {self._declared} frames, "
                                         f"the file holds {len(self._rows)}"))

    def frame_rows(self, subject: str, sentence: str) -> np.ndarray:
        """Rows of ``data_verts.npy`` holding the sentence's frames, ``(T,) int64`` in frame order."""
        self._check_subject(subject)
        if (subject, sentence) not in self._index:
            self._fail("missing_sentence", subject, sentence, "subj_seq_to_idx.pkl has no frames")
        if (subject, sentence) in self._bad_rows:
            raise VocasetError(self._bad_rows[subject, sentence])
        return self._index[subject, sentence]

    def num_frames(self, subject: str, sentence: str) -> int:
        return len(self.frame_rows(subject, sentence))

    def template(self, subject: str) -> np.ndarray:
        """Neutral mesh of ``subject``, ``(V, 3) float64``."""
        self._check_subject(subject)
        if subject not in self._templates:
            self._fail("missing_template", subject, None, "templates.pkl has no entry")
        try:
            V = np.asarray(self._templates[subject])
        except ValueError as error:  # a ragged nest of lists
            self._fail("unreadable", subject, None, f"templates.pkl: not an array of vertices ({error})")
        if V.dtype.kind not in "fiu":
            self._fail("unreadable", subject, None,
                       f"templates.pkl: the entry is {_entry_kind(self._templates[subject])} (dtype {V.dtype}), "
                       f"expected ({self.num_vertices}, 3) vertex coordinates")
        V = V.astype(np.float64)
        if V.shape != (self.num_vertices, 3):
            self._fail("vertex_count", subject, None, f"templates.pkl: shape {V.shape}, expected ({self.num_vertices}, 3)")
        if not np.isfinite(V).all():
            self._fail("nan", subject, None, "templates.pkl: NaN or infinite coordinates")
        return V

    @functools.cached_property
    def faces(self) -> np.ndarray:
        """FLAME triangles ``(9976, 3) int64`` (the processed layout stores none: asset ``flame-sample``)."""
        return read_ply(resolve("flame-sample"))[1]

    def frames(self, subject: str, sentence: str, dtype=np.float64) -> np.ndarray:
        """Mesh sequence ``(T, V, 3)`` at 60 fps in ``dtype`` (None: as stored, float32 in VOCASET; see
        ``VocasetError`` for bad items)."""
        rows = self.frame_rows(subject, sentence)
        for p in self.problems:
            if (p.subject, p.sentence) == (subject, sentence) and p.kind in ("missing_frame", "truncated"):
                raise VocasetError(p)
        frames = np.asarray(self._rows[rows], dtype=dtype)
        return self._check_frames(subject, sentence, frames, "data_verts.npy")

    def has_posed(self, subject: str, sentence: str) -> bool:
        """Whether ``data_verts_posed.npy`` is present (it then holds every sentence's rows)."""
        self._check_subject(subject)
        return (self.root / POSED_FILE).is_file()

    def posed_frames(self, subject: str, sentence: str) -> np.ndarray:
        """The sentence with head pose, ``(T, V, 3) float64`` from ``data_verts_posed.npy``.

        Raises
        ------
        VocasetError
            No posed file (``missing_sentence``), or the sentence's rows beyond its end
            (``truncated``).
        DataError
            A posed file of another row shape than ``data_verts.npy``.
        """
        rows = self.frame_rows(subject, sentence)
        path = self.root / POSED_FILE
        if not path.is_file():
            self._fail("missing_sentence", subject, sentence, f"{path}: no posed frames (the file is absent)")
        if getattr(self, "_posed_rows", None) is None:
            posed, declared = open_rows(path, self.num_vertices)
            if posed.shape[1:] != (self.num_vertices, 3) or declared != self._declared:
                raise DataError(f"{path}: holds an array of shape {(declared, *posed.shape[1:])}; expected "
                                f"data_verts.npy's ({self._declared}, {self.num_vertices}, 3), row for row")
            self._posed_rows = posed
        beyond = np.flatnonzero(rows >= len(self._posed_rows))
        if len(beyond):
            self._fail("truncated", subject, sentence, f"{path}: holds {len(self._posed_rows)} of the declared rows",
                       frame=int(beyond[0]))
        frames = np.asarray(self._posed_rows[rows], dtype=np.float64)
        return self._check_frames(subject, sentence, frames, POSED_FILE)

    def audio(self, subject: str, sentence: str) -> tuple[np.ndarray, int]:
        """Speech at its native rate: ``(samples (N,) float32 mono, rate)``; int16 is scaled by 1/32768."""
        self._check_subject(subject)
        entry = self._audio.get(subject, {}).get(sentence)
        if entry is None:
            self._fail("missing_audio", subject, sentence, "raw_audio_fixed.pkl has no entry")
        try:
            samples, rate = np.asarray(entry["audio"]), entry["sample_rate"]
        except (KeyError, TypeError, IndexError, ValueError) as error:  # not a dict; lacks a key; ragged samples
            self._fail("unreadable", subject, sentence, f"raw_audio_fixed.pkl: entry lacks 'audio'/'sample_rate' ({error})")
        if not (_is_int(rate) or (isinstance(rate, (float, np.floating)) and np.isfinite(rate) and rate == int(rate))):
            self._fail("unreadable", subject, sentence,
                       f"raw_audio_fixed.pkl: sample_rate is {_entry_kind(rate)}, expected a whole number of Hz")
        rate = int(rate)
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
