"""NVIDIA Audio2Face-3D's blendshape weight export (the JSON its "Export blendshape
weights" writes and Maya/Unreal importers read):

``{"exportFps": 60, "trackPath": "<audio file>", "numPoses": K, "numFrames": T,
"facsNames": [K names], "weightMat": [[K floats] x T]}``
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from blendvoca.errors import DataError
from blendvoca.export._support import (count, positive_number, read_json_object, string_list, weight_matrix,
                                       write_json_document)
from blendvoca.export.align import AlignedTrack, align_track
from blendvoca.export.base import ExportFormat, ExportOptions, audio_reference, export_audio


def a2f_document(coeffs, names: Sequence[str], fps: float = 60.0, track_path: str = "") -> tuple[dict, AlignedTrack]:
    """The A2F JSON document of a track over the 52 ARKit poses (shapes it lacks are 0)."""
    aligned = align_track(coeffs, names, "a2f52", where="a2f-json")
    doc = {
        "exportFps": int(fps) if float(fps).is_integer() else float(fps),
        "trackPath": str(track_path),
        "numPoses": len(aligned.names),
        "numFrames": int(len(aligned.coeffs)),
        "facsNames": list(aligned.names),
        "weightMat": [[round(float(v), 9) for v in row] for row in aligned.coeffs],
    }
    return doc, aligned


def write_a2f_json(path, coeffs, names: Sequence[str], fps: float = 60.0, track_path: str = "") -> AlignedTrack:
    """Write the A2F JSON of a track, atomically; ``track_path`` names the audio (as written:
    :func:`blendvoca.export.base.audio_reference` gives the path relative to the file)."""
    doc, aligned = a2f_document(coeffs, names, fps, track_path)
    write_json_document(path, doc, indent=1)
    return aligned


def read_a2f_json(path) -> tuple[np.ndarray, tuple[str, ...], float]:
    """``(coeffs (T, numPoses), facsNames, exportFps)`` of an A2F blendshape JSON.

    Raises
    ------
    DataError
        Naming the file and what is wrong: not a JSON object, a missing key, a value of
        the wrong type, counts that disagree with the names and frames, or the frame
        whose vector has the wrong length or a value that is not a finite number.
    """
    doc = read_json_object(path, "an Audio2Face blendshape JSON",
                           ("exportFps", "numPoses", "numFrames", "facsNames", "weightMat"))
    names = string_list(doc, "facsNames", path)
    fps = positive_number(doc, "exportFps", path)
    poses, frames = count(doc, "numPoses", path), count(doc, "numFrames", path)
    weights = weight_matrix(doc, "weightMat", names, path)
    if poses != len(names) or frames != len(weights):
        raise DataError(f"{path}: numPoses/numFrames ({poses}, {frames}) disagree with "
                        f"facsNames/weightMat ({len(names)}, {len(weights)})")
    return weights, names, fps


class A2fJson(ExportFormat):
    """``a2f-json``: Audio2Face-3D blendshape weights JSON (``trackPath`` names the audio)."""

    name, suffix = "a2f-json", ".json"

    def write(self, out, coeffs, names, options: ExportOptions) -> AlignedTrack:
        audio = export_audio(options, out)
        return write_a2f_json(out, coeffs, names, options.fps, "" if audio is None else audio_reference(audio, out))

    def read(self, path, *, fps: float):
        return read_a2f_json(path)
