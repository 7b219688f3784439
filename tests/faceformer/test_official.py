"""The authors' vocaset.pth layout loads strictly and predicts like the authors' predict."""

import pytest
import torch
from torch import nn

from baselines.faceformer import load_official
from baselines.wav2vec2 import current_layout_state, legacy_layout_state, tiny_config, wav2vec2_model
from blendvoca.errors import DataError, UserError
from tests.faceformer.authors_reference import (
    reference_autoregression,
    reference_decoder,
    reference_pe,
    reference_wav2vec2,
)
from tests.fixtures.paths import FsPath

VDIM, D, NSUBJ, PERIOD = 5023 * 3, 64, 8, 30


def authors_state(legacy: bool, seed: int = 0, vdim: int = VDIM) -> dict:
    """A random-init state_dict with the key names and shapes of the authors' Faceformer (tiny wav2vec 2.0)."""
    torch.manual_seed(seed)
    w2v = wav2vec2_model(tiny_config()).state_dict()
    state = {"audio_encoder." + k: v for k, v in (legacy_layout_state(w2v) if legacy else w2v).items()}

    def linear(name, i, o, bias=True):
        m = nn.Linear(i, o, bias=bias)
        state[name + ".weight"] = m.weight.detach().clone()
        if bias:
            state[name + ".bias"] = m.bias.detach().clone()

    linear("audio_feature_map", 32, D)
    linear("vertice_map", vdim, D)
    state["PPE.pe"] = reference_pe(D, PERIOD)
    layer = nn.TransformerDecoderLayer(d_model=D, nhead=4, dim_feedforward=2 * D, batch_first=True)
    for k, v in nn.TransformerDecoder(layer, num_layers=1).state_dict().items():
        state["transformer_decoder." + k] = v.detach().clone()
    linear("vertice_map_r", D, vdim)
    with torch.no_grad():
        state["vertice_map_r.weight"] *= 0.01
    linear("obj_vector", NSUBJ, D, bias=False)
    return state


def reference_predict(state, audio, template, one_hot):
    w2v = wav2vec2_model(tiny_config())
    w2v.load_state_dict(current_layout_state({k[len("audio_encoder."):]: v for k, v in state.items()
                                              if k.startswith("audio_encoder.")}))
    w2v.eval()

    def linear(name, bias=True):
        w = state[name + ".weight"]
        m = nn.Linear(w.shape[1], w.shape[0], bias=bias)
        m.load_state_dict({k: state[name + "." + k] for k in (["weight", "bias"] if bias else ["weight"])})
        return m

    afm, vmap, vmap_r, obj = linear("audio_feature_map"), linear("vertice_map"), linear("vertice_map_r"), linear("obj_vector", False)
    dec = reference_decoder(state, "transformer_decoder.", D, 4, 1)
    memory = afm(reference_wav2vec2(w2v, audio))
    style = obj(one_hot).unsqueeze(1)
    out = reference_autoregression(dec, memory, style, vmap, vmap_r, state["PPE.pe"], PERIOD, memory.shape[1])
    return out + template.unsqueeze(1)


@pytest.mark.parametrize("legacy", [True, False])
def test_authors_checkpoint_loads_and_predicts_like_theirs(tmp_path, legacy):
    state = authors_state(legacy)
    path = tmp_path / "vocaset.pth"
    torch.save(state, path)
    model = load_official(path, wav2vec2_config="tiny")
    assert not model.training
    assert model.config["period"] == PERIOD and model.config["num_subjects"] == NSUBJ
    torch.manual_seed(5)
    audio = torch.randn(1, 16000 + 777)
    audio = (audio - audio.mean()) / audio.std()
    template = torch.randn(1, VDIM) * 0.05
    one_hot = torch.eye(NSUBJ)[2:3]
    with torch.no_grad():
        ours = model.predict(audio, template, one_hot)
        ref = reference_predict(state, audio, template, one_hot)
    assert ours.shape == ref.shape
    assert ours.shape[1] == int(52 / 50 * 30) == 31  # 16777 samples: 52 CNN frames
    torch.testing.assert_close(ours, ref, rtol=1e-4, atol=1e-5)
    # the loaded weights are the file's, in the model's own layout
    reloaded = model.state_dict()
    assert torch.equal(reloaded["obj_vector.weight"], state["obj_vector.weight"])


def test_wrong_checkpoint_is_a_clear_error(tmp_path):
    state = authors_state(legacy=True)
    del state["vertice_map_r.bias"]
    path = tmp_path / "broken.pth"
    torch.save(state, path)
    with pytest.raises(ValueError, match="missing.*vertice_map_r.bias"):
        load_official(path, wav2vec2_config="tiny")
    with pytest.raises(UserError, match="not found"):  # a path the user named: exit 2 at a command line
        load_official(tmp_path / "nope.pth")
    (tmp_path / "text.pth").write_text("not a checkpoint")
    with pytest.raises(DataError, match="not a readable torch checkpoint"):  # the file's content: exit 2 too
        load_official(tmp_path / "text.pth")


def test_official_files_are_named_by_any_path_like(tmp_path):
    import json

    from baselines.faceformer.plugin import FaceFormerMethod

    torch.save(authors_state(legacy=True), tmp_path / "vocaset.pth")
    assert load_official(FsPath(tmp_path / "vocaset.pth"), wav2vec2_config="tiny").config["num_subjects"] == NSUBJ
    method = FaceFormerMethod.from_official_checkpoint(FsPath(tmp_path / "vocaset.pth"), official_wav2vec2="tiny")
    assert json.loads(json.dumps(method.config()))["official"] == str(tmp_path / "vocaset.pth")  # saved as text


def test_paper_architecture_key_shapes():
    """The default (authors') config builds the key set and shapes of the released model."""
    from baselines.faceformer import Faceformer

    with torch.device("meta"):
        model = Faceformer()
    shapes = {k: tuple(v.shape) for k, v in model.state_dict().items()}
    assert shapes["audio_feature_map.weight"] == (64, 768)
    assert shapes["vertice_map.weight"] == (64, 15069)
    assert shapes["vertice_map_r.weight"] == (15069, 64)
    assert shapes["obj_vector.weight"] == (64, 8)
    assert shapes["PPE.pe"] == (1, 630, 64)
    assert shapes["transformer_decoder.layers.0.linear1.weight"] == (128, 64)
    assert shapes["audio_encoder.encoder.layers.11.feed_forward.intermediate_dense.weight"] == (3072, 768)
    assert not any(k.startswith("transformer_decoder.layers.1.") for k in shapes)
    assert "audio_encoder.masked_spec_embed" in shapes
