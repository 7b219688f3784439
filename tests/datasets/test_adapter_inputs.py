"""Bad and unusual corpora given to the coefficient adapters (issue 56, reliability round 4).

Each case was built silently wrong, merged, skipped or crashed before: now every take is
either built (its speaker's name kept by an injective file-name encoding) or a failure of
its own counted in the summary (exit 5), and a corpus file that points outside ``--root``
or at a speaker that does not exist is one error naming the entry.
"""

from __future__ import annotations

import hashlib
import json
import shutil

import numpy as np
import pytest

from blendvoca import format as fmt
from blendvoca.builder.__main__ import main as build_main
from blendvoca.datasets import adapter
from blendvoca.datasets.coefficients import RANGE_TOLERANCE, folder_name
from blendvoca.errors import DataError
from blendvoca.io.audio import write_wav
from tests.datasets.corpora import speech, write_beat, write_unitalker_layout


def _build(name, root, out):
    return adapter(name)(root, out)


def _edit_beat(path, edit):
    doc = json.loads(path.read_text())
    edit(doc)
    path.write_text(json.dumps(doc))


def _set_weight(value, frames, column="jawOpen"):
    def edit(doc):
        k = doc["names"].index(column)
        for t in frames:
            doc["frames"][t]["weights"][k] = value
    return edit


def _failure(summary, source):
    found = [f for f in summary.failures if f["reason"].startswith(source)]
    assert len(found) == 1, summary.failures
    return found[0]["reason"]


# ---------------------------------------------------------------------------- names


def test_folder_names_are_injective_and_safe():
    names = ["1_wayne", "spk_a", "spk a", "spk~20a", "说话人", "发言人", "١_wayne", "٢_wayne", ".hidden", "_hidden",
             "a/b", "a_b", "", "~", "CON"]
    encoded = [folder_name(n) for n in names]
    assert len(set(encoded)) == len(names), dict(zip(names, encoded))
    for name in ("1_wayne", "spk_a", "a-b.c", "CON"):
        assert folder_name(name) == name  # plain names are kept as they are
    for text in encoded:
        assert text and not text.startswith(".") and all(c.isascii() and (c.isalnum() or c in "_.-~") for c in text)
    assert folder_name("说话人") != folder_name("发言人")


# ---------------------------------------------------------------------------- BEAT weights and frame times


def test_beat_weights_outside_zero_one_or_not_finite_fail_their_take_naming_frame_and_column(tmp_path):
    write_beat(tmp_path / "beat", takes=2)
    _edit_beat(tmp_path / "beat" / "1" / "1_wayne_0_2_2.json", _set_weight(5.0, range(3, 13)))
    _edit_beat(tmp_path / "beat" / "2" / "2_scott_0_2_2.json", _set_weight(1e300, [7], "mouthClose"))
    _edit_beat(tmp_path / "beat" / "3" / "3_solomon_0_2_2.json", _set_weight(-3.0, range(0, 10), "mouthFunnel"))
    # capture noise within the tolerance is kept as captured
    _edit_beat(tmp_path / "beat" / "3" / "3_solomon_0_1_1.json", _set_weight(1 + RANGE_TOLERANCE / 2, [4]))
    summary = _build("beat", tmp_path / "beat", tmp_path / "out")
    assert len(summary.failures) == 3 and summary.built["sentences"] == 3
    for source, frame, column, value in [("1/1_wayne_0_2_2.json", 3, "jawOpen", "5"),
                                         ("2/2_scott_0_2_2.json", 7, "mouthClose", "1e+300"),
                                         ("3/3_solomon_0_2_2.json", 0, "mouthFunnel", "-3")]:
        reason = _failure(summary, source)
        assert f"frame {frame}" in reason and repr(column) in reason and f"weight {value}" in reason, reason
        assert "[0, 1]" in reason, reason
    assert "(10 outside in all)" in _failure(summary, "1/1_wayne_0_2_2.json")
    std = np.loadtxt(tmp_path / "out" / "coeffs_std.csv", delimiter=",", skiprows=1, ndmin=1)
    assert np.all(np.isfinite(std)) and std.max() <= 1.0


@pytest.mark.parametrize("step, rate", [(1e-6, "1e+06"), (1000.0, "0.001")])
def test_beat_frame_times_of_an_implausible_rate_fail_their_take_before_resampling(tmp_path, step, rate):
    write_beat(tmp_path / "beat", takes=2)

    def times(doc):
        doc["frames"] = doc["frames"][:10]
        for t, frame in enumerate(doc["frames"]):
            frame["time"] = t * step
    _edit_beat(tmp_path / "beat" / "2" / "2_scott_0_2_2.json", times)
    summary = _build("beat", tmp_path / "beat", tmp_path / "out")
    reason = _failure(summary, "2/2_scott_0_2_2.json")
    assert f"{rate} fps" in reason and "expected 10 to 1000 fps" in reason, reason
    assert summary.built["sentences"] == 5


# ---------------------------------------------------------------------------- BEAT takes never skipped


def test_beat_takes_without_audio_or_with_an_unreadable_name_fail_alone_with_exit_5(tmp_path, capsys):
    write_beat(tmp_path / "beat", takes=2)
    (tmp_path / "beat" / "1" / "1_wayne_0_2_2.wav").unlink()
    folder = tmp_path / "beat" / "2"
    for suffix in (".json", ".wav"):
        shutil.copy(folder / f"2_scott_0_2_2{suffix}", folder / f"2_scott 0_3_3{suffix}")
    code = build_main(["--dataset", "beat", "--root", str(tmp_path / "beat"), "--out", str(tmp_path / "out"),
                       "--quiet"])
    out = capsys.readouterr()
    assert code == 5, (out.out, out.err)
    summary = json.loads((tmp_path / "out" / "manifest.json").read_text())["failures"]
    reasons = {f["reason"].split(":")[0]: f["reason"] for f in summary}
    assert set(reasons) == {"1/1_wayne_0_2_2.json", "2/2_scott 0_3_3.json"}, summary
    assert "1_wayne_0_2_2.wav" in reasons["1/1_wayne_0_2_2.json"] and "no such file" in reasons["1/1_wayne_0_2_2.json"]
    assert "not a BEAT take name" in reasons["2/2_scott 0_3_3.json"]
    assert {f["subject"] for f in summary} == {"1_wayne", "2_scott"}


def test_beat_speakers_with_non_ascii_letters_or_digits_are_built_under_distinct_folders(tmp_path):
    write_beat(tmp_path / "beat", speakers=(("١", "wayne"), ("٢", "wayne"), ("3", "wäyne")), takes=1)
    summary = _build("beat", tmp_path / "beat", tmp_path / "out")
    assert summary.ok and summary.built == {"speakers": 3, "sentences": 3}
    subjects = {folder_name("١_wayne"), folder_name("٢_wayne"), folder_name("3_wäyne")}
    assert len(subjects) == 3
    splits = fmt.read_splits(tmp_path / "out")
    assert set(sum(splits.values(), [])) == subjects
    record = fmt.read_manifest(tmp_path / "out")["dataset"]
    assert record["speakers"] == {folder_name(n): n for n in ("١_wayne", "٢_wayne", "3_wäyne")}
    assert record["sources"][f"{folder_name('3_wäyne')}/sentence01"] == "3/3_wäyne_0_1_1.json"


# ---------------------------------------------------------------------------- a rebuild's clean-up


def test_a_rebuild_deletes_only_its_own_previous_files_under_out(tmp_path):
    write_beat(tmp_path / "beat", takes=2)
    out = tmp_path / "a" / "out"
    _build("beat", tmp_path / "beat", out)
    victim = tmp_path / "victim" / "keep.txt"
    victim.parent.mkdir()
    victim.write_text("mine")
    mine = out / "audio" / "notes.txt"
    mine.write_text("also mine")
    manifest = json.loads((out / "manifest.json").read_text())
    digest = hashlib.sha256(b"mine").hexdigest()
    manifest["files"]["../../victim/keep.txt"] = digest  # the right sha256, outside --out
    manifest["files"]["audio/notes.txt"] = digest  # under --out, but not what the build wrote there
    (out / "manifest.json").write_text(json.dumps(manifest))
    (tmp_path / "beat" / "3" / "3_solomon_0_2_2.json").unlink()
    summary = _build("beat", tmp_path / "beat", out)
    assert summary.built["sentences"] == 5
    assert victim.read_text() == "mine" and mine.read_text() == "also mine"
    assert not fmt.coeffs_path(out, "3_solomon", "sentence02").exists()  # its own stale file went


# ---------------------------------------------------------------------------- UniTalker entries


def _unitalker(root, **kwargs):
    return write_unitalker_layout(root, annot_type="inhouse_blendshape_weight", convention="unitalker51", **kwargs)


def _edit_split(root, split, edit):
    doc = json.loads((root / f"{split}.json").read_text())
    edit(doc)
    (root / f"{split}.json").write_text(json.dumps(doc))


@pytest.mark.parametrize("key, value, what", [
    ("annot_path", "../outside/secret.npy", "leaves --root"),
    ("audio_path", "ABSOLUTE", "is absolute"),
    ("annot_path", "annot/link.npy", "leaves --root"),
])
def test_unitalker_paths_outside_the_root_are_refused_naming_the_entry(tmp_path, key, value, what):
    root = tmp_path / "d6"
    _unitalker(root)
    (tmp_path / "outside").mkdir()
    np.save(tmp_path / "outside" / "secret.npy", np.zeros((75, 51), dtype=np.float32))
    write_wav(tmp_path / "outside" / "a.wav", speech(2.5, 0), 16000)
    (root / "annot" / "link.npy").symlink_to(tmp_path / "outside" / "secret.npy")
    value = str(tmp_path / "outside" / "a.wav") if value == "ABSOLUTE" else value
    _edit_split(root, "train", lambda doc: doc["data"][1].update({key: value}))
    with pytest.raises(DataError) as caught:
        _build("unitalker", root, tmp_path / "out")
    message = str(caught.value)
    assert str(root / "train.json") in message and "data[1]" in message and key in message, message
    assert what in message and value in message, message
    assert not (tmp_path / "out" / "manifest.json").exists()


@pytest.mark.parametrize("value, what", [(-1, "id -1"), (4, "id 4"), (1.5, "id 1.5"), (True, "id True"),
                                         ("0", "id '0'")])
def test_unitalker_ids_that_name_no_speaker_are_refused_naming_the_item(tmp_path, value, what):
    root = tmp_path / "d6"
    _unitalker(root)
    _edit_split(root, "val", lambda doc: doc["data"][0].update({"id": value}))
    with pytest.raises(DataError) as caught:
        _build("unitalker", root, tmp_path / "out")
    message = str(caught.value)
    assert str(root / "val.json") in message and "data[0]" in message and what in message, message
    assert "info.id_list" in message and "4 speakers" in message, message


@pytest.mark.parametrize("speakers", [("spk a", "spk_a", "spk_c"), ("说话人", "发言人", "spk_c", "spk_d"),
                                      ("说话人", "发言人", "讲者")])
def test_unitalker_speakers_are_never_merged_and_their_own_split_is_kept(tmp_path, speakers):
    root = tmp_path / "d6"
    _unitalker(root, speakers=speakers)
    summary = _build("unitalker", root, tmp_path / "out")
    assert summary.ok and summary.built == {"speakers": len(speakers), "sentences": 2 * len(speakers)}
    folders = [folder_name(s) for s in speakers]
    assert len(set(folders)) == len(speakers)
    splits = fmt.read_splits(tmp_path / "out")
    assert splits == {"train": folders[:-2], "val": [folders[-2]], "test": [folders[-1]]} or \
        splits == {k: sorted(v) for k, v in {"train": folders[:-2], "val": [folders[-2]], "test": [folders[-1]]}.items()}
    messages = [w["message"] for w in summary.warnings]
    assert not any("splits by sentence" in m for m in messages), messages
    assert any("the corpus's own split, which is by speaker, is kept" in m for m in messages), messages
    record = fmt.read_manifest(tmp_path / "out")["dataset"]
    assert {record["speakers"].get(f, f) for f in folders} == set(speakers)


def test_unitalker_one_speaker_listed_twice_is_refused(tmp_path):
    root = tmp_path / "d6"
    _unitalker(root)
    for split in ("train", "val", "test"):
        _edit_split(root, split, lambda doc: doc["info"].update({"id_list": ["spk_a", "spk_b", "spk_a", "spk_d"]}))
    with pytest.raises(DataError, match=r"train.json: info.id_list names 'spk_a' twice \(ids 0 and 2\)"):
        _build("unitalker", root, tmp_path / "out")


# ---------------------------------------------------------------------------- 3D-ETF audio


def test_3d_etf_audio_of_one_millisecond_fails_its_take_as_too_short(tmp_path):
    root = tmp_path / "d3"
    write_unitalker_layout(root, annot_type="3DETF_blendshape_weight", convention="etf52",
                           speakers=("a", "b", "c", "d"), takes=2)
    write_wav(root / "audio" / "b_001.wav", speech(0.001, 0), 16000)
    summary = _build("3d-etf", root, tmp_path / "out")
    reason = _failure(summary, "annot/b_001.npy")
    assert "audio of 0.001 s" in reason and "too short" in reason and "2.50 s of motion" in reason, reason
    assert summary.built["sentences"] == 7
