"""FaceFormer building blocks against closed forms and loop-built references."""

import pytest
import torch

from baselines.common.attention_bias import alibi_slopes, biased_causal_mask, enc_dec_mask
from baselines.common.encoders.trainable import authors_frame_count, wav2vec2_motion_features
from baselines.common.motion_decoder import decode_step, decode_teacher_forced, motion_decoder
from baselines.common.positional import PeriodicPositionalEncoding
from tests.faceformer.authors_reference import (
    reference_autoregression,
    reference_biased_mask,
    reference_pe,
    reference_wav2vec2,
)


def test_slopes_closed_form():
    assert alibi_slopes(4) == [2**-2, 2**-4, 2**-6, 2**-8]
    assert alibi_slopes(8) == [2.0**-k for k in range(1, 9)]
    assert alibi_slopes(6) == [2**-2, 2**-4, 2**-6, 2**-8, 2**-1, 2**-3]


@pytest.mark.parametrize("length,period", [(1, 30), (7, 3), (30, 30), (61, 30), (50, 25)])
def test_biased_causal_mask(length, period):
    mask = biased_causal_mask(4, length, period)
    assert mask.shape == (4, length, length)
    ref = reference_biased_mask(4, 600, period)[:, :length, :length]
    torch.testing.assert_close(mask, ref)
    slopes = alibi_slopes(4)
    for h in range(4):
        for i in range(length):
            for j in range(length):
                want = float("-inf") if j > i else -slopes[h] * ((i - j) // period)
                assert mask[h, i, j].item() == want


def test_enc_dec_mask():
    m = enc_dec_mask(5, 5)
    assert torch.equal(m, ~torch.eye(5, dtype=torch.bool))
    b = enc_dec_mask(3, 6, "BIWI")
    allowed = [[s for s in range(6) if not b[t, s]] for t in range(3)]
    assert allowed == [[0, 1], [2, 3], [4, 5]]
    with pytest.raises(ValueError, match="vocaset"):
        enc_dec_mask(2, 2, "other")


def test_periodic_positional_encoding():
    ppe = PeriodicPositionalEncoding(16, dropout=0.0, period=30).eval()
    torch.testing.assert_close(ppe.pe, reference_pe(16, 30))
    assert ppe.pe.shape == (1, 630, 16)
    x = torch.zeros(1, 700, 16)
    out = ppe(x)
    torch.testing.assert_close(out[:, 30:60], out[:, :30])
    torch.testing.assert_close(out[:, 690:700], out[:, 0:10])


@pytest.mark.parametrize("num_samples", [16000, 16000 * 2 + 123, 4321])
def test_interpolation_frame_counts(num_samples):
    from baselines.wav2vec2 import tiny_config, wav2vec2_model

    torch.manual_seed(0)
    w2v = wav2vec2_model(tiny_config()).eval()
    audio = torch.randn(1, num_samples)
    cnn = w2v.feature_extractor(audio).shape[-1]
    length = num_samples
    for k, s in zip(w2v.config.conv_kernel, w2v.config.conv_stride):
        length = (length - k) // s + 1
    assert cnn == length
    with torch.no_grad():
        auto = wav2vec2_motion_features(w2v, audio)
        assert auto.shape[1] == authors_frame_count(cnn) == int(cnn / 50.0 * 30)
        torch.testing.assert_close(auto, reference_wav2vec2(w2v, audio))
        fixed = wav2vec2_motion_features(w2v, audio, 17)
        assert fixed.shape == (1, 17, 32)
        torch.testing.assert_close(fixed, reference_wav2vec2(w2v, audio, 17))


@pytest.mark.parametrize("num_layers", [1, 2])
def test_cached_decoding_equals_full_prefix_redecoding(num_layers):
    torch.manual_seed(1)
    d, period, T = 16, 5, 12
    dec = motion_decoder(d, 4, num_layers).eval()
    memory = torch.randn(1, T, d)
    style = torch.randn(1, 1, d)
    embed, to_out = torch.nn.Linear(8, d), torch.nn.Linear(d, 8)
    pe = reference_pe(d, period)
    with torch.no_grad():
        ref = reference_autoregression(dec, memory, style, embed, to_out, pe, period, T)
        cache, token, outs = [None] * num_layers, style, []
        for t in range(T):
            out = to_out(decode_step(dec, token + pe[:, t : t + 1], memory, cache, period=period))
            outs.append(out)
            token = embed(out) + style
        ours = torch.cat(outs, 1)
        torch.testing.assert_close(ours, ref, rtol=1e-5, atol=1e-6)
        # and the teacher-forced pass over the same inputs gives the same frames
        inputs = torch.cat([style, embed(ours[:, :-1]) + style], 1) + pe[:, :T]
        tf = to_out(decode_teacher_forced(dec, inputs, memory, period=period))
        torch.testing.assert_close(tf, ref, rtol=1e-5, atol=1e-6)
