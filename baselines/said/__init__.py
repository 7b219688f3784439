"""SAiD: conditional diffusion over ARKit blendshape coefficient tracks.

The package is split into one file per algorithm step (noise schedule, guidance,
losses, samplers, editing, denoiser, training); the alignment bias and the speech
encoders, which CDFace and FaceFormer use too, are in :mod:`baselines.common`.
:mod:`baselines.said.plugin` adapts it to the benchmark's method contract and
:mod:`baselines.said.generate` is the command line for users.  Importing this
package does not import the benchmark.
"""

from baselines.common.attention_bias import alignment_bias
from baselines.said.guidance import classifier_free_guidance
from baselines.said.losses import noise_l1_loss, said_loss, velocity_loss
from baselines.said.official import load_official
from baselines.said.schedule import (
    add_noise,
    alphas_cumprod_schedule,
    sampling_timesteps,
)

__all__ = [
    "add_noise",
    "alignment_bias",
    "alphas_cumprod_schedule",
    "classifier_free_guidance",
    "load_official",
    "noise_l1_loss",
    "said_loss",
    "sampling_timesteps",
    "velocity_loss",
]
