"""No checkpoint can run code: every method's files are read without pickle, a bad
file is one ``error:`` line with exit 2 naming it, and an earlier version's pickled
checkpoint is refused with the converter, which converts it only with ``--trust``."""

import json
import pickle

import numpy as np
import pytest
import torch

from benchmark.methods import get_method
from benchmark.methods.base import Budget, TrainingRequest, Method
from benchmark.methods.convert_checkpoint import convert_checkpoint
from benchmark.methods.convert_checkpoint import main as convert_main
from benchmark.run import main as run_main
from blendvoca.errors import DataError, UserError
from tests.io.test_torch_file import _Payload, bad_checkpoints
from tests.methods.fakes import fake_evaluate_split, speech_dataset

#: Tiny configs (constructing them trains nothing) and the torch file each method's folder holds.
METHODS = {
    "faceformer": ({"feature_dim": 16, "max_seconds": None}, "faceformer.pt"),
    "codetalker": ({"feature_dim": 16, "vq_hidden_size": 16, "vq_zquant_dim": 4, "vq_n_embed": 16,
                    "max_seconds": None}, "codetalker.pt"),
    "cdface": ({"vq_hidden": 16, "vq_heads": 2, "num_codes": 2, "code_dim": 4, "codebook_size": 8,
                "vq_half_width": 2, "width": 16, "heads": 2, "audio_self_half_width": 5, "self_context": 4,
                "period": 8, "num_lip_samples": 3, "num_upper_samples": 2, "encoder": "logmel",
                "active_threshold": None, "vq_max_seconds": None, "query_max_seconds": None}, "cdface.pt"),
    "said": ({"channels": 16, "cond_dim": 16, "heads": 2, "window": 30, "batch_size": 4, "num_steps": 3,
              "num_threads": 1}, "said.pt"),
    "regression": ({"n_mels": 8, "channels": 4, "hidden": 4, "steps": 2}, "model.pt"),
}
KINDS = ("torch-pickle", "raw-pickle", "raw-pickle-2", "truncated", "random", "empty")


@pytest.fixture(scope="module")
def dataset():
    return speech_dataset(seed=0, sentences=1, seconds=1.0, train=("A", "B"), val=(), test=("D",))


@pytest.fixture()
def runner(dataset, monkeypatch):
    """``benchmark.run``'s main on ``dataset`` (whatever ``--data`` names) with a fake evaluation."""
    from benchmark.protocol import scoring, spec

    monkeypatch.setattr(spec, "_open_default", lambda root, **kw: dataset)
    monkeypatch.setattr(scoring, "evaluate_split", fake_evaluate_split)

    def run(tmp_path, *argv):
        return run_main(["--data", str(tmp_path), "--results", str(tmp_path / "results"), "--quiet",
                         *map(str, argv)])

    return run


def _method_folder(folder, name):
    """A folder as ``save`` writes it: the method's JSON config, and (below) its files."""
    config, checkpoint = METHODS[name]
    Method.save(get_method(name)(**config), folder)
    return folder / checkpoint


def _one_error_line(capsys, *fragments):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: "), err
    assert all(f in err[0] for f in fragments), err[0]
    assert "file an issue" not in err[0] and "Traceback" not in err[0]
    return err[0]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("name", sorted(METHODS))
def test_a_bad_checkpoint_file_runs_nothing_and_is_named(tmp_path, runner, capsys, name, kind):
    marker = tmp_path / "MARKER"
    checkpoint = _method_folder(tmp_path / "ckpt", name)
    checkpoint.write_bytes(bad_checkpoints(tmp_path / "files", marker)[kind].read_bytes())
    assert runner(tmp_path, "--method", name, "--checkpoint", tmp_path / "ckpt") == 2
    _one_error_line(capsys, str(checkpoint), "is not a readable torch checkpoint")
    assert not marker.exists()
    assert not (tmp_path / "results").exists() or not any((tmp_path / "results").iterdir())


@pytest.mark.parametrize("payload", [{"w": torch.zeros(2)}, [1, 2],
                                     {"subjects": ["A"], "templates": {"A": torch.zeros(3, 3)}, "state_dict": {}}])
@pytest.mark.parametrize("name", sorted(METHODS))
def test_a_torch_file_of_other_content_is_the_users_to_fix(tmp_path, runner, capsys, name, payload):
    checkpoint = _method_folder(tmp_path / "ckpt", name)
    torch.save(payload, checkpoint)
    assert runner(tmp_path, "--method", name, "--checkpoint", tmp_path / "ckpt") == 2  # not "the method misbehaved"
    _one_error_line(capsys, str(checkpoint))


@pytest.mark.parametrize("name", sorted(METHODS))
def test_an_earlier_versions_pickled_checkpoint_names_the_converter(tmp_path, runner, capsys, name):
    checkpoint = _method_folder(tmp_path / "ckpt", name)
    torch.save({"state_dict": {}, "templates": {"A": np.zeros((3, 3))}}, checkpoint)  # numpy pickled in
    assert runner(tmp_path, "--method", name, "--checkpoint", tmp_path / "ckpt") == 2
    _one_error_line(capsys, str(checkpoint), "python -m benchmark.methods.convert_checkpoint",
                    str(tmp_path / "ckpt"), "--trust")


@pytest.mark.parametrize("name, filename, arrays", [
    ("regression", "feature_stats.npz", ("mean", "std")),
    ("ground-truth", "tracks.npz", ("track_0",)),
])
def test_an_npz_with_pickled_objects_runs_nothing_and_is_named(tmp_path, runner, capsys, name, filename, arrays):
    marker = tmp_path / "MARKER"
    folder = tmp_path / "ckpt"
    method = get_method(name)(**(METHODS[name][0] if name in METHODS else {}))
    Method.save(method, folder)
    if name == "regression":
        from baselines.regression.model import AudioToCoefficients

        torch.save(AudioToCoefficients(n_mels=8, channels=4, hidden=4).state_dict(), folder / "model.pt")
    else:
        (folder / "tracks.json").write_text(json.dumps([["D", "sentence01"]]))
    evil = np.empty(1, dtype=object)
    evil[0] = _Payload(marker)
    np.savez(folder / filename, **{key: evil for key in arrays})
    assert runner(tmp_path, "--method", name, "--checkpoint", folder) == 2
    _one_error_line(capsys, str(folder / filename), "not a readable .npz")
    assert not marker.exists()


# ---------------------------------------------------------------------------- the generate CLIs


@pytest.fixture(scope="module")
def wav(tmp_path_factory):
    from blendvoca.io.audio import write_wav

    path = tmp_path_factory.mktemp("audio") / "x.wav"
    write_wav(path, 0.3 * np.sin(np.arange(8000) / 7.0), 16000)
    return path


@pytest.mark.parametrize("kind", ("torch-pickle", "raw-pickle", "truncated", "random"))
@pytest.mark.parametrize("tool", ("said", "cdface"))
def test_generate_clis_on_a_bad_checkpoint_are_one_error_line(tmp_path, capsys, wav, tool, kind):
    if tool == "said":
        from baselines.said.generate import main
    else:
        from baselines.cdface.generate import main
    marker = tmp_path / "MARKER"
    checkpoint = tmp_path / "ckpt" / f"{tool}.pt"
    checkpoint.parent.mkdir()
    checkpoint.write_bytes(bad_checkpoints(tmp_path / "files", marker)[kind].read_bytes())
    code = main(["--checkpoint", str(checkpoint.parent), "--audio", str(wav), "--out", str(tmp_path / "out.npy"),
                 "--quiet"])
    assert code == 2
    _one_error_line(capsys, str(checkpoint), "is not a readable torch checkpoint")
    assert not marker.exists() and not (tmp_path / "out.npy").exists()


@pytest.mark.parametrize("module, filename, out", [("baselines.said.generate", "said.pt", "o.csv"),
                                                   ("baselines.cdface", "cdface.pt", "o.npy")])
def test_generate_clis_as_a_process_run_nothing(tmp_path, wav, module, filename, out):
    """``python -m ...`` itself on a pickle payload: exit 2, one line, no warning from torch."""
    import subprocess
    import sys

    marker = tmp_path / "MARKER"
    checkpoint = tmp_path / filename
    checkpoint.write_bytes(pickle.dumps({"w": _Payload(marker)}, protocol=4))
    done = subprocess.run([sys.executable, "-m", module, "--checkpoint", str(checkpoint), "--audio", str(wav),
                           "--out", str(tmp_path / out), "--quiet"], capture_output=True, text=True, timeout=120)
    err = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(err) == 1 and str(checkpoint) in err[0], done.stderr
    assert not marker.exists() and not (tmp_path / out).exists()


# ---------------------------------------------------------------------------- the converter


def _old_cdface_file(cdface, path):
    """``cdface`` written the way earlier versions did: numpy arrays pickled in."""
    torch.save({"config": cdface.config,
                "parts": {"lips": cdface.parts.lips, "upper": cdface.parts.upper,
                          "num_vertices": cdface.parts.num_vertices},
                "styles": cdface.styles, "templates": dict(cdface.templates),
                "state_dict": cdface.model.state_dict()}, path)


def test_an_old_cdface_file_is_refused_then_converted_once_knowingly(tmp_path, capsys):
    from baselines.cdface.pipeline import CDFace
    from blendvoca.runtime.progress import progress_bars
    from tests.cdface.test_model import _tiny_cdface

    cdface, _template = _tiny_cdface()
    cdface.model.requires_grad_(False)  # as load leaves it (autograd off takes other, equally exact kernels)
    audio = np.random.default_rng(0).normal(scale=0.1, size=8000).astype(np.float32)
    with progress_bars(False):  # no frame bar in the captured stderr
        expected = cdface.generate(audio, 30, subject="A", samples=2, seed=1)
    old, new = tmp_path / "old.pt", tmp_path / "new.pt"
    _old_cdface_file(cdface, old)
    with pytest.raises(DataError, match=rf"{old}.*numpy.*convert_checkpoint {old} NEW --trust"):
        CDFace.load(old)
    assert convert_main([str(old), str(new)]) == 2
    _one_error_line(capsys, str(old), "--trust", "runs whatever code")
    assert not new.exists()
    assert convert_main([str(old), str(new), "--trust"]) == 0
    assert f"converted: {new}" in capsys.readouterr().out
    again = CDFace.load(new)
    with progress_bars(False):
        np.testing.assert_array_equal(again.generate(audio, 30, subject="A", samples=2, seed=1), expected)
    assert again.parts.lips.dtype == np.int64 and again.templates["C"].dtype == np.float64
    assert convert_main([str(old), str(new), "--trust"]) == 2  # nothing is overwritten
    _one_error_line(capsys, "exists")


def test_a_pickle_payload_is_converted_only_with_trust(tmp_path, capsys):
    marker = tmp_path / "MARKER"
    path = bad_checkpoints(tmp_path / "files", marker)["torch-pickle"]
    with pytest.raises(UserError, match="only with --trust"):
        convert_checkpoint(path, tmp_path / "new.pt")
    assert not marker.exists()
    with pytest.raises(DataError, match="not a readable torch checkpoint"):
        convert_checkpoint(bad_checkpoints(tmp_path / "more", marker)["random"], tmp_path / "new.pt", trust=True)
    assert not (tmp_path / "new.pt").exists()


@pytest.mark.parametrize("name", ("faceformer", "codetalker"))
def test_an_old_vertex_method_folder_converts_and_predicts_the_same(tmp_path, name, capsys):
    from benchmark.testing import FakeBlendVOCA

    ds = FakeBlendVOCA(1, train=2, sentences=1)
    method = get_method(name)(**METHODS[name][0])
    method.train(ds, TrainingRequest(seed=0, budget=Budget(max_steps=2)))
    method.save(tmp_path / "saved")
    old = tmp_path / "old"
    old.mkdir()
    (old / "method_config.json").write_bytes((tmp_path / "saved" / "method_config.json").read_bytes())
    payload = torch.load(tmp_path / "saved" / METHODS[name][1], weights_only=True)
    payload["templates"] = {k: v.numpy() for k, v in payload["templates"].items()}  # as an earlier version might
    payload["history"] = {"loss": np.float32(0.5), "curve": np.arange(3.0)}
    torch.save(payload, old / METHODS[name][1])
    with pytest.raises(DataError, match="convert_checkpoint"):
        type(method).load(old)
    assert convert_main([str(old), str(tmp_path / "new"), "--trust"]) == 0
    assert str(tmp_path / "new" / METHODS[name][1]) in capsys.readouterr().out
    back = type(method).load(tmp_path / "new")
    subject = ds.split("test")[0]
    utterance = ds.utterance(subject, ds.sentences(subject)[0], "test")
    np.testing.assert_array_equal(back.generate(utterance, samples=2), method.generate(utterance, samples=2))
    assert back.history["loss"] == 0.5 and back.history["curve"].tolist() == [0.0, 1.0, 2.0]
    assert not list(tmp_path.glob(".new.convert-*"))  # the staging folder is gone


def test_a_safe_folder_is_copied_unchanged(tmp_path, capsys):
    from baselines.said.pipeline import SAiD
    from blendvoca.names import BLENDVOCA_NAMES

    said = SAiD.from_preset(BLENDVOCA_NAMES, channels=16, cond_dim=16, heads=2, num_steps=4)
    said.save(tmp_path / "old" / "said.pt")
    (tmp_path / "old" / "method_config.json").write_text("{}\n")
    assert convert_main([str(tmp_path / "old"), str(tmp_path / "new")]) == 0  # nothing to trust
    assert "converted: none" in capsys.readouterr().out
    for name in ("said.pt", "method_config.json"):
        assert (tmp_path / "new" / name).read_bytes() == (tmp_path / "old" / name).read_bytes()


def test_every_checkpoint_file_written_loads_safely(tmp_path):
    """What CDFace, SAiD and regression write holds tensors, numbers and strings only
    (FaceFormer and CodeTalker: their save/load tests)."""
    from baselines.regression.model import AudioToCoefficients
    from baselines.said.pipeline import SAiD
    from blendvoca.names import BLENDVOCA_NAMES
    from tests.cdface.test_model import _tiny_cdface

    cdface, _template = _tiny_cdface()
    cdface.save(tmp_path / "cdface.pt")
    SAiD.from_preset(BLENDVOCA_NAMES, channels=16, cond_dim=16, heads=2, num_steps=4).save(tmp_path / "said.pt")
    regression = get_method("regression")(**METHODS["regression"][0])
    regression.model = AudioToCoefficients(n_mels=8, channels=4, hidden=4)
    regression.stats, regression.history = (np.zeros(8), np.ones(8)), {"loss": [1.0]}
    regression.save(tmp_path / "regression")
    for path in (tmp_path / "cdface.pt", tmp_path / "said.pt", tmp_path / "regression" / "model.pt"):
        assert isinstance(torch.load(path, weights_only=True), dict)
    payload = torch.load(tmp_path / "cdface.pt", weights_only=True)
    assert payload["parts"]["lips"].dtype == torch.int64 and payload["templates"]["A"].dtype == torch.float64
    loaded = get_method("regression").load(tmp_path / "regression")
    assert all(torch.equal(a, b) for a, b in zip(loaded.model.state_dict().values(),
                                                 regression.model.state_dict().values()))


@pytest.mark.parametrize("name, filename", [("regression", "history.json"), ("ground-truth", "tracks.json")])
def test_a_json_file_of_a_checkpoint_that_does_not_read_is_named(tmp_path, runner, capsys, name, filename):
    folder = tmp_path / "ckpt"
    Method.save(get_method(name)(**(METHODS[name][0] if name in METHODS else {})), folder)
    if name == "regression":
        from baselines.regression.model import AudioToCoefficients

        torch.save(AudioToCoefficients(n_mels=8, channels=4, hidden=4).state_dict(), folder / "model.pt")
        np.savez(folder / "feature_stats.npz", mean=np.zeros(8), std=np.ones(8))
    (folder / filename).write_text('{"cut short": ')
    assert runner(tmp_path, "--method", name, "--checkpoint", folder) == 2
    _one_error_line(capsys, str(folder / filename))


def test_a_reference_checkpoint_without_its_tracks_is_named(tmp_path, runner, capsys):
    folder = tmp_path / "ckpt"
    Method.save(get_method("ground-truth")(), folder)  # the config only: tracks.json and tracks.npz missing
    assert runner(tmp_path, "--method", "ground-truth", "--checkpoint", folder) == 2
    _one_error_line(capsys, "lacks tracks.json")


def test_a_folder_is_converted_whole_or_not_at_all(tmp_path):
    old, new = tmp_path / "old", tmp_path / "out" / "new"
    old.mkdir()
    (old / "config.json").write_text("{}")
    torch.save({"weights": np.arange(3.0)}, old / "b.pt")  # numpy inside: converted only with trust
    with pytest.raises(UserError, match="--trust"):  # the second file fails: nothing of new is left
        convert_checkpoint(old, new)
    assert list(new.parent.iterdir()) == []
    assert convert_checkpoint(old, new, trust=True) == [new / "b.pt"]
    assert sorted(p.name for p in new.iterdir()) == ["b.pt", "config.json"]
    assert [p.name for p in new.parent.iterdir()] == ["new"]  # no staging folder left beside it
