import numpy as np
import pytest

from blendvoca.io.audio import load_audio, read_wav, write_wav


@pytest.mark.parametrize(
    "asset,rate,channels",
    [("voca/test_sentence.wav", 22000, 1), ("faceformer/test.wav", 44100, 1), ("codetalker/man.wav", 44100, 2)],
)
def test_real_clips_load_as_16k_mono(assets_dir, asset, rate, channels):
    raw, native = read_wav(assets_dir / asset)
    assert native == rate
    assert (raw.ndim == 1) == (channels == 1)
    audio = load_audio(assets_dir / asset)
    assert audio.dtype == np.float32 and audio.ndim == 1
    assert abs(len(audio) - len(raw) * 16000 / rate) <= 1
    assert 0.01 < np.abs(audio).max() <= 1.0


def test_resampled_tone_keeps_its_frequency(tmp_path):
    rate = 44100
    t = np.arange(rate) / rate
    stereo = np.stack([0.5 * np.sin(2 * np.pi * 440 * t)] * 2, axis=1)
    write_wav(tmp_path / "tone.wav", stereo, rate)
    audio = load_audio(tmp_path / "tone.wav")
    assert len(audio) == 16000
    spectrum = np.abs(np.fft.rfft(audio))
    assert abs(np.argmax(spectrum) - 440) <= 1  # 1 Hz bins for a 1 s clip
    assert np.isclose(np.abs(audio[100:-100]).max(), 0.5, atol=0.01)


def test_missing_and_garbage_files(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_audio(tmp_path / "none.wav")
    (tmp_path / "bad.wav").write_bytes(b"RIFF....garbage")
    with pytest.raises(ValueError, match="bad.wav"):
        load_audio(tmp_path / "bad.wav")
