"""Stored runs: the on-disk layout of a benchmark run, written by ``benchmark.run``
and read back by ``benchmark.render``, the plots and result browsers.

A run is a result JSON ``R/<run>.json`` (``benchmark.results``) plus, next to it,
the folder its key ``tracks`` names (relative to the JSON's folder, ``<run>``)::

    R/<run>.json
    R/<run>/<subject>/sentenceNN-<k>.csv            sample k (from 0), SAiD's layout, 60 fps
    R/<run>/<subject>/sentenceNN.vertices.npz       vertex methods: "offsets" (S, T, V, 3) float16
                                                    metres from the speaker's template
    R/<run>/<subject>/template.npy                  vertex methods: the template (V, 3) float64

A run over several training seeds (``benchmark.run --seeds 0,1,2``) keeps each seed's
tracks in a subfolder of the same layout, ``R/<run>/seed<k>/`` (:func:`seed_folder_name`);
its JSON's ``tracks`` names the first seed's (``<run>/seed0``), so every reader of
a run folder reads that seed, and ``per_seed[i].tracks`` names each seed's.

The CSVs are the coefficient tracks that were scored (for vertex methods, the
tracks fitted with the speaker's rig). The vertex files store the method's own
vertices compactly; float16 offsets keep 2^-11 relative precision (about 0.01 mm
for the centimetre-scale motion of a face), and the vertex metrics are computed
from exactly these stored values, so a stored run rescores to the same numbers.
The JSON key ``dataset.path`` is the BlendVOCA root the run was scored on.
"""

from __future__ import annotations

import re
import shutil
import zipfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchmark.results import Result, read
from blendvoca.errors import DataError
from blendvoca.io.atomic import atomic_write
from blendvoca.io.coeffs import read_coeffs_csv, write_coeffs_csv
from blendvoca.runtime.staging import move_into_place, process_staging

__all__ = [
    "TRACKS_KEY",
    "MissingTracksError",
    "StoredRun",
    "StoredVertices",
    "TrackWriter",
    "read_run",
    "seed_folder_name",
    "template_path",
    "track_path",
    "tracks_folder_name",
    "vertices_path",
]

#: Result-JSON key holding the tracks folder, relative to the JSON's folder.
TRACKS_KEY = "tracks"
_TRACK = re.compile(r"^(sentence\d+)-(\d+)\.csv$")
_VERTICES_SUFFIX = ".vertices.npz"


class MissingTracksError(DataError, KeyError):
    """A stored run lacks the tracks (or vertices) of a sentence; a ``KeyError`` too, for
    callers that look sentences up."""

    def __str__(self) -> str:  # KeyError would print the message in quotes
        return str(self.args[0]) if self.args else ""


def tracks_folder_name(json_name: str) -> str:
    """Tracks folder of a result file name: ``<run>.json`` -> ``<run>``."""
    name = Path(json_name).name
    return name[:-5] if name.endswith(".json") else name


def seed_folder_name(seed: int) -> str:
    """The subfolder of a run over several training seeds that holds seed ``seed``'s tracks: ``seed<k>``."""
    return f"seed{int(seed)}"


def track_path(folder, subject: str, sentence: str, sample: int) -> Path:
    """``<folder>/<subject>/<sentence>-<sample>.csv``."""
    return Path(folder) / subject / f"{sentence}-{int(sample)}.csv"


def vertices_path(folder, subject: str, sentence: str) -> Path:
    """``<folder>/<subject>/<sentence>.vertices.npz``."""
    return Path(folder) / subject / f"{sentence}{_VERTICES_SUFFIX}"


def template_path(folder, subject: str) -> Path:
    """``<folder>/<subject>/template.npy``."""
    return Path(folder) / subject / "template.npy"


def _read_vertices(folder, subject: str, sentence: str) -> np.ndarray:
    path = vertices_path(folder, subject, sentence)
    if not path.is_file():
        raise MissingTracksError(f"stored run {folder}: no vertices for {subject}/{sentence} (expected {path})")
    template = np.load(template_path(folder, subject))
    with np.load(path) as data:
        offsets = data["offsets"]
    return offsets.astype(np.float64) + template[None, None]


def _write_npz(handle, **arrays) -> None:
    """``np.savez_compressed`` at deflate level 1: the same ``.npz`` format (``np.load``
    reads it), about 6x faster to write than the default level for 10 % more bytes."""
    with zipfile.ZipFile(handle, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1) as archive:
        for name, array in arrays.items():
            with archive.open(f"{name}.npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, np.asanyarray(array), allow_pickle=False)


class StoredVertices(Mapping):
    """``(subject, sentence) -> (S, T, V, 3)`` float64 vertices of a run folder, read on access."""

    def __init__(self, folder):
        self.folder = Path(folder)

    def _keys(self):
        if not self.folder.is_dir():
            return []
        return sorted((p.parent.name, p.name[: -len(_VERTICES_SUFFIX)])
                      for p in self.folder.glob(f"*/*{_VERTICES_SUFFIX}"))

    def __getitem__(self, key):
        subject, sentence = key
        return _read_vertices(self.folder, subject, sentence)

    def __contains__(self, key):
        return isinstance(key, tuple) and len(key) == 2 and vertices_path(self.folder, *key).is_file()

    def __iter__(self):
        return iter(self._keys())

    def __len__(self):
        return len(self._keys())


class TrackWriter:
    """Writes a run's tracks folder; files land in ``.<final>.<host>-<pid>.partial`` until :meth:`commit`.

    Parameters
    ----------
    folder : path-like
        The final tracks folder ``R/<run>``.
    names : sequence of str
        Coefficient column names of the CSVs.
    """

    def __init__(self, folder, names):
        self.folder = Path(folder)
        self.names = tuple(names)
        # one staging folder per process: two runs of the same setting never share files
        self.staging = process_staging(self.folder)
        self._templates = set()

    def write_tracks(self, subject: str, sentence: str, tracks) -> list[Path]:
        """One CSV per sample of ``tracks`` (S, T, K); returns the final paths."""
        tracks = np.asarray(tracks, dtype=np.float64)
        for k, track in enumerate(tracks):
            write_coeffs_csv(track_path(self.staging, subject, sentence, k), track, self.names)
        return [track_path(self.folder, subject, sentence, k) for k in range(len(tracks))]

    def write_vertices(self, subject: str, sentence: str, vertices, template) -> None:
        """The method's own vertices (S, T, V, 3) as float16 offsets from ``template`` (V, 3)."""
        template = np.asarray(template, dtype=np.float64)
        if subject not in self._templates:
            with atomic_write(template_path(self.staging, subject), "wb") as handle:
                np.save(handle, template)
            self._templates.add(subject)
        offsets = (np.asarray(vertices, dtype=np.float64) - template[None, None]).astype(np.float16)
        with atomic_write(vertices_path(self.staging, subject, sentence), "wb") as handle:
            _write_npz(handle, offsets=offsets)

    def stored_vertices(self) -> StoredVertices:
        """The vertices written so far (read from the staging folder)."""
        return StoredVertices(self.staging)

    def for_seed(self, seed: int) -> TrackWriter:
        """A writer of training seed ``seed``'s tracks into the subfolder
        :func:`seed_folder_name` of this run's folder, staged with it: :meth:`commit` (or
        :meth:`discard`) this writer, not the seed's."""
        return _SeedWriter(self, seed_folder_name(seed))

    def commit(self) -> Path:
        """Move the staged folder to its final name (replacing that run's previous tracks)."""
        return move_into_place(self.staging, self.folder, replace=True)

    def discard(self) -> None:
        """Remove the staged files (the run failed)."""
        shutil.rmtree(self.staging, ignore_errors=True)


class _SeedWriter(TrackWriter):
    """One seed's part of a :class:`TrackWriter` (see :meth:`TrackWriter.for_seed`)."""

    def __init__(self, run: TrackWriter, name: str):
        self.folder = run.folder / name
        self.staging = run.staging / name
        self.names = run.names
        self._templates = set()
        self.staging.mkdir(parents=True, exist_ok=True)

    def for_seed(self, seed: int) -> TrackWriter:
        raise RuntimeError("TrackWriter.for_seed: a seed's writer has no seeds of its own")

    def commit(self) -> Path:
        raise RuntimeError("TrackWriter.for_seed: commit the run's writer, which moves every seed's tracks")

    def discard(self) -> None:
        shutil.rmtree(self.staging, ignore_errors=True)


@dataclass
class StoredRun:
    """A run read back by :func:`read_run`.

    Attributes
    ----------
    json_path : Path
    result : benchmark.results.Result
        The result record.
    tracks_dir : Path
        Absolute tracks folder.
    dataset_root : Path
        The BlendVOCA root the run was scored on (``dataset.path``).
    """

    json_path: Path
    result: Result
    tracks_dir: Path
    dataset_root: Path

    @property
    def keys(self) -> list[tuple[str, str]]:
        """``(subject, sentence)`` of every stored track, sorted."""
        found = {(p.parent.name, m.group(1)) for p in self.tracks_dir.glob("*/*.csv") if (m := _TRACK.match(p.name))}
        return sorted(found)

    def track_paths(self, subject: str, sentence: str) -> list[Path]:
        """The CSVs of a sentence, in sample order (``sentenceNN-0.csv`` first)."""
        folder = self.tracks_dir / subject
        found = sorted((int(m.group(2)), p) for p in folder.glob(f"{sentence}-*.csv")
                       if (m := _TRACK.match(p.name)) and m.group(1) == sentence)
        if not found:
            raise MissingTracksError(f"stored run {self.json_path}: no tracks for {subject}/{sentence} in {folder}")
        return [p for _, p in found]

    def tracks(self, subject: str, sentence: str) -> np.ndarray:
        """The stored samples of a sentence, ``(S, T, 32)`` float64.

        Raises
        ------
        MissingTracksError
            The run stored none for this sentence.
        DataError
            A stored CSV does not read (``blendvoca.io.coeffs``: the message names it and the row).
        """
        return np.stack([np.asarray(read_coeffs_csv(p)[0], dtype=np.float64)
                         for p in self.track_paths(subject, sentence)])

    def has_vertices(self) -> bool:
        """True for runs of ``output = "vertices"`` methods."""
        return len(StoredVertices(self.tracks_dir)) > 0

    def vertices(self, subject: str, sentence: str) -> np.ndarray:
        """The method's own vertices of a sentence (vertex methods), ``(S, T, V, 3)`` float64 metres."""
        return _read_vertices(self.tracks_dir, subject, sentence)


def read_run(json_path) -> StoredRun:
    """Read a stored run from its result JSON.

    Raises
    ------
    DataError
        The JSON is not a result file or names no tracks folder (a run written
        before tracks were stored).
    FileNotFoundError
        The tracks folder it names is missing.
    """
    json_path = Path(json_path)
    result = read(json_path)
    rel = result.tracks
    if not rel:
        raise DataError(f"{json_path}: no {TRACKS_KEY!r} key; the run stored no tracks (rerun benchmark.run)")
    tracks_dir = (json_path.parent / rel).resolve()
    if not tracks_dir.is_dir():
        raise FileNotFoundError(f"{json_path}: tracks folder {tracks_dir} (key {TRACKS_KEY!r} = {rel!r}) not found")
    return StoredRun(json_path=json_path, result=result, tracks_dir=tracks_dir,
                     dataset_root=Path(result.dataset.path or ""))
