"""glTF 2.0 binary (GLB) of a rig with a weights animation, written with pygltflib.

One node and mesh: the neutral as POSITION, the triangles as uint32 indices, one
morph target (POSITION offsets) per blendshape named in ``mesh.extras.targetNames``
(the convention three.js, Babylon.js and Blender read), and one animation whose
"weights" channel has one linear key per frame (``T * K`` outputs, frame-major).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError
from blendvoca.export._support import optional_module
from blendvoca.export.align import AlignedTrack, align_track
from blendvoca.io.atomic import atomic_write

_FLOAT, _UINT32 = 5126, 5125
_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963


@dataclass(frozen=True)
class GlbContents:
    """What :func:`read_glb` recovers.

    Attributes
    ----------
    neutral : (V, 3) float64, faces : (F, 3) int64, deltas : (K, V, 3) float64
    names : tuple of K str (``extras.targetNames``)
    times : (T,) float64 seconds, weights : (T, K) float64
    """

    neutral: np.ndarray
    faces: np.ndarray
    deltas: np.ndarray
    names: tuple[str, ...]
    times: np.ndarray
    weights: np.ndarray


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
    (or any GLB whose first mesh has morph targets and whose first animation drives them)."""
    g = optional_module("pygltflib", "pygltflib", "the glb format")

    gltf = g.GLTF2().load_binary(os.fspath(path))
    blob = gltf.binary_blob()
    if not gltf.meshes or not gltf.meshes[0].primitives:
        raise DataError(f"{path}: the GLB has no mesh")

    def read(index: int) -> np.ndarray:
        accessor = gltf.accessors[index]
        view = gltf.bufferViews[accessor.bufferView]
        width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[accessor.type]
        dtype = {_FLOAT: "<f4", _UINT32: "<u4", 5123: "<u2", 5121: "u1"}[accessor.componentType]
        start = (view.byteOffset or 0) + (accessor.byteOffset or 0)
        array = np.frombuffer(blob, dtype=dtype, count=accessor.count * width, offset=start)
        return array.reshape(accessor.count, width) if width > 1 else array

    mesh = gltf.meshes[0]
    primitive = mesh.primitives[0]
    neutral = read(primitive.attributes.POSITION).astype(np.float64)
    faces = read(primitive.indices).astype(np.int64).reshape(-1, 3)
    targets = primitive.targets or []
    deltas = np.stack([read(t["POSITION"]) for t in targets]).astype(np.float64) if targets else np.zeros((0, *neutral.shape))
    names = tuple((mesh.extras or {}).get("targetNames", [f"target{k}" for k in range(len(targets))]))
    if not gltf.animations:
        raise DataError(f"{path}: the GLB has no animation")
    sampler = gltf.animations[0].samplers[gltf.animations[0].channels[0].sampler]
    times = read(sampler.input).astype(np.float64)
    weights = read(sampler.output).astype(np.float64).reshape(len(times), len(targets))
    return GlbContents(neutral, faces, deltas, names, times, weights)


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
