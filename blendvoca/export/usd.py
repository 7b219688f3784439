"""OpenUSD UsdSkel blend shapes with a SkelAnimation of the weights over time (usd-core),
the layout Omniverse and Audio2Face use.

``/Face`` (SkelRoot, default prim) holds ``Skel`` (a one-joint Skeleton whose
``skel:animationSource`` is ``Skel/Anim``, a SkelAnimation with ``blendShapes`` and
time-sampled ``blendShapeWeights``, one sample per frame) and ``Mesh`` (the neutral,
bound to the skeleton, with one ``BlendShape`` child of offsets per shape). Time codes
are frames: ``timeCodesPerSecond`` = ``framesPerSecond`` = the track's fps. With audio,
``Audio`` is a UsdMedia.SpatialAudio prim pointing at the file. ``.usda`` writes text,
``.usd``/``.usdc`` binary crate.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError, UserError
from blendvoca.export._support import foreign_parser, optional_module
from blendvoca.export.align import AlignedTrack, align_track
from blendvoca.export.base import ExportFormat, ExportOptions, RigAnimation, audio_reference, export_audio
from blendvoca.io.atomic import permissions_for

SUFFIXES = (".usda", ".usdc", ".usd")


@dataclass(frozen=True)
class UsdContents(RigAnimation):
    """What :func:`read_usd` recovers: the GLB reader's fields, the frame rate and the audio."""

    fps: float
    audio: str | None


def write_usd(path, rig, coeffs, names: Sequence[str], fps: float = 60.0, audio=None) -> AlignedTrack:
    """Write a UsdSkel stage of ``rig`` animated by a track, atomically.

    Parameters
    ----------
    path : .usda, .usdc or .usd
    rig : blendvoca.rig.Rig
    coeffs : (T, K) track, columns ``names`` (mapped to ``rig.names`` by name)
    fps : float
    audio : path of a sound file to reference, optional (written relative to ``path``, so that
        the two can be moved together)
    """
    optional_module("pxr", "usd-core", "the usd format")
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdMedia, UsdSkel, Vt

    path = Path(os.fspath(path))
    if path.suffix.lower() not in SUFFIXES:
        raise UserError(f"write_usd: {path}: expected a {'/'.join(SUFFIXES)} file")
    aligned = align_track(coeffs, names, rig.names, where="usd")
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}.", suffix=path.suffix)
    os.close(fd)
    try:
        stage = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
        UsdGeom.SetStageMetersPerUnit(stage, 1.0)
        count = len(aligned.coeffs)
        stage.SetTimeCodesPerSecond(float(fps))
        stage.SetFramesPerSecond(float(fps))
        stage.SetStartTimeCode(0)
        stage.SetEndTimeCode(max(count - 1, 0))

        root = UsdSkel.Root.Define(stage, "/Face")
        stage.SetDefaultPrim(root.GetPrim())
        skeleton = UsdSkel.Skeleton.Define(stage, "/Face/Skel")
        skeleton.CreateJointsAttr(Vt.TokenArray(["root"]))
        skeleton.CreateBindTransformsAttr(Vt.Matrix4dArray([Gf.Matrix4d(1.0)]))
        skeleton.CreateRestTransformsAttr(Vt.Matrix4dArray([Gf.Matrix4d(1.0)]))
        anim = UsdSkel.Animation.Define(stage, "/Face/Skel/Anim")
        anim.CreateJointsAttr(Vt.TokenArray(["root"]))
        anim.CreateTranslationsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0, 0)]))
        anim.CreateRotationsAttr(Vt.QuatfArray([Gf.Quatf(1, 0, 0, 0)]))
        anim.CreateScalesAttr(Vt.Vec3hArray([Gf.Vec3h(1, 1, 1)]))
        anim.CreateBlendShapesAttr(Vt.TokenArray(list(rig.names)))
        weights_attr = anim.CreateBlendShapeWeightsAttr()
        for t, row in enumerate(aligned.coeffs.astype(np.float32)):
            weights_attr.Set(Vt.FloatArray.FromNumpy(row), Usd.TimeCode(t))
        UsdSkel.BindingAPI.Apply(skeleton.GetPrim()).CreateAnimationSourceRel().SetTargets([anim.GetPath()])

        mesh = UsdGeom.Mesh.Define(stage, "/Face/Mesh")
        mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(rig.neutral, dtype=np.float32)))
        faces = np.asarray(rig.faces, dtype=np.int32)
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(faces), 3, dtype=np.int32)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(faces.reshape(-1)))
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.CreateDoubleSidedAttr(True)
        binding = UsdSkel.BindingAPI.Apply(mesh.GetPrim())
        binding.CreateSkeletonRel().SetTargets([skeleton.GetPath()])
        binding.CreateJointIndicesPrimvar(constant=True, elementSize=1).Set(Vt.IntArray([0]))
        binding.CreateJointWeightsPrimvar(constant=True, elementSize=1).Set(Vt.FloatArray([1.0]))
        binding.CreateGeomBindTransformAttr(Gf.Matrix4d(1.0))
        binding.CreateBlendShapesAttr(Vt.TokenArray(list(rig.names)))
        targets = []
        for name, delta in zip(rig.names, rig.deltas):
            shape = UsdSkel.BlendShape.Define(stage, f"/Face/Mesh/{name}")
            shape.CreateOffsetsAttr(Vt.Vec3fArray.FromNumpy(np.asarray(delta, dtype=np.float32)))
            targets.append(shape.GetPath())
        binding.CreateBlendShapeTargetsRel().SetTargets(targets)

        if audio is not None:
            sound = UsdMedia.SpatialAudio.Define(stage, "/Face/Audio")
            sound.CreateFilePathAttr(Sdf.AssetPath(audio_reference(audio, path)))  # relative to the layer
            sound.CreateAuralModeAttr(UsdMedia.Tokens.nonSpatial)
            sound.CreateStartTimeAttr(Sdf.TimeCode(0))
        stage.GetRootLayer().Export(tmp, args={"format": "usda" if path.suffix.lower() == ".usda" else "usdc"})
        os.chmod(tmp, permissions_for(path))  # after writing: the replaced file may be read-only
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return aligned


def read_usd(path) -> UsdContents:
    """Read back the first UsdSkel-bound mesh with blend shapes and its SkelAnimation.

    Raises
    ------
    DataError
        Naming the file and what is wrong: a file pxr cannot open as a stage, no mesh
        with blend shapes, or a skeleton, animation or shape the mesh names that the
        stage lacks or that disagrees with it.
    """
    optional_module("pxr", "usd-core", "reading the usd format")

    # pxr raises its own Tf.ErrorException on a file that does not parse, and the
    # lookups below raise IndexError, ValueError, TypeError on a stage that is not laid
    # out as expected; all of them mean "not a readable UsdSkel track"
    with foreign_parser(path, "USD stage"):
        return _usd_contents(path)


def _usd_contents(path) -> UsdContents:
    """The contents of the stage at ``path`` (:func:`read_usd`)."""
    from pxr import Usd, UsdGeom, UsdMedia, UsdSkel

    stage = Usd.Stage.Open(os.fspath(path))
    if stage is None:
        raise DataError(f"{path}: not a USD stage")
    mesh_prim = next((p for p in stage.Traverse() if p.HasAPI(UsdSkel.BindingAPI)
                      and UsdSkel.BindingAPI(p).GetBlendShapesAttr().HasAuthoredValue()), None)
    if mesh_prim is None:
        raise DataError(f"{path}: no mesh with UsdSkel blend shapes")
    mesh = UsdGeom.Mesh(mesh_prim)
    binding = UsdSkel.BindingAPI(mesh_prim)
    neutral = np.asarray(mesh.GetPointsAttr().Get(), dtype=np.float64)
    faces = np.asarray(mesh.GetFaceVertexIndicesAttr().Get(), dtype=np.int64).reshape(-1, 3)
    shape_names = tuple(binding.GetBlendShapesAttr().Get())
    targets = binding.GetBlendShapeTargetsRel().GetTargets()
    if len(targets) != len(shape_names):
        raise DataError(f"{path}: {len(shape_names)} blend shape names but {len(targets)} blend shape targets")
    if not binding.GetSkeletonRel().GetTargets():
        raise DataError(f"{path}: the mesh with blend shapes is bound to no skeleton")
    deltas = np.stack([np.asarray(UsdSkel.BlendShape(stage.GetPrimAtPath(t)).GetOffsetsAttr().Get(), dtype=np.float64)
                       for t in targets])
    skeleton = UsdSkel.Skeleton(stage.GetPrimAtPath(binding.GetSkeletonRel().GetTargets()[0]))
    anim = UsdSkel.Animation(stage.GetPrimAtPath(UsdSkel.BindingAPI(skeleton.GetPrim()).GetAnimationSourceRel().GetTargets()[0]))
    anim_names = tuple(anim.GetBlendShapesAttr().Get())
    attr = anim.GetBlendShapeWeightsAttr()
    codes = attr.GetTimeSamples()
    weights = np.stack([np.asarray(attr.Get(Usd.TimeCode(c)), dtype=np.float64) for c in codes])
    order = [anim_names.index(n) for n in shape_names]
    fps = stage.GetTimeCodesPerSecond()
    if not np.isfinite(fps) or fps <= 0:
        raise DataError(f"{path}: timeCodesPerSecond is {fps}, expected a positive frame rate")
    audio = next((str(UsdMedia.SpatialAudio(p).GetFilePathAttr().Get().path) for p in stage.Traverse()
                  if p.IsA(UsdMedia.SpatialAudio)), None)
    return UsdContents(neutral, faces, deltas, shape_names, np.asarray(codes, dtype=np.float64) / fps,
                       weights[:, order], float(fps), audio)


class Usd(ExportFormat):
    """``usd``: UsdSkel blend shapes + SkelAnimation (needs a rig; references the audio)."""

    name, suffix, needs_rig = "usd", ".usda", True

    def write(self, out, coeffs, names, options: ExportOptions) -> AlignedTrack:
        return write_usd(out, options.rig, coeffs, names, options.fps, audio=export_audio(options, out))

    def read(self, path, *, fps: float):
        usd = read_usd(path)
        return usd.weights, usd.names, usd.fps
