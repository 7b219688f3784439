"""Find the tracks of one sentence in a stored benchmark run (protocol v2 layout).

A result JSON ``R/<run>.json`` names, under ``tracks``, a folder relative to its own
folder holding ``<subject>/<sentence>-<k>.csv`` (sample k from 0, SAiD CSV layout at
60 fps); its ``dataset.path`` is the BlendVOCA build root, with the ground truth at
``blendshape_coeffs/<subject>/<sentence>.csv``, the audio at
``audio/<subject>/<sentence>.wav`` and the rig at ``rigs/<subject>.npz``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from blendvoca.errors import DataError


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
    DataError
        When the JSON lacks ``tracks`` or ``dataset.path``.
    """
    from benchmark.runs import read_run
    from blendvoca.format import audio_path, coeffs_path, rig_path

    result_json = Path(result_json)
    if not result_json.is_file():
        raise FileNotFoundError(f"result file not found: {result_json}")
    stored = read_run(result_json)  # the run layout's owner: tracks folder, dataset.path
    data_path = stored.result.dataset.path
    if not data_path:
        raise DataError(f"{result_json}: no 'dataset.path'; expected the BlendVOCA build root the run used")
    root = Path(data_path)
    if not root.is_absolute():
        root = (result_json.parent / root).resolve()
    try:
        samples = stored.track_paths(subject, sentence)
    except KeyError:
        have = sorted({q for s, q in stored.keys if s == subject})
        raise FileNotFoundError(f"{result_json}: no track of {subject}/{sentence}; the run has "
                                + (f"{have[:8]} for {subject}" if have else
                                   f"subjects {sorted({s for s, _ in stored.keys})}")) from None
    if not 0 <= sample < len(samples):
        raise FileNotFoundError(f"{result_json}: no sample {sample} of {subject}/{sentence}; the run has "
                                f"{[p.name for p in samples]}")
    generated = samples[sample]
    files = StoredSentence(str(stored.result.method.name or result_json.stem), generated,
                           coeffs_path(root, subject, sentence),
                           audio_path(root, subject, sentence), rig_path(root, subject))
    for what in ("ground_truth", "audio", "rig"):
        if not getattr(files, what).is_file():
            raise FileNotFoundError(f"{result_json}: the {what.replace('_', ' ')} of {subject}/{sentence} is missing: "
                                    f"{getattr(files, what)} (dataset.path = {data_path})")
    return files
