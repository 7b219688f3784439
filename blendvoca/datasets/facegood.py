"""The FACEGOOD adapter (``--dataset facegood [--root DIR]``): FACEGOOD-Audio2Face's captured takes.

Layout read (the files of FACEGOOD-Audio2Face's ``code/train``, as ``SOURCES.md`` of the
real-data folder lists them)::

    <root>/bs_value_<take>.npy   (T, 116) float rig controls in [0, 1], 30 fps
    <root>/<take>.wav            the take's speech (16 kHz mono)
    <root>/bs_names_1015.npy     the 116 control names, in the values' column order

The controls are FACEGOOD's own rig (:data:`blendvoca.names.FACEGOOD116`, the
``facegood116`` convention), not ARKit names: each take's controls are moved onto ARKit's
shapes by :func:`blendvoca.names.controls_to_arkit` (the map
:data:`blendvoca.names.FACEGOOD_TO_ARKIT`; what it leaves out, the tongue, teeth and eyes,
is listed by the build report). The corpus is one speaker; its splits are by take, each
take a subject of the folder (:data:`DEFAULT_SPLITS`). Without ``--root`` the seven takes
of the repository come through the asset resolver (:data:`ASSET_IDS`, the ids in
``data_manifest.yaml``). See ``docs/datasets.md``.
"""

from __future__ import annotations

import os
import re
import warnings
from pathlib import Path

import numpy as np

from blendvoca import format as fmt
from blendvoca.assets import resolve
from blendvoca.builder.report_takes import speech_tracks_figure, utterances_markdown
from blendvoca.datasets.coefficients import DatasetLayoutError, Take, coefficient_adapter, safe_name
from blendvoca.errors import DataError
from blendvoca.io.audio import load_audio
from blendvoca.io.npy_file import read_array
from blendvoca.names import FACEGOOD_TO_ARKIT, FACEGOOD_UNMAPPED, controls_to_arkit

#: The names file of the layout (FACEGOOD's ``shirley_1015_bs_name.npy``).
NAMES_FILE = "bs_names_1015.npy"
#: A take's values file: ``bs_value_<take>.npy``.
VALUES_FILE = re.compile(r"^bs_value_(?P<take>[A-Za-z0-9_.-]+)\.npy$")
#: FACEGOOD's capture rate (the repository's step1_LPC.py: 30 frames per second of audio).
FPS = 30.0
#: The speaker of every take (FACEGOOD's names file is ``shirley_...``).
SPEAKER = "shirley"
#: Values may stray this far outside [0, 1] (``-0.0`` and rounding) before a take is refused.
RANGE_TOLERANCE = 1e-6
#: Each take's split in the folder: the takes of session 2 to train (the last of them to
#: validate), the two shorter takes of session 3 to test.
DEFAULT_SPLITS: dict[str, str] = {
    "1114_2_01": "train", "1114_2_02": "train", "1114_2_03": "train", "1114_2_04": "train",
    "1114_2_05": "val", "1114_3_15": "test", "1114_3_16": "test",
}
EXPECTED = (f"<root>/bs_value_<take>.npy ((T, 116) rig controls in [0, 1] at 30 fps), <root>/<take>.wav and "
            f"<root>/{NAMES_FILE} (the 116 control names), e.g. bs_value_1114_2_01.npy and 1114_2_01.wav")


def _asset_ids() -> dict[str, str]:
    """Asset id -> file name of the corpus files ``data_manifest.yaml`` names."""
    ids = {"facegood-names": NAMES_FILE}
    for take in DEFAULT_SPLITS:
        short = take.replace("_", "-")
        ids[f"facegood-{short}-values"] = f"bs_value_{take}.npy"
        ids[f"facegood-{short}-wav"] = f"{take}.wav"
    return ids


#: Asset id (``data_manifest.yaml``) -> file name, for the build without ``--root``.
ASSET_IDS: dict[str, str] = _asset_ids()


def resolved_root() -> Path:
    """The folder holding FACEGOOD's files as the asset resolver finds them (each checked
    against its sha256): the corpus of a build without ``--root``.

    Raises
    ------
    AssetError
        A file missing or corrupted (the message says where to put it).
    DatasetLayoutError
        The files found in different folders.
    """
    paths = {asset_id: resolve(asset_id) for asset_id in ASSET_IDS}
    folders = sorted({str(p.parent) for p in paths.values()})
    if len(folders) != 1 or any(p.name != ASSET_IDS[i] for i, p in paths.items()):
        raise DatasetLayoutError(f"the FACEGOOD files resolve to several folders {folders}; put them in one "
                                 f"(the mirror paths facegood/... of data_manifest.yaml) or give --root: {EXPECTED}")
    return Path(folders[0])


def read_names(path) -> tuple[str, ...]:
    """The control names of a names file (a 1-D string array; Python 2's pickled files read too).

    Raises
    ------
    DataError
        Not a 1-D array of distinct strings (naming the file).
    """
    names = read_array(path, what="control names (strings)", kinds="US", encoding="latin1")
    if names.ndim != 1 or len(names) == 0:
        raise DataError(f"{path}: expected a 1-D array of control names (strings), got {names.dtype} "
                        f"of shape {names.shape}")
    names = tuple(n.decode("latin1") if isinstance(n, bytes) else str(n) for n in names.tolist())
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise DataError(f"{path}: control names repeated: {repeated[:5]}")
    return names


def read_values(path, names: tuple[str, ...], names_path) -> tuple[np.ndarray, tuple[str, ...], float]:
    """One take's controls as ARKit shapes: ``(weights (T, M), ARKit names (M,), 30.0)``.

    Raises
    ------
    DataError
        Naming the file: not a (T, K) array of numbers, K not the names file's count,
        a value not finite or outside [0, 1].
    """
    values = read_array(path, what=f"(T, {len(names)}) rig controls", encoding="latin1")
    if values.ndim != 2 or values.dtype.kind not in "fiu" or len(values) == 0:
        raise DataError(f"{path}: expected (T, {len(names)}) rig controls, got {values.dtype} of shape {values.shape}")
    if values.shape[1] != len(names):
        raise DataError(f"{path}: {values.shape[1]} columns, but {names_path} names {len(names)} controls; "
                        "expected one column per name")
    values = values.astype(np.float64)
    bad = ~np.isfinite(values)
    if bad.any():
        t, k = np.argwhere(bad)[0]
        raise DataError(f"{path}: value {values[t, k]} at frame {t}, control {names[k]!r}; expected finite "
                        "values in [0, 1]")
    outside = (values < -RANGE_TOLERANCE) | (values > 1 + RANGE_TOLERANCE)
    if outside.any():
        t, k = np.argwhere(outside)[0]
        raise DataError(f"{path}: value {values[t, k]:.6g} at frame {t}, control {names[k]!r} "
                        f"({int(outside.sum())} outside in all); expected rig controls in [0, 1]")
    try:
        track, arkit = controls_to_arkit(np.clip(values, 0.0, 1.0), names, "facegood116", where=str(path))
    except ValueError as error:  # a UserError: the names lack controls the map needs
        raise DataError(str(error)) from None
    return track, arkit, FPS


def facegood_takes(root) -> list[Take]:
    """The takes of a FACEGOOD root (every ``bs_value_<take>.npy``), in name order.

    A take without its WAV is kept: reading it fails, which the build reports as that
    take's failure (the others are built).

    Raises
    ------
    DatasetLayoutError
        ``root`` is not a folder, has no names file, or no values file (:data:`EXPECTED`).
    """
    root = Path(os.fspath(root)).expanduser() if root is not None else resolved_root()
    if not root.is_dir():
        raise DatasetLayoutError(f"--root {root}: not a folder; expected FACEGOOD's layout: {EXPECTED}")
    names_path = root / NAMES_FILE
    values = sorted(p for p in root.iterdir() if VALUES_FILE.match(p.name) and p.is_file())
    if not values:
        raise DatasetLayoutError(f"--root {root}: no bs_value_<take>.npy found; expected {EXPECTED}")
    if not names_path.is_file():
        raise DatasetLayoutError(f"--root {root}: no {NAMES_FILE} (the control names of the values' columns); "
                                 f"expected {EXPECTED}")
    names = read_names(names_path)
    takes = []
    for path in values:
        take = VALUES_FILE.match(path.name).group("take")
        wav = root / f"{take}.wav"
        takes.append(Take(
            subject=safe_name(take), name=take, source=path.name,
            weights=lambda path=path: read_values(path, names, names_path),
            audio=lambda wav=wav, path=path: _read_audio(wav, path),
            split=DEFAULT_SPLITS.get(take),
        ))
    return takes


def _read_audio(wav: Path, values: Path) -> tuple[np.ndarray, int]:
    """A take's speech at 16 kHz, or a DataError naming the WAV the take lacks."""
    if not wav.is_file():
        raise DataError(f"{wav}: no such file; the take {values.name} needs its speech as {wav.name} beside it")
    return load_audio(wav, rate=16000), 16000


#: A control "moves" in a take when its largest value there is at least this.
MOVES = 0.01
#: The figure of tracks against the speech envelope in the build report.
FIGURE = "speech_tracks.png"


def control_peaks(root) -> dict[str, np.ndarray]:
    """``{take: (K,) largest value of each control}`` of every take of ``root`` that reads."""
    root = Path(root)
    peaks = {}
    for path in sorted(p for p in root.iterdir() if VALUES_FILE.match(p.name)):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                values = np.load(path, allow_pickle=False)
        except (ValueError, OSError):
            continue
        if values.ndim == 2 and len(values) and values.dtype.kind in "fiu":
            peaks[VALUES_FILE.match(path.name).group("take")] = np.nanmax(values, axis=0)
    return peaks


def lost_markdown(root) -> str:
    """A markdown section: what FACEGOOD's controls carry that the map onto ARKit leaves out,
    and which controls (mapped or not) move in the takes built."""
    try:
        names = read_names(Path(root) / NAMES_FILE)
    except DataError:
        return ""
    peaks = {take: p for take, p in control_peaks(root).items() if len(p) == len(names)}
    moving = {n for k, n in enumerate(names) if any(p[k] >= MOVES for p in peaks.values())}
    groups: dict[str, list[str]] = {}
    for control, carries in FACEGOOD_UNMAPPED:
        groups.setdefault(carries, []).append(control)
    lines = ["## What the map onto ARKit keeps and loses", "",
             f"FACEGOOD's rig has {len(names)} controls; {len({c for m in FACEGOOD_TO_ARKIT for c, _ in m.terms})} "
             f"form {len(FACEGOOD_TO_ARKIT)} ARKit shapes (`blendvoca.names.FACEGOOD_TO_ARKIT`, docs/datasets.md). "
             f"A control moves when it reaches {MOVES} in a take; {len(moving)} move in the "
             f"{len(peaks)} takes read.", "",
             "| left out | controls | moving in these takes (largest value) |", "|---|---|---|"]
    for carries, controls in groups.items():
        moved = [f"{c} ({max(p[names.index(c)] for p in peaks.values()):.2f})" for c in controls if c in moving]
        lines.append(f"| {carries} | {len(controls)} | {', '.join(moved) or 'none'} |")
    lost = sorted(c for c, _ in FACEGOOD_UNMAPPED if c in moving)
    lines += ["", "Lost: " + (f"{', '.join(lost)} move but form no ARKit shape: ARKit has no teeth apart "
                              "from the jaw and no corrective shapes." if lost else "no moving control is left out.")
              + " The tongue and the eyes do not move in these takes; ARKit's tongueOut is not on the "
              "reference rig, and mouthClose has no FACEGOOD control (written as 0)."]
    return "\n".join(lines) + "\n"


def facegood_report(out, record: dict, splits: dict) -> tuple[list[str], list[str]]:
    """The FACEGOOD sections of the build report and its figure (``report/speech_tracks.png``):
    the utterances, what the map loses, and tracks of one utterance per split against the speech."""
    utterances = record["utterances"]
    sections = [utterances_markdown(utterances, splits), lost_markdown(record["root"])]
    items = []
    for name in ("train", "val", "test"):
        subjects = splits.get(name) or []
        keys = sorted(k for k in utterances if subjects and k.split("/")[0] == subjects[0])
        if keys:
            items.append(tuple(keys[len(keys) // 2].split("/")))
    if not items:
        return sections, []
    rel = f"{fmt.REPORT_DIR}/{FIGURE}"
    speech_tracks_figure(Path(out) / rel, out, items)
    sections.append("## Tracks against the speech\n\nA middle utterance of the first take of each split: "
                    "mapped ARKit tracks (left axis) and the speech energy (dB, dashed, right axis).\n\n"
                    f"![tracks against the speech envelope]({FIGURE})\n")
    return sections, [rel]


#: The ``--dataset facegood`` adapter (:data:`blendvoca.datasets.DATASETS`).
ADAPTER = coefficient_adapter(facegood_takes, dataset="facegood", title="FACEGOOD", convention="facegood116",
                              default_root=resolved_root, long_takes=True, report_sections=facegood_report)
