"""Saving and loading SAiD checkpoints (config, column names, weights, training history)."""

from __future__ import annotations

import os
from pathlib import Path

import torch

from baselines.common.checkpoint import load_checkpoint_file, old_format_hint, safe_payload, save_checkpoint_file
from blendvoca.errors import DataError

FORMAT = "blendvoca-said/1"


def _stored_state(model) -> dict[str, torch.Tensor]:
    # Pretrained or deterministic encoders are rebuilt from their spec; only the
    # random-init test encoder carries weights that the spec does not determine.
    keep_encoder = model.encoder_spec.get("kind") == "wav2vec2-tiny"
    return {k: v.detach().cpu().clone() for k, v in model.state_dict().items() if keep_encoder or not k.startswith("encoder.")}


def save_checkpoint(path: str | os.PathLike, model, config: dict, names: tuple[str, ...], history: dict | None = None) -> Path:
    """Write a checkpoint file atomically (temporary file + rename): tensors, numbers,
    strings, lists and dicts only, so that it loads with ``weights_only=True``.

    Parameters
    ----------
    path : str or os.PathLike
        Target file (``.pt``); parent directories are created.
    model : baselines.said.model.SAiDModel
    config : dict
        Nested config from :func:`baselines.said.presets.resolve_config`.
    names : tuple of str
        Column names of the coefficient tracks, ``(K,)``.
    history : dict, optional
        Training history (losses), JSON-able.

    Returns
    -------
    path : Path
    """
    payload = {"format": FORMAT, "config": config, "names": list(names), "state_dict": _stored_state(model), "history": history or {}}
    return save_checkpoint_file(path, safe_payload(payload, where=f"SAiD checkpoint {os.fspath(path)}"))


def read_checkpoint(path: str | os.PathLike) -> dict:
    """Return the raw checkpoint payload ``{"format", "config", "names", "state_dict", "history"}``.

    Raises
    ------
    UserError
        If the file is missing.
    DataError
        If it is not a SAiD checkpoint.
    """
    path = Path(os.fspath(path))
    payload = load_checkpoint_file(path, where="SAiD checkpoint", old_format_hint=old_format_hint(path))
    if not isinstance(payload, dict) or payload.get("format") != FORMAT:
        got = payload.get("format") if isinstance(payload, dict) else type(payload).__name__
        raise DataError(f"SAiD checkpoint: expected format {FORMAT!r} in {path}, got {got!r}")
    return payload
