"""The BIWI 3D audiovisual corpus in the layout FaceFormer and CodeTalker train on (``--dataset biwi``).

::

    templates.pkl                   {subject: (23370, 3) neutral}   e.g. "F2"
    vertices_npy/<subject>_<sentence>.npy   (T, 70110) or (T, 23370, 3), 25 fps
    wav/<subject>_<sentence>.wav    the sentence's speech
    BIWI.ply                        the topology's triangles (CodeTalker ships it), or
    rigid_scans/<subject>.obj       BIWI's own personalised templates (their triangles)

Sentence names are what follows the subject and its underscore (``e01`` ...
``e40`` in FaceFormer's preparation); the reader calls them ``sentenceNN`` with
BIWI's number (``e07`` is ``sentence07``), as a BlendVOCA folder names them. BIWI's 14 speakers (F1-F8, M1-M6) read 40
English sentences each, tracked as 23,370-vertex face meshes at 25 fps (Fanelli
et al. 2010); the corpus is distributed by ETH Zurich on request for
non-commercial research. The frames are resampled to 60 fps and converted to
metres (the unit is guessed from the template's size unless ``units`` is given).

Splits by speaker: FaceFormer's six training speakers (F2 F3 F4 M3 M4 M5) are
train; of its eight unseen speakers (its "BIWI-Test-B"), F1 and M1 are val and
F5 F6 F7 F8 M2 M6 test. Other speaker names are split in VOCASET's proportions.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError
from blendvoca.io.mesh import read_mesh
from blendvoca.vocaset.errors import Problem, check_safe_name
from blendvoca.vocaset.processed import UnsafePickleError, load_data_pickle, open_rows
from blendvoca.vocaset.splits import proportional_split

from ._vertex import LayoutError, VertexCorpus, sentence_numbers, vertex_adapter

NUM_VERTICES = 23370
FPS = 25
#: Speaker splits (see the module docstring).
BIWI_SPLITS = {
    "train": ("F2", "F3", "F4", "M3", "M4", "M5"),
    "val": ("F1", "M1"),
    "test": ("F5", "F6", "F7", "F8", "M2", "M6"),
}
#: What a root must hold (named by the layout error).
EXPECTED = ("templates.pkl", "vertices_npy/<subject>_<sentence>.npy (T, 70110) at 25 fps",
            "wav/<subject>_<sentence>.wav", "BIWI.ply or rigid_scans/<subject>.obj (the triangles)")


class BiwiCorpus(VertexCorpus):
    """Reader of the BIWI layout above (the :class:`~blendvoca.vocaset.base.VocasetCorpus` interface).

    Parameters
    ----------
    root : str or os.PathLike
    units : {"auto", "m", "cm", "mm"}
        The corpus's length unit; ``auto`` picks the one giving the template a head's size.
    landmarks : str or os.PathLike, optional
        The 68-landmark file of the BIWI topology; default the asset ``biwi-landmarks``.
    """

    layout = "biwi"
    topology = "BIWI"
    vertex_count = NUM_VERTICES
    source_fps = FPS
    landmark_asset = "biwi-landmarks"

    def __init__(self, root, **kwargs):
        super().__init__(root, **kwargs)
        missing = [name for name in ("templates.pkl", "vertices_npy", "wav") if not (self.root / name).exists()]
        if missing:
            raise LayoutError(f"{self.root}: not the BIWI layout (missing {', '.join(missing)}); expected "
                              + "; ".join(EXPECTED))
        try:
            templates = load_data_pickle(self.root / "templates.pkl")
        except UnsafePickleError as error:
            raise DataError(str(error)) from None
        if not isinstance(templates, dict):
            raise DataError(f"{self.root / 'templates.pkl'}: expected a dict of subject -> (23370, 3) template, "
                            f"got {type(templates).__name__}")
        self._raw_templates = {str(k): v for k, v in templates.items()}
        for subject in self._raw_templates:
            check_safe_name(subject, "subject", self.root / "templates.pkl")
        found = []
        for path in sorted((self.root / "vertices_npy").glob("*.npy")):
            subject, _, name = path.stem.rpartition("_")
            if subject and name:
                found.append((subject, name, path))
        numbers = sentence_numbers(name for _, name, _ in found)
        self._source_names = {number: name for name, number in numbers.items()}
        self._files: dict[str, dict[str, Path]] = {}
        for subject, name, path in found:
            self._files.setdefault(subject, {})[numbers[name]] = path
        self._subjects = sorted(set(self._raw_templates) | set(self._files))
        self._sentences = {subject: sorted(self._files.get(subject, {})) for subject in self._subjects}
        for subject in self._subjects:
            if subject not in self._raw_templates:
                self._record_problem("missing_template", subject, None, "templates.pkl has no entry")
            for sentence in self._files.get(subject, {}):
                if not self._wav(subject, sentence).is_file():
                    self._record_problem("missing_audio", subject, sentence, f"{self._wav(subject, sentence)} not found")

    def _record_problem(self, kind, subject, sentence, message):
        self._record(Problem(subject, sentence, None, kind, message))

    def _wav(self, subject: str, sentence: str) -> Path:
        return self.root / "wav" / f"{subject}_{self.source_name(sentence)}.wav"

    def _raw_template(self, subject: str) -> np.ndarray:
        if subject not in self._raw_templates:
            self._fail("missing_template", subject, None, f"{self.root / 'templates.pkl'} has no entry")
        template = np.asarray(self._raw_templates[subject], dtype=np.float64)
        return template.reshape(-1, 3) if template.ndim == 1 and template.size == 3 * NUM_VERTICES else template

    def _raw_frames(self, subject: str, sentence: str) -> np.ndarray:
        path = self._files.get(subject, {}).get(sentence)
        if path is None:
            self._fail("missing_sentence", subject, sentence,
                       f"{self.root / 'vertices_npy'}: no {subject}_{self.source_name(sentence)}.npy")
        rows, declared = open_rows(path, NUM_VERTICES)
        if len(rows) < declared:
            self._fail("truncated", subject, sentence, f"{path}: holds {len(rows)} of {declared} frames", frame=len(rows))
        if rows.ndim != 3 or rows.shape[1:] != (NUM_VERTICES, 3):
            self._fail("vertex_count", subject, sentence,
                       f"{path}: shape {(declared, *rows.shape[1:])}, expected (T, {3 * NUM_VERTICES}) or "
                       f"(T, {NUM_VERTICES}, 3)")
        if len(rows) == 0:
            self._fail("missing_frame", subject, sentence, f"{path}: no frames")
        return np.asarray(rows, dtype=np.float64)

    @functools.cached_property
    def faces(self) -> np.ndarray:
        """Triangles ``(F, 3)`` of the BIWI topology: ``BIWI.ply``, else the first ``rigid_scans/*.obj``."""
        candidates = [self.root / "BIWI.ply"] + sorted((self.root / "rigid_scans").glob("*.obj"))
        path = next((p for p in candidates if p.is_file()), None)
        if path is None:
            raise LayoutError(f"{self.root}: no triangles of the BIWI topology; expected BIWI.ply (CodeTalker's "
                              "BIWI/BIWI.ply) or rigid_scans/<subject>.obj (BIWI's templates)")
        vertices, faces = read_mesh(path)
        if len(vertices) != NUM_VERTICES or faces is None or len(faces) == 0:
            raise DataError(f"{path}: {len(vertices)} vertices and {0 if faces is None else len(faces)} "
                            f"triangles; expected a {NUM_VERTICES}-vertex BIWI mesh with its faces")
        return np.asarray(faces, dtype=np.int64)

    @property
    def splits(self) -> dict[str, list[str]]:
        """BIWI's speaker split (module docstring) restricted to the speakers present, else VOCASET's proportions."""
        known = {s for names in BIWI_SPLITS.values() for s in names}
        if self._subjects and set(self._subjects) <= known:
            splits = {k: [s for s in v if s in self._subjects] for k, v in BIWI_SPLITS.items()}
            if all(splits.values()):
                return splits
        return proportional_split(self._subjects)


def open_biwi(root, **kwargs) -> BiwiCorpus:
    """Open a BIWI corpus (see :class:`BiwiCorpus` for the options)."""
    return BiwiCorpus(root, **kwargs)


#: The ``--dataset biwi`` adapter (:data:`blendvoca.datasets.DATASETS`): the vertex-corpus build with this reader.
ADAPTER = vertex_adapter("blendvoca.datasets.biwi:open_biwi")
