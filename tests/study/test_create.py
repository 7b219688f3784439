"""``python -m benchmark.study create``: stimuli from stored runs, the design, the refusals.

Rows are written in about a second on the bundled default (tests/study/create_fixtures.py);
the studies use 1-1.5 s clips at 256 px and 30 fps.
"""

from __future__ import annotations

import json
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np
import pytest

from tests.study.create_fixtures import write_stored_rows

SIZE = 256
SECONDS = 1.5
FPS = 30


def _create(*argv) -> int:
    from benchmark.study.__main__ import main

    return main(["create", *map(str, argv)])


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> Path:
    return write_stored_rows(tmp_path_factory.mktemp("rows") / "results")


@pytest.fixture(scope="module")
def ab_study(results, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("ab") / "study"
    code = _create("--results", results, "--rows", "truth,still,sampler", "--design", "ab",
                   "--questions", "lipsync,realism", "--out", out, "--sentences", 2, "--participants", 4,
                   "--judgements", 3, "--size", SIZE, "--max-seconds", SECONDS, "--seed", 7, "--quiet")
    assert code == 0
    return out


@pytest.fixture(scope="module")
def spoken_word(tmp_path_factory) -> Path:
    """A WAV whose 0.5-1.0 s holds a 'word' (a tone burst) between silences."""
    from blendvoca.io.audio import write_wav

    rate = 16000
    t = np.arange(int(1.5 * rate)) / rate
    audio = np.where((t >= 0.5) & (t < 1.0), 0.5 * np.sin(2 * np.pi * 220 * t), 0.0)
    path = tmp_path_factory.mktemp("word") / "word.wav"
    write_wav(path, audio.astype(np.float32), rate)
    return path


@pytest.fixture(scope="module")
def mos_study(results, spoken_word, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("mos") / "study"
    out.mkdir()  # an empty folder is taken
    code = _create("--results", results, "--rows", "sampler", "--design", "mos", "--questions",
                   "lipsync,realism,diversity", "--out", out, "--sentences", 2, "--size", SIZE,
                   "--max-seconds", SECONDS, "--attention", "mismatched", "--sound-check", spoken_word,
                   "--sound-check-answer", " Hello ", "--sound-check-span", "0.5,1.0", "--quiet")
    assert code == 0
    return out


def _decode(path):
    """Codec names, pixel format, frames (RGB) and audio seconds of a clip, through PyAV."""
    import av

    with av.open(str(path)) as container:
        video = container.streams.video[0]
        audio = container.streams.audio[0]
        codecs = (video.codec_context.name, audio.codec_context.name, video.codec_context.pix_fmt)
        frames = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
    with av.open(str(path)) as container:
        samples = sum(f.samples for f in container.decode(audio=0))
        rate = container.streams.audio[0].rate
    return codecs, np.stack(frames), samples / rate


def _study(folder):
    from benchmark.study.design import read_study

    return read_study(folder)


# --- the clips ---------------------------------------------------------------------------

def _top_level_boxes(path) -> list[str]:
    """The names of an MP4's top-level boxes, in file order."""
    import struct

    data, names, at = Path(path).read_bytes(), [], 0
    while at + 8 <= len(data):
        size, name = struct.unpack(">I4s", data[at:at + 8])
        if size == 1:
            size = struct.unpack(">Q", data[at + 8:at + 16])[0]
        names.append(name.decode("latin-1"))
        at += size if size else len(data)
    return names


def test_every_clip_is_h264_yuv420p_with_aac_and_the_clips_of_a_sentence_last_as_long(ab_study):
    study = _study(ab_study)
    by_sentence = defaultdict(set)
    for stimulus in study.stimuli.values():
        boxes = _top_level_boxes(ab_study / stimulus.path)
        assert boxes.index("moov") < boxes.index("mdat")  # a browser plays it while it loads
        codecs, frames, audio_seconds = _decode(ab_study / stimulus.path)
        assert codecs == ("h264", "aac", "yuv420p")
        assert frames.shape[1:] == (SIZE, SIZE * len(stimulus.samples), 3)
        assert len(frames) == stimulus.frames == round(SECONDS * FPS)
        assert abs(audio_seconds - SECONDS) < 0.05  # AAC pads a frame at most
        by_sentence[(stimulus.subject, stimulus.sentence)].add(len(frames))
    assert all(len(counts) == 1 for counts in by_sentence.values())
    chosen = {tuple(pair) for pair in study.settings["sentences"]}
    assert len(chosen) == 2 and set(by_sentence) == chosen | {tuple(study.settings["practice_sentence"])}


def test_a_vertex_row_is_drawn_on_the_same_head_with_the_same_camera_as_a_coefficient_row(results, tmp_path):
    """The vertex row holds the ground truth's vertices (through the rig, stored as float16
    offsets): its clip matches the coefficient row's clip of the same motion."""
    out = tmp_path / "study"
    assert _create("--results", results, "--rows", "truth,meshes", "--design", "ab", "--out", out,
                   "--sentences", 1, "--attention-checks", 0, "--size", SIZE, "--max-seconds", 1, "--quiet") == 0
    study = _study(out)
    clips = {s.row: _decode(out / s.path)[1].astype(float) for s in study.stimuli.values()}
    assert set(clips) == {"truth", "meshes"}
    assert np.abs(clips["truth"] - clips["meshes"]).mean() < 2.0  # of 255: encoder noise
    assert clips["truth"].std(axis=0).mean() > 0.5  # it moves


def test_study_json_names_rows_by_result_file_digest_and_build(ab_study, results):
    from benchmark.study.design import sha256_of

    study = _study(ab_study)
    assert set(study.rows) == {"truth", "still", "sampler"}
    for name, row in study.rows.items():
        assert Path(row["result"]) == (results / f"{name}.json").resolve()
        assert row["result_sha256"] == sha256_of(results / f"{name}.json")
    assert len({row["recipe_id"] for row in study.rows.values()}) == 1
    assert study.settings["recipe_id"] == study.rows["truth"]["recipe_id"]
    # the file names say nothing of the row
    assert all(Path(s.path).stem == key and key.startswith("v") for key, s in study.stimuli.items())


def test_the_stimuli_are_verified_by_their_sha256(ab_study, tmp_path):
    import shutil

    from benchmark.study.design import read_study, verify_stimuli, write_study
    from blendvoca.errors import DataError

    study = read_study(ab_study)
    verify_stimuli(study, ab_study)
    listed = {s.path for s in study.stimuli.values()} | {study.sound_check.path}
    assert {p.relative_to(ab_study).as_posix() for p in ab_study.rglob("*") if p.is_file()} == listed | {"study.json"}
    copy = tmp_path / "copy"
    shutil.copytree(ab_study, copy)
    write_study(study, copy)
    assert read_study(copy) == study  # round trip
    victim = copy / next(iter(study.stimuli.values())).path
    victim.write_bytes(victim.read_bytes()[:-1] + b"\0")
    with pytest.raises(DataError, match="changed since the study was created"):
        verify_stimuli(study, copy)
    (copy / study.sound_check.path).unlink()
    victim.unlink()
    with pytest.raises(DataError, match="missing"):
        verify_stimuli(study, copy)


# --- the design --------------------------------------------------------------------------

def test_every_pair_is_judged_by_enough_distinct_participants_with_sides_balanced(ab_study):
    study = _study(ab_study)
    trials = study.trials_by_id()
    judges = defaultdict(list)
    sides = Counter()
    shown = Counter()
    for slot in study.participants:
        items = [trials[t].item for t in slot.trials if trials[t].kind == "ab"]
        assert len(items) == len(set(items))  # nobody judges an item twice
        for t in slot.trials:
            trial = trials[t]
            if trial.kind != "ab":
                continue
            judges[trial.item].append(slot.slot)
            left, right = (study.stimuli[s].row for s in trial.stimuli)
            sides[left] += 1
            shown[left] += 1
            shown[right] += 1
            assert trial.questions == ("lipsync", "realism")
    pairs = {frozenset(study.stimuli[s].row for s in trials[f"{item}-ab"].stimuli) for item in judges
             if f"{item}-ab" in trials}
    assert len(judges) == 3 * 2  # 3 pairs x 2 sentences
    assert len(pairs) == 3
    assert min(len(slots) for slots in judges.values()) >= 3
    for row in ("truth", "still", "sampler"):
        assert abs(2 * sides[row] - shown[row]) <= 2, (row, sides[row], shown[row])


def test_each_participant_gets_a_practice_trial_first_and_attention_checks_with_an_unmistakable_answer(ab_study):
    study = _study(ab_study)
    trials = study.trials_by_id()
    for slot in study.participants:
        assert trials[slot.trials[0]].kind == "practice"
        checks = [trials[t] for t in slot.trials if trials[t].kind == "attention"]
        assert len(checks) == 2 and trials[slot.trials[1]].kind != "attention"
    expected = Counter()
    for trial in (t for t in study.trials if t.kind == "attention"):
        rows = [study.stimuli[s].row for s in trial.stimuli]
        assert rows[("left", "right").index(trial.expected)] == "_ground_truth"
        assert set(rows) == {"_ground_truth", "_static"}
        assert trial.questions == ("lipsync",)
        expected[trial.expected] += 1
        truth, still = (_decode(ab_study / study.stimuli[s].path)[1].astype(float)
                        for s in sorted(trial.stimuli, key=lambda s: study.stimuli[s].row))
        assert np.abs(still - still[0]).max() < 8  # the motionless face
        assert np.abs(truth - truth[0]).max() > 40  # the ground truth moves
    assert expected["left"] == expected["right"]


def test_mos_shows_a_samplers_three_samples_together_and_checks_attention_with_a_left_right_question(mos_study):
    from benchmark.study.design import ATTENTION_QUESTION

    study = _study(mos_study)
    assert [q.id for q in study.questions] == ["lipsync", "realism", "diversity", ATTENTION_QUESTION]
    assert study.question("lipsync").choices == ("1", "2", "3", "4", "5")
    assert study.question(ATTENTION_QUESTION).choices == ("left", "right")
    rated = [t for t in study.trials if t.kind == "mos"]
    assert len(rated) == 2
    for trial in rated:
        (clip,) = trial.stimuli
        assert study.stimuli[clip].samples == (0, 1, 2) and study.stimuli[clip].width == 3 * SIZE
        assert trial.questions == ("lipsync", "realism", "diversity")
        frames = _decode(mos_study / study.stimuli[clip].path)[1].astype(float)
        thirds = np.split(frames, 3, axis=2)
        assert np.abs(thirds[0] - thirds[1]).mean() > 0.05  # three different samples
    for trial in (t for t in study.trials if t.kind == "attention"):
        rows = [study.stimuli[s].row for s in trial.stimuli]
        assert rows[("left", "right").index(trial.expected)] == "_ground_truth"
        assert any(r.startswith("_mismatched:sentence") for r in rows)
        assert trial.questions == (ATTENTION_QUESTION,)
    for slot in study.participants:
        assert sum(1 for t in slot.trials if t.endswith("-mos")) == 2


def test_the_sound_check_holds_the_word_cut_from_the_recording(mos_study, spoken_word):
    from blendvoca.io.audio import load_audio

    study = _study(mos_study)
    check = study.sound_check
    assert check.answer == "hello" and check.accepts("HELLO.") and not check.accepts("yellow")
    assert check.source.endswith("[0.5 s, 1 s]")
    audio = load_audio(mos_study / check.path, rate=16000)
    assert abs(len(audio) / 16000 - 0.5) < 1e-3 and np.abs(audio).min() < 0.01 and np.abs(audio).max() > 0.4


def test_the_default_sound_check_speaks_the_word_its_answer_names(ab_study):
    """The clip is the synthesiser speaking the answer: speaking the answer again gives the same
    samples (espeak-ng is deterministic), and another word does not."""
    import shutil

    from benchmark.study.stimuli import ESPEAK, SPOKEN_WORDS, spoken_word
    from blendvoca.io.audio import load_audio

    if shutil.which(ESPEAK) is None:
        pytest.skip(f"{ESPEAK} is not installed (apt-get install {ESPEAK}); the default is counted beeps")
    check = _study(ab_study).sound_check
    assert check.answer in SPOKEN_WORDS and check.source.endswith(f"speaking {check.answer!r}")
    stored = load_audio(ab_study / check.path, rate=16000)
    voiced = np.flatnonzero(np.abs(stored) > 0.05)
    assert 0.2 < (voiced[-1] - voiced[0]) / 16000 < 1.5  # a word, not silence and not a sentence
    assert np.abs(stored[:7000]).max() < 1e-3 and np.abs(stored[-7000:]).max() < 1e-3  # silence around it
    by_word = {}
    for seed in range(40):
        clip = spoken_word(np.random.default_rng(seed))
        by_word.setdefault(clip.answer, clip.audio)
    assert len(stored) == len(by_word[check.answer]) and np.allclose(stored, by_word[check.answer], atol=1e-3)
    others = [audio for word, audio in by_word.items() if word != check.answer]
    assert others and all(len(a) != len(stored) or not np.allclose(a, stored, atol=1e-3) for a in others)


def test_without_the_synthesiser_the_sound_check_counts_beeps(monkeypatch):
    import shutil

    from benchmark.study import stimuli

    monkeypatch.setattr(shutil, "which", lambda name: None)
    check = stimuli.spoken_word(np.random.default_rng(0))
    assert "apt-get install espeak-ng" in check.source
    loud = np.convolve(np.abs(check.audio) > 0.1, np.ones(80), mode="same") > 0
    onsets = int(np.sum(np.diff(loud.astype(int)) == 1))
    assert check.answer == str(onsets)
    from benchmark.study.design import SoundCheck

    sound = SoundCheck("s.wav", "0" * 64, check.answer, check.accepted)
    assert sound.accepts(stimuli.NUMBER_WORDS[onsets]) and sound.accepts(f" {onsets} ")


def test_a_recording_named_by_asset_id_is_resolved_through_the_assets():
    from benchmark.study.stimuli import recorded_word
    from blendvoca.assets import AssetError, resolve

    asset = "vocaset-facetalk-170725-00137-ta-sentence01-wav"
    try:
        resolve(asset, download_missing=False)
    except AssetError:
        pytest.skip(f"asset {asset} is not present (BLENDVOCA_ASSETS)")
    clip = recorded_word(asset, "word", (0.0, 0.5))
    assert clip.source == f"asset {asset} [0 s, 0.5 s]" and len(clip.audio) == 8000


# --- the pure parts ----------------------------------------------------------------------

@pytest.mark.parametrize("items,judgements,participants", [(6, 3, 4), (120, 3, 15), (7, 2, 2), (10, 3, 29)])
def test_dealing_gives_every_item_its_judgements_from_distinct_slots(items, judgements, participants):
    from benchmark.study.schedule import deal, per_participant_for

    per = per_participant_for(items, judgements, participants, None)
    slots = deal(items, participants, per, np.random.default_rng(0))
    count = Counter()
    for slot in slots:
        assert len(slot) == per and len({i for i, _ in slot}) == per
        count.update(i for i, _ in slot)
    assert set(count) == set(range(items))
    assert min(count.values()) >= judgements and max(count.values()) - min(count.values()) <= 1


def test_codetalkers_design_120_pairs_3_judgements_24_per_participant_needs_15_participants():
    from benchmark.study.schedule import per_participant_for, slots_needed

    assert slots_needed(120, 3, 24) == 15
    assert per_participant_for(120, 3, 15, 24) == 24


def test_sentences_are_balanced_over_speakers_and_samples_over_styles():
    from benchmark.study.stimuli import choose_sentences, samples_shown

    candidates = [(s, f"sentence{k:02d}") for s, n in (("A", 5), ("B", 2), ("C", 4)) for k in range(n)]
    chosen = choose_sentences(candidates, 6, np.random.default_rng(0))
    assert Counter(s for s, _ in chosen) == {"A": 2, "B": 2, "C": 2}
    assert chosen == choose_sentences(candidates, 6, np.random.default_rng(0))
    assert len(set(chosen)) == 6
    shown = Counter(samples_shown(3, 1, k, 5)[0] for k in range(6))
    assert shown == {0: 2, 1: 2, 2: 2}
    assert samples_shown(1, 3, 4, 5) == (0,)  # a deterministic row shows its one track


# --- refusals ----------------------------------------------------------------------------

def _refused(capsys, tmp_path, *argv, match: str):
    out = tmp_path / "refused"
    before = sorted(p.name for p in tmp_path.iterdir())
    code = _create(*argv, "--out", out, "--size", SIZE, "--max-seconds", 1, "--quiet")
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 and err[0].startswith("error:") and match in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written, no staging left


@pytest.mark.parametrize("rows,match", [
    ("truth,nobody", "--rows nobody: no result file"),
    ("truth,scores-only", "holds scores only, no stored tracks"),
    ("truth,elsewhere", "scored on different builds"),
])
def test_rows_that_cannot_be_studied_are_refused(results, tmp_path, capsys, rows, match):
    _refused(capsys, tmp_path, "--results", results, "--rows", rows, "--design", "ab", match=match)


def test_the_scores_only_refusal_says_how_to_recreate_the_tracks(results, tmp_path, capsys):
    _refused(capsys, tmp_path, "--results", results, "--rows", "scores-only,truth", "--design", "ab",
             match="leaderboard.reproduce")


@pytest.mark.parametrize("extra,match", [
    (("--participants", 2), "at least 3 participants"),
    (("--participants", 3, "--per-participant", 1), "ask for at least 6 participants"),
])
def test_a_design_that_cannot_give_every_item_its_judgements_is_refused(results, tmp_path, capsys, extra, match):
    _refused(capsys, tmp_path, "--results", results, "--rows", "truth,still", "--design", "ab", "--sentences", 2,
             *extra, match=match)


def test_an_out_folder_with_files_is_refused_and_left_alone(results, tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep me")
    code = _create("--results", results, "--rows", "truth,still", "--design", "ab", "--out", out, "--quiet")
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "exists and is a folder that is not empty" in err[0]
    assert [p.name for p in out.iterdir()] == ["notes.txt"] and (out / "notes.txt").read_text() == "keep me"


def test_more_sentences_than_the_rows_share_is_refused(results, tmp_path, capsys):
    _refused(capsys, tmp_path, "--results", results, "--rows", "truth,still", "--design", "ab", "--sentences", 99,
             match="share only 4 sentences")


def test_the_study_json_of_a_created_study_is_plain_json_with_the_format(ab_study):
    data = json.loads((ab_study / "study.json").read_text())
    assert data["format"] == "blendvoca-study-1" and data["design"] == "ab"
    assert data["created"]["command"].startswith("python -m benchmark.study create --results ")
