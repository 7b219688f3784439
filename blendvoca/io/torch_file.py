"""Reading and writing torch files (``.pt`` / ``.pth``): the one reader of every
checkpoint the project loads (the VAE, SyncNet, the sync expert, the baselines).

A path that names no file is a :class:`~blendvoca.errors.UserError`; a file that
torch cannot read (not a checkpoint, truncated, or holding objects that
``weights_only`` refuses) is a :class:`~blendvoca.errors.DataError`, or the subclass
the caller names; a write is atomic. torch is imported when a file is read or
written, so importing :mod:`blendvoca.io` does not import it.
"""

from __future__ import annotations

import os
from pathlib import Path

from blendvoca.errors import DataError, UserError
from blendvoca.io.atomic import atomic_write

__all__ = ["read_torch_file", "write_torch_file"]


def read_torch_file(path: str | os.PathLike, *, where: str, weights_only: bool = True, map_location="cpu",
                    error: type[DataError] = DataError):
    """The object stored in the torch file ``path``, its tensors on ``map_location``.

    Parameters
    ----------
    path : str or os.PathLike
        ``~`` is expanded.
    where : str
        Names the reader in the errors.
    weights_only : bool, default True
        ``torch.load``'s safe mode (tensors, containers, numbers, strings); False only
        for the project's own files that hold other objects (numpy arrays).
    map_location : default "cpu"
        As for ``torch.load``.
    error : type, default DataError
        The :class:`~blendvoca.errors.DataError` subclass raised for an unreadable file.

    Raises
    ------
    UserError
        No file at ``path``.
    DataError
        (or ``error``) A file torch cannot read.
    OSError
        The file exists but cannot be opened (permissions).
    """
    import torch

    path = Path(os.fspath(path)).expanduser()
    if not path.is_file():
        raise UserError(f"{where}: expected a file at {path}, not found")
    try:
        return torch.load(path, map_location=map_location, weights_only=weights_only)
    except OSError:
        raise
    except Exception as exc:  # noqa: BLE001 - torch raises many types (unpickling, zip, EOF) for a file that is no checkpoint
        raise error(f"{where}: {path} is not a readable torch checkpoint ({type(exc).__name__}: {exc})") from exc


def write_torch_file(path: str | os.PathLike, payload) -> Path:
    """Write ``payload`` with ``torch.save`` to ``path`` atomically (temporary file, then
    rename); parent folders are created and an interrupted write leaves ``path`` as it was."""
    import torch

    path = Path(os.fspath(path))
    with atomic_write(path, "wb") as handle:
        torch.save(payload, handle)
    return path
