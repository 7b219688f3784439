"""Synthetic head motion: command line, bounds, smoothness, the pose convention."""

import json

import numpy as np
from scipy.spatial.transform import Rotation

from blendvoca.synthetic.__main__ import main
from blendvoca.synthetic.headpose import apply_pose, head_motion


def test_head_motion_is_smooth_bounded_and_about_the_pivot():
    pivot = np.array([0.0, -0.05, -0.03])
    rot, trans = head_motion(240, pivot, np.random.default_rng(0), max_angle_deg=3.0)
    euler = np.degrees(Rotation.from_matrix(rot).as_euler("xyz"))
    peaks = np.abs(euler).max(axis=0)
    assert np.all(peaks >= 1.0 - 1e-9) and np.all(peaks <= 3.0 + 1e-9)
    assert np.abs(np.diff(euler, axis=0)).max() < 0.3  # degrees per 60 fps frame: smooth
    shift = trans - (pivot - rot @ pivot)
    assert np.abs(shift).max() <= 0.003 + 1e-12
    # The pivot moves only by the translation part.
    moved = apply_pose(np.broadcast_to(pivot, (240, 1, 3)), rot, trans)[:, 0]
    np.testing.assert_allclose(moved - pivot, shift, atol=1e-15)


def test_cli_writes_posed_frames_and_rejects_bad_angles(tmp_path, capsys):
    out = tmp_path / "posed"
    assert main(["--out", str(out), "--speakers", "3", "--sentences", "1", "--min-duration", "0.8",
                 "--max-duration", "0.8", "--head-motion", "2", "--quiet"]) == 0
    meta = json.loads((out / "synthetic.json").read_text())
    assert meta["head_motion"]["max_angle_deg"] == 2.0
    assert len(list((out / "registereddata" / "Synth_000_TA" / "sentence01").glob("*.ply"))) == 48
    plain = tmp_path / "plain"
    assert main(["--out", str(plain), "--speakers", "3", "--sentences", "1", "--min-duration", "0.8",
                 "--max-duration", "0.8", "--quiet"]) == 0
    assert "head_motion" not in json.loads((plain / "synthetic.json").read_text())
    assert not (plain / "registereddata").exists()
    assert main(["--out", str(tmp_path / "bad"), "--speakers", "3", "--sentences", "1", "--head-motion", "45",
                 "--quiet"]) == 2
    assert "head_motion must be" in capsys.readouterr().err
