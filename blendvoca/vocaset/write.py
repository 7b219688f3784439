"""Writers of the two VOCASET layouts (used by the synthetic corpus and for conversion)."""

from __future__ import annotations

import errno
import os
import pickle
from pathlib import Path

import numpy as np

from blendvoca.errors import UserError
from blendvoca.io.audio import write_wav
from blendvoca.io.mesh import ply_face_block, ply_header, write_ply
from blendvoca.runtime.progress import bar
from blendvoca.vocaset.errors import VocasetError
from blendvoca.vocaset.processed import POSED_FILE
from blendvoca.vocaset.splits import NUM_VERTICES


def _check_sentence(subject: str, sentence: str, frames: np.ndarray, num_vertices: int) -> np.ndarray:
    frames = np.asarray(frames)
    if frames.ndim != 3 or frames.shape[1:] != (num_vertices, 3) or len(frames) == 0:
        raise UserError(f"{subject}/{sentence}: frames must be (T>0, {num_vertices}, 3), got shape {frames.shape}")
    return frames


def quantize_pcm16(samples: np.ndarray) -> np.ndarray:
    """Mono float audio in [-1, 1] as ``(N,) int16`` (``round(x * 32768)``, clipped)."""
    samples = np.asarray(samples, dtype=np.float64)
    if samples.ndim != 1:
        raise ValueError(f"quantize_pcm16: expected mono (N,) samples, got shape {samples.shape}")
    return np.clip(np.round(samples * 32768.0), -32768, 32767).astype(np.int16)


class OfficialWriter:
    """Write ``templates/``, ``unposedcleaneddata/`` and ``audio/`` like the VOCASET download.

    Parameters
    ----------
    root : path
    frame_faces : bool
        Store the triangles in every frame PLY (as the real data does) or write
        vertex-only frames (a third of the size; the readers handle both).
    """

    layout = "official"

    def __init__(self, root, *, frame_faces: bool = False, num_vertices: int = NUM_VERTICES):
        self.root = Path(root)
        self.frame_faces = frame_faces
        self.num_vertices = num_vertices
        self._faces = None

    def add_template(self, subject: str, vertices: np.ndarray, faces: np.ndarray) -> None:
        self._faces = np.asarray(faces, dtype=np.int64)
        write_ply(self.root / "templates" / f"{subject}.ply", vertices, self._faces)

    def add_sentence(self, subject: str, sentence: str, frames: np.ndarray, audio: np.ndarray, rate: int) -> None:
        """Frames ``(T, V, 3)`` as ``sentenceNN.%06d.ply`` (1-based) and audio as 16-bit WAV."""
        self._write_frames("unposedcleaneddata", subject, sentence, frames)
        write_wav(self.root / "audio" / subject / f"{sentence}.wav",
                  quantize_pcm16(audio).astype(np.float32) / 32768.0, rate)

    def add_posed_sentence(self, subject: str, sentence: str, frames: np.ndarray) -> None:
        """Frames ``(T, V, 3)`` with head pose under ``registereddata/`` (VOCASET's posed data)."""
        self._write_frames("registereddata", subject, sentence, frames)

    def _write_frames(self, kind: str, subject: str, sentence: str, frames: np.ndarray) -> None:
        frames = _check_sentence(subject, sentence, frames, self.num_vertices)
        folder = self.root / kind / subject / sentence
        folder.mkdir(parents=True, exist_ok=True)
        faces = self._faces if self.frame_faces else None
        # Thousands of small files: write them directly (same bytes as write_ply)
        # without write_ply's per-file fsync; corpus-level atomicity comes from
        # generating into a temporary folder.
        header = ply_header(frames.shape[1], None if faces is None else len(faces))
        face_block = b"" if faces is None else ply_face_block(faces)
        for t, V in enumerate(frames, start=1):
            with open(folder / f"{sentence}.{t:06d}.ply", "wb") as f:
                f.write(header + np.asarray(V, dtype="<f4").tobytes() + face_block)

    def finish(self) -> Path:
        return self.root


def reserved_npy(path: Path, dtype, shape: tuple) -> np.memmap:
    """A new ``.npy`` file of ``shape`` mapped for writing (``open_memmap(mode="w+")``), its
    blocks reserved on the disk first.

    ``open_memmap`` makes a sparse file; filling its pages through the map on a disk that
    runs out of space ends the process with SIGBUS, with no error to report. Reserving the
    blocks (``posix_fallocate``) turns that into an ``OSError`` (ENOSPC, naming the file) here,
    before anything is written; the new file is removed. File systems that cannot reserve
    blocks (EINVAL, EOPNOTSUPP) keep the sparse file.
    """
    rows = np.lib.format.open_memmap(path, mode="w+", dtype=dtype, shape=shape)
    try:
        with open(path, "r+b") as f:
            os.posix_fallocate(f.fileno(), 0, os.fstat(f.fileno()).st_size)
    except OSError as error:
        if error.errno in (errno.EINVAL, errno.EOPNOTSUPP):
            return rows
        del rows
        Path(path).unlink(missing_ok=True)
        raise OSError(error.errno, error.strerror, str(path)) from None
    return rows


class ProcessedWriter:
    """Write ``data_verts.npy`` and the three pickles of the processed layout.

    ``data_verts.npy`` is pre-allocated for ``total_frames`` (its blocks reserved on the disk,
    :func:`reserved_npy`) and filled in place, so a VOCASET-size corpus is written without
    holding it in memory, and a disk too small for it is an error before the first frame.

    Parameters
    ----------
    root : path
    total_frames : int
        Number of frames of all sentences together.
    dtype : numpy dtype
        Storage type of the vertices (float32, as VOCA's file).
    """

    layout = "processed"

    def __init__(self, root, total_frames: int, *, num_vertices: int = NUM_VERTICES, dtype=np.float32):
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self.num_vertices = num_vertices
        self._verts = reserved_npy(self.root / "data_verts.npy", dtype, (int(total_frames), num_vertices, 3))
        self._posed = None
        self._cursor = 0
        self._index: dict = {}
        self._audio: dict = {}
        self._templates: dict = {}

    def add_template(self, subject: str, vertices: np.ndarray, faces: np.ndarray | None = None) -> None:
        # Stored as float64 of the float32-rounded values, like a template read from PLY.
        self._templates[subject] = np.asarray(vertices, dtype=np.float32).astype(np.float64)

    def add_sentence(self, subject: str, sentence: str, frames: np.ndarray, audio: np.ndarray, rate: int) -> None:
        frames = _check_sentence(subject, sentence, frames, self.num_vertices)
        T = len(frames)
        if self._cursor + T > len(self._verts):
            raise ValueError(f"{subject}/{sentence}: {T} more frames exceed the {len(self._verts)} allocated")
        self._verts[self._cursor:self._cursor + T] = frames
        self._index.setdefault(subject, {})[sentence] = {t: self._cursor + t for t in range(T)}
        self._audio.setdefault(subject, {})[sentence] = {"audio": quantize_pcm16(audio), "sample_rate": int(rate)}
        self._cursor += T

    def add_posed_sentence(self, subject: str, sentence: str, frames: np.ndarray) -> None:
        """Frames ``(T, V, 3)`` with head pose in ``data_verts_posed.npy``, in the rows of the sentence's
        (unposed) frames: added after :meth:`add_sentence`."""
        frames = _check_sentence(subject, sentence, frames, self.num_vertices)
        if self._posed is None:
            self._posed = reserved_npy(self.root / POSED_FILE, self._verts.dtype, self._verts.shape)
        first = self._index[subject][sentence][0]
        self._posed[first:first + len(frames)] = frames

    def finish(self) -> Path:
        if self._cursor != len(self._verts):
            raise ValueError(f"{self.root}: {self._cursor} frames written, {len(self._verts)} allocated")
        for rows in (self._verts, self._posed):
            if rows is not None:
                rows.flush()
        del self._verts, self._posed
        for name, obj in (("subj_seq_to_idx.pkl", self._index), ("raw_audio_fixed.pkl", self._audio),
                          ("templates.pkl", self._templates)):
            with open(self.root / name, "wb") as f:
                pickle.dump(obj, f, protocol=2)  # protocol 2: readable by VOCA's Python 2 tools too
        return self.root


def convert_corpus(corpus, out, *, layout: str = "processed") -> Path:
    """Write an opened corpus (any layout) to ``out`` in ``layout``; bad items are skipped.

    Parameters
    ----------
    corpus : VocasetCorpus
    out : path
    layout : {"processed", "official"}

    Returns
    -------
    Path
        ``out``. Skipped items are in ``corpus.problems``.
    """
    good = []
    for subject, sentence in corpus.items():
        try:
            frames = corpus.frames(subject, sentence)
            audio = corpus.audio(subject, sentence)
        except VocasetError:
            continue
        good.append((subject, sentence, len(frames)))
    if layout == "processed":
        writer = ProcessedWriter(out, sum(n for *_, n in good), num_vertices=corpus.num_vertices)
    elif layout == "official":
        writer = OfficialWriter(out, num_vertices=corpus.num_vertices)
    else:
        raise UserError(f"convert_corpus: layout must be 'processed' or 'official', got {layout!r}")
    for subject in corpus.subjects:
        try:
            writer.add_template(subject, corpus.template(subject), corpus.faces)
        except VocasetError:
            continue
    for subject, sentence, _ in bar(good, desc=f"write {layout}"):
        samples, rate = corpus.audio(subject, sentence)
        writer.add_sentence(subject, sentence, corpus.frames(subject, sentence), samples, rate)
    return writer.finish()
