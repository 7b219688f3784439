"""Reading and writing torch files (``.pt`` / ``.pth``): the one reader of every
checkpoint the project loads (the VAE, SyncNet, the sync expert, the baselines).

Every file is read with ``torch.load(weights_only=True)``: tensors, containers,
numbers and strings come back, and a pickled Python object (a numpy array, a
function call) is refused before anything of it runs. So every file the project
writes holds only those types: :func:`write_torch_file` refuses anything else, and
:func:`safe_payload` turns numpy arrays and scalars into tensors and plain numbers
first.

A path that names no file is a :class:`~blendvoca.errors.UserError`; a file that
is no checkpoint (empty, truncated, random bytes, pickled objects that a safe load
refuses) is a :class:`~blendvoca.errors.DataError`, or the subclass the caller
names, whose message says what the file is not; a write is atomic. torch is
imported when a file is read or written, so importing :mod:`blendvoca.io` does
not import it.
"""

from __future__ import annotations

import os
import pickle
import re
import warnings
import zipfile
from pathlib import Path, PurePath

import numpy as np

from blendvoca.errors import DataError, UserError
from blendvoca.io.atomic import atomic_write

__all__ = ["REFUSED_OBJECTS", "read_torch_file", "safe_payload", "write_torch_file"]

#: The words every refusal of pickled objects carries (callers and tests match on them).
REFUSED_OBJECTS = "holds pickled Python objects"

#: Markers of torch's long advice texts, which say nothing about this file to a user.
_BOILERPLATE = ("file an issue", "Weights only load failed", "miniz", "torch.load", "weights_only")


def read_torch_file(path: str | os.PathLike, *, where: str, weights_only: bool = True, map_location="cpu",
                    error: type[DataError] = DataError, old_format_hint: str | None = None):
    """The object stored in the torch file ``path``, its tensors on ``map_location``.

    Parameters
    ----------
    path : str or os.PathLike
        ``~`` is expanded.
    where : str
        Names the reader in the errors.
    weights_only : bool, default True
        ``torch.load``'s safe mode (tensors, containers, numbers, strings). False
        runs whatever the file's pickle asks for: only the checkpoint converter
        passes it, for a file its user declared trusted.
    map_location : default "cpu"
        As for ``torch.load``.
    error : type, default DataError
        The :class:`~blendvoca.errors.DataError` subclass raised for an unreadable file.
    old_format_hint : str, optional
        Added to the message when the file holds pickled numpy objects, as the
        project's checkpoints of earlier versions did (how to convert them).

    Raises
    ------
    UserError
        No file at ``path``.
    DataError
        (or ``error``) A file torch cannot read, or one holding objects that a safe
        load refuses; the message names the file and what it is not.
    OSError
        The file exists but cannot be opened (permissions).
    """
    import torch

    path = Path(os.fspath(path)).expanduser()
    if not path.is_file():
        raise UserError(f"{where}: expected a file at {path}, not found")
    try:
        with warnings.catch_warnings():
            # torch warns about pickle protocols it did not write, asking to "file an issue";
            # whether the file is readable is said by the error below, once
            warnings.filterwarnings("ignore", message=".*pickle protocol.*")
            return torch.load(path, map_location=map_location, weights_only=weights_only)
    except OSError:
        raise
    except Exception as exc:  # noqa: BLE001 - torch raises many types (unpickling, zip, EOF) for a file that is no checkpoint
        raise error(f"{where}: {path} is not a readable torch checkpoint: "
                    f"{_what_it_is(path, exc, old_format_hint)}") from None


def _what_it_is(path: Path, exc: Exception, old_format_hint: str | None) -> str:
    """What the file ``path`` is, given the exception torch raised on it, in a few words."""
    text = str(exc)
    refused = re.search(r"GLOBAL ([\w.]+)", text)
    if refused:
        name = refused.group(1)
        said = f"it {REFUSED_OBJECTS} ({name}), which a safe load refuses: nothing of it was run"
        if name.split(".")[0] == "numpy":
            return f"{said}; {old_format_hint}" if old_format_hint else said
        return f"{said} (loading it would call {name}; do not use a file of unknown origin)"
    size = path.stat().st_size
    if size == 0:
        return "the file is empty"
    with open(path, "rb") as handle:
        head = handle.read(4)
    if head == b"PK\x03\x04":
        if not zipfile.is_zipfile(path):
            return "a damaged zip archive (truncated, or an incomplete copy?)"
        return "a zip archive whose members are not a torch checkpoint's (damaged?)"
    if isinstance(exc, EOFError):
        return "the data ends early (truncated?)"
    reason = ""
    operand = re.search(r"Unsupported operand (\d+)", text)
    if operand:
        reason = f" (byte {operand.group(1)} is no pickle instruction a safe load reads)"
    elif isinstance(exc, pickle.UnpicklingError) and text and not any(b in text for b in _BOILERPLATE):
        reason = f" ({text.splitlines()[0][:120]})"
    return f"neither a torch zip archive nor a legacy torch file{reason}"


def safe_payload(value, *, where: str = "payload"):
    """``value`` with every numpy array made a tensor (same dtype and values), every
    numpy scalar a Python number and every path a string, tuples kept: what
    ``torch.load(weights_only=True)`` reads back.

    Parameters
    ----------
    value : object
        Dicts, lists, tuples, tensors, numpy arrays and scalars, str, int, float,
        bool, None.
    where : str
        Names the payload in the error.

    Raises
    ------
    TypeError
        Another type, named with its key path (such an object would need pickle).
    """
    import torch

    def convert(item, key):
        if isinstance(item, np.ndarray):
            if item.dtype == object:
                raise TypeError(f"{where}: {key} is an object array; expected numbers")
            return torch.from_numpy(np.ascontiguousarray(item))
        if isinstance(item, np.generic):
            return item.item()
        if isinstance(item, PurePath):
            return str(item)
        if isinstance(item, dict):
            pairs = [(k, v, convert(v, f"{key}[{k!r}]")) for k, v in item.items()]
            if all(new is old for _, old, new in pairs):
                return item  # unchanged, with what it carries (a state_dict's _metadata)
            return type(item)((k, new) for k, _, new in pairs)
        if isinstance(item, (list, tuple)) and not isinstance(item, torch.Size):
            return type(item)(convert(v, f"{key}[{i}]") for i, v in enumerate(item))
        _check_safe(item, key, where)
        return item

    return convert(value, "payload")


def _check_safe(item, key: str, where: str) -> None:
    """TypeError unless ``item`` is a leaf that ``torch.load(weights_only=True)`` reads."""
    import torch

    if item is None or isinstance(item, (str, bytes, bool, int, float, torch.Tensor, torch.dtype, torch.Size,
                                         torch.device)):
        return
    raise TypeError(f"{where}: {key} is a {type(item).__module__}.{type(item).__qualname__}, which a safe load "
                    "refuses; store tensors, numbers, strings, lists and dicts only")


def _check_tree(value, key: str, where: str) -> None:
    """:func:`_check_safe` on every leaf of ``value`` (dicts, lists, tuples)."""
    if isinstance(value, dict):
        for k, v in value.items():
            if not isinstance(k, (str, int)):
                raise TypeError(f"{where}: {key} has a key of type {type(k).__name__}; expected str or int keys")
            _check_tree(v, f"{key}[{k!r}]", where)
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            _check_tree(v, f"{key}[{i}]", where)
    else:
        _check_safe(value, key, where)


def write_torch_file(path: str | os.PathLike, payload) -> Path:
    """Write ``payload`` with ``torch.save`` to ``path`` atomically (temporary file, then
    rename); parent folders are created and an interrupted write leaves ``path`` as it was.

    Raises
    ------
    TypeError
        ``payload`` holds something that ``weights_only=True`` would refuse (a numpy
        array: convert with :func:`safe_payload`); nothing is written.
    """
    import torch

    path = Path(os.fspath(path))
    _check_tree(payload, "payload", f"write_torch_file {path}")
    with atomic_write(path, "wb") as handle:
        torch.save(payload, handle)
    return path
