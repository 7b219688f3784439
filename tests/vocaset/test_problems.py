"""Every kind of bad input is reported with subject, sentence and frame; the rest still reads."""

import pickle
import shutil

import numpy as np
import pytest

from blendvoca.io.mesh import read_ply_vertices, write_ply
from blendvoca.vocaset import PROBLEM_KINDS, VocasetError, open_vocaset

S = [f"Synth_{i:03d}_TA" for i in range(6)]


def _frame(root, subject, sentence, number):
    return root / "unposedcleaneddata" / subject / sentence / f"{sentence}.{number:06d}.ply"


@pytest.fixture(scope="module")
def broken_official(synthetic_corpus, tmp_path_factory):
    root = tmp_path_factory.mktemp("broken") / "official"
    shutil.copytree(synthetic_corpus, root)
    shutil.rmtree(root / "unposedcleaneddata" / S[0] / "sentence02")
    (root / "audio" / S[1] / "sentence01.wav").unlink()
    write_ply(_frame(root, S[1], "sentence02", 6), np.zeros((5000, 3)))
    nan = read_ply_vertices(_frame(root, S[2], "sentence01", 11))
    nan[100, 1] = np.nan
    write_ply(_frame(root, S[2], "sentence01", 11), nan)
    path = _frame(root, S[2], "sentence02", 3)
    path.write_bytes(path.read_bytes()[:-1000])
    wav = root / "audio" / S[3] / "sentence01.wav"
    wav.write_bytes(wav.read_bytes()[:-5000])
    _frame(root, S[3], "sentence02", 7).unlink()
    (root / "templates" / f"{S[4]}.ply").unlink()
    return root


EXPECTED = {
    (S[0], "sentence02", None, "missing_sentence"),
    (S[1], "sentence01", None, "missing_audio"),
    (S[1], "sentence02", 5, "vertex_count"),
    (S[2], "sentence01", 10, "nan"),
    (S[2], "sentence02", 2, "truncated"),
    (S[3], "sentence01", None, "truncated"),
    (S[3], "sentence02", 6, "missing_frame"),
    (S[4], None, None, "missing_template"),
}


def test_official_scan_reports_every_problem_and_nothing_else(broken_official):
    corpus = open_vocaset(broken_official)
    problems = corpus.scan()
    assert {(p.subject, p.sentence, p.frame, p.kind) for p in problems} == EXPECTED
    assert all(p.kind in PROBLEM_KINDS for p in problems)
    # Structural problems are known at open time, before any frame is read.
    opened = open_vocaset(broken_official).problems
    assert {p.kind for p in opened} == {"missing_sentence", "missing_audio", "missing_frame", "missing_template"}


@pytest.mark.parametrize("subject, sentence, frame, kind", sorted(EXPECTED - {(S[4], None, None, "missing_template")},
                                                                 key=str))
def test_official_bad_item_raises_a_clear_error(broken_official, subject, sentence, frame, kind):
    corpus = open_vocaset(broken_official)
    read = corpus.audio if kind in ("missing_audio",) or (kind == "truncated" and frame is None) else corpus.frames
    with pytest.raises(VocasetError) as info:
        read(subject, sentence)
    error = info.value
    assert (error.subject, error.sentence, error.frame, error.kind) == (subject, sentence, frame, kind)
    assert isinstance(error, ValueError) and subject in str(error) and sentence in str(error)


def test_official_rest_of_the_corpus_still_reads(broken_official, synthetic_corpus):
    good, bad = open_vocaset(synthetic_corpus), open_vocaset(broken_official)
    with pytest.raises(VocasetError, match="missing_template"):
        bad.template(S[4])
    assert np.array_equal(bad.template(S[5]), good.template(S[5]))
    broken = {(s, q) for s, q, _, k in EXPECTED if q is not None}
    for subject, sentence in good.items():
        if (subject, sentence) in broken:
            continue
        assert np.array_equal(bad.frames(subject, sentence), good.frames(subject, sentence))
        assert np.array_equal(bad.audio(subject, sentence)[0], good.audio(subject, sentence)[0])
    # Frames of a sentence whose audio is missing still read, and vice versa.
    assert np.array_equal(bad.frames(S[1], "sentence01"), good.frames(S[1], "sentence01"))
    assert np.array_equal(bad.audio(S[2], "sentence02")[0], good.audio(S[2], "sentence02")[0])
    assert bad.sentences(S[0]) == ["sentence01"]


@pytest.fixture(scope="module")
def broken_processed(synthetic_corpus_processed, tmp_path_factory):
    root = tmp_path_factory.mktemp("broken") / "processed"
    shutil.copytree(synthetic_corpus_processed, root)

    def edit(name, change):
        data = pickle.loads((root / name).read_bytes())
        change(data)
        (root / name).write_bytes(pickle.dumps(data))

    index = pickle.loads((root / "subj_seq_to_idx.pkl").read_bytes())
    edit("raw_audio_fixed.pkl", lambda d: d[S[1]].pop("sentence01"))
    edit("subj_seq_to_idx.pkl", lambda d: (d[S[0]].pop("sentence02"), d[S[3]]["sentence02"].pop(6)))
    edit("templates.pkl", lambda d: d.__setitem__(S[4], np.zeros((5000, 3))))
    verts = np.load(root / "data_verts.npy", mmap_mode="r+")
    verts[index[S[2]]["sentence01"][10], 7, 0] = np.nan
    verts.flush()
    del verts
    last = index[S[5]]["sentence02"]
    cut = 20 * 5023 * 3 * 4 + 11  # the last 20 frames, and part of one more
    path = root / "data_verts.npy"
    path.write_bytes(path.read_bytes()[:-cut])
    return root, len(last) - 21


def test_processed_scan_reports_every_problem_and_the_rest_reads(broken_processed, synthetic_corpus_processed):
    root, first_cut = broken_processed
    bad, good = open_vocaset(root), open_vocaset(synthetic_corpus_processed)
    expected = {
        (S[0], "sentence02", None, "missing_sentence"),
        (S[1], "sentence01", None, "missing_audio"),
        (S[2], "sentence01", 10, "nan"),
        (S[3], "sentence02", 6, "missing_frame"),
        (S[4], None, None, "vertex_count"),
        (S[5], "sentence02", first_cut, "truncated"),
    }
    assert {(p.subject, p.sentence, p.frame, p.kind) for p in bad.scan()} == expected
    with pytest.raises(VocasetError) as info:
        bad.frames(S[5], "sentence02")
    assert (info.value.kind, info.value.frame) == ("truncated", first_cut)
    with pytest.raises(VocasetError) as info:
        bad.frames(S[2], "sentence01")
    assert (info.value.kind, info.value.frame) == ("nan", 10)
    for subject, sentence in [(S[5], "sentence01"), (S[1], "sentence02"), (S[4], "sentence01")]:
        assert np.array_equal(bad.frames(subject, sentence), good.frames(subject, sentence))
    assert np.array_equal(bad.audio(S[5], "sentence02")[0], good.audio(S[5], "sentence02")[0])
