"""What the export formats share besides column alignment (private): reading a JSON
file as a :class:`~blendvoca.errors.DataError` when it does not parse, and importing
a format's optional dependency with an install hint."""

from __future__ import annotations

import importlib
import json
import os
from pathlib import Path
from types import ModuleType

from blendvoca.errors import DataError, UserError


def read_json(path) -> dict:
    """The JSON document of ``path`` (str or os.PathLike).

    Raises
    ------
    DataError
        The file is not UTF-8 JSON (naming the file, line and column).
    """
    path = Path(os.fspath(path))
    with open(path, encoding="utf-8") as f:
        try:
            return json.load(f)
        except json.JSONDecodeError as error:
            raise DataError(f"{path}: not a JSON file (line {error.lineno}, column {error.colno}: "
                            f"{error.msg})") from None
        except UnicodeDecodeError as error:
            raise DataError(f"{path}: not a UTF-8 text file ({error.reason} at byte {error.start})") from None


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
