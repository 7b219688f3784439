import numpy as np
import pytest
import torch

from benchmark.features import CoeffsVAE, encode_windows, load_published_vae, load_vae_state
from benchmark.features.train import cyclical_beta, train_vae, vae_losses, warmup_lr_factor


def test_published_checkpoint_loads_strictly_and_is_deterministic(assets_dir):
    path = assets_dir / "said" / "vae.pth"
    state = torch.load(path, map_location="cpu", weights_only=True)
    model = load_published_vae(path)
    assert not model.training
    own = model.state_dict()
    assert set(own) == set(state)
    assert all(own[k].shape == state[k].shape for k in state)
    rng = np.random.default_rng(0)
    windows = rng.uniform(0, 0.5, size=(7, 120, 32)).astype(np.float32)
    with torch.no_grad():
        mean = model.encode(torch.as_tensor(windows))
    assert mean.shape == (7, 64)
    again = encode_windows(load_published_vae(path), windows, batch_size=3)
    np.testing.assert_allclose(again, mean.double().numpy(), rtol=1e-4, atol=1e-5)  # float32 batching
    np.testing.assert_array_equal(encode_windows(model, windows), encode_windows(model, windows))


def test_resolve_default_path(assets_dir, monkeypatch):
    monkeypatch.setenv("BLENDVOCA_ASSETS", str(assets_dir))
    model = load_published_vae()
    assert isinstance(model, CoeffsVAE)


def test_strict_loading_rejects_other_shapes():
    state = CoeffsVAE().state_dict()
    state["encoder.fc_layers.0.weight"] = torch.zeros(256, 100)
    with pytest.raises(RuntimeError, match="size mismatch"):
        load_vae_state(state)
    with pytest.raises(ValueError, match="lacks the key"):
        load_vae_state({"foo": torch.zeros(1)})


def test_encode_checks_shape():
    with pytest.raises(ValueError, match=r"\(B, 120, 32\)"):
        CoeffsVAE().eval().encode(torch.zeros(2, 100, 32))


def test_schedules():
    betas = [cyclical_beta(s, 100, n_cycles=5, ratio=0.5) for s in range(100)]
    assert betas[0] == 0.0 and betas[20] == 0.0 and betas[80] == 0.0
    assert betas[5] == pytest.approx(0.5) and max(betas) == 1.0
    assert betas[12] == 1.0 and betas[19] == 1.0
    assert warmup_lr_factor(0, 10) == 0.0 and warmup_lr_factor(5, 10) == 0.5 and warmup_lr_factor(50, 10) == 1.0


def test_losses_closed_form():
    model = CoeffsVAE().eval()
    x = torch.rand(3, 120, 32)
    std = torch.full((32,), 0.5)
    reconst, kl, vel = vae_losses(model, x, std, sample=False)
    mean, log_var, _, recon = model(x, sample=False)
    assert reconst.item() == pytest.approx((0.5 * ((x - recon) / 0.5) ** 2).sum().item() / 3, rel=1e-5)
    expected_kl = 0.5 * (mean**2 + log_var.exp() - log_var - 1).sum().item() / 3
    assert kl.item() == pytest.approx(expected_kl, rel=1e-5)
    dv = (torch.diff(x, dim=1) - torch.diff(recon, dim=1)) / 0.5
    assert vel.item() == pytest.approx(0.5 * (dv**2).sum().item() / 3, rel=1e-5)


@pytest.fixture
def one_thread():
    # a tiny network: thread hand-offs cost more than they save on a shared CPU
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


def test_training_reduces_loss(one_thread):
    rng = np.random.default_rng(0)
    t = np.linspace(0, 20, 300)[:, None]
    tracks = [0.5 + 0.4 * np.sin(t * rng.uniform(0.5, 2, size=32) + rng.uniform(0, 6, size=32)) for _ in range(4)]
    std = np.full(32, 0.3)
    windows = torch.as_tensor(np.stack([tr[:120] for tr in tracks]), dtype=torch.float32)
    torch.manual_seed(0)
    before = CoeffsVAE().eval()
    model = train_vae(tracks, std, steps=40, batch_size=8, lr=3e-3, seed=0, n_cycles=1)
    with torch.no_grad():
        loss_before = vae_losses(before, windows, torch.as_tensor(std, dtype=torch.float32), sample=False)[0]
        loss_after = vae_losses(model, windows, torch.as_tensor(std, dtype=torch.float32), sample=False)[0]
    assert loss_after < 0.5 * loss_before
    assert not model.training


def test_training_cli(fake_dataset_dir, tmp_path, assets_dir, monkeypatch, one_thread):
    from benchmark.features.train import main

    monkeypatch.setenv("BLENDVOCA_ASSETS", str(assets_dir))
    out = tmp_path / "vae.pth"
    main(["--data", str(fake_dataset_dir), "--out", str(out), "--max-steps", "3", "--batch-size", "2"])
    model = load_published_vae(out)
    assert model.encode(torch.zeros(1, 120, 32)).shape == (1, 64)


@pytest.mark.parametrize("argv, steps, seconds", [
    ([], 300, None),
    (["--max-steps", "7"], 7, None),
    (["--budget", "12"], 12, None),
    (["--budget", "5m"], 300, 300.0),
    (["--budget", "steps=12,seconds=30", "--max-steps", "4"], 4, 30.0),
])
def test_training_cli_budget(fake_dataset_dir, tmp_path, assets_dir, monkeypatch, argv, steps, seconds):
    import benchmark.features.train as train

    monkeypatch.setenv("BLENDVOCA_ASSETS", str(assets_dir))
    seen = {}

    def fake_train(tracks, std, **kwargs):
        seen.update(kwargs)
        return CoeffsVAE()

    monkeypatch.setattr(train, "train_vae", fake_train)
    assert train.main(["--data", str(fake_dataset_dir), "--out", str(tmp_path / "vae.pth"), *argv]) == 0
    assert (seen["steps"], seen["max_seconds"]) == (steps, seconds)


def test_training_cli_refuses_a_bad_budget_in_one_line(fake_dataset_dir, tmp_path, capsys):
    from benchmark.features.train import main

    assert main(["--data", str(fake_dataset_dir), "--out", str(tmp_path / "vae.pth"), "--budget", "soon"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: --budget")


def test_training_stops_at_the_time_budget(one_thread):
    import time

    rng = np.random.default_rng(0)
    tracks = [rng.uniform(size=(150, 32)) for _ in range(2)]
    start = time.perf_counter()
    model = train_vae(tracks, np.full(32, 0.3), steps=10**6, max_seconds=0.5, batch_size=2)
    assert time.perf_counter() - start < 30 and not model.training
