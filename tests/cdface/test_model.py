import numpy as np
import pytest
import torch

from baselines.cdface.model import CDFaceModel, sample_pairs
from baselines.cdface.parts import FaceParts, face_parts
from baselines.cdface.pipeline import CDFace
from baselines.cdface.presets import resolve_config
from baselines.cdface.query import PartQuery
from baselines.cdface.vqvae import PartVQVAE

TINY = dict(vq_hidden=16, vq_heads=2, num_codes=2, code_dim=4, codebook_size=8, vq_half_width=2, width=16, heads=2,
            audio_self_half_width=5, self_context=4, period=8, num_lip_samples=3, num_upper_samples=2,
            encoder={"kind": "logmel", "n_mels": 8}, active_threshold=None)


def test_sample_pairs_visit_every_pair_before_repeating():
    pairs = sample_pairs(15, 3, 5, seed=0)
    assert len(set(pairs)) == 15
    assert len({i for i, _ in pairs[:3]}) == 3 and len({j for _, j in pairs[:3]}) == 3
    assert sample_pairs(16, 3, 5)[15] == sample_pairs(16, 3, 5)[0]  # then they cycle
    assert sample_pairs(5, 3, 5, seed=1) != pairs[:5]
    lips = sample_pairs(4, 3, 5, seed=2, control="lips")
    assert len({i for i, _ in lips}) == 1 and len({j for _, j in lips}) == 4
    with pytest.raises(ValueError, match="control"):
        sample_pairs(2, 2, 2, control="eyes")


def test_vq_windowed_decoding_equals_the_whole_sequence():
    torch.manual_seed(0)
    vq = PartVQVAE(9, hidden=16, layers=2, heads=2, num_codes=2, code_dim=4, codebook_size=8, half_width=2, period=8).eval()
    x = torch.randn(1, 30, 9)
    with torch.no_grad():
        q, _, idx = vq.quantized(vq.encode(x))
        full = vq.decode(q)
        np.testing.assert_allclose(vq.codes(idx).numpy(), q.numpy(), atol=1e-6)
        r = vq.receptive_field
        t = 20
        # the last frame of a prefix depends on the r frames before it only
        prefix = vq.decode(q[:, :t + 1])[:, -1]
        window = vq.decode(q[:, t - r:t + 1], offset=t - r, last=True)
        np.testing.assert_allclose(window.numpy(), prefix.numpy(), atol=1e-5)
        assert not torch.allclose(prefix, full[:, t])  # the whole sequence also looks ahead
    z = vq.encode(x).detach().requires_grad_(True)
    q, _, _ = vq.quantized(z)
    q.sum().backward()
    np.testing.assert_allclose(z.grad.numpy(), 1.0)  # straight-through


def test_query_is_causal_and_windowed_like_the_whole_past():
    torch.manual_seed(0)
    query = PartQuery(6, 8, 3, width=16, layers=2, heads=2, self_context=3, audio_half_width=1, period=8).eval()
    past, audio, style = torch.randn(1, 25, 6), torch.randn(1, 25, 16), torch.randn(1, 16)
    with torch.no_grad():
        full = query(past, audio, style)  # (N, 1, 25, 8)
        changed = past.clone()
        changed[:, 15:] += 1.0
        np.testing.assert_allclose(query(changed, audio, style)[:, :, :15].numpy(), full[:, :, :15].numpy(), atol=1e-5)
        t, lo = 20, 20 - query.receptive_field
        last = query(past[:, lo:t + 1], audio, style, start=lo, last=True)
        np.testing.assert_allclose(last.numpy(), full[:, :, t].numpy(), atol=1e-5)


def _tiny_model(num_styles=2):
    torch.manual_seed(0)
    return CDFaceModel(12, 9, 8, num_styles, resolve_config(**TINY)["model"]).eval()


def test_teacher_forced_shapes_and_lip_context():
    m = _tiny_model()
    args = torch.randn(2, 10, 12), torch.randn(2, 10, 9), torch.randn(2, 10, 8), torch.tensor([0, 1])
    out = m.teacher_forced(*args)
    assert out["lips"].shape == (3, 2, 10, 12) and out["lip_codes"].shape == (3, 2, 10, 8)
    # ground-truth lip context: one upper-face group stands for the N^l equal ones
    assert out["upper"].shape == (1, 2, 2, 10, 9) and out["upper_quantized"].shape == (1, 2, 2, 10, 8)
    m.upper_context = "predicted"
    out = m.teacher_forced(*args)
    assert out["upper"].shape == (3, 2, 2, 10, 9)
    # each group reads its own lip sample: groups differ exactly where the lip samples do
    same_lips = torch.equal(out["lips"][0], out["lips"][1])
    assert torch.equal(out["upper"][0], out["upper"][1]) == same_lips


def test_sampling_each_pair_alone_gives_the_same_sample():
    m = _tiny_model()
    feats = torch.randn(1, 14, 8)
    lips, upper = m.sample(feats, 0, [(0, 0), (2, 1), (1, 1)])
    lips2, upper2 = m.sample(feats, 0, [(2, 1)])
    np.testing.assert_allclose(lips2[0].numpy(), lips[1].numpy(), atol=1e-5)
    np.testing.assert_allclose(upper2[0].numpy(), upper[1].numpy(), atol=1e-5)
    assert not torch.allclose(upper[1], upper[2])  # same upper head, other lips: other upper face


def test_fixed_lip_codes_give_identical_lips():
    m = _tiny_model()
    feats = torch.randn(1, 12, 8)
    ref = torch.randn(12, 12)
    codes = m.encode_lips(ref)
    lips, upper = m.sample(feats, 1, [(0, 0), (0, 1)], lip_codes=codes)
    assert torch.equal(lips[0], lips[1])
    np.testing.assert_allclose(lips[0].numpy(), m.lip_vq.decode(codes[None])[0].detach().numpy(), atol=1e-6)
    assert not torch.allclose(upper[0], upper[1])


def _tiny_cdface():
    rng = np.random.default_rng(0)
    template = rng.normal(scale=0.05, size=(7, 3))
    parts = FaceParts(lips=[0, 1, 2, 3], upper=[4, 5], num_vertices=7)  # vertex 6 static
    return CDFace(resolve_config(**TINY), parts, ["A", "B"], {"A": template, "C": template + 0.01}), template


def test_generate_modes_save_and_load(tmp_path):
    from benchmark.metrics import average_pairwise_distance

    cdface, template = _tiny_cdface()
    audio = np.random.default_rng(1).normal(scale=0.1, size=16000).astype(np.float32)
    out = cdface.generate(audio, 15, subject="C", samples=4, seed=0)
    assert out.shape == (4, 15, 7, 3) and out.dtype == np.float64
    np.testing.assert_allclose(out[:, :, 6], np.broadcast_to(template[6] + 0.01, (4, 15, 3)))  # static vertex
    assert average_pairwise_distance(out, [0, 1, 2, 3]) > 0 and average_pairwise_distance(out, [4, 5]) > 0
    fixed = cdface.generate(audio, 15, subject="C", samples=4, seed=0, control="lips")
    assert average_pairwise_distance(fixed, [0, 1, 2, 3]) == 0.0 and average_pairwise_distance(fixed, [4, 5]) > 0
    reference = template[None] + np.random.default_rng(2).normal(scale=0.002, size=(15, 7, 3))
    ref = cdface.generate(audio, 15, template=template, samples=3, control="lips", reference=reference)
    assert average_pairwise_distance(ref, [0, 1, 2, 3]) == 0.0
    cdface.save(tmp_path / "m.pt")
    again = CDFace.load(tmp_path / "m.pt")
    np.testing.assert_allclose(again.generate(audio, 15, subject="C", samples=4, seed=0), out, atol=1e-6)
    with pytest.raises(ValueError, match="no template stored"):
        cdface.generate(audio, 15, subject="Z")
    with pytest.raises(ValueError, match="control"):
        cdface.generate(audio, 15, subject="A", control="eyes")


def test_face_parts_keep_the_lips_in_the_lip_part():
    # a column of vertices: y from -1 to 1, nose tip (most forward) at y = 0
    y = np.linspace(-1, 1, 11)
    template = np.stack([np.zeros(11), y, 1 - np.abs(y)], axis=1)
    parts = face_parts(template, lip_vertices=[7])
    assert 7 in parts.lips and 7 not in parts.upper
    assert len(parts.lips) + len(parts.upper) == 11
    active = np.ones(11, dtype=bool)
    active[[0, 10]] = False
    parts = face_parts(template, active=active)
    assert 0 not in parts.lips and 10 not in parts.upper
    disp = np.random.default_rng(0).normal(size=(3, 11, 3))
    lips, upper = parts.split(disp)
    back = parts.compose(lips, upper)
    np.testing.assert_allclose(back[:, active], disp[:, active])
    assert np.all(back[:, ~active] == 0)
    with pytest.raises(ValueError, match="disjoint"):
        FaceParts(lips=[0, 1], upper=[1, 2], num_vertices=3)


def test_past_dropout_one_ignores_the_past():
    m = _tiny_model()
    lips, upper, feats, style = torch.randn(1, 10, 12), torch.randn(1, 10, 9), torch.randn(1, 10, 8), torch.tensor([0])
    with torch.no_grad():
        a = m.teacher_forced(lips, upper, feats, style, past_dropout=1.0)
        b = m.teacher_forced(lips + 1.0, upper - 1.0, feats, style, past_dropout=1.0)
        c = m.teacher_forced(lips + 1.0, upper - 1.0, feats, style)
    assert torch.equal(a["lip_codes"], b["lip_codes"]) and torch.equal(a["upper_codes"], b["upper_codes"])
    assert not torch.equal(a["lip_codes"], c["lip_codes"])
