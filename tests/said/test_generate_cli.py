import subprocess
import sys

import numpy as np
import pytest

from baselines.said.generate import checkpoint_file, main, output_paths
from baselines.said.pipeline import SAiD


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory):
    from blendvoca.names import BLENDVOCA_NAMES

    said = SAiD.from_preset(BLENDVOCA_NAMES, channels=16, cond_dim=16, heads=2, num_steps=4)
    return said.save(tmp_path_factory.mktemp("said") / "said.pt")


@pytest.fixture(scope="module")
def wav(tmp_path_factory):
    from blendvoca.io.audio import write_wav

    path = tmp_path_factory.mktemp("audio") / "x.wav"
    t = np.arange(22050) / 22050  # 1 s at 22.05 kHz: exercises resampling
    write_wav(path, 0.3 * np.sin(2 * np.pi * 200 * t), 22050)
    return path


def test_generate_writes_one_csv_per_sample(tmp_path, checkpoint, wav):
    from blendvoca.io.coeffs import read_coeffs_csv
    from blendvoca.names import BLENDVOCA_NAMES

    main(["--audio", str(wav), "--out", str(tmp_path / "y.csv"), "--checkpoint", str(checkpoint.parent), "--samples", "2"])
    tracks = []
    for path in output_paths(tmp_path / "y.csv", 2):
        coeffs, names = read_coeffs_csv(path)
        assert names == BLENDVOCA_NAMES and coeffs.shape == (60, 32)
        assert coeffs.min() >= 0 and coeffs.max() <= 1
        tracks.append(coeffs)
    assert not np.allclose(tracks[0], tracks[1])


def test_generate_editing_keeps_the_reference(tmp_path, checkpoint, wav):
    from blendvoca.io.coeffs import read_coeffs_csv, write_coeffs_csv
    from blendvoca.names import BLENDVOCA_NAMES

    rng = np.random.default_rng(0)
    ref = np.round(rng.random((50, 32)), 6)
    mask = np.zeros((50, 32))
    mask[:10], mask[-10:] = 1, 1
    # columns in another order: the CLI maps them by name
    order = list(reversed(BLENDVOCA_NAMES))
    write_coeffs_csv(tmp_path / "ref.csv", ref[:, ::-1], order)
    write_coeffs_csv(tmp_path / "mask.csv", mask[:, ::-1], order)
    main(["--audio", str(wav), "--out", str(tmp_path / "e.csv"), "--checkpoint", str(checkpoint),
          "--reference", str(tmp_path / "ref.csv"), "--mask", str(tmp_path / "mask.csv")])
    out, _ = read_coeffs_csv(tmp_path / "e.csv", names=BLENDVOCA_NAMES)
    assert out.shape == (50, 32)
    np.testing.assert_allclose(out[mask == 1], ref[mask == 1], atol=1e-6)


def test_missing_checkpoint_explains(tmp_path, monkeypatch):
    monkeypatch.delenv("BLENDVOCA_SAID_CHECKPOINT", raising=False)
    with pytest.raises(ValueError, match="--checkpoint"):
        checkpoint_file(None)
    with pytest.raises(ValueError, match="found none"):
        checkpoint_file(tmp_path)


def test_module_runs_as_a_script():
    out = subprocess.run([sys.executable, "-m", "baselines.said.generate", "--help"], capture_output=True, text=True, check=True)
    assert "--reference" in out.stdout and "--samples" in out.stdout


def test_cli_mistake_is_one_error_line(tmp_path, capsys):
    from baselines.said.generate import main

    code = main(["--audio", str(tmp_path / "missing.wav"), "--out", str(tmp_path / "o.csv"),
                 "--checkpoint", str(tmp_path / "none")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("error: ")
    assert not (tmp_path / "o.csv").exists()
