"""The authors' SAiD network: strict loading of their state_dict layout, and noise predictions
checked against an independent functional computation from the raw tensors."""

import math

import pytest
import torch
import torch.nn.functional as F

pytest.importorskip("transformers")

from baselines.common.attention_bias import alignment_mask  # noqa: E402
from baselines.said import load_official  # noqa: E402
from baselines.said.official import SAID_UNet1D, official_state_keys  # noqa: E402
from baselines.wav2vec2 import legacy_layout_state, tiny_config  # noqa: E402

WIDTH, HEAD = 64, 16


def _authors_state(seed=0, feature_dim=-1):
    """A random-init SAID_UNet1D state_dict in the published file's layout (legacy weight-norm names),
    with no zero-initialised tensors so that every layer shows in the output."""
    torch.manual_seed(seed)
    model = SAID_UNet1D(tiny_config(), feature_dim=feature_dim, model_channels=WIDTH, num_head_channels=HEAD)
    state = {}
    for key, value in model.state_dict().items():
        if value.is_floating_point():
            g = torch.Generator().manual_seed(hash(key) % (2**31))
            value = torch.randn(value.shape, generator=g) * (0.2 if value.ndim > 1 else 0.1)
            if key.endswith("weight") and value.ndim == 1:  # normalisation gains
                value = 1.0 + value
        state[key] = value
    return legacy_layout_state(state)


# ---- an independent computation of the authors' forward, from the tensors ---------------
def _authors_band(t, s, pad=1):
    """Their loop, with Python's round: True = masked."""
    masked = torch.ones(t, s, dtype=torch.bool)
    ratio = s / t
    half = ratio / 2 + pad
    for i in range(t):
        mid = (i + 0.5) * ratio
        masked[i, max(round(mid - half), 0):min(round(mid + half), s)] = False
    return masked


def _attention(p, x, context, heads, masked=None):
    q, k, v = x @ p["to_q.weight"].T, context @ p["to_k.weight"].T, context @ p["to_v.weight"].T
    b, n, inner = q.shape
    d = inner // heads

    def split(z):
        return z.reshape(z.shape[0], z.shape[1], heads, d).permute(0, 2, 1, 3).reshape(z.shape[0] * heads, z.shape[1], d)

    sim = torch.einsum("bid,bjd->bij", split(q), split(k)) * d**-0.5
    if masked is not None:
        sim = sim.masked_fill(masked[None], -torch.finfo(sim.dtype).max)
    out = torch.einsum("bij,bjd->bid", sim.softmax(-1), split(v))
    out = out.reshape(b, heads, n, d).permute(0, 2, 1, 3).reshape(b, n, inner)
    return out @ p["to_out.0.weight"].T + p["to_out.0.bias"]


def _sub(state, prefix):
    return {k[len(prefix):]: v for k, v in state.items() if k.startswith(prefix)}


def _resblock(p, x, emb):
    h = F.conv1d(F.silu(F.group_norm(x, 32, p["in_layers.0.weight"], p["in_layers.0.bias"])), p["in_layers.2.weight"], p["in_layers.2.bias"], padding=1)
    h = h + (F.silu(emb) @ p["emb_layers.1.weight"].T + p["emb_layers.1.bias"])[:, :, None]
    h = F.group_norm(h, 32, p["out_layers.0.weight"], p["out_layers.0.bias"])
    h = F.conv1d(F.silu(h), p["out_layers.3.weight"], p["out_layers.3.bias"], padding=1)
    skip = F.conv1d(x, p["skip_connection.weight"], p["skip_connection.bias"]) if "skip_connection.weight" in p else x
    return skip + h


def _transformer(p, x, context, heads):
    h = F.group_norm(x, 32, p["norm.weight"], p["norm.bias"], eps=1e-6).transpose(1, 2)
    b = _sub(p, "transformer_blocks.0.")

    def ln(z, name):
        return F.layer_norm(z, z.shape[-1:], b[f"{name}.weight"], b[f"{name}.bias"])

    h = _attention(_sub(b, "attn1."), ln(h, "norm1"), ln(h, "norm1"), heads) + h
    h = _attention(_sub(b, "attn2."), ln(h, "norm2"), context, heads, _authors_band(h.shape[1], context.shape[1])) + h
    a, gate = (ln(h, "norm3") @ b["ff.net.0.proj.weight"].T + b["ff.net.0.proj.bias"]).chunk(2, dim=-1)
    h = (a * F.gelu(gate)) @ b["ff.net.2.weight"].T + b["ff.net.2.bias"] + h
    return F.conv1d(h.transpose(1, 2), p["proj_out.weight"], p["proj_out.bias"]) + x


def _unet(state, x, timesteps, context, heads):
    p = _sub(state, "denoiser.model.")
    c = p["time_embed.0.weight"].shape[1]
    freqs = torch.exp(-math.log(10000) * torch.arange(c // 2, dtype=torch.float32) / (c // 2))
    args = timesteps.float()[:, None] * freqs
    emb = torch.cat([args.cos(), args.sin()], -1) @ p["time_embed.0.weight"].T + p["time_embed.0.bias"]
    emb = F.silu(emb) @ p["time_embed.2.weight"].T + p["time_embed.2.bias"]
    h0 = F.conv1d(x.transpose(1, 2), p["input_blocks.0.0.weight"], p["input_blocks.0.0.bias"], padding=1)
    h1 = _transformer(_sub(p, "input_blocks.1.1."), _resblock(_sub(p, "input_blocks.1.0."), h0, emb), context, heads)
    h = _resblock(_sub(p, "middle_block.0."), h1, emb)
    h = _transformer(_sub(p, "middle_block.1."), h, context, heads)
    h = _resblock(_sub(p, "middle_block.2."), h, emb)
    for i, skip in enumerate((h1, h0)):
        h = _transformer(_sub(p, f"output_blocks.{i}.1."), _resblock(_sub(p, f"output_blocks.{i}.0."), torch.cat([h, skip], 1), emb), context, heads)
    h = F.silu(F.group_norm(h, 32, p["out.0.weight"], p["out.0.bias"]))
    return F.conv1d(h, p["out.2.weight"], p["out.2.bias"], padding=1).transpose(1, 2)


def _reference_noise(state, noisy, timesteps, waveform, feature_dim=-1):
    """The authors' pipeline written out: processor normalisation, wav2vec 2.0 with the CNN features
    interpolated before the projection (their ModifiedWav2Vec2Model), projection, UNet."""
    from transformers import Wav2Vec2Model

    from baselines.wav2vec2 import current_layout_state

    config = tiny_config()
    config._attn_implementation = "eager"
    w2v = Wav2Vec2Model(config).eval()
    w2v.load_state_dict(current_layout_state(_sub(state, "audio_encoder.")))
    x = torch.stack([(w - w.mean()) / torch.sqrt(w.var(unbiased=False) + 1e-7) for w in waveform])
    feats = F.interpolate(w2v.feature_extractor(x), size=noisy.shape[1], align_corners=True, mode="linear").transpose(1, 2)
    hidden = w2v.feature_projection(feats)
    hidden = hidden[0] if isinstance(hidden, tuple) else hidden
    context = w2v.encoder(hidden).last_hidden_state
    if feature_dim > 0:
        context = context @ state["audio_proj_layer.weight"].T + state["audio_proj_layer.bias"]
    return _unet(state, noisy, timesteps, context, WIDTH // HEAD)


@pytest.mark.parametrize("feature_dim", [-1, 24])
def test_authors_layout_loads_strictly_and_predicts_like_the_reference(tmp_path, feature_dim):
    state = _authors_state(feature_dim=feature_dim)
    assert "audio_encoder.encoder.pos_conv_embed.conv.weight_g" in state
    path = tmp_path / "SAiD.pth"
    torch.save(state, path)
    model = load_official(path, audio_config=tiny_config(), num_head_channels=HEAD)
    assert model.denoiser.model.model_channels == WIDTH and model.feature_dim == feature_dim
    torch.manual_seed(1)
    noisy, waveform = torch.randn(2, 37, 32), 0.3 * torch.randn(2, 9920) + 0.1
    timesteps = torch.tensor([3, 871])
    got = model.predict_noise(noisy, timesteps, waveform)
    with torch.no_grad():
        want = _reference_noise(state, noisy, timesteps, waveform, feature_dim)
    assert want.abs().mean() > 0.1  # every layer contributes (no zero-initialised output)
    torch.testing.assert_close(got, want, rtol=1e-4, atol=1e-4)


def test_cached_context_gives_the_same_output():
    torch.manual_seed(0)
    model = SAID_UNet1D(tiny_config(), model_channels=WIDTH, num_head_channels=HEAD)
    model.load_state_dict(legacy_to_current(_authors_state()))
    model.eval()
    x, t, ctx = torch.randn(3, 20, 32), torch.tensor([1, 500, 999]), torch.randn(3, 20, 32)
    with torch.no_grad():
        plain = model(x, t, ctx)
        cached = model(x, t, None, model.denoiser.model.context_cache(ctx))
    torch.testing.assert_close(cached, plain, rtol=0, atol=1e-6)


def test_repeated_batch_equals_the_batch_passed_twice():
    """x of batch B with a context of batch 2B (guidance): the layers before the first cross-attention run once."""
    model = SAID_UNet1D(tiny_config(), model_channels=WIDTH, num_head_channels=HEAD)
    model.load_state_dict(legacy_to_current(_authors_state(seed=1)))
    model.eval()
    torch.manual_seed(4)
    x, t, ctx = torch.randn(3, 20, 32), torch.tensor([7, 500, 500]), torch.randn(6, 20, 32)
    with torch.no_grad():
        twice = model(torch.cat([x, x]), torch.cat([t, t]), ctx)
        once = model(x, t, ctx)
        cached = model(x, t, None, model.denoiser.model.context_cache(ctx))
        assert twice.abs().mean() > 0.1
        torch.testing.assert_close(once, twice, rtol=0, atol=1e-6)
        torch.testing.assert_close(cached, twice, rtol=0, atol=1e-6)
        with pytest.raises(ValueError, match="dividing the context"):
            model(torch.randn(4, 20, 32), torch.full((4,), 3), ctx)


def legacy_to_current(state):
    from baselines.wav2vec2 import current_layout_state

    return current_layout_state(state)


def test_wrong_layout_and_shapes_are_named(tmp_path):
    path = tmp_path / "x.pth"
    torch.save({"weight": torch.zeros(3)}, path)
    with pytest.raises(ValueError, match="SAID_UNet1D state_dict"):
        load_official(path)
    state = _authors_state()
    del state["denoiser.model.out.2.bias"]
    torch.save(state, path)
    with pytest.raises(ValueError, match="missing.*out.2.bias"):
        load_official(path, audio_config=tiny_config(), num_head_channels=HEAD)
    with pytest.raises(ValueError, match="expected a file"):
        load_official(tmp_path / "none.pth")


def test_published_key_set_and_shapes():
    keys = official_state_keys()
    assert len(keys) == 372
    assert {"null_cond_emb", "audio_encoder.masked_spec_embed", "audio_encoder.encoder.pos_conv_embed.conv.weight_g"} <= set(keys)
    assert not any(k.startswith("audio_proj_layer") for k in keys)
    with torch.device("meta"):
        shapes = {k: tuple(v.shape) for k, v in SAID_UNet1D().state_dict().items()}
    assert shapes["null_cond_emb"] == (1, 1, 768)
    assert shapes["denoiser.model.time_embed.0.weight"] == (768, 192)
    assert shapes["denoiser.model.input_blocks.0.0.weight"] == (192, 32, 3)
    assert shapes["denoiser.model.output_blocks.0.0.skip_connection.weight"] == (192, 384, 1)
    assert shapes["denoiser.model.middle_block.1.transformer_blocks.0.attn2.to_k.weight"] == (192, 768)
    assert shapes["denoiser.model.middle_block.1.transformer_blocks.0.ff.net.0.proj.weight"] == (1536, 192)
    assert shapes["denoiser.model.out.2.weight"] == (32, 192, 3)
    # time_embed 4 + conv_in 2 + ResBlock 10 + transformer 24 + middle (10 + 24 + 10)
    # + 2 x (ResBlock with 1x1 skip 12 + transformer 24) + out 4
    assert sum(k.startswith("denoiser.model.") for k in shapes) == 160


@pytest.mark.parametrize("t,s", [(60, 60), (37, 60), (60, 37), (50, 149), (7, 3)])
def test_alignment_mask_is_the_authors_band(t, s):
    assert torch.equal(alignment_mask(t, s), ~_authors_band(t, s))


def test_context_of_another_length_uses_the_general_band():
    state = _authors_state(seed=3)
    model = SAID_UNet1D(tiny_config(), model_channels=WIDTH, num_head_channels=HEAD).eval()
    model.load_state_dict(legacy_to_current(state))
    torch.manual_seed(2)
    x, t = torch.randn(2, 23, 32), torch.tensor([10, 600])
    for frames in (23, 50, 11):
        ctx = torch.randn(2, frames, 32)
        with torch.no_grad():
            torch.testing.assert_close(model(x, t, ctx), _unet(state, x, t, ctx, WIDTH // HEAD), rtol=1e-4, atol=1e-4)
