"""Finding and reading the vertex outputs of a method."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError, UserError
from blendvoca.io.mesh import read_mesh, read_ply_sequence

__all__ = ["MESH_SUFFIXES", "find_sequences", "read_vertex_sequence"]

MESH_SUFFIXES = (".ply", ".obj")
_DIGITS = re.compile(r"(\d+)")


def find_sequences(root: str | os.PathLike) -> dict[tuple[str, str], Path]:
    """``{(subject, sentence): path}`` of every output under ``root``.

    Accepted layouts: ``<root>/<subject>/<sentence>.npy`` (a ``(T, V, 3)`` array)
    and ``<root>/<subject>/<sentence>/`` holding one ``.ply`` / ``.obj`` per frame.

    Raises
    ------
    UserError
        ``root`` is not a folder.
    """
    root = Path(os.fspath(root))
    if not root.is_dir():
        raise UserError(f"mesh-adapter: vertex output folder {root} does not exist")
    found = {}
    for subject_dir in sorted(p for p in root.iterdir() if p.is_dir()):
        for item in sorted(subject_dir.iterdir()):
            if item.is_file() and item.suffix == ".npy":
                found[(subject_dir.name, item.stem)] = item
            elif item.is_dir() and any(f.suffix in MESH_SUFFIXES for f in item.iterdir()):
                found[(subject_dir.name, item.name)] = item
    return found


def _frame_order(path: Path):
    # natural order: frame2 before frame10, whatever the zero padding
    return [int(t) if t.isdigit() else t for t in _DIGITS.split(path.name)]


def read_vertex_sequence(path: str | os.PathLike) -> np.ndarray:
    """Vertices of one output sequence.

    Parameters
    ----------
    path : path-like
        A ``.npy`` file of shape ``(T, V, 3)`` (or ``(T, 3V)``) or a folder of
        per-frame meshes, read in natural file-name order.

    Returns
    -------
    (T, V, 3) float64 ndarray

    Raises
    ------
    DataError
        No frames, another shape, or NaN / infinite values.
    """
    path = Path(os.fspath(path))
    if path.is_file():
        frames = np.load(path, allow_pickle=False)
        if frames.ndim == 2 and frames.shape[1] % 3 == 0:
            frames = frames.reshape(frames.shape[0], -1, 3)
    else:
        files = sorted((f for f in path.iterdir() if f.suffix in MESH_SUFFIXES), key=_frame_order)
        if not files:
            raise DataError(f"mesh-adapter: {path} holds no .ply/.obj frames")
        if all(f.suffix == ".ply" for f in files):
            frames = read_ply_sequence(files)
        else:
            frames = np.stack([read_mesh(f)[0] for f in files])
    frames = np.asarray(frames, dtype=np.float64)
    if frames.ndim != 3 or frames.shape[2] != 3 or frames.shape[0] == 0:
        raise DataError(f"mesh-adapter: {path}: expected (T, V, 3) vertices, got shape {frames.shape}")
    if not np.all(np.isfinite(frames)):
        raise DataError(f"mesh-adapter: {path}: vertex sequence contains NaN or infinite values")
    return frames
