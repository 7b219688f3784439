"""``python -m blendvoca.fit``: frames in, coefficient CSV out, one error line on bad input."""

import json
import subprocess
import sys

import numpy as np
import pytest

from blendvoca.fit import StreamingSolver, StreamingSolverConfig
from blendvoca.fit.__main__ import main
from blendvoca.io.coeffs import read_coeffs_csv
from blendvoca.names import BLENDVOCA_NAMES
from blendvoca.rig import Rig

from .conftest import drive, make_rig

NAMES = BLENDVOCA_NAMES[:6]


@pytest.fixture
def files(tmp_path, rng):
    neutral, deltas = make_rig(rng, num_vertices=80, num_shapes=len(NAMES))
    rig = Rig(neutral, deltas, NAMES, np.array([[0, 1, 2]]))
    rig.save(tmp_path / "rig.npz")
    t = np.arange(30)[:, None]
    coeffs = np.clip(0.5 + 0.7 * np.sin(0.2 * t + np.arange(len(NAMES))), 0, 1)
    frames = drive(neutral, deltas, coeffs).astype(np.float32)
    np.save(tmp_path / "frames.npy", frames)
    return tmp_path, rig, frames


def _error_line(capsys):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: "), err
    return err[0]


def test_writes_the_streamed_track(files, capsys):
    folder, rig, frames = files
    assert main(["--rig", str(folder / "rig.npz"), "--frames", str(folder / "frames.npy"),
                 "--out", str(folder / "out.csv")]) == 0
    assert "30 frames solved" in capsys.readouterr().out
    coeffs, names = read_coeffs_csv(folder / "out.csv")
    assert names == NAMES and coeffs.shape == (30, len(NAMES))
    expected = StreamingSolver.from_rig(rig).solve_sequence(frames)
    np.testing.assert_allclose(coeffs, expected, atol=5e-7)  # the CSV's 6 decimals


def test_a2f_config_and_options(files, capsys):
    folder, rig, frames = files
    k = len(NAMES)
    params = {"strengthL1regularization": 1.0, "strengthL2regularization": 0.0, "strengthTemporalSmoothing": 0.0,
              "strengthSymmetry": 0.0, "numPoses": k, "bsSolveActivePoses": [1] * k,
              "bsSolveCancelPoses": [-1] * k, "bsSolveSymmetryPoses": [-1] * k,
              "bsWeightMultipliers": [1.0] * k, "bsWeightOffsets": [0.0] * (k - 1) + [0.25]}
    (folder / "a2f.json").write_text(json.dumps({"blendshape_params": params}))
    assert main(["--rig", str(folder / "rig.npz"), "--frames", str(folder / "frames.npy"), "--out",
                 str(folder / "out.csv"), "--config", str(folder / "a2f.json"), "--config", "rate_bound=0.05",
                 "--quiet"]) == 0
    assert capsys.readouterr().out == ""
    coeffs, _ = read_coeffs_csv(folder / "out.csv")
    config = StreamingSolverConfig.from_a2f(folder / "a2f.json", rate_bound=0.05)
    np.testing.assert_allclose(coeffs, StreamingSolver.from_rig(rig, config).solve_sequence(frames), atol=5e-7)
    assert np.all(coeffs[:, -1] >= 0.25) and np.abs(np.diff(coeffs[:, :-1], axis=0)).max() <= 0.05 + 1e-6


def test_config_file_applied_by_pose_names(files, capsys):
    folder, rig, frames = files
    params = {"strengthL1regularization": 1.0, "strengthL2regularization": 3.5, "strengthTemporalSmoothing": 0.0,
              "strengthSymmetry": 100.0, "numPoses": 3, "bsSolveActivePoses": [1, 0, 1],
              "bsSolveCancelPoses": [-1, -1, -1], "bsSolveSymmetryPoses": [-1, -1, -1],
              "bsWeightMultipliers": [1.0, 1.0, 1.0], "bsWeightOffsets": [0.0, 0.0, 0.0]}
    (folder / "a2f.json").write_text(json.dumps({"blendshape_params": params}))
    (folder / "poses.txt").write_text("EyeBlinkLeft\nJawLeft\n\nJawForward\n")  # the SDK's order, any case
    args = ["--rig", str(folder / "rig.npz"), "--frames", str(folder / "frames.npy"), "--out", str(folder / "out.csv")]
    assert main(args + ["--config", str(folder / "a2f.json"), "--pose-names", str(folder / "poses.txt"),
                        "--quiet"]) == 0
    coeffs, _ = read_coeffs_csv(folder / "out.csv")
    assert np.all(coeffs[:, NAMES.index("jawLeft")] == 0.0)  # inactive by name
    config = StreamingSolverConfig(inactive=("jawLeft",), cancel_pairs=(), symmetry_pairs=())
    np.testing.assert_allclose(coeffs, StreamingSolver.from_rig(rig, config).solve_sequence(frames), atol=5e-7)
    # Without the names the file's 3 poses cannot be applied to the rig's 6 shapes.
    assert main(args + ["--config", str(folder / "a2f.json")]) == 2
    assert "numPoses=3 poses by index, the rig has 6" in _error_line(capsys)
    assert main(args + ["--pose-names", str(folder / "poses.txt")]) == 2
    assert "--pose-names: only with a --config file" in _error_line(capsys)


def test_preset_and_config_entries(files, capsys):
    folder, rig, frames = files
    assert main(["--rig", str(folder / "rig.npz"), "--frames", str(folder / "frames.npy"), "--out",
                 str(folder / "out.csv"), "--preset", "bounded-least-squares", "--config", "objective=a2f",
                 "--config", 'inactive=["jawLeft"]', "--quiet"]) == 0
    coeffs, _ = read_coeffs_csv(folder / "out.csv")
    config = StreamingSolverConfig.bounded_least_squares(objective="a2f", inactive=("jawLeft",))
    np.testing.assert_allclose(coeffs, StreamingSolver.from_rig(rig, config).solve_sequence(frames), atol=5e-7)
    assert np.all(coeffs[:, NAMES.index("jawLeft")] == 0.0)


def test_bad_frames_are_one_error_line_and_nothing_written(files, capsys):
    folder, rig, frames = files
    np.save(folder / "short.npy", frames[:, :70])
    code = main(["--rig", str(folder / "rig.npz"), "--frames", str(folder / "short.npy"),
                 "--out", str(folder / "out.csv")])
    line = _error_line(capsys)
    assert code == 2 and "short.npy" in line and "expected (T, 80, 3)" in line and "got (30, 70, 3)" in line
    assert not (folder / "out.csv").exists()

    bad = frames.copy()
    bad[12, 5, 0] = np.nan
    np.save(folder / "nan.npy", bad)
    code = main(["--rig", str(folder / "rig.npz"), "--frames", str(folder / "nan.npy"), "--out", str(folder / "o.csv")])
    line = _error_line(capsys)
    assert code == 2 and "nan.npy" in line and "frame 12" in line and "vertex 5" in line
    assert not (folder / "o.csv").exists()

    (folder / "text.npy").write_text("not an array")
    assert main(["--rig", str(folder / "rig.npz"), "--frames", str(folder / "text.npy"),
                 "--out", str(folder / "o.csv")]) == 2
    assert "expected a .npy array of shape (T, V, 3)" in _error_line(capsys)

    assert main(["--rig", str(folder / "missing.npz"), "--frames", str(folder / "frames.npy"),
                 "--out", str(folder / "o.csv")]) == 2
    assert "missing.npz" in _error_line(capsys)


def test_bad_config_is_one_error_line(files, capsys):
    folder, _, _ = files
    (folder / "a2f.json").write_text(json.dumps({"blendshape_params": {"numPoses": 6}}))
    code = main(["--rig", str(folder / "rig.npz"), "--frames", str(folder / "frames.npy"),
                 "--out", str(folder / "o.csv"), "--config", str(folder / "a2f.json")])
    line = _error_line(capsys)
    assert code == 2 and "a2f.json" in line and "bsSolveActivePoses is missing" in line
    code = main(["--rig", str(folder / "rig.npz"), "--frames", str(folder / "frames.npy"),
                 "--out", str(folder / "o.csv"), "--config", "rate_bound=-1"])
    assert code == 2 and "rate_bound must be a number > 0" in _error_line(capsys)
    code = main(["--rig", str(folder / "rig.npz"), "--frames", str(folder / "frames.npy"),
                 "--out", str(folder / "o.csv"), "--config", "ratebound=0.1"])
    line = _error_line(capsys)
    assert code == 2 and "unknown keys ['ratebound']" in line and "rate_bound" in line
    code = main(["--rig", str(folder / "rig.npz"), "--frames", str(folder / "frames.npy"),
                 "--out", str(folder / "o.csv"), "--preset", "fast"])
    assert code == 2 and "--preset: expected one of ['sdk', 'bounded-least-squares']" in _error_line(capsys)
    assert not (folder / "o.csv").exists()
    with pytest.raises(SystemExit) as info:
        main(["--rig", str(folder / "rig.npz")])
    assert info.value.code == 2 and "--frames" in _error_line(capsys)


def test_runs_as_a_module(files):
    folder, _, _ = files
    done = subprocess.run([sys.executable, "-m", "blendvoca.fit", "--rig", str(folder / "rig.npz"),
                           "--frames", str(folder / "frames.npy"), "--out", str(folder / "m.csv")],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert (folder / "m.csv").read_text().startswith(",".join(NAMES))


def test_inputs_out_and_scale_are_checked_before_anything_is_written(files, capsys):
    """Issue 56's stream cases: --out on an input or a folder, a frame in other units, a text file as
    --frames, --pose-names that name nothing of the rig or one pose many times."""
    folder, rig, frames = files
    rig_bytes, frames_bytes = (folder / "rig.npz").read_bytes(), (folder / "frames.npy").read_bytes()
    base = ["--rig", str(folder / "rig.npz"), "--frames", str(folder / "frames.npy")]
    for target, flag in ((folder / "frames.npy", "--frames"), (folder / "rig.npz", "--rig")):
        assert main(base + ["--out", str(target)]) == 2
        line = _error_line(capsys)
        assert f"is the {flag} input" in line and str(target) in line
    assert (folder / "rig.npz").read_bytes() == rig_bytes and (folder / "frames.npy").read_bytes() == frames_bytes

    assert main(base + ["--out", str(folder)]) == 2
    line = _error_line(capsys)
    assert str(folder) in line and "a folder is there" in line and not list(folder.glob(".blendvoca-*"))

    huge = frames.copy()
    huge[7] *= 1e30
    np.save(folder / "huge.npy", huge)
    assert main(["--rig", str(folder / "rig.npz"), "--frames", str(folder / "huge.npy"),
                 "--out", str(folder / "o.csv")]) == 2
    line = _error_line(capsys)
    assert "huge.npy" in line and "frame 7" in line and "rig's units" in line and not (folder / "o.csv").exists()

    (folder / "text.npy").write_text("not an array")
    assert main(["--rig", str(folder / "rig.npz"), "--frames", str(folder / "text.npy"),
                 "--out", str(folder / "o.csv")]) == 2
    line = _error_line(capsys)
    assert "not a NumPy .npy file" in line and "pickled" not in line

    k = 3
    params = {"strengthL1regularization": 1.0, "strengthL2regularization": 0.0, "strengthTemporalSmoothing": 0.0,
              "strengthSymmetry": 0.0, "numPoses": k, "bsSolveActivePoses": [0] * k,
              "bsSolveCancelPoses": [-1] * k, "bsSolveSymmetryPoses": [-1] * k,
              "bsWeightMultipliers": [1.0] * k, "bsWeightOffsets": [0.0] * k}
    (folder / "a2f.json").write_text(json.dumps({"blendshape_params": params}))
    config = ["--config", str(folder / "a2f.json"), "--out", str(folder / "o.csv")]
    (folder / "none.txt").write_text("poseA\nposeB\nposeC\n")
    assert main(base + config + ["--pose-names", str(folder / "none.txt")]) == 2
    assert "none of the configuration's 3 pose names" in _error_line(capsys)
    (folder / "same.txt").write_text("jawOpen\n" * k)
    assert main(base + config + ["--pose-names", str(folder / "same.txt")]) == 2
    assert "'jawOpen' 3 times" in _error_line(capsys)
    assert not (folder / "o.csv").exists()
