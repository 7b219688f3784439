"""Read a BlendVOCA build (or a plain SAiD-layout folder) as a benchmark dataset.

Layout (docs/architecture.md)::

    blendshape_coeffs/<subject>/sentenceNN.csv       ground truth, 60 fps
    blendshape_coeffs/<subject>/sentenceNN-<k>.csv   optional extra samples
    audio/<subject>/sentenceNN.wav
    rigs/<subject>.npz                               blendvoca.rig.Rig (optional)
    blendshapes_head/<subject>/<name>.obj            SAiD layout rig (fallback)
    templates_head/<subject>.obj
    splits.json                                      {"train": [...], "val": [...], "test": [...]}
    manifest.json

Without ``splits.json`` the standard VOCASET split is used; without ``rigs/`` the
rig is built from the SAiD-layout OBJ files.

Vertex-trained methods read the source mesh sequences through
:meth:`BlendVOCADataset.vertices` and :meth:`BlendVOCADataset.template`: they come
from the VOCASET corpus the build recorded in ``manifest.json`` (``inputs.vocaset.path``),
or from the corpus passed as ``open_blendvoca(root, vocaset=DIR)`` or named by
``$BLENDVOCA_VOCASET``.
"""

from __future__ import annotations

import functools
import hashlib
import json
import re
from os import PathLike
from pathlib import Path

import numpy as np

_SENTENCE = re.compile(r"^(sentence\d+)\.csv$")
_SAMPLE = re.compile(r"^(sentence\d+)-(\d+)\.csv$")


class BlendVOCADataset:
    """A BlendVOCA dataset folder. Create it with :func:`open_blendvoca`.

    Attributes
    ----------
    root : Path
    names : tuple of str
        Coefficient column order (BlendVOCA's 32 names).
    subjects : list of str
    manifest_hash : str
        sha256 of the data files listed in ``manifest.json`` with their sha256
        (the build report excluded), or, with no manifest, of the sorted file listing.
    """

    def __init__(self, root: Path, vocaset=None):
        from blendvoca.names import BLENDVOCA_NAMES

        self.root = root
        self._vocaset = None if vocaset is None else Path(vocaset).expanduser()
        self.names = tuple(BLENDVOCA_NAMES)
        coeff_dir = root / "blendshape_coeffs"
        if not coeff_dir.is_dir():
            raise ValueError(f"open_blendvoca: {root} has no blendshape_coeffs/ folder; not a BlendVOCA dataset")
        self.subjects = sorted(p.name for p in coeff_dir.iterdir() if p.is_dir())
        if not self.subjects:
            raise ValueError(f"open_blendvoca: {coeff_dir} holds no subject folders")
        self._splits = self._read_splits()
        self.manifest_hash = self._hash_manifest()

    def _read_splits(self) -> dict:
        path = self.root / "splits.json"
        if path.exists():
            splits = json.loads(path.read_text())
            if not isinstance(splits, dict):
                raise ValueError(f"open_blendvoca: {path}: expected an object of split -> subjects")
        else:
            from blendvoca.vocaset import VOCASET_SPLITS

            splits = VOCASET_SPLITS
        return {name: [s for s in subjects if s in self.subjects] for name, subjects in splits.items()}

    def _hash_manifest(self) -> str:
        path = self.root / "manifest.json"
        digest = hashlib.sha256()
        if path.exists():
            # The data's identity is its data files: the build report, tool version
            # and parameters do not change what a method is scored on, so results
            # of builds that differ only in those land in one leaderboard table.
            manifest = json.loads(path.read_text())
            if isinstance(manifest, dict) and isinstance(manifest.get("files"), dict):
                for name, sha in sorted(manifest["files"].items()):
                    if not name.startswith("report/"):
                        digest.update(f"{name}\t{sha}\n".encode())
            else:  # not written by blendvoca.build: the whole file is its identity
                digest.update(path.read_bytes())
        else:
            for p in sorted(self.root.rglob("*")):
                if p.is_file():
                    digest.update(f"{p.relative_to(self.root).as_posix()}\t{p.stat().st_size}\n".encode())
        return digest.hexdigest()

    @property
    def splits(self) -> dict:
        """Split name -> list of subjects present in this folder."""
        return {k: list(v) for k, v in self._splits.items()}

    def split(self, name: str) -> list:
        """Subjects of a split (``"train"``, ``"val"``, ``"test"``)."""
        if name not in self._splits:
            raise ValueError(f"BlendVOCADataset.split: unknown split {name!r}; expected one of {sorted(self._splits)}")
        return list(self._splits[name])

    def _subject_dir(self, subject: str) -> Path:
        if subject not in self.subjects:
            raise ValueError(f"BlendVOCADataset: unknown subject {subject!r} in {self.root}")
        return self.root / "blendshape_coeffs" / subject

    def sentences(self, subject: str) -> list:
        """Sentence names (``sentenceNN``) with a ground-truth track, sorted."""
        d = self._subject_dir(subject)
        return sorted(m.group(1) for p in d.iterdir() if (m := _SENTENCE.match(p.name)))

    def coeffs(self, subject: str, sentence: str) -> np.ndarray:
        """Ground-truth track, (T, 32) float64 in ``names`` order, 60 fps."""
        from blendvoca.io.coeffs import read_coeffs_csv

        path = self._subject_dir(subject) / f"{sentence}.csv"
        if not path.exists():
            raise ValueError(f"BlendVOCADataset.coeffs: no track {path}")
        coeffs, _ = read_coeffs_csv(path, names=self.names)
        return np.asarray(coeffs, dtype=np.float64)

    def samples(self, subject: str, sentence: str) -> np.ndarray:
        """All stored tracks of a sentence: ``sentenceNN-<k>.csv`` in k order, or the
        single ``sentenceNN.csv``; (S, T, 32) (tracks truncated to the shortest)."""
        from blendvoca.io.coeffs import read_coeffs_csv

        d = self._subject_dir(subject)
        found = sorted(
            (int(m.group(2)), p) for p in d.iterdir() if (m := _SAMPLE.match(p.name)) and m.group(1) == sentence
        )
        if not found:
            return self.coeffs(subject, sentence)[None]
        tracks = [np.asarray(read_coeffs_csv(p, names=self.names)[0], dtype=np.float64) for _, p in found]
        t = min(len(x) for x in tracks)
        return np.stack([x[:t] for x in tracks])

    def audio(self, subject: str, sentence: str) -> tuple[np.ndarray, int]:
        """Speech of a sentence: ((N,) float32 mono at 16 kHz, 16000)."""
        from blendvoca.io.audio import load_audio

        path = self.root / "audio" / subject / f"{sentence}.wav"
        if not path.exists():
            raise ValueError(f"BlendVOCADataset.audio: no audio {path}")
        return np.asarray(load_audio(path, rate=16000), dtype=np.float32), 16000

    def rig(self, subject: str):
        """The speaker's rig (:class:`blendvoca.rig.Rig`), cached."""
        return self._rig(subject)

    @functools.cache  # noqa: B019 - one dataset object per run
    def _rig(self, subject: str):
        from blendvoca.rig import Rig

        self._subject_dir(subject)
        npz = self.root / "rigs" / f"{subject}.npz"
        if npz.exists():
            return Rig.load(npz)
        return said_layout_rig(self.root, subject, self.names)

    def utterance(self, subject: str, sentence: str, split: str | None = None):
        """The :class:`benchmark.methods.contract.Utterance` of a sentence (what ``generate`` receives)."""
        from benchmark.methods.contract import AUDIO_RATE, Utterance

        if split is None:
            split = next((name for name, subjects in self._splits.items() if subject in subjects), "")
        audio, rate = self.audio(subject, sentence)
        if rate != AUDIO_RATE:
            raise ValueError(f"BlendVOCADataset.utterance {subject}/{sentence}: expected {AUDIO_RATE} Hz audio, got {rate}")
        num_frames = int(self.coeffs(subject, sentence).shape[0])
        return Utterance(subject=subject, sentence=sentence, split=split, audio=audio, num_frames=num_frames)

    def corpus_root(self) -> Path:
        """The VOCASET corpus this build was made from.

        In order: the ``vocaset`` given to :func:`open_blendvoca`, ``$BLENDVOCA_VOCASET``,
        ``inputs.vocaset.path`` in ``manifest.json``.

        Raises
        ------
        FileNotFoundError
            None of them names an existing folder (the message says how to give one).
        """
        import os

        candidates = []
        if self._vocaset is not None:
            candidates.append(("open_blendvoca(vocaset=...)", self._vocaset))
        if os.environ.get("BLENDVOCA_VOCASET"):
            candidates.append(("$BLENDVOCA_VOCASET", Path(os.environ["BLENDVOCA_VOCASET"]).expanduser()))
        manifest = self.root / "manifest.json"
        if manifest.is_file():
            try:
                recorded = json.loads(manifest.read_text()).get("inputs", {}).get("vocaset", {}).get("path")
            except (ValueError, AttributeError):
                recorded = None
            if recorded:
                candidates.append((f"{manifest} inputs.vocaset.path", Path(recorded)))
        for _, path in candidates:
            if path.is_dir():
                return path
        tried = "; ".join(f"{where}: {path} (not a folder)" for where, path in candidates) or "none recorded"
        raise FileNotFoundError(
            f"BlendVOCADataset {self.root}: the source VOCASET corpus is not reachable ({tried}); pass "
            f"open_blendvoca(root, vocaset=DIR), benchmark.run --vocaset DIR or set BLENDVOCA_VOCASET"
        )

    @functools.cached_property
    def corpus(self):
        """The source corpus (:class:`blendvoca.vocaset.VocasetCorpus`), opened on first use."""
        from blendvoca.vocaset import open_vocaset

        return open_vocaset(self.corpus_root())

    def vertices(self, subject: str, sentence: str) -> np.ndarray:
        """Source mesh sequence of a sentence, ``(T, 5023, 3)`` float64 metres at 60 fps.

        ``T`` equals the coefficient track's frame count (the build fits every frame).
        """
        self._subject_dir(subject)
        return self.corpus.frames(subject, sentence)

    def template(self, subject: str) -> np.ndarray:
        """The speaker's neutral mesh on the source topology, ``(5023, 3)`` float64 metres."""
        self._subject_dir(subject)
        return self.corpus.template(subject)

    def faces(self) -> np.ndarray:
        """Triangles of the source topology, ``(F, 3)`` int64."""
        faces = self.corpus.faces
        return np.asarray(faces() if callable(faces) else faces, dtype=np.int64)

    def __repr__(self) -> str:
        return f"BlendVOCADataset({str(self.root)!r}, subjects={len(self.subjects)})"


def said_layout_rig(root, subject: str, names):
    """Rig from ``templates_head/<subject>.obj`` and ``blendshapes_head/<subject>/<name>.obj``."""
    from blendvoca.rig import Rig

    root = Path(root)
    template = root / "templates_head" / f"{subject}.obj"
    shape_dir = root / "blendshapes_head" / subject
    if not template.exists() or not shape_dir.is_dir():
        raise ValueError(
            f"said_layout_rig: subject {subject!r} has neither rigs/{subject}.npz nor "
            f"templates_head/{subject}.obj + blendshapes_head/{subject}/ in {root}"
        )
    return Rig.load_said_folder(shape_dir, names=tuple(names), neutral_path=template)


def open_blendvoca(root: str | PathLike, *, vocaset: str | PathLike | None = None) -> BlendVOCADataset:
    """Open a BlendVOCA build or SAiD-layout folder.

    Parameters
    ----------
    root : path-like
    vocaset : path-like, optional
        The source VOCASET corpus, for :meth:`BlendVOCADataset.vertices` (default:
        ``$BLENDVOCA_VOCASET``, then the corpus recorded in ``manifest.json``).

    Returns
    -------
    BlendVOCADataset
    """
    root = Path(root)
    if not root.is_dir():
        raise ValueError(f"open_blendvoca: {root} is not a directory")
    return BlendVOCADataset(root, vocaset=vocaset)
