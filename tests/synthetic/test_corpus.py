"""The generated corpus: layout, sidecar, lip sync at the true lag, determinism, CLI, cache."""

import json

import numpy as np
import pytest

from blendvoca.synthetic import default_corpus, generate_corpus, read_npz
from blendvoca.synthetic import corpus as corpus_module
from blendvoca.synthetic.__main__ import main
from blendvoca.vocaset import open_vocaset


def _normalised_xcorr(x, y, lag):
    """Correlation of x[t] with y[t + lag]."""
    if lag > 0:
        x, y = x[:-lag], y[lag:]
    elif lag < 0:
        x, y = x[-lag:], y[:lag]
    x, y = x - x.mean(), y - y.mean()
    return float(np.dot(x, y) / (np.linalg.norm(x) * np.linalg.norm(y) + 1e-12))


def _rms_60fps(samples, rate, num_frames):
    edges = np.round(np.arange(num_frames + 1) * rate / 60).astype(int)
    return np.array([np.sqrt(np.mean(samples[a:b] ** 2)) for a, b in zip(edges[:-1], edges[1:])])


def test_sidecar_describes_the_corpus(synthetic_corpus):
    meta = json.loads((synthetic_corpus / "synthetic.json").read_text())
    corpus = open_vocaset(synthetic_corpus)
    assert meta["seed"] == 0 and meta["fps"] == 60 and set(meta["splits"]) == {"train", "val", "test"}
    for subject in corpus.subjects:
        for sentence in corpus.sentences(subject):
            info = meta["subjects"][subject]["sentences"][sentence]
            assert abs(info["lag_frames"]) <= meta["max_lag_frames"]
            assert 1.5 <= info["duration"] <= 2.0
            gt = read_npz(synthetic_corpus / "groundtruth" / subject / f"{sentence}.npz")
            assert int(gt["lag_frames"]) == info["lag_frames"]
            assert len(gt["jaw"]) == info["num_frames"] == len(corpus.frames(subject, sentence))


def _lag_errors(root, assets_dir):
    """Per sentence: the lag (frames) that best aligns the mouth opening with the audio RMS and with
    the sidecar's envelope, minus the true lag; and the correlation at the true lag."""
    from blendvoca.io.mesh import read_index_list

    lm = read_index_list(assets_dir / "said" / "FLAME_landmarks.txt")
    corpus = open_vocaset(root)
    meta = corpus.synthetic
    found, at_true, from_sidecar = [], [], []
    for subject, sentence in corpus.items():
        frames = corpus.frames(subject, sentence)
        samples, rate = corpus.audio(subject, sentence)
        true_lag = meta["subjects"][subject]["sentences"][sentence]["lag_frames"]
        # Mouth opening measured on the mesh: lower-lip-to-upper-lip plus chin drop.
        opening = np.linalg.norm(frames[:, lm[57]] - frames[:, lm[51]], axis=1)
        envelope = _rms_60fps(samples, rate, len(frames))
        lags = list(range(-8, 9))
        scores = [_normalised_xcorr(envelope, opening, k) for k in lags]
        found.append(lags[int(np.argmax(scores))] - true_lag)
        at_true.append(_normalised_xcorr(envelope, opening, true_lag))
        # Against the sidecar's syllable envelope (audio timeline) too.
        gt = read_npz(root / "groundtruth" / subject / f"{sentence}.npz")
        exact = [_normalised_xcorr(gt["envelope"], opening, k) for k in lags]
        from_sidecar.append(lags[int(np.argmax(exact))] - true_lag)
    print("lag error (frames), audio RMS:", found, "sidecar envelope:", from_sidecar, "corr:", np.round(at_true, 2))
    return np.array(found), np.array(from_sidecar), np.array(at_true)


def test_lip_motion_follows_the_audio_at_the_true_lag(tmp_path, assets_dir):
    # Without undetermined components (F = 1) the motion is the audio's plan at the true lag, exactly.
    root = generate_corpus(tmp_path / "f1", speakers=6, sentences=2, seed=0, duration=(1.5, 2.0),
                           audio_determined=1.0)
    found, from_sidecar, at_true = _lag_errors(root, assets_dir)
    assert np.median(at_true) > 0.6
    assert np.all(np.abs(found) <= 2) and np.median(np.abs(found)) <= 1
    assert np.all(np.abs(from_sidecar) <= 1) and np.median(np.abs(from_sidecar)) == 0


def test_lip_motion_follows_the_audio_at_the_default_f(synthetic_corpus, assets_dir):
    # The undetermined components (onset jitter, intensity, pause gestures) blur it by a frame.
    found, from_sidecar, at_true = _lag_errors(synthetic_corpus, assets_dir)
    assert np.median(at_true) > 0.5
    assert np.all(np.abs(found) <= 3) and np.median(np.abs(found)) <= 1.5
    assert np.all(np.abs(from_sidecar) <= 2) and np.median(np.abs(from_sidecar)) <= 1


def test_generation_is_byte_identical_for_a_seed(tmp_path):
    kwargs = dict(speakers=3, sentences=1, seed=7, duration=(1.0, 1.2))
    a = generate_corpus(tmp_path / "a", **kwargs)
    b = generate_corpus(tmp_path / "b", **kwargs)
    files_a = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    files_b = sorted(p.relative_to(b) for p in b.rglob("*") if p.is_file())
    assert files_a == files_b and len(files_a) > 10
    assert all((a / f).read_bytes() == (b / f).read_bytes() for f in files_a)
    c = generate_corpus(tmp_path / "c", **dict(kwargs, seed=8))
    assert (c / "audio/Synth_000_TA/sentence01.wav").read_bytes() != (a / "audio/Synth_000_TA/sentence01.wav").read_bytes()


def test_processed_generation_is_byte_identical_too(tmp_path):
    kwargs = dict(speakers=3, sentences=1, seed=7, duration=(1.0, 1.2), layout="processed")
    a, b = generate_corpus(tmp_path / "a", **kwargs), generate_corpus(tmp_path / "b", **kwargs)
    for name in ("data_verts.npy", "subj_seq_to_idx.pkl", "raw_audio_fixed.pkl", "templates.pkl", "synthetic.json"):
        assert (a / name).read_bytes() == (b / name).read_bytes()


def test_speakers_differ_plausibly(synthetic_corpus):
    corpus = open_vocaset(synthetic_corpus)
    t = np.stack([corpus.template(s) for s in corpus.subjects])
    diff = np.linalg.norm(t[:, None] - t[None], axis=3).mean(axis=2)[np.triu_indices(len(t), 1)]
    assert np.all(diff > 0.002) and np.all(diff < 0.03)  # a few millimetres to centimetres


def test_cli_and_bad_arguments(tmp_path, capsys):
    out = tmp_path / "cli"
    assert main(["--out", str(out), "--speakers", "3", "--sentences", "1", "--seed", "1",
                 "--min-duration", "1", "--max-duration", "1.1", "--quiet"]) == 0
    assert open_vocaset(out).subjects == ["Synth_000_TA", "Synth_001_TA", "Synth_002_TA"]
    assert main(["--out", str(out), "--speakers", "3", "--sentences", "1", "--quiet"]) == 2
    assert "exists" in capsys.readouterr().err
    with pytest.raises(ValueError, match="speakers must be"):
        generate_corpus(tmp_path / "x", speakers=2)
    with pytest.raises(ValueError, match="layout"):
        generate_corpus(tmp_path / "y", speakers=3, sentences=1, duration=(1, 1), layout="nope")
    assert not (tmp_path / "y").exists()  # nothing half-written is left behind


def test_default_corpus_is_generated_once_into_the_cache(tmp_path, monkeypatch):
    monkeypatch.setattr(corpus_module, "DEFAULT_CORPUS", dict(speakers=3, sentences=1, seed=0, duration=(1.0, 1.0)))
    root = default_corpus(tmp_path)
    assert root.parent == tmp_path and (root / "synthetic.json").is_file()
    stamp = (root / "synthetic.json").stat().st_mtime_ns
    assert default_corpus(tmp_path) == root
    assert (root / "synthetic.json").stat().st_mtime_ns == stamp
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temp folders left


@pytest.mark.slow
def test_bundled_default_corpus(tmp_path):
    root = default_corpus(tmp_path)
    corpus = open_vocaset(root)
    assert len(corpus.subjects) == 6 and all(len(corpus.sentences(s)) == 4 for s in corpus.subjects)
    assert corpus.splits["test"] == ["Synth_005_TA"] and corpus.scan() == []
