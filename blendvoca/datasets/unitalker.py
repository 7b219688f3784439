"""The UniTalker adapter (``--dataset unitalker --root DIR``): its D6/D7 corpora, 51 ARKit weights.

Layout read (UniTalker's processed release, ``unitalker_data_release/<corpus>/``,
as its ``dataset/dataset.py`` and ``dataset/data_item.py`` read it)::

    <root>/train.json, val.json, test.json   {"info": {"id_list": [speaker, ...]},
                                               "data": [{"annot_path", "audio_path", "id",
                                                         "annot_type", "dataset", "fps"}, ...]}
    <root>/<annot_path>                       (T, 51) float .npy, columns in UniTalker's order
    <root>/<audio_path>                       .wav, or a .npy of 16 kHz samples

Paths in the JSON are relative to ``<root>`` and must stay under it (an absolute
path, ``../`` or a link leading out is refused, naming the entry: what a build reads is
what its recipe id hashes). Only items of the corpus's annotation type are read
(``inhouse_blendshape_weight`` for D6/D7); the speaker is ``id_list[id]`` (an id that is
not an index of the list is refused), its folder the name's
:func:`~blendvoca.datasets.coefficients.folder_name` (non-ASCII names kept, never merged). The same layout carries 3D-ETF in UniTalker's release
(:mod:`blendvoca.datasets.etf3d`). See ``docs/datasets.md``.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path

import numpy as np

from blendvoca.datasets.coefficients import DatasetLayoutError, Take, coefficient_adapter, folder_name
from blendvoca.errors import DataError
from blendvoca.io.audio import load_audio
from blendvoca.io.json_file import read_json
from blendvoca.io.npy_file import read_array
from blendvoca.names import convention_names

SPLIT_FILES = ("train.json", "val.json", "test.json")
#: ``annot_type`` of UniTalker's ARKit corpora D6 and D7.
ANNOT_TYPE = "inhouse_blendshape_weight"


def expected_layout(annot_type: str, width: int) -> str:
    """The files a root in UniTalker's layout holds, for messages."""
    return (f"<root>/train.json, val.json or test.json ({{'info': {{'id_list': [...]}}, 'data': [{{'annot_path', "
            f"'audio_path', 'id', 'annot_type': '{annot_type}', 'fps'}}, ...]}}) and the (T, {width}) .npy weights "
            "and .wav (or 16 kHz .npy) audio they name, relative to <root>")


def _load_npy(path: Path, what: str) -> np.ndarray:
    """The numeric array of a .npy file (:func:`blendvoca.io.npy_file.read_array`)."""
    return read_array(path, what=what)


def read_audio(path: Path) -> tuple[np.ndarray, int]:
    """One item's speech ``(samples, 16000)``: a WAV, or UniTalker's .npy of 16 kHz samples."""
    if path.suffix.lower() == ".npy":
        samples = _load_npy(path, "audio samples")
        if samples.ndim != 1:
            raise DataError(f"{path}: expected (N,) audio samples at 16 kHz, got shape {samples.shape}")
        return samples.astype(np.float32), 16000
    return load_audio(path, rate=16000), 16000


def read_weights(path: Path, names: tuple[str, ...], fps: float) -> tuple[np.ndarray, tuple[str, ...], float]:
    """One item's weights ``(weights (T, len(names)), names, fps)`` from its .npy."""
    weights = _load_npy(path, "weights")
    if weights.ndim != 2 or weights.shape[1] != len(names):
        raise DataError(f"{path}: expected (T, {len(names)}) weights, got shape {weights.shape}")
    return weights, names, fps


def _inside(root: Path, path: Path, k: int, key: str, value) -> Path:
    """``root / value`` when ``value`` names a file under ``root``, else a DataError naming the entry."""
    where = f"{path}: data[{k}].{key}"
    if not isinstance(value, str) or not value or "\x00" in value:
        raise DataError(f"{where} is {value!r}; expected a path relative to --root {root}")
    if os.path.isabs(value):
        raise DataError(f"{where} {value!r} is absolute; expected a path relative to --root {root} (a build reads "
                        "only the corpus under --root)")
    target = root / value
    try:
        resolved = target.resolve()
    except (OSError, RuntimeError) as error:  # a loop of links
        raise DataError(f"{where} {value!r} cannot be resolved ({error}); expected a file under --root {root}") from None
    try:
        rel = resolved.relative_to(root.resolve())
    except ValueError:
        raise DataError(f"{where} {value!r} leaves --root {root} (resolved: {resolved}); expected a file of "
                        "the corpus under --root") from None
    if not rel.parts:
        raise DataError(f"{where} {value!r} names --root itself; expected a file of the corpus under it")
    if any(part.startswith(".") for part in rel.parts):
        raise DataError(f"{where} {value!r} names a hidden file; expected a file of the corpus under --root {root}")
    return target


def _speaker_list(doc, path: Path, expected: str) -> list[str]:
    """A split file's ``info.id_list``: distinct speaker names (a DataError naming the file otherwise)."""
    try:
        speakers = doc["info"]["id_list"]
        items = doc["data"]
        if not isinstance(speakers, list) or not isinstance(items, list):
            raise TypeError("info.id_list and data must be lists")
    except (KeyError, TypeError) as error:
        raise DataError(f"{path}: not UniTalker's split JSON ({error}); expected {expected}") from None
    first: dict[str, int] = {}
    for k, name in enumerate(speakers):
        if not isinstance(name, str):
            raise DataError(f"{path}: info.id_list[{k}] is {name!r}; expected speaker names (strings)")
        if first.setdefault(name, k) != k:
            raise DataError(f"{path}: info.id_list names {name!r} twice (ids {first[name]} and {k}); expected each "
                            "speaker once")
    return speakers


def _speaker(item: dict, speakers: list[str], path: Path, k: int) -> str:
    """The speaker ``id_list[id]`` of an item, refusing an id that is not an index of the list."""
    ident = item["id"]
    whole = (isinstance(ident, int) or (isinstance(ident, float) and ident.is_integer())) and not isinstance(ident, bool)
    if not whole or not 0 <= ident < len(speakers):
        raise DataError(f"{path}: data[{k}] has id {ident!r}; expected an index into info.id_list "
                        f"(0 to {len(speakers) - 1}: {len(speakers)} speakers)")
    return speakers[int(ident)]


def unitalker_layout_takes(root, *, annot_type: str, convention: str) -> list[Take]:
    """The items of a root in UniTalker's layout whose ``annot_type`` is ``annot_type``.

    Parameters
    ----------
    root : path
    annot_type : str
        The annotation type to read (``inhouse_blendshape_weight``, ``3DETF_blendshape_weight``).
    convention : str
        The names of the weights' columns (:mod:`blendvoca.names`).

    Raises
    ------
    DatasetLayoutError
        ``root`` holds none of the split files, or no item of ``annot_type`` (naming the expected files).
    DataError
        A split file that is not UniTalker's JSON (naming the file and the entry).
    """
    root = Path(os.fspath(root)).expanduser()
    names = convention_names(convention)
    expected = expected_layout(annot_type, len(names))
    if not root.is_dir():
        raise DatasetLayoutError(f"--root {root}: not a folder; expected {expected}")
    present = [root / name for name in SPLIT_FILES if (root / name).is_file()]
    if not present:
        raise DatasetLayoutError(f"--root {root}: none of {', '.join(SPLIT_FILES)}; expected {expected}")
    takes, seen = [], set()
    for path in present:
        doc = read_json(path, what="UniTalker's split JSON (info, data)")
        speakers = _speaker_list(doc, path, expected)
        for k, item in enumerate(doc["data"]):
            try:
                if item["annot_type"] != annot_type:
                    continue
                annot = _inside(root, path, k, "annot_path", item["annot_path"])
                audio = _inside(root, path, k, "audio_path", item["audio_path"])
                speaker = _speaker(item, speakers, path, k)
                fps = float(item["fps"])
                name = Path(item["annot_path"]).with_suffix("").as_posix()
            except DataError:
                raise
            except (KeyError, TypeError, ValueError, IndexError, OverflowError) as error:
                raise DataError(f"{path}: data[{k}] is not a UniTalker item "
                                f"({type(error).__name__}: {error})") from None
            subject = folder_name(speaker)
            if (subject, name) in seen:
                continue
            seen.add((subject, name))
            takes.append(Take(subject=subject, name=name, source=Path(item["annot_path"]).as_posix(),
                              weights=functools.partial(read_weights, annot, names, fps),
                              audio=functools.partial(read_audio, audio),
                              split=path.stem, speaker=speaker))
    if not takes:
        raise DatasetLayoutError(f"--root {root}: no item of annot_type {annot_type!r} in "
                                 f"{', '.join(p.name for p in present)}; expected {expected}")
    return takes


#: The ``--dataset unitalker`` adapter (:data:`blendvoca.datasets.DATASETS`): D6/D7.
ADAPTER = coefficient_adapter(functools.partial(unitalker_layout_takes, annot_type=ANNOT_TYPE, convention="unitalker51"),
                              dataset="unitalker", title="UniTalker (D6/D7)", convention="unitalker51")
