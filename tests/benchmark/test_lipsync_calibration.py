"""The calibration of the lip-sync estimators by audio shifts: the shift itself, the
figures on known answers, the command line on a synthetic build and on an SMPL-X take,
and bad input."""

import json

import numpy as np
import pytest

from benchmark.lipsync.calibrate import main as calibrate_main
from benchmark.lipsync.calibration import Calibration, Utterance, calibrate, checked_shifts, shifted_audio
from benchmark.lipsync.geometric import geometric_sync
from blendvoca.errors import UserError


def test_shifted_audio_delays_and_advances_by_whole_frames():
    x = np.arange(1, 16001, dtype=np.float32)  # 1 s at 16 kHz; 1 frame at 60 fps = 266.67 samples
    late = shifted_audio(x, 3, 16000, 60.0)    # 800 samples later
    assert late.shape == x.shape and late.dtype == x.dtype
    assert np.all(late[:800] == 0) and np.array_equal(late[800:], x[:-800])
    early = shifted_audio(x, -3)
    assert np.array_equal(early[:-800], x[800:]) and np.all(early[-800:] == 0)
    assert np.array_equal(shifted_audio(x, 0), x)
    with pytest.raises(UserError, match="not shorter than the audio"):
        shifted_audio(x[:100], 1)


def test_the_figures_on_known_estimates():
    # utterance 0 moves exactly, utterance 1 is one frame off on +4, utterance 2 stays put
    shifts = (0, 4, -4)
    offsets = {"geometric": np.array([[2, -2, 6], [0, -3, 4], [5, 5, 5]]),
               "expert": np.array([[3, -1, 7], [9, 5, 13], [5, 1, 9]])}
    conf = {k: np.array([[0.5, 0.4, 0.4]] * 3) for k in offsets}
    cal = Calibration(shifts=shifts, names=("a", "b", "c"), offsets=offsets, confidences=conf)
    assert cal.within("geometric") == pytest.approx(4 / 6)
    assert cal.within_by_shift("geometric") == {4: pytest.approx(2 / 3), -4: pytest.approx(2 / 3)}
    assert cal.within("expert") == 1.0
    assert cal.agreement("expert") == pytest.approx(2 / 3)  # 3 vs 2, 9 vs 0, 5 vs 5
    summary = cal.summary()
    assert summary["estimators"]["geometric"]["exact"] == pytest.approx(3 / 6)
    assert summary["estimators"]["expert"]["confidence_true"] == pytest.approx(0.5)
    assert summary["estimators"]["expert"]["confidence_shifted"] == pytest.approx(0.4)
    assert summary["estimators"]["geometric"]["unshifted"]["median"] == 2.0
    # SyncNet counts 25 fps frames: a 12-frame shift at 60 fps is 5 of its frames
    sn = Calibration(shifts=(0, 12), names=("a",), offsets={"syncnet": np.array([[1, -4]])},
                     confidences={"syncnet": np.zeros((1, 2))}, frames_per_shift={"syncnet": 25 / 60})
    assert sn.within("syncnet") == 1.0


def _envelope_follower(rng, lag, frames=360):
    """Speech-like audio and an activity that follows its envelope ``lag`` frames later."""
    from benchmark.lipsync.envelope import speech_envelope
    from scipy.ndimage import gaussian_filter1d

    t = np.arange(frames * 16000 // 60) / 16000
    bursts = gaussian_filter1d(rng.exponential(size=frames), 3.0)
    amp = np.interp(t, np.arange(frames) / 60, np.clip(bursts - bursts.mean(), 0, None))
    audio = (amp * np.sin(2 * np.pi * 160 * t) + 1e-3 * rng.normal(size=t.size)).astype(np.float32)
    env = speech_envelope(audio, 16000, 60.0, frames)
    activity = np.concatenate([np.full(lag, env[0]), env[:frames - lag]]) if lag >= 0 else \
        np.concatenate([env[-lag:], np.full(-lag, env[-1])])
    return audio, activity


def test_an_exact_estimator_moves_by_every_shift_from_its_own_offset():
    rng = np.random.default_rng(0)
    utts = []
    for i, lag in enumerate((3, -2, 0)):  # each capture its own offset
        audio, activity = _envelope_follower(rng, lag)
        utts.append(Utterance(f"u{i}", audio, 16000, {"geometric": activity}))
    cal = calibrate(utts, {"geometric": lambda a, x, r: geometric_sync(a, x, r, visibility=0.0)},
                    shifts=(0, 1, -1, 4, -4, 8, -8))
    assert list(cal.unshifted("geometric")) == [3, -2, 0]
    assert cal.within("geometric") == 1.0
    np.testing.assert_array_equal(cal.offsets["geometric"][0], [3, 2, 4, -1, 7, -5, 11])
    with pytest.raises(UserError, match="no utterances"):
        calibrate([], {"geometric": geometric_sync})


@pytest.mark.parametrize("bad, match", [((1, 2), "expected 0"), ((0,), "expected 0"), ((0, 1, 1), "each shift once"),
                                        ((0, 1.5), "whole frames"), (("a", 0), "expected integers")])
def test_bad_shift_lists(bad, match):
    with pytest.raises(UserError, match=match):
        checked_shifts(bad)


def test_the_command_line_on_a_synthetic_build(built_dataset, tmp_path, capsys):
    """The geometric estimator is exact on synthetic shifts: every utterance-shift moves by
    the shift, and the unshifted estimate is the corpus's true lag."""
    from benchmark.data import open_blendvoca

    out = tmp_path / "cal.json"
    assert calibrate_main(["--data", str(built_dataset), "--split", "test", "--shifts", "0,2,-2,8,-8",
                           "--out", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "| moved by the shift within 1 frame" in printed and "| geometric |" in printed
    result = json.loads(out.read_text())
    geo = result["estimators"]["geometric"]
    assert result["shifts"] == [0, 2, -2, 8, -8] and result["utterances"] == 2
    assert geo["within_1"] == 1.0 and geo["exact"] == 1.0
    meta = open_blendvoca(built_dataset).corpus.synthetic
    for row in result["per_utterance"]:
        subject, sentence = row["name"].split("/")
        assert row["geometric"][0] == meta["subjects"][subject]["sentences"][sentence]["lag_frames"]
        assert row["geometric"][1:] == [row["geometric"][0] - s for s in (2, -2, 8, -8)]
    md = tmp_path / "cal.md"
    assert calibrate_main(["--data", str(built_dataset), "--shifts", "0,1", "--out", str(md), "--quiet"]) == 0
    assert md.read_text().startswith("**") and "100.0%" in md.read_text()


def test_the_command_line_with_an_expert(built_dataset, tmp_path, capsys):
    from benchmark.lipsync.train_expert import main as train_main

    expert = tmp_path / "e.pt"
    assert train_main(["--data", str(built_dataset), "--out", str(expert), "--max-steps", "2", "--quiet"]) == 0
    out = tmp_path / "cal.json"
    assert calibrate_main(["--data", str(built_dataset), "--sync-expert", str(expert), "--shifts", "0,4",
                           "--out", str(out), "--quiet"]) == 0
    result = json.loads(out.read_text())
    assert set(result["estimators"]) == {"geometric", "expert"}
    assert 0.0 <= result["estimators"]["expert"]["agrees_with_geometric"] <= 1.0
    assert "learned expert" in capsys.readouterr().out


def _smplx_take(path, rng, lag, fps=30):
    """An SMPL-X archive whose jaw opens with the speech envelope ``lag`` frames (60 fps) later."""
    from blendvoca.io.audio import write_wav

    audio, activity = _envelope_follower(rng, lag, frames=900)
    act = activity - activity.min()
    angle = 0.3 * act / act.max()
    poses = np.zeros((len(angle) * fps // 60, 165))
    poses[:, 66] = angle[:: 60 // fps][: len(poses)]
    np.savez(path, poses=poses, mocap_frame_rate=np.array(fps), expressions=np.zeros((len(poses), 100)))
    write_wav(path.with_suffix(".wav"), audio, 16000)


def test_the_command_line_on_an_smplx_take(tmp_path, capsys):
    npz = tmp_path / "take.npz"
    _smplx_take(npz, np.random.default_rng(1), lag=4, fps=60)
    out = tmp_path / "b.json"
    assert calibrate_main(["--beat2", str(npz), "--window", "5", "--out", str(out), "--quiet"]) == 0
    result = json.loads(out.read_text())
    geo = result["estimators"]["geometric"]
    assert result["utterances"] == 3 and geo["within_1"] == 1.0
    assert geo["unshifted"]["min"] == geo["unshifted"]["max"] == 4
    # by default the take is cut as the builds cut long takes: 2-10 s utterances covering it
    assert calibrate_main(["--beat2", str(npz), "--out", str(out), "--quiet"]) == 0
    result = json.loads(out.read_text())
    spans = [tuple(float(t) for t in row["name"].split("/")[1].rstrip("s").split("-")) for row in result["per_utterance"]]
    assert spans[0][0] == 0 and spans[-1][1] == pytest.approx(15.0, abs=0.05)
    assert all(2 <= b - a <= 10 for a, b in spans) and all(p[1] == q[0] for p, q in zip(spans, spans[1:]))
    assert result["estimators"]["geometric"]["within_1"] == 1.0


@pytest.mark.parametrize("args, message", [
    (["--shifts", "1,2"], "--shifts 1,2: expected 0"),
    (["--shifts", "0,a"], "--shifts: expected comma-separated whole frames"),
    (["--split", "nosuch"], "--split: the build has no split 'nosuch'"),
])
def test_bad_command_lines(built_dataset, capsys, args, message):
    assert calibrate_main(["--data", str(built_dataset), *args, "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and message in err and err.count("\n") == 1


def test_bad_inputs_name_what_was_expected(tmp_path, capsys):
    assert calibrate_main(["--quiet"]) == 2
    assert "give --data BUILD or --beat2 NPZ" in capsys.readouterr().err
    assert calibrate_main(["--data", str(tmp_path / "none"), "--quiet"]) == 2
    assert "no such folder" in capsys.readouterr().err
    npz = tmp_path / "t.npz"
    np.savez(npz, expressions=np.zeros((10, 100)))
    assert calibrate_main(["--beat2", str(npz), "--quiet"]) == 2
    assert "expected the take's speech" in capsys.readouterr().err
    from blendvoca.io.audio import write_wav

    write_wav(npz.with_suffix(".wav"), np.zeros(16000, np.float32), 16000)
    assert calibrate_main(["--beat2", str(npz), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert str(npz) in err and "'poses'" in err
    short = tmp_path / "short.npz"
    _smplx_take(short, np.random.default_rng(2), lag=0)
    assert calibrate_main(["--beat2", str(short), "--window", "60", "--quiet"]) == 2
    assert "shorter than one 60 s window" in capsys.readouterr().err
    assert not list(tmp_path.glob("*.json")) and not list(tmp_path.glob("*.md"))


def test_an_empty_split_is_refused():
    from benchmark.lipsync.calibrate import build_utterances

    class Empty:
        root, names, splits = "B", (), {"test": []}

        def split(self, name):
            return self.splits[name]

    with pytest.raises(UserError, match="--split test: no utterances"):
        build_utterances(Empty(), "test")
