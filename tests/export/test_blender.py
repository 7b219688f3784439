"""The Blender add-on, run headless with the ``bpy`` package in a subprocess.

The subprocess is ``$BLENDVOCA_BPY_PYTHON`` (a Python with ``bpy``; CI makes one in
its own virtual environment, since bpy pins an older numpy) or this interpreter.
Skipped where neither has ``bpy``, with :data:`BPY_INSTALL` (a virtual environment of
its own: bpy pins an older numpy); its wheels (about 370 MB) exist for one Python
version per Blender release (3.11 for Blender 4.1 to 5.0). In CI, with ``BLENDVOCA_BPY_PYTHON`` set, a missing ``bpy`` fails.
"""

import functools
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ADDON = Path(__file__).resolve().parents[2] / "blendvoca" / "blender" / "blendvoca_addon.py"
#: How to get bpy without touching this environment: it pins an older numpy, so it gets a virtual environment of
#: its own, as .ci/run makes one.
BPY_INSTALL = ("bpy pins an older numpy, so install it in a virtual environment of its own (not this one, whose "
               "numpy it would downgrade), as .ci/run does: python3.11 -m venv .cache/venv-bpy && "
               ".cache/venv-bpy/bin/python -m pip install 'bpy==5.0.1' && "
               "export BLENDVOCA_BPY_PYTHON=$PWD/.cache/venv-bpy/bin/python (Python 3.11 wheels, ~370 MB)")

SCRIPT = r"""
import importlib.util, json, sys
import numpy as np
import bpy

spec = importlib.util.spec_from_file_location("blendvoca_addon", sys.argv[1])
addon = importlib.util.module_from_spec(spec)
spec.loader.exec_module(addon)
addon.register()
rig_path, track_path, wav_path, frames = sys.argv[2], sys.argv[3], sys.argv[4], json.loads(sys.argv[5])
for obj in list(bpy.data.objects):
    bpy.data.objects.remove(obj)
assert bpy.ops.import_scene.blendvoca_rig(filepath=rig_path) == {"FINISHED"}
obj = bpy.data.objects["rig"]
bpy.context.view_layer.objects.active = obj
assert bpy.ops.import_anim.blendvoca_track(filepath=track_path, audio=wav_path) == {"FINISHED"}
scene = bpy.context.scene
editor = scene.sequence_editor
strips = editor.strips if hasattr(editor, "strips") else editor.sequences
out = {"keys": [b.name for b in obj.data.shape_keys.key_blocks], "fps": scene.render.fps / scene.render.fps_base,
       "range": [scene.frame_start, scene.frame_end], "sounds": [s.sound.filepath for s in strips if s.type == "SOUND"],
       "values": {}, "vertices": {}}
for t in frames:
    scene.frame_set(1 + t)
    out["values"][t] = {b.name: b.value for b in obj.data.shape_keys.key_blocks[1:]}
    depsgraph = bpy.context.evaluated_depsgraph_get()
    mesh = obj.evaluated_get(depsgraph).to_mesh()
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    np.save(sys.argv[6] + f"/v{t}.npy", co.reshape(-1, 3))
# the add-on's own reader (Blender's Python has no blendvoca) agrees with blendvoca's
full = addon.read_track_file(track_path)
sys.modules["blendvoca.export"] = None
own = addon.read_track_file(track_path)
lower = [n.lower() for n in own[1]]
columns = [lower.index(n.lower()) for n in full[1]]
out["readers_agree"] = bool(np.allclose(np.asarray(full[0]), np.asarray(own[0])[:, columns], atol=1e-9))
print("RESULT" + json.dumps(out))
"""


@functools.cache
def bpy_python() -> str:
    """A Python interpreter that imports ``bpy``, or skip (fail in CI when one was named)."""
    named = os.environ.get("BLENDVOCA_BPY_PYTHON")
    python = named or sys.executable
    probe = subprocess.run([python, "-c", "import bpy"], capture_output=True, text=True, timeout=300)
    if probe.returncode != 0:
        reason = (f"bpy (Blender as a Python module) does not import in {python}: {BPY_INSTALL}")
        if named and os.environ.get("CI"):
            pytest.fail(reason)
        pytest.skip(reason)
    return python


def test_addon_imports_rig_and_livelink_track_with_audio(tmp_path, small_rig, track):
    from blendvoca.export import export_track
    from blendvoca.io.audio import write_wav

    coeffs, names = track
    small_rig.save(tmp_path / "rig.npz")
    export_track(tmp_path / "take.csv", coeffs, names, "livelink", fps=60.0)
    write_wav(tmp_path / "take.wav", np.zeros(16000 * 2, np.float32), 16000)
    frames = [0, 37, 119]
    run = subprocess.run([bpy_python(), "-c", SCRIPT, str(ADDON), str(tmp_path / "rig.npz"), str(tmp_path / "take.csv"),
                          str(tmp_path / "take.wav"), json.dumps(frames), str(tmp_path)],
                         capture_output=True, text=True, timeout=300)
    lines = [line for line in run.stdout.splitlines() if line.startswith("RESULT")]
    assert run.returncode == 0 and lines, run.stderr[-3000:]
    out = json.loads(lines[-1][len("RESULT"):])
    assert out["keys"] == ["Basis", *small_rig.names]
    assert out["fps"] == pytest.approx(60.0) and out["range"] == [1, len(coeffs)]
    assert len(out["sounds"]) == 1 and out["sounds"][0].endswith("take.wav")
    assert out["readers_agree"]
    for t in frames:
        values = out["values"][str(t)]
        np.testing.assert_allclose([values[n] for n in names], coeffs[t], atol=1e-6)
        vertices = np.load(tmp_path / f"v{t}.npy")
        np.testing.assert_allclose(vertices, small_rig.evaluate(coeffs[t]), atol=1e-5)


def test_the_skip_message_installs_bpy_beside_this_environment_not_into_it():
    # installing bpy here would pin numpy down; the message points at a virtual environment of its own
    assert "pip install 'blendvoca[blender]'" not in BPY_INSTALL and "-m venv .cache/venv-bpy" in BPY_INSTALL
    assert "BLENDVOCA_BPY_PYTHON=" in BPY_INSTALL and "numpy" in BPY_INSTALL
    ci = (Path(__file__).resolve().parents[2] / ".ci" / "run").read_text()
    assert 'BPY_VENV="$PWD/.cache/venv-bpy"' in ci and '"bpy==5.0.1"' in ci  # the same place and pin as CI
