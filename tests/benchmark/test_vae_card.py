"""A VAE's card (the shapes it was trained on) and the refusal of a VAE of another shape set."""

import json

import pytest
import torch

from benchmark.features import CoeffsVAE
from benchmark.features.card import check_vae_fits, read_vae_card, vae_card_path, vae_channels, write_vae_card
from blendvoca.errors import UserError
from blendvoca.io.torch_file import write_torch_file

NAMES = [f"shape{i}" for i in range(6)]


def _vae(tmp_path, channels, names=None, name="vae.pth"):
    path = tmp_path / name
    write_torch_file(path, CoeffsVAE(channels=channels).state_dict())
    if names is not None:
        write_vae_card(path, names, recipe_id="r" * 64, dataset="facegood", steps=3, seed=0)
    return path


def test_the_card_records_the_names_and_the_count_is_read_off_the_weights(tmp_path):
    path = _vae(tmp_path, 6, NAMES)
    assert vae_card_path(path).name == "vae.pth.json"
    assert read_vae_card(path) == {"names": NAMES, "data": {"recipe_id": "r" * 64, "dataset": "facegood"},
                                   "steps": 3, "seed": 0}
    assert vae_channels(path) == 6 and vae_channels(_vae(tmp_path, 9, name="other.pth")) == 9
    assert read_vae_card(tmp_path / "other.pth") is None
    check_vae_fits(path, NAMES)  # its own shapes: fits


def test_a_vae_of_another_shape_set_is_refused_by_count_and_by_name(tmp_path):
    with pytest.raises(UserError, match=r"a VAE of 9 coefficients, but the build has 6 \(shape0, shape1, shape2"):
        check_vae_fits(_vae(tmp_path, 9, name="nine.pth"), NAMES, data="BUILD")
    swapped = NAMES[:2] + [NAMES[3], NAMES[2]] + NAMES[4:]
    with pytest.raises(UserError, match="a VAE trained on another shape set, trained on facegood build rrrrrrrrrrrr: "
                                        "its column 2 is 'shape3', the build's is 'shape2'") as error:
        check_vae_fits(_vae(tmp_path, 6, swapped), NAMES, data="BUILD")
    assert "python -m benchmark.features.train --data BUILD" in str(error.value)
    # without a card only the count can be checked
    check_vae_fits(_vae(tmp_path, 6, name="bare.pth"), swapped)
    with pytest.raises(UserError, match=r"--vae .*none\.pth: no such file \(a VAE state dict"):
        check_vae_fits(tmp_path / "none.pth", NAMES)


def test_trained_on_a_build_the_vae_carries_that_builds_names(tmp_path, built_dataset):
    from benchmark.data import open_blendvoca
    from benchmark.features.train import train_vae_on_build

    out = tmp_path / "vae.pth"
    train_vae_on_build(built_dataset, out, steps=2)
    card = json.loads(vae_card_path(out).read_text())
    dataset = open_blendvoca(built_dataset)
    assert card["names"] == list(dataset.names) and card["data"]["recipe_id"] == dataset.recipe_id
    assert card["steps"] == 2 and vae_channels(out) == len(dataset.names)
    loaded = torch.load(out, weights_only=True)
    assert loaded["encoder.conv_layers.0.weight"].shape[1] == len(dataset.names)


def test_benchmark_run_refuses_a_vae_of_another_shape_set_before_anything_runs(tmp_path, built_dataset, capsys):
    from benchmark.run import main

    vae = _vae(tmp_path, 52, [f"s{i}" for i in range(52)])
    code = main(["--method", "static", "--data", str(built_dataset), "--vae", str(vae),
                 "--results", str(tmp_path / "results"), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith(f"error: --vae {vae}: a VAE of 52 coefficients, trained on facegood build rrrrrrrrrrrr, "
                             "but the build has 32")
    assert not any((tmp_path / "results").glob("*.json"))
