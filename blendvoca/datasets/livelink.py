"""The Live Link Face adapter (``--dataset livelink --root DIR``): takes captured with Epic's iOS app.

Layouts read (a subject per take, named after it, as FACEGOOD's: the build splits by
take, so no take is in two splits; fewer than 3 takes all go to the test split)::

    <root>/<take>.csv + <root>/<take>.wav           a take and the WAV its user exported beside it
    <root>/<take>.csv + <root>/<take>.mov | .mp4    a take and its video, whose sound is decoded (PyAV)
    <root>/<YYYYMMDD>_<slate>_<n>/                  the app's export, a folder per take:
        <slate>_<n>_<device>.mov                    the take's video with its sound
        <slate>_<n>_<device>_raw.csv                ARKit's weights (read)
        <slate>_<n>_<device>_cal.csv                the same after the app's calibration (read without a _raw)
        <slate>_<n>_<device>_neutral.csv            the calibration's neutral pose (not a take; not read)
        take.json, video_metadata.json, thumbnail   (not read)

A take's CSV and its sound share a stem (``_raw``/``_cal`` left off); a WAV beside the
CSV wins over the video. Every other CSV of the root and of its folders is a take. The
app's zipped exports (``LiveLinkFace_<date>_<slate>_<n>_<device>.zip``) are to be
unzipped first. Each take is read by :func:`blendvoca.io.livelink.read_livelink_take`
(the rate from the timecodes), resampled to 60 fps, with its head and eye rotations
written to ``pose/<subject>/<sentence>.csv``; a take whose sound and motion differ by
more than 5 %, or shorter than :data:`MIN_TAKE_SECONDS`, fails alone. See ``docs/datasets.md``.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path

from blendvoca.datasets.coefficients import DatasetLayoutError, Take, coefficient_adapter, safe_name
from blendvoca.errors import DataError
from blendvoca.io.audio import load_audio
from blendvoca.io.livelink import read_livelink_take

#: The shortest take built, in seconds of motion.
MIN_TAKE_SECONDS = 1.0
#: Suffixes of a take's sound, in the order they are looked for.
SOUND_SUFFIXES = (".wav", ".mov", ".mp4")
#: A take's CSV variants in the app's export, in the order they are preferred (plain: a CSV of its own).
CSV_VARIANTS = ("_raw", "", "_cal")
EXPECTED = ("<root>/<take>.csv (Live Link Face's CSV: Timecode, BlendShapeCount, the 52 ARKit shapes, the 9 "
            "rotations) with <take>.wav, <take>.mov or <take>.mp4 beside it, or the app's export of a folder per "
            "take (<root>/<date>_<slate>_<n>/<slate>_<n>_<device>_raw.csv and <slate>_<n>_<device>.mov)")


def _variant(csv: Path) -> tuple[str, int]:
    """The take's stem of a CSV (``_raw``/``_cal`` left off) and the variant's rank in :data:`CSV_VARIANTS`."""
    stem = csv.stem
    for rank, suffix in enumerate(CSV_VARIANTS):
        if suffix and stem.lower().endswith(suffix):
            return stem[: -len(suffix)], rank
    return stem, CSV_VARIANTS.index("")


def _sound(folder: Path, stems: list[str]) -> Path | None:
    """The take's sound in ``folder``: a file named like one of ``stems`` with a suffix of
    :data:`SOUND_SUFFIXES` (any case), the earlier suffix first."""
    files = {p.name.lower(): p for p in folder.iterdir() if p.is_file()}
    for suffix in SOUND_SUFFIXES:
        for stem in stems:
            if (stem + suffix).lower() in files:
                return files[(stem + suffix).lower()]
    return None


def _take_csvs(folder: Path) -> dict[str, Path]:
    """``{take stem: CSV}`` of a folder: every CSV but the neutral pose's, the preferred variant of each take."""
    chosen: dict[str, tuple[int, Path]] = {}
    for csv in sorted(folder.iterdir()):
        if not csv.is_file() or csv.suffix.lower() != ".csv" or csv.name.startswith("."):
            continue
        if csv.stem.lower().endswith("_neutral"):
            continue
        stem, rank = _variant(csv)
        if stem not in chosen or rank < chosen[stem][0]:
            chosen[stem] = (rank, csv)
    return {stem: csv for stem, (_, csv) in chosen.items()}


def read_take(csv: Path):
    """The reader of one take: ``() -> LiveLinkTake``, read once (weights and pose share it).

    Raises
    ------
    DataError
        (when called) The take's own errors, and a take shorter than :data:`MIN_TAKE_SECONDS`.
    """

    @functools.cache
    def read():
        take = read_livelink_take(csv)
        seconds = len(take.weights) / take.fps
        if seconds < MIN_TAKE_SECONDS:
            raise DataError(f"{csv}: a take of {seconds:.2f} s ({len(take.weights)} frames at {take.fps:.2f} fps) is "
                            f"too short; expected at least {MIN_TAKE_SECONDS:g} s of motion")
        return take

    return read


def _audio(csv: Path, sound: Path | None, stem: str):
    """``() -> (samples, 16000)`` of the take's sound, or a DataError naming what was looked for."""
    if sound is None:
        def missing():
            raise DataError(f"{csv}: no sound for the take; expected {', '.join(stem + s for s in SOUND_SUFFIXES)} "
                            "beside it (the WAV exported with it, or the take's video)")
        return missing
    return lambda: (load_audio(sound, rate=16000), 16000)


def livelink_takes(root) -> list[Take]:
    """The takes of a folder of Live Link Face takes (:data:`EXPECTED`), in path order; a
    take without sound is listed (it fails in the build, naming what was looked for).

    Raises
    ------
    DatasetLayoutError
        ``root`` is not a folder, or holds no take CSV in it or its folders.
    """
    root = Path(os.fspath(root)).expanduser()
    if not root.is_dir():
        raise DatasetLayoutError(f"--root {root}: not a folder; expected {EXPECTED}")
    folders = [root] + sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith("."))
    takes = []
    for folder in folders:
        for stem, csv in _take_csvs(folder).items():
            reader = read_take(csv)
            name = (csv.parent / stem).relative_to(root).as_posix()
            takes.append(Take(
                subject=safe_name(name.replace("/", "_")), name=name,
                source=csv.relative_to(root).as_posix(),
                weights=lambda read=reader: (read().weights, read().names, read().fps),
                audio=_audio(csv, _sound(folder, [stem, csv.stem]), stem),
                pose=lambda read=reader: None if read().pose is None else (read().pose, read().fps),
                durations="fail",
            ))
    if not takes:
        zips = sorted(p.name for p in root.glob("*.zip"))
        hint = f"; unzip the app's exports first ({', '.join(zips[:3])})" if zips else ""
        raise DatasetLayoutError(f"--root {root}: no Live Link Face take found; expected {EXPECTED}{hint}")
    return takes


#: The ``--dataset livelink`` adapter (:data:`blendvoca.datasets.DATASETS`).
ADAPTER = coefficient_adapter(livelink_takes, dataset="livelink", title="Live Link Face", convention="livelink")
