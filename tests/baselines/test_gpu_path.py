"""The device path of the trained baselines (docs/gpu.md).

On every machine: ``device="cpu"`` handed through the runner trains and generates bit for
bit what a run without a device does; the runner passes ``device`` only to a ``train``
that takes it and moves a trained or loaded method with its ``to``; ``--device cuda``
without a GPU is one ``error:`` line, exit status 2; the GPU tests say why they skip.

With a GPU: one forward pass and one sampling pass on ``cuda`` equal the CPU's within the
tolerances of :data:`TOLERANCES`, and a few mixed-precision steps train to finite weights.
"""

from __future__ import annotations

import copy
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from benchmark.methods.base import Budget, Method
from benchmark.methods.request import CONTRACT, train_contract
from benchmark.protocol.training import moved_to, prepared_method
from blendvoca.cli import checked_device
from benchmark.run import main
from benchmark.testing import FakeBlendVOCA
from blendvoca.errors import UserError

#: Why the CUDA tests skip on a machine without a GPU (checked by a test: the reason is reported).
NO_CUDA = "no CUDA device: torch.cuda.is_available() is False (the GPU path is checked on a GPU machine only)"
CUDA = pytest.mark.skipif(not torch.cuda.is_available(), reason=NO_CUDA)

# Tiny configs of the five trained baselines (as tests/methods/test_checkpoint_hook.py) and their step budgets.
TINY = {
    "regression": ({"steps": 100, "channels": 16, "hidden": 16, "batch": 8, "window": 40}, 4),
    "faceformer": ({"feature_dim": 16, "max_seconds": None}, 2),
    "codetalker": ({"feature_dim": 16, "vq_hidden_size": 16, "vq_zquant_dim": 4, "vq_n_embed": 16,
                    "max_seconds": None}, 4),
    "cdface": (None, 2),  # tests.cdface.test_plugin.PLUGIN_TINY
    "said": ({"channels": 16, "cond_dim": 16, "heads": 2, "window": 30, "batch_size": 4, "num_steps": 3,
              "val_every": 2, "num_threads": 1}, 3),
}

#: Largest |CUDA - CPU| per method, float32 on both (TF32 off), in the output's units: coefficients
#: in [0, 1] (regression, said) or metres (vertex methods). "forward": one teacher-forced / denoising
#: pass of the network; "sample": one full ``generate`` (deterministic or seeded) of a short sentence.
#: float32 sums in another order differ by ~1e-7 relative per operation; a forward pass stays within
#: 1e-5. Sampling repeats the network per frame (autoregressive methods) or per step (SAiD), so the
#: differences compound: 1e-4 (0.1 mm / 1e-4 of the coefficient range), far below the seed spread of
#: every metric (tenths of a millimetre of LVE at the least). The VQ methods (codetalker, cdface) pick a
#: code by nearest neighbour per frame: a near tie may pick another code, so their sampling pass is
#: compared on the mean |difference| (5e-5 m) instead of the largest.
TOLERANCES = {
    "regression": {"forward": 1e-5, "sample": 1e-5},
    "faceformer": {"forward": 1e-5, "sample": 1e-4},
    "codetalker": {"forward": 1e-5, "sample_mean": 5e-5},
    "cdface": {"forward": 1e-5, "sample_mean": 5e-5},
    "said": {"forward": 1e-4, "sample": 1e-4},
}


def _config(name):
    config, steps = TINY[name]
    if config is None:
        from tests.cdface.test_plugin import PLUGIN_TINY

        config = PLUGIN_TINY
    return dict(config), steps


def _dataset():
    return FakeBlendVOCA(0, train=["A", "B"], val=["C"], test=["D"], sentences=2, frames=(62, 80))


def _utterance(dataset):
    subject = dataset.split("test")[0]
    return dataset.utterance(subject, dataset.sentences(subject)[0], "test")


# ---- every machine ------------------------------------------------------------------------------


@pytest.mark.parametrize("name", list(TINY))
def test_device_cpu_through_the_runner_is_bit_identical_to_no_device(name):
    config, steps = _config(name)
    dataset = _dataset()
    utterance = _utterance(dataset)
    outputs = []
    for device in (None, "cpu"):
        torch.manual_seed(1234)  # the same global state before both runs
        method, _ = prepared_method(name, config, dataset, seed=0, budget=Budget(max_steps=steps), device=device)
        outputs.append(np.asarray(method.generate(utterance, samples=2, seed=5)))
    assert train_contract(type(method)) == CONTRACT
    np.testing.assert_array_equal(outputs[1], outputs[0], err_msg=f"{name}: device='cpu' changed the result")


def test_a_whole_run_on_device_cpu_stores_the_results_of_a_run_without_one(tmp_path):
    from tests.methods.fakes import fake_evaluate, speech_dataset

    dataset = speech_dataset(seed=0, sentences=2, seconds=1.0)
    config, steps = _config("regression")
    stored = []
    for folder, device in (("plain", None), ("cpu", "cpu")):
        from benchmark.protocol import RunSpec, run

        path = run(RunSpec("regression", data_root="unused", results_dir=tmp_path / folder,
                           config=config, budget=Budget(max_steps=steps), device=device),
                   evaluate=fake_evaluate, open_dataset=lambda root: dataset)
        stored.append(json.loads(Path(path).read_text())["metrics"])
    assert stored[0] == stored[1]


class _OldPlugin(Method):
    """A plug-in written before ``device`` existed: no ``device`` keyword, no ``to``."""

    def train(self, dataset, *, seed, budget):
        self.trained = True

    def generate(self, utterance, *, samples=1, seed=0):
        return np.full((samples, utterance.num_frames, 32), 0.5)


class _Recorder(Method):
    """Records the device ``train`` gets and the moves the runner makes."""

    calls: list = []

    contract = 3

    def train(self, dataset, request):
        type(self).calls.append(("train", request.device))

    def to(self, device):
        type(self).calls.append(("to", device))
        return self

    def generate(self, utterance, *, samples=1, seed=0):
        return np.full((samples, utterance.num_frames, 32), 0.5)


def test_the_runner_passes_device_only_to_a_v3_train_and_moves_the_method(tmp_path):
    dataset = _dataset()
    method, _ = prepared_method(f"{__name__}:_OldPlugin", {}, dataset, seed=0, budget=Budget(max_steps=1), device="cpu")
    assert method.trained and train_contract(_OldPlugin) == 2
    _Recorder.calls = []
    method, _ = prepared_method(f"{__name__}:_Recorder", {}, dataset, seed=0, budget=Budget(max_steps=1),
                                device="cpu", checkpoint=tmp_path / "saved")
    assert _Recorder.calls == [("train", "cpu"), ("to", "cpu")]
    _Recorder.calls = []  # a loaded method is moved too
    prepared_method(f"{__name__}:_Recorder", {}, dataset, seed=0, budget=Budget(max_steps=1), device="cpu",
                    checkpoint=tmp_path / "saved")
    assert _Recorder.calls == [("to", "cpu")]
    _Recorder.calls = []  # no device: nothing passed, nothing moved
    prepared_method(f"{__name__}:_Recorder", {}, dataset, seed=0, budget=Budget(max_steps=1))
    assert _Recorder.calls == [("train", None)]
    assert moved_to(method, None) is method


def test_checked_device_names(monkeypatch):
    assert checked_device(None) is None and checked_device("cpu") == "cpu" and checked_device("CPU") == "cpu"
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    assert checked_device("auto") == "cpu"
    for bad in ("gpu", "cuda:x", "cpu:0", "mps", ""):
        with pytest.raises(UserError, match="expected auto, cpu, cuda or cuda:N"):
            checked_device(bad)
    with pytest.raises(UserError, match="torch sees no CUDA device"):
        checked_device("cuda:0")


@pytest.mark.parametrize("device, message", [("cuda", "--device cuda: torch sees no CUDA device here"),
                                             ("tpu", "--device: expected auto, cpu, cuda or cuda:N")])
def test_cli_device_without_cuda_is_one_error_line_exit_2(device, message, monkeypatch, tmp_path, capsys):
    import benchmark.run

    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)  # as on a machine without a GPU
    monkeypatch.setattr(benchmark.run, "run", lambda *a, **k: pytest.fail("the run started"))
    rc = main(["--method", "regression", "--results", str(tmp_path), "--device", device, "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].startswith("error: ") and message in err[0], err


def test_cli_device_reaches_the_run(monkeypatch, tmp_path, capsys):
    import benchmark.run

    seen = []

    def fake_run(spec):
        seen.append((spec.device, spec.vae))
        return tmp_path / "result.json"

    vae = tmp_path / "v.pt"
    vae.write_bytes(b"")  # RunSpec checks that the file is there
    monkeypatch.setattr(benchmark.run, "run", fake_run)
    assert main(["--method", "regression", "--results", str(tmp_path), "--quiet"]) == 0
    assert main(["--method", "regression", "--results", str(tmp_path), "--device", "cpu", "--vae", str(vae),
                 "--quiet"]) == 0
    assert seen == [("cpu", None), ("cpu", str(vae))]  # the CPU unless asked
    assert capsys.readouterr().out.splitlines() == [str(tmp_path / "result.json")] * 2


def test_mixed_precision_is_a_config_switch_that_changes_nothing_on_the_cpu():
    from baselines.common.device import MixedPrecision, precision_config

    assert precision_config("off") == {} and precision_config("bf16") == {"mixed_precision": "bf16"}
    amp = MixedPrecision("fp16", "cpu")
    assert not amp.enabled and amp.scaler is None and amp.describe() == "off"
    with pytest.raises(UserError, match="mixed_precision"):
        MixedPrecision("fp8", "cpu")
    config, steps = _config("regression")
    dataset, utterance = _dataset(), _utterance(_dataset())
    outputs = []
    for precision in ("off", "bf16"):
        torch.manual_seed(1234)
        method, _ = prepared_method("regression", {**config, "mixed_precision": precision}, dataset, seed=0,
                                    budget=Budget(max_steps=steps), device="cpu")
        outputs.append(method.generate(utterance, samples=1, seed=0))
    np.testing.assert_array_equal(outputs[0], outputs[1])
    assert method.config()["mixed_precision"] == "bf16"  # recorded when on; absent when off


@pytest.mark.skipif(torch.cuda.is_available(), reason="a GPU is here: the CUDA tests run instead of skipping")
def test_the_cuda_tests_skip_with_their_reason_reported():
    """Without a GPU the CUDA tests are reported as skipped, with :data:`NO_CUDA` as the reason."""
    assert CUDA.kwargs["reason"] == NO_CUDA and CUDA.args == (True,)
    out = subprocess.run([sys.executable, "-m", "pytest", "-q", "-rs", "-p", "no:cacheprovider",
                          f"{__file__}::test_cuda_forward_and_sampling_match_the_cpu"],
                         capture_output=True, text=True, cwd=Path(__file__).parents[2], timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    assert f"{len(TINY)} skipped" in out.stdout and NO_CUDA in out.stdout, out.stdout


# ---- a GPU --------------------------------------------------------------------------------------


def _trained_on_cpu(name):
    config, steps = _config(name)
    dataset = _dataset()
    torch.manual_seed(1234)
    method, _ = prepared_method(name, config, dataset, seed=0, budget=Budget(max_steps=steps))
    return method, dataset


def _network(method, name):
    return {"regression": lambda m: m.model, "faceformer": lambda m: m.network, "codetalker": lambda m: m.network,
            "cdface": lambda m: m.cdface.model, "said": lambda m: m.said.model}[name](method)


def _forward(method, name, dataset, device):
    """One pass of the network on fixed inputs, as a CPU float64 array."""
    torch.manual_seed(0)
    net = _network(method, name).eval()
    with torch.no_grad():
        if name == "regression":
            x = torch.randn(1, 60, method._config["n_mels"])
            out = net(x.to(device))
        elif name in ("faceformer", "codetalker"):
            subject = dataset.split("train")[0]
            from baselines.common.sequences import motion_sequences, sequence_tensors

            seq = motion_sequences(dataset, "train")[0]
            a, t, v = (x.to(device) for x in sequence_tensors(seq, scale=method.motion_scale,
                                                             normalise_audio=net.config["audio"]["kind"] == "wav2vec2"))
            one_hot = torch.eye(len(method.subjects), device=device)[method.subjects.index(subject)][None]
            out = net(a, t, v, one_hot)
            out = out if name == "faceformer" else out[0]
            out = out / method.motion_scale
        elif name == "cdface":
            b, w = 2, 8
            lips = torch.randn(b, w, net.lip_query.motion_dim)
            upper = torch.randn(b, w, net.upper_query.motion_dim)
            features = torch.randn(b, w, method.cdface.encoder.feature_dim)
            out = net.teacher_forced(lips.to(device), upper.to(device), features.to(device),
                                     torch.zeros(b, dtype=torch.int64, device=device))["lips"]
        else:  # said: the denoiser on noised coefficients at fixed timesteps
            x = torch.randn(2, 30, 32)
            t = torch.tensor([10, 500])
            audio = torch.randn(2, 8000)
            cond = net.condition(net.audio_features(audio.to(device), 30))
            out = net(x.to(device), t.to(device), cond)
    return out.double().cpu().numpy()


def _sample(method, dataset, device):
    """One ``generate`` of a short test sentence on ``device`` (the method moved there)."""
    return np.asarray(moved_to(method, device).generate(_utterance(dataset), samples=2, seed=5))


@pytest.fixture()
def _full_float32():
    """float32 on the GPU as on the CPU: no TF32 in matmuls and convolutions while comparing."""
    saved = torch.backends.cuda.matmul.allow_tf32, torch.backends.cudnn.allow_tf32
    torch.backends.cuda.matmul.allow_tf32 = torch.backends.cudnn.allow_tf32 = False
    yield
    torch.backends.cuda.matmul.allow_tf32, torch.backends.cudnn.allow_tf32 = saved


@CUDA
@pytest.mark.parametrize("name", list(TINY))
def test_cuda_forward_and_sampling_match_the_cpu(name, _full_float32):
    method, dataset = _trained_on_cpu(name)
    on_cpu = _forward(method, name, dataset, "cpu")
    cpu_sample = _sample(method, dataset, "cpu")
    gpu = moved_to(copy.deepcopy(method), "cuda")
    assert next(_network(gpu, name).parameters()).device.type == "cuda"
    on_gpu = _forward(gpu, name, dataset, "cuda")
    tol = TOLERANCES[name]
    assert np.max(np.abs(on_gpu - on_cpu)) <= tol["forward"], (name, np.max(np.abs(on_gpu - on_cpu)))
    if name == "said":
        # the network's sampling chain from the same CPU noise (baselines.said.sample draws on the
        # generator's device); SAiD.generate itself draws on a generator of the model's device
        gpu_sample = _said_chain(gpu, "cuda")
        cpu_sample = _said_chain(method.to("cpu"), "cpu")
    else:
        gpu_sample = _sample(gpu, dataset, "cuda")
    assert gpu_sample.shape == cpu_sample.shape and np.all(np.isfinite(gpu_sample))
    difference = np.abs(gpu_sample - cpu_sample)
    if "sample" in tol:
        assert difference.max() <= tol["sample"], (name, difference.max())
    else:
        assert difference.mean() <= tol["sample_mean"], (name, difference.mean())


def _said_chain(method, device):
    from baselines.said.sample import sample_diffusion

    said = method.said.to(device)
    net = said.model.eval()
    audio = torch.randn(1, 8000, generator=torch.Generator().manual_seed(3)).to(device)
    with torch.no_grad():
        cond = net.condition(net.audio_features(audio, 30))
        x = sample_diffusion(lambda x, t: net(x, t, cond), (1, 30, 32), said.alphas_cumprod, num_steps=3,
                             generator=torch.Generator().manual_seed(5))
    return said.from_diffusion(x.double()).cpu().numpy()


@CUDA
@pytest.mark.parametrize("precision", ["bf16", "fp16"])
@pytest.mark.parametrize("name", list(TINY))
def test_cuda_training_with_mixed_precision_gives_finite_weights(name, precision):
    config, steps = _config(name)
    dataset = _dataset()
    method, _ = prepared_method(name, {**config, "mixed_precision": precision}, dataset, seed=0,
                                budget=Budget(max_steps=steps), device="cuda")
    net = _network(method, name)
    assert all(p.device.type == "cuda" and torch.isfinite(p).all() for p in net.parameters())
    out = np.asarray(method.generate(_utterance(dataset), samples=2, seed=5))
    assert np.all(np.isfinite(out))
