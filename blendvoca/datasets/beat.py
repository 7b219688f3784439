"""The BEAT adapter (``--dataset beat --root DIR``): ARKit weights captured on an iPhone, 60 fps.

Layout read (BEAT's release, e.g. ``beat_english_v0.2.1/``; PantoMatrix's loader
``dataloaders/beat.py`` pairs a take's files by name)::

    <root>/<speaker id>/<speaker id>_<name>_<type>_<a>_<b>.json   facial weights
    <root>/<speaker id>/<speaker id>_<name>_<type>_<a>_<b>.wav    speech

Each JSON holds ``names`` (the ARKit shapes of its columns) and ``frames``, a
list of ``{"time": seconds, "weights": [one per name]}``; the other files of a
take (``.bvh``, ``.TextGrid``, ``.txt``) are not read. The speaker is
``<speaker id>_<name>`` (``1_wayne``), its folder :func:`~blendvoca.datasets.coefficients.folder_name`
of that (a name with a non-ASCII letter or digit is kept, encoded). Every JSON of a speaker folder
is a take: one without its WAV, or whose name is not in BEAT's form, fails alone (the build counts
it). See ``docs/datasets.md``.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from blendvoca.datasets.coefficients import DatasetLayoutError, Take, coefficient_adapter, folder_name, frame_rate
from blendvoca.errors import DataError
from blendvoca.io.audio import load_audio
from blendvoca.io.json_file import read_json

#: A take's file name: speaker id, speaker name (letters, any script), then the take's numbers.
TAKE_NAME = re.compile(r"^(\d+)_([^\W\d_]+)_\w+$")
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
        if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in row + [frame["time"]]):
            raise DataError(f"{path}: frame {t}: a weight or its time is not a number")
        weights.append(row)
        times.append(frame["time"])
    try:
        array = np.asarray(weights, dtype=np.float64)
        times = np.asarray(times, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as error:
        raise DataError(f"{path}: a weight or time that is not a number ({error})") from None
    return array, tuple(names), frame_rate(times, where=str(path))


def _refused(error: str):
    """A take's reader that fails with ``error`` (a take the build must count, not skip)."""
    def read():
        raise DataError(error)
    return read


def _read_audio(wav: Path, weights: Path) -> tuple[np.ndarray, int]:
    """A take's speech at 16 kHz, or a DataError naming the WAV the take lacks."""
    if not wav.is_file():
        raise DataError(f"{wav}: no such file; the take {weights.name} needs its speech as {wav.name} beside it")
    return load_audio(wav, rate=16000), 16000


def beat_takes(root) -> list[Take]:
    """The takes of a BEAT root: every facial JSON of a speaker folder, in name order (one
    without its WAV or with a name not in BEAT's form is listed, and fails when read).

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
        files = sorted(folder.glob("*.json"))
        matches = {path: TAKE_NAME.match(path.stem) for path in files}
        speakers = {f"{m.group(1)}_{m.group(2)}" for m in matches.values() if m and m.group(1) == folder.name}
        for weights, match in matches.items():
            source = weights.relative_to(root).as_posix()
            wav = weights.with_suffix(".wav")
            if match and match.group(1) == folder.name:
                speaker = f"{match.group(1)}_{match.group(2)}"
                read = lambda path=weights: read_beat_json(path)  # noqa: E731
            else:  # counted as the folder's speaker's failure (the folder's name when it has none or several)
                speaker = next(iter(speakers)) if len(speakers) == 1 else folder.name
                read = _refused(f"{weights}: not a BEAT take name (a space, or an id other than its folder's "
                                f"{folder.name}); expected {EXPECTED}")
            takes.append(Take(
                subject=folder_name(speaker), name=weights.stem, source=source, weights=read,
                audio=lambda path=wav, json_path=weights: _read_audio(path, json_path), speaker=speaker,
            ))
    if not takes:
        raise DatasetLayoutError(f"--root {root}: no BEAT take found; expected {EXPECTED}")
    return takes


#: The ``--dataset beat`` adapter (:data:`blendvoca.datasets.DATASETS`).
ADAPTER = coefficient_adapter(beat_takes, dataset="beat", title="BEAT", convention="beat")
