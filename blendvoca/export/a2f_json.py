"""NVIDIA Audio2Face-3D's blendshape weight export (the JSON its "Export blendshape
weights" writes and Maya/Unreal importers read):

``{"exportFps": 60, "trackPath": "<audio file>", "numPoses": K, "numFrames": T,
"facsNames": [K names], "weightMat": [[K floats] x T]}``
"""

from __future__ import annotations

import json
from collections.abc import Sequence

import numpy as np

from blendvoca.errors import DataError
from blendvoca.export._support import read_json
from blendvoca.export.align import AlignedTrack, align_track
from blendvoca.export.arkit_json import _weights
from blendvoca.io.atomic import atomic_write
from blendvoca.names import ARKIT_FACE_ORDER


def a2f_document(coeffs, names: Sequence[str], fps: float = 60.0, track_path: str = "") -> tuple[dict, AlignedTrack]:
    """The A2F JSON document of a track over the 52 ARKit poses (shapes it lacks are 0)."""
    aligned = align_track(coeffs, names, ARKIT_FACE_ORDER, where="a2f-json")
    doc = {
        "exportFps": int(fps) if float(fps).is_integer() else float(fps),
        "trackPath": str(track_path),
        "numPoses": len(ARKIT_FACE_ORDER),
        "numFrames": int(len(aligned.coeffs)),
        "facsNames": list(ARKIT_FACE_ORDER),
        "weightMat": [[round(float(v), 9) for v in row] for row in aligned.coeffs],
    }
    return doc, aligned


def write_a2f_json(path, coeffs, names: Sequence[str], fps: float = 60.0, track_path: str = "") -> AlignedTrack:
    """Write the A2F JSON of a track, atomically; ``track_path`` names the audio."""
    doc, aligned = a2f_document(coeffs, names, fps, track_path)
    with atomic_write(path, "w", encoding="utf-8") as f:
        json.dump(doc, f, indent=1)
    return aligned


def read_a2f_json(path) -> tuple[np.ndarray, tuple[str, ...], float]:
    """``(coeffs (T, numPoses), facsNames, exportFps)`` of an A2F blendshape JSON."""
    doc = read_json(path)
    for key in ("exportFps", "numPoses", "numFrames", "facsNames", "weightMat"):
        if key not in doc:
            raise DataError(f"{path}: not an Audio2Face blendshape JSON: missing key {key!r}")
    names = tuple(doc["facsNames"])
    if int(doc["numPoses"]) != len(names) or int(doc["numFrames"]) != len(doc["weightMat"]):
        raise DataError(f"{path}: numPoses/numFrames ({doc['numPoses']}, {doc['numFrames']}) disagree with "
                         f"facsNames/weightMat ({len(names)}, {len(doc['weightMat'])})")
    return _weights(doc["weightMat"], names, path), names, float(doc["exportFps"])
