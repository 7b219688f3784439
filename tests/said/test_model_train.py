import numpy as np
import pytest
import torch

from baselines.said.model import SAiDModel, timestep_embedding
from baselines.said.pipeline import SAiD
from baselines.said.presets import resolve_config
from baselines.said.train import diffusion_loss, train_said

NAMES = ("a", "b", "c", "d")
TINY = {"channels": 16, "cond_dim": 16, "heads": 2, "window": 30, "batch_size": 8, "num_steps": 5, "warmup_steps": 5, "val_every": 20, "num_threads": 1}


def toy_pairs(n, seed):
    """Coefficient 0 follows the loudness envelope of tone bursts; the others are constant."""
    rng = np.random.default_rng(seed)
    pairs = []
    for _ in range(n):
        frames = int(rng.integers(40, 70))
        env = (np.sin(np.arange(frames) / 60 * 2 * np.pi * rng.uniform(1, 3) + rng.uniform(0, 6)) > 0).astype(float)
        coeffs = np.column_stack([env, np.full(frames, 0.3), np.full(frames, 0.6), 0.1 + 0.1 * env])
        t = np.arange(frames * 16000 // 60) / 16000
        audio = 0.3 * np.sin(2 * np.pi * 440 * t) * np.repeat(env, 16000 // 60 + 1)[: t.size]
        pairs.append((coeffs, audio.astype(np.float32)))
    return pairs


def test_timestep_embedding_closed_form():
    e = timestep_embedding(torch.tensor([0, 7]), 4)
    torch.testing.assert_close(e[0], torch.tensor([1.0, 1.0, 0.0, 0.0]))
    torch.testing.assert_close(e[1], torch.tensor([np.cos(7.0), np.cos(0.07), np.sin(7.0), np.sin(0.07)], dtype=torch.float32))


def test_denoiser_shapes_for_any_length_and_trainable_split():
    torch.manual_seed(0)
    m = SAiDModel(num_coeffs=4, channels=16, cond_dim=16, heads=2)
    for frames in (2, 17, 61):
        feats = m.audio_features(torch.randn(2, frames * 16000 // 60), frames)
        cond = m.condition(feats, drop=torch.tensor([True, False]))
        torch.testing.assert_close(cond[0], m.null_cond.expand(frames, -1))
        assert m(torch.randn(2, frames, 4), torch.tensor([3, 900]), cond).shape == (2, frames, 4)
    names = {n for n, p in m.named_parameters() if p.requires_grad}
    assert "null_cond" in names and not any(n.startswith("encoder.") for n in names)


def test_short_training_reduces_the_loss():
    said = SAiD.from_preset(NAMES, lr=3e-3, ema_decay=0.9, **TINY)
    pairs = toy_pairs(6, 0)
    c = torch.from_numpy(np.stack([p[0][:30] for p in pairs])).float()
    a = torch.from_numpy(np.stack([p[1][:8000] for p in pairs]))

    def loss():
        with torch.no_grad():
            return float(diffusion_loss(said, c, a, generator=torch.Generator().manual_seed(5)))

    before = loss()
    history = train_said(said, pairs, toy_pairs(2, 1), seed=0, max_steps=80)
    after = loss()
    assert history["steps"] == 80 and len(history["train_loss"]) == 80
    assert history["best_step"] in (20, 40, 60, 80)
    assert after < 0.75 * before, (before, after)


@pytest.mark.parametrize("encoder", ["logmel", "wav2vec2-tiny"])
def test_save_load_round_trip_is_exact(tmp_path, encoder):
    said = SAiD.from_preset(NAMES, encoder=encoder, **TINY)
    train_said(said, toy_pairs(3, 2), seed=1, max_steps=3)
    path = said.save(tmp_path / "ck" / "said.pt")
    back = SAiD.load(path)
    assert back.config == said.config and back.names == NAMES and back.history == said.history
    sd1, sd2 = said.model.state_dict(), back.model.state_dict()
    assert sd1.keys() == sd2.keys()
    for k in sd1:
        assert torch.equal(sd1[k], sd2[k]), k
    audio = toy_pairs(1, 3)[0][1]
    np.testing.assert_array_equal(said.generate(audio, samples=2, seed=3), back.generate(audio, samples=2, seed=3))


def test_generate_output_range_diversity_and_seed():
    said = SAiD.from_preset(NAMES, **TINY)
    audio = toy_pairs(1, 4)[0][1]
    out = said.generate(audio, 50, samples=3, seed=0)
    assert out.shape == (3, 50, 4) and out.dtype == np.float64
    assert out.min() >= 0 and out.max() <= 1
    assert np.abs(out[0] - out[1]).mean() > 1e-3
    np.testing.assert_array_equal(out, said.generate(audio, 50, samples=3, seed=0))
    assert said.generate(audio, samples=1, sampler="ddpm", num_steps=4, guidance=0).shape == (1, round(audio.size * 60 / 16000), 4)


def test_config_resolution_and_errors():
    cfg = resolve_config("cpu-demo", channels=32, sampler="ddpm")
    assert cfg["model"]["channels"] == 32 and cfg["sampling"]["sampler"] == "ddpm" and cfg["preset"] == "cpu-demo"
    paper = resolve_config("paper", wav2vec2_path="/some/dir")
    assert paper["model"]["encoder"] == {"kind": "wav2vec2", "path": "/some/dir"}
    assert paper["sampling"]["num_steps"] == 1000 and paper["training"]["lr"] == 1e-5 and paper["training"]["ema_decay"] == 0.9999
    with pytest.raises(ValueError, match="chanels"):
        resolve_config("cpu-demo", chanels=3)
    with pytest.raises(ValueError, match="cpu-demo"):
        resolve_config("cpu_demo")


def test_train_rejects_bad_pairs():
    said = SAiD.from_preset(NAMES, **TINY)
    with pytest.raises(ValueError, match=r"\(T>=2, 4\)"):
        train_said(said, [(np.zeros((10, 3)), np.zeros(100, np.float32))], max_steps=1)
    with pytest.raises(TypeError, match="pairs"):
        train_said(said, [np.zeros((10, 4))], max_steps=1)


def test_v_loss_space_is_l1_plus_velocity_on_the_v_target():
    """loss_space='v': the loss equals said_loss on v = sqrt(a) eps - sqrt(1-a) x0 (and trains high noise)."""
    from baselines.said.losses import said_loss
    from baselines.said.schedule import add_noise, alphas_of

    said = SAiD.from_preset(NAMES, prediction="v", loss_space="v", **TINY)
    pairs = toy_pairs(4, 0)
    c = torch.from_numpy(np.stack([p[0][:30] for p in pairs])).float()
    a = torch.from_numpy(np.stack([p[1][:8000] for p in pairs]))
    with torch.no_grad():
        got = diffusion_loss(said, c, a, generator=torch.Generator().manual_seed(5))
        g = torch.Generator().manual_seed(5)
        x0 = said.to_diffusion(c)
        t = torch.randint(0, said.alphas_cumprod.shape[0], (4,), generator=g)
        noise = torch.randn(x0.shape, generator=g)
        x_t = add_noise(x0, noise, t, said.alphas_cumprod)
        m = said.model
        out = m(x_t, t, m.condition(m.audio_features(a, 30)))
        ab = alphas_of(t, said.alphas_cumprod)[:, None, None]
        want = said_loss(ab.sqrt() * noise - (1 - ab).sqrt() * x0, out)
    torch.testing.assert_close(got, want)
    with pytest.raises(ValueError, match="loss_space"):
        diffusion_loss(SAiD.from_preset(NAMES, prediction="epsilon", loss_space="v", **TINY), c, a)


def test_a_step_budget_alone_ignores_the_presets_time_cap():
    said = SAiD.from_preset(NAMES, **TINY)
    said.config["training"]["max_seconds"] = 0.0  # a time cap that would stop at once
    history = train_said(said, toy_pairs(3, 2), seed=1, max_steps=3)
    assert history["steps"] == 3
    said = SAiD.from_preset(NAMES, **TINY)
    said.config["training"]["max_seconds"] = 0.0
    assert train_said(said, toy_pairs(3, 2), seed=1)["steps"] == 0  # no budget: the preset's cap


@pytest.mark.slow
def test_train_cli_seed_fixes_the_initial_weights_too(built_dataset, tmp_path):
    """``python -m baselines.said.train --max-steps N --seed S`` writes the same network
    whatever state the global RNG was in before."""
    from baselines.said.train import main

    states = []
    for global_seed in (1, 2):
        torch.manual_seed(global_seed)
        out = tmp_path / f"said-{global_seed}.pt"
        main(["--data", str(built_dataset), "--out", str(out), "--max-steps", "2", "--seed", "4"])
        states.append(SAiD.load(out).model.state_dict())
    for key in states[0]:
        torch.testing.assert_close(states[0][key], states[1][key], rtol=0, atol=0, msg=key)


def test_budget_decay_closed_forms():
    from baselines.said.train import budget_decay

    assert [budget_decay("constant", d) for d in (0.0, 0.5, 1.0)] == [1.0, 1.0, 1.0]
    assert [budget_decay("linear", d) for d in (0.0, 0.25, 1.0, 2.0)] == [1.0, 0.75, 0.0, 0.0]
    assert budget_decay("cosine", 0.5) == pytest.approx(0.5) and budget_decay("cosine", 1.0) == pytest.approx(0.0)
    with pytest.raises(ValueError, match="lr_decay"):
        budget_decay("step", 0.5)


def test_linear_lr_decay_reaches_zero_at_the_end_of_a_step_budget():
    lr = resolve_config(**TINY)["training"]["lr"]
    said = SAiD.from_preset(NAMES, **{**TINY, "warmup_steps": 1}, lr_decay="linear")
    history = train_said(said, toy_pairs(3, 2), seed=1, max_steps=4)
    np.testing.assert_allclose(history["lr"], [lr, 0.75 * lr, 0.5 * lr, 0.25 * lr], rtol=1e-12)
    said = SAiD.from_preset(NAMES, **{**TINY, "warmup_steps": 2})  # constant: warm-up, then the preset's rate
    np.testing.assert_allclose(train_said(said, toy_pairs(3, 2), seed=1, max_steps=3)["lr"],
                               [0.5 * lr, lr, lr], rtol=1e-12)
    with pytest.raises(ValueError, match="lr_decay"):
        train_said(SAiD.from_preset(NAMES, **TINY, lr_decay="exp"), toy_pairs(3, 2), max_steps=1)


def test_zero_init_starts_the_authors_output_layers_at_zero_or_not():
    """``zero_init`` (default True) changes the initial values only: the same parameters, and
    with it the untrained network predicts exactly zero."""
    torch.manual_seed(0)
    zero = SAiDModel(num_coeffs=4, channels=16, cond_dim=16, heads=2, architecture="authors")
    torch.manual_seed(0)
    other = SAiDModel(num_coeffs=4, channels=16, cond_dim=16, heads=2, architecture="authors", zero_init=False)
    layers = zero.denoiser.zero_initialised_layers()
    assert len(layers) == 5 + 4 + 1  # five residual blocks, four transformers, the output convolution
    assert all(not p.any() for layer in layers for p in layer.parameters())
    assert all(layer.weight.abs().sum() > 0 for layer in other.denoiser.zero_initialised_layers())
    assert {k: v.shape for k, v in zero.state_dict().items()} == {k: v.shape for k, v in other.state_dict().items()}
    x, cond = torch.randn(2, 20, 4), torch.randn(2, 20, 16)
    assert not zero(x, torch.tensor([3, 500]), cond).any()
    assert other(x, torch.tensor([3, 500]), cond).abs().sum() > 0


def test_zero_init_groups_keep_the_named_layers_at_zero_and_no_others():
    """A list of groups keeps exactly those layers at zero; ``False`` draws the same default
    initial values as a list that names none, and an unknown group is an error."""
    def model(zero_init):
        torch.manual_seed(0)
        return SAiDModel(num_coeffs=4, channels=16, cond_dim=16, heads=2, architecture="authors", zero_init=zero_init)

    sizes = {"res": 5, "attention": 4, "out": 1}
    for groups in (["res"], ["attention"], ["out"], ["res", "out"]):
        net = model(groups).denoiser
        zeroed = {id(layer) for layer in net.zero_initialised_layers(groups)}
        assert len(zeroed) == sum(sizes[g] for g in groups)
        for layer in net.zero_initialised_layers():
            assert (not layer.weight.any()) == (id(layer) in zeroed)
    none, listed_none = model(False).state_dict(), model([]).state_dict()
    assert all(torch.equal(none[k], listed_none[k]) for k in none)
    with pytest.raises(ValueError, match="zero_init"):
        model(["proj"])
    with pytest.raises(ValueError, match="zero_init"):  # checked for the compact UNet too
        SAiDModel(num_coeffs=4, channels=16, cond_dim=16, heads=2, architecture="compact", zero_init="yes")
    with pytest.raises(ValueError, match="zero-init groups"):
        model(True).denoiser.zero_initialised_layers(["proj"])
