import subprocess
import sys

import numpy as np
import pytest

from baselines.said.generate import checkpoint_file, main, output_paths
from baselines.said.pipeline import SAiD
from tests.fixtures.paths import FsPath


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


def test_entry_points_take_any_path_like(tmp_path, checkpoint, wav):
    from baselines.said.generate import generate_files

    said = SAiD.load(FsPath(checkpoint))
    said.save(FsPath(tmp_path / "again.pt"))
    paths = generate_files(FsPath(wav), FsPath(tmp_path / "y.csv"), checkpoint=FsPath(tmp_path / "again.pt"),
                           image_path=FsPath(tmp_path / "y.png"))
    assert paths == [tmp_path / "y.csv"] and (tmp_path / "y.png").is_file()


@pytest.mark.parametrize("argv, message", [
    (["--samples", "0"], "samples >= 1"),                    # a bad option
    (["--steps", "5000"], "num_steps"),                      # more sampling steps than the checkpoint's diffusion
    (["--device", "tpu"], "--device"),
    (["--strength", "0.5"], "authors' weights"),             # an option of the authors' weights only
])
def test_option_mistakes_are_one_error_line(tmp_path, capsys, checkpoint, wav, argv, message):
    code = main(["--audio", str(wav), "--out", str(tmp_path / "o.csv"), "--checkpoint", str(checkpoint), "--quiet",
                 *argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("error: ") and message in err[0], err
    assert not (tmp_path / "o.csv").exists()


def test_a_file_that_is_no_checkpoint_is_a_data_error(tmp_path, capsys, wav):
    (tmp_path / "said.pt").write_text("not a checkpoint")
    code = main(["--audio", str(wav), "--out", str(tmp_path / "o.csv"), "--checkpoint", str(tmp_path), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "not a readable torch checkpoint" in err[0], err


def test_train_cli_mistakes_are_one_error_line(tmp_path, capsys):
    from baselines.said.train import main as train_main

    for argv, message in ((["--data", str(tmp_path / "none")], "not a directory"),
                          (["--data", str(tmp_path), "--budget", "soon"], "--budget"),
                          (["--data", str(tmp_path), "--max-steps", "0"], "--max-steps")):
        code = train_main([*argv, "--out", str(tmp_path / "said.pt")])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and message in err[0], err
    assert not (tmp_path / "said.pt").exists()


def test_plain_generation_warns_naming_benchmark_generate_and_editing_does_not(tmp_path, checkpoint, wav):
    import warnings

    with pytest.warns(DeprecationWarning, match=r"removed after 2027-06-30: use python -m benchmark.generate "
                                                r"--method said --checkpoint DIR"):
        assert main(["--audio", str(wav), "--out", str(tmp_path / "p.csv"), "--checkpoint", str(checkpoint)]) == 0
    assert (tmp_path / "p.csv").is_file()  # still generates
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)  # the image is this command's own: no warning
        assert main(["--audio", str(wav), "--out", str(tmp_path / "i.csv"), "--checkpoint", str(checkpoint),
                     "--image", str(tmp_path / "i.png")]) == 0
