"""The blendshape rig value: neutral mesh, per-shape vertex offsets, names, faces.

A rig is evaluated linearly: ``vertices(u) = neutral + sum_k u_k * deltas[k]``.
It is saved either compactly (one ``.npz``, exact float64) or in SAiD's folder
layout (``Neutral.obj`` plus ``<name>.obj`` per shape, absolute positions).
"""

from __future__ import annotations

import io
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from blendvoca.io.atomic import atomic_write
from blendvoca.io.mesh import obj_face_records, parse_obj, read_obj, write_obj
from blendvoca.names import ARKIT_NAMES, BLENDVOCA_NAMES, check_names

NEUTRAL_NAME = "Neutral"


@dataclass(frozen=True, eq=False)
class Rig:
    """A linear blendshape rig.

    Attributes
    ----------
    neutral : (V, 3) float64 ndarray
    deltas : (K, V, 3) float64 ndarray, offsets of each shape from the neutral
    names : tuple of K str
    faces : (F, 3) int64 ndarray
    """

    neutral: np.ndarray
    deltas: np.ndarray
    names: tuple[str, ...]
    faces: np.ndarray

    def __post_init__(self):
        neutral = np.asarray(self.neutral, dtype=np.float64)
        deltas = np.asarray(self.deltas, dtype=np.float64)
        faces = np.asarray(self.faces, dtype=np.int64)
        names = check_names(self.names, where="Rig")
        if neutral.ndim != 2 or neutral.shape[1] != 3:
            raise ValueError(f"Rig.neutral must be (V, 3), got {neutral.shape}")
        if deltas.shape != (len(names), *neutral.shape):
            raise ValueError(f"Rig.deltas must be (K={len(names)}, V={len(neutral)}, 3), got {deltas.shape}")
        if faces.ndim != 2 or faces.shape[1] != 3 or (faces.size and (faces.min() < 0 or faces.max() >= len(neutral))):
            raise ValueError(f"Rig.faces must be (F, 3) indices into {len(neutral)} vertices, got shape {faces.shape}")
        for field, value in (("neutral", neutral), ("deltas", deltas)):
            if not np.all(np.isfinite(value)):
                raise ValueError(f"Rig.{field} contains NaN or infinite values")
        for field, value in (("neutral", neutral), ("deltas", deltas), ("faces", faces), ("names", names)):
            if isinstance(value, np.ndarray):
                value.setflags(write=False)
            object.__setattr__(self, field, value)

    @property
    def num_vertices(self) -> int:
        return len(self.neutral)

    def __len__(self) -> int:
        return len(self.names)

    def __eq__(self, other) -> bool:
        return (
            isinstance(other, Rig)
            and self.names == other.names
            and np.array_equal(self.neutral, other.neutral)
            and np.array_equal(self.deltas, other.deltas)
            and np.array_equal(self.faces, other.faces)
        )

    def evaluate(self, coeffs: np.ndarray) -> np.ndarray:
        """Vertices for coefficients: ``(T, K) -> (T, V, 3)`` (or ``(K,) -> (V, 3)``)."""
        coeffs = np.asarray(coeffs, dtype=np.float64)
        if coeffs.shape[-1] != len(self.names):
            raise ValueError(f"coefficients have {coeffs.shape[-1]} columns, the rig has {len(self.names)} shapes")
        flat = coeffs.reshape(-1, len(self.names)) @ self.deltas.reshape(len(self.names), -1)
        return self.neutral + flat.reshape(*coeffs.shape[:-1], *self.neutral.shape)

    def shape_vertices(self, name: str) -> np.ndarray:
        """Absolute vertices of one shape at full weight, ``(V, 3)``."""
        return self.neutral + self.deltas[self.names.index(name)]

    def delta_matrix(self) -> np.ndarray:
        """The ``(3V, K)`` matrix B whose column k is shape k's flattened offsets."""
        return self.deltas.reshape(len(self.names), -1).T

    def select(self, names: Sequence[str]) -> Rig:
        """A rig with the shapes ``names`` in that order."""
        missing = [n for n in names if n not in self.names]
        if missing:
            raise ValueError(f"the rig has no shapes {missing}; it has {list(self.names)}")
        order = [self.names.index(n) for n in names]
        return Rig(self.neutral, self.deltas[order], tuple(names), self.faces)

    # ------------------------------------------------------------------ files

    def save(self, path) -> None:
        """Save as one compressed ``.npz`` (exact float64), atomically."""
        buffer = io.BytesIO()
        np.savez_compressed(buffer, neutral=self.neutral, deltas=self.deltas,
                            names=np.array(self.names), faces=self.faces)
        with atomic_write(path, "wb") as f:
            f.write(buffer.getvalue())

    @classmethod
    def load(cls, path) -> Rig:
        """Load a rig written by `save`."""
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"rig file not found: {path}")
        with np.load(path, allow_pickle=False) as data:
            missing = {"neutral", "deltas", "names", "faces"} - set(data.files)
            if missing:
                raise ValueError(f"{path}: not a BlendVOCA rig file, missing arrays {sorted(missing)}")
            return cls(data["neutral"], data["deltas"], tuple(str(n) for n in data["names"]), data["faces"])

    def save_said_folder(self, directory) -> None:
        """Write ``Neutral.obj`` and ``<name>.obj`` (absolute vertices) per shape."""
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        face_records = obj_face_records(self.faces)
        write_obj(directory / f"{NEUTRAL_NAME}.obj", self.neutral, self.faces, face_records=face_records)
        for name, delta in zip(self.names, self.deltas):
            write_obj(directory / f"{name}.obj", self.neutral + delta, self.faces, face_records=face_records)

    @classmethod
    def load_said_folder(cls, directory, names: Sequence[str] | None = None, *, neutral_path=None) -> Rig:
        """Load SAiD's folder layout.

        Parameters
        ----------
        directory : path-like, holding ``<name>.obj`` per shape (and usually ``Neutral.obj``)
        names : shapes to load, in order (default: every ARKit name present, ARKit order)
        neutral_path : the neutral OBJ if it is elsewhere (BlendVOCA keeps it in
            ``templates_head/<subject>.obj``)
        """
        directory = Path(directory)
        if not directory.is_dir():
            raise FileNotFoundError(f"rig folder not found: {directory}")
        neutral_path = Path(neutral_path) if neutral_path else directory / f"{NEUTRAL_NAME}.obj"
        neutral, faces = read_obj(neutral_path)
        if names is None:
            names = [n for n in ARKIT_NAMES if (directory / f"{n}.obj").is_file()]
        deltas = []
        for name in names:
            path = directory / f"{name}.obj"
            if not path.is_file():
                raise FileNotFoundError(f"rig folder {directory} has no {name}.obj")
            V, _ = read_obj(path)
            if V.shape != neutral.shape:
                raise ValueError(f"{path}: {len(V)} vertices, the neutral {neutral_path} has {len(neutral)}")
            deltas.append(V - neutral)
        return cls(neutral, np.array(deltas).reshape(len(names), *neutral.shape), tuple(names), faces)


def read_rig_zip(path, names: Sequence[str]) -> Rig:
    """A rig from a zip of ``<folder>/Neutral.obj`` and ``<folder>/<name>.obj`` files."""
    meshes = {}
    with zipfile.ZipFile(path) as archive:
        for member in archive.namelist():
            stem = Path(member).stem
            if member.endswith(".obj") and (stem == NEUTRAL_NAME or stem in names):
                text = archive.read(member).decode("utf-8", errors="replace")
                meshes[stem] = parse_obj(text, where=f"{path}:{member}")
    missing = [n for n in (NEUTRAL_NAME, *names) if n not in meshes]
    if missing:
        raise ValueError(f"{path}: no OBJ for {missing}")
    neutral, faces = meshes[NEUTRAL_NAME]
    deltas = np.array([meshes[n][0] - neutral for n in names])
    return Rig(neutral, deltas, tuple(names), faces)


def load_arkit_reference(shapes: str | Sequence[str] = "speech") -> Rig:
    """The ARKit reference rig from the ``arkit-reference-rig`` asset.

    Parameters
    ----------
    shapes : "speech" (the 32 BlendVOCA names in BlendVOCA order), "all" (the 51
        shapes of the reference rig, ARKit order) or an explicit list of names.
    """
    from blendvoca.assets import resolve

    return read_rig_zip(resolve("arkit-reference-rig"), shape_names(shapes))


def shape_names(shapes: str | Sequence[str]) -> tuple[str, ...]:
    """Resolve a ``--shapes`` value ("speech", "all" or names) to a tuple of names."""
    if isinstance(shapes, str):
        if shapes == "speech":
            return BLENDVOCA_NAMES
        if shapes == "all":
            return ARKIT_NAMES
        raise ValueError(f"shapes must be 'speech', 'all' or a list of names, got {shapes!r}")
    return check_names(shapes, where="shapes")
