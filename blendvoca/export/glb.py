"""glTF 2.0 binary (GLB) of a rig with a weights animation, written with pygltflib.

One node and mesh: the neutral as POSITION, the triangles as uint32 indices, one
morph target (POSITION offsets) per blendshape named in ``mesh.extras.targetNames``
(the convention three.js, Babylon.js and Blender read), and one animation whose
"weights" channel has one linear key per frame (``T * K`` outputs, frame-major).
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError
from blendvoca.export._support import foreign_parser, optional_module
from blendvoca.export.align import AlignedTrack, align_track
from blendvoca.export.base import ExportFormat, ExportOptions, RigAnimation
from blendvoca.io.atomic import atomic_write

_FLOAT, _UINT32 = 5126, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963


#: What :func:`read_glb` recovers (the names from ``extras.targetNames``).
GlbContents = RigAnimation


def glb_bytes(rig, coeffs, names: Sequence[str], fps: float = 60.0) -> tuple[bytes, AlignedTrack]:
    """The GLB file of ``rig`` animated by a track (columns mapped to ``rig.names`` by
    name; rig shapes the track lacks stay at 0)."""
    g = optional_module("pygltflib", "pygltflib", "the glb format")

    aligned = align_track(coeffs, names, rig.names, where="glb")
    neutral = np.asarray(rig.neutral, dtype=np.float32)
    deltas = np.asarray(rig.deltas, dtype=np.float32)
    faces = np.asarray(rig.faces, dtype=np.uint32)
    count = len(aligned.coeffs)
    times = (np.arange(count) / float(fps)).astype(np.float32)
    weights = aligned.coeffs.astype(np.float32)

    blob = bytearray()
    views, accessors = [], []

    def add(array: np.ndarray, component: int, kind: str, target=None, bounds: bool = False) -> int:
        while len(blob) % 4:
            blob.append(0)
        data = np.ascontiguousarray(array).tobytes()
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data), target=target))
        blob.extend(data)
        flat = array.reshape(len(array), -1) if array.ndim > 1 else array.reshape(-1, 1)
        accessor = g.Accessor(bufferView=len(views) - 1, componentType=component, count=len(flat), type=kind)
        if bounds:
            accessor.min = [float(v) for v in flat.min(axis=0)]
            accessor.max = [float(v) for v in flat.max(axis=0)]
        accessors.append(accessor)
        return len(accessors) - 1

    position = add(neutral, _FLOAT, "VEC3", _ARRAY_BUFFER, bounds=True)
    indices = add(faces.reshape(-1), _UINT32, "SCALAR", _ELEMENT_ARRAY_BUFFER)
    targets = [{"POSITION": add(d, _FLOAT, "VEC3", _ARRAY_BUFFER, bounds=True)} for d in deltas]
    time_accessor = add(times, _FLOAT, "SCALAR", bounds=True)
    weight_accessor = add(weights.reshape(-1), _FLOAT, "SCALAR")

    primitive = g.Primitive(attributes=g.Attributes(POSITION=position), indices=indices, mode=4,
                            targets=targets)
    mesh = g.Mesh(name="face", primitives=[primitive], weights=[0.0] * len(rig.names),
                  extras={"targetNames": list(rig.names)})
    animation = g.Animation(name="speech", samplers=[g.AnimationSampler(input=time_accessor, output=weight_accessor,
                                                                        interpolation="LINEAR")],
                            channels=[g.AnimationChannel(sampler=0, target=g.AnimationChannelTarget(node=0, path="weights"))])
    gltf = g.GLTF2(
        asset=g.Asset(version="2.0", generator="BlendVOCA blendvoca.export"),
        scene=0, scenes=[g.Scene(nodes=[0])], nodes=[g.Node(name="face", mesh=0)], meshes=[mesh],
        animations=[animation], accessors=accessors, bufferViews=views,
        buffers=[g.Buffer(byteLength=len(blob))],
    )
    gltf.set_binary_blob(bytes(blob))
    return b"".join(gltf.save_to_bytes()), aligned


def write_glb(path, rig, coeffs, names: Sequence[str], fps: float = 60.0) -> AlignedTrack:
    """Write the GLB of a rig and track, atomically."""
    data, aligned = glb_bytes(rig, coeffs, names, fps)
    with atomic_write(path, "wb") as f:
        f.write(data)
    return aligned


def read_glb(path) -> GlbContents:
    """Read back the mesh, morph targets and weights animation of a GLB written here
    (or any GLB whose first mesh has morph targets and whose first animation drives them).

    Raises
    ------
    DataError
        Naming the file and what is wrong: not a GLB pygltflib can parse, no mesh or
        animation, an accessor that points outside the file's buffer or has a type this
        reader does not know, or keys and weights whose counts disagree.
    """
    g = optional_module("pygltflib", "pygltflib", "the glb format")

    # pygltflib parses the container and the JSON chunk into objects whose fields hold
    # whatever the file held (a string where a count belongs, a list where an object
    # belongs); it and the lookups below raise many types on a damaged file, all of
    # which mean "not a readable GLB"
    with foreign_parser(path, "GLB file"):
        with warnings.catch_warnings():
            # on a damaged file pygltflib warns (an unknown version or chunk type) and asks
            # the user to report it upstream; the error below says what is wrong instead
            warnings.simplefilter("ignore")
            gltf = g.GLTF2().load_binary(os.fspath(path))
        if gltf is None:
            raise DataError(f"{path}: not a GLB file (no glTF binary header)")
        return _glb_contents(gltf, gltf.binary_blob() or b"", path)


def _glb_contents(gltf, blob: bytes, path) -> GlbContents:
    """The contents of a parsed GLB (:func:`read_glb`)."""
    if not gltf.meshes or not gltf.meshes[0].primitives:
        raise DataError(f"{path}: the GLB has no mesh")

    def read(index, what: str) -> np.ndarray:
        if not isinstance(index, int) or not 0 <= index < len(gltf.accessors or []):
            raise DataError(f"{path}: the {what} names accessor {index!r}, which the GLB lacks")
        accessor = gltf.accessors[index]
        if not isinstance(accessor.bufferView, int) or not 0 <= accessor.bufferView < len(gltf.bufferViews or []):
            raise DataError(f"{path}: the {what} accessor names buffer view {accessor.bufferView!r}, "
                            f"which the GLB lacks")
        view = gltf.bufferViews[accessor.bufferView]
        width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}.get(accessor.type)
        dtype = {_FLOAT: "<f4", _UINT32: "<u4", 5123: "<u2", 5121: "u1"}.get(accessor.componentType)
        if width is None or dtype is None:
            raise DataError(f"{path}: the {what} accessor has type {accessor.type!r} / component type "
                            f"{accessor.componentType!r}, which this reader does not know")
        start = (view.byteOffset or 0) + (accessor.byteOffset or 0)
        size = accessor.count * width * np.dtype(dtype).itemsize if isinstance(accessor.count, int) else -1
        if size < 0 or start < 0 or start + size > len(blob):
            raise DataError(f"{path}: the {what} accessor ({accessor.count!r} x {accessor.type}) lies outside "
                            f"the GLB's {len(blob)}-byte buffer")
        array = np.frombuffer(blob, dtype=dtype, count=accessor.count * width, offset=start)
        return array.reshape(accessor.count, width) if width > 1 else array

    mesh = gltf.meshes[0]
    primitive = mesh.primitives[0]
    neutral = read(primitive.attributes.POSITION, "POSITION").astype(np.float64)
    if neutral.ndim != 2 or neutral.shape[1] != 3:
        raise DataError(f"{path}: the POSITION accessor is not VEC3")
    faces = read(primitive.indices, "indices").astype(np.int64)
    if faces.size % 3:
        raise DataError(f"{path}: {faces.size} triangle indices, not a multiple of 3")
    faces = faces.reshape(-1, 3)
    targets = primitive.targets or []
    deltas = [read(t["POSITION"], f"morph target {k}").astype(np.float64) for k, t in enumerate(targets)]
    if any(d.shape != neutral.shape for d in deltas):
        raise DataError(f"{path}: a morph target's offsets do not match the {len(neutral)} vertices")
    deltas = np.stack(deltas) if deltas else np.zeros((0, *neutral.shape))
    names = (mesh.extras or {}).get("targetNames", [f"target{k}" for k in range(len(targets))])
    if (not isinstance(names, list) or len(names) != len(targets)
            or not all(isinstance(n, str) for n in names)):
        raise DataError(f"{path}: extras.targetNames is not a list of {len(targets)} names (one per morph target)")
    if not gltf.animations or not gltf.animations[0].channels:
        raise DataError(f"{path}: the GLB has no animation")
    animation = gltf.animations[0]
    index = animation.channels[0].sampler
    if not isinstance(index, int) or not 0 <= index < len(animation.samplers or []):
        raise DataError(f"{path}: the animation's channel names sampler {index!r}, which it lacks")
    sampler = animation.samplers[index]
    times = read(sampler.input, "animation input").astype(np.float64).reshape(-1)
    if not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
        raise DataError(f"{path}: the animation's key times are not finite and increasing")
    weights = read(sampler.output, "animation output").astype(np.float64).reshape(-1)
    if weights.size != len(times) * len(targets):
        raise DataError(f"{path}: {weights.size} animation weights for {len(times)} keys x {len(targets)} targets")
    weights = weights.reshape(len(times), len(targets))
    return GlbContents(neutral, faces, deltas, tuple(names), times, weights)


def validate_glb(path, validator: str | Path | None = None) -> dict:
    """Run the Khronos glTF validator (npm ``gltf-validator``) on a file.

    Parameters
    ----------
    path : the .glb
    validator : folder holding ``node_modules/gltf-validator`` (default: the
        ``BLENDVOCA_NODE_MODULES`` environment variable's parent, else ``.cache/npm``)

    Returns
    -------
    dict : the validator's report (``report["issues"]["numErrors"]`` ...)
    """
    import json
    import shutil
    import subprocess

    node = shutil.which("node")
    if node is None:
        raise RuntimeError("validate_glb needs node (Node.js) on PATH")
    root = Path(validator) if validator else Path(os.environ.get("BLENDVOCA_NPM_PREFIX", ".cache/npm"))
    module = root / "node_modules" / "gltf-validator"
    if not module.is_dir():
        raise RuntimeError(f"validate_glb: gltf-validator not found under {root}; "
                           f"install it with: npm install --prefix {root} gltf-validator")
    script = ("const v=require(process.argv[1]);const fs=require('fs');"
              "v.validateBytes(new Uint8Array(fs.readFileSync(process.argv[2])))"
              ".then(r=>{console.log(JSON.stringify(r));}).catch(e=>{console.error(e);process.exit(1);});")
    out = subprocess.run([node, "-e", script, str(module.resolve()), str(Path(path).resolve())],
                         capture_output=True, text=True, check=False)
    if out.returncode != 0:
        raise RuntimeError(f"gltf-validator failed on {path}: {out.stderr.strip()}")
    return json.loads(out.stdout)


class Glb(ExportFormat):
    """``glb``: glTF 2.0 mesh + morph targets + animation (needs a rig)."""

    name, suffix, needs_rig = "glb", ".glb", True

    def write(self, out, coeffs, names, options: ExportOptions) -> AlignedTrack:
        return write_glb(out, options.rig, coeffs, names, options.fps)

    def read(self, path, *, fps: float):
        glb = read_glb(path)
        rate = 1.0 / float(np.median(np.diff(glb.times))) if len(glb.times) > 1 else fps
        return glb.weights, glb.names, rate
