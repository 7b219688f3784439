"""``python -m benchmark.generate``: one command, the same flags, for every method of the registry.

Each method kind animates a real recording (the VOCA test sentence of ``$BLENDVOCA_ASSETS``,
22 kHz mono, resampled to the methods' 16 kHz) from a checkpoint folder that
``benchmark.run --checkpoint`` would write (trained for two steps on the test kit's fake
corpus), or from nothing for a method that trains nothing; bad input is one ``error:``
line, exit 2, and nothing written.
"""

from __future__ import annotations

import numpy as np
import pytest
import soundfile

from benchmark import generate as gen
from benchmark.methods import COEFFICIENT_NAMES, Budget, available_methods, get_method
from benchmark.protocol.training import prepared_method
from benchmark.testing import FakeBlendVOCA
from blendvoca import cli
from blendvoca.assets import resolve
from blendvoca.io.audio import load_audio
from blendvoca.io.coeffs import read_coeffs_csv

TINY = {
    "regression": {"steps": 2, "channels": 8, "hidden": 8},
    "said": {"channels": 16, "cond_dim": 16, "heads": 2, "window": 30, "batch_size": 4, "num_steps": 3,
             "val_every": 2, "num_threads": 1},
    "faceformer": {"feature_dim": 16, "max_seconds": None},
    "cdface": {"vq_hidden": 16, "vq_heads": 2, "num_codes": 2, "code_dim": 4, "codebook_size": 8, "vq_half_width": 2,
               "width": 16, "heads": 2, "audio_self_half_width": 5, "self_context": 4, "period": 8,
               "num_lip_samples": 3, "num_upper_samples": 2, "encoder": "logmel", "active_threshold": None,
               "vq_max_seconds": None, "query_max_seconds": None},
}


@pytest.fixture(scope="module")
def wav():
    return resolve("speech-voca")


@pytest.fixture(scope="module")
def frames(wav):
    info = soundfile.info(str(wav))
    return int(round(info.frames / info.samplerate * 60))


@pytest.fixture(scope="module")
def dataset():
    return FakeBlendVOCA(0, train=["s0", "s1"], val=["s2"], test=["s3"], sentences=2, frames=(60, 71))


@pytest.fixture(scope="module")
def checkpoints(tmp_path_factory, dataset):
    """``{method: folder}``: each trained two steps and saved as ``benchmark.run --checkpoint`` saves it."""
    root = tmp_path_factory.mktemp("checkpoints")
    folders = {}
    for name, config in TINY.items():
        folder = root / name
        prepared_method(name, config, dataset, seed=0, budget=Budget(max_steps=2), checkpoint=folder)
        folders[name] = folder
    return folders


def _one_error(capsys, *words):
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and err[0].startswith("error: "), err
    assert all(word in err[0] for word in words), err[0]
    return err[0]


def test_a_trained_coefficient_method_writes_its_csv_for_a_real_wav(checkpoints, wav, frames, tmp_path, capsys):
    out = tmp_path / "out" / "take.csv"
    assert gen.main(["--method", "regression", "--checkpoint", str(checkpoints["regression"]), "--audio", str(wav),
                     "--out", str(out)]) == cli.EXIT_OK
    assert capsys.readouterr().out.split() == [str(out)]
    coeffs, names = read_coeffs_csv(out)
    assert names == tuple(COEFFICIENT_NAMES) and coeffs.shape == (frames, 32)
    assert np.all((coeffs >= 0) & (coeffs <= 1))
    # the same as the method itself gives for the 16 kHz audio (the command adds nothing of its own)
    method = get_method("regression").load(checkpoints["regression"])
    direct = gen.generated_animation(method, load_audio(wav, 16000), name="regression")
    np.testing.assert_allclose(coeffs, direct[0], atol=1e-6)  # the CSV's printed precision


def test_said_samples_go_to_numbered_csvs_or_one_npy(checkpoints, wav, frames, tmp_path):
    args = ["--method", "said", "--checkpoint", str(checkpoints["said"]), "--audio", str(wav), "--samples", "2",
            "--seed", "3"]
    assert gen.main([*args, "--out", str(tmp_path / "s.csv")]) == cli.EXIT_OK
    first, second = (read_coeffs_csv(tmp_path / f"s-{k}.csv")[0] for k in range(2))
    assert first.shape == second.shape == (frames, 32) and not np.allclose(first, second)
    assert not (tmp_path / "s.csv").exists()
    assert gen.main([*args, "--out", str(tmp_path / "s.npy")]) == cli.EXIT_OK
    stacked = np.load(tmp_path / "s.npy")
    assert stacked.shape == (2, frames, 32) and stacked.dtype == np.float64
    np.testing.assert_allclose(stacked[0], first, atol=1e-6)  # same seed, same samples


@pytest.mark.parametrize("name", ["faceformer", "cdface"])
def test_a_vertex_method_writes_its_vertices_on_the_chosen_speaker(name, checkpoints, dataset, wav, frames, tmp_path):
    out = tmp_path / f"{name}.npy"
    folder = str(checkpoints[name])
    assert gen.main(["--method", name, "--checkpoint", folder, "--audio", str(wav), "--samples", "2",
                     "--style", "s2", "--out", str(out)]) == cli.EXIT_OK
    verts = np.load(out)
    template = dataset.template("s2")
    assert verts.shape == (2, frames, *template.shape) and verts.dtype == np.float32
    # on the speaker's face: within a few centimetres of its template (a two-step model moves little)
    assert np.abs(verts - template).max() < 0.05
    other = tmp_path / "other.npy"
    assert gen.main(["--method", name, "--checkpoint", folder, "--audio", str(wav), "--samples", "2",
                     "--style", "s0", "--out", str(other)]) == cli.EXIT_OK
    assert np.abs(np.load(other) - dataset.template("s0")).max() < 0.05


def test_any_rate_and_channels_are_resampled(tmp_path, wav, frames):
    audio, rate = soundfile.read(str(wav))
    stereo = tmp_path / "stereo44k.wav"
    from blendvoca.io.audio import resample_audio

    up = resample_audio(audio.astype(np.float32), rate, 44100)
    soundfile.write(str(stereo), np.stack([up, 0.5 * up], axis=1), 44100)
    assert gen.main(["--method", "random", "--audio", str(stereo), "--samples", "3", "--out",
                     str(tmp_path / "r.npy")]) == cli.EXIT_OK
    tracks = np.load(tmp_path / "r.npy")
    assert tracks.shape[0] == 3 and abs(tracks.shape[1] - frames) <= 1


def test_methods_that_train_nothing_need_no_checkpoint(wav, frames, tmp_path):
    assert gen.main(["--method", "static", "--audio", str(wav), "--out", str(tmp_path / "s.csv")]) == cli.EXIT_OK
    coeffs, _ = read_coeffs_csv(tmp_path / "s.csv")
    assert coeffs.shape == (frames, 32) and not coeffs.any()


def test_every_registered_method_is_either_generated_or_refused_with_a_reason(wav, tmp_path, capsys):
    """The same flags for all: a method without a checkpoint generates (trains nothing), says it needs
    --checkpoint (trains), or says it cannot animate new audio (looks its output up)."""
    for name in available_methods():
        cls = get_method(name)
        suffix = ".npy" if cls.output == "vertices" else ".csv"
        out = tmp_path / f"{name}{suffix}"
        code = gen.main(["--method", name, "--audio", str(wav), "--out", str(out)])
        if not cls.new_audio:
            assert code == cli.EXIT_USER and not out.exists()
            _one_error(capsys, name, "cannot animate a new recording")
        elif gen.trains(cls):
            assert code == cli.EXIT_USER and not out.exists()
            _one_error(capsys, name, "--checkpoint DIR", f"benchmark.run --method {name} --checkpoint")
        else:
            assert code == cli.EXIT_OK and out.is_file(), name
            capsys.readouterr()


@pytest.mark.parametrize("case", ["unknown-method", "empty-wav", "corrupt-wav", "missing-wav", "missing-checkpoint",
                                  "empty-checkpoint", "other-method", "unknown-style", "style-free", "suffix",
                                  "deterministic-samples"])
def test_bad_input_is_one_error_line_and_nothing_written(case, checkpoints, wav, tmp_path, capsys):
    empty = tmp_path / "empty.wav"
    soundfile.write(str(empty), np.zeros(0, np.float32), 16000)
    corrupt = tmp_path / "corrupt.wav"
    corrupt.write_bytes(b"RIFF\x00\x00not really a wave file")
    (tmp_path / "ckpt-empty").mkdir()
    ff = str(checkpoints["faceformer"])
    out = tmp_path / "out.csv"
    argv, words = {
        "unknown-method": (["--method", "facefromer"], ["unknown method 'facefromer'", "faceformer"]),
        "empty-wav": (["--method", "static", "--audio", str(empty)], ["no samples"]),
        "corrupt-wav": (["--method", "static", "--audio", str(corrupt)], [str(corrupt)]),
        "missing-wav": (["--method", "static", "--audio", str(tmp_path / "nope.wav")], ["no such file"]),
        "missing-checkpoint": (["--method", "regression", "--checkpoint", str(tmp_path / "nope")],
                               ["no such folder", "benchmark.run --method regression --checkpoint"]),
        "empty-checkpoint": (["--method", "regression", "--checkpoint", str(tmp_path / "ckpt-empty")],
                             ["an empty folder"]),
        "other-method": (["--method", "regression", "--checkpoint", str(checkpoints["said"])],
                         ["holds method 'said'"]),
        "unknown-style": (["--method", "faceformer", "--checkpoint", ff, "--style", "nobody", "--out",
                           str(tmp_path / "out.npy")], ["--style nobody", "s0, s1"]),
        "style-free": (["--method", "static", "--style", "s0"], ["animates no speaker style"]),
        "suffix": (["--method", "faceformer", "--checkpoint", ff], ["outputs vertices", ".npy", "'.csv'"]),
        "deterministic-samples": (["--method", "static", "--samples", "2"], ["deterministic"]),
    }[case]
    if "--audio" not in argv:
        argv = [*argv, "--audio", str(wav)]
    if "--out" not in argv:
        argv = [*argv, "--out", str(out)]
    assert gen.main(argv) == cli.EXIT_USER
    _one_error(capsys, *words)
    assert not out.exists() and not (tmp_path / "out.npy").exists()
    assert not list(tmp_path.glob(".blendvoca-*"))  # no temporary left either


def test_a_sampling_option_is_set_on_the_loaded_method(checkpoints, wav, tmp_path):
    # CDFace's control is a sampling option: --config control=lips fixes the lips of every sample
    out = tmp_path / "lips.npy"
    folder = str(checkpoints["cdface"])
    assert gen.main(["--method", "cdface", "--checkpoint", folder, "--audio", str(wav), "--samples", "3",
                     "--config", "control=lips", "--out", str(out)]) == cli.EXIT_OK
    verts = np.load(out)
    lips = get_method("cdface").load(folder).cdface.parts.lips
    np.testing.assert_array_equal(verts[0][:, lips], verts[2][:, lips])
    assert not np.array_equal(verts[0], verts[1])  # the upper face still varies (two upper samples here)
    free = tmp_path / "free.npy"  # without it the lips differ between samples
    assert gen.main(["--method", "cdface", "--checkpoint", folder, "--audio", str(wav), "--samples", "3",
                     "--out", str(free)]) == cli.EXIT_OK
    diverse = np.load(free)
    assert not np.array_equal(diverse[0][:, lips], diverse[2][:, lips])
    # a key the checkpoint was trained with is not a sampling option: refused
    assert gen.main(["--method", "cdface", "--checkpoint", folder, "--audio", str(wav), "--config", "width=32",
                     "--out", str(tmp_path / "w.npy")]) == cli.EXIT_USER
    assert not (tmp_path / "w.npy").exists()
