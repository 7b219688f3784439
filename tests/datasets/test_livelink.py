"""``--dataset livelink``: folders of Live Link Face takes (CSV + WAV, CSV + video, the app's
folder per take) built into BlendVOCA folders at 60 fps with the takes' head pose; bad
takes fail alone, naming the file and what was expected."""

from __future__ import annotations

import json
import re
import warnings

import numpy as np
import pytest

from blendvoca import format as fmt
from blendvoca.builder.__main__ import main as build_main
from blendvoca.datasets import DATASETS, adapter
from blendvoca.names import ARKIT_FACE_ORDER, LIVELINK_HEADER
from tests.datasets.livelink_fixtures import NTSC_60, RESAMPLING_ERROR, clock_take, pose_at, weights_at, write_mov, write_sound


def _build(root, out):
    return adapter("livelink")(root, out)


def _check_track(out, subject, sentence, seconds):
    """The built track and pose against the take's motion at 60 fps, within linear interpolation's error."""
    coeffs, names = fmt.read_coeffs(out, subject, sentence)
    assert names == ARKIT_FACE_ORDER
    frames = len(coeffs)
    assert abs(frames - seconds * 60) <= 1
    t = np.arange(frames) / 60.0
    inside = t <= t[-1] - 1 / 60  # the last frame may hold the take's last row
    np.testing.assert_allclose(coeffs[inside], weights_at(t[inside]), atol=RESAMPLING_ERROR)
    pose = fmt.read_pose(out, subject, sentence)
    assert pose.shape == (frames, 9)
    np.testing.assert_allclose(pose[inside], pose_at(t[inside]), atol=RESAMPLING_ERROR)


def test_the_three_layouts_build_at_60_fps_with_the_head_pose(tmp_path):
    root = tmp_path / "alice"
    clock_take(root / "wav_take.csv", 2.5)
    write_sound(root / "wav_take.wav", 2.5)
    clock_take(root / "mov_take.csv", 2.0, spelling="BlendshapeCount")
    write_mov(root / "mov_take.mov", 2.0)
    app = root / "20240531_MySlate_3"
    clock_take(app / "MySlate_3_iPhone_raw.csv", 3.0, fps=60.0)
    (app / "MySlate_3_iPhone_cal.csv").write_text("not read: the _raw file is\n")
    (app / "MySlate_3_iPhone_neutral.csv").write_text("not a take\n")
    (app / "take.json").write_text('{"slate": "MySlate", "take": 3, "subject": "iPhone"}')
    write_mov(app / "MySlate_3_iPhone.mov", 3.0)
    summary = _build(root, tmp_path / "out")
    assert summary.failures == [] and summary.built == {"speakers": 3, "sentences": 3}
    manifest = fmt.read_manifest(tmp_path / "out")
    sources = manifest["dataset"]["sources"]
    app_take = "20240531_MySlate_3_MySlate_3_iPhone"  # a subject per take, named after its path
    assert sources == {f"{app_take}/sentence01": "20240531_MySlate_3/MySlate_3_iPhone_raw.csv",
                       "mov_take/sentence01": "mov_take.csv", "wav_take/sentence01": "wav_take.csv"}
    for subject, seconds in ((app_take, 3.0), ("mov_take", 2.0), ("wav_take", 2.5)):
        _check_track(tmp_path / "out", subject, "sentence01", seconds)
        assert fmt.pose_relpath(subject, "sentence01") in manifest["files"]
        audio, rate = fmt.read_audio(tmp_path / "out", subject, "sentence01")
        assert rate == 16000 and abs(len(audio) / rate - seconds) < 0.02
    splits = fmt.read_splits(tmp_path / "out")  # by take: no take in two splits
    assert sorted(sum(splits.values(), [])) == sorted([app_take, "mov_take", "wav_take"])
    assert all(len(v) == 1 for v in splits.values())


def test_one_take_alone_is_a_corpus_in_the_test_split(tmp_path):
    clock_take(tmp_path / "solo" / "take.csv", 1.5)
    write_sound(tmp_path / "solo" / "take.wav", 1.5)
    summary = _build(tmp_path / "solo", tmp_path / "out")
    assert summary.built == {"speakers": 1, "sentences": 1}
    assert fmt.read_splits(tmp_path / "out")["test"] == ["take"]
    assert any("all are in the test split" in w["message"] for w in summary.warnings)
    assert "livelink" in DATASETS


def _write_bad_takes(root):
    """Takes of every kind of bad input, each beside a good take; returns {take: what its failure must say}."""
    clock_take(root / "good.csv", 2.0)
    write_sound(root / "good.wav", 2.0)
    header = list(LIVELINK_HEADER)
    cases = {}
    clock_take(root / "nojaw.csv", 2.0, header=[c if c != "JawOpen" else "Jaw" for c in header])
    cases["nojaw"] = r"nojaw\.csv: missing ARKit shape columns \['jawOpen'\]"
    clock_take(root / "twice.csv", 2.0, header=[c if c != "MouthClose" else "JAWOPEN" for c in header])
    cases["twice"] = r"twice\.csv: columns repeated in the header .*\['jawOpen'\]"
    codes = [f"00:00:{1 + i // 60:02d}:{i % 60:02d}.000" for i in range(120)]
    codes[30], codes[31] = codes[31], codes[30]
    clock_take(root / "backwards.csv", 2.0, fps=60.0, timecodes=codes)
    cases["backwards"] = r"backwards\.csv: row 33 \(frame 31\): timecode .* does not come after"
    codes = [f"00:00:{1 + i // 60:02d}:{i % 60:02d}.000" for i in range(120)]
    codes[5] = "5 past noon"
    clock_take(root / "garbled.csv", 2.0, fps=60.0, timecodes=codes)
    cases["garbled"] = r"garbled\.csv: row 7 \(frame 5\): not a Live Link timecode: '5 past noon'"
    for name in ("nojaw", "twice", "backwards", "garbled"):
        write_sound(root / f"{name}.wav", 2.0)
    clock_take(root / "silent.csv", 2.0)
    cases["silent"] = r"silent\.csv: no sound for the take; expected silent\.wav, silent\.mov, silent\.mp4"
    clock_take(root / "mute.csv", 2.0)
    write_mov(root / "mute.mov", 2.0, sound=False)
    cases["mute"] = r"mute\.mov: no audio stream \(streams: video \(mpeg4\)\); expected the take's speech"
    clock_take(root / "clipped.csv", 2.0)
    write_sound(root / "clipped.wav", 1.8)
    cases["clipped"] = r"clipped\.csv: audio 1\.80 s and motion 2\.00 s differ by more than 5%"
    clock_take(root / "padded.csv", 2.0)
    write_sound(root / "padded.wav", 2.2)
    cases["padded"] = r"padded\.csv: audio 2\.20 s and motion 2\.00 s differ by more than 5%"
    clock_take(root / "brief.csv", 0.6, start=10.5)
    write_sound(root / "brief.wav", 0.6)
    cases["brief"] = r"brief\.csv: a take of 0\.60 s .* is too short; expected at least 1 s of motion"
    return cases


def test_bad_takes_fail_alone_naming_the_file_and_nothing_of_them_is_written(tmp_path):
    cases = _write_bad_takes(tmp_path / "bad")
    summary = _build(tmp_path / "bad", tmp_path / "out")
    assert summary.built["sentences"] == 1
    reasons = {f["reason"].split(":")[0].rsplit(".", 1)[0]: f["reason"] for f in summary.failures}
    assert set(reasons) == set(cases)
    for name, pattern in cases.items():
        assert re.search(pattern, reasons[name]), (name, reasons[name])
    listed = fmt.listed_files(tmp_path / "out")
    built = sorted(rel for rel in listed if rel.startswith((fmt.COEFFS_DIR, fmt.AUDIO_DIR, fmt.POSE_DIR)))
    sentence = [s for s, src in fmt.read_manifest(tmp_path / "out")["dataset"]["sources"].items()][0].split("/")[1]
    assert built == [fmt.audio_relpath("good", sentence), fmt.coeffs_relpath("good", sentence),
                     fmt.pose_relpath("good", sentence)]  # a subject per take: the good take alone
    assert fmt.read_splits(tmp_path / "out") == {"train": [], "val": [], "test": ["good"]}  # split what was built
    on_disk = sorted(p.relative_to(tmp_path / "out").as_posix() for d in (fmt.COEFFS_DIR, fmt.AUDIO_DIR, fmt.POSE_DIR)
                     for p in (tmp_path / "out" / d).rglob("*") if p.is_file())
    assert on_disk == built
    report = (tmp_path / "out" / "report" / "README.md").read_text()
    assert "## Failed" in report and "no sound for the take" in report


def test_command_line_builds_a_two_take_folder_the_benchmark_scores(tmp_path, capsys):
    from benchmark.run import main as run_main

    for k, seconds in enumerate((3.0, 3.5)):  # a take of 2 s or less has no 2 s window for the latent metrics
        clock_take(tmp_path / "takes" / f"take{k}.csv", seconds)
        write_sound(tmp_path / "takes" / f"take{k}.wav", seconds)
    assert build_main(["--dataset", "livelink", "--root", str(tmp_path / "takes"), "--out", str(tmp_path / "out"),
                       "--quiet"]) == 0
    assert "sentences built 2" in capsys.readouterr().out
    with pytest.warns(UserWarning, match="source meshes cannot be read"):
        rc = run_main(["--method", "ground-truth", "--data", str(tmp_path / "out"), "--results",
                       str(tmp_path / "results"), "--quiet"])
    assert rc == 0, capsys.readouterr().err
    (path,) = (tmp_path / "results").glob("*.json")
    result = json.loads(path.read_text())
    assert result["metrics"]["av_offset_signed_geometric"]["n"] == 2
    assert {(p["subject"], p["sentence"]) for p in result["per_sentence"]} == {("take0", "sentence01"),
                                                                               ("take1", "sentence01")}


def test_command_line_error_lines(tmp_path, capsys):
    (tmp_path / "zips").mkdir()
    (tmp_path / "zips" / "LiveLinkFace_20240531_MySlate_3_iPhone.zip").write_bytes(b"PK")
    clock_take(tmp_path / "allbad" / "silent.csv", 2.0)
    cases = [(tmp_path / "zips", "no Live Link Face take found; expected <root>/<take>.csv"),
             (tmp_path / "zips", "unzip the app's exports first (LiveLinkFace_20240531_MySlate_3_iPhone.zip)"),
             (tmp_path / "nowhere", "not a folder"),
             (tmp_path / "allbad", "no take of the Live Link Face corpus could be read: silent.csv: ")]
    for root, message in cases:
        code = build_main(["--dataset", "livelink", "--root", str(root), "--out", str(tmp_path / "x")])
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and err[-1].startswith("error:") and message in err[-1], (root, err)
        assert not fmt.manifest_path(tmp_path / "x").exists()
        assert not any((tmp_path / "x" / d).exists() for d in (fmt.COEFFS_DIR, fmt.AUDIO_DIR, fmt.POSE_DIR))


def test_a_long_59_94_take_is_resampled_not_relabelled_and_its_pose_cut_with_it(tmp_path):
    # 20 s at 59.94 fps: read as 60 fps its last frames would be 1.2 frames late; cut into utterances
    clock_take(tmp_path / "long" / "take.csv", 20.0)
    write_sound(tmp_path / "long" / "take.wav", 20.0)
    _build(tmp_path / "long", tmp_path / "out")
    utterances = fmt.read_utterances(tmp_path / "out")
    assert len(utterances) >= 2
    frames = round(int(round(20.0 * NTSC_60)) * 60 / NTSC_60)
    spans = sorted((u["start_frame"], u["end_frame"]) for u in utterances.values())
    assert spans[0][0] == 0 and spans[-1][1] == frames and all(a[1] == b[0] for a, b in zip(spans, spans[1:]))
    for key, record in utterances.items():
        subject, sentence = key.split("/")
        coeffs, _ = fmt.read_coeffs(tmp_path / "out", subject, sentence)
        pose = fmt.read_pose(tmp_path / "out", subject, sentence)
        assert len(coeffs) == len(pose) == record["end_frame"] - record["start_frame"]
        t = (record["start_frame"] + np.arange(len(coeffs))) / 60.0
        inside = t < (frames - 1) / 60.0
        np.testing.assert_allclose(coeffs[inside], weights_at(t[inside]), atol=RESAMPLING_ERROR)
        np.testing.assert_allclose(pose[inside], pose_at(t[inside]), atol=RESAMPLING_ERROR)


def delayed_takes(root, data, keys, delays) -> dict:
    """Write each sentence ``keys`` of the build ``data`` as a Live Link take through the project's
    exporter (the track resampled to 59.94 fps, timecodes at 59.94) with its audio as a WAV, once per
    delay ``k`` in ``delays``: the audio moved k frames (k / 60 s) later, its length kept. Returns
    ``{take name: (key, k)}``."""
    from blendvoca.export import export_track
    from blendvoca.fit.resample import resample_sequence
    from blendvoca.io.audio import write_wav
    from blendvoca.names import BLENDVOCA_NAMES

    written = {}
    for subject, sentence in keys:
        track = np.clip(resample_sequence(data.coeffs(subject, sentence), 60.0, NTSC_60), 0.0, 1.0)
        audio, rate = data.audio(subject, sentence)
        for k in delays:
            name = f"{subject}_{sentence}_delay{k}"
            export_track(root / f"{name}.csv", track, BLENDVOCA_NAMES, "livelink", fps=59.94)
            n = int(round(k * rate / 60))
            write_wav(root / f"{name}.wav", np.concatenate([np.zeros(n, np.float32), audio[: len(audio) - n]]), rate)
            written[name] = ((subject, sentence), k)
    return written


@pytest.mark.slow  # the bundled default (built once into the cache), one build and one scoring: ~30 s
def test_audio_delayed_by_k_frames_reads_k_frames_lower(tmp_path, assets_dir, capsys):
    """Issue 53's acceptance, on the synthetic corpus's test sentences and audio: each written as a
    59.94 fps Live Link take and again with its audio delayed by 2 and 4 frames, built together and
    scored with the geometric estimator; the delayed copies read k frames lower than the undelayed one."""
    from benchmark.data import open_blendvoca
    from benchmark.protocol import default_data_root
    from benchmark.run import main as run_main

    data = open_blendvoca(default_data_root())
    keys = [(s, t) for s in data.split("test") for t in data.sentences(s)]
    written = delayed_takes(tmp_path / "takes", data, keys, (0, 2, 4))
    assert build_main(["--dataset", "livelink", "--root", str(tmp_path / "takes"), "--out", str(tmp_path / "out"),
                       "--quiet"]) == 0
    sources = fmt.read_manifest(tmp_path / "out")["dataset"]["sources"]
    take_of = {key: src[: -len(".csv")] for key, src in sources.items()}
    offset = {}
    for split in ("train", "val", "test"):  # a subject per take: the takes are split by take, every one scored
        with warnings.catch_warnings():  # the rig-space note, and the latent metrics a split too small lacks
            warnings.simplefilter("ignore", UserWarning)
            assert run_main(["--method", "ground-truth", "--data", str(tmp_path / "out"), "--split", split,
                             "--config", f"split={split}", "--results", str(tmp_path / split),
                             "--quiet"]) == 0, capsys.readouterr().err
        (path,) = (tmp_path / split).glob("*.json")
        result = json.loads(path.read_text())
        offset.update({written[take_of[f"{p['subject']}/{p['sentence']}"]]: p["av_offset_signed_geometric"]
                       for p in result["per_sentence"]})
    assert len(offset) == 3 * len(keys)
    for key in keys:
        for k in (2, 4):
            assert abs(offset[(key, k)] - (offset[(key, 0)] - k)) <= 1, (key, k, offset)
