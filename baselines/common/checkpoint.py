"""Checkpoint files of the baselines: reading and writing torch files, and the authors' state dicts.

:func:`load_checkpoint_file` and :func:`save_checkpoint_file` are the one way a
baseline reads or writes a ``.pt`` / ``.pth`` file: a path the user named that is
missing is a :class:`~blendvoca.errors.UserError`, a file torch cannot read a
:class:`~blendvoca.errors.DataError`, and a write is atomic. :func:`checkpoint_state`,
:func:`require_key`, :func:`count_layers` and :func:`load_into` read the authors'
released state dicts (FaceFormer, CodeTalker), whose wav2vec 2.0 part may be in the
layout of an older transformers version.
"""

from __future__ import annotations

import os
import pickle
import re
from pathlib import Path

import torch

from baselines.wav2vec2 import current_layout_state, legacy_layout_state
from blendvoca.errors import DataError, UserError

__all__ = ["checkpoint_state", "count_layers", "load_checkpoint_file", "load_into", "require_key",
           "save_checkpoint_file"]


def load_checkpoint_file(path: str | os.PathLike, *, where: str, weights_only: bool = True, map_location="cpu"):
    """The object stored in the torch file ``path``, its tensors on ``map_location`` (default the CPU).

    Parameters
    ----------
    path : str or os.PathLike
        ``~`` is expanded.
    where : str
        Names the reader in the errors.
    weights_only : bool, default True
        ``torch.load``'s safe mode (tensors, containers, numbers, strings); False for
        the project's own files that hold other objects (numpy arrays).
    map_location : default "cpu"
        As for ``torch.load``.

    Raises
    ------
    UserError
        No file at ``path``.
    DataError
        A file torch cannot read (not a checkpoint, truncated, or objects that
        ``weights_only`` refuses).
    """
    path = Path(os.fspath(path)).expanduser()
    if not path.is_file():
        raise UserError(f"{where}: expected a file at {path}, not found")
    try:
        return torch.load(path, map_location=map_location, weights_only=weights_only)
    except (pickle.UnpicklingError, EOFError, RuntimeError) as exc:  # what torch.load raises on a bad file
        raise DataError(f"{where}: cannot read {path} as a torch checkpoint: {exc}") from exc


def save_checkpoint_file(path: str | os.PathLike, payload) -> Path:
    """Write ``payload`` with ``torch.save`` to ``path`` atomically (temporary file, then rename).

    Parent folders are created; an interrupted write leaves ``path`` as it was.

    Returns
    -------
    Path
    """
    from blendvoca.io.atomic import atomic_write

    path = Path(os.fspath(path))
    with atomic_write(path, "wb") as handle:
        torch.save(payload, handle)
    return path


def checkpoint_state(path: str | os.PathLike, *, where: str) -> dict:
    """The ``state_dict`` stored in ``path`` (a plain one, or under ``"state_dict"``), ``module.`` prefixes removed.

    Raises
    ------
    UserError
        No file at ``path``.
    DataError
        The file holds no state dict of tensors.
    """
    payload = load_checkpoint_file(path, where=where)
    if isinstance(payload, dict) and isinstance(payload.get("state_dict"), dict):
        payload = payload["state_dict"]
    if not isinstance(payload, dict) or not all(isinstance(v, torch.Tensor) for v in payload.values()):
        raise DataError(f"{where}: expected a state_dict of tensors in {path}, got {type(payload).__name__}")
    return {(k[len("module."):] if k.startswith("module.") else k): v for k, v in payload.items()}


def count_layers(state: dict, prefix: str) -> int:
    """Number of layers ``<prefix><n>.*`` in ``state``: the largest ``n`` plus one (0 when there are none)."""
    pattern = re.compile(re.escape(prefix) + r"(\d+)\.")
    found = {int(m.group(1)) for k in state for m in [pattern.match(k)] if m}
    return max(found) + 1 if found else 0


def require_key(state: dict, key: str, where: str) -> torch.Tensor:
    """``state[key]``; a :class:`~blendvoca.errors.DataError` naming the key and a few present ones when missing."""
    if key not in state:
        raise DataError(f"{where}: expected key {key!r} in the authors' state_dict, not found "
                        f"(got {len(state)} keys, e.g. {sorted(state)[:5]})")
    return state[key]


def load_into(model: torch.nn.Module, state: dict, *, where: str) -> None:
    """``model.load_state_dict(state, strict=True)`` after matching the wav2vec 2.0 layout to the model's.

    Raises
    ------
    DataError
        Missing or unexpected keys, or tensors of other shapes than the model's.
    """
    wanted = model.state_dict()
    if any(k.endswith("parametrizations.weight.original0") for k in wanted):
        state = current_layout_state(state)
    else:
        state = legacy_layout_state(state)
    missing = sorted(set(wanted) - set(state))
    unexpected = sorted(set(state) - set(wanted))
    if missing or unexpected:
        raise DataError(f"{where}: the state_dict does not match the authors' architecture: "
                        f"missing {missing[:8]}{'...' if len(missing) > 8 else ''} ({len(missing)}), "
                        f"unexpected {unexpected[:8]}{'...' if len(unexpected) > 8 else ''} ({len(unexpected)})")
    bad = [(k, tuple(state[k].shape), tuple(v.shape)) for k, v in wanted.items() if state[k].shape != v.shape]
    if bad:
        raise DataError(f"{where}: shape mismatch (key, got, expected): {bad[:5]}")
    model.load_state_dict(state, strict=True)
