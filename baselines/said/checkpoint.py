"""Saving and loading SAiD checkpoints (config, column names, weights, training history)."""

from __future__ import annotations

import os
from pathlib import Path

import torch

from blendvoca.io.atomic import atomic_write

FORMAT = "blendvoca-said/1"


def _stored_state(model) -> dict[str, torch.Tensor]:
    # Pretrained or deterministic encoders are rebuilt from their spec; only the
    # random-init test encoder carries weights that the spec does not determine.
    keep_encoder = model.encoder_spec.get("kind") == "wav2vec2-tiny"
    return {k: v.detach().cpu().clone() for k, v in model.state_dict().items() if keep_encoder or not k.startswith("encoder.")}


def save_checkpoint(path: str | os.PathLike, model, config: dict, names: tuple[str, ...], history: dict | None = None) -> Path:
    """Write a checkpoint file atomically (temporary file + rename).

    Parameters
    ----------
    path : path-like
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
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    payload = {"format": FORMAT, "config": config, "names": list(names), "state_dict": _stored_state(model), "history": history or {}}
    with atomic_write(path, "wb") as handle:
        torch.save(payload, handle)
    return path


def read_checkpoint(path: str | os.PathLike) -> dict:
    """Return the raw checkpoint payload ``{"format", "config", "names", "state_dict", "history"}``.

    Raises
    ------
    ValueError
        If the file is missing or is not a SAiD checkpoint.
    """
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"SAiD checkpoint: expected a file at {path}, found none")
    payload = torch.load(path, map_location="cpu", weights_only=True)
    if not isinstance(payload, dict) or payload.get("format") != FORMAT:
        raise ValueError(f"SAiD checkpoint: expected format {FORMAT!r} in {path}, got {payload.get('format') if isinstance(payload, dict) else type(payload).__name__!r}")
    return payload
