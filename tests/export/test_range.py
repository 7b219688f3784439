"""Weights outside [0, 1] are refused by every export format (as the benchmark refuses
them) unless clipped on request, which says how many values moved."""

import numpy as np
import pytest

from blendvoca.errors import UserError
from blendvoca.export import export_track, read_track


def _out_of_range(track):
    coeffs, names = track
    coeffs = np.array(coeffs[:10], dtype=np.float64)
    coeffs[4, names.index("jawOpen")] = -0.4
    coeffs[7, names.index("mouthClose")] = 1.7
    return coeffs, names


@pytest.mark.parametrize("fmt, suffix", [("livelink", ".csv"), ("arkit-json", ".json"), ("a2f-json", ".json"),
                                         ("csv", ".csv")])
def test_export_refuses_weights_outside_the_unit_range(fmt, suffix, track, tmp_path):
    coeffs, names = _out_of_range(track)
    out = tmp_path / f"t{suffix}"
    with pytest.raises(UserError, match=r"2 value\(s\) outside \[0, 1\].*frame 4, column 'jawOpen': -0.4"):
        export_track(out, coeffs, names, fmt)
    assert not out.exists()
    aligned = export_track(out, coeffs, names, fmt, clip=True)
    assert aligned.clipped == 2 and any("2 value(s) outside [0, 1] were clipped" in n for n in aligned.notes())
    back, back_names, _ = read_track(out)
    assert back.min() >= 0.0 and back.max() <= 1.0
    assert back[4, back_names.index("jawOpen")] == 0.0 and back[7, back_names.index("mouthClose")] == 1.0


def test_cli_refuses_then_clips_and_says_how_many(track, tmp_path, capsys):
    from blendvoca.export.__main__ import main

    coeffs, names = _out_of_range(track)
    csv = tmp_path / "t.csv"
    header = ",".join(names)
    rows = [",".join(f"{v:.4f}" for v in row) for row in coeffs]
    csv.write_text(header + "\n" + "\n".join(rows) + "\n")
    out = tmp_path / "t.json"
    assert main(["--coeffs", str(csv), "--format", "arkit-json", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err
    assert str(csv) in lines[0] and "frame 4, column 'jawOpen'" in lines[0] and "--clip" in lines[0]
    assert not out.exists()
    assert main(["--coeffs", str(csv), "--format", "arkit-json", "--out", str(out), "--clip"]) == 0
    assert "note: 2 value(s) outside [0, 1] were clipped" in capsys.readouterr().err
    back, _, _ = read_track(out)
    assert back.min() >= 0.0 and back.max() <= 1.0
