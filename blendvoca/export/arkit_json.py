"""ARKit blendshape JSON: the 52 ARKit names (camelCase, ARKit's order), the frame
rate and one weight vector per frame.

``{"format": "arkit-blendshapes", "version": 1, "frameRate": 60.0, "numFrames": T,
"blendShapeNames": [52 names], "timestamps": [T seconds], "weights": [[52 floats] x T]}``
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from blendvoca.errors import DataError
from blendvoca.export._support import positive_number, read_json_object, string_list, weight_matrix, write_json_document
from blendvoca.export.align import AlignedTrack, align_track
from blendvoca.export.base import ExportFormat, ExportOptions

FORMAT_NAME = "arkit-blendshapes"


def arkit_json_document(coeffs, names: Sequence[str], fps: float = 60.0) -> tuple[dict, AlignedTrack]:
    """The JSON document of a track (shapes it lacks are 0) and the aligned track."""
    aligned = align_track(coeffs, names, "arkit52", where="arkit-json")
    doc = {
        "format": FORMAT_NAME,
        "version": 1,
        "frameRate": float(fps),
        "numFrames": int(len(aligned.coeffs)),
        "blendShapeNames": list(aligned.names),
        "timestamps": [round(t / fps, 9) for t in range(len(aligned.coeffs))],
        "weights": [[round(float(v), 9) for v in row] for row in aligned.coeffs],
    }
    return doc, aligned


def write_arkit_json(path, coeffs, names: Sequence[str], fps: float = 60.0) -> AlignedTrack:
    """Write the ARKit JSON of a track, atomically."""
    doc, aligned = arkit_json_document(coeffs, names, fps)
    write_json_document(path, doc)
    return aligned


def read_arkit_json(path) -> tuple[np.ndarray, tuple[str, ...], float]:
    """``(coeffs (T, K), names, fps)`` of an ARKit JSON file.

    Raises
    ------
    DataError
        Naming the file and what is wrong: not a JSON object, a missing key, a frame rate
        that is not a positive number, names that are not strings, or the frame whose
        vector has the wrong length or a value that is not a finite number.
    """
    doc = read_json_object(path, "an ARKit blendshape JSON", ("frameRate", "blendShapeNames", "weights"))
    names = string_list(doc, "blendShapeNames", path)
    return weight_matrix(doc, "weights", names, path), names, positive_number(doc, "frameRate", path)


class ArkitJson(ExportFormat):
    """``arkit-json``: the 52 ARKit weights per frame, JSON."""

    name, suffix = "arkit-json", ".json"

    def write(self, out, coeffs, names, options: ExportOptions) -> AlignedTrack:
        return write_arkit_json(out, coeffs, names, options.fps)

    def read(self, path, *, fps: float):
        return read_arkit_json(path)
