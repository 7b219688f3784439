"""Checkpoint files of the baselines: reading and writing torch files, and the authors' state dicts.

:func:`load_checkpoint_file` and :func:`save_checkpoint_file` (the project's torch
file reader and writer, :mod:`blendvoca.io.torch_file`, under the names the baselines
use) are the one way a baseline reads or writes a ``.pt`` / ``.pth`` file: a path the
user named that is missing is a :class:`~blendvoca.errors.UserError`, a file torch
cannot read a :class:`~blendvoca.errors.DataError`, and a write is atomic. :func:`checkpoint_state`,
:func:`require_key`, :func:`count_layers` and :func:`load_into` read the authors'
released state dicts (FaceFormer, CodeTalker), whose wav2vec 2.0 part may be in the
layout of an older transformers version.

Every checkpoint a baseline writes holds tensors, numbers, strings, lists and dicts
only (numpy arrays are stored as tensors, :func:`safe_payload`, and turned back on
loading), next to the method's JSON config; it is read with ``weights_only=True``, so
a file cannot run code. A checkpoint of an earlier version, which pickled numpy
arrays, is refused with :func:`old_format_hint`: the one-time converter
``python -m benchmark.methods.convert_checkpoint OLD NEW --trust``.
:func:`baselines.common.npz_file.read_npz_arrays` reads a method's ``.npz`` file
without pickle.
"""

from __future__ import annotations

import os
import re

import torch

from baselines.wav2vec2 import current_layout_state, legacy_layout_state
from blendvoca.errors import DataError
from blendvoca.io.torch_file import read_torch_file as load_checkpoint_file
from blendvoca.io.torch_file import safe_payload
from blendvoca.io.torch_file import write_torch_file as save_checkpoint_file

__all__ = ["CONVERTER", "checkpoint_state", "count_layers", "load_checkpoint_file", "load_into", "old_format_hint",
           "require_key", "safe_payload", "save_checkpoint_file"]

#: The command that rewrites a checkpoint of an earlier version in the safe format.
CONVERTER = "python -m benchmark.methods.convert_checkpoint"


def old_format_hint(path: str | os.PathLike) -> str:
    """What to do with ``path``, a checkpoint (file or folder) an earlier version wrote
    with pickled numpy arrays: convert it once, knowingly."""
    return (f"a checkpoint of an earlier BlendVOCA version? If you trust where it came from, convert it once with "
            f"`{CONVERTER} {os.fspath(path)} NEW --trust` and use NEW")


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
