"""Reading and writing the items of a BlendVOCA folder: coefficient tracks, audio,
captured head poses, rigs (``.npz`` and SAiD's OBJ heads), ``coeffs_std.csv`` and ``splits.json``.

Each function takes the folder's root and the item's subject / sentence, finds
the file through :mod:`blendvoca.format.layout` and reads or writes it with
:mod:`blendvoca.io` (writes are atomic; folders are made as needed). Writers
return the relative path they wrote (the key ``manifest.json`` lists it under).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from blendvoca.errors import DataError
from blendvoca.io.atomic import atomic_write
from blendvoca.io.audio import load_audio, resample_audio, to_mono, write_wav
from blendvoca.io.coeffs import read_coeffs_csv, write_coeffs_csv
from blendvoca.io.json_file import read_json
from blendvoca.io.mesh import obj_face_records, write_obj
from blendvoca.rig import Rig

from .layout import (
    AUDIO_RATE,
    COEFFS_STD_FILE,
    POSE_COLUMNS,
    SPLITS_FILE,
    audio_path,
    audio_relpath,
    blendshape_relpath,
    blendshapes_dir,
    blendshapes_relpath,
    coeffs_relpath,
    oracle_coeffs_relpath,
    pose_path,
    pose_relpath,
    rig_path,
    rig_relpath,
    splits_path,
    template_path,
    template_relpath,
)

__all__ = [
    "read_audio",
    "read_coeffs",
    "read_coeffs_file",
    "read_oracle_coeffs",
    "read_pose",
    "read_rig",
    "read_said_rig",
    "read_splits",
    "write_audio",
    "write_coeffs",
    "write_coeffs_std",
    "write_oracle_coeffs",
    "write_pose",
    "write_rig",
    "write_said_rig",
    "write_splits",
]


# ----------------------------------------------------------------------------- coefficient tracks


def write_coeffs(root, subject: str, sentence: str, coeffs, names: Sequence[str], *,
                 sample: int | None = None) -> str:
    """Write a sentence's track (or its extra sample ``sample``) as SAiD's CSV; return its relative path.

    Parameters
    ----------
    coeffs : (T, K) array_like
        At 60 fps, any float dtype; written with 6 decimals.
    names : sequence of str
        The K column names.
    """
    rel = coeffs_relpath(subject, sentence, sample)
    write_coeffs_csv(Path(root) / rel, coeffs, names)
    return rel


def read_coeffs_file(root, relpath: str, *, names: Sequence[str] | None = None) -> tuple[np.ndarray, tuple]:
    """The coefficient CSV at ``relpath`` under ``root``.

    Returns
    -------
    coeffs : (T, K) float64 ndarray
        Columns in ``names`` order (default: the file's).
    names : tuple of str
    """
    return read_coeffs_csv(Path(root) / relpath, names=names)


def read_coeffs(root, subject: str, sentence: str, *, names: Sequence[str] | None = None,
                sample: int | None = None) -> tuple[np.ndarray, tuple]:
    """A sentence's track (or its extra sample ``sample``); see :func:`read_coeffs_file`."""
    return read_coeffs_file(root, coeffs_relpath(subject, sentence, sample), names=names)


def write_oracle_coeffs(root, subject: str, sentence: str, sample: int, coeffs, names: Sequence[str]) -> str:
    """Write a sentence's fitted oracle sample ``sample`` (0-based) as SAiD's CSV; return its relative path."""
    rel = oracle_coeffs_relpath(subject, sentence, sample)
    write_coeffs_csv(Path(root) / rel, coeffs, names)
    return rel


def read_oracle_coeffs(root, subject: str, sentence: str, sample: int, *,
                       names: Sequence[str] | None = None) -> tuple[np.ndarray, tuple]:
    """A sentence's fitted oracle sample ``sample``; see :func:`read_coeffs_file`."""
    return read_coeffs_file(root, oracle_coeffs_relpath(subject, sentence, sample), names=names)


def write_coeffs_std(root, std, names: Sequence[str]) -> str:
    """Write ``coeffs_std.csv`` as SAiD's asset: a header of names and one row (``%.4f``).

    Parameters
    ----------
    std : (K,) array_like
    names : sequence of str
    """
    with atomic_write(Path(root) / COEFFS_STD_FILE, "w", encoding="utf-8", newline="") as f:
        f.write(",".join(names) + "\n" + ",".join("%.4f" % v for v in std) + "\n")
    return COEFFS_STD_FILE


# ----------------------------------------------------------------------------- audio


def write_audio(root, subject: str, sentence: str, samples, rate: int) -> str:
    """Write a sentence's speech as 16-bit mono WAV at 16 kHz; return its relative path.

    Parameters
    ----------
    samples : (N,) or (N, C) array_like
        Float audio in [-1, 1] at ``rate`` Hz; channels are averaged, then resampled.
    rate : int
    """
    rel = audio_relpath(subject, sentence)
    write_wav(Path(root) / rel, resample_audio(to_mono(samples), rate, AUDIO_RATE), AUDIO_RATE)
    return rel


def read_audio(root, subject: str, sentence: str) -> tuple[np.ndarray, int]:
    """A sentence's speech: ``((N,) float32 mono, 16000)``."""
    return np.asarray(load_audio(audio_path(root, subject, sentence), rate=AUDIO_RATE), dtype=np.float32), AUDIO_RATE


# ----------------------------------------------------------------------------- captured head pose


def write_pose(root, subject: str, sentence: str, pose) -> str:
    """Write a sentence's captured head and eye rotations (``(T, 9)``, columns
    :data:`~blendvoca.format.layout.POSE_COLUMNS`, one row per frame of its track); return
    its relative path."""
    rel = pose_relpath(subject, sentence)
    write_coeffs_csv(Path(root) / rel, pose, POSE_COLUMNS)
    return rel


def read_pose(root, subject: str, sentence: str) -> np.ndarray:
    """A sentence's captured head and eye rotations, ``(T, 9)`` float64 in
    :data:`~blendvoca.format.layout.POSE_COLUMNS` order.

    Raises
    ------
    FileNotFoundError
        The sentence has no pose file.
    DataError
        A header other than the pose columns, or a value that is no number (naming the file).
    """
    path = pose_path(root, subject, sentence)
    lines = path.read_text(encoding="utf-8").splitlines()
    header = tuple(h.strip() for h in lines[0].split(",")) if lines else ()
    if header != POSE_COLUMNS:
        raise DataError(f"{path}: header {list(header)}; expected the pose columns {list(POSE_COLUMNS)}")
    try:
        return np.loadtxt(lines[1:], delimiter=",", ndmin=2, dtype=np.float64).reshape(-1, len(POSE_COLUMNS))
    except ValueError as error:
        raise DataError(f"{path}: {error}") from None


# ----------------------------------------------------------------------------- rigs


def write_rig(root, subject: str, rig) -> str:
    """Write the speaker's full-topology rig (:class:`blendvoca.rig.Rig`) as ``.npz``; return its relative path."""
    rel = rig_relpath(subject)
    rig.save(Path(root) / rel)
    return rel


def read_rig(root, subject: str):
    """The speaker's rig from ``rigs/<subject>.npz`` (:class:`blendvoca.rig.Rig`)."""
    return Rig.load(rig_path(root, subject))


def write_said_rig(root, subject: str, neutral, deltas, names: Sequence[str], faces) -> list[str]:
    """Write a rig in SAiD's layout: the neutral head and one head per blendshape (OBJ).

    Parameters
    ----------
    neutral : (V, 3) array_like
        The neutral head (``templates_head/<subject>.obj``).
    deltas : (K, V, 3) array_like
        Each blendshape's offset; ``blendshapes_head/<subject>/<name>.obj`` holds
        ``neutral + delta``.
    names : sequence of str
        The K blendshape names.
    faces : (F, 3) array_like of int
        Triangles of the head, shared by every file.

    Returns
    -------
    list of str
        The relative paths written: the template, then each blendshape in ``names`` order.
    """
    root = Path(root)
    neutral = np.asarray(neutral)
    face_records = obj_face_records(faces)  # one topology: the face records of every file
    files = [template_relpath(subject)]
    write_obj(root / files[0], neutral, faces, face_records=face_records)
    for name, delta in zip(names, deltas):
        rel = blendshape_relpath(subject, name)
        write_obj(root / rel, neutral + delta, faces, face_records=face_records)
        files.append(rel)
    return files


def read_said_rig(root, subject: str, names: Sequence[str]):
    """The speaker's rig from SAiD's layout: ``templates_head/<subject>.obj`` and
    ``blendshapes_head/<subject>/<name>.obj`` (:class:`blendvoca.rig.Rig`, ``names`` in order).

    Raises
    ------
    DataError
        Neither the template nor the blendshape folder is there.
    """
    root = Path(root)
    template = template_path(root, subject)
    shape_dir = blendshapes_dir(root, subject)
    if not template.exists() or not shape_dir.is_dir():
        raise DataError(f"read_said_rig: subject {subject!r} has neither {rig_relpath(subject)} nor "
                        f"{template_relpath(subject)} + {blendshapes_relpath(subject)}/ in {root}")
    return Rig.load_said_folder(shape_dir, names=tuple(names), neutral_path=template)


# ----------------------------------------------------------------------------- splits


def write_splits(root, splits: dict) -> str:
    """Write ``splits.json`` (split name -> subjects; sorted keys, so identical splits give identical bytes)."""
    with atomic_write(splits_path(root), "w", encoding="utf-8") as f:
        f.write(json.dumps(splits, indent=2, sort_keys=True) + "\n")
    return SPLITS_FILE


def read_splits(root) -> dict:
    """``splits.json``: split name -> list of subjects.

    Raises
    ------
    DataError
        Not readable JSON, or not an object of split name -> list of subject names.
    """
    path = splits_path(root)
    splits = read_json(path, what="readable JSON (an object of split -> subjects)")
    if not isinstance(splits, dict):
        raise DataError(f"{path}: expected an object of split -> subjects, got {type(splits).__name__}")
    for name, subjects in splits.items():
        if not isinstance(subjects, list) or not all(isinstance(s, str) for s in subjects):
            raise DataError(f"{path}: split {name!r} is not a list of subject names: {subjects!r:.80}")
    return splits
