"""Reading a method's ``.npz`` file without pickle (importing no torch)."""

from __future__ import annotations

import os
import pickle
import zipfile
import zlib
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError, UserError

__all__ = ["read_npz_arrays"]


def read_npz_arrays(path: str | os.PathLike, *, where: str) -> dict[str, np.ndarray]:
    """Every array of the ``.npz`` file ``path``, read without pickle.

    Raises
    ------
    UserError
        No file at ``path``.
    DataError
        Not an ``.npz`` archive, or it holds object arrays (pickled Python objects).
    """
    path = Path(os.fspath(path))
    if not path.is_file():
        raise UserError(f"{where}: expected a file at {path}, not found")
    try:
        with np.load(path, allow_pickle=False) as data:
            if not hasattr(data, "files"):
                raise ValueError("a single .npy array, not an .npz archive")
            return {name: data[name] for name in data.files}
    except (ValueError, EOFError, zipfile.BadZipFile, pickle.UnpicklingError, zlib.error) as exc:
        raise DataError(f"{where}: {path} is not a readable .npz of numeric arrays ({exc})") from None
