import numpy as np
import pytest
import torch

from baselines.common.encoders import build_encoder, interpolate_features, mel_filterbank
from baselines.common.encoders.logmel import LogMelEncoder


def test_mel_filterbank_matches_transformers_htk():
    from transformers.audio_utils import mel_filter_bank

    for n_fft, n_mels, fmin, fmax in [(400, 80, 0.0, 8000.0), (512, 40, 50.0, 7600.0)]:
        ref = mel_filter_bank(n_fft // 2 + 1, n_mels, fmin, fmax, 16000, norm=None, mel_scale="htk").T
        np.testing.assert_allclose(mel_filterbank(n_fft, n_mels, 16000, fmin, fmax), ref, atol=1e-12)


def test_logmel_tone_peaks_at_its_mel_band_and_is_gain_invariant():
    enc = LogMelEncoder()
    t = np.arange(16000) / 16000
    filters = mel_filterbank()
    for freq in (300.0, 1000.0, 3000.0):
        wav = torch.from_numpy(np.sin(2 * np.pi * freq * t).astype(np.float32))[None]
        feats = enc(wav, 60)
        assert feats.shape == (1, 60, 80)
        band = int(np.argmax(filters[:, round(freq / 40)]))  # 40 Hz per FFT bin
        assert abs(int(feats[0, 30].argmax()) - band) <= 1
        torch.testing.assert_close(enc(wav * 0.01, 60), feats, atol=1e-4, rtol=0)
        assert feats.min() >= -1 and feats.max() <= 1


def test_interpolation_of_a_ramp_is_exact():
    # features linear in time stay linear: centre-aligned resampling of t -> t
    t_in, t_out = 50, 60
    x = (torch.arange(t_in, dtype=torch.float64) + 0.5) / t_in
    out = interpolate_features(x[None, :, None], t_out)[0, :, 0]
    centres = (torch.arange(t_out, dtype=torch.float64) + 0.5) / t_out
    inner = (centres > 0.5 / t_in) & (centres < 1 - 0.5 / t_in)
    torch.testing.assert_close(out[inner], centres[inner])
    assert interpolate_features(x[None, :, None], t_in).shape == (1, t_in, 1)
    with pytest.raises(ValueError):
        interpolate_features(x[None], 10)


def test_tiny_wav2vec2_gives_one_feature_per_frame_and_is_frozen():
    enc = build_encoder({"kind": "wav2vec2-tiny", "seed": 0})
    assert not any(p.requires_grad for p in enc.parameters())
    wav = torch.randn(2, 16000)
    for frames in (60, 47, 75):
        assert enc(wav, frames).shape == (2, frames, 32)
    again = build_encoder({"kind": "wav2vec2-tiny", "seed": 0})
    torch.testing.assert_close(again(wav, 60), enc(wav, 60))


def test_wav2vec2_from_local_directory_round_trip(tmp_path):
    enc = build_encoder({"kind": "wav2vec2-tiny", "seed": 3})
    enc.model.save_pretrained(tmp_path)
    loaded = build_encoder({"kind": "wav2vec2", "path": str(tmp_path)})
    wav = torch.randn(1, 12000)
    torch.testing.assert_close(loaded(wav, 45), enc(wav, 45))
    with pytest.raises(ValueError, match="config.json"):
        build_encoder({"kind": "wav2vec2", "path": str(tmp_path / "missing")})


def test_unknown_encoder():
    with pytest.raises(ValueError, match="expected kind"):
        build_encoder({"kind": "mfcc"})
    with pytest.raises(TypeError):
        build_encoder("logmel")
