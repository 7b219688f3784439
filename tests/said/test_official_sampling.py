"""SAiD's inference against diffusers' schedulers: same initial noise, same steps, same result."""

import pytest
import torch

pytest.importorskip("transformers")
diffusers = pytest.importorskip("diffusers")

from baselines.said.guidance import rescale_guidance  # noqa: E402
from baselines.said.inference import said_inference  # noqa: E402
from baselines.said.official import SAID_UNet1D  # noqa: E402
from baselines.said.schedule import authors_alphas_cumprod, leading_timesteps  # noqa: E402
from baselines.wav2vec2 import tiny_config  # noqa: E402


@pytest.fixture(scope="module")
def model():
    torch.manual_seed(0)
    m = SAID_UNet1D(tiny_config(), model_channels=32, num_head_channels=16).eval()
    with torch.no_grad():  # no zero-initialised layers: the network output depends on everything
        for name, p in m.denoiser.named_parameters():
            gain = name.endswith("weight") and p.ndim == 1
            p.copy_(torch.randn_like(p) * (0.1 if p.ndim > 1 else 0.05) + (1.0 if gain else 0.0))
        m.null_cond_emb.normal_()
    return m


@pytest.fixture(scope="module")
def embedding(model):
    torch.manual_seed(1)
    with torch.no_grad():
        return model.get_audio_embedding(model.process_audio(torch.randn(1, 8000)), 30)


def _scheduler(kind, prediction="epsilon"):
    cls = diffusers.DDIMScheduler if kind == "ddim" else diffusers.DDPMScheduler
    return cls(num_train_timesteps=1000, beta_schedule="squaredcos_cap_v2", prediction_type=prediction)


@torch.no_grad()
def _diffusers_loop(model, embedding, latents, *, kind="ddim", steps=50, guidance=2.0, rescale=0.0, eta=0.0,
                    generator=None, init=None, mask=None, strength=1.0, edit_noise=None):
    """The authors' loop over a diffusers scheduler (one sequence batch, CFG by concatenation)."""
    from diffusers.pipelines.stable_diffusion.pipeline_stable_diffusion import rescale_noise_cfg

    sched = _scheduler(kind, model.prediction_type)
    sched.set_timesteps(steps)
    b = latents.shape[0]
    cond = embedding.expand(b, -1, -1)
    init_t = min(int(steps * strength), steps)
    if init is not None:
        latents = sched.add_noise(init.clone(), edit_noise, torch.tensor([sched.timesteps[-init_t]] * b))
    ctx = torch.cat([model.null_cond_emb.repeat(b, cond.shape[1], 1), cond]) if guidance > 1 else cond
    start = steps - init_t
    kwargs = {"eta": eta} if kind == "ddim" else {}
    for idx, t in enumerate(sched.timesteps[start:]):
        x = torch.cat([latents] * 2) if guidance > 1 else latents
        out = model(sched.scale_model_input(x, t), t, ctx)
        if guidance > 1:
            u, c = out.chunk(2)
            out = c + guidance * (c - u)
            if rescale > 0:
                out = rescale_noise_cfg(out, c, rescale)
        latents = sched.step(out, t, latents, generator=generator, **kwargs).prev_sample
        if mask is not None:
            kept = init
            if start + idx + 1 < steps:
                kept = sched.add_noise(init, edit_noise, sched.timesteps[start + idx + 1])
            latents = kept * mask + latents * (1 - mask)
    return latents.clamp(0, 1)


def test_schedule_and_timesteps_equal_diffusers():
    for kind in ("ddim", "ddpm"):
        sched = _scheduler(kind)
        assert torch.equal(authors_alphas_cumprod(1000), sched.alphas_cumprod)
        for n in (1, 50, 333, 1000):
            sched.set_timesteps(n)
            assert leading_timesteps(1000, n).tolist() == sched.timesteps.tolist()


def test_ddim50_reproduces_the_diffusers_loop(model, embedding):
    noise = torch.randn(3, 30, 32, generator=torch.Generator().manual_seed(5))
    want = _diffusers_loop(model, embedding, noise.clone())
    got = said_inference(model, embedding, batch=3, num_steps=50, guidance=2.0, noise=noise).result
    assert 0.05 < want.mean() < 0.95 and want.std() > 0.05  # not all clipped
    torch.testing.assert_close(got, want, rtol=0, atol=1e-5)
    uncached = said_inference(model, embedding, batch=3, num_steps=50, guidance=2.0, noise=noise, use_cache=False).result
    torch.testing.assert_close(uncached, want, rtol=0, atol=1e-5)


@pytest.mark.parametrize("kind,eta,rescale,guidance", [("ddim", 0.7, 0.5, 2.5), ("ddpm", 0.0, 0.0, 2.0), ("ddim", 0.0, 0.0, 1.0)])
def test_stochastic_and_rescaled_chains_reproduce_diffusers(model, embedding, kind, eta, rescale, guidance):
    noise = torch.randn(2, 30, 32, generator=torch.Generator().manual_seed(6))
    want = _diffusers_loop(model, embedding, noise.clone(), kind=kind, steps=20, guidance=guidance, rescale=rescale,
                           eta=eta, generator=torch.Generator().manual_seed(7))
    got = said_inference(model, embedding, batch=2, num_steps=20, sampler=kind, guidance=guidance, guidance_rescale=rescale,
                         eta=eta, noise=noise, generator=torch.Generator().manual_seed(7)).result
    torch.testing.assert_close(got, want, rtol=0, atol=1e-5)


def test_editing_with_strength_and_mask_reproduces_diffusers(model, embedding):
    g = torch.Generator().manual_seed(8)
    init = torch.rand(2, 30, 32, generator=g)
    edit_noise = torch.randn(2, 30, 32, generator=g)
    mask = torch.zeros(2, 30, 32)
    mask[:, :8] = 1.0
    mask[:, -8:] = 1.0
    want = _diffusers_loop(model, embedding, init.clone(), steps=25, init=init, mask=mask, strength=0.6, edit_noise=edit_noise)
    out = said_inference(model, embedding, batch=2, num_steps=25, guidance=2.0, init_samples=init, mask=mask, strength=0.6,
                         noise=edit_noise, save_intermediates=True)
    torch.testing.assert_close(out.result, want, rtol=0, atol=1e-5)
    assert len(out.intermediates) == int(25 * 0.6)
    torch.testing.assert_close(out.result[mask.bool()], init[mask.bool()].clamp(0, 1), rtol=0, atol=1e-6)


def test_rescale_guidance_matches_diffusers():
    from diffusers.pipelines.stable_diffusion.pipeline_stable_diffusion import rescale_noise_cfg

    g = torch.Generator().manual_seed(0)
    eps, cond = torch.randn(3, 10, 4, generator=g) * 2, torch.randn(3, 10, 4, generator=g)
    torch.testing.assert_close(rescale_guidance(eps, cond, 0.7), rescale_noise_cfg(eps, cond, 0.7))
