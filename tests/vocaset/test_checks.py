import numpy as np

from blendvoca.io.audio import write_wav
from blendvoca.vocaset.checks import first_bad_frame, frame_gaps, wav_truncation
from blendvoca.vocaset.processed import open_rows, sentence_name


def test_first_bad_frame():
    x = np.zeros((5, 4, 3))
    assert first_bad_frame(x) is None
    x[3, 2, 1] = np.nan
    x[4, 0, 0] = np.inf
    assert first_bad_frame(x) == 3


def test_frame_gaps():
    assert frame_gaps(np.array([1, 2, 3])) == []
    assert frame_gaps(np.array([1, 2, 5, 6])) == [3, 4]
    assert frame_gaps(np.array([], dtype=int)) == []


def test_wav_truncation(tmp_path):
    path = tmp_path / "a.wav"
    write_wav(path, np.zeros(1000, np.float32), 22000)
    assert wav_truncation(path) is None
    data = path.read_bytes()
    path.write_bytes(data[:-100])
    assert "only 1900 present" in wav_truncation(path)


def test_open_rows_maps_a_truncated_npy_as_far_as_it_goes(tmp_path):
    a = np.arange(10 * 4 * 3, dtype=np.float32).reshape(10, 4, 3)
    path = tmp_path / "v.npy"
    np.save(path, a)
    rows, declared = open_rows(path)
    assert declared == 10 and np.array_equal(rows, a)
    path.write_bytes(path.read_bytes()[: -(4 * 3 * 4) * 3 - 5])  # cut 3 rows and a bit
    rows, declared = open_rows(path)
    assert declared == 10 and len(rows) == 6 and np.array_equal(rows, a[:6])


def test_open_rows_sees_flat_rows_as_vertices_when_given_their_count(tmp_path):
    a = np.arange(5 * 4 * 3, dtype=np.float32).reshape(5, 4, 3)
    path = tmp_path / "flat.npy"
    np.save(path, a.reshape(5, 12))
    assert open_rows(path)[0].shape == (5, 12)
    rows, declared = open_rows(path, 4)
    assert declared == 5 and np.array_equal(rows, a)
    assert open_rows(path, 3)[0].shape == (5, 12)  # rows of another width are left as they are
    path.write_bytes(path.read_bytes()[:128])  # the header only: no row, still seen as vertices
    rows, declared = open_rows(path, 4)
    assert declared == 5 and rows.shape == (0, 4, 3)


def test_sentence_name_accepts_int_and_str_keys():
    assert sentence_name(7) == "sentence07"
    assert sentence_name("7") == "sentence07"
    assert sentence_name("sentence32") == "sentence32"
