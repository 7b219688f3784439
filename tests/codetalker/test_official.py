"""The authors' CodeTalker stage-1/stage-2 files load strictly and predict like the authors' predict."""

import math

import pytest
import torch
from torch import nn

from baselines.codetalker import CodeTalker, VQAutoEncoder, load_official
from baselines.wav2vec2 import current_layout_state, legacy_layout_state, tiny_config, wav2vec2_model
from blendvoca.errors import DataError
from tests.codetalker.authors_reference import reference_codetalker_predict, reference_vq_decode, reference_vq_encode
from tests.faceformer.authors_reference import reference_pe

CFG1 = {"in_dim": 5023 * 3, "hidden_size": 32, "num_hidden_layers": 2, "num_attention_heads": 8,
        "intermediate_size": 48, "face_quan_num": 4, "zquant_dim": 8, "n_embed": 32}
D, N_HEAD, LAYERS, PERIOD, NSUBJ = 32, 4, 2, 30, 8


def _sinusoid_table(d, max_len=5000):
    pos = torch.arange(max_len, dtype=torch.float).unsqueeze(1)
    div = torch.exp(torch.arange(0, d, 2).float() * (-math.log(10000.0) / d))
    pe = torch.zeros(max_len, d)
    pe[:, 0::2], pe[:, 1::2] = torch.sin(pos * div), torch.cos(pos * div)
    return pe.unsqueeze(1)


def authors_stage1_shapes(c):
    h, i, v = c["hidden_size"], c["intermediate_size"], c["in_dim"]
    shapes = {"encoder.vertice_mapping.0.weight": (h, v), "encoder.vertice_mapping.0.bias": (h,),
              "encoder.squasher.0.0.weight": (h, h, 5), "encoder.squasher.0.0.bias": (h,),
              "encoder.encoder_linear_embedding.net.weight": (h, h), "encoder.encoder_linear_embedding.net.bias": (h,),
              "decoder.expander.0.0.weight": (h, h, 5), "decoder.expander.0.0.bias": (h,),
              "decoder.decoder_linear_embedding.net.weight": (h, h), "decoder.decoder_linear_embedding.net.bias": (h,),
              "decoder.vertice_map_reverse.weight": (v, h), "decoder.vertice_map_reverse.bias": (v,),
              "quantize.embedding.weight": (c["n_embed"], c["zquant_dim"])}
    for part in ("encoder.encoder_transformer", "decoder.decoder_transformer"):
        for n in range(c["num_hidden_layers"]):
            a, m = f"{part}.net.{2 * n}.fn", f"{part}.net.{2 * n + 1}.fn"
            shapes.update({a + ".norm.weight": (h,), a + ".norm.bias": (h,), a + ".fn.to_qkv.weight": (3 * h, h),
                           a + ".fn.to_out.weight": (h, h), a + ".fn.to_out.bias": (h,),
                           m + ".norm.weight": (h,), m + ".norm.bias": (h,), m + ".fn.l1.weight": (i, h),
                           m + ".fn.l1.bias": (i,), m + ".fn.l2.weight": (h, i), m + ".fn.l2.bias": (h,)})
    return shapes


def _random(shape, key):
    if key.endswith("norm.weight"):
        return 1.0 + 0.1 * torch.randn(shape)
    fan_in = shape[1] * (shape[2] if len(shape) > 2 else 1) if len(shape) > 1 else 10
    return torch.randn(shape) / math.sqrt(fan_in)


def authors_stage1_state(seed=0, cfg1=CFG1):
    torch.manual_seed(seed)
    state = {k: _random(s, k) for k, s in authors_stage1_shapes(cfg1).items()}
    state["quantize.embedding.weight"] = torch.randn(cfg1["n_embed"], cfg1["zquant_dim"])
    state["encoder.encoder_pos_embedding.pe"] = _sinusoid_table(cfg1["hidden_size"])
    state["decoder.decoder_pos_embedding.pe"] = _sinusoid_table(cfg1["hidden_size"])
    return state


def authors_stage2_state(legacy, seed=1, cfg1=CFG1):
    torch.manual_seed(seed)
    w2v = wav2vec2_model(tiny_config()).state_dict()
    state = {"audio_encoder." + k: v for k, v in (legacy_layout_state(w2v) if legacy else w2v).items()}
    for name, shape in {"audio_feature_map.weight": (D, 32), "audio_feature_map.bias": (D,),
                        "vertice_map.weight": (D, cfg1["in_dim"]), "vertice_map.bias": (D,),
                        "feat_map.weight": (cfg1["face_quan_num"] * cfg1["zquant_dim"], D),
                        "learnable_style_emb.weight": (NSUBJ, D)}.items():
        state[name] = _random(shape, name)
    state["learnable_style_emb.weight"] = torch.randn(NSUBJ, D)
    state["feat_map.weight"] *= 3.0
    state["PPE.pe"] = reference_pe(D, PERIOD)
    layer = nn.TransformerDecoderLayer(d_model=D, nhead=N_HEAD, dim_feedforward=2 * D, batch_first=True)
    for k, v in nn.TransformerDecoder(layer, num_layers=LAYERS).state_dict().items():
        state["transformer_decoder." + k] = v.detach().clone()
    return state


def test_vq_autoencoder_matches_functional_reference():
    s1 = authors_stage1_state()
    vq = VQAutoEncoder(CFG1).eval()
    vq.load_state_dict(s1, strict=True)
    torch.manual_seed(3)
    disp = 0.01 * torch.randn(1, 9, CFG1["in_dim"])
    with torch.no_grad():
        z = vq.encoder(disp).reshape(1, -1, CFG1["zquant_dim"])
        torch.testing.assert_close(z, reference_vq_encode(s1, disp, CFG1), rtol=1e-4, atol=1e-5)
        quant, _, (_, _, idx) = vq.encode(disp)
        e = s1["quantize.embedding.weight"]
        brute = ((z[0][:, None] - e[None]) ** 2).sum(-1).argmin(-1)
        assert torch.equal(idx[:, 0], brute)
        torch.testing.assert_close(vq.decode(quant), reference_vq_decode(s1, e[brute][None], CFG1), rtol=1e-4, atol=1e-5)


@pytest.mark.parametrize("legacy", [True, False])
def test_authors_checkpoints_load_and_predict_like_theirs(tmp_path, legacy):
    s1, s2 = authors_stage1_state(), authors_stage2_state(legacy)
    torch.save({"state_dict": s1}, tmp_path / "vocaset_stage1.pth.tar")
    torch.save({"state_dict": s2}, tmp_path / "vocaset_stage2.pth.tar")
    model = load_official(tmp_path / "vocaset_stage2.pth.tar", tmp_path / "vocaset_stage1.pth.tar", wav2vec2_config="tiny")
    assert not model.training and model.config["num_layers"] == LAYERS and model.stage1["face_quan_num"] == 4
    w2v = wav2vec2_model(tiny_config())
    w2v.load_state_dict(current_layout_state({k[len("audio_encoder."):]: v for k, v in s2.items()
                                              if k.startswith("audio_encoder.")}))
    w2v.eval()
    torch.manual_seed(4)
    audio = torch.randn(1, 9000)
    audio = (audio - audio.mean()) / audio.std()
    template = 0.05 * torch.randn(1, CFG1["in_dim"])
    one_hot = torch.eye(NSUBJ)[5:6]
    with torch.no_grad():
        ours = model.predict(audio, template, one_hot)
        ref = reference_codetalker_predict(s1, s2, w2v, audio, template, one_hot, CFG1, D, N_HEAD, LAYERS, PERIOD)
    assert ours.shape == ref.shape and ours.shape[1] == int(28 / 50 * 30)
    torch.testing.assert_close(ours, ref, rtol=1e-4, atol=1e-5)
    # the stage-2 file holds no VQ-VAE keys; saving ours the same way gives the same key set
    assert set(model.stage2_state_dict()) == set(current_layout_state(s2))


def test_stage2_without_stage1_keys_only(tmp_path):
    s1, s2 = authors_stage1_state(), authors_stage2_state(True)
    del s1["quantize.embedding.weight"]
    torch.save({"state_dict": s1}, tmp_path / "s1.pth.tar")
    torch.save({"state_dict": s2}, tmp_path / "s2.pth.tar")
    with pytest.raises(DataError, match="quantize.embedding.weight"):  # the file's content: exit 2
        load_official(tmp_path / "s2.pth.tar", tmp_path / "s1.pth.tar", wav2vec2_config="tiny")


def test_paper_architecture_key_shapes():
    with torch.device("meta"):
        model = CodeTalker()
    shapes = {k: tuple(v.shape) for k, v in model.state_dict().items()}
    paper1 = {"in_dim": 15069, "hidden_size": 1024, "num_hidden_layers": 6, "intermediate_size": 1536,
              "n_embed": 256, "zquant_dim": 64}
    for k, s in authors_stage1_shapes(paper1).items():
        assert shapes["autoencoder." + k] == s, k
    assert shapes["autoencoder.encoder.encoder_pos_embedding.pe"] == (5000, 1, 1024)
    assert shapes["feat_map.weight"] == (16 * 64, 1024)
    assert shapes["learnable_style_emb.weight"] == (8, 1024)
    assert shapes["audio_feature_map.weight"] == (1024, 768)
    assert shapes["transformer_decoder.layers.5.linear1.weight"] == (2048, 1024)
    assert "feat_map.bias" not in shapes
    n_ae = sum(1 for k in shapes if k.startswith("autoencoder."))
    assert n_ae == len(authors_stage1_shapes(paper1)) + 2
