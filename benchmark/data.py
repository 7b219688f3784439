"""Read a BlendVOCA build (or a plain SAiD-layout folder) as a benchmark dataset.

Layout (:mod:`blendvoca.format`, which this module reads it through)::

    blendshape_coeffs/<subject>/sentenceNN.csv       ground truth, 60 fps
    blendshape_coeffs/<subject>/sentenceNN-<k>.csv   optional extra samples
    oracle_coeffs/<subject>/sentenceNN-<k>.csv       synthetic corpora: fitted oracle samples (optional)
    audio/<subject>/sentenceNN.wav
    rigs/<subject>.npz                               blendvoca.rig.Rig (optional)
    blendshapes_head/<subject>/<name>.obj            SAiD layout rig (fallback)
    templates_head/<subject>.obj
    splits.json                                      {"train": [...], "val": [...], "test": [...]}
    manifest.json

Only the files ``manifest.json`` lists exist for the dataset (outputs of failed or
removed sentences left on disk are not seen); a folder without a manifest is
refused with the command that builds it (a hand-made SAiD-layout folder is listed
once with ``python -m blendvoca.format manifest DIR``). Without ``splits.json`` the
standard VOCASET split is used; without ``rigs/`` the rig is built from the
SAiD-layout OBJ files.

Vertex-trained methods read mesh sequences through :meth:`BlendVOCADataset.vertices`
and :meth:`BlendVOCADataset.template`; :attr:`BlendVOCADataset.vertex_space` says which:

* ``"mesh"`` (a build with source meshes, VOCASET's FLAME topology): the source meshes,
  from the VOCASET corpus the build recorded in ``manifest.json`` (``inputs.vocaset.path``),
  or from the corpus passed as ``open_blendvoca(root, vocaset=DIR)`` or named by
  ``$BLENDVOCA_VOCASET``.
* ``"rig"`` (a build without source meshes to score against, :attr:`~BlendVOCADataset.has_meshes`
  False: the coefficient corpora FACEGOOD, Live Link, BEAT, UniTalker, 3D-ETF, and the vertex
  corpora of other topologies): the speaker's rig (``rigs/<subject>.npz``, the ARKit
  reference rig's 1220 vertices on a coefficient corpus) evaluated at the sentence's
  ground-truth coefficients, and the rig's neutral as the template. This is the reference
  the rig-space metrics score with, and a vertex method's output is fitted back to
  coefficients through the same rig, so on such a build a vertex method trains, generates
  and is scored in rig space (no ``*_mesh`` metrics).
"""

from __future__ import annotations

import functools
import os
from os import PathLike
from pathlib import Path

import numpy as np

from benchmark.methods.contract import AUDIO_RATE, Utterance
from blendvoca import format as fmt
from blendvoca.errors import CheckFailed, DataError, UserError
from blendvoca.names import BLENDVOCA_NAMES
from blendvoca.vocaset import VOCASET_SPLITS, open_vocaset


class BlendVOCADataset:
    """A BlendVOCA dataset folder. Create it with :func:`open_blendvoca`.

    Satisfies :class:`benchmark.methods.Dataset`, what method plug-ins are given.

    Parameters
    ----------
    root : str or os.PathLike
        The folder (a build, or a hand-made SAiD-layout folder listed once).
    vocaset : str or os.PathLike, optional
        The source VOCASET corpus (see :meth:`corpus_root`).

    Attributes
    ----------
    root : Path
    names : tuple of str
        Coefficient column order (BlendVOCA's 32 names).
    subjects : list of str
    recipe_id : str
        The dataset's identity (64 hex digits), the same on every machine that
        builds the same corpus with the same tool and parameters: the recipe id
        its manifest records (:func:`blendvoca.format.dataset_id`; a folder listed
        by an older tool: its content hash). Results record it and are named by it.
    manifest_hash : str
        The content hash: sha256 of the data files listed in ``manifest.json``
        with their sha256 (the build report excluded,
        :func:`blendvoca.format.manifest_hash`); it differs between BLAS kernels,
        and results record it for information.
    dataset_name, dataset_title : str
        The corpus the build was made from (``vocaset``, ``beat``, ... and the name
        tables show): the manifest's ``dataset`` record, VOCASET for a build without one.
    has_meshes : bool
        Whether the build's source meshes can be scored against (the mesh-space
        metrics): False for coefficient corpora (BEAT, UniTalker, 3D-ETF), which have
        none, and for vertex corpora of other topologies than FLAME (BIWI, Multiface:
        the lip and upper-face regions are FLAME's), docs/datasets.md.
    vertex_space : {"mesh", "rig"}
        What :meth:`vertices` and :meth:`template` give a vertex method: ``"mesh"``, the
        source meshes (builds with :attr:`has_meshes`); ``"rig"``, each speaker's rig
        evaluated at the ground-truth coefficients (builds without).
    """

    def __init__(self, root: str | PathLike, vocaset: str | PathLike | None = None):
        root = Path(os.fspath(root))
        self.root = root
        self._vocaset = None if vocaset is None else Path(os.fspath(vocaset)).expanduser()
        self.names = tuple(BLENDVOCA_NAMES)
        self._listed = fmt.listed_files(root)  # the dataset is what manifest.json lists, nothing else
        self._held = {}  # (what, subject, sentence) -> array read by hold(): the verified ground truth
        self.subjects = fmt.listed_subjects(self._listed)
        if not self.subjects:
            raise DataError(f"open_blendvoca: {fmt.manifest_path(root)} lists no "
                            f"{fmt.coeffs_relpath('<subject>', '<sentence>')} in {root / fmt.COEFFS_DIR}; "
                            "not a BlendVOCA dataset")
        self._splits = self._read_splits()
        self.manifest_hash = fmt.manifest_hash(root)
        self.recipe_id = fmt.dataset_id(root)
        try:
            manifest = fmt.read_manifest(root)
        except (DataError, FileNotFoundError):
            manifest = {}
        record = manifest.get("dataset") if isinstance(manifest.get("dataset"), dict) else {}
        reader = (manifest.get("parameters") or {}).get("reader") if isinstance(manifest.get("parameters"), dict) \
            else None
        self.dataset_name = str(record.get("name") or "vocaset")
        self.dataset_title = str(record.get("title") or ("VOCASET" if self.dataset_name == "vocaset"
                                                           else self.dataset_name))
        self.has_meshes = bool(record.get("meshes", True)) and reader is None
        self.vertex_space = "mesh" if self.has_meshes else "rig"
        if reader is not None:  # a vertex corpus read by its own reader (biwi, multiface): name it
            self.dataset_name = reader.rpartition(".")[2].split(":")[0]
            self.dataset_title = self.dataset_name.upper() if self.dataset_name == "biwi" else self.dataset_name.title()

    def _listed_path(self, relpath: str) -> Path | None:
        """The file at ``relpath`` when the manifest lists it and it is on disk, else None."""
        path = self.root / relpath
        return path if relpath in self._listed and path.exists() else None

    def _read_splits(self) -> dict:
        splits = fmt.read_splits(self.root) if fmt.SPLITS_FILE in self._listed else VOCASET_SPLITS
        return {name: [s for s in subjects if s in self.subjects] for name, subjects in splits.items()}

    @property
    def splits(self) -> dict:
        """Split name -> list of subjects present in this folder."""
        return {k: list(v) for k, v in self._splits.items()}

    def split(self, name: str) -> list:
        """Subjects of a split (``"train"``, ``"val"``, ``"test"``)."""
        if name not in self._splits:
            raise UserError(f"BlendVOCADataset.split: unknown split {name!r}; expected one of {sorted(self._splits)}")
        return list(self._splits[name])

    def _check_subject(self, subject: str) -> None:
        if subject not in self.subjects:
            raise UserError(f"BlendVOCADataset: unknown subject {subject!r} in {self.root}")

    def sentences(self, subject: str) -> list:
        """Sentence names (``sentenceNN``) with a ground-truth track, sorted."""
        self._check_subject(subject)
        return fmt.listed_sentences(self._listed, subject)

    def hold(self, subjects) -> int:
        """Read the ground truth of ``subjects`` into memory: their tracks, stored samples,
        oracle samples and audio, and their rigs; from now on :meth:`coeffs`,
        :meth:`samples`, :meth:`oracle_coeffs` and :meth:`audio` answer for them from
        memory (copies), whatever happens to the files (the runner holds the scored split
        before a method runs, then verifies the folder again). Returns the arrays held."""
        for subject in subjects:
            self.rig(subject)
            for sentence in self.sentences(subject):
                self._held[("coeffs", subject, sentence)] = self.coeffs(subject, sentence)
                self._held[("samples", subject, sentence)] = self.samples(subject, sentence)
                self._held[("audio", subject, sentence)] = self.audio(subject, sentence)
                if self.oracle_count(subject, sentence):
                    self._held[("oracle", subject, sentence)] = self.oracle_coeffs(subject, sentence)
        return len(self._held)

    def _from_memory(self, what: str, subject: str, sentence: str):
        held = self._held.get((what, subject, sentence))
        if held is None:
            return None
        if isinstance(held, tuple):  # audio: (samples, rate)
            return held[0].copy(), held[1]
        return held.copy()

    def coeffs(self, subject: str, sentence: str) -> np.ndarray:
        """Ground-truth track, (T, 32) float64 in ``names`` order, 60 fps."""
        held = self._from_memory("coeffs", subject, sentence)
        if held is not None:
            return held
        self._check_subject(subject)
        if self._listed_path(fmt.coeffs_relpath(subject, sentence)) is None:
            raise UserError(f"BlendVOCADataset.coeffs: no track {fmt.coeffs_path(self.root, subject, sentence)} "
                            f"(in {fmt.MANIFEST_FILE} and on disk)")
        coeffs, _ = fmt.read_coeffs(self.root, subject, sentence, names=self.names)
        return np.asarray(coeffs, dtype=np.float64)

    def samples(self, subject: str, sentence: str) -> np.ndarray:
        """All stored tracks of a sentence: ``sentenceNN-<k>.csv`` in k order, or the
        single ``sentenceNN.csv``; (S, T, 32) (tracks truncated to the shortest)."""
        held = self._from_memory("samples", subject, sentence)
        if held is not None:
            return held
        self._check_subject(subject)
        found = fmt.listed_samples(self._listed, subject, sentence)
        if not found:
            return self.coeffs(subject, sentence)[None]
        tracks = [np.asarray(fmt.read_coeffs_file(self.root, rel, names=self.names)[0], dtype=np.float64)
                  for rel in found]
        t = min(len(x) for x in tracks)
        return np.stack([x[:t] for x in tracks])

    def oracle_count(self, subject: str, sentence: str) -> int:
        """K, the fitted oracle samples of a sentence the build lists (0: none)."""
        self._check_subject(subject)
        return len(fmt.listed_oracle_samples(self._listed, subject, sentence))

    def has_oracle(self, subject: str | None = None, sentence: str | None = None) -> bool:
        """Whether the build has fitted oracle samples (of a sentence, of a subject, or at all).

        Oracle samples are conditional draws of a synthetic sentence's motion given its
        audio and speaker (``python -m blendvoca.synthetic --oracle-samples K``), fitted
        by the build like the ground truth: ``oracle_coeffs/<subject>/<sentence>-<k>.csv``.
        """
        if subject is None:
            return any(rel.startswith(f"{fmt.ORACLE_COEFFS_DIR}/") for rel in self._listed)
        if sentence is None:
            self._check_subject(subject)
            return any(rel.startswith(f"{fmt.ORACLE_COEFFS_DIR}/{subject}/") for rel in self._listed)
        return self.oracle_count(subject, sentence) > 0

    def oracle_coeffs(self, subject: str, sentence: str) -> np.ndarray:
        """The fitted oracle samples of a sentence, ``(K, T, 32)`` float64 in ``names`` order, 60 fps.

        Raises
        ------
        UserError
            The build lists none for the sentence (a corpus generated without
            ``--oracle-samples``, or real data).
        DataError
            A listed file is missing or unreadable, or the samples differ in length.
        """
        held = self._from_memory("oracle", subject, sentence)
        if held is not None:
            return held
        self._check_subject(subject)
        found = fmt.listed_oracle_samples(self._listed, subject, sentence)
        if not found:
            raise UserError(f"BlendVOCADataset.oracle_coeffs: {fmt.manifest_path(self.root)} lists no oracle "
                            f"samples {fmt.ORACLE_COEFFS_DIR}/{subject}/{sentence}-<k>.csv; generate the corpus with "
                            "`python -m blendvoca.synthetic --oracle-samples K` and build it")
        tracks = []
        for rel in found:
            if self._listed_path(rel) is None:
                raise DataError(f"{self.root / rel}: listed in {fmt.manifest_path(self.root)} but missing; "
                                "rebuild the dataset")
            tracks.append(np.asarray(fmt.read_coeffs_file(self.root, rel, names=self.names)[0], dtype=np.float64))
        if len({len(t) for t in tracks}) != 1:
            raise DataError(f"{self.root / fmt.ORACLE_COEFFS_DIR / subject}: the oracle samples of {sentence} "
                            f"differ in length ({sorted({len(t) for t in tracks})} frames)")
        return np.stack(tracks)

    def audio(self, subject: str, sentence: str) -> tuple[np.ndarray, int]:
        """Speech of a sentence: ((N,) float32 mono at 16 kHz, 16000)."""
        held = self._from_memory("audio", subject, sentence)
        if held is not None:
            return held
        if self._listed_path(fmt.audio_relpath(subject, sentence)) is None:
            raise UserError(f"BlendVOCADataset.audio: no audio {fmt.audio_path(self.root, subject, sentence)} "
                            f"(in {fmt.MANIFEST_FILE} and on disk)")
        return fmt.read_audio(self.root, subject, sentence)

    @functools.cache  # noqa: B019 - one dataset object per run
    def rig(self, subject: str):
        """The speaker's rig (:class:`blendvoca.rig.Rig`), cached."""
        self._check_subject(subject)
        if self._listed_path(fmt.rig_relpath(subject)) is not None:
            return fmt.read_rig(self.root, subject)
        if fmt.template_relpath(subject) not in self._listed:
            raise DataError(f"said_layout_rig: subject {subject!r} has neither {fmt.rig_relpath(subject)} nor "
                            f"{fmt.template_relpath(subject)} + {fmt.blendshapes_relpath(subject)}/ listed in "
                            f"{fmt.manifest_path(self.root)}")
        return fmt.read_said_rig(self.root, subject, self.names)

    def scored_files(self, subjects) -> list[str]:
        """The files a run that scores ``subjects`` reads of them, as the manifest lists
        them (relative paths, sorted): every coefficient track, fitted oracle sample
        (synthetic corpora) and audio file of those speakers, and their rig
        (``rigs/<subject>.npz``, or the SAiD-layout heads where there is none)."""
        wanted = []
        for subject in subjects:
            self._check_subject(subject)
            folders = (f"{fmt.COEFFS_DIR}/{subject}/", f"{fmt.AUDIO_DIR}/{subject}/",
                       f"{fmt.ORACLE_COEFFS_DIR}/{subject}/")
            wanted += [rel for rel in self._listed if rel.startswith(folders)]
            if fmt.rig_relpath(subject) in self._listed:
                wanted.append(fmt.rig_relpath(subject))
            else:
                heads = fmt.blendshapes_relpath(subject) + "/"
                wanted += [rel for rel in self._listed
                           if rel == fmt.template_relpath(subject) or rel.startswith(heads)]
        return sorted(set(wanted))

    def verify(self, subjects) -> int:
        """Check that the files a run on ``subjects`` reads are the ones the build made:
        each one's sha256 against the digest ``manifest.json`` lists for it.

        Parameters
        ----------
        subjects : iterable of str

        Returns
        -------
        int
            The number of files checked.

        Raises
        ------
        CheckFailed
            A file whose content differs from the build's (edited, replaced or damaged
            since); the message names the first one.
        DataError
            A listed file that is no longer there.
        """
        files = self.scored_files(subjects)
        for rel in files:
            path = self.root / rel
            if not path.is_file():
                raise DataError(f"{path}: listed in {fmt.manifest_path(self.root)} but missing; rebuild the "
                                f"dataset")
            if fmt.file_digest(path) != self._listed[rel]:
                raise CheckFailed(
                    f"{path}: its content is not what the build made (its sha256 differs from the one "
                    f"{fmt.manifest_path(self.root)} lists), so results on it would be filed under a dataset "
                    f"it no longer is; rebuild the dataset, or pass --no-verify to score the files as they are")
        return len(files)

    def utterance(self, subject: str, sentence: str, split: str | None = None):
        """The :class:`benchmark.methods.contract.Utterance` of a sentence (what ``generate`` receives)."""
        if split is None:
            split = next((name for name, subjects in self._splits.items() if subject in subjects), "")
        audio, rate = self.audio(subject, sentence)
        if rate != AUDIO_RATE:
            raise DataError(f"BlendVOCADataset.utterance {subject}/{sentence}: expected {AUDIO_RATE} Hz audio, got {rate}")
        num_frames = int(self.coeffs(subject, sentence).shape[0])
        return Utterance(subject=subject, sentence=sentence, split=split, audio=audio, num_frames=num_frames)

    def corpus_root(self) -> Path:
        """The VOCASET corpus this build was made from.

        In order: the ``vocaset`` given to :func:`open_blendvoca`, ``$BLENDVOCA_VOCASET``,
        ``inputs.vocaset.path`` in ``manifest.json``.

        Raises
        ------
        FileNotFoundError
            A build without source meshes to score against (:attr:`has_meshes`), or
            none of the places names an existing folder (the message says how to give one).
        """
        if not self.has_meshes:
            raise FileNotFoundError(
                f"BlendVOCADataset {self.root}: a build of the {self.dataset_title} corpus, which has no source meshes "
                "in FLAME topology to score against (docs/datasets.md); its vertex metrics are rig-space only")
        candidates = []
        if self._vocaset is not None:
            candidates.append(("open_blendvoca(vocaset=...)", self._vocaset))
        if os.environ.get("BLENDVOCA_VOCASET"):
            candidates.append(("$BLENDVOCA_VOCASET", Path(os.environ["BLENDVOCA_VOCASET"]).expanduser()))
        recorded = fmt.recorded_vocaset(self.root)
        if recorded:
            candidates.append((f"{fmt.manifest_path(self.root)} inputs.vocaset.path", Path(recorded)))
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
        return open_vocaset(self.corpus_root())

    def vertices(self, subject: str, sentence: str) -> np.ndarray:
        """Mesh sequence of a sentence at 60 fps, float64 metres, ``T`` = the coefficient
        track's frame count.

        ``vertex_space == "mesh"``: the source meshes, ``(T, 5023, 3)`` (the build fits every
        frame). ``"rig"``: the speaker's rig (its shapes ``names``) evaluated at the
        ground-truth coefficients, ``(T, V, 3)`` on the rig's topology (1220 vertices
        for the ARKit reference rig): the reference of the rig-space metrics.
        """
        self._check_subject(subject)
        if self.vertex_space == "rig":
            return self._speech_rig(subject).evaluate(self.coeffs(subject, sentence))
        return self.corpus.frames(subject, sentence)

    def template(self, subject: str) -> np.ndarray:
        """The speaker's neutral mesh, ``(V, 3)`` float64 metres: on the source topology
        (``(5023, 3)``), or the rig's neutral when ``vertex_space == "rig"``."""
        self._check_subject(subject)
        if self.vertex_space == "rig":
            return np.array(self.rig(subject).neutral, dtype=np.float64)
        return self.corpus.template(subject)

    def faces(self) -> np.ndarray:
        """Triangles of the topology :meth:`vertices` is on (the source's, or the first
        speaker's rig's when ``vertex_space == "rig"``), ``(F, 3)`` int64."""
        if self.vertex_space == "rig":
            return np.asarray(self.rig(self.subjects[0]).faces, dtype=np.int64)
        faces = self.corpus.faces
        return np.asarray(faces() if callable(faces) else faces, dtype=np.int64)

    def _speech_rig(self, subject: str):
        """The speaker's rig with the shapes ``names`` in that order (what the coefficients drive)."""
        rig = self.rig(subject)
        return rig if tuple(rig.names) == self.names else rig.select(self.names)

    def __repr__(self) -> str:
        return f"BlendVOCADataset({str(self.root)!r}, subjects={len(self.subjects)})"


def open_blendvoca(root: str | PathLike, *, vocaset: str | PathLike | None = None) -> BlendVOCADataset:
    """Open a BlendVOCA build or SAiD-layout folder (the files its ``manifest.json`` lists).

    Parameters
    ----------
    root : str or os.PathLike
    vocaset : str or os.PathLike, optional
        The source VOCASET corpus, for :meth:`BlendVOCADataset.vertices` (default:
        ``$BLENDVOCA_VOCASET``, then the corpus recorded in ``manifest.json``).

    Returns
    -------
    BlendVOCADataset

    Raises
    ------
    UserError
        Not a folder.
    DataError
        No usable ``manifest.json`` (:class:`blendvoca.format.ManifestError`, whose
        message gives the command that makes one), or no tracks listed.
    """
    root = Path(os.fspath(root))
    if not root.is_dir():
        raise UserError(f"open_blendvoca: {root} is not a directory")
    return BlendVOCADataset(root, vocaset=vocaset)
