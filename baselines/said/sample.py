"""The sampling loop: DDIM or DDPM over a noise-prediction callable, with optional editing."""

from __future__ import annotations

from collections.abc import Callable

import torch

from baselines.said.edit import masked_replace, noised_reference
from baselines.said.samplers import SAMPLERS, ddim_step, ddpm_step
from baselines.said.schedule import sampling_timesteps
from blendvoca.errors import UserError
from blendvoca.runtime.progress import bar

NoiseFn = Callable[[torch.Tensor, torch.Tensor], torch.Tensor]


def padded_batch(parts, num_frames: int) -> torch.Tensor:
    """The ``(S_i, T_i, ...)`` parts stacked along the batch, each zero-padded after its ``T_i`` frames to
    ``num_frames`` (one part of ``num_frames`` frames: that part itself)."""
    if len(parts) == 1 and parts[0].shape[1] == num_frames:
        return parts[0]
    return torch.cat([torch.nn.functional.pad(p, (0, 0, 0, num_frames - p.shape[1])) if p.shape[1] < num_frames else p
                      for p in parts])


def _randn(shape, generator, *, dtype, device) -> torch.Tensor:
    """Standard normal noise drawn on ``generator``'s device and moved to ``device``: a CPU
    generator gives the same noise for a seed whether the chain runs on the CPU or a GPU."""
    where = device if generator is None else generator.device
    return torch.randn(shape, generator=generator, dtype=dtype, device=where).to(device)


def utterance_noise(generators, lengths, samples: int, channels: int, *, num_frames: int, dtype, device):
    """A ``draw()`` for a batch of utterances (``sample_diffusion(..., draw=)``): each utterance's
    ``(samples, T_i, channels)`` noise from its own generator, as it draws it sampled alone, zero-padded
    (:func:`padded_batch`) to ``num_frames``; drawn on each generator's device, then moved to ``device``."""
    def draw():
        return padded_batch([_randn((samples, frames, channels), g, dtype=dtype, device=device)
                             for g, frames in zip(generators, lengths)], num_frames)
    return draw


def sample_diffusion(
    noise_fn: NoiseFn,
    shape: tuple[int, int, int],
    alphas_cumprod: torch.Tensor,
    *,
    sampler: str = "ddim",
    num_steps: int = 50,
    eta: float = 0.0,
    clip: float | tuple | None = 1.0,
    reference: torch.Tensor | None = None,
    mask: torch.Tensor | None = None,
    generator: torch.Generator | None = None,
    draw: Callable[[], torch.Tensor] | None = None,
) -> torch.Tensor:
    """Return samples ``x0`` drawn by running the reverse chain from pure noise.

    Parameters
    ----------
    noise_fn : callable ``(x_t (B, T, K), t (B,) int64) -> eps (B, T, K)``
        The (guided) noise predictor.
    shape : (B, T, K)
    alphas_cumprod : (N,) Tensor
        The training schedule; its dtype and device are used for the chain.
    sampler : {"ddim", "ddpm"}, default "ddim"
    num_steps : int, default 50
        Steps of the chain, ``1 <= num_steps <= N``.
    eta : float, default 0.0
        DDIM stochasticity (ignored by DDPM).
    clip : float, (lo, hi) pair of (K,) Tensors, or None; default 1.0
        Clamp of the predicted ``x0`` at each step (see :func:`ddim_step`).
    reference : (T, K) Tensor, optional
        Editing: track in data space whose masked part is kept.  At every step the
        kept part of the sample is replaced by the reference noised to that step; at
        the end it equals the reference exactly.
    mask : (T, K) Tensor, optional
        1 = keep the reference, 0 = generate.  Required with ``reference``.
    generator : torch.Generator, optional
        Source of all randomness (initial noise, DDPM/DDIM noise, reference noising). A
        CPU generator with a chain on a GPU draws on the CPU and moves the noise: the
        same seed then gives the same noise on every device.
    draw : callable ``() -> (B, T, K) Tensor``, optional
        Draws the initial and the step noise instead of ``generator`` (e.g. one
        generator per utterance of a batch); ``generator`` still noises the reference.

    Returns
    -------
    x0 : (B, T, K) Tensor
    """
    if sampler not in SAMPLERS:
        raise UserError(f"sample_diffusion: expected sampler in {SAMPLERS}, got {sampler!r}")
    if (reference is None) != (mask is None):
        raise ValueError("sample_diffusion: expected both reference and mask, or neither")
    batch = shape[0]
    dtype, device = alphas_cumprod.dtype, alphas_cumprod.device
    steps = sampling_timesteps(alphas_cumprod.shape[0], num_steps).tolist()
    prevs = steps[1:] + [-1]
    one = alphas_cumprod.new_ones(())

    def randn():
        if draw is not None:
            return draw()
        return _randn(shape, generator, dtype=dtype, device=device)

    x = randn()
    if reference is not None:
        reference = reference.to(dtype=dtype, device=device)
        mask = mask.to(dtype=dtype, device=device)
        x = masked_replace(x, noised_reference(reference, steps[0], alphas_cumprod, batch=batch, generator=generator), mask)
    for t, t_prev in bar(list(zip(steps, prevs)), desc=f"{sampler} sampling"):
        tt = torch.full((batch,), t, dtype=torch.long, device=device)
        eps = noise_fn(x, tt).to(dtype)
        ab = alphas_cumprod[t]
        ab_prev = alphas_cumprod[t_prev] if t_prev >= 0 else one
        if sampler == "ddim":
            x = ddim_step(x, eps, ab, ab_prev, eta=eta, noise=randn() if eta > 0 else None, clip=clip)
        else:
            x = ddpm_step(x, eps, ab, ab_prev, noise=randn(), clip=clip)
        if reference is not None:
            x = masked_replace(x, noised_reference(reference, t_prev, alphas_cumprod, batch=batch, generator=generator), mask)
    return x
