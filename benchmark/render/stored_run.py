"""Find the tracks of one sentence in a stored benchmark run (protocol v2 layout).

A result JSON ``R/<run>.json`` names, under ``tracks``, a folder relative to its own
folder holding ``<subject>/<sentence>-<k>.csv`` (sample k from 0, SAiD CSV layout at
60 fps); its ``dataset.path`` is the BlendVOCA build root, with the ground truth at
``blendshape_coeffs/<subject>/<sentence>.csv``, the audio at
``audio/<subject>/<sentence>.wav`` and the rig at ``rigs/<subject>.npz``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class StoredSentence:
    """The files of one sentence of a stored run.

    Attributes
    ----------
    method : str, the method's name (the result's ``method``, else the file name)
    generated : Path, the method's track (sample ``sample``)
    ground_truth : Path, audio : Path, rig : Path
    """

    method: str
    generated: Path
    ground_truth: Path
    audio: Path
    rig: Path


def locate_sentence(result_json, subject: str, sentence: str, sample: int = 0) -> StoredSentence:
    """The generated and ground-truth tracks, audio and rig of one sentence of a run.

    Raises
    ------
    FileNotFoundError
        Naming the missing file and, for a missing sample or sentence, what the run has.
    ValueError
        When the JSON lacks ``tracks`` or ``dataset.path``.
    """
    result_json = Path(result_json)
    if not result_json.is_file():
        raise FileNotFoundError(f"result file not found: {result_json}")
    with open(result_json, encoding="utf-8") as f:
        result = json.load(f)
    if "tracks" not in result:
        raise ValueError(f"{result_json}: no 'tracks' key; this result stores no generated tracks (protocol v2 runs do)")
    dataset = result.get("dataset") or {}
    if not isinstance(dataset, dict) or "path" not in dataset:
        raise ValueError(f"{result_json}: no 'dataset.path'; expected the BlendVOCA build root the run used")
    tracks = (result_json.parent / result["tracks"]).resolve()
    root = Path(dataset["path"])
    if not root.is_absolute():
        root = (result_json.parent / root).resolve()
    generated = tracks / subject / f"{sentence}-{sample}.csv"
    if not generated.is_file():
        have = sorted(p.name for p in (tracks / subject).glob("*.csv")) if (tracks / subject).is_dir() else []
        subjects = sorted(p.name for p in tracks.iterdir() if p.is_dir()) if tracks.is_dir() else []
        raise FileNotFoundError(f"{result_json}: no track {generated}; the run has "
                                + (f"{have[:8]} for {subject}" if have else f"subjects {subjects}"))
    method = result.get("method")
    if isinstance(method, dict):
        method = method.get("name")
    files = StoredSentence(str(method or result_json.stem), generated,
                           root / "blendshape_coeffs" / subject / f"{sentence}.csv",
                           root / "audio" / subject / f"{sentence}.wav", root / "rigs" / f"{subject}.npz")
    for what in ("ground_truth", "audio", "rig"):
        if not getattr(files, what).is_file():
            raise FileNotFoundError(f"{result_json}: the {what.replace('_', ' ')} of {subject}/{sentence} is missing: "
                                    f"{getattr(files, what)} (dataset.path = {dataset['path']})")
    return files
