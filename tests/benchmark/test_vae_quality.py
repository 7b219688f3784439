"""A VAE's held-out reconstruction R^2 (benchmark.features.quality), the trainer's start from the
published VAE (--init published) and KL weight (--beta), and the sanity suite scoring with a given VAE."""

import json

import numpy as np
import pytest
import torch

from benchmark.features.card import read_vae_card
from benchmark.features.quality import MIN_RECONSTRUCTION_R2, held_out_windows, reconstruction_r2


class _Fixed:
    """encode/decode with a known reconstruction: the input back (``gain`` 1), a shrunk copy, or one window."""

    def __init__(self, gain=1.0, constant=None):
        self.gain, self.constant = gain, constant

    def encode(self, x):
        return x

    def decode(self, z):
        return self.gain * z if self.constant is None else torch.as_tensor(self.constant).expand_as(z).clone()


def test_r2_is_one_for_a_perfect_reconstruction_and_at_most_zero_for_one_window_whatever_the_input():
    rng = np.random.default_rng(0)
    windows = rng.uniform(0, 1, size=(12, 120, 4)).astype(np.float32)
    std = np.array([0.1, 0.2, 0.3, 0.4])
    assert reconstruction_r2(_Fixed(), windows, std) == pytest.approx(1.0)
    # x - 0.5 x leaves a quarter of each window's energy about 0; about the mean, the closed form
    x = windows / std
    expected = 1 - ((0.5 * x) ** 2).sum() / ((x - x.mean(axis=(0, 1))) ** 2).sum()
    assert reconstruction_r2(_Fixed(gain=0.5), windows, std) == pytest.approx(expected)
    # a decoder that ignores its latent: the windows' mean is its best answer, R^2 = 0; any other, below
    assert reconstruction_r2(_Fixed(constant=windows.mean(axis=(0, 1))), windows, std) == pytest.approx(0, abs=1e-6)
    assert reconstruction_r2(_Fixed(constant=np.zeros(4, dtype=np.float32)), windows, std) < 0 < MIN_RECONSTRUCTION_R2
    assert reconstruction_r2(_Fixed(), windows[:1], std) is None


def test_held_out_windows_hop_over_every_track():
    tracks = [np.zeros((150, 3)), np.zeros((119, 3)), np.zeros((240, 3))]
    assert held_out_windows(tracks).shape == (2 + 0 + 5, 120, 3)  # starts 0, 30 | none | 0, 30, ..., 120


def test_the_trainer_starts_from_the_published_vae_and_records_its_start_and_r2(tmp_path):
    from benchmark.features.train import train_vae_on_build
    from benchmark.features.vae import load_published_vae, load_vae_state
    from benchmark.protocol import default_data_root

    out = tmp_path / "vae.pth"
    train_vae_on_build(default_data_root(), out, steps=1, init="published", lr=1e-12)
    card = read_vae_card(out)
    assert card["init"] == "published" and "beta" not in card
    assert isinstance(card["reconstruction_r2"], float)
    # one step at a vanishing learning rate: the published weights, moved by nothing to see
    tuned, published = load_vae_state(torch.load(out)), load_published_vae()
    for (name, a), b in zip(tuned.state_dict().items(), published.state_dict().values()):
        if a.dtype.is_floating_point and "running" not in name:
            assert torch.allclose(a, b, atol=1e-6), name


def test_bad_init_and_beta_are_refused_in_one_line(tmp_path, capsys):
    from benchmark.features.train import main
    from benchmark.protocol import default_data_root

    data = str(default_data_root())
    capsys.readouterr()
    for argv, message in ((["--init", str(tmp_path / "none.pth")], "--init "), (["--beta", "0"], "--beta: expected")):
        assert main(["--data", data, "--out", str(tmp_path / "v.pth"), "--max-steps", "1", *argv]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("error: " + message), err
    assert not (tmp_path / "v.pth").exists()


def test_the_sanity_suite_scores_the_latent_metrics_with_a_given_vae(tmp_path, capsys):
    from benchmark.features.train import train_vae_on_build
    from benchmark.protocol import default_data_root
    from benchmark.sanity.__main__ import main

    data = default_data_root()
    vae = tmp_path / "vae.pth"
    train_vae_on_build(data, vae, steps=2)
    args = ["--data", str(data), "--disturbances", "noise", "--quiet"]
    main([*args, "--out", str(tmp_path / "own"), "--vae", str(vae)])
    main([*args, "--out", str(tmp_path / "published")])
    meta = json.loads((tmp_path / "own" / "sanity_meta.json").read_text())
    assert meta["evaluation"]["vae"] == str(vae.resolve())
    own, published = (json.loads((tmp_path / d / "sanity.json").read_text())["fd"]["noise"]["values"]
                      for d in ("own", "published"))
    assert not np.allclose(own, published)
    capsys.readouterr()
    assert main([*args, "--out", str(tmp_path / "x"), "--vae", str(tmp_path / "missing.pth")]) == 2
    assert capsys.readouterr().err.startswith("error: --vae ")
