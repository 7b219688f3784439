"""Independent reference computations of the authors' FaceFormer forward pass, for tests.

Written from the published description and the public code's behaviour (loop-built
masks, full re-decoding of the prefix at every step, stock torch modules), sharing no
code with ``baselines.faceformer``.
"""

import math

import torch
import torch.nn.functional as F
from torch import nn


def reference_slopes(n):
    def p2(n):
        start = 2 ** (-(2 ** -(math.log2(n) - 3)))
        return [start * start**i for i in range(n)]

    if math.log2(n).is_integer():
        return p2(n)
    c = 2 ** math.floor(math.log2(n))
    return p2(c) + reference_slopes(2 * c)[0::2][: n - c]


def reference_biased_mask(n_head, max_seq_len, period):
    slopes = torch.tensor(reference_slopes(n_head), dtype=torch.float32)
    steps = torch.arange(0, max_seq_len, period).unsqueeze(1).repeat(1, period).view(-1) // period
    steps = -torch.flip(steps, dims=[0])
    alibi = torch.zeros(max_seq_len, max_seq_len)
    for i in range(max_seq_len):
        alibi[i, : i + 1] = steps[-(i + 1):]
    alibi = slopes[:, None, None] * alibi[None]
    causal = (torch.triu(torch.ones(max_seq_len, max_seq_len)) == 1).transpose(0, 1).float()
    causal = causal.masked_fill(causal == 0, float("-inf")).masked_fill(causal == 1, 0.0)
    return causal[None] + alibi


def reference_enc_dec_mask(T, S):
    mask = torch.ones(T, S)
    for i in range(T):
        mask[i, i] = 0
    return mask == 1


def reference_pe(d_model, period, max_seq_len=600):
    pe = torch.zeros(period, d_model)
    pos = torch.arange(0, period, dtype=torch.float).unsqueeze(1)
    div = torch.exp(torch.arange(0, d_model, 2).float() * (-math.log(10000.0) / d_model))
    pe[:, 0::2] = torch.sin(pos * div)
    pe[:, 1::2] = torch.cos(pos * div)
    return pe.unsqueeze(0).repeat(1, max_seq_len // period + 1, 1)


def reference_wav2vec2(w2v, audio, frame_num=None):
    hidden = w2v.feature_extractor(audio).transpose(1, 2)
    if frame_num is None:
        frame_num = int(hidden.shape[1] / 50.0 * 30)
    hidden = F.interpolate(hidden.transpose(1, 2), size=frame_num, align_corners=True, mode="linear").transpose(1, 2)
    hidden = w2v.feature_projection(hidden)
    hidden = hidden[0] if isinstance(hidden, tuple) else hidden
    return w2v.encoder(hidden).last_hidden_state


def reference_decoder(state, prefix, d_model, n_head, num_layers):
    layer = nn.TransformerDecoderLayer(d_model=d_model, nhead=n_head, dim_feedforward=2 * d_model, batch_first=True)
    dec = nn.TransformerDecoder(layer, num_layers=num_layers)
    dec.load_state_dict({k[len(prefix):]: v for k, v in state.items() if k.startswith(prefix)})
    return dec.eval()


def reference_autoregression(decoder, memory, style, embed, to_out, pe, period, n_frames, n_head=4):
    """The authors' predict loop: re-decode the whole prefix each step, keep the last frame."""
    biased = reference_biased_mask(n_head, 600, period)
    vertice_emb = style
    for i in range(n_frames):
        x = vertice_emb + pe[:, : vertice_emb.shape[1]]
        L = x.shape[1]
        out = decoder(x, memory, tgt_mask=biased[:, :L, :L], memory_mask=reference_enc_dec_mask(L, memory.shape[1]))
        out = to_out(out)
        vertice_emb = torch.cat([vertice_emb, embed(out[:, -1]).unsqueeze(1) + style], dim=1)
    return out
