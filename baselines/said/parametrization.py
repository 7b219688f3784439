"""What the denoiser's output means, converted to the noise estimate that the loss and samplers use."""

from __future__ import annotations

import torch

PREDICTIONS = ("epsilon", "v")


def noise_from_output(output: torch.Tensor, x_t: torch.Tensor, alpha_bar: torch.Tensor, prediction: str = "epsilon") -> torch.Tensor:
    """Return the noise estimate ``eps`` for the network output.

    ``epsilon``: the output is ``eps`` itself (SAiD).  ``v``: the output is
    ``v = sqrt(a) eps - sqrt(1 - a) x0`` (Salimans & Ho 2022), so
    ``eps = sqrt(a) v + sqrt(1 - a) x_t``: near pure noise ``eps ~ x_t`` needs no
    learning and ``x0 = sqrt(a) x_t - sqrt(1 - a) v`` stays well conditioned.  The
    loss is the same L1 (+ velocity) on ``eps`` either way.

    Parameters
    ----------
    output, x_t : (B, T, K) Tensor
    alpha_bar : (B,) Tensor
        ``alpha_bar`` of each item's timestep.
    prediction : {"epsilon", "v"}

    Returns
    -------
    eps : (B, T, K) Tensor
    """
    if prediction == "epsilon":
        return output
    if prediction != "v":
        raise ValueError(f"noise_from_output: expected prediction in {PREDICTIONS}, got {prediction!r}")
    a = alpha_bar.to(output.dtype)[:, None, None]
    return a.sqrt() * output + (1.0 - a).sqrt() * x_t
