"""Multiface's speech captures in MeshTalk's 6,172-vertex topology (``--dataset multiface``).

::

    face_template.obj                               MeshTalk's face template (6172 vertices): the triangles
    <capture>/tracked_mesh/<SEN_...>/<NNNNNN>.bin   one frame: 6172 x 3 float32 (x, y, z), little-endian
                                          or .obj   the same frame as an OBJ (MeshTalk's conversion writes these)
    <capture>/audio/<SEN_...>.wav                   the sentence's speech
    <capture>/template.obj                          (optional) the speaker's neutral; default: the first
                                                    frame of <capture>/tracked_mesh/EXP_neutral_peak/

``<capture>`` is a Multiface capture folder (``m--20180227--0000--6795937--GHS``);
only ``SEN_`` sequences (read sentences, with audio) are sentences, numbered
``sentenceNN`` in the sorted order of every ``SEN_`` name in the corpus (one
number per sentence for every speaker; ``source_name`` maps back). Multiface
(Wuu et al. 2022, facebookresearch/multiface, CC-BY-NC 4.0) tracks its
speakers at 30 fps in millimetres with the head pose in the meshes; the release
stores 7,306-vertex meshes, which MeshTalk's topology drops to 6,172 (the
``convert_topology`` step of MeshTalk-based repositories, e.g. FaceDiffuser's
``data/multiface/convert_topolgy.py``): this reader takes the converted frames and
says so when it meets 7,306-vertex ones. Frames are numbered by capture frame;
they are read in numeric order, resampled to 60 fps and converted to metres.
Splits: VOCASET's proportions over the sorted capture names.
"""

from __future__ import annotations

import functools
import re
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError
from blendvoca.io.mesh import read_obj
from blendvoca.vocaset.checks import frame_gaps
from blendvoca.vocaset.errors import Problem, check_safe_name
from blendvoca.vocaset.splits import proportional_split

from ._vertex import LayoutError, VertexCorpus, sentence_numbers, vertex_adapter

NUM_VERTICES = 6172
#: Vertices of Multiface's own (unconverted) tracked meshes.
RELEASE_VERTICES = 7306
FPS = 30
NEUTRAL_SEQUENCE = "EXP_neutral_peak"
EXPECTED = ("face_template.obj (MeshTalk's, 6172 vertices)",
            "<capture>/tracked_mesh/SEN_<sentence>/<frame>.bin or .obj (6172 vertices, 30 fps)",
            "<capture>/audio/SEN_<sentence>.wav",
            "<capture>/template.obj or <capture>/tracked_mesh/EXP_neutral_peak/<frame>.bin")
_FRAME = re.compile(r"^(\d+)\.(bin|obj)$")


def read_frame(path) -> np.ndarray:
    """One tracked frame ``(V, 3)`` from a ``.bin`` (float32 triples) or ``.obj`` file."""
    path = Path(path)
    if path.suffix == ".obj":
        return read_obj(path)[0]
    data = np.fromfile(path, dtype="<f4")
    if data.size % 3:
        raise DataError(f"{path}: {data.size} floats, not a whole number of (x, y, z) vertices")
    return data.reshape(-1, 3).astype(np.float64)


def _frame_files(folder: Path) -> tuple[list[Path], np.ndarray]:
    found = sorted((int(m.group(1)), p) for p in folder.iterdir() if (m := _FRAME.match(p.name)))
    return [p for _, p in found], np.array([n for n, _ in found], dtype=np.int64)


class MultifaceCorpus(VertexCorpus):
    """Reader of the Multiface layout above (the :class:`~blendvoca.vocaset.base.VocasetCorpus` interface).

    Parameters
    ----------
    root : str or os.PathLike
    units : {"auto", "m", "cm", "mm"}
        The corpus's length unit (Multiface: millimetres; ``auto`` finds it from the template's size).
    landmarks : str or os.PathLike, optional
        The 68-landmark file of MeshTalk's topology; default the asset ``multiface-landmarks``.
    """

    layout = "multiface"
    topology = "MeshTalk (Multiface)"
    vertex_count = NUM_VERTICES
    source_fps = FPS
    landmark_asset = "multiface-landmarks"

    def __init__(self, root, **kwargs):
        super().__init__(root, **kwargs)
        captures = sorted(p.name for p in self.root.iterdir() if (p / "tracked_mesh").is_dir()) \
            if self.root.is_dir() else []
        if not (self.root / "face_template.obj").is_file() or not captures:
            raise LayoutError(f"{self.root}: not the Multiface layout (no face_template.obj or no "
                              "<capture>/tracked_mesh/ folder); expected " + "; ".join(EXPECTED))
        found: dict[str, list[str]] = {}
        for capture in captures:
            check_safe_name(capture, "subject", self.root)
            meshes = self.root / capture / "tracked_mesh"
            found[capture] = sorted(p.name for p in meshes.iterdir() if p.is_dir() and p.name.startswith("SEN_"))
        # one number per SEN_ name across the corpus: the same sentence is the same sentenceNN for every speaker
        numbers = sentence_numbers(name for names in found.values() for name in names)
        self._source_names = {number: name for name, number in numbers.items()}
        self._sentences = {capture: sorted(numbers[name] for name in names) for capture, names in found.items()}
        for capture, names in self._sentences.items():
            for sentence in names:
                if not self._wav(capture, sentence).is_file():
                    self._record(Problem(capture, sentence, None, "missing_audio",
                                         f"{self._wav(capture, sentence)} not found"))
        self._subjects = captures

    def _wav(self, subject: str, sentence: str) -> Path:
        return self.root / subject / "audio" / f"{self.source_name(sentence)}.wav"

    def _checked_vertices(self, subject, sentence, path: Path, vertices: np.ndarray, frame=None) -> np.ndarray:
        if len(vertices) == RELEASE_VERTICES:
            self._fail("vertex_count", subject, sentence,
                       f"{path}: {RELEASE_VERTICES} vertices, Multiface's release topology; convert the "
                       f"frames to MeshTalk's {NUM_VERTICES}-vertex topology first (MeshTalk's convert_topology "
                       "step, see docs/datasets.md)", frame=frame)
        if len(vertices) != NUM_VERTICES:
            self._fail("vertex_count", subject, sentence, f"{path}: {len(vertices)} vertices, expected {NUM_VERTICES}",
                       frame=frame)
        return vertices

    def _raw_template(self, subject: str) -> np.ndarray:
        own = self.root / subject / "template.obj"
        if own.is_file():
            return self._checked_vertices(subject, None, own, read_frame(own))
        neutral = self.root / subject / "tracked_mesh" / NEUTRAL_SEQUENCE
        paths = _frame_files(neutral)[0] if neutral.is_dir() else []
        if not paths:
            self._fail("missing_template", subject, None,
                       f"neither {own} nor frames in {neutral}: the speaker has no neutral")
        return self._checked_vertices(subject, None, paths[0], read_frame(paths[0]))

    def _raw_frames(self, subject: str, sentence: str) -> np.ndarray:
        folder = self.root / subject / "tracked_mesh" / self.source_name(sentence)
        if sentence not in self._sentences.get(subject, []):
            self._fail("missing_sentence", subject, sentence, f"{folder}: no such sentence")
        paths, numbers = _frame_files(folder)
        if not paths:
            self._fail("missing_frame", subject, sentence, f"{folder}: no frame files (<frame>.bin or .obj)")
        gaps = frame_gaps(numbers, limit=5)
        if gaps:
            self._fail("missing_frame", subject, sentence, f"{folder}: frames {gaps} missing",
                       frame=int(np.searchsorted(numbers, gaps[0])))
        frames = []
        for t, path in enumerate(paths):
            try:
                vertices = read_frame(path)
            except (DataError, OSError, ValueError) as error:
                self._fail("unreadable", subject, sentence, f"{path}: {error}", frame=t)
            frames.append(self._checked_vertices(subject, sentence, path, vertices, frame=t))
        return np.stack(frames)

    @functools.cached_property
    def faces(self) -> np.ndarray:
        """Triangles ``(F, 3)`` of MeshTalk's topology, from ``face_template.obj``."""
        path = self.root / "face_template.obj"
        vertices, faces = read_obj(path)
        if len(vertices) != NUM_VERTICES or len(faces) == 0:
            raise DataError(f"{path}: {len(vertices)} vertices and {len(faces)} triangles; expected MeshTalk's "
                            f"{NUM_VERTICES}-vertex face template with its faces")
        return np.asarray(faces, dtype=np.int64)

    @property
    def splits(self) -> dict[str, list[str]]:
        """VOCASET's proportions over the sorted capture names."""
        return proportional_split(self._subjects)


def open_multiface(root, **kwargs) -> MultifaceCorpus:
    """Open a Multiface corpus (see :class:`MultifaceCorpus` for the options)."""
    return MultifaceCorpus(root, **kwargs)


#: The ``--dataset multiface`` adapter (:data:`blendvoca.datasets.DATASETS`): the vertex-corpus build with this reader.
ADAPTER = vertex_adapter("blendvoca.datasets.multiface:open_multiface")
