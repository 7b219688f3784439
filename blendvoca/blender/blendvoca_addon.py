"""BlendVOCA for Blender: import a rig as shape keys and a coefficient track as keyframes.

File > Import > BlendVOCA rig (.npz): a mesh object named after the file, a Basis key
and one shape key per blendshape (the rig's Y-up metres shown Z-up by a 90 degree
rotation of the object, as Blender's glTF importer does).

File > Import > BlendVOCA track (.csv/.json) onto the active object: one linear
keyframe per frame on every shape key whose name the track has (any case; BlendVOCA
CSV, Live Link Face CSV, ARKit JSON or Audio2Face JSON), the scene's frame rate and
range set to the track's, and the audio (a WAV of the same name beside the track, or
the one chosen) as a sound strip from the first frame.

The functions ``build_rig_object``, ``apply_track`` and ``read_track_file`` do the work
and run headless (``pip install bpy``). Blender's own Python lacks the blendvoca
package, so this file carries a small reader of those formats; with blendvoca
importable, its ``blendvoca.export.read_track`` is used instead.
"""

bl_info = {
    "name": "BlendVOCA",
    "author": "BlendVOCA contributors",
    "version": (0, 1, 0),
    "blender": (4, 1, 0),
    "location": "File > Import > BlendVOCA rig / BlendVOCA track",
    "description": "Import BlendVOCA rigs as shape keys and speech-driven coefficient tracks as keyframes with audio",
    "category": "Import-Export",
}

import csv
import json
import math
import os

import bpy
from bpy.props import StringProperty
from bpy_extras.io_utils import ImportHelper

# Columns of Live Link Face exports that carry no shape weight.
_IGNORED = {"timecode", "blendshapecount", "headyaw", "headpitch", "headroll", "lefteyeyaw", "lefteyepitch",
            "lefteyeroll", "righteyeyaw", "righteyepitch", "righteyeroll"}


def read_track_file(path, fps=60.0):
    """``(rows, names, fps)`` of a track file: rows a list of T lists of K floats.

    CSV (BlendVOCA/SAiD or Live Link Face; CSVs store no rate, ``fps`` is returned),
    ARKit JSON (``blendShapeNames``/``weights``/``frameRate``) or Audio2Face JSON
    (``facsNames``/``weightMat``/``exportFps``).
    """
    try:
        from blendvoca.export import read_track
    except ImportError:
        read_track = None
    if read_track is not None:
        coeffs, names, rate = read_track(path, fps=fps)
        return [list(map(float, row)) for row in coeffs], list(names), float(rate)
    if path.lower().endswith(".json"):
        with open(path, encoding="utf-8") as f:
            doc = json.load(f)
        if "weightMat" in doc:
            return doc["weightMat"], list(doc["facsNames"]), float(doc["exportFps"])
        if "blendShapeNames" in doc:
            return doc["weights"], list(doc["blendShapeNames"]), float(doc["frameRate"])
        raise ValueError(f"{path}: neither ARKit (blendShapeNames) nor Audio2Face (weightMat) weights")
    with open(path, newline="", encoding="utf-8-sig") as f:
        reader = csv.reader(f)
        header = [h.strip() for h in next(reader)]
        keep = [i for i, h in enumerate(header) if h.lower() not in _IGNORED]
        rows = [[float(row[i]) for i in keep] for row in reader if row]
    return rows, [header[i] for i in keep], float(fps)


def build_rig_object(name, neutral, faces, deltas, names, collection=None):
    """A mesh object with a Basis key and one shape key per blendshape.

    Parameters
    ----------
    name : str
    neutral : (V, 3) array_like, faces : (F, 3) array_like, deltas : (K, V, 3) array_like
    names : K str
    collection : bpy.types.Collection, default the scene's

    Returns
    -------
    bpy.types.Object
    """
    import numpy as np

    neutral = np.asarray(neutral, dtype=np.float64)
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(neutral.tolist(), [], np.asarray(faces, dtype=np.int64).tolist())
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    (collection or bpy.context.scene.collection).objects.link(obj)
    obj.rotation_euler = (math.pi / 2, 0.0, 0.0)  # Y-up rig, Z-up Blender
    obj.shape_key_add(name="Basis", from_mix=False)
    for shape, delta in zip(names, deltas):
        key = obj.shape_key_add(name=str(shape), from_mix=False)
        key.data.foreach_set("co", (neutral + np.asarray(delta, dtype=np.float64)).astype(np.float32).ravel())
    mesh.update()
    return obj


def load_rig_npz(path):
    """``(neutral, faces, deltas, names)`` of a BlendVOCA rig ``.npz``."""
    import numpy as np

    with np.load(path, allow_pickle=False) as data:
        missing = {"neutral", "deltas", "names", "faces"} - set(data.files)
        if missing:
            raise ValueError(f"{path}: not a BlendVOCA rig file, missing arrays {sorted(missing)}")
        return data["neutral"], data["faces"], data["deltas"], [str(n) for n in data["names"]]


def _fcurves(action, animation_data):
    """The F-curve collection of an action: its own (Blender < 4.4) or its slot's channelbag."""
    if hasattr(action, "fcurves"):
        return action.fcurves
    from bpy_extras import anim_utils

    return anim_utils.action_get_channelbag_for_slot(action, animation_data.action_slot).fcurves


def apply_track(obj, rows, names, fps=60.0, audio=None, frame_start=1):
    """Keyframe ``obj``'s shape keys with a track; returns the names keyed.

    Frame ``t`` of the track is scene frame ``frame_start + t``; the scene's rate is set
    to ``fps`` and its range to the track. Track names match shape keys in any case;
    shape keys the track lacks are not touched. With ``audio``, a sound strip starts at
    ``frame_start``.
    """
    key = obj.data.shape_keys
    if key is None:
        raise ValueError(f"{obj.name} has no shape keys; import a BlendVOCA rig first")
    blocks = {b.name.lower(): b for b in key.key_blocks[1:]}
    columns = [(k, blocks[n.lower()]) for k, n in enumerate(names) if n.lower() in blocks]
    if not columns:
        raise ValueError(f"none of the track's names {list(names)[:4]}... is a shape key of {obj.name}")
    count = len(rows)
    scene = bpy.context.scene
    scene.render.fps = max(int(round(fps)), 1)
    scene.render.fps_base = scene.render.fps / float(fps)
    scene.frame_start = frame_start
    scene.frame_end = frame_start + count - 1
    keyed = []
    for k, block in columns:
        block.value = float(rows[0][k])
        block.keyframe_insert("value", frame=frame_start)
        fcurve = _fcurves(key.animation_data.action, key.animation_data).find(f'key_blocks["{block.name}"].value')
        points = fcurve.keyframe_points
        points.add(count - 1)
        flat = []
        for t in range(count):
            flat += [float(frame_start + t), float(rows[t][k])]
        points.foreach_set("co", flat)
        for point in points:
            point.interpolation = "LINEAR"
        fcurve.update()
        keyed.append(block.name)
    if audio:
        editor = scene.sequence_editor or scene.sequence_editor_create()
        strips = editor.strips if hasattr(editor, "strips") else editor.sequences
        strips.new_sound(os.path.splitext(os.path.basename(audio))[0], audio, 1, frame_start)
    return keyed


class IMPORT_OT_blendvoca_rig(bpy.types.Operator, ImportHelper):
    """Import a BlendVOCA rig (.npz) as a mesh with shape keys"""

    bl_idname = "import_scene.blendvoca_rig"
    bl_label = "Import BlendVOCA rig"
    filename_ext = ".npz"
    filter_glob: StringProperty(default="*.npz", options={"HIDDEN"})

    def execute(self, context):
        try:
            neutral, faces, deltas, names = load_rig_npz(self.filepath)
        except (OSError, ValueError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        obj = build_rig_object(os.path.splitext(os.path.basename(self.filepath))[0], neutral, faces, deltas, names)
        context.view_layer.objects.active = obj
        obj.select_set(True)
        self.report({"INFO"}, f"{obj.name}: {len(names)} shape keys")
        return {"FINISHED"}


class IMPORT_OT_blendvoca_track(bpy.types.Operator, ImportHelper):
    """Import a coefficient track (.csv or .json) as shape-key keyframes on the active object"""

    bl_idname = "import_anim.blendvoca_track"
    bl_label = "Import BlendVOCA track"
    filter_glob: StringProperty(default="*.csv;*.json", options={"HIDDEN"})
    audio: StringProperty(name="Audio", description="WAV to add as a sound strip (default: <track>.wav beside it)",
                          subtype="FILE_PATH", default="")

    def execute(self, context):
        obj = context.active_object
        if obj is None or obj.type != "MESH":
            self.report({"ERROR"}, "select the mesh with the shape keys first")
            return {"CANCELLED"}
        try:
            rows, names, fps = read_track_file(self.filepath)
            audio = self.audio or os.path.splitext(self.filepath)[0] + ".wav"
            keyed = apply_track(obj, rows, names, fps, audio if os.path.isfile(audio) else None)
        except (OSError, ValueError, KeyError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self.report({"INFO"}, f"{len(rows)} frames on {len(keyed)} shape keys at {fps:g} fps")
        return {"FINISHED"}


def _menu(self, context):
    self.layout.operator(IMPORT_OT_blendvoca_rig.bl_idname, text="BlendVOCA rig (.npz)")
    self.layout.operator(IMPORT_OT_blendvoca_track.bl_idname, text="BlendVOCA track (.csv/.json)")


def register():
    bpy.utils.register_class(IMPORT_OT_blendvoca_rig)
    bpy.utils.register_class(IMPORT_OT_blendvoca_track)
    bpy.types.TOPBAR_MT_file_import.append(_menu)


def unregister():
    bpy.types.TOPBAR_MT_file_import.remove(_menu)
    bpy.utils.unregister_class(IMPORT_OT_blendvoca_track)
    bpy.utils.unregister_class(IMPORT_OT_blendvoca_rig)
