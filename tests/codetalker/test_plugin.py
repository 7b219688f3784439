"""CodeTalker plug-in and training: contract, codebook learning, two-stage freeze, round trip."""

import math

import numpy as np
import pytest
import torch

from baselines.codetalker.plugin import CodeTalkerMethod
from baselines.codetalker.train import split_budget, train_stage1
from baselines.codetalker.vqvae import VQAutoEncoder
from baselines.common.sequences import MotionSequence
from benchmark.methods.base import Budget, TrainingRequest
from benchmark.testing import FakeBlendVOCA, check_method

TINY = {"feature_dim": 16, "vq_hidden_size": 16, "vq_zquant_dim": 4, "vq_n_embed": 16, "max_seconds": None}


def test_check_method_contract():
    check_method(CodeTalkerMethod, max_steps=4, samples=2, **TINY)


def test_budget_split():
    assert split_budget(10, float("inf"), 0.4) == ((4, float("inf")), (6, float("inf")))
    (s1, t1), (s2, t2) = split_budget(float("inf"), 100.0, 0.25)
    assert (t1, t2) == (25.0, 75.0) and s1 == s2 == float("inf")


@pytest.mark.slow
def test_stage1_learns_a_codebook_that_reconstructs():
    """On a toy of 8 repeated poses the VQ-VAE's reconstruction error falls well below the motion's size."""
    rng = np.random.default_rng(0)
    poses = rng.standard_normal((8, 12)).astype(np.float32)
    seqs = [MotionSequence("A", f"s{i}", np.zeros(16000, np.float32), poses[rng.integers(0, 8, 30)],
                           np.zeros(12, np.float32)) for i in range(4)]
    torch.manual_seed(0)
    vq = VQAutoEncoder({"in_dim": 12, "hidden_size": 16, "num_hidden_layers": 1, "num_attention_heads": 2,
                        "intermediate_size": 32, "face_quan_num": 2, "zquant_dim": 8, "n_embed": 32})
    before = vq.quantize.embedding.weight.detach().clone()
    training = {"motion_scale": 1.0, "quant_loss_weight": 1.0, "stage1_lr": 3e-3, "num_threads": 1, "grad_clip": 1.0}
    hist = train_stage1(vq, seqs, [], training=training, seed=0, max_steps=400, max_seconds=float("inf"))
    assert hist["steps"] == 400
    assert not torch.equal(vq.quantize.embedding.weight, before)
    x = torch.from_numpy(seqs[0].vertices)[None]
    with torch.no_grad():
        recon, _, (perplexity, _, _) = vq(x, torch.zeros(1, 12))
    err = float(torch.mean(torch.abs(recon - x)))
    assert err < 0.35 * float(torch.mean(torch.abs(x)))
    assert float(perplexity) > 2.0  # more than a couple of codes in use


def test_stage2_training_leaves_the_vq_vae_frozen():
    ds = FakeBlendVOCA(0, train=2, sentences=1)
    m = CodeTalkerMethod(**TINY)
    m.train(ds, TrainingRequest(seed=0, budget=Budget(max_steps=6)))
    assert m.history["stage1"]["steps"] == 2 and m.history["stage2"]["steps"] == 4
    vq_before = {k: v.clone() for k, v in m.network.autoencoder.state_dict().items()}
    from baselines.codetalker.train import train_stage2
    from baselines.common.sequences import motion_sequences

    train_stage2(m.network, motion_sequences(ds, "train"), [], m.subjects, training=m.settings["training"], seed=0,
                 max_steps=2, max_seconds=float("inf"))
    for k, v in m.network.autoencoder.state_dict().items():
        assert torch.equal(v, vq_before[k]), k
    assert not any(p.requires_grad for p in m.network.autoencoder.parameters())


def test_save_load_round_trip(tmp_path):
    ds = FakeBlendVOCA(2, train=2, sentences=1)
    m = CodeTalkerMethod(**TINY)
    m.train(ds, TrainingRequest(seed=0, budget=Budget(max_steps=3)))
    m.save(tmp_path)
    back = CodeTalkerMethod.load(tmp_path)
    subject = ds.split("test")[0]
    u = ds.utterance(subject, ds.sentences(subject)[0], "test")
    np.testing.assert_array_equal(back.generate(u, samples=2), m.generate(u, samples=2))  # bit for bit
    payload = torch.load(tmp_path / m.checkpoint_file, weights_only=True)  # tensors, numbers and strings only
    assert set(payload) >= {"state_dict", "subjects", "templates"}


def test_official_paths_come_in_pairs():
    with pytest.raises(ValueError, match="official_stage1"):
        CodeTalkerMethod(official="stage2.pth.tar")


def test_official_checkpoints_through_the_runner(tmp_path):
    """``benchmark.run --checkpoint vocaset_stage2.pth.tar`` finds the stage-1 file beside it."""
    from benchmark.protocol import prepared_method
    from tests.codetalker import test_official as official

    ds = FakeBlendVOCA(0, train=2, sentences=1)
    subject = ds.split("test")[0]
    vdim = ds.template(subject).size
    cfg1 = {**official.CFG1, "in_dim": vdim}
    s1, s2 = official.authors_stage1_state(cfg1=cfg1), official.authors_stage2_state(True, cfg1=cfg1)
    torch.save({"state_dict": s1}, tmp_path / "vocaset_stage1.pth.tar")
    torch.save({"state_dict": s2}, tmp_path / "vocaset_stage2.pth.tar")
    method, timings = prepared_method("codetalker", {"official_wav2vec2": "tiny"}, ds, seed=0,
                                      budget=Budget(max_steps=5), checkpoint=tmp_path / "vocaset_stage2.pth.tar")
    assert timings["train_s"] is None and len(method.subjects) == 8
    u = ds.utterance(subject, ds.sentences(subject)[0], "test")
    out = method.generate(u, samples=2)
    assert out.shape == (2, u.num_frames, vdim // 3, 3) and np.isfinite(out).all()
    (tmp_path / "vocaset_stage1.pth.tar").unlink()
    with pytest.raises(Exception, match="stage-1 file"):
        prepared_method("codetalker", {"official_wav2vec2": "tiny"}, ds, seed=0, budget=Budget(max_steps=5),
                        checkpoint=tmp_path / "vocaset_stage2.pth.tar")


def test_official_files_are_named_by_any_path_like(tmp_path):
    import json

    from baselines.codetalker import load_official
    from tests.codetalker import test_official as official
    from tests.fixtures.paths import FsPath

    torch.save({"state_dict": official.authors_stage1_state()}, tmp_path / "v_stage1.pth.tar")
    torch.save({"state_dict": official.authors_stage2_state(True)}, tmp_path / "v_stage2.pth.tar")
    model = load_official(FsPath(tmp_path / "v_stage2.pth.tar"), FsPath(tmp_path / "v_stage1.pth.tar"),
                          wav2vec2_config="tiny")
    assert not model.training
    method = CodeTalkerMethod.from_official_checkpoint(FsPath(tmp_path / "v_stage2.pth.tar"), official_wav2vec2="tiny")
    saved = json.loads(json.dumps(method.config()))  # the paths are recorded as text
    assert (saved["official"], saved["official_stage1"]) == (str(tmp_path / "v_stage2.pth.tar"),
                                                            str(tmp_path / "v_stage1.pth.tar"))


def test_paper_schedule_is_epochs_when_no_budget_is_given():
    from baselines.common.training import epochs_to_steps
    from baselines.common.vertex_method import training_limits

    from baselines.codetalker.presets import resolve_config

    t = resolve_config("paper")["training"]
    steps, seconds = training_limits(Budget(), t["max_steps"], t["max_seconds"])
    assert math.isinf(steps) and math.isinf(seconds)
    assert epochs_to_steps(t, 320, steps, seconds) == 100 * 320
    assert training_limits(Budget(max_steps=7), t["max_steps"], t["max_seconds"]) == (7, math.inf)
    with pytest.raises(ValueError, match="CodeTalker config: unknown key 'widht'"):
        resolve_config("paper", widht=3)


def test_fed_back_frames_replace_the_ground_truth_inputs_only():
    """``vertice_input`` changes what is fed back, not the targets; its last frame is never fed."""
    m = CodeTalkerMethod(**TINY)
    torch.manual_seed(0)
    m.build_network(2, 12)
    net = m.network.eval()
    torch.nn.init.normal_(net.feat_map.weight, std=0.5)  # zero at init would hide the inputs' effect
    g = torch.Generator().manual_seed(1)
    audio, tpl = torch.randn(1, 16000, generator=g) * 0.1, torch.randn(1, 12, generator=g)
    target, fed = torch.randn(1, 30, 12, generator=g), torch.randn(1, 30, 12, generator=g)
    one_hot = torch.eye(2)[:1]
    with torch.no_grad():
        pred_fed, _, _ = net(audio, tpl, fed, one_hot)
        pred, motion, _ = net(audio, tpl, target, one_hot, vertice_input=fed)
        torch.testing.assert_close(pred, pred_fed)
        torch.testing.assert_close(motion, torch.mean((pred - target) ** 2))
        torch.testing.assert_close(net(audio, tpl, target, one_hot, vertice_input=target)[0], net(audio, tpl, target, one_hot)[0])
        last_changed = fed.clone()
        last_changed[:, -1] += 1.0
        torch.testing.assert_close(net(audio, tpl, target, one_hot, vertice_input=last_changed)[0], pred)
        assert not torch.allclose(pred, net(audio, tpl, target, one_hot)[0])


def test_own_input_feeding_is_switchable_and_seeded():
    """``own_input_prob`` 0 is the authors' teacher forcing; > 0 trains differently, reproducibly."""
    from baselines.codetalker.train import train_stage2
    from baselines.common.sequences import motion_sequences

    ds = FakeBlendVOCA(0, train=2, sentences=1)
    train, subjects = motion_sequences(ds, "train"), list(ds.split("train"))
    weights = []
    for prob in (0.0, 1.0, 1.0):
        m = CodeTalkerMethod(**TINY, own_input_prob=prob, val_free_running=False)
        torch.manual_seed(0)
        m.build_network(len(subjects), int(train[0].template.size))
        torch.nn.init.normal_(m.network.feat_map.weight, std=0.1)
        train_stage2(m.network, train, [], subjects, training=m.settings["training"],
                     seed=0, max_steps=4, max_seconds=float("inf"))
        weights.append(m.network.vertice_map.weight.detach().clone())
    assert not torch.allclose(weights[0], weights[1])
    torch.testing.assert_close(weights[1], weights[2])
