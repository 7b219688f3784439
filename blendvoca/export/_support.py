"""What the export formats share besides column alignment (private): reading a JSON
file and checking the shape of its values as :class:`~blendvoca.errors.DataError`\\ s
that name the file, turning a third-party parser's failures into one, and importing a
format's optional dependency with an install hint."""

from __future__ import annotations

import contextlib
import importlib
import json
import math
from collections.abc import Iterator
from types import ModuleType

import numpy as np

from blendvoca.errors import BlendVOCAError, DataError, UserError
from blendvoca.io.atomic import atomic_write
from blendvoca.io.json_file import json_kind, read_json


def read_json_object(path, what: str, required: tuple[str, ...] = ()) -> dict:
    """The JSON object (a dict) of ``path`` holding the ``required`` keys; ``what`` names
    the format for the error.

    Raises
    ------
    DataError
        As :func:`blendvoca.io.json_file.read_json`, or the document is not an object,
        or it lacks a required key (naming the first).
    """
    doc = read_json(path)
    if not isinstance(doc, dict):
        raise DataError(f"{path}: not {what}: the document is {json_kind(doc)}, expected an object")
    for key in required:
        if key not in doc:
            raise DataError(f"{path}: not {what}: missing key {key!r}")
    return doc


def write_json_document(path, doc: dict, **dump_options) -> None:
    """Write ``doc`` as JSON to ``path`` atomically (``dump_options`` as for :func:`json.dump`)."""
    with atomic_write(path, "w", encoding="utf-8") as f:
        json.dump(doc, f, **dump_options)


def _finite(value) -> float | None:
    """``value`` as a finite float, or None when it is not a finite JSON number."""
    # bool is an int in Python, but a JSON boolean is no number
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return None
    try:
        number = float(value)
    except OverflowError:  # an integer beyond float's range
        return None
    return number if math.isfinite(number) else None


def positive_number(doc: dict, key: str, path) -> float:
    """``doc[key]`` as a finite positive float (a frame rate).

    Raises
    ------
    DataError
        Naming the file and the key: not a number, not finite or not positive.
    """
    value = doc[key]
    number = _finite(value)
    if number is None or number <= 0:
        raise DataError(f"{path}: {key!r} is {_shown(value)}, expected a finite positive number")
    return number


def count(doc: dict, key: str, path) -> int:
    """``doc[key]`` as a non-negative int (``3`` and ``3.0`` both count).

    Raises
    ------
    DataError
        Naming the file and the key: not a whole non-negative number.
    """
    value = doc[key]
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if not isinstance(value, int) or isinstance(value, bool) or value < 0:
        raise DataError(f"{path}: {key!r} is {_shown(value)}, expected a whole number >= 0")
    return value


def string_list(doc: dict, key: str, path) -> tuple[str, ...]:
    """``doc[key]`` as a tuple of str.

    Raises
    ------
    DataError
        Naming the file, the key and the first entry that is not a string.
    """
    value = doc[key]
    if not isinstance(value, list):
        raise DataError(f"{path}: {key!r} is {json_kind(value)}, expected a list of names")
    for index, item in enumerate(value):
        if not isinstance(item, str):
            raise DataError(f"{path}: {key!r} entry {index} is {json_kind(item)}, expected a name (a string)")
    return tuple(value)


def weight_matrix(doc: dict, key: str, names: tuple[str, ...], path) -> np.ndarray:
    """``doc[key]``, one list of ``len(names)`` finite numbers per frame, as ``(T, K)`` float64.

    Raises
    ------
    DataError
        Naming the file, the key, and the first frame (and column) that is not a list of
        the right length or not a finite number.
    """
    rows = doc[key]
    if not isinstance(rows, list):
        raise DataError(f"{path}: {key!r} is {json_kind(rows)}, expected one list of weights per frame")
    out = np.empty((len(rows), len(names)), dtype=np.float64)
    for t, row in enumerate(rows):
        if not isinstance(row, list):
            raise DataError(f"{path}: {key!r} frame {t} is {json_kind(row)}, expected a list of {len(names)} weights")
        if len(row) != len(names):
            raise DataError(f"{path}: frame {t} has {len(row)} weights, expected {len(names)} (one per name)")
        for k, value in enumerate(row):
            number = _finite(value)
            if number is None:
                raise DataError(f"{path}: frame {t}, {names[k]!r}: weight {_shown(value)} is not a finite number")
            out[t, k] = number
    return out


@contextlib.contextmanager
def foreign_parser(path, what: str) -> Iterator[None]:
    """Turn what a third-party parser raises on a damaged file into a :class:`DataError`.

    The project's own errors pass through, and so does an ``OSError`` that carries an
    OS condition (a permission, a missing file: the command-line layer reports those
    against the path); ``MemoryError`` is not the file's fault and passes too.
    """
    try:
        yield
    except (BlendVOCAError, MemoryError):
        raise
    except OSError as error:
        if error.errno is not None:
            raise
        raise DataError(f"{path}: not a readable {what} ({_brief(error)})") from error
    except Exception as error:  # noqa: BLE001 - parsers of binary formats raise many types on junk
        raise DataError(f"{path}: not a readable {what} ({_brief(error)})") from error


def _shown(value) -> str:
    """A JSON value for a message: a container by its kind, anything else by its (cut) ``repr``."""
    return _short(json_kind(value) if isinstance(value, (list, dict)) else repr(value))


def _short(text: str, limit: int = 80) -> str:
    """``text`` cut to ``limit`` characters (a value from a file may be a 4000-digit number)."""
    return text if len(text) <= limit else text[:limit] + "..."


def _brief(error: BaseException) -> str:
    """The error's type and the first line of its message, cut to a readable length."""
    try:
        lines = str(error).strip().splitlines()
    except Exception:  # noqa: BLE001 - pxr's errors fail str() on a message that is not UTF-8
        lines = []
    text = lines[0].strip() if lines else ""
    if text.startswith("Error in '") and " : " in text:
        # pxr's "Error in '<C++ function>' at line N in file <header> : <message>"
        text = text.split(" : ", 1)[1].strip("'")
    kind = type(error).__name__
    if type(error).__module__ not in ("builtins", "__main__"):
        kind = f"{type(error).__module__}.{kind}"  # struct.error says more than "error"
    return f"{kind}: {_short(text, 200)}" if text else kind


def optional_module(module: str, package: str, what: str) -> ModuleType:
    """Import ``module`` for ``what`` (e.g. ``"the usd format"``) or say which package to install.

    Raises
    ------
    UserError
        ``module`` is not installed: names ``package`` and the ``blendvoca[export]`` extra.
    """
    try:
        return importlib.import_module(module)
    except ImportError as error:
        raise UserError(f"{what} needs {package}, which is not installed here ({error}): "
                        f"pip install {package}  (or pip install 'blendvoca[export]')") from None
