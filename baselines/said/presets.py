"""Presets of SAiD (model, diffusion, sampling, training) and flat overrides of them.

``cpu-demo`` (default) trains in minutes on 2 CPU cores with the log-mel encoder and
no pretrained weights; ``paper`` follows the paper (wav2vec 2.0 from a local
directory, 1000 diffusion steps, DDIM 1000, lr 1e-5, EMA 0.9999) and wants a GPU.
"""

from __future__ import annotations

from baselines.common.presets import resolved_preset
from baselines.common.chunking import chunk_section

DEFAULT_PRESET = "cpu-demo"

PRESETS: dict[str, dict[str, dict]] = {
    "cpu-demo": {
        "inference": chunk_section(),
        "model": {
            "architecture": "authors",
            "channels": 32,
            "cond_dim": 32,
            "heads": 4,
            "dropout": 0.0,
            "encoder": {"kind": "logmel", "n_mels": 80},
            "adapter_layers": 2,
            "adapter_kernel": 5,
            "attention_half_width": 1,
            # PyTorch's default initialisation for the layers the authors start at zero:
            # lower LVE and FDD, more diverse samples, a higher FD (+6 % on the bundled default; docs/said.md)
            "zero_init": False,
        },
        "diffusion": {"num_train_steps": 1000, "schedule": "cosine", "normalization": "standardized", "prediction": "v"},
        # gamma 1: with 2 the short run's samples overshoot (LVE 3.2 vs 2.3 mm at 300 s)
        "sampling": {"sampler": "ddim", "num_steps": 50, "eta": 0.0, "guidance": 1.0, "clip": True},
        "training": {
            "window": 60,
            "batch_size": 16,
            # 1e-5 is the paper's rate for a long GPU run; a few CPU minutes need more.
            "lr": 1e-3,
            "lr_decay": "constant",
            "warmup_steps": 100,
            "weight_decay": 1e-2,
            "betas": [0.9, 0.999],
            "ema_decay": 0.999,
            "cond_drop_prob": 0.1,
            "velocity_weight": 1.0,
            # L1 + velocity on the v target (noise loss weighted by 1/sqrt(alpha_bar)):
            # the plain noise loss leaves the x0 of nearly pure noise untrained
            "loss_space": "v",
            "audio_shift_prob": 0.5,
            "mirror_prob": 0.5,
            "grad_clip": 1.0,
            "max_steps": 20000,
            "max_seconds": 300.0,
            "val_every": 500,
            # one thread: with other jobs on the 2 cores, two threads ran 9x slower here
            "num_threads": 1,
        },
    },
    "paper": {
        "inference": chunk_section(),
        "model": {
            # the authors' network: width 192, 6 heads of 32, wav2vec 2.0 features
            # straight into the cross-attention (no projection), dropout 0.1
            "architecture": "authors",
            "channels": 192,
            "cond_dim": None,
            "heads": 6,
            "dropout": 0.1,
            "encoder": {"kind": "wav2vec2", "path": "${BLENDVOCA_WAV2VEC2:-~/models/wav2vec2-base-960h}"},
            "adapter_layers": 0,
            "adapter_kernel": 5,
            "attention_half_width": 1,
            "zero_init": True,
        },
        "diffusion": {"num_train_steps": 1000, "schedule": "cosine", "normalization": "unit-interval", "prediction": "epsilon"},
        "sampling": {"sampler": "ddim", "num_steps": 1000, "eta": 0.0, "guidance": 2.0, "clip": True},
        "training": {
            "window": 120,
            "batch_size": 8,
            "lr": 1e-5,
            "lr_decay": "constant",
            "warmup_steps": 5000,
            "weight_decay": 1e-2,
            "betas": [0.9, 0.999],
            "ema_decay": 0.9999,
            "cond_drop_prob": 0.1,
            "velocity_weight": 1.0,
            "loss_space": "noise",
            "audio_shift_prob": 0.5,
            "mirror_prob": 0.5,
            "grad_clip": 1.0,
            "max_steps": 50000,
            "max_seconds": None,
            "val_every": 1000,
            "num_threads": None,
        },
    },
}


#: One sentence per flat key (``benchmark.run --method said --list-config``), besides the shared ones.
HELP = {
    "architecture": "UNet layout: authors (the authors' ConditionalUNet1D) or compact (earlier checkpoints)",
    "channels": "UNet width",
    "cond_dim": "size of the audio condition fed to the cross-attention (null: the encoder's, unprojected)",
    "heads": "attention heads of the UNet",
    "dropout": "dropout of the residual blocks (authors) or of every block (compact)",
    "adapter_layers": "convolution layers of the audio adapter between encoder and UNet",
    "adapter_kernel": "kernel size of the audio adapter's convolutions",
    "attention_half_width": "frames each coefficient frame attends to on either side in the audio (alignment bias)",
    "zero_init": "start the layers the authors start at zero at zero (false: PyTorch's default initialisation)",
    "num_train_steps": "diffusion steps of the noise schedule in training",
    "schedule": "noise schedule of the diffusion: cosine, linear or scaled_linear",
    "normalization": "how coefficients are normalised before diffusion (unit-interval, centered, standardized)",
    "prediction": "what the network predicts: epsilon (the noise) or v",
    "sampler": "sampler: ddim or ddpm",
    "num_steps": "sampling steps",
    "eta": "DDIM eta in [0, 1] (0: deterministic given the start noise)",
    "guidance": "classifier-free guidance scale gamma (1: none)",
    "clip": "clip each step's estimate of the clean track to the coefficients' range",
    "batch_size": "training windows per step",
    "lr_decay": "learning-rate schedule after warm-up: constant, linear or cosine",
    "warmup_steps": "steps of linear learning-rate warm-up",
    "betas": "Adam(W) betas",
    "ema_decay": "decay of the exponential moving average of the weights (what generates)",
    "cond_drop_prob": "probability of dropping the audio condition in training (for classifier-free guidance)",
    "velocity_weight": "weight of the velocity term of the loss",
    "loss_space": "where the loss is taken: noise, or v (with prediction v)",
    "audio_shift_prob": "probability of the audio-shift augmentation of a training window",
    "mirror_prob": "probability of the left/right mirror augmentation of a training window",
    "val_every": "steps between validations (the best weights on validation are kept)",
}


def resolve_config(preset: str = DEFAULT_PRESET, **overrides) -> dict[str, dict]:
    """Return the nested config of ``preset`` with flat ``overrides`` applied.

    Parameters
    ----------
    preset : {"cpu-demo", "paper"}, default "cpu-demo"
    **overrides
        Any key of any section, e.g. ``channels=128``, ``num_steps=100``,
        ``sampler="ddpm"``, ``lr=1e-4``; ``encoder`` may be a spec dict or a kind
        string (``"logmel"``, ``"wav2vec2"``, ``"wav2vec2-tiny"``) and
        ``wav2vec2_path`` sets the directory of the wav2vec2 encoder.

    Returns
    -------
    config : dict
        ``{"preset", "model", "diffusion", "sampling", "training"}``.
    """
    return {**resolved_preset(PRESETS, preset, overrides, method="SAiD"), "preset": preset}
