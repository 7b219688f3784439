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


def test_the_sound_of_a_video_decodes_from_the_video_s_first_frame(tmp_path):
    from blendvoca.io.audio import read_media_audio
    from tests.datasets.livelink_fixtures import write_mov

    rate = 48000
    t = np.arange(2 * rate) / rate
    tone = (0.5 * np.sin(2 * np.pi * 440 * t) * (t >= 0.5)).astype(np.float32)  # silent, then a tone at 0.5 s
    for name, start in (("a.mov", 0.0), ("late.mp4", 0.25)):
        write_mov(tmp_path / name, 2.5, samples=tone, rate=rate, sound_start=start)
        samples, native = read_media_audio(tmp_path / name)
        assert native == rate and samples.shape[1] == 1
        onset = np.argmax(np.abs(samples[:, 0]) > 0.1) / rate
        assert onset == pytest.approx(0.5 + start, abs=2e-3)  # AAC's priming samples are cut by their time stamps
        audio = load_audio(tmp_path / name)
        spectrum = np.abs(np.fft.rfft(audio[int((0.6 + start) * 16000):int((1.6 + start) * 16000)]))
        assert abs(np.argmax(spectrum) - 440) <= 1


def test_a_video_without_sound_or_without_pyav_is_one_clear_error(tmp_path, monkeypatch):
    import sys

    from blendvoca.errors import UserError
    from blendvoca.io.audio import AudioFormatError
    from tests.datasets.livelink_fixtures import write_mov

    write_mov(tmp_path / "mute.mov", 1.0, sound=False)
    with pytest.raises(AudioFormatError, match=r"mute\.mov: no audio stream \(streams: video \(mpeg4\)\)"):
        load_audio(tmp_path / "mute.mov")
    (tmp_path / "junk.mp4").write_bytes(b"\x00\x00\x00\x18ftypjunk" * 4)
    with pytest.raises(AudioFormatError, match=r"junk\.mp4: not a readable video or audio file"):
        load_audio(tmp_path / "junk.mp4")
    monkeypatch.setitem(sys.modules, "av", None)
    with pytest.raises(UserError, match=r"needs PyAV: pip install av"):
        load_audio(tmp_path / "mute.mov")
