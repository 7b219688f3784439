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
