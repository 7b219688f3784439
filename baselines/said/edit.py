"""Editing by masked replacement: keep part of a reference track while sampling."""

from __future__ import annotations

import torch

from baselines.said.schedule import add_noise
from blendvoca.errors import UserError


def masked_replace(x: torch.Tensor, kept: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Return ``mask * kept + (1 - mask) * x``.

    Parameters
    ----------
    x : (B, T, K) Tensor
        Current sample.
    kept : (B, T, K) or (T, K) Tensor
        Values to keep (the reference, noised to the sample's timestep).
    mask : (T, K) or (B, T, K) Tensor
        1 where the reference is kept, 0 where it is generated.

    Returns
    -------
    x : (B, T, K) Tensor
    """
    mask = mask.to(x.dtype)
    return mask * kept.to(x.dtype) + (1.0 - mask) * x


def noised_reference(
    reference: torch.Tensor,
    timestep: int,
    alphas_cumprod: torch.Tensor,
    *,
    batch: int,
    generator: torch.Generator | None = None,
) -> torch.Tensor:
    """Return the reference track noised to ``timestep`` by the forward process.

    Parameters
    ----------
    reference : (T, K) Tensor
        In the diffusion's data space (``[-1, 1]``).
    timestep : int
        ``-1`` returns the reference itself.
    alphas_cumprod : (N,) Tensor
    batch : int
        Number of independent noisings ``B``.
    generator : torch.Generator, optional

    Returns
    -------
    noised : (B, T, K) Tensor
    """
    ref = reference.expand(batch, *reference.shape)
    if timestep < 0:
        return ref.clone()
    # drawn on the generator's device (a CPU generator serves a chain on any device), then moved
    where = ref.device if generator is None else generator.device
    noise = torch.randn(ref.shape, generator=generator, dtype=ref.dtype, device=where).to(ref.device)
    t = torch.full((batch,), int(timestep), dtype=torch.long, device=ref.device)
    return add_noise(ref, noise, t, alphas_cumprod.to(ref.dtype))


def check_edit_inputs(reference, mask, num_frames: int, num_coeffs: int) -> None:
    """Raise a UserError unless reference and mask are both given, shaped ``(T, K)``, mask in {0, 1}.

    Parameters
    ----------
    reference, mask : (T, K) array-like or None
    num_frames, num_coeffs : int
        Expected ``T`` and ``K``.
    """
    if (reference is None) != (mask is None):
        raise UserError("editing: expected both a reference and a mask, or neither")
    if reference is None:
        return
    for name, arr in (("reference", reference), ("mask", mask)):
        if tuple(arr.shape) != (num_frames, num_coeffs):
            raise UserError(
                f"editing: expected {name} of shape ({num_frames}, {num_coeffs}), got {tuple(arr.shape)}"
            )
    m = torch.as_tensor(mask)
    if not bool(((m == 0) | (m == 1)).all()):
        raise UserError("editing: expected a binary mask (0 = generate, 1 = keep)")
