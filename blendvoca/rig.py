"""The blendshape rig value: neutral mesh, per-shape vertex offsets, names, faces.

A rig is evaluated linearly: ``vertices(u) = neutral + sum_k u_k * deltas[k]``.
It is saved either compactly (one ``.npz``, exact float64) or in SAiD's folder
layout (``Neutral.obj`` plus ``<name>.obj`` per shape, absolute positions).
"""

from __future__ import annotations

import io
import os
import zipfile
import zlib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from blendvoca.assets import resolve
from blendvoca.errors import DataError, UserError
from blendvoca.io.arrays import float_array
from blendvoca.io.atomic import atomic_write
from blendvoca.io.mesh import obj_face_records, parse_obj, read_obj, write_obj
from blendvoca.names import ARKIT_NAMES, BLENDVOCA_NAMES, check_names

NEUTRAL_NAME = "Neutral"

#: What reading a broken zip archive raises: a bad or truncated structure (BadZipFile,
#: EOFError, ValueError for a seek before the start), a corrupted deflate stream
#: (zlib.error), an unsupported compression method (NotImplementedError) or an
#: encrypted member (RuntimeError).
_BROKEN_ARCHIVE = (zipfile.BadZipFile, EOFError, ValueError, zlib.error, NotImplementedError, RuntimeError)


#: How an ``.npz`` (a zip archive: a local file header, or the end record of an empty
#: one) and, to be told apart in the error, a single ``.npy`` array begin.
_NPZ_SIGNATURES = (b"PK\x03\x04", b"PK\x05\x06", b"\x93NUMPY")


def _first_bytes(raw: bytes) -> str:
    """What a file that is no archive begins with, for an error message."""
    if not raw:
        return "the file is empty"
    head = raw[:16]
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError:
        return f"it begins with the bytes {head!r}"
    if text.isprintable() or all(c.isprintable() or c in "\t\r\n" for c in text):
        return f"it is text, beginning {text!r}"
    return f"it begins with the bytes {head!r}"


@dataclass(frozen=True, eq=False)
class Rig:
    """A linear blendshape rig.

    Attributes
    ----------
    neutral : (V, 3) float64 ndarray
    deltas : (K, V, 3) float64 ndarray, offsets of each shape from the neutral
    names : tuple of K str
    faces : (F, 3) int64 ndarray

    The constructor takes any real dtype (float32 neutral and deltas are converted to
    float64, integer faces to int64) and raises :class:`~blendvoca.errors.UserError`
    (a ``ValueError``) naming the field that has the wrong shape, non-finite values or
    values that are not numbers.
    """

    neutral: np.ndarray
    deltas: np.ndarray
    names: tuple[str, ...]
    faces: np.ndarray

    def __post_init__(self):
        neutral = float_array(self.neutral, where="Rig", name="neutral", shape="(V, 3)")
        deltas = float_array(self.deltas, where="Rig", name="deltas", shape="(K, V, 3)")
        faces = _face_array(self.faces)
        names = check_names(self.names, where="Rig")
        if neutral.ndim != 2 or neutral.shape[1] != 3:
            raise UserError(f"Rig.neutral must be (V, 3), got {neutral.shape}")
        if deltas.shape != (len(names), *neutral.shape):
            raise UserError(f"Rig.deltas must be (K={len(names)}, V={len(neutral)}, 3), got {deltas.shape}")
        if faces.ndim != 2 or faces.shape[1] != 3 or (faces.size and (faces.min() < 0 or faces.max() >= len(neutral))):
            raise UserError(f"Rig.faces must be (F, 3) indices into {len(neutral)} vertices, got shape {faces.shape}")
        for field, value in (("neutral", neutral), ("deltas", deltas)):
            if not np.all(np.isfinite(value)):
                raise UserError(f"Rig.{field} contains NaN or infinite values")
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
        """Vertices for coefficients (any real dtype): ``(T, K) -> (T, V, 3)`` (or ``(K,) -> (V, 3)``)."""
        coeffs = float_array(coeffs, where="Rig.evaluate", name="coeffs", shape=f"(T, {len(self.names)})")
        if coeffs.ndim == 0 or coeffs.shape[-1] != len(self.names):
            raise UserError(f"coefficients have {coeffs.shape[-1]} columns, the rig has {len(self.names)} shapes")
        flat = coeffs.reshape(-1, len(self.names)) @ self.deltas.reshape(len(self.names), -1)
        return self.neutral + flat.reshape(*coeffs.shape[:-1], *self.neutral.shape)

    def delta_matrix(self) -> np.ndarray:
        """The ``(3V, K)`` matrix B whose column k is shape k's flattened offsets."""
        return self.deltas.reshape(len(self.names), -1).T

    def select(self, names: Sequence[str]) -> Rig:
        """A rig with the shapes ``names`` in that order."""
        missing = [n for n in names if n not in self.names]
        if missing:
            raise UserError(f"the rig has no shapes {missing}; it has {list(self.names)}")
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
        """Load a rig written by `save`.

        Parameters
        ----------
        path : str or os.PathLike
            A ``.npz`` with ``neutral``, ``deltas``, ``names`` and ``faces``.

        Raises
        ------
        FileNotFoundError
            No file at ``path``.
        DataError
            The file is no ``.npz``, lacks an array, or its arrays do not form a rig (naming the file).
        """
        path = Path(os.fspath(path))
        if not path.is_file():
            raise FileNotFoundError(f"rig file not found: {path}")
        # Read into memory first: a broken archive's seeks then fail as the format errors
        # below, and an OSError is only ever the file system's.
        raw = path.read_bytes()
        if not raw.startswith(_NPZ_SIGNATURES):
            # np.load takes any other bytes for a pickle and answers with its allow_pickle
            # advice, which misleads: the file is simply not an archive
            raise DataError(f"{path}: not a .npz archive ({_first_bytes(raw)}); a BlendVOCA rig file is the "
                            f".npz that Rig.save writes (or give a SAiD folder of OBJ files)")
        content = io.BytesIO(raw)
        try:
            data = np.load(content, allow_pickle=False)
            if not isinstance(data, np.lib.npyio.NpzFile):
                raise DataError(f"{path}: not a BlendVOCA rig file: a single array, expected an .npz archive")
            with data:
                missing = {"neutral", "deltas", "names", "faces"} - set(data.files)
                if missing:
                    raise DataError(f"{path}: not a BlendVOCA rig file, missing arrays {sorted(missing)}")
                arrays = {k: data[k] for k in ("neutral", "deltas", "names", "faces")}
        except DataError:
            raise
        except _BROKEN_ARCHIVE as error:  # not an .npz, truncated, corrupted, pickled objects
            raise DataError(f"{path}: not a readable BlendVOCA rig file (.npz): {error}") from None
        if arrays["names"].ndim != 1:
            raise DataError(f"{path}: names must be a 1-D array of shape names, got shape {arrays['names'].shape}")
        try:
            return cls(arrays["neutral"], arrays["deltas"], tuple(str(n) for n in arrays["names"]), arrays["faces"])
        except UserError as error:
            raise DataError(f"{path}: {error}") from None

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
        directory : str or os.PathLike, holding ``<name>.obj`` per shape (and usually ``Neutral.obj``)
        names : shapes to load, in order (default: every ARKit name present, ARKit order)
        neutral_path : the neutral OBJ if it is elsewhere (BlendVOCA keeps it in
            ``templates_head/<subject>.obj``)

        Raises
        ------
        FileNotFoundError
            No such folder, or no OBJ of a wanted shape.
        DataError
            An OBJ with another vertex count than the neutral.
        UserError
            ``names`` that are not ARKit names.
        """
        directory = Path(os.fspath(directory))
        if not directory.is_dir():
            raise FileNotFoundError(f"rig folder not found: {directory}")
        neutral_path = Path(os.fspath(neutral_path)) if neutral_path else directory / f"{NEUTRAL_NAME}.obj"
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
                raise DataError(f"{path}: {len(V)} vertices, the neutral {neutral_path} has {len(neutral)}")
            deltas.append(V - neutral)
        return cls(neutral, np.array(deltas).reshape(len(names), *neutral.shape), tuple(names), faces)


def load_rig(path) -> Rig:
    """A rig from a ``.npz`` (:meth:`Rig.save`) or a SAiD folder (``Neutral.obj`` + ``<name>.obj``)."""
    return Rig.load_said_folder(path) if Path(os.fspath(path)).is_dir() else Rig.load(path)


def read_rig_zip(path, names: Sequence[str]) -> Rig:
    """A rig from a zip (str or os.PathLike) of ``<folder>/Neutral.obj`` and ``<folder>/<name>.obj`` files."""
    path = Path(os.fspath(path))
    meshes = {}
    content = io.BytesIO(path.read_bytes())  # in memory, as in Rig.load: an OSError is the file system's
    try:
        with zipfile.ZipFile(content) as archive:
            for member in archive.namelist():
                stem = Path(member).stem
                if member.endswith(".obj") and (stem == NEUTRAL_NAME or stem in names):
                    text = archive.read(member).decode("utf-8", errors="replace")
                    meshes[stem] = parse_obj(text, where=f"{path}:{member}")
    except DataError:  # an OBJ member that does not parse, named by parse_obj
        raise
    except _BROKEN_ARCHIVE as error:
        raise DataError(f"{path}: not a readable zip of OBJ files ({error})") from None
    missing = [n for n in (NEUTRAL_NAME, *names) if n not in meshes]
    if missing:
        raise DataError(f"{path}: no OBJ for {missing}")
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
    return read_rig_zip(resolve("arkit-reference-rig"), shape_names(shapes))


def shape_names(shapes: str | Sequence[str]) -> tuple[str, ...]:
    """Resolve a ``--shapes`` value ("speech", "all" or names) to a tuple of names."""
    if isinstance(shapes, str):
        if shapes == "speech":
            return BLENDVOCA_NAMES
        if shapes == "all":
            return ARKIT_NAMES
        raise UserError(f"shapes must be 'speech', 'all' or a list of names, got {shapes!r}")
    return check_names(shapes, where="shapes")


def _face_array(faces) -> np.ndarray:
    """``(F, 3)`` int64 faces from integer (or integral float) indices, or a :class:`UserError`."""
    try:
        array = np.asarray(faces)
        if array.size and not (np.issubdtype(array.dtype, np.integer)
                               or (np.issubdtype(array.dtype, np.floating) and np.all(array == np.round(array)))):
            raise TypeError(f"dtype {array.dtype}")
        return array.astype(np.int64)
    except (TypeError, ValueError) as error:
        got = getattr(faces, "dtype", type(faces).__name__)
        raise UserError(f"Rig: expected faces as an (F, 3) array of vertex indices (integers), "
                        f"got {got} ({error})") from None
