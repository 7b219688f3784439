"""SAiD's inference loop as the authors run it, batched and with the condition's attention cached.

Same steps as their ``SAID.inference``: "leading" timesteps of a DDIM (or DDPM)
chain over the float32 ``squaredcos_cap_v2`` schedule, the predicted ``x0``
clipped to ``[-1, 1]`` at every step, classifier-free guidance
``eps_c + gamma (eps_c - eps_u)`` with the null condition (only when
``gamma > 1``), optional guidance rescale, editing by ``strength`` (start from a
noised ``init_samples``) and ``mask`` (1 = keep ``init_samples``), and the final
clamp to ``[0, 1]``.  What differs is only how the work is done: the audio
embedding is computed once and shared by all samples of an utterance, the
conditional and unconditional passes of all samples run as one batch whose
layers before the first cross-attention (identical for both conditions) run
once, and the cross-attention keys and values of both conditions are computed
once per utterance instead of once per step.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import torch

from baselines.said.guidance import classifier_free_guidance, rescale_guidance
from baselines.said.samplers import SAMPLERS, ddim_step, ddpm_step
from baselines.said.schedule import add_noise, authors_alphas_cumprod, leading_timesteps
from blendvoca.errors import UserError
from blendvoca.runtime.progress import bar

PREDICTION_TYPES = ("epsilon", "v_prediction", "sample")


@dataclass
class InferenceOutput:
    """``result``: (B, T, C) coefficients in [0, 1]; ``intermediates``: the chain's states (B, T, C) before each step."""

    result: torch.Tensor
    intermediates: list = field(default_factory=list)


def noise_estimate(output: torch.Tensor, x_t: torch.Tensor, alpha_bar: torch.Tensor, prediction_type: str) -> torch.Tensor:
    """Return ``eps`` for a network output of ``prediction_type`` at ``x_t`` with scalar ``alpha_bar``."""
    if prediction_type == "epsilon":
        return output
    if prediction_type == "v_prediction":
        return alpha_bar.sqrt() * output + (1.0 - alpha_bar).sqrt() * x_t
    if prediction_type == "sample":
        return (x_t - alpha_bar.sqrt() * output) / (1.0 - alpha_bar).sqrt()
    raise ValueError(f"noise_estimate: expected prediction_type in {PREDICTION_TYPES}, got {prediction_type!r}")


@torch.no_grad()
def said_inference(
    model,
    audio_embedding: torch.Tensor,
    *,
    batch: int | None = None,
    num_steps: int = 100,
    sampler: str = "ddim",
    strength: float = 1.0,
    guidance: float = 2.5,
    guidance_rescale: float = 0.0,
    eta: float = 0.0,
    init_samples: torch.Tensor | None = None,
    mask: torch.Tensor | None = None,
    noise: torch.Tensor | None = None,
    generator: torch.Generator | None = None,
    draw=None,
    lengths: torch.Tensor | None = None,
    save_intermediates: bool = False,
    clip_sample: bool = True,
    use_cache: bool = True,
) -> InferenceOutput:
    """Sample coefficient tracks with a :class:`baselines.said.official.SAID_UNet1D`-like model.

    Parameters
    ----------
    model : SAID_UNet1D
        Needs ``forward(x, t, context, caches, lengths)``, ``null_condition(B, T)``,
        ``in_channels``, ``prediction_type`` and ``denoiser.model.context_cache``.
    audio_embedding : (E, T, D) Tensor
        From ``model.get_audio_embedding``; ``E == 1`` is shared by all ``batch`` samples.
    batch : int, optional
        Number of tracks ``B`` (default ``E``).
    num_steps : int, default 100
    sampler : {"ddim", "ddpm"}
    strength : float, default 1.0
        With ``init_samples``: the chain starts ``int(num_steps * strength)`` steps
        before the end, from ``init_samples`` noised to that step.
    guidance : float, default 2.5
        ``gamma``; guidance is used only when ``gamma > 1`` (as the authors do).
    guidance_rescale : float, default 0.0
    eta : float, default 0.0
        DDIM stochasticity.
    init_samples, mask : (B, T, C) Tensor, optional
        Editing start point; ``mask`` 1 = keep ``init_samples``.
    noise : (B, T, C) Tensor, optional
        Initial noise (drawn from ``generator`` otherwise).
    generator : torch.Generator, optional
        Source of the initial, editing and step noise (global RNG when None).
    draw : callable ``() -> (B, T, C) Tensor``, optional
        Draws that noise instead of ``generator`` (one generator per utterance of a batch).
    lengths : (B,) Tensor, optional
        Valid frames of each track when utterances of different lengths share the
        batch (zero-padded ``audio_embedding`` of batch ``B``); see
        :meth:`baselines.said.unet1d.ConditionalUNet1D.forward`.
    save_intermediates : bool, default False
    clip_sample : bool, default True
        Clip the predicted ``x0`` to ``[-1, 1]`` (the schedulers' default).
    use_cache : bool, default True
        Precompute the cross-attention keys/values (same result, faster).

    Returns
    -------
    InferenceOutput
    """
    if sampler not in SAMPLERS:
        raise UserError(f"said_inference: expected sampler in {SAMPLERS}, got {sampler!r}")
    if not 0.0 < strength <= 1.0:
        raise UserError(f"said_inference: expected 0 < strength <= 1, got {strength}")
    if mask is not None and init_samples is None:
        raise ValueError("said_inference: a mask needs init_samples")
    emb_batch, frames, _ = audio_embedding.shape
    batch = int(batch or emb_batch)
    if emb_batch not in (1, batch):
        raise ValueError(f"said_inference: expected an audio embedding of batch 1 or {batch}, got {emb_batch}")
    channels = model.in_channels
    device = audio_embedding.device
    shape = (batch, frames, channels)
    alphas = authors_alphas_cumprod(1000).to(device)
    num_train = alphas.shape[0]
    timesteps = leading_timesteps(num_train, num_steps).tolist()
    stride = num_train // num_steps
    one = alphas.new_ones(())

    def randn():
        if draw is not None:
            return draw()
        return torch.randn(shape, generator=generator, device=device, dtype=torch.float32)

    if init_samples is None:
        latents = noise.to(device=device, dtype=torch.float32).clone() if noise is not None else randn()
    else:
        latents = init_samples.to(device=device, dtype=torch.float32).clone()
        if latents.shape != shape:
            raise ValueError(f"said_inference: expected init_samples of shape {shape}, got {tuple(latents.shape)}")
    init_latents = latents.clone()
    init_timestep = min(int(num_steps * strength), num_steps)
    start = num_steps - init_timestep
    edit_noise = None
    if init_samples is not None:
        edit_noise = noise.to(device=device, dtype=torch.float32) if noise is not None else randn()
        t0 = torch.full((batch,), timesteps[-init_timestep], dtype=torch.long, device=device)
        latents = add_noise(latents, edit_noise, t0, alphas)
        if mask is not None:
            mask = mask.to(device=device, dtype=torch.float32)

    cond = audio_embedding.expand(batch, -1, -1)
    cfg = guidance > 1.0
    context = torch.cat([model.null_condition(batch, frames).to(cond.dtype), cond]) if cfg else cond
    caches = model.denoiser.model.context_cache(context) if use_cache else None
    if lengths is not None:
        lengths = torch.as_tensor(lengths, device=device).long()
        if lengths.shape != (batch,):
            raise ValueError(f"said_inference: expected lengths of shape ({batch},), got {tuple(lengths.shape)}")

    intermediates = []
    for idx, t in enumerate(bar(timesteps[start:], desc=f"SAiD {sampler}")):
        if save_intermediates:
            intermediates.append(latents.clone())
        # with guidance the context has 2B rows: the network repeats the latents itself after the
        # layers that do not see the condition (the same output as passing them twice)
        tt = torch.full((batch,), t, dtype=torch.long, device=device)
        out = model(latents, tt, context, caches, lengths)
        if cfg:
            uncond, audio = out.chunk(2)
            out = classifier_free_guidance(audio, uncond, guidance)
            if guidance_rescale > 0.0:
                out = rescale_guidance(out, audio, guidance_rescale)
        ab = alphas[t]
        ab_prev = alphas[t - stride] if t - stride >= 0 else one
        eps = noise_estimate(out, latents, ab, model.prediction_type)
        clip = 1.0 if clip_sample else None
        if sampler == "ddim":
            latents = ddim_step(latents, eps, ab, ab_prev, eta=eta, noise=randn() if eta > 0 else None, clip=clip)
        else:
            latents = ddpm_step(latents, eps, ab, ab_prev, noise=randn() if t > 0 else torch.zeros(shape, device=device), clip=clip)
        if mask is not None:
            kept = init_latents
            nxt = start + idx + 1
            if nxt < num_steps:
                kept = add_noise(init_latents, edit_noise, torch.full((batch,), timesteps[nxt], dtype=torch.long, device=device), alphas)
            latents = kept * mask + latents * (1 - mask)
    return InferenceOutput(result=latents.clamp(0, 1), intermediates=intermediates)
