"""Reading JSON files a user brings (manifests, splits, result files, sidecars, exported
tracks): the one reader that turns every way such a file can be broken into a
:class:`~blendvoca.errors.DataError` naming the file."""

from __future__ import annotations

import json
import os
from pathlib import Path

from blendvoca.errors import DataError

__all__ = ["json_kind", "read_json"]


def read_json(path: str | os.PathLike, *, what: str = "a JSON file", error: type[DataError] = DataError) -> object:
    """The JSON document of ``path``, whatever its top-level type.

    Parameters
    ----------
    path : str or os.PathLike
    what : str
        What the file should be, for the message: ``"<path>: not <what> (<reason>)"``.
    error : type, default DataError
        The :class:`~blendvoca.errors.DataError` subclass to raise.

    Raises
    ------
    DataError
        (or ``error``) The file is not UTF-8, not JSON (line and column given), holds an
        integer longer than Python converts, or nests deeper than Python can parse.
    OSError
        The file cannot be read.
    """
    path = Path(os.fspath(path))
    data = path.read_bytes()
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{path}: not {what} (not UTF-8 text: {exc.reason} at byte {exc.start})") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise error(f"{path}: not {what} (line {exc.lineno}, column {exc.colno}: {exc.msg})") from None
    except ValueError:  # json's one other ValueError: an integer past sys.get_int_max_str_digits()
        raise error(f"{path}: not {what} (a number with more digits than Python reads)") from None
    except RecursionError:
        raise error(f"{path}: not {what} (nested too deeply to parse)") from None


def json_kind(value) -> str:
    """What a parsed JSON value is, in JSON's words: ``null``, ``a boolean``, ``a number``,
    ``a string``, ``a list``, ``an object`` (else the Python type's name)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return "a number"
    return {str: "a string", list: "a list", dict: "an object"}.get(type(value), type(value).__name__)
