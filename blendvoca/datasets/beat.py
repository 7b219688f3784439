"""The BEAT adapter (``--dataset beat --root DIR``): ARKit weights captured on an iPhone, 60 fps.

Layout read (BEAT's release, e.g. ``beat_english_v0.2.1/``; PantoMatrix's loader
``dataloaders/beat.py`` pairs a take's files by name)::

    <root>/<speaker id>/<speaker id>_<name>_<type>_<a>_<b>.json   facial weights
    <root>/<speaker id>/<speaker id>_<name>_<type>_<a>_<b>.wav    speech

Each JSON holds ``names`` (the ARKit shapes of its columns) and ``frames``, a
list of ``{"time": seconds, "weights": [one per name]}``; the other files of a
take (``.bvh``, ``.TextGrid``, ``.txt``) are not read. The speaker is
``<speaker id>_<name>`` (``1_wayne``). See ``docs/datasets.md``.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from blendvoca.datasets.coefficients import DatasetLayoutError, Take, coefficient_adapter, frame_rate, safe_name
from blendvoca.errors import DataError
from blendvoca.io.audio import load_audio
from blendvoca.io.json_file import read_json

#: A take's file name: speaker id, speaker name, then the take's numbers.
TAKE_NAME = re.compile(r"^(\d+)_([A-Za-z]+)_\w+$")
EXPECTED = ("<root>/<speaker id>/<speaker id>_<name>_<type>_<a>_<b>.json (BEAT's facial weights: 'names' and "
            "'frames' of {'time', 'weights'}) with the take's .wav beside it, e.g. 1/1_wayne_0_1_1.json and "
            "1/1_wayne_0_1_1.wav")


def read_beat_json(path) -> tuple[np.ndarray, tuple[str, ...], float]:
    """A BEAT facial JSON: ``(weights (T, K), names (K,), fps)``.

    Raises
    ------
    DataError
        Naming the file: not JSON, no ``names`` list of strings, no ``frames`` of
        ``time`` and ``weights``, a frame whose weights are not one per name.
    """
    doc = read_json(path, what="a BEAT facial JSON (names, frames)")
    if not isinstance(doc, dict):
        raise DataError(f"{path}: expected a JSON object with 'names' and 'frames', got {type(doc).__name__}")
    names, frames = doc.get("names"), doc.get("frames")
    if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
        raise DataError(f"{path}: no 'names' list of blendshape names; BEAT's facial JSON lists the shapes of "
                        "its weights under 'names'")
    if not isinstance(frames, list) or not frames:
        raise DataError(f"{path}: no 'frames' list; expected frames of {{'time', 'weights'}}")
    weights, times = [], []
    for t, frame in enumerate(frames):
        if not isinstance(frame, dict) or "weights" not in frame or "time" not in frame:
            raise DataError(f"{path}: frame {t} is not an object with 'time' and 'weights'")
        row = frame["weights"]
        if not isinstance(row, list) or len(row) != len(names):
            raise DataError(f"{path}: frame {t} has {len(row) if isinstance(row, list) else 'no list of'} weights "
                            f"for {len(names)} names")
        weights.append(row)
        times.append(frame["time"])
    try:
        array = np.asarray(weights, dtype=np.float64)
        times = np.asarray(times, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise DataError(f"{path}: a weight or time that is not a number ({error})") from None
    return array, tuple(names), frame_rate(times, where=str(path))


def beat_takes(root) -> list[Take]:
    """The takes of a BEAT root with both a facial JSON and a WAV, in name order.

    Raises
    ------
    DatasetLayoutError
        ``root`` is not a folder, or holds no take in BEAT's layout (:data:`EXPECTED`).
    """
    root = Path(os.fspath(root)).expanduser()
    if not root.is_dir():
        raise DatasetLayoutError(f"--root {root}: not a folder; expected BEAT's layout: {EXPECTED}")
    takes = []
    for folder in sorted(p for p in root.iterdir() if p.is_dir() and p.name.isdigit()):
        for weights in sorted(folder.glob("*.json")):
            match = TAKE_NAME.match(weights.stem)
            wav = weights.with_suffix(".wav")
            if not match or match.group(1) != folder.name or not wav.is_file():
                continue
            takes.append(Take(
                subject=safe_name(f"{match.group(1)}_{match.group(2)}"), name=weights.stem,
                source=weights.relative_to(root).as_posix(),
                weights=lambda path=weights: read_beat_json(path),
                audio=lambda path=wav: (load_audio(path, rate=16000), 16000),
            ))
    if not takes:
        raise DatasetLayoutError(f"--root {root}: no BEAT take found; expected {EXPECTED}")
    return takes


#: The ``--dataset beat`` adapter (:data:`blendvoca.datasets.DATASETS`).
ADAPTER = coefficient_adapter(beat_takes, dataset="beat", title="BEAT", convention="beat")
