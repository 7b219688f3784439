"""FBX through Blender: a 10 s take written and read back gives the same weights, the audio is
named relative to the file, and a request without Blender is one error line with the install
command. The round trips need ``bpy`` (``$BLENDVOCA_BPY_PYTHON``, as tests/export/test_blender.py)."""

from __future__ import annotations

import numpy as np
import pytest

from blendvoca.export import detect_format, export_track, read_track
from tests.export.test_blender import bpy_python


@pytest.fixture
def blender(monkeypatch):
    monkeypatch.setenv("BLENDVOCA_BPY_PYTHON", bpy_python())


def test_a_ten_second_take_round_trips_through_fbx_within_1e_4(tmp_path, small_rig, blender):
    """Issue 57's acceptance: exported and re-imported, the weights agree within 1e-4 per frame and key."""
    from blendvoca.export.fbx import read_fbx
    from blendvoca.io.audio import write_wav

    rng = np.random.default_rng(5)
    t = np.arange(600)[:, None] / 60.0  # 10 s at 60 fps
    coeffs = 0.5 + 0.5 * np.sin(2 * np.pi * (rng.uniform(0.3, 4, 32) * t + rng.uniform(0, 1, 32)))
    coeffs[::97] = rng.uniform(0, 1, (len(coeffs[::97]), 32))  # jumps the exporter must not simplify away
    wav = tmp_path / "take.wav"
    write_wav(wav, np.zeros(16000, np.float32), 16000)
    out = tmp_path / "out" / "take.fbx"
    aligned = export_track(out, coeffs, small_rig.names, "fbx", rig=small_rig, fps=60.0, audio=wav)
    assert detect_format(out) == "fbx" and not [p for p in out.parent.iterdir() if p.name.startswith(".")]
    back, names, fps, audio = read_fbx(out)
    assert fps == pytest.approx(60.0) and back.shape == (600, 32) and set(names) == set(small_rig.names)
    order = [names.index(n) for n in small_rig.names]
    assert np.abs(back[:, order] - aligned.coeffs).max() < 1e-4
    assert audio == "../take.wav"
    coeffs_read, names_read, fps_read = read_track(out)  # the registry's reader agrees
    np.testing.assert_array_equal(coeffs_read, back)
    assert names_read == names and fps_read == fps


def test_fbx_keeps_a_frame_rate_that_is_not_whole(tmp_path, small_rig, track, blender):
    coeffs, names = track
    export_track(tmp_path / "t.fbx", coeffs, names, "fbx", rig=small_rig, fps=59.94)
    back, back_names, fps = read_track(tmp_path / "t.fbx")
    assert fps == pytest.approx(59.94, abs=1e-3) and len(back) == len(coeffs)
    order = [back_names.index(n) for n in names]
    assert np.abs(back[:, order] - coeffs).max() < 1e-4


def test_fbx_without_blender_is_one_error_line_with_the_install_command(tmp_path, small_rig, track, monkeypatch,
                                                                         capsys):
    import importlib.util

    from blendvoca.export.__main__ import main
    from blendvoca.io.coeffs import write_coeffs_csv

    monkeypatch.delenv("BLENDVOCA_BPY_PYTHON", raising=False)
    real_find_spec = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "bpy" else real_find_spec(name, *a))
    coeffs, names = track
    write_coeffs_csv(tmp_path / "t.csv", coeffs, names)
    small_rig.save(tmp_path / "rig.npz")
    out = tmp_path / "t.fbx"
    assert main(["--coeffs", str(tmp_path / "t.csv"), "--format", "fbx", "--rig", str(tmp_path / "rig.npz"),
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("error:") == 1 and "pip install 'bpy==5.0.1'" in err and "BLENDVOCA_BPY_PYTHON" in err
    assert {p.name for p in tmp_path.iterdir()} == {"t.csv", "rig.npz"}  # nothing written
