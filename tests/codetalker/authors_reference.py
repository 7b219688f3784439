"""Functional reference of the authors' CodeTalker forward passes, straight from a state dict.

Plain torch functions over the tensors of the authors' key layout (no module of
``baselines.codetalker``), the prefix re-decoded in full at every step, brute-force
nearest codes.
"""

import math

import torch
import torch.nn.functional as F

from tests.faceformer.authors_reference import (
    reference_biased_mask,
    reference_decoder,
    reference_enc_dec_mask,
    reference_wav2vec2,
)


def _linear(s, name, x, bias=True):
    return F.linear(x, s[name + ".weight"], s.get(name + ".bias") if bias else None)


def _gelu_tanh(x):
    return 0.5 * x * (1.0 + torch.tanh(math.sqrt(2 / math.pi) * (x + 0.044715 * x**3)))


def _transformer(s, prefix, x, layers, heads, hidden):
    for n in range(layers):
        a = f"{prefix}.net.{2 * n}.fn"
        h = F.layer_norm(x, (hidden,), s[a + ".norm.weight"], s[a + ".norm.bias"], 1e-5)
        qkv = F.linear(h, s[a + ".fn.to_qkv.weight"])
        b, t, _ = qkv.shape
        qkv = qkv.view(b, t, 3, heads, -1)
        q, k, v = (qkv[:, :, i].transpose(1, 2) for i in range(3))
        att = torch.softmax(q @ k.transpose(-1, -2) * hidden**-0.5, dim=-1)
        out = (att @ v).transpose(1, 2).reshape(b, t, -1)
        x = x + _linear(s, a + ".fn.to_out", out)
        m = f"{prefix}.net.{2 * n + 1}.fn"
        h = F.layer_norm(x, (hidden,), s[m + ".norm.weight"], s[m + ".norm.bias"], 1e-5)
        x = x + _linear(s, m + ".fn.l2", _gelu_tanh(_linear(s, m + ".fn.l1", h)))
    return x


def _conv_block(s, prefix, x):
    x = F.conv1d(F.pad(x, (2, 2), mode="replicate"), s[prefix + ".0.weight"], s[prefix + ".0.bias"])
    x = F.leaky_relu(x, 0.2)
    return F.instance_norm(x, eps=1e-5)


def _sinusoid_row0(hidden):
    # pe[:x.size(0)] on a batch-first input with batch 1: the position-0 row (sin 0, cos 0)
    row = torch.zeros(hidden)
    row[1::2] = 1.0
    return row


def reference_vq_decode(s, codes, cfg):
    """codes (B, T*fqn, zd) -> displacements (B, T, in_dim)."""
    b = codes.shape[0]
    x = codes.reshape(b, -1, cfg["hidden_size"]).transpose(1, 2)
    x = _conv_block(s, "decoder.expander.0", x).transpose(1, 2)
    x = _linear(s, "decoder.decoder_linear_embedding.net", x) + _sinusoid_row0(cfg["hidden_size"])
    x = _transformer(s, "decoder.decoder_transformer", x, cfg["num_hidden_layers"], cfg["num_attention_heads"], cfg["hidden_size"])
    return _linear(s, "decoder.vertice_map_reverse", x)


def reference_vq_encode(s, disp, cfg):
    """displacements (B, T, in_dim) -> continuous features (B, T*fqn, zd)."""
    x = F.leaky_relu(_linear(s, "encoder.vertice_mapping.0", disp), 0.2)
    x = _conv_block(s, "encoder.squasher.0", x.transpose(1, 2)).transpose(1, 2)
    x = _linear(s, "encoder.encoder_linear_embedding.net", x) + _sinusoid_row0(cfg["hidden_size"])
    x = _transformer(s, "encoder.encoder_transformer", x, cfg["num_hidden_layers"], cfg["num_attention_heads"], cfg["hidden_size"])
    return x.reshape(x.shape[0], -1, cfg["zquant_dim"])


def nearest(s, z):
    e = s["quantize.embedding.weight"]
    d = ((z[..., None, :] - e) ** 2).sum(-1)
    return e[d.argmin(-1)]


def reference_codetalker_predict(s1, s2, w2v, audio, template, one_hot, cfg1, d, n_head, layers, period):
    memory = _linear(s2, "audio_feature_map", reference_wav2vec2(w2v, audio))
    style = s2["learnable_style_emb.weight"][one_hot.argmax(1)].unsqueeze(1)
    dec = reference_decoder(s2, "transformer_decoder.", d, n_head, layers)
    pe = s2["PPE.pe"]
    biased = reference_biased_mask(n_head, 600, period)
    fqn, zd = cfg1["face_quan_num"], cfg1["zquant_dim"]
    emb = style
    T = memory.shape[1]
    for i in range(T):
        x = emb + pe[:, : emb.shape[1]]
        L = x.shape[1]
        feat = F.linear(dec(x, memory, tgt_mask=biased[:, :L, :L], memory_mask=reference_enc_dec_mask(L, T)),
                        s2["feat_map.weight"])
        q = nearest(s1, feat.reshape(1, L * fqn, zd))
        if i == 0:
            out = reference_vq_decode(s1, torch.cat([q, q], dim=1), cfg1)[:, :1]
        else:
            out = reference_vq_decode(s1, q, cfg1)
        if i != T - 1:
            emb = torch.cat([emb, _linear(s2, "vertice_map", out[:, -1]).unsqueeze(1) + style], dim=1)
    q = nearest(s1, feat.reshape(1, T * fqn, zd))
    return reference_vq_decode(s1, q, cfg1) + template.unsqueeze(1)
