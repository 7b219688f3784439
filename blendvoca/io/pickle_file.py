"""Plain-data pickles: the processed VOCASET layout's ``*.pkl`` files and a build's
``blendshape_residuals.pickle``, read without running any code they could name.

A pickle can name any importable callable and run it while loading, so these files
are read by an unpickler that allows only numpy's array and scalar reconstruction
(numpy 1 and 2 module paths), plain containers and the bytes codec
(:data:`_ALLOWED_GLOBALS`); anything else is refused with the file's name.
"""

from __future__ import annotations

import builtins
import copyreg
import pickle
from pathlib import Path

from blendvoca.errors import DataError

__all__ = ["UnsafePickleError", "load_data_pickle"]


class UnsafePickleError(DataError):
    """A pickle that is not plain data (names a class or function outside the allowed list) or does not parse."""


#: The only globals a plain-data pickle may name: numpy's array and scalar
#: reconstruction (numpy 1 and 2 module paths), plain containers and the bytes codec.
_ALLOWED_GLOBALS = {
    ("numpy.core.multiarray", "_reconstruct"), ("numpy._core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "scalar"), ("numpy._core.multiarray", "scalar"),
    ("numpy", "ndarray"), ("numpy", "dtype"),
    ("collections", "OrderedDict"), ("builtins", "set"), ("builtins", "frozenset"), ("builtins", "complex"),
    ("copy_reg", "_reconstructor"), ("copyreg", "_reconstructor"),
    ("builtins", "object"), ("__builtin__", "object"),
    ("_codecs", "encode"),  # how protocol 2 stores bytes (an array's buffer)
}


class _DataUnpickler(pickle.Unpickler):
    def __init__(self, file, where):
        super().__init__(file, encoding="latin1")
        self._where = where

    def find_class(self, module, name):
        if (module, name) not in _ALLOWED_GLOBALS:
            raise UnsafePickleError(
                f"{self._where}: refusing to load {module}.{name}: plain-data pickles hold only dicts, lists, "
                "numbers, strings and numpy arrays (a pickle naming other classes or functions could run code)"
            )
        if module in ("copy_reg", "copyreg"):
            return copyreg._reconstructor
        if module in ("builtins", "__builtin__"):
            return getattr(builtins, name)
        return super().find_class(module, name)


def load_data_pickle(path):
    """Load a pickle allowing only plain data (see :data:`_ALLOWED_GLOBALS`).

    Raises
    ------
    UnsafePickleError
        The pickle names anything else, or is truncated or corrupted (naming the file).
    """
    path = Path(path)
    with open(path, "rb") as f:
        try:
            obj = _DataUnpickler(f, path).load()
        except UnsafePickleError:
            raise
        except Exception as error:  # truncated / corrupted: EOFError, UnpicklingError, ValueError, ...
            raise UnsafePickleError(f"{path}: not a readable pickle ({type(error).__name__}: {error})") from None
    return obj
