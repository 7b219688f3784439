"""The BIWI reader on small corpora written in FaceFormer's BIWI layout (23,370 vertices, 25 fps)."""

import pickle

import numpy as np
import pytest

from blendvoca.assets import AssetError
from blendvoca.datasets._vertex import LayoutError, sentence_numbers
from blendvoca.datasets.biwi import BiwiCorpus, open_biwi
from blendvoca.errors import DataError, UserError
from blendvoca.fit.resample import resample_sequence
from blendvoca.io.mesh import write_obj
from blendvoca.vocaset.errors import VocasetError

from .vertex_fixtures import posed_source, truth, write_biwi, write_landmarks


@pytest.fixture(scope="module")
def source(tmp_path_factory, assets_dir):
    return posed_source(tmp_path_factory.mktemp("posed") / "corpus")


@pytest.fixture(scope="module")
def biwi(tmp_path_factory, source):
    return write_biwi(tmp_path_factory.mktemp("biwi") / "BIWI", source)


def test_reads_the_layout_at_60_fps_in_metres(biwi, source):
    corpus = open_biwi(biwi)
    assert isinstance(corpus, BiwiCorpus) and corpus.layout == "biwi" and corpus.posed
    assert corpus.subjects == ["F1", "F2", "F5"] and corpus.sentences("F2") == ["sentence01"]
    assert corpus.source_name("sentence01") == "e01"  # BlendVOCA's name, BIWI's number
    # FaceFormer's training speaker is train, its unseen ones val and test
    assert corpus.splits == {"train": ["F2"], "val": ["F1"], "test": ["F5"]}
    stored = np.load(biwi / "vertices_npy" / "F2_e01.npy")
    assert stored.shape[1] == 70110 and stored.dtype == np.float32
    frames = corpus.frames("F2", "sentence01")
    np.testing.assert_array_equal(frames, resample_sequence(stored.reshape(len(stored), 23370, 3), 25, 60))
    assert frames.shape == (round(len(stored) * 60 / 25), 23370, 3) and corpus.fps == 60
    assert corpus.scale == 1.0
    template = corpus.template("F2")
    np.testing.assert_allclose(template[:5023], source[0].template(source[0].subjects[0]), atol=1e-12)
    assert corpus.faces.shape[1] == 3 and corpus.faces.max() == 23369
    assert np.array_equal(corpus.head_index(), np.arange(23370))
    samples, rate = corpus.audio("F2", "sentence01")
    assert samples.dtype == np.float32 and samples.size > rate // 2
    assert corpus.problems == []


def test_sentence_names_keep_the_corpus_number_or_are_numbered_in_order():
    assert sentence_numbers(["e10", "e01", "e01"]) == {"e01": "sentence01", "e10": "sentence10"}
    assert sentence_numbers(["41", "7"]) == {"41": "sentence41", "7": "sentence07"}
    assert sentence_numbers(["SEN_b", "SEN_a"]) == {"SEN_a": "sentence01", "SEN_b": "sentence02"}
    assert sentence_numbers(["e1", "e01"]) == {"e01": "sentence01", "e1": "sentence02"}  # one number, twice


def test_millimetres_are_found_and_converted(tmp_path, source, biwi):
    mm = open_biwi(write_biwi(tmp_path / "mm", source, scale=1000.0))
    assert mm.scale == 0.001
    np.testing.assert_allclose(mm.template("F1"), open_biwi(biwi).template("F1"), atol=1e-9)
    np.testing.assert_allclose(mm.frames("F1", "sentence01"), open_biwi(biwi).frames("F1", "sentence01"), atol=1e-6)
    assert open_biwi(biwi, units="mm").scale == 0.001  # an explicit unit is taken as said
    with pytest.raises(UserError, match="units: expected auto or one of m, cm, mm"):
        open_biwi(biwi, units="inch")


def test_triangles_from_biwi_rigid_scans_when_there_is_no_biwi_ply(tmp_path, source, biwi):
    root = write_biwi(tmp_path / "scans", source)
    faces = open_biwi(root).faces
    (root / "BIWI.ply").unlink()
    (root / "rigid_scans").mkdir()
    write_obj(root / "rigid_scans" / "F1.obj", open_biwi(root).template("F1"), faces)
    np.testing.assert_array_equal(open_biwi(root).faces, faces)
    (root / "rigid_scans" / "F1.obj").unlink()
    with pytest.raises(LayoutError, match="BIWI.ply .* or rigid_scans/<subject>.obj"):
        open_biwi(root).faces  # noqa: B018


def test_another_layout_names_the_expected_files(tmp_path):
    with pytest.raises(LayoutError, match=r"not the BIWI layout \(missing templates.pkl, vertices_npy, wav\).*"
                                          r"vertices_npy/<subject>_<sentence>.npy \(T, 70110\) at 25 fps"):
        open_biwi(tmp_path)
    assert issubclass(LayoutError, UserError)  # one error: line, exit 2


def test_landmarks_are_supplied_by_the_user(tmp_path, biwi, monkeypatch):
    corpus = open_biwi(biwi)
    text = write_landmarks(tmp_path / "lm.txt").read_text()  # before the asset directory moves
    monkeypatch.setenv("BLENDVOCA_ASSETS", str(tmp_path / "assets"))
    monkeypatch.setenv("BLENDVOCA_CACHE", str(tmp_path / "cache"))
    with pytest.raises(AssetError, match=r"biwi-landmarks.*68 whitespace-separated 0-based vertex indices into the "
                                         r"23,370-vertex\s+BIWI mesh.*biwi/landmarks68.txt"):
        corpus.landmarks()
    (tmp_path / "assets" / "biwi").mkdir(parents=True)
    placed = tmp_path / "assets" / "biwi" / "landmarks68.txt"
    placed.write_text(text)
    assert corpus.landmarks().shape == (68,)
    given = open_biwi(biwi, landmarks=placed)
    assert np.array_equal(given.landmarks(), corpus.landmarks())
    short = tmp_path / "short.txt"
    short.write_text(" ".join(map(str, range(67))))
    with pytest.raises(DataError, match=r"short.txt: holds 67 indices .* expected a text file of 68"):
        open_biwi(biwi, landmarks=short).landmarks()
    with pytest.raises(UserError, match="landmark file not found"):
        open_biwi(biwi, landmarks=tmp_path / "absent.txt").landmarks()


def test_bad_items_are_problems_of_their_own(tmp_path, source):
    root = write_biwi(tmp_path / "bad", source)
    np.save(root / "vertices_npy" / "F5_e01.npy", np.zeros((4, 3 * 5023), dtype=np.float32))
    (root / "wav" / "F1_e01.wav").unlink()
    with open(root / "templates.pkl", "rb") as f:
        templates = pickle.load(f)
    templates["M1"] = templates.pop("F5")[:100]
    with open(root / "templates.pkl", "wb") as f:
        pickle.dump(templates, f, protocol=2)
    corpus = open_biwi(root)
    with pytest.raises(VocasetError, match=r"F5_e01.npy: shape \(4, 15069\), expected \(T, 70110\)"):
        corpus.frames("F5", "sentence01")
    with pytest.raises(VocasetError, match="vertex_count|shape"):
        corpus.template("M1")
    corpus.frames("F2", "sentence01")  # the rest reads
    kinds = {(p.subject, p.kind) for p in corpus.problems}
    assert {("F1", "missing_audio"), ("F5", "missing_template"), ("F5", "vertex_count"), ("M1", "vertex_count")} <= kinds


@pytest.mark.slow
def test_the_build_stages_run_on_biwi_frames(biwi, source, tmp_path):
    """Rig transfer with the dataset's landmarks, then the joint pose and expression fit, unchanged."""
    from blendvoca.assets import load_index_list
    from blendvoca.builder.sentence import sentence_fit
    from blendvoca.builder.speaker import speaker_rig
    from blendvoca.rig import load_arkit_reference

    corpus = open_biwi(biwi, landmarks=write_landmarks(tmp_path / "lm.txt"))
    rig = speaker_rig(load_arkit_reference("speech"), corpus.template("F2"), corpus.faces,
                      load_index_list("arkit-landmarks"), corpus.landmarks(), corpus.head_index())
    frames = corpus.frames("F2", "sentence01")
    coeffs, stats = sentence_fit(rig, frames, corpus.head_index(), posed=corpus.posed)
    assert coeffs.shape == (len(frames), 32) and stats["pose"]["method"] == "joint" and stats["pose"]["converged"]
    rotations, _ = truth(source, 0)  # F2 is the first synthetic speaker
    angles = np.degrees(np.arccos(np.clip((np.trace(rotations, axis1=1, axis2=2) - 1) / 2, -1, 1)))
    assert abs(stats["pose"]["rotation_deg_max"] - angles.max()) < 0.5  # 25 fps sampling, a rig that cannot
    assert stats["rmse_mm"] < 1.0  # explain every synthetic mesh
