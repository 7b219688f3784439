import numpy as np
import pytest

from blendvoca.io.coeffs import read_coeffs_csv, write_coeffs_csv
from blendvoca.names import BLENDVOCA_NAMES


def test_round_trip(tmp_path):
    coeffs = np.random.default_rng(0).uniform(size=(20, 32))
    write_coeffs_csv(tmp_path / "a.csv", coeffs, BLENDVOCA_NAMES)
    back, names = read_coeffs_csv(tmp_path / "a.csv")
    assert names == BLENDVOCA_NAMES
    np.testing.assert_allclose(back, coeffs, atol=5e-7)
    text = (tmp_path / "a.csv").read_text()
    assert text.splitlines()[0] == ",".join(BLENDVOCA_NAMES)  # header = names, no index
    assert len(text.splitlines()[1].split(",")) == 32


def test_columns_are_mapped_by_name(tmp_path):
    # Live Link Face order: jawRight before jawLeft, plus columns we do not use.
    (tmp_path / "llf.csv").write_text("Timecode,jawRight,jawLeft,jawOpen\nx,0.1,0.2,0.3\nx,0.4,0.5,0.6\n")
    coeffs, names = read_coeffs_csv(tmp_path / "llf.csv", names=["jawLeft", "jawRight", "jawOpen"])
    assert names == ("jawLeft", "jawRight", "jawOpen")
    np.testing.assert_array_equal(coeffs, [[0.2, 0.1, 0.3], [0.5, 0.4, 0.6]])


def test_missing_column_and_bad_value(tmp_path):
    (tmp_path / "a.csv").write_text("jawOpen\n0.1\n")
    with pytest.raises(ValueError, match=r"missing columns \['jawLeft'\]"):
        read_coeffs_csv(tmp_path / "a.csv", names=["jawOpen", "jawLeft"])
    (tmp_path / "b.csv").write_text("jawOpen\n0.1\nabc\n")
    with pytest.raises(ValueError, match=r"b\.csv: row 3 \(frame 1\)"):
        read_coeffs_csv(tmp_path / "b.csv")
    with pytest.raises(ValueError, match="NaN"):
        write_coeffs_csv(tmp_path / "c.csv", np.array([[np.nan]]), ["jawOpen"])


def test_writing_is_deterministic(tmp_path):
    coeffs = np.array([[-0.0, 1e-9, 0.5]])
    write_coeffs_csv(tmp_path / "a.csv", coeffs, ["jawOpen", "jawLeft", "jawRight"])
    assert (tmp_path / "a.csv").read_text().splitlines()[1] == "0.000000,0.000000,0.500000"


def _livelink_take(path, rows):
    """A take in the layout of a file exported by the Live Link Face app (header of 63
    columns, ``HH:MM:SS:FF.fff`` timecodes with a subframe, count 61, 10 decimals,
    rotations that can be negative)."""
    from blendvoca.names import LIVELINK_HEADER

    lines = [",".join(LIVELINK_HEADER)]
    for t, values in enumerate(rows):
        lines.append(f"00:32:09:{7 + t:02d}.{867 + t:03d},61," + ",".join("%.10f" % v for v in values))
    path.write_text("\r\n".join(lines) + "\r\n")


def test_live_link_face_take_reads_by_name(tmp_path):
    from blendvoca.names import LIVELINK_HEADER

    rng = np.random.default_rng(1)
    rows = rng.uniform(size=(4, 61))
    rows[:, -9:] = rng.uniform(-0.2, 0.2, size=(4, 9))
    _livelink_take(tmp_path / "take.csv", rows)
    coeffs, names = read_coeffs_csv(tmp_path / "take.csv", names=BLENDVOCA_NAMES)
    assert names == BLENDVOCA_NAMES and coeffs.shape == (4, 32)
    for name in ("jawOpen", "jawLeft", "jawRight", "mouthLeft", "mouthRight", "noseSneerRight"):
        column = LIVELINK_HEADER.index(name[0].upper() + name[1:]) - 2
        np.testing.assert_allclose(coeffs[:, BLENDVOCA_NAMES.index(name)], rows[:, column], atol=1e-10)
    # without names: the 52 shapes in camelCase, timecode, count and rotations ignored
    everything, all_names = read_coeffs_csv(tmp_path / "take.csv")
    assert len(all_names) == 52 and all_names[0] == "eyeBlinkLeft" and "HeadYaw" not in all_names


def test_names_match_in_any_case_and_errors_name_the_columns(tmp_path):
    (tmp_path / "a.csv").write_text("Timecode,JawOpen,mouthclose,Smile\nx,0.1,0.2,0.3\n")
    coeffs, names = read_coeffs_csv(tmp_path / "a.csv", names=["jawOpen", "MouthClose"])
    assert names == ("jawOpen", "mouthClose")
    np.testing.assert_array_equal(coeffs, [[0.1, 0.2]])
    with pytest.raises(ValueError, match=r"unknown columns \['Smile'\]"):
        read_coeffs_csv(tmp_path / "a.csv")
    with pytest.raises(ValueError, match=r"missing columns \['jawLeft'\].*no ARKit name: \['Smile'\]"):
        read_coeffs_csv(tmp_path / "a.csv", names=["jawOpen", "jawLeft"])
    (tmp_path / "b.csv").write_text("jawOpen,JawOpen\n0.1,0.2\n")
    with pytest.raises(ValueError, match=r"repeated columns .*\['jawOpen'\]"):
        read_coeffs_csv(tmp_path / "b.csv")


def test_missing_columns_as_zero(tmp_path):
    from blendvoca.io.coeffs import missing_columns

    (tmp_path / "a.csv").write_text("jawOpen,mouthClose\n0.1,0.2\n0.3,0.4\n")
    coeffs, names = read_coeffs_csv(tmp_path / "a.csv", names=["eyeBlinkLeft", "jawOpen", "mouthClose"], missing="zero")
    np.testing.assert_array_equal(coeffs, [[0, 0.1, 0.2], [0, 0.3, 0.4]])
    assert missing_columns(tmp_path / "a.csv", ["eyeBlinkLeft", "JawOpen"]) == ("eyeBlinkLeft",)


def test_a_convention_name_selects_its_columns_in_its_order(tmp_path):
    from blendvoca.names import convention_names

    names = convention_names("arkit52")
    track = np.arange(3 * 52, dtype=np.float64).reshape(3, 52) / 1000.0
    write_coeffs_csv(tmp_path / "t.csv", track, names)
    coeffs, read_names = read_coeffs_csv(tmp_path / "t.csv", names="unitalker51")
    assert read_names == convention_names("unitalker51")
    assert np.allclose(coeffs, track[:, [names.index(n) for n in read_names]])
