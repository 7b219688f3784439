"""Presets of CDFace and flat overrides of them.

``cpu-demo`` (default) trains in a few minutes on 2 CPU cores: log-mel audio
features (no pretrained weights), small transformers, motion in millimetres,
windows of 48 frames, each stage bounded in seconds (120 + 120 + 360), and one
departure from the paper, past dropout (docs/cdface.md). ``paper`` follows the
paper where it says (wav2vec 2.0 audio encoder, N^l = 5 lip samples, the VOCASET
loss weights and epsilon, 200 VQ epochs and 50 querying epochs, AdamW, motion in
metres) and CodeTalker's VOCASET sizes where it does not (the paper builds its
priors on CodeTalker's and gives no sizes); it wants a GPU.
"""

from __future__ import annotations

from baselines.common.presets import resolved_preset
from baselines.common.chunking import chunk_section

DEFAULT_PRESET = "cpu-demo"

PRESETS: dict[str, dict[str, dict]] = {
    "cpu-demo": {
        "inference": chunk_section(),
        "model": {
            "encoder": {"kind": "logmel", "n_mels": 80},
            # displacements are multiplied by this inside the model (1000: millimetres)
            "motion_scale": 1000.0,
            # model only the vertices whose displacement std exceeds this (metres) in training
            "active_threshold": 1e-5,
            "vq_hidden": 64, "vq_layers": 1, "vq_heads": 4, "num_codes": 4, "code_dim": 16,
            "codebook_size": 64, "vq_half_width": 4,
            "width": 64, "query_layers": 1, "heads": 4, "audio_layers": 1, "audio_self_half_width": 30,
            "self_context": 60, "audio_half_width": 2, "period": 60,
            "num_lip_samples": 5, "num_upper_samples": 5, "dropout": 0.0,
            # past lips the upper face reads in training: "ground-truth" (teacher forcing)
            # or "predicted" (each lip sample's own output, N^l times the cost)
            "upper_context": "ground-truth",
        },
        "loss": {
            # Eq. 15/16 weights as the paper's VOCASET setting
            "lambda_d_lips": 0.02, "lambda_d_upper": 0.02, "lambda_rc_lips": 1.0, "lambda_rc_upper": 1.0,
            "lambda_rg": 1.0,
            # the synthetic corpus opens the mouth less than VOCASET (at most ~13 mm):
            # 3.5 mm keeps every bilabial closure of its ground truth in the mask
            "epsilon": 0.0035,
        },
        "training": {
            "window": 48, "batch_size": 2, "vq_batch_size": 8, "lr": 1e-3, "weight_decay": 1e-2, "grad_clip": 1.0,
            # "constant", or "cosine": each stage decays lr to 0 on a half cosine
            "lr_schedule": "constant",
            "vq_epochs": None, "query_epochs": None,
            "vq_max_steps": 4000, "query_max_steps": 4000,
            # seconds per stage: lip prior, upper-face prior, code querying
            "vq_max_seconds": 120.0, "query_max_seconds": 360.0,
            # zero a frame's ground-truth past with this probability (not in the paper): a
            # short teacher-forced run otherwise leans on the past, and its own rollout
            # drifts from it (0.5: lip error 3.1-3.7 mm per sample; 0.9: 2.4 mm, docs/cdface.md)
            "past_dropout": 0.9,
            "num_threads": 1,
        },
    },
    "paper": {
        "inference": chunk_section(),
        "model": {
            "encoder": {"kind": "wav2vec2", "path": "${BLENDVOCA_WAV2VEC2:-~/models/wav2vec2-base-960h}"},
            "motion_scale": 1.0,
            "active_threshold": None,
            "vq_hidden": 1024, "vq_layers": 6, "vq_heads": 8, "num_codes": 16, "code_dim": 64,
            "codebook_size": 256, "vq_half_width": None,
            "width": 1024, "query_layers": 6, "heads": 4, "audio_layers": 1, "audio_self_half_width": None,
            "self_context": None, "audio_half_width": 0, "period": 25,
            "num_lip_samples": 5, "num_upper_samples": 5, "dropout": 0.1,
            "upper_context": "ground-truth",
        },
        "loss": {
            "lambda_d_lips": 0.02, "lambda_d_upper": 0.02, "lambda_rc_lips": 1.0, "lambda_rc_upper": 1.0,
            "lambda_rg": 1.0, "epsilon": 0.005,
        },
        "training": {
            "window": None, "batch_size": 1, "vq_batch_size": 1, "lr": 1e-4, "weight_decay": 1e-2, "grad_clip": None,
            "lr_schedule": "constant",
            "vq_epochs": 200, "query_epochs": 50,
            "vq_max_steps": None, "query_max_steps": None,
            "vq_max_seconds": None, "query_max_seconds": None,
            "past_dropout": 0.0,
            "num_threads": None,
        },
    },
}


#: One sentence per flat key (``benchmark.run --method cdface --list-config``), besides the shared ones.
HELP = {
    "active_threshold": "model only the vertices whose displacement std in training exceeds this, in metres (null: all)",
    "vq_hidden": "width of the part VQ-VAEs' transformers",
    "vq_layers": "transformer layers of each part VQ-VAE",
    "vq_heads": "attention heads of the part VQ-VAEs",
    "num_codes": "codes per frame of each part",
    "code_dim": "size of one code vector",
    "codebook_size": "entries of each part's codebook",
    "vq_half_width": "frames each VQ-VAE frame attends to on either side (null: all)",
    "width": "width of the code-querying transformer",
    "query_layers": "layers of the code-querying transformer",
    "heads": "attention heads of the code-querying transformer",
    "audio_layers": "self-attention layers over the audio features",
    "audio_self_half_width": "frames the audio self-attention sees on either side (null: all)",
    "self_context": "past frames the querying self-attention sees (null: all)",
    "audio_half_width": "audio frames a motion frame attends to on either side",
    "num_lip_samples": "lip samples N^l drawn per sentence",
    "num_upper_samples": "upper-face samples drawn per lip sample",
    "upper_context": "past lips the upper face reads in training: ground-truth (teacher forcing) or predicted",
    "lambda_d_lips": "weight of the lip diversity loss (Eq. 15/16)",
    "lambda_d_upper": "weight of the upper-face diversity loss (Eq. 15/16)",
    "lambda_rc_lips": "weight of the lip reconstruction loss (Eq. 15/16)",
    "lambda_rc_upper": "weight of the upper-face reconstruction loss (Eq. 15/16)",
    "lambda_rg": "weight of the regularisation loss (Eq. 15/16)",
    "epsilon": "lip distance in metres under which a ground-truth frame counts as closed (closure mask)",
    "batch_size": "windows per querying step",
    "vq_batch_size": "windows per VQ-VAE step",
    "lr_schedule": "constant, or cosine (each stage decays the rate to 0 on a half cosine)",
    "vq_epochs": "epochs of each part VQ-VAE stage (null: by steps or seconds)",
    "query_epochs": "epochs of the querying stage (null: by steps or seconds)",
    "vq_max_steps": "steps of each part VQ-VAE stage",
    "query_max_steps": "steps of the querying stage",
    "vq_max_seconds": "seconds of each part VQ-VAE stage (lip prior, upper-face prior)",
    "query_max_seconds": "seconds of the code-querying stage",
    "past_dropout": "probability of zeroing a frame's ground-truth past in training (not in the paper)",
}


def resolve_config(preset: str = DEFAULT_PRESET, **overrides) -> dict:
    """Nested config of ``preset`` with flat ``overrides`` applied.

    Parameters
    ----------
    preset : {"cpu-demo", "paper"}
    **overrides
        Any key of any section (``width=128``, ``epsilon=0.005``, ``num_lip_samples=3``);
        ``encoder`` may be a spec dict or a kind string, ``wav2vec2_path`` sets the
        wav2vec 2.0 directory.

    Returns
    -------
    dict ``{"preset", "model", "loss", "training"}``
    """
    return {**resolved_preset(PRESETS, preset, overrides, method="CDFace"), "preset": preset}
