"""Reading one ``.npy`` array a user brings, refusing anything else with a DataError.

``numpy.load`` raises what the bytes lead it to (``ValueError``, ``EOFError``,
``UnicodeError``, ``zipfile.BadZipFile`` for a file that starts like a zip) and returns an
``NpzFile`` for an archive; :func:`read_array` turns all of these into one
:class:`~blendvoca.errors.DataError` naming the file and what it should hold. Pickled
(object) arrays are never loaded.
"""

from __future__ import annotations

import os
import warnings
import zipfile
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError


def read_array(path, *, what: str, kinds: str = "fiu", encoding: str = "ASCII") -> np.ndarray:
    """The array of the ``.npy`` file ``path`` whose dtype kind is one of ``kinds``.

    Parameters
    ----------
    path : str or os.PathLike
    what : str
        What the array holds, for messages (``"weights"``).
    kinds : str
        The accepted :attr:`numpy.dtype.kind` letters (numbers by default; ``"US"`` for names).
    encoding : str
        How Python 2's strings are read (``numpy.load``'s ``encoding``).

    Raises
    ------
    DataError
        The file cannot be read (missing, a folder, no permission), is not a ``.npy`` file,
        is an archive, pickled data, or an array of another kind.
    """
    path = Path(os.fspath(path))
    try:
        with warnings.catch_warnings():  # "created on Python 2"
            warnings.simplefilter("ignore", UserWarning)
            array = np.load(path, allow_pickle=False, encoding=encoding)
    except OSError as error:
        raise DataError(f"{path}: not readable ({error.strerror or error}); expected a .npy array of {what}") from None
    except (ValueError, EOFError, UnicodeError, zipfile.BadZipFile) as error:
        raise DataError(f"{path}: not a readable .npy array of {what} ({type(error).__name__}: {error})") from None
    if not isinstance(array, np.ndarray):
        close = getattr(array, "close", None)
        if close is not None:
            close()
        raise DataError(f"{path}: an .npz archive; expected a .npy array of {what}")
    if array.dtype.kind not in kinds:
        raise DataError(f"{path}: an array of {array.dtype} of shape {array.shape}; expected {what}")
    return array
