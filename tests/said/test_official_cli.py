"""The authors' weights through the command line and the benchmark method (tiny wav2vec 2.0 config)."""

import numpy as np
import pytest
import torch

pytest.importorskip("transformers")

import baselines.said.official as official  # noqa: E402
from baselines.said.coeff_image import coefficient_image  # noqa: E402
from baselines.said.official import SAID_UNet1D  # noqa: E402
from baselines.wav2vec2 import legacy_layout_state, tiny_config  # noqa: E402


@pytest.fixture
def weights(tmp_path, monkeypatch):
    """A SAiD.pth in the published layout, with the tiny encoder standing in for base-960h."""
    monkeypatch.setattr(official, "base_config", lambda: tiny_config())
    torch.manual_seed(0)
    model = SAID_UNet1D(tiny_config(), model_channels=64)
    with torch.no_grad():
        for name, p in model.denoiser.named_parameters():
            if name.endswith("out.2.weight"):
                p.normal_(0, 0.05)
    path = tmp_path / "SAiD.pth"
    torch.save(legacy_layout_state(model.state_dict()), path)
    return path


@pytest.fixture
def wav(tmp_path):
    from blendvoca.io.audio import write_wav

    path = tmp_path / "a.wav"
    rng = np.random.default_rng(0)
    write_wav(path, (0.1 * rng.standard_normal(12345)).astype(np.float32), 16000)
    return path


def test_generate_cli_with_official_weights(weights, wav, tmp_path):
    from baselines.said.generate import main
    from blendvoca.io.coeffs import read_coeffs_csv, write_coeffs_csv
    from blendvoca.names import BLENDVOCA_NAMES

    out = tmp_path / "o.csv"
    main(["--audio", str(wav), "--out", str(out), "--checkpoint", str(weights), "--official", "--steps", "4",
          "--eta", "0.5", "--guidance-rescale", "0.5", "--image", str(tmp_path / "o.png"),
          "--intermediates", str(tmp_path / "interm")])
    coeffs, names = read_coeffs_csv(out)
    assert names == BLENDVOCA_NAMES and coeffs.shape == (int(12345 * 60 / 16000), 32)
    assert 0 <= coeffs.min() and coeffs.max() <= 1
    from PIL import Image

    # --image: the labelled figure (a row per blendshape name, time axis, title, colour bar), not the raw strip
    picture = np.asarray(Image.open(tmp_path / "o.png"))
    assert picture.shape[1] > picture.shape[0] > 300 and picture.shape[:2] != coefficient_image(coeffs).shape
    # --intermediates keep the raw strip beside their CSVs: row k = blendshape k, column t = frame t
    last, _ = read_coeffs_csv(tmp_path / "interm" / "1.csv")
    assert np.array_equal(np.asarray(Image.open(tmp_path / "interm" / "1.png")),
                          coefficient_image(last.astype(np.float32)))
    assert sorted(p.name for p in (tmp_path / "interm").iterdir()) == ["1.csv", "1.png", "2.csv", "2.png", "3.csv", "3.png", "4.csv", "4.png"]
    # editing: strength 0.5 from a reference, the mask keeps the first 10 frames
    ref = np.full_like(coeffs, 0.25)
    mask = np.zeros_like(coeffs)
    mask[:10] = 1
    write_coeffs_csv(tmp_path / "r.csv", ref, names)
    write_coeffs_csv(tmp_path / "m.csv", mask, names)
    main(["--audio", str(wav), "--out", str(out), "--checkpoint", str(weights), "--steps", "4", "--strength", "0.5",
          "--reference", str(tmp_path / "r.csv"), "--mask", str(tmp_path / "m.csv")])
    edited, _ = read_coeffs_csv(out)
    np.testing.assert_allclose(edited[:10], 0.25, atol=1e-6)


def test_authors_only_options_need_the_authors_weights(tmp_path, wav):
    from baselines.said.generate import generate_files
    from baselines.said.pipeline import SAiD
    from blendvoca.names import BLENDVOCA_NAMES

    said = SAiD.from_preset(BLENDVOCA_NAMES, "cpu-demo", channels=32)
    said.save(tmp_path / "said.pt")
    with pytest.raises(ValueError, match="--guidance-rescale.*authors' weights"):
        generate_files(wav, tmp_path / "x.csv", checkpoint=tmp_path / "said.pt", guidance_rescale=0.5)
    with pytest.raises(ValueError, match="--official expects"):
        generate_files(wav, tmp_path / "x.csv", checkpoint=tmp_path / "said.pt", official=True)


def test_benchmark_loads_official_weights_from_a_file(weights):
    from baselines.said.plugin import SAiDMethod
    from benchmark.methods.base import Budget
    from benchmark.methods.contract import Utterance
    from benchmark.protocol import prepared_method

    method, timings = prepared_method("said", {"official_steps": 3}, None, seed=0, budget=Budget(), checkpoint=weights)
    assert isinstance(method, SAiDMethod) and timings["train_s"] is None and method.said.sampling["num_steps"] == 3
    utt = Utterance(subject="s", sentence="x", split="test", audio=np.zeros(8000, np.float32) + 0.01, num_frames=31)
    out = method.generate(utt, samples=2, seed=1)
    assert out.shape == (2, 31, 32) and np.all((0 <= out) & (out <= 1))
    np.testing.assert_array_equal(out, method.generate(utt, samples=2, seed=1))
