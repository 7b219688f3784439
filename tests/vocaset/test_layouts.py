"""Both VOCASET layouts of the same synthetic corpus read as identical arrays."""

import json
import pickle

import numpy as np
import pytest

from blendvoca.io.mesh import read_ply
from blendvoca.vocaset import FPS, VocasetError, convert_corpus, detect_layout, open_vocaset


def test_layouts_are_detected(synthetic_corpus, synthetic_corpus_processed, tmp_path):
    assert detect_layout(synthetic_corpus) == "official"
    assert detect_layout(synthetic_corpus_processed) == "processed"
    with pytest.raises(ValueError, match="not a VOCASET folder"):
        detect_layout(tmp_path)
    with pytest.raises(FileNotFoundError):
        open_vocaset(tmp_path / "nope")


def test_both_layouts_give_identical_arrays(synthetic_corpus, synthetic_corpus_processed):
    a, b = open_vocaset(synthetic_corpus), open_vocaset(synthetic_corpus_processed)
    assert (a.layout, b.layout) == ("official", "processed")
    assert a.subjects == b.subjects and len(a.subjects) == 6
    assert a.splits == b.splits == {"train": a.subjects[:4], "val": a.subjects[4:5], "test": a.subjects[5:]}
    assert np.array_equal(a.faces, b.faces) and a.faces.shape == (9976, 3)
    for subject in a.subjects:
        assert a.sentences(subject) == b.sentences(subject) == ["sentence01", "sentence02"]
        ta, tb = a.template(subject), b.template(subject)
        assert ta.shape == (5023, 3) and ta.dtype == np.float64 and np.array_equal(ta, tb)
        for sentence in a.sentences(subject):
            fa, fb = a.frames(subject, sentence), b.frames(subject, sentence)
            assert fa.dtype == np.float64 and fa.shape[1:] == (5023, 3)
            assert np.array_equal(fa, fb)
            stored = b.frames(subject, sentence, dtype=None)  # the processed layout keeps float32
            assert stored.dtype == np.float32 and np.array_equal(stored.astype(np.float64), fb)
            assert a.frames(subject, sentence, dtype=None).dtype == np.float64
            (xa, ra), (xb, rb) = a.audio(subject, sentence), b.audio(subject, sentence)
            assert xa.dtype == np.float32 and ra == rb == 22000 and np.array_equal(xa, xb)
            # 60 fps motion and audio of the same length.
            assert len(xa) == round(len(fa) / FPS * ra)
    assert a.problems == [] and b.problems == []


def test_official_frames_match_the_files_and_the_sidecar(synthetic_corpus):
    corpus = open_vocaset(synthetic_corpus)
    meta = json.loads((synthetic_corpus / "synthetic.json").read_text())
    subject = corpus.subjects[2]
    frames = corpus.frames(subject, "sentence02")
    assert len(frames) == meta["subjects"][subject]["sentences"]["sentence02"]["num_frames"]
    first = synthetic_corpus / "unposedcleaneddata" / subject / "sentence02" / "sentence02.000001.ply"
    assert np.array_equal(read_ply(first)[0], frames[0])
    assert corpus.synthetic["seed"] == 0


def test_processed_pickles_follow_voca_conventions(synthetic_corpus_processed):
    with open(synthetic_corpus_processed / "subj_seq_to_idx.pkl", "rb") as f:
        index = pickle.load(f)
    with open(synthetic_corpus_processed / "raw_audio_fixed.pkl", "rb") as f:
        audio = pickle.load(f)
    verts = np.load(synthetic_corpus_processed / "data_verts.npy", mmap_mode="r")
    subject = sorted(index)[0]
    frames = index[subject]["sentence01"]            # sentence keys are VOCA's strings
    assert sorted(frames) == list(range(len(frames)))  # 0-based int frame keys
    assert verts.shape[1:] == (5023, 3) and verts.dtype == np.float32
    entry = audio[subject]["sentence01"]
    assert entry["sample_rate"] == 22000 and entry["audio"].dtype == np.int16


def test_integer_sentence_keys_are_read(synthetic_corpus_processed, tmp_path):
    import shutil

    root = tmp_path / "intkeys"
    shutil.copytree(synthetic_corpus_processed, root)
    for name in ("subj_seq_to_idx.pkl", "raw_audio_fixed.pkl"):
        data = pickle.loads((root / name).read_bytes())
        data = {s: {int(q[-2:]): v for q, v in d.items()} for s, d in data.items()}
        (root / name).write_bytes(pickle.dumps(data))
    a, b = open_vocaset(synthetic_corpus_processed), open_vocaset(root)
    subject = a.subjects[0]
    assert b.sentences(subject) == ["sentence01", "sentence02"]
    assert np.array_equal(a.frames(subject, "sentence02"), b.frames(subject, "sentence02"))


def test_convert_official_to_processed_round_trip(synthetic_corpus, tmp_path):
    a = open_vocaset(synthetic_corpus)
    b = open_vocaset(convert_corpus(a, tmp_path / "p"))
    c = open_vocaset(convert_corpus(b, tmp_path / "o", layout="official"))
    for subject, sentence in a.items()[:3]:
        assert np.array_equal(a.frames(subject, sentence), b.frames(subject, sentence))
        assert np.array_equal(a.frames(subject, sentence), c.frames(subject, sentence))
        assert np.array_equal(a.audio(subject, sentence)[0], c.audio(subject, sentence)[0])
    assert np.array_equal(a.template(a.subjects[0]), c.template(a.subjects[0]))


def test_unknown_subject_and_sentence(synthetic_corpus):
    corpus = open_vocaset(synthetic_corpus)
    with pytest.raises(KeyError, match="unknown subject"):
        corpus.sentences("FaceTalk_170725_00137_TA")
    with pytest.raises(VocasetError) as info:
        corpus.frames(corpus.subjects[0], "sentence40")
    assert info.value.kind == "missing_sentence" and info.value.sentence == "sentence40"


def test_the_processed_writer_puts_posed_frames_in_the_rows_of_the_unposed_ones(tmp_path):
    from blendvoca.vocaset import ProcessedWriter

    rng = np.random.default_rng(0)
    unposed = [rng.normal(size=(t, 5, 3)) for t in (3, 2, 4)]
    writer = ProcessedWriter(tmp_path, sum(len(f) for f in unposed), num_vertices=5)
    for k, frames in enumerate(unposed):
        writer.add_template(f"S{k}", frames[0])
        writer.add_sentence(f"S{k}", "sentence01", frames, np.zeros(100), 16000)
        writer.add_posed_sentence(f"S{k}", "sentence01", frames + 1.0)
    writer.finish()
    corpus = open_vocaset(tmp_path, num_vertices=5)
    for k, frames in enumerate(unposed):
        assert corpus.has_posed(f"S{k}", "sentence01")
        posed = corpus.posed_frames(f"S{k}", "sentence01")
        assert np.array_equal(posed, (frames + 1.0).astype(np.float32).astype(np.float64))
        assert np.allclose(posed - 1.0, corpus.frames(f"S{k}", "sentence01"), atol=1e-6)  # float32 storage


def test_the_processed_writer_reserves_the_disk_its_frames_need(tmp_path):
    """A sparse ``data_verts.npy`` filled through its memory map on a full disk ends the process with
    SIGBUS (a CI run crashed so); the writer reserves the file's blocks before the first frame."""
    import os

    from blendvoca.vocaset import ProcessedWriter

    ProcessedWriter(tmp_path, 20000, num_vertices=5)  # 1.2 MB of frames
    status = os.stat(tmp_path / "data_verts.npy")
    assert status.st_blocks * 512 >= status.st_size > 1_000_000  # sparse, it would hold two blocks


def test_a_disk_too_small_for_the_frames_is_an_error_before_the_first_frame(tmp_path, monkeypatch, capsys):
    import errno
    import os

    from blendvoca.errors import ran_out_of
    from blendvoca.synthetic.__main__ import main
    from blendvoca.vocaset import ProcessedWriter

    def full_disk(fd, offset, length):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(os, "posix_fallocate", full_disk)
    with pytest.raises(OSError) as caught:
        ProcessedWriter(tmp_path / "w", 20000, num_vertices=5)
    assert caught.value.errno == errno.ENOSPC and caught.value.filename == str(tmp_path / "w" / "data_verts.npy")
    assert ran_out_of(caught.value) == "disk space"
    assert not (tmp_path / "w" / "data_verts.npy").exists()  # nothing half-written
    # the command a user runs: one error line naming the file, exit 2, no corpus folder left
    code = main(["--out", str(tmp_path / "c"), "--layout", "processed", "--speakers", "3", "--sentences", "1",
                 "--min-duration", "1", "--max-duration", "1.1", "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert err[0].startswith("error:") and "data_verts.npy" in err[0] and "ran out of disk space" in err[0]
    assert not (tmp_path / "c").exists()
