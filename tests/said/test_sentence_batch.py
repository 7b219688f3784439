"""Utterances of different lengths in one SAiD batch: padded rows give each utterance's own output."""

import numpy as np
import pytest
import torch

from baselines.said.pipeline import SAiD
from baselines.said.unet1d import ConditionalUNet1D
from blendvoca.names import BLENDVOCA_NAMES

LENGTHS = (37, 50, 23)


def _randomised(module, scale=0.05):
    """Give the zero-initialised layers weights, so that every layer shapes the output."""
    with torch.no_grad():
        for p in module.parameters():
            if not p.abs().sum():
                p.normal_(0.0, scale)
    return module


@pytest.fixture(scope="module")
def unet():
    torch.manual_seed(0)
    return _randomised(ConditionalUNet1D(32, 32, 24, model_channels=64, num_head_channels=16, dropout=0.0)).eval()


def _padded_inputs(seed=0):
    gen = torch.Generator().manual_seed(seed)
    xs = [torch.randn(1, 32, n, generator=gen) for n in LENGTHS]
    conds = [torch.randn(1, n, 24, generator=gen) for n in LENGTHS]
    null = torch.randn(1, 1, 24, generator=gen)
    longest = max(LENGTHS)
    x = torch.cat([torch.nn.functional.pad(v, (0, longest - v.shape[2])) for v in xs])
    cond = torch.cat([torch.nn.functional.pad(c, (0, 0, 0, longest - c.shape[1])) for c in conds])
    return xs, conds, null, x, cond


@pytest.mark.parametrize("cached", [False, True])
def test_padded_rows_give_each_sequence_its_own_output(unet, cached):
    xs, conds, null, x, cond = _padded_inputs()
    batch, longest = len(LENGTHS), max(LENGTHS)
    t = torch.tensor([500, 120, 500])
    context = torch.cat([null.expand(batch, longest, -1), cond])  # guidance: the null and the audio condition
    with torch.no_grad():
        if cached:
            out = unet(x, t, None, unet.context_cache(context), lengths=torch.tensor(LENGTHS))
        else:
            out = unet(x, t, context, lengths=torch.tensor(LENGTHS))
        for i, n in enumerate(LENGTHS):
            alone = unet(xs[i], t[i:i + 1], torch.cat([null.expand(1, n, -1), conds[i]]))
            rows = out[[i, batch + i]]
            assert torch.allclose(rows[..., :n], alone, atol=1e-5, rtol=0), (n, (rows[..., :n] - alone).abs().max())
            assert torch.all(rows[..., n:] == 0)


def test_full_lengths_are_the_plain_forward_bit_for_bit(unet):
    _, _, null, x, cond = _padded_inputs()
    t = torch.full((len(LENGTHS),), 300)
    with torch.no_grad():
        plain = unet(x, t, cond)
        full = unet(x, t, cond, lengths=torch.full((len(LENGTHS),), x.shape[2]))
    assert torch.equal(plain, full)


def test_bad_lengths_are_named(unet):
    _, _, _, x, cond = _padded_inputs()
    with pytest.raises(ValueError, match=r"lengths \(B,\) = \(3,\) in 1\.\.50"):
        unet(x, torch.zeros(3, dtype=torch.long), cond, lengths=torch.tensor([10, 60, 5]))


def _utterances(seed=0):
    rng = np.random.default_rng(seed)
    return [((0.1 * rng.standard_normal(int(n / 60 * 16000))).astype(np.float32), n) for n in (61, 97, 80)]


@pytest.fixture(scope="module")
def said():
    torch.manual_seed(0)
    pipeline = SAiD.from_preset(BLENDVOCA_NAMES, "cpu-demo")
    _randomised(pipeline.model)
    return pipeline


@pytest.mark.parametrize("options", [{"guidance": 2.0}, {"guidance": 1.0}, {"guidance": 0.0}, {"sampler": "ddpm", "guidance": 2.0}])
def test_generate_many_equals_one_utterance_at_a_time(said, options):
    utterances = _utterances()
    seeds = [3, 11, 7]
    many = said.generate_many(utterances, samples=2, seeds=seeds, num_steps=6, **options)
    for (audio, frames), seed, got in zip(utterances, seeds, many):
        alone = said.generate(audio, frames, samples=2, seed=seed, num_steps=6, **options)
        assert got.shape == alone.shape == (2, frames, 32)
        np.testing.assert_allclose(got, alone, atol=1e-4, rtol=0)


def test_one_utterance_is_generate_itself_and_seeds_are_checked(said):
    (audio, frames), = _utterances()[:1]
    alone = said.generate(audio, frames, samples=2, seed=5, num_steps=4)
    many, = said.generate_many([(audio, frames)], samples=2, seeds=[5], num_steps=4)
    assert np.array_equal(alone, many)
    with pytest.raises(ValueError, match="one seed per utterance, got 1 for 2"):
        said.generate_many(_utterances()[:2], seeds=[1])


def test_compact_unet_samples_one_utterance_at_a_time():
    torch.manual_seed(0)
    compact = SAiD.from_preset(BLENDVOCA_NAMES, "cpu-demo", architecture="compact")
    _randomised(compact.model)
    utterances = _utterances()[:2]
    many = compact.generate_many(utterances, samples=1, seeds=[1, 2], num_steps=3)
    for (audio, frames), seed, got in zip(utterances, (1, 2), many):
        assert np.array_equal(got, compact.generate(audio, frames, samples=1, seed=seed, num_steps=3))


def test_official_pipeline_batches_sentences_like_one_at_a_time():
    pytest.importorskip("transformers")
    from baselines.said.official import SAID_UNet1D
    from baselines.said.official_pipeline import OfficialSAiD
    from baselines.wav2vec2 import tiny_config

    torch.manual_seed(0)
    model = _randomised(SAID_UNet1D(tiny_config(), model_channels=32, num_head_channels=16), 0.1).eval()
    official = OfficialSAiD(model, {"num_steps": 5})
    utterances = _utterances(1)
    many = official.generate_many(utterances, samples=2, seeds=[0, 1, 2])
    for (audio, frames), seed, got in zip(utterances, (0, 1, 2), many):
        alone = official.generate(audio, frames, samples=2, seed=seed)
        assert got.shape == alone.shape == (2, frames, 32)
        np.testing.assert_allclose(got, alone, atol=1e-4, rtol=0)
