"""ARKit blendshape JSON: the 52 ARKit names (camelCase, ARKit's order), the frame
rate and one weight vector per frame.

``{"format": "arkit-blendshapes", "version": 1, "frameRate": 60.0, "numFrames": T,
"blendShapeNames": [52 names], "timestamps": [T seconds], "weights": [[52 floats] x T]}``
"""

from __future__ import annotations

import json
from collections.abc import Sequence

import numpy as np

from blendvoca.errors import DataError
from blendvoca.export._support import read_json
from blendvoca.export.align import AlignedTrack, align_track
from blendvoca.io.atomic import atomic_write
from blendvoca.names import ARKIT_FACE_ORDER

FORMAT_NAME = "arkit-blendshapes"


def arkit_json_document(coeffs, names: Sequence[str], fps: float = 60.0) -> tuple[dict, AlignedTrack]:
    """The JSON document of a track (shapes it lacks are 0) and the aligned track."""
    aligned = align_track(coeffs, names, ARKIT_FACE_ORDER, where="arkit-json")
    doc = {
        "format": FORMAT_NAME,
        "version": 1,
        "frameRate": float(fps),
        "numFrames": int(len(aligned.coeffs)),
        "blendShapeNames": list(ARKIT_FACE_ORDER),
        "timestamps": [round(t / fps, 9) for t in range(len(aligned.coeffs))],
        "weights": [[round(float(v), 9) for v in row] for row in aligned.coeffs],
    }
    return doc, aligned


def write_arkit_json(path, coeffs, names: Sequence[str], fps: float = 60.0) -> AlignedTrack:
    """Write the ARKit JSON of a track, atomically."""
    doc, aligned = arkit_json_document(coeffs, names, fps)
    with atomic_write(path, "w", encoding="utf-8") as f:
        json.dump(doc, f)
    return aligned


def read_arkit_json(path) -> tuple[np.ndarray, tuple[str, ...], float]:
    """``(coeffs (T, K), names, fps)`` of an ARKit JSON file.

    Raises
    ------
    ValueError
        Naming the file and the missing key or the frame whose vector has the wrong length.
    """
    doc = read_json(path)
    for key in ("frameRate", "blendShapeNames", "weights"):
        if key not in doc:
            raise DataError(f"{path}: not an ARKit blendshape JSON: missing key {key!r}")
    names = tuple(doc["blendShapeNames"])
    return _weights(doc["weights"], names, path), names, float(doc["frameRate"])


def _weights(rows, names, path) -> np.ndarray:
    for t, row in enumerate(rows):
        if len(row) != len(names):
            raise DataError(f"{path}: frame {t} has {len(row)} weights, expected {len(names)} (one per name)")
    return np.asarray(rows, dtype=np.float64).reshape(len(rows), len(names))
