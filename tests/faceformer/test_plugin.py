"""FaceFormer plug-in: the method contract, styles as samples, frame rates, a trained toy."""

import numpy as np
import pytest
import torch

from baselines.common.sequences import motion_frames, to_benchmark_rate
from baselines.common.vertex_method import style_indices
from baselines.faceformer.plugin import FaceFormerMethod
from benchmark.testing import FakeBlendVOCA, check_method
from blendvoca.errors import UserError

TINY = {"feature_dim": 16, "max_seconds": None}


def test_check_method_contract():
    report = check_method(FaceFormerMethod, max_steps=2, samples=3, **TINY)
    assert report is not None


def test_benchmark_rate_resampling_closed_form():
    track = np.arange(5, dtype=float)[:, None] * np.array([[1.0, -2.0]])
    out = to_benchmark_rate(track, 10)
    np.testing.assert_allclose(out[:, 0], [0, 0.5, 1, 1.5, 2, 2.5, 3, 3.5, 4, 4])
    np.testing.assert_allclose(out[:, 1], -2 * out[:, 0])
    assert [motion_frames(n) for n in (1, 2, 3, 10, 11)] == [1, 1, 2, 5, 6]


def test_samples_are_training_speaker_styles():
    assert style_indices(5, 1, 3) == [1, 2, 0, 1, 2]
    ds = FakeBlendVOCA(0, train=2, sentences=1)
    from benchmark.methods.base import Budget, TrainingRequest

    m = FaceFormerMethod(**TINY)
    m.train(ds, TrainingRequest(seed=0, budget=Budget(max_steps=3)))
    # push the style embedding apart so that styles visibly differ
    with torch.no_grad():
        m.network.obj_vector.weight.normal_()
    subject = ds.split("test")[0]
    u = ds.utterance(subject, ds.sentences(subject)[0], "test")
    out = m.generate(u, samples=3, seed=0)
    assert out.shape == (3, u.num_frames, ds.template(subject).shape[0], 3)
    assert np.abs(out[0] - out[1]).max() > 0
    # the styles run as one batch: equal up to float32 rounding of a different batch size
    np.testing.assert_allclose(out[2], out[0], rtol=0, atol=1e-6)
    np.testing.assert_allclose(m.generate(u, samples=1, seed=1)[0], out[1], rtol=0, atol=1e-6)


@pytest.mark.slow
def test_teacher_forcing_and_autoregression_agree_on_a_trained_toy():
    """Trained to reproduce one sequence, the free-running prediction follows the teacher-forced one."""
    from baselines.faceformer.model import Faceformer

    torch.manual_seed(0)
    torch_frames, vdim = 40, 6
    model = Faceformer({"vertice_dim": vdim, "feature_dim": 32, "num_subjects": 2, "dropout": 0.0, "period": 10,
                        "audio": {"kind": "logmel", "n_mels": 20, "hidden_size": 16, "layers": 1}})
    t = torch.linspace(0, 4 * np.pi, torch_frames)
    target = torch.stack([torch.sin(t * (k + 1) / 2) for k in range(vdim)], -1)[None] * 0.5
    template = torch.zeros(1, vdim)
    audio = torch.randn(1, int(torch_frames / 30 * 16000))
    one_hot = torch.eye(2)[:1]
    opt = torch.optim.Adam(model.parameters(), lr=3e-3)
    model.train()
    for _ in range(300):
        loss = torch.mean((model(audio, template, target, one_hot) - target) ** 2)
        opt.zero_grad()
        loss.backward()
        opt.step()
    model.eval()
    with torch.no_grad():
        tf = model(audio, template, target, one_hot)
        ar = model.predict(audio, template, one_hot, torch_frames)
    assert float(torch.mean((tf - target) ** 2)) < 1e-3
    assert float(torch.mean((ar - tf) ** 2)) < 0.05 * float(torch.mean(target**2))
    # Feeding the free-running output back in teacher-forced mode reproduces it exactly once
    # the motion encoder's bias is zero: the authors' teacher forcing embeds the template
    # displacement (vertice_map(0) = bias) at frame 0 where predict uses the style alone.
    with torch.no_grad():
        model.vertice_map.bias.zero_()
        ar = model.predict(audio, template, one_hot, torch_frames)
        torch.testing.assert_close(model(audio, template, ar, one_hot), ar, rtol=1e-4, atol=1e-5)


def test_save_load_round_trip(tmp_path):
    from benchmark.methods.base import Budget, TrainingRequest

    ds = FakeBlendVOCA(1, train=2, sentences=1)
    m = FaceFormerMethod(**TINY)
    m.train(ds, TrainingRequest(seed=0, budget=Budget(max_steps=2)))
    m.save(tmp_path)
    back = FaceFormerMethod.load(tmp_path)
    subject = ds.split("test")[0]
    u = ds.utterance(subject, ds.sentences(subject)[0], "test")
    np.testing.assert_array_equal(back.generate(u, samples=2), m.generate(u, samples=2))  # bit for bit
    payload = torch.load(tmp_path / m.checkpoint_file, weights_only=True)  # tensors, numbers and strings only
    assert set(payload) >= {"state_dict", "subjects", "templates"}
    assert back.subjects == m.subjects


def test_official_checkpoint_through_the_runner(tmp_path):
    """``benchmark.run --checkpoint vocaset.pth``: the authors' weights, their 8 styles, no training."""
    from baselines.faceformer import load_official
    from benchmark.methods.base import Budget, TrainingRequest
    from benchmark.protocol import prepared_method
    from tests.faceformer.test_official import authors_state

    ds = FakeBlendVOCA(0, train=2, sentences=1)
    subject = ds.split("test")[0]
    vdim = ds.template(subject).size
    torch.save(authors_state(legacy=True, vdim=vdim), tmp_path / "vocaset.pth")
    with pytest.raises(UserError, match="missing.pth"):
        FaceFormerMethod(official=str(tmp_path / "missing.pth"))
    method, timings = prepared_method("faceformer", {"official_wav2vec2": "tiny"}, ds, seed=0,
                                      budget=Budget(max_steps=5), checkpoint=tmp_path / "vocaset.pth")
    assert timings["train_s"] is None and len(method.subjects) == 8
    u = ds.utterance(subject, ds.sentences(subject)[0], "test")
    out = method.generate(u, samples=2, seed=3)
    assert out.shape == (2, u.num_frames, vdim // 3, 3)
    # sample 0 is style 3: the authors' predict with one-hot 3, at 30 fps, resampled to 60 fps
    from baselines.common.encoders.wav2vec2 import normalize_waveform
    from baselines.common.sequences import motion_frames, to_benchmark_rate

    model = load_official(tmp_path / "vocaset.pth", wav2vec2_config="tiny")
    with torch.no_grad():
        ref = model.predict(normalize_waveform(torch.from_numpy(u.audio)[None]),
                            torch.from_numpy(ds.template(subject).reshape(1, -1)).float(),
                            torch.eye(8)[3:4], motion_frames(u.num_frames))[0].numpy()
    np.testing.assert_allclose(out[0], to_benchmark_rate(ref, u.num_frames).reshape(out[0].shape), atol=1e-6)


@pytest.mark.parametrize("plugin", ["faceformer", "codetalker"])
def test_all_styles_in_one_batch_equal_one_call_per_style(plugin):
    from benchmark.methods import get_method
    from benchmark.methods.base import Budget, TrainingRequest

    config = TINY if plugin == "faceformer" else {"feature_dim": 16, "vq_hidden_size": 16, "vq_zquant_dim": 4,
                                                   "vq_n_embed": 16, "max_seconds": None}
    ds = FakeBlendVOCA(1, train=3, sentences=1)
    m = get_method(plugin)(**config)
    m.train(ds, TrainingRequest(seed=0, budget=Budget(max_steps=3)))
    with torch.no_grad():  # styles far apart
        (m.network.obj_vector if plugin == "faceformer" else m.network.learnable_style_emb).weight.normal_()
    subject = ds.split("test")[0]
    u = ds.utterance(subject, ds.sentences(subject)[0], "test")
    template = m.templates[subject]
    frames = motion_frames(u.num_frames)
    batched = m.predict_motion(u.audio, template, [2, 0, 1, 2], frames)
    single = np.stack([m.predict_motion(u.audio, template, s, frames) for s in (2, 0, 1, 2)])
    assert batched.shape == single.shape == (4, frames, template.size)
    np.testing.assert_allclose(batched, single, rtol=0, atol=1e-6)
    # styles differ by far more than the batching tolerance (the zero-initialised output
    # layer has moved for 3 steps only)
    assert np.abs(single[0] - single[1]).max() > 2e-5
    if plugin == "codetalker":  # the authors' network depends on the batch position: one style per call
        assert not m.batch_styles
        with torch.no_grad():
            one_hot = torch.eye(3)[[0, 1]]
            a = torch.from_numpy(u.audio)[None].expand(2, -1)
            tpl = torch.from_numpy(template.astype(np.float32)).reshape(1, -1).expand(2, -1)
            second = m.network.eval().predict(a, tpl, one_hot, frames)[1].numpy() / m.motion_scale
        assert np.abs(second - m.predict_motion(u.audio, template, 1, frames)).max() > 1e-3
