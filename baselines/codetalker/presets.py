"""CodeTalker presets and flat overrides.

``cpu-demo`` shrinks both stages (VQ-VAE hidden 64 = 4 codes x 16, one transformer
layer each; stage-2 width 64, log-mel front end) to train on 2 CPU cores in minutes,
the budget split between the stages; its stage 2 is fed its own predictions
(``own_input_prob``) and keeps the weights by free-running validation
(``val_free_running``), two departures from the authors' teacher forcing. ``paper`` is the authors' VOCASET setup
(config/vocaset/stage1.yaml and stage2.yaml: VQ-VAE 1024 wide, 6+6 layers, 256 codes of
64, 16 per frame, AdamW 1e-4 for 200 epochs with the rate halved every 20; stage 2
1024 wide, 6 layers, Adam 1e-4 for 100 epochs, wav2vec 2.0 base-960h from a local
directory) and wants a GPU.
"""

from __future__ import annotations

from baselines.common.chunking import chunk_section
from baselines.common.presets import resolved_preset

__all__ = ["HELP", "PREFIXES", "PRESETS", "resolve_config"]

#: The flat-key prefix of a section's keys: ``vq_hidden_size`` sets ``stage1.hidden_size``.
PREFIXES = {"stage1": "vq_"}

PRESETS = {
    "cpu-demo": {
        "inference": chunk_section(),
        "stage1": {"hidden_size": 64, "num_hidden_layers": 1, "num_attention_heads": 4, "intermediate_size": 128,
                   "face_quan_num": 4, "zquant_dim": 16, "n_embed": 128},
        "model": {"feature_dim": 64, "period": 30, "n_head": 4, "num_layers": 1, "dropout": 0.1,
                  "audio": {"kind": "logmel", "n_mels": 80, "hidden_size": 64, "layers": 3, "kernel": 5}},
        "training": {"stage1_lr": 1e-3, "stage1_epochs": None, "stage1_step_epochs": None, "stage1_fraction": 0.4,
                     "lr": 1e-3, "max_epochs": None, "max_steps": 4000, "max_seconds": 300.0,
                     "quant_loss_weight": 1.0, "motion_scale": 100.0, "num_threads": 1, "grad_clip": 1.0,
                     "own_input_prob": 1.0, "val_free_running": True},
        "wav2vec2_path": None,
    },
    "paper": {
        "inference": chunk_section(),
        "stage1": {"hidden_size": 1024, "num_hidden_layers": 6, "num_attention_heads": 8, "intermediate_size": 1536,
                   "face_quan_num": 16, "zquant_dim": 64, "n_embed": 256},
        "model": {"feature_dim": 1024, "period": 30, "n_head": 4, "num_layers": 6, "dropout": 0.1,
                  "audio": {"kind": "wav2vec2", "config": "base"}},
        "training": {"stage1_lr": 1e-4, "stage1_epochs": 200, "stage1_step_epochs": 20, "stage1_fraction": None,
                     "lr": 1e-4, "max_epochs": 100, "max_steps": None, "max_seconds": None,
                     "quant_loss_weight": 1.0, "motion_scale": 1.0, "num_threads": None, "grad_clip": None,
                     "own_input_prob": 0.0, "val_free_running": False},
        "wav2vec2_path": "${BLENDVOCA_WAV2VEC2:-~/models/wav2vec2-base-960h}",
    },
}


#: One sentence per flat key (``benchmark.run --method codetalker --list-config``), besides the shared ones.
HELP = {
    "vq_hidden_size": "width of the stage-1 VQ-VAE's transformers",
    "vq_num_hidden_layers": "transformer layers of the VQ-VAE's encoder and of its decoder",
    "vq_num_attention_heads": "attention heads of the VQ-VAE",
    "vq_intermediate_size": "feed-forward width of the VQ-VAE's transformer layers",
    "vq_face_quan_num": "codes per frame",
    "vq_zquant_dim": "size of one code vector",
    "vq_n_embed": "entries of the codebook",
    "stage1_lr": "learning rate of stage 1 (the VQ-VAE)",
    "stage1_epochs": "epochs of stage 1 (null: by the budget's share, stage1_fraction)",
    "stage1_step_epochs": "epochs between halvings of the stage-1 learning rate (null: constant)",
    "stage1_fraction": "share of the step or time budget given to stage 1",
    "lr": "learning rate of stage 2 (speech to codes)",
    "quant_loss_weight": "weight of the codebook (quantisation) loss in stage 1",
    "own_input_prob": "probability that stage 2 is fed its own predictions instead of the ground truth",
    "val_free_running": "keep the stage-2 weights that validate best running free (not teacher-forced)",
}


def resolve_config(preset: str, **overrides) -> dict:
    """The nested config of ``preset`` with flat overrides (``vq_<key>`` for the VQ-VAE's keys;
    :func:`baselines.common.presets.resolved_preset`)."""
    return resolved_preset(PRESETS, preset, overrides, method="CodeTalker", prefixes=PREFIXES)
