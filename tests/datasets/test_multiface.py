"""The Multiface reader on small corpora in MeshTalk's topology (6,172 vertices, 30 fps, millimetres)."""

import numpy as np
import pytest

from blendvoca.assets import AssetError
from blendvoca.datasets._vertex import LayoutError
from blendvoca.datasets.multiface import MultifaceCorpus, open_multiface, read_frame
from blendvoca.errors import UserError
from blendvoca.fit.resample import resample_sequence
from blendvoca.io.mesh import write_obj
from blendvoca.vocaset.errors import VocasetError

from .vertex_fixtures import posed_source, truth, write_landmarks, write_multiface

CAPTURE = "m--20180227--0000--6795937--GHS"
SOURCE = "SEN_oh_we_managed_she_said"
SENTENCE = "sentence01"


@pytest.fixture(scope="module")
def source(tmp_path_factory, assets_dir):
    return posed_source(tmp_path_factory.mktemp("posed") / "corpus")


@pytest.fixture(scope="module")
def multiface(tmp_path_factory, source):
    return write_multiface(tmp_path_factory.mktemp("mf") / "multiface", source)


def test_reads_the_layout_at_60_fps_in_metres(multiface, source):
    corpus = open_multiface(multiface)
    assert isinstance(corpus, MultifaceCorpus) and corpus.layout == "multiface" and corpus.posed
    assert corpus.subjects[0] == CAPTURE and len(corpus.subjects) == 3
    assert corpus.sentences(CAPTURE) == [SENTENCE]  # EXP_ sequences are not sentences
    assert corpus.source_name(SENTENCE) == SOURCE
    assert corpus.splits == {"train": [corpus.subjects[0]], "val": [corpus.subjects[1]], "test": [corpus.subjects[2]]}
    folder = multiface / CAPTURE / "tracked_mesh" / SOURCE
    files = sorted(folder.glob("*.bin"))
    assert files[0].name == "021897.bin" and files[0].stat().st_size == 6172 * 3 * 4
    stored = np.stack([read_frame(p) for p in files])
    assert corpus.scale == 0.001  # millimetres, found from the template's size
    frames = corpus.frames(CAPTURE, SENTENCE)
    np.testing.assert_allclose(frames, resample_sequence(stored, 30, 60) / 1000.0, rtol=1e-12)
    assert frames.shape == (2 * len(files), 6172, 3)
    np.testing.assert_allclose(corpus.template(CAPTURE)[:5023], source[0].template(source[0].subjects[0]),
                               atol=1e-7)  # float32 millimetres
    assert corpus.faces.max() == 6171 and np.array_equal(corpus.head_index(), np.arange(6172))
    assert corpus.audio(CAPTURE, SENTENCE)[0].dtype == np.float32 and corpus.problems == []


def test_obj_frames_and_an_own_template(tmp_path, source, multiface):
    root = write_multiface(tmp_path / "obj", source, fmt="obj", captures=(CAPTURE,))
    corpus = open_multiface(root)
    np.testing.assert_allclose(corpus.frames(CAPTURE, SENTENCE), open_multiface(multiface).frames(CAPTURE, SENTENCE),
                               atol=1e-6)
    moved = corpus.template(CAPTURE) * 1000.0 + 1.0
    write_obj(root / CAPTURE / "template.obj", moved, corpus.faces)
    np.testing.assert_allclose(open_multiface(root).template(CAPTURE), moved / 1000.0, atol=1e-9)


def test_release_topology_gaps_and_layout_errors(tmp_path, source):
    root = write_multiface(tmp_path / "bad", source)
    folder = root / CAPTURE / "tracked_mesh" / SOURCE
    np.zeros(7306 * 3, dtype="<f4").tofile(folder / "021898.bin")
    corpus = open_multiface(root)
    with pytest.raises(VocasetError, match=r"7306 vertices, Multiface's release topology; convert the frames to "
                                           r"MeshTalk's 6172-vertex topology"):
        corpus.frames(CAPTURE, SENTENCE)
    other = corpus.subjects[1]
    gap = root / other / "tracked_mesh" / SOURCE
    sorted(gap.glob("*.bin"))[3].unlink()
    with pytest.raises(VocasetError, match=r"frames \[21900\] missing"):
        corpus.frames(other, SENTENCE)
    (root / corpus.subjects[2] / "audio" / f"{SOURCE}.wav").unlink()
    assert ("missing_audio" in {p.kind for p in open_multiface(root).problems})
    with pytest.raises(LayoutError, match=r"not the Multiface layout.*face_template.obj \(MeshTalk's, 6172 vertices\)"):
        open_multiface(tmp_path)
    assert issubclass(LayoutError, UserError)


def test_missing_landmarks_say_what_to_supply(multiface, tmp_path, monkeypatch):
    monkeypatch.setenv("BLENDVOCA_ASSETS", str(tmp_path / "assets"))
    monkeypatch.setenv("BLENDVOCA_CACHE", str(tmp_path / "cache"))
    with pytest.raises(AssetError, match=r"multiface-landmarks.*6,172-vertex face template.*multiface/landmarks68.txt"):
        open_multiface(multiface).landmarks()


def test_the_build_stages_run_on_multiface_frames(multiface, source, tmp_path):
    """Rig transfer with the dataset's landmarks, then the joint fit recovers the capture's head motion."""
    from blendvoca.assets import load_index_list
    from blendvoca.builder.sentence import sentence_fit
    from blendvoca.builder.speaker import speaker_rig
    from blendvoca.rig import load_arkit_reference

    corpus = open_multiface(multiface, landmarks=write_landmarks(tmp_path / "lm.txt"))
    rig = speaker_rig(load_arkit_reference("speech"), corpus.template(CAPTURE), corpus.faces,
                      load_index_list("arkit-landmarks"), corpus.landmarks(), corpus.head_index())
    frames = corpus.frames(CAPTURE, SENTENCE)
    coeffs, stats = sentence_fit(rig, frames, corpus.head_index(), posed=corpus.posed)
    assert coeffs.shape == (len(frames), 32) and stats["pose"]["converged"]
    rotations, _ = truth(source, 0)
    angles = np.degrees(np.arccos(np.clip((np.trace(rotations, axis1=1, axis2=2) - 1) / 2, -1, 1)))
    assert abs(stats["pose"]["rotation_deg_max"] - angles.max()) < 0.5
    assert stats["rmse_mm"] < 1.0  # the head motion alone moves the face by millimetres
