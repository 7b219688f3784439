"""FaceFormer presets and flat overrides.

``cpu-demo`` trains in minutes on 2 CPU cores: the authors' decoder width (64) with
the log-mel front end instead of wav2vec 2.0 and a larger learning rate.
``paper`` is the authors' VOCASET setup (wav2vec 2.0 base-960h initialised from a
local ``from_pretrained`` directory, Adam 1e-4, batch 1, 100 epochs) and wants a GPU.
"""

from __future__ import annotations

from baselines.common.chunking import chunk_section
from baselines.common.presets import resolved_preset

__all__ = ["HELP", "PRESETS", "resolve_config"]

PRESETS = {
    "cpu-demo": {
        "inference": chunk_section(),
        "model": {"feature_dim": 64, "period": 30, "n_head": 4, "num_layers": 1, "dropout": 0.1,
                  "audio": {"kind": "logmel", "n_mels": 80, "hidden_size": 64, "layers": 3, "kernel": 5}},
        "training": {"lr": 1e-3, "max_steps": 4000, "max_seconds": 240.0, "max_epochs": None,
                     "motion_scale": 100.0, "num_threads": 1, "grad_clip": 1.0},
        "wav2vec2_path": None,
    },
    "paper": {
        "inference": chunk_section(),
        "model": {"feature_dim": 64, "period": 30, "n_head": 4, "num_layers": 1, "dropout": 0.1,
                  "audio": {"kind": "wav2vec2", "config": "base"}},
        "training": {"lr": 1e-4, "max_steps": None, "max_seconds": None, "max_epochs": 100,
                     "motion_scale": 1.0, "num_threads": None, "grad_clip": None},
        "wav2vec2_path": "${BLENDVOCA_WAV2VEC2:-~/models/wav2vec2-base-960h}",
    },
}


#: FaceFormer's flat keys are the shared ones (:data:`baselines.common.presets.COMMON_HELP`).
HELP: dict = {}


def resolve_config(preset: str, presets: dict = PRESETS, **overrides) -> dict:
    """The nested config of ``preset`` with flat ``overrides`` (model, training, inference or
    top-level keys; :func:`baselines.common.presets.resolved_preset`)."""
    return resolved_preset(presets, preset, overrides, method="FaceFormer")
