"""Put a coefficient track on a character: export to the formats animation tools read,
and read them back.

=============  ==========================================  ==================
format         what                                        needs a rig
=============  ==========================================  ==================
``livelink``   Live Link Face CSV (Unreal, MetaHuman)      no
``arkit-json`` the 52 ARKit weights per frame, JSON        no
``a2f-json``   Audio2Face-3D blendshape weights JSON       no
``glb``        glTF 2.0 mesh + morph targets + animation   yes
``usd``        UsdSkel blend shapes + SkelAnimation        yes
``fbx``        FBX mesh + blend shapes + animation         yes (and Blender's ``bpy``)
``csv``        BlendVOCA/SAiD CSV (rig or BlendVOCA names) no
=============  ==========================================  ==================

``export_track(out, coeffs, names, fmt)`` writes one; ``read_track(path)`` reads any
back as ``(coeffs, names, fps)``. Columns are always matched by name; shapes a target
lacks are 0 and reported in the returned :class:`~blendvoca.export.align.AlignedTrack`.

Each format is one :class:`~blendvoca.export.base.ExportFormat` class in its own module,
named in :data:`FORMAT_REGISTRY` (a :class:`~blendvoca.registry.Registry`): adding a
format is that module and one registry line.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError, UserError
from blendvoca.export._support import read_json_object
from blendvoca.export.align import AlignedTrack, align_track, check_track, unit_range_track
from blendvoca.export.base import ExportFormat, ExportOptions
from blendvoca.registry import Registry
from blendvoca.rig import load_rig

#: Format name -> ``"module:Class"`` of its :class:`~blendvoca.export.base.ExportFormat`;
#: adding a format is its module and one line here.
FORMAT_REGISTRY = Registry("format", {
    "livelink": "blendvoca.export.livelink:LiveLinkCsv",
    "arkit-json": "blendvoca.export.arkit_json:ArkitJson",
    "a2f-json": "blendvoca.export.a2f_json:A2fJson",
    "glb": "blendvoca.export.glb:Glb",
    "usd": "blendvoca.export.usd:Usd",
    "fbx": "blendvoca.export.fbx:Fbx",
    "csv": "blendvoca.export.coeffs_csv:CoeffsCsv",
})
FORMATS: tuple[str, ...] = FORMAT_REGISTRY.names()
NEEDS_RIG: frozenset[str] = frozenset(name for name in FORMATS if FORMAT_REGISTRY.get(name).needs_rig)
SUFFIX: dict[str, str] = {name: FORMAT_REGISTRY.get(name).suffix for name in FORMATS}


def export_format(fmt: str, *, where: str = "export_track") -> ExportFormat:
    """The :class:`~blendvoca.export.base.ExportFormat` called ``fmt``.

    Raises
    ------
    UserError
        An unknown name: ``"<where>: unknown format ..."`` with the close matches.
    """
    if fmt not in FORMAT_REGISTRY:
        raise FORMAT_REGISTRY.unknown(fmt, where=where)
    return FORMAT_REGISTRY.get(fmt)()


def export_track(out, coeffs, names: Sequence[str], fmt: str, *, rig=None, fps: float = 60.0,
                 audio=None, clip: bool = False, convention: str | None = None,
                 copy_audio: bool = False) -> AlignedTrack:
    """Write a ``(T, K)`` track in format ``fmt``.

    Parameters
    ----------
    out : path-like
    coeffs : (T, K) array_like at ``fps``
    names : K ARKit names (any case), the columns of ``coeffs``
    fmt : one of :data:`FORMATS`
    rig : blendvoca.rig.Rig, needed by ``glb`` and ``usd``
    fps : float
    audio : path of the sound, optional (``a2f-json`` names it as ``trackPath``, ``usd``
        references it; both by its path relative to ``out``)
    clip : bool
        Clip weights outside [0, 1] instead of refusing the track.
    convention : str, optional
        ``csv`` only: write the columns of this naming convention of :mod:`blendvoca.names`
        (``unitalker51``, ``metahuman``, ...), in its order and spelling, instead of the
        rig's names or BlendVOCA's 32.
    copy_audio : bool
        Copy ``audio`` beside ``out`` first and reference the copy (the export and its sound
        then move together).

    Returns
    -------
    AlignedTrack : the track as written (its ``notes()`` say what was 0, left out or
        clipped; ``clipped`` counts the values moved)

    Raises
    ------
    UserError
        An unknown format, a missing rig, or a track that is not (T, K) finite weights
        in [0, 1] (``clip`` off), naming the first bad frame and column.
    """
    writer = export_format(fmt)
    if writer.needs_rig and rig is None:
        raise UserError(f"export_track: format {fmt!r} needs a rig (the mesh and its blendshapes)")
    if fps <= 0:
        raise UserError(f"export_track: fps must be positive, got {fps}")
    if convention is not None and not writer.takes_convention:
        raise UserError(f"export_track: a convention applies to the csv format only; {fmt!r} has its own columns")
    checked, _ = check_track(coeffs, names, where="export_track")
    coeffs, clipped = unit_range_track(checked, tuple(str(n) for n in names), where="export_track", clip=clip)
    options = ExportOptions(fps=fps, rig=rig, audio=audio, convention=convention, copy_audio=copy_audio)
    aligned = writer.write(out, coeffs, names, options)
    return dataclasses.replace(aligned, clipped=clipped)


def detect_format(path) -> str:
    """The format of an exported file, from its suffix and (CSV/JSON) its first bytes.

    Raises
    ------
    UserError
        An unknown suffix.
    DataError
        A JSON file that is not an object of either JSON format, or a CSV whose first
        line is not UTF-8 (naming the file).
    """
    path = Path(os.fspath(path))
    suffix = path.suffix.lower()
    if suffix == ".glb":
        return "glb"
    if suffix in (".usd", ".usda", ".usdc"):
        return "usd"
    if suffix == ".fbx":
        return "fbx"
    if suffix == ".json":
        doc = read_json_object(path, "an ARKit or Audio2Face weights JSON")
        if "weightMat" in doc:
            return "a2f-json"
        if "blendShapeNames" in doc:
            return "arkit-json"
        raise DataError(f"{path}: a JSON file that is neither ARKit (blendShapeNames) nor Audio2Face (weightMat) weights")
    if suffix == ".csv":
        with open(path, "rb") as f:
            first_bytes = f.readline()
        try:
            first = first_bytes.decode("utf-8-sig")
        except UnicodeDecodeError as error:
            raise DataError(f"{path}: not a UTF-8 text file ({error.reason} at byte {error.start}); "
                            f"a coefficient CSV is UTF-8") from None
        return "livelink" if first.split(",")[0].strip() == "Timecode" else "csv"
    raise UserError(f"{path}: unknown suffix {suffix!r}; expected .csv, .json, .glb, .fbx, .usd, .usda or .usdc")


def read_track(path, fmt: str | None = None, *, fps: float = 60.0) -> tuple[np.ndarray, tuple[str, ...], float]:
    """Read any exported track back.

    Parameters
    ----------
    path : path-like
    fmt : one of :data:`FORMATS`, default from :func:`detect_format`
    fps : the rate of CSV files (which do not store one)

    Returns
    -------
    coeffs : (T, K) float64, names : K camelCase ARKit names, fps : float

    Raises
    ------
    DataError
        A file that is not a readable track of its format, naming the file and what is
        wrong (the parsers of the binary formats are third-party; what they raise on a
        damaged file is reported as this too).
    UserError
        An unknown format or suffix.
    """
    fmt = fmt or detect_format(path)
    return export_format(fmt, where="read_track").read(path, fps=fps)


__all__ = ["FORMATS", "FORMAT_REGISTRY", "AlignedTrack", "ExportFormat", "ExportOptions", "align_track",
           "detect_format", "export_format", "export_track", "load_rig", "read_track"]
