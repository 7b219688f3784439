"""FBX (Autodesk): the rig as a mesh with blend shapes and the track as their animation,
written and read back through Blender (the ``bpy`` package), the FBX writer Unity, Maya,
MotionBuilder and Unreal users already trust.

Blender runs in a subprocess: ``$BLENDVOCA_BPY_PYTHON`` (a Python with ``bpy``; bpy pins
an older numpy, so it usually has a virtual environment of its own) or this interpreter
when it imports ``bpy``. The mesh is built by the project's Blender add-on
(:mod:`blendvoca.blender.blendvoca_addon`: shape keys, one linear keyframe per frame),
exported with every frame baked (no curve simplification), at the track's frame rate; the
audio is referenced by its path relative to the file, in the mesh object's user property
``blendvoca_audio`` (FBX has no sound track that the importers read).

Reading imports the file into an empty Blender scene and reads the shape keys' baked keys
(one per frame): ``(coeffs, names, fps)`` like every other format.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError, UserError
from blendvoca.export.align import AlignedTrack, align_track
from blendvoca.export.base import ExportFormat, ExportOptions, audio_reference, export_audio

#: The Blender add-on that builds the rig object and keys the track (run inside Blender).
ADDON = Path(__file__).resolve().parents[1] / "blender" / "blendvoca_addon.py"
#: How to get Blender as a Python module without touching this environment (bpy pins an older numpy).
BPY_INSTALL = ("python3.11 -m venv .cache/venv-bpy && .cache/venv-bpy/bin/python -m pip install 'bpy==5.0.1' && "
               "export BLENDVOCA_BPY_PYTHON=$PWD/.cache/venv-bpy/bin/python")
#: The name of the FBX mesh object, and of its user property that names the audio.
OBJECT_NAME, AUDIO_PROPERTY = "BlendVOCA_face", "blendvoca_audio"

_WRITE = r"""
import importlib.util, json, sys
import numpy as np
import bpy

spec = importlib.util.spec_from_file_location("blendvoca_addon", sys.argv[1])
addon = importlib.util.module_from_spec(spec)
spec.loader.exec_module(addon)
job = json.loads(open(sys.argv[2], encoding="utf-8").read())
bpy.ops.wm.read_factory_settings(use_empty=True)
rig = np.load(job["rig"], allow_pickle=False)
obj = addon.build_rig_object(job["object"], rig["neutral"], rig["faces"], rig["deltas"], job["names"])
weights = np.load(job["weights"], allow_pickle=False)
addon.apply_track(obj, weights.tolist(), job["names"], fps=job["fps"])
if job["audio"] is not None:
    obj[job["audio_property"]] = job["audio"]
for other in bpy.context.scene.objects:
    other.select_set(other is obj)
bpy.context.view_layer.objects.active = obj
result = bpy.ops.export_scene.fbx(
    filepath=job["out"], use_selection=True, object_types={"MESH"}, use_mesh_modifiers=False,
    add_leaf_bones=False, bake_anim=True, bake_anim_use_all_bones=False, bake_anim_use_nla_strips=False,
    bake_anim_use_all_actions=False, bake_anim_force_startend_keying=True, bake_anim_step=1.0,
    bake_anim_simplify_factor=0.0, use_custom_props=True, axis_forward="-Z", axis_up="Y")
if result != {"FINISHED"}:
    sys.exit(f"Blender's FBX exporter returned {result}")
"""

_READ = r"""
import importlib.util, json, sys
import bpy

spec = importlib.util.spec_from_file_location("blendvoca_addon", sys.argv[1])
addon = importlib.util.module_from_spec(spec)
spec.loader.exec_module(addon)
bpy.ops.wm.read_factory_settings(use_empty=True)
result = bpy.ops.import_scene.fbx(filepath=sys.argv[2], use_custom_props=True)
if result != {"FINISHED"}:
    sys.exit(f"Blender's FBX importer returned {result}")
scene = bpy.context.scene
meshes = [o for o in scene.objects if o.type == "MESH" and o.data.shape_keys is not None]
if not meshes:
    sys.exit("no mesh with blend shapes in the file")
obj = meshes[0]
key = obj.data.shape_keys
if key.animation_data is None or key.animation_data.action is None:
    sys.exit("the blend shapes are not animated")
curves = addon._fcurves(key.animation_data.action, key.animation_data)
names, columns = [], []
for block in list(key.key_blocks)[1:]:
    curve = curves.find(f'key_blocks["{block.name}"].value')
    names.append(block.name)
    # the baked keys themselves (one per frame): sampling the scene at whole frames would
    # interpolate between keys wherever the file's rate is not a whole number of frames per second
    columns.append(None if curve is None else [point.co[1] for point in curve.keyframe_points])
counts = {len(c) for c in columns if c is not None}
if len(counts) != 1:
    sys.exit(f"the blend shapes have different key counts {sorted(counts)}; expected one key per frame each")
count = counts.pop()
rows = [[column[t] if column is not None else block.value for column, block in zip(columns, list(key.key_blocks)[1:])]
        for t in range(count)]
fps = scene.render.fps / scene.render.fps_base
audio = obj.get(sys.argv[4])
json.dump({"names": names, "rows": rows, "fps": fps, "audio": None if audio is None else str(audio)},
          open(sys.argv[3], "w", encoding="utf-8"))
"""


def blender_python() -> str:
    """The Python that runs Blender: ``$BLENDVOCA_BPY_PYTHON``, else this interpreter when it
    has ``bpy``.

    Raises
    ------
    UserError
        Neither has ``bpy`` (the message gives the install command).
    """
    import importlib.util

    named = os.environ.get("BLENDVOCA_BPY_PYTHON")
    if named:
        if not shutil.which(named) and not Path(named).is_file():
            raise UserError(f"BLENDVOCA_BPY_PYTHON={named}: no such program; FBX needs a Python with Blender's "
                            f"bpy: {BPY_INSTALL}")
        return named
    if importlib.util.find_spec("bpy") is not None:
        return sys.executable
    raise UserError(f"the fbx format is written through Blender (the bpy package), which this Python lacks; "
                    f"install it in a virtual environment of its own (bpy pins an older numpy): {BPY_INSTALL}")


def _run_blender(script: str, args: list[str], what: str) -> None:
    done = subprocess.run([blender_python(), "-c", script, *args], capture_output=True, text=True)
    if done.returncode != 0:
        lines = [line for line in (done.stderr or done.stdout).strip().splitlines() if line.strip()]
        if any("No module named 'bpy'" in line for line in lines):
            raise UserError(f"{blender_python()} has no bpy; FBX needs Blender as a Python module: {BPY_INSTALL}")
        raise DataError(f"{what}: Blender failed: {lines[-1] if lines else f'exit status {done.returncode}'}")


def write_fbx(path, rig, coeffs, names, fps: float = 60.0, audio=None) -> AlignedTrack:
    """Write an FBX of ``rig`` animated by a track, atomically (through Blender).

    Parameters
    ----------
    path : .fbx
    rig : blendvoca.rig.Rig
    coeffs : (T, K) track, columns ``names`` (mapped to ``rig.names`` by name)
    fps : float
    audio : path of a sound file, optional (named relative to ``path`` in a user property)
    """
    path = Path(os.fspath(path))
    if path.suffix.lower() != ".fbx":
        raise UserError(f"write_fbx: {path}: expected a .fbx file")
    aligned = align_track(coeffs, names, rig.names, where="fbx")
    path.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=f".{path.stem}.", dir=path.parent) as work:
        work = Path(work)
        np.savez(work / "rig.npz", neutral=rig.neutral, faces=rig.faces, deltas=rig.deltas)
        np.save(work / "weights.npy", np.asarray(aligned.coeffs, dtype=np.float64))
        partial = work / path.name
        job = {"rig": str(work / "rig.npz"), "weights": str(work / "weights.npy"), "names": list(aligned.names),
               "fps": float(fps), "object": OBJECT_NAME, "out": str(partial), "audio_property": AUDIO_PROPERTY,
               "audio": None if audio is None else audio_reference(audio, path)}
        (work / "job.json").write_text(json.dumps(job), encoding="utf-8")
        _run_blender(_WRITE, [str(ADDON), str(work / "job.json")], str(path))
        os.replace(partial, path)
    return aligned


def read_fbx(path) -> tuple[np.ndarray, tuple[str, ...], float, str | None]:
    """``(coeffs (T, K), names, fps, audio)`` of an FBX's animated blend shapes (through Blender);
    ``audio`` is the ``blendvoca_audio`` property or None."""
    path = Path(os.fspath(path))
    if not path.is_file():
        raise FileNotFoundError(f"FBX file not found: {path}")
    with tempfile.TemporaryDirectory(prefix=".fbx-read-") as work:
        out = Path(work) / "track.json"
        _run_blender(_READ, [str(ADDON), str(path.resolve()), str(out), AUDIO_PROPERTY], str(path))
        doc = json.loads(out.read_text(encoding="utf-8"))
    coeffs = np.asarray(doc["rows"], dtype=np.float64).reshape(len(doc["rows"]), len(doc["names"]))
    return coeffs, tuple(doc["names"]), float(doc["fps"]), doc["audio"]


class Fbx(ExportFormat):
    """``fbx``: mesh, blend shapes and their animation, written by Blender (needs a rig and ``bpy``)."""

    name, suffix, needs_rig = "fbx", ".fbx", True

    def write(self, out, coeffs, names, options: ExportOptions) -> AlignedTrack:
        blender_python()  # refused before anything is copied when Blender is missing
        return write_fbx(out, options.rig, coeffs, names, options.fps, audio=export_audio(options, out))

    def read(self, path, *, fps: float):
        coeffs, names, file_fps, _ = read_fbx(path)
        return coeffs, names, file_fps
