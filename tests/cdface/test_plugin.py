import numpy as np
import pytest

from tests.cdface.test_model import TINY, _tiny_cdface
from tests.fixtures.paths import FsPath

PLUGIN_TINY = {k: v for k, v in TINY.items() if k != "encoder"} | {"encoder": "logmel", "vq_max_seconds": None,
                                                                     "query_max_seconds": None}


def test_cdface_passes_the_method_check():
    from baselines.cdface.plugin import CDFaceMethod
    from benchmark.testing import check_method

    check_method(CDFaceMethod, max_steps=2, samples=3, **PLUGIN_TINY)


def test_registered_stochastic_vertex_method():
    from benchmark.methods import get_method

    cls = get_method("cdface")
    assert cls.stochastic and cls.output == "vertices"
    with pytest.raises(ValueError, match="control"):
        cls(control="eyes")
    assert cls(control="lips").config()["control"] == "lips"


def test_cli_writes_samples_for_any_wav(tmp_path, capsys):
    from baselines.cdface.generate import main
    from blendvoca.io.audio import write_wav
    from blendvoca.io.mesh import write_obj

    cdface, template = _tiny_cdface()
    cdface.save(tmp_path / "cdface.pt")
    wav = tmp_path / "speech.wav"
    write_wav(wav, np.random.default_rng(0).normal(scale=0.1, size=8000).astype(np.float32), 22050)
    out = tmp_path / "out.npy"
    assert main(["--checkpoint", str(tmp_path), "--audio", str(wav), "--out", str(out), "--samples", "3",
                 "--subject", "A", "--control", "lips", "--quiet"]) == 0
    verts = np.load(out)
    assert verts.shape == (3, 22, 7, 3)  # 8000 samples at 22.05 kHz = 0.363 s = 22 frames
    np.testing.assert_array_equal(verts[0, :, :4], verts[2, :, :4])  # lips fixed
    obj = tmp_path / "neutral.obj"
    write_obj(obj, template, np.array([[0, 1, 2], [3, 4, 5]]))
    assert main(["--checkpoint", str(tmp_path / "cdface.pt"), "--audio", str(wav), "--out", str(out), "--samples", "2",
                 "--template", str(obj), "--obj-dir", str(tmp_path / "objs"), "--quiet"]) == 0
    assert len(list((tmp_path / "objs" / "sample_1").glob("*.obj"))) == 22
    assert main(["--checkpoint", str(tmp_path / "nope"), "--audio", str(wav), "--out", str(out)]) == 2
    assert "error: --checkpoint" in capsys.readouterr().err


def test_cli_file_mistakes_are_one_error_line_and_paths_any_path_like(tmp_path, capsys):
    from baselines.cdface.generate import generate_file, main
    from blendvoca.io.audio import write_wav
    from blendvoca.runtime.progress import progress_bars

    cdface, _template = _tiny_cdface()
    cdface.save(FsPath(tmp_path / "cdface.pt"))
    wav = tmp_path / "speech.wav"
    write_wav(wav, np.random.default_rng(0).normal(scale=0.1, size=8000).astype(np.float32), 16000)
    with progress_bars(False):
        out = generate_file(FsPath(wav), FsPath(tmp_path / "out.npy"), checkpoint=FsPath(tmp_path), samples=2,
                            subject="A")
    assert out == tmp_path / "out.npy" and np.load(out).shape == (2, 30, 7, 3)
    (tmp_path / "ref.npy").write_text("not an array")
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "cdface.pt").write_text("not a checkpoint")
    for argv, message in ((["--checkpoint", str(tmp_path), "--subject", "A", "--control", "lips",
                            "--reference", str(tmp_path / "ref.npy")], "--reference"),
                          (["--checkpoint", str(tmp_path / "bad")], "not a readable torch checkpoint"),
                          (["--checkpoint", str(tmp_path)], "--subject")):  # two stored speakers: which one?
        code = main([*argv, "--audio", str(wav), "--out", str(tmp_path / "o.npy"), "--quiet"])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and err[0].startswith("error: ") and message in err[0], err
    assert not (tmp_path / "o.npy").exists()


def test_a_trained_model_samples_lips_fixed_through_a_sampling_option():
    from baselines.cdface.plugin import CDFaceMethod
    from benchmark.methods.contract import Utterance

    cdface, _template = _tiny_cdface()
    diverse = CDFaceMethod(**PLUGIN_TINY)
    diverse.cdface = cdface
    lips = diverse.with_sampling_options(control="lips")
    assert lips.cdface is cdface and lips.config()["control"] == "lips" and lips.label == "cdface (lips fixed)"
    assert diverse.control == "none" and diverse.label is None
    utterance = Utterance("A", "sentence01", "test", np.random.default_rng(0).normal(scale=0.1, size=8000)
                          .astype(np.float32), 30)
    out = lips.generate(utterance, samples=3, seed=0)
    np.testing.assert_array_equal(out[0, :, :4], out[2, :, :4])  # the lip vertices of the tiny model
    free = diverse.generate(utterance, samples=3, seed=0)
    assert not np.array_equal(free[0, :, :4], free[2, :, :4])
    with pytest.raises(ValueError, match="not sampling options"):
        diverse.with_sampling_options(preset="paper")


def test_training_under_a_step_budget_gives_the_same_model_every_run():
    import torch

    from baselines.cdface.plugin import CDFaceMethod
    from benchmark.methods.base import Budget, TrainingRequest
    from benchmark.testing import FakeBlendVOCA

    dataset = FakeBlendVOCA(0, sentences=1)
    states = []
    for run in range(2):
        torch.manual_seed(1000 + run)  # the global generator's state must not matter
        method = CDFaceMethod(**PLUGIN_TINY)
        method.train(dataset, TrainingRequest(seed=3, budget=Budget(max_steps=2)))
        states.append(method.cdface.model.state_dict())
    for key, value in states[0].items():
        torch.testing.assert_close(value, states[1][key], rtol=0, atol=0, msg=key)


def test_cosine_learning_rate_closed_form():
    import math

    from baselines.cdface.train import cosine_lr

    assert cosine_lr(1e-3, 0, 100) == pytest.approx(1e-3)
    assert cosine_lr(1e-3, 50, 100) == pytest.approx(5e-4)
    assert cosine_lr(1e-3, 25, 100) == pytest.approx(1e-3 * (1 + math.cos(math.pi / 4)) / 2)
    assert cosine_lr(1e-3, 100, 100) == pytest.approx(0.0, abs=1e-18)
    # a time limit only: the fraction of the seconds elapsed; both limits: the further along
    assert cosine_lr(2.0, 7, None, elapsed=30.0, seconds=60.0) == pytest.approx(1.0)
    assert cosine_lr(2.0, 10, 20, elapsed=45.0, seconds=60.0) == pytest.approx((1 + math.cos(0.75 * math.pi)))
    assert cosine_lr(2.0, 5, None) == pytest.approx(2.0)


def test_cosine_schedule_sets_every_step_of_every_stage(monkeypatch):
    import torch

    from baselines.cdface.plugin import CDFaceMethod
    from baselines.cdface.train import cosine_lr
    from benchmark.methods.base import Budget, TrainingRequest
    from benchmark.testing import FakeBlendVOCA

    seen = []

    class Recording(torch.optim.AdamW):
        def step(self, closure=None):
            seen.append(self.param_groups[0]["lr"])
            return super().step(closure)

    monkeypatch.setattr(torch.optim, "AdamW", Recording)
    method = CDFaceMethod(**PLUGIN_TINY, lr_schedule="cosine", lr=0.01)
    method.train(FakeBlendVOCA(0, sentences=1), TrainingRequest(seed=0, budget=Budget(max_steps=4)))
    expected = [cosine_lr(0.01, k, 4) for k in range(4)]
    assert seen == pytest.approx(expected * 3)  # lip prior, upper-face prior, querying
    with pytest.raises(ValueError, match="lr_schedule"):
        CDFaceMethod(**PLUGIN_TINY, lr_schedule="step").train(FakeBlendVOCA(0, sentences=1),
                                                               TrainingRequest(seed=0, budget=Budget(max_steps=1)))


def test_cli_plain_generation_warns_naming_benchmark_generate(tmp_path):
    import warnings

    from baselines.cdface.generate import main
    from blendvoca.io.audio import write_wav

    cdface, _template = _tiny_cdface()
    cdface.save(tmp_path / "cdface.pt")
    wav = tmp_path / "speech.wav"
    write_wav(wav, np.random.default_rng(0).normal(scale=0.1, size=8000).astype(np.float32), 16000)
    with pytest.warns(DeprecationWarning, match=r"removed after 2027-06-30: use python -m benchmark.generate "
                                                r"--method cdface .* --style A --audio WAV"):
        assert main(["--checkpoint", str(tmp_path), "--audio", str(wav), "--out", str(tmp_path / "p.npy"),
                     "--subject", "A", "--quiet"]) == 0
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)  # lip control is this command's own: no warning
        assert main(["--checkpoint", str(tmp_path), "--audio", str(wav), "--out", str(tmp_path / "l.npy"),
                     "--subject", "A", "--control", "lips", "--quiet"]) == 0
