"""The learned lip-sync expert: features, SyncNet-style scoring, checkpoints, a short
training on the test build, the command line."""

import numpy as np
import pytest
import torch

from benchmark.lipsync import expert_sync_metrics, load_expert, save_expert
from benchmark.lipsync.expert import audio_features, build_expert, shift_distances
from benchmark.lipsync.expert_training import SyncItem, dataset_items, train_expert
from benchmark.lipsync.train_expert import main as train_main


def _speechlike(rng, seconds=2.0, rate=16000):
    """A 180 Hz buzz under an irregular syllable-like envelope, with a little noise."""
    from scipy.ndimage import gaussian_filter1d

    t = np.arange(int(seconds * rate)) / rate
    bursts = gaussian_filter1d(rng.exponential(size=int(seconds * 100)), 4.0)  # 100 Hz control rate
    envelope = np.interp(t, np.arange(len(bursts)) / 100, np.clip(bursts - bursts.mean(), 0, None))
    envelope /= envelope.max()
    return (envelope * np.sin(2 * np.pi * 180 * t) + 0.01 * rng.normal(size=t.size)).astype(np.float32)


def test_audio_features_ignore_loudness_and_follow_time():
    rng = np.random.default_rng(0)
    x = _speechlike(rng)
    feats = audio_features(x, num_frames=120)
    assert feats.shape == (120, 40) and feats.dtype == np.float32
    np.testing.assert_allclose(audio_features(0.25 * x, num_frames=120), feats, atol=1e-4)
    # Delaying the audio by 4 frames (1/15 s) delays the features by 4 frames.
    late = np.concatenate([np.zeros(4 * 16000 // 60, np.float32), x])[: len(x)]
    f_late = audio_features(late, num_frames=120)
    errors = [np.abs(f_late[20 + lag:100 + lag] - feats[20:100]).mean() for lag in range(-8, 9)]
    assert int(np.argmin(errors)) - 8 == 4


def test_shift_distances_find_a_known_shift():
    rng = np.random.default_rng(1)
    T, S, k = 50, 6, 3
    audio_emb = rng.normal(size=(T + 2 * S, 4))
    # motion frame t equals audio frame t - k: audio_emb index (t - k) + S
    motion_emb = audio_emb[S - k: S - k + T]
    d = shift_distances(motion_emb, audio_emb, S)
    assert d.shape == (2 * S + 1,)
    assert d[S + k] == 0.0 and np.all(np.delete(d, S + k) > 0.5)


def _items(rng, count=3, frames=150, lag=0):
    """Sentences whose coefficient 24 is the loudness of the audio, ``lag`` frames later."""
    out = []
    for i in range(count):
        audio = _speechlike(rng, frames / 60)
        env = np.sqrt(np.convolve(audio.astype(np.float64) ** 2, np.ones(400) / 400, mode="same"))
        coeffs = np.full((frames, 32), 0.1)
        idx = np.clip(np.round((np.arange(frames) - lag) * 16000 / 60).astype(int), 0, len(audio) - 1)
        coeffs[:, 24] = env[idx] / env.max()
        out.append(SyncItem(coeffs=coeffs, audio=audio, lag=lag, name=f"s/{i}"))
    return out


def test_checkpoint_round_trip_and_bad_files(tmp_path):
    torch.manual_seed(0)
    expert = build_expert({}, np.zeros(32), np.ones(32), [f"c{i}" for i in range(32)], {"data": "x"})
    path = tmp_path / "expert.pt"
    save_expert(expert, path)
    loaded = load_expert(path)
    item = _items(np.random.default_rng(2), count=1)[0]
    a, b = expert.sync(item.coeffs, item.audio), loaded.sync(item.coeffs, item.audio)
    assert a.offset == b.offset and a.confidence == pytest.approx(b.confidence, abs=1e-9)
    np.testing.assert_allclose(a.scores, b.scores, atol=1e-9)
    assert loaded.trained_on == {"data": "x"}
    assert a.confidence == pytest.approx(np.median(a.scores) - a.scores.min())
    assert a.offset == int(np.argmin(a.scores)) - loaded.max_shift
    other = tmp_path / "syncnet_v2.model"
    torch.save({"netcnnaud.0.weight": torch.zeros(1)}, other)
    with pytest.raises(ValueError, match="not a blendvoca-sync-expert checkpoint"):
        load_expert(other)
    with pytest.raises(ValueError, match=r"expected coeffs \(T, 32\)"):
        loaded.sync(np.zeros((10, 31)), item.audio)


def test_the_weights_digest_names_the_weights_not_the_file(tmp_path):
    import hashlib

    from benchmark.protocol import lipsync_models_provenance

    torch.manual_seed(0)
    names = [f"c{i}" for i in range(32)]
    expert = build_expert({}, np.zeros(32), np.ones(32), names, {"data": "/a", "seconds": 46.4})
    first, again = tmp_path / "a.pt", tmp_path / "b.pt"
    save_expert(expert, first)
    expert.trained_on = {"data": "/elsewhere", "seconds": 61.6}  # the same training, another place and time
    save_expert(expert, again)
    files = [hashlib.sha256(p.read_bytes()).hexdigest() for p in (first, again)]
    digests = [load_expert(p).weights_digest() for p in (first, again)]
    assert files[0] != files[1] and digests[0] == digests[1] == expert.weights_digest()
    record = lipsync_models_provenance(sync_expert=again)["sync_expert"]
    assert record["sha256"] == files[1] and record["weights_sha256"] == digests[0]
    with torch.no_grad():
        next(expert.net.parameters()).view(-1)[0] += 1e-6  # one weight moved: another expert
    assert expert.weights_digest() != digests[0]


@pytest.mark.slow
def test_short_training_learns_the_offset_sign():
    lag = 3  # the motion 3 frames after the sound
    rng = np.random.default_rng(3)
    items = _items(rng, count=4, lag=lag)
    expert = train_expert(items, max_steps=40, batch_size=16, seed=0)
    assert expert.trained_on["steps"] == 40
    held_out = _items(np.random.default_rng(4), count=2, lag=lag)
    for it in held_out:
        truth = expert.sync(it.coeffs, it.audio)
        assert abs(truth.offset - lag) <= 1
        later = np.concatenate([np.repeat(it.coeffs[:1], 6, axis=0), it.coeffs[:-6]])  # motion 6 frames later
        assert abs(expert.sync(later, it.audio).offset - (lag + 6)) <= 2


def test_metrics_score_every_sample(tmp_path):
    torch.manual_seed(0)
    expert = build_expert({}, np.zeros(32), np.ones(32), [f"c{i}" for i in range(32)], {"data": "d"})
    item = _items(np.random.default_rng(5), count=1)[0]
    generated = {("s", "a"): np.stack([item.coeffs, item.coeffs[::-1]])}
    out = expert_sync_metrics(generated, {("s", "a"): (item.audio, 16000)}, expert)
    assert out["av_offset_expert"].shape == (2,) and np.all(out["av_offset_expert"] >= 0)
    assert out["keys"] == [("s", "a", 0), ("s", "a", 1)] and out["trained_on"] == {"data": "d"}
    assert out["av_offset_expert"][0] == abs(expert.sync(item.coeffs, item.audio).offset)
    with pytest.raises(ValueError, match="no audio for s/a"):
        expert_sync_metrics(generated, {}, expert)


def test_command_line_trains_on_the_build(built_dataset, tmp_path, capsys):
    out = tmp_path / "expert.pt"
    assert train_main(["--data", str(built_dataset), "--out", str(out), "--max-steps", "3", "--quiet"]) == 0
    expert = load_expert(out)
    assert expert.trained_on["split"] == "train" and expert.trained_on["steps"] == 3
    assert expert.trained_on["subjects"] == ["Synth_000_TA", "Synth_001_TA", "Synth_002_TA", "Synth_003_TA"]
    assert "saved" in capsys.readouterr().out
    assert train_main(["--data", str(built_dataset), "--out", str(out), "--max-steps", "3"]) == 2
    assert "exists" in capsys.readouterr().err
    assert train_main(["--data", str(tmp_path / "nothing"), "--out", str(tmp_path / "x.pt")]) == 2
    assert capsys.readouterr().err.startswith("error: ")


def test_dataset_items_carry_the_true_lags(built_dataset):
    from benchmark.data import open_blendvoca

    dataset = open_blendvoca(built_dataset)
    items = dataset_items(dataset, "val")
    meta = dataset.corpus.synthetic
    for it in items:
        subject, sentence = it.name.split("/")
        assert it.lag == meta["subjects"][subject]["sentences"][sentence]["lag_frames"]
        assert it.coeffs.shape[1] == 32 and it.audio.dtype == np.float32


def test_cached_expert_trains_once_per_build(built_dataset, tmp_path):
    from benchmark.lipsync.expert_training import cached_expert

    expert, path = cached_expert(built_dataset, max_steps=2, cache_dir=tmp_path)
    assert path.is_file() and path.parent == tmp_path / "sync-expert"
    stamp = path.stat().st_mtime_ns
    again, same = cached_expert(built_dataset, max_steps=2, cache_dir=tmp_path)
    assert same == path and path.stat().st_mtime_ns == stamp
    assert again.trained_on == expert.trained_on and again.trained_on["steps"] == 2


def test_per_utterance_motion_ignores_a_captures_scale_and_rest_pose():
    torch.manual_seed(0)
    expert = build_expert({"motion_norm": "utterance"}, np.zeros(32), np.full(32, 0.01), [f"c{i}" for i in range(32)])
    item = _items(np.random.default_rng(6), count=1)[0]
    feats = expert.motion_features(item.coeffs)
    np.testing.assert_allclose(feats.mean(axis=0), 0.0, atol=1e-6)
    assert np.sqrt((feats.astype(np.float64) ** 2).mean(axis=0).sum() / 32) == pytest.approx(1.0, rel=1e-5)
    # the same motion five times larger on a rig resting elsewhere: the same input and the same estimate
    other = 5.0 * item.coeffs + 0.2
    np.testing.assert_allclose(expert.motion_features(other), feats, atol=1e-5)
    a, b = expert.sync(item.coeffs, item.audio), expert.sync(other, item.audio)
    assert a.offset == b.offset and a.confidence == pytest.approx(b.confidence, abs=1e-5)
    assert np.abs(expert.motion_features(np.full((20, 32), 0.3))).max() < 1e-9  # a still track stays still
    # the original recipe keeps its config (and so its experts' weights digests) as it was
    original = build_expert({"motion_norm": "training"}, np.zeros(32), np.ones(32), ["c"] * 32)
    assert "motion_norm" not in original.config and expert.config["motion_norm"] == "utterance"
    with pytest.raises(ValueError, match="motion_norm must be 'training' or 'utterance'"):
        build_expert({"motion_norm": "clip"}, np.zeros(32), np.ones(32), ["c"] * 32)
