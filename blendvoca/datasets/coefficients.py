"""Coefficient corpora (ARKit weights captured or solved per frame) as BlendVOCA folders.

A coefficient corpus needs no rig retargeting and no fit: each take's weights are
read, moved to ARKit's names by :func:`blendvoca.names.remap`, resampled to the
build's 60 fps by :func:`blendvoca.fit.resample.resample_sequence` and written,
with the take's speech, in the layout of :mod:`blendvoca.format`. What differs
between corpora (where the files are, how a take's weights and sound are read) is
an adapter's list of :class:`Take`; :func:`build_coefficient_dataset` does the rest.

What the folder holds, per speaker: ``blendshape_coeffs/<subject>/sentenceNN.csv``
(the corpus's shapes in ARKit's order, plus any of BlendVOCA's 32 speech shapes it
lacks as 0 with a warning), ``audio/<subject>/sentenceNN.wav`` and
``rigs/<subject>.npz``, the ARKit reference rig (51 shapes): these corpora have no
meshes, so every speaker is rendered through the one reference head (rig space
only). A take that carries its head and eye rotations (``Take.pose``) has them in
``pose/<subject>/sentenceNN.csv``, resampled and cut as its weights. ``splits.json``
splits by speaker (a corpus of fewer than 3 puts them all in
test, and says so); ``manifest.json`` records the dataset (``dataset``: name, title,
kind, the source file of every sentence).

A take longer than an utterance (10 s) is cut at its pauses into utterances of 2-10 s
(:mod:`blendvoca.datasets.utterances`), or where the user's cut list (``--cuts FILE``)
says; each utterance is a sentence, numbered on from the subject's previous take, and
the dataset record's ``utterances`` (:func:`blendvoca.format.utterance_record`) say
which take and which seconds of it each sentence is. A corpus of long takes
(``long_takes``, FACEGOOD) also fails a take shorter than one utterance (2 s).
"""

from __future__ import annotations

import re
import time
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from blendvoca import format as fmt
from blendvoca.assets import resolve
from blendvoca.builder.outdir import build_lock, check_output_dir, claim_output_dir, remove_own_outputs, unwritable
from blendvoca.builder.pipeline import BuildInputError, BuildSummary
from blendvoca.builder.report import coeffs_std
from blendvoca.builder.report_takes import utterances_markdown
from blendvoca.datasets import DatasetAdapter
from blendvoca.datasets.utterances import check_cut_list, read_cut_list, take_spans
from blendvoca.errors import BlendVOCAError, DataError, UserError
from blendvoca.fit.resample import resample_sequence
from blendvoca.format.manifest import write_dataset_manifest
from blendvoca.io.atomic import atomic_write
from blendvoca.names import ARKIT_FACE_ORDER, BLENDVOCA_NAMES, MissingShapesWarning, arkit_name, remap
from blendvoca.rig import load_arkit_reference
from blendvoca.runtime.progress import bar
from blendvoca.vocaset.splits import proportional_split

#: Audio and motion durations further apart than this share are reported (as the mesh build does).
DURATION_TOLERANCE = 0.05
#: ``dataset.kind`` of a coefficient corpus in the manifest: no source meshes.
KIND = "coefficients"
#: Weights may stray this far outside the convention's range [0, 1] (capture noise: ARKit's solver
#: and its exporters round to 1e-6 and overshoot by a few 1e-4) and are then kept as captured (not
#: clipped, so a corpus within range builds the same folder as before); further out, or not finite,
#: the take fails naming the file, frame and column.
RANGE_TOLERANCE = 1e-3
#: The frame rates a take may have (frames per second): a capture's rate is 24-240, UniTalker's
#: 25-60; outside this range the times or the rate are wrong (microseconds or milliseconds read as
#: seconds) and resampling them would make a take of a handful of frames or of millions.
FPS_RANGE = (10.0, 1000.0)
#: A take shorter than this (seconds of audio or motion, after cutting to the shorter) fails: it
#: holds less than a syllable.
MIN_TAKE_S = 0.25


class DatasetLayoutError(UserError):
    """A ``--root`` that is not in the layout the dataset's adapter reads; names the expected files."""


@dataclass(frozen=True)
class Take:
    """One take (sentence) of a coefficient corpus, read on demand.

    Attributes
    ----------
    subject : str
        The speaker, as the folder will name it (letters, digits, ``_ . -``).
    name : str
        The take's name in the corpus.
    source : str
        Its coefficient file, relative to the corpus root (recorded in the manifest).
    weights : callable () -> (coeffs (T, K), names (K,), fps)
        The take's weights, their ARKit names (any case) and frame rate.
    audio : callable () -> (samples (N,), rate)
    split : str, optional
        The corpus's own split of the take, if it has one.
    speaker : str, optional
        The speaker's name in the corpus, when ``subject`` is its :func:`folder_name` (recorded
        in the manifest's ``dataset.speakers``; two names never share a folder).
    pose : callable () -> (pose (T, 9), fps) or None, optional
        The capture's head and eye rotations (:data:`blendvoca.format.POSE_COLUMNS`), one
        row per row of ``weights``; written to ``pose/`` beside the track.
    durations : {"warn", "fail"}
        Audio and motion longer than each other by more than :data:`DURATION_TOLERANCE`:
        both cut to the shorter and reported (``"warn"``), or the take fails.
    """

    subject: str
    name: str
    source: str
    weights: Callable[[], tuple]
    audio: Callable[[], tuple]
    split: str | None = None
    pose: Callable[[], tuple] | None = None
    durations: str = "warn"
    speaker: str | None = None


def safe_name(text: str) -> str:
    """``text`` with every character but letters, digits, ``_``, ``.`` and ``-`` replaced by ``_``
    (and no leading dot): a name the layout can use for a folder or a file."""
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", str(text).strip()) or "_"
    return "_" + name[1:] if name.startswith(".") else name


#: The characters a folder name keeps as they are; any other is written ``~HH`` per UTF-8 byte.
_PLAIN = re.compile(r"[A-Za-z0-9_.-]")


def folder_name(text: str) -> str:
    """``text`` as a folder or file name: letters, digits, ``_``, ``.`` and ``-`` kept, every other
    character (a space, a non-ASCII letter or digit, ``~``, ``/``) and a leading dot written as
    ``~HH`` per byte of its UTF-8 (``spk a`` -> ``spk~20a``, ``说`` -> ``~E8~AF~B4``), the empty
    name as ``~``.

    Injective: ``~`` is never kept, so it always starts an escape and the name decodes back;
    two different names never share a folder. Plain names (``1_wayne``) are unchanged.
    """
    text = str(text)
    if not text:
        return "~"
    out = []
    for k, char in enumerate(text):
        if _PLAIN.fullmatch(char) and not (k == 0 and char == "."):
            out.append(char)
        else:
            out.append("".join(f"~{b:02X}" for b in char.encode("utf-8", "surrogatepass")))
    return "".join(out)


def check_frame_rate(fps, *, where: str) -> float:
    """``fps`` as a float when it is a plausible frame rate (:data:`FPS_RANGE`), else a DataError
    naming ``where`` (checked before resampling: a rate of 1e6 or 0.001 is times in the wrong unit)."""
    try:
        fps = float(fps)
    except (TypeError, ValueError, OverflowError):
        raise DataError(f"{where}: frame rate {fps!r} is not a number; expected {FPS_RANGE[0]:g} to "
                        f"{FPS_RANGE[1]:g} fps") from None
    if not (FPS_RANGE[0] <= fps <= FPS_RANGE[1]):
        raise DataError(f"{where}: a frame rate of {fps:g} fps; expected {FPS_RANGE[0]:g} to {FPS_RANGE[1]:g} fps "
                        "(a capture's rate: are the frame times in seconds?)")
    return fps


def frame_rate(times, *, where: str) -> float:
    """Frames per second of a track from its frame times (seconds).

    The rate over the whole track, ``(T - 1) / (t_last - t_first)``, snapped to the
    nearest whole number when within 0.1 % of it: capture apps store times rounded
    (to the microsecond, or to timecode frames), which would otherwise turn 60 fps
    into 59.999 and make the resampling blend neighbouring frames.

    Raises
    ------
    DataError
        Fewer than two times, times that do not increase, or a rate outside
        :data:`FPS_RANGE` (naming ``where``).
    """
    times = np.asarray(times, dtype=np.float64)
    if times.ndim != 1 or len(times) < 2:
        raise DataError(f"{where}: need at least 2 frame times to tell the frame rate, got {times.shape}")
    steps = np.diff(times)
    if not np.all(np.isfinite(steps)) or np.any(steps <= 0):
        t = int(np.argmax(~np.isfinite(steps) | (steps <= 0)))
        raise DataError(f"{where}: frame times do not increase (frame {t + 1}: {times[t + 1]} after {times[t]})")
    with np.errstate(over="ignore"):
        fps = (len(times) - 1) / (times[-1] - times[0])
    if not np.isfinite(fps) or fps <= 0:
        raise DataError(f"{where}: frame times {times[0]} to {times[-1]} give no frame rate")
    fps = float(round(fps)) if abs(fps - round(fps)) <= 1e-3 * fps else float(fps)
    return check_frame_rate(fps, where=where)


def build_columns(names) -> tuple[str, ...]:
    """The columns a take is written with: its shapes and BlendVOCA's 32, in ARKit's order."""
    have = set(names) | set(BLENDVOCA_NAMES)
    return tuple(n for n in ARKIT_FACE_ORDER if n in have)


def take_track(coeffs, names, fps: float, *, where: str) -> tuple[np.ndarray, tuple[str, ...], list[str]]:
    """A take's weights as the build writes them: ARKit order, 60 fps.

    Parameters
    ----------
    coeffs : (T, K) array_like
    names : K ARKit names (any case)
    fps : float
        The take's frame rate.
    where : str
        What the take is, for messages.

    Returns
    -------
    track : (T', K') float64 ndarray at :data:`blendvoca.format.FPS`
    columns : K' names (:func:`build_columns`)
    notes : list of str
        The speech shapes the take lacks (written as 0), if any.
    """
    coeffs = np.asarray(coeffs, dtype=np.float64)
    if coeffs.ndim != 2 or len(coeffs) == 0:
        raise DataError(f"{where}: expected (T, K) weights with T >= 1, got shape {coeffs.shape}")
    fps = check_frame_rate(fps, where=where)
    with np.errstate(invalid="ignore"):
        outside = ~np.isfinite(coeffs) | (coeffs < -RANGE_TOLERANCE) | (coeffs > 1 + RANGE_TOLERANCE)
    if outside.any():
        t, k = (int(i) for i in np.argwhere(outside)[0])
        column = repr(str(names[k])) if len(names) == coeffs.shape[1] else k
        raise DataError(f"{where}: weight {coeffs[t, k]:g} at frame {t}, column {column} ({int(outside.sum())} "
                        f"outside in all); expected finite weights in [0, 1] (up to {RANGE_TOLERANCE:g} of capture "
                        "noise)")
    try:
        canonical = tuple(arkit_name(n) or str(n) for n in names)
        columns = build_columns(canonical)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", MissingShapesWarning)
            track = remap(coeffs, canonical, columns, missing="zero")
    except UserError as error:  # names that are not ARKit's, or as many as the weights
        raise DataError(f"{where}: {error}") from None
    notes = [str(w.message) for w in caught if issubclass(w.category, MissingShapesWarning)]
    return resample_sequence(track, fps, fmt.FPS), columns, notes


def take_pose(take: Take, frames: int, *, where: str) -> np.ndarray | None:
    """A take's head and eye rotations as the build writes them: ``(frames, 9)`` at
    :data:`blendvoca.format.FPS`, resampled as its weights are; None for a take without."""
    got = None if take.pose is None else take.pose()
    if got is None:
        return None
    pose, fps = got
    pose = np.asarray(pose, dtype=np.float64)
    if pose.ndim != 2 or pose.shape[1] != len(fmt.POSE_COLUMNS) or len(pose) == 0:
        raise DataError(f"{where}: expected (T, {len(fmt.POSE_COLUMNS)}) head and eye rotations, got shape {pose.shape}")
    if not np.all(np.isfinite(pose)):
        raise DataError(f"{where}: NaN/inf rotation at frame {int(np.argwhere(~np.isfinite(pose))[0][0])}")
    return resample_sequence(pose, fps, fmt.FPS)[:frames]


def check_durations(take: Take, seconds_audio: float, seconds_motion: float, *, where: str) -> str | None:
    """The warning for audio and motion of a take whose lengths differ by more than
    :data:`DURATION_TOLERANCE` (both are then cut to the shorter), None when they agree.

    Raises
    ------
    DataError
        They differ and the take's ``durations`` is ``"fail"``.
    """
    if abs(seconds_audio - seconds_motion) <= DURATION_TOLERANCE * max(seconds_audio, seconds_motion):
        return None
    if take.durations == "fail":
        raise DataError(f"{where}: audio {seconds_audio:.2f} s and motion {seconds_motion:.2f} s differ by more than "
                        f"{DURATION_TOLERANCE:.0%}; expected the take's audio and motion to cover the same time")
    return f"audio {seconds_audio:.2f} s and motion {seconds_motion:.2f} s differ; both were cut to the shorter"


def subject_splits(subjects: list[str]) -> dict:
    """A split by speaker of sorted ``subjects`` in VOCASET's proportions
    (:func:`blendvoca.vocaset.splits.proportional_split`: a sixth each to val and test).

    Raises
    ------
    BuildInputError
        Fewer than 3 speakers (each split needs one).
    """
    subjects = sorted(subjects)
    if len(subjects) < 3:
        raise BuildInputError(f"the corpus has {len(subjects)} speaker(s) {subjects}; a BlendVOCA folder splits by "
                              "speaker into train, val and test, which needs at least 3")
    return proportional_split(subjects)


def corpus_splits(takes: list[Take]) -> tuple[dict, str]:
    """The corpus's own split when it is by speaker, else :func:`subject_splits`.

    Returns
    -------
    splits : dict
        ``{"train": [...], "val": [...], "test": [...]}`` of subjects.
    note : str
        The split rule that was applied, and why (the build's warning and its report say it).
    """
    subjects = sorted({t.subject for t in takes})
    if len(subjects) < 3:
        return {"train": [], "val": [], "test": subjects}, (
            f"split: the corpus has {len(subjects)} speaker(s) or take(s) ({', '.join(subjects)}), fewer than the 3 "
            "splits: all are in the test split (nothing to train or validate on)")
    declared = {}
    for take in takes:
        if take.split is not None:
            declared.setdefault(take.subject, set()).add(take.split)
    if declared and len(declared) == len(subjects) and all(len(v) == 1 for v in declared.values()):
        splits = {name: sorted(s for s, v in declared.items() if name in v) for name in ("train", "val", "test")}
        if all(splits.values()) and set().union(*declared.values()) <= set(splits):
            return splits, "split: the corpus's own split, which is by speaker, is kept"
    if declared and len(declared) == len(subjects) and all(len(v) == 1 for v in declared.values()):
        note = ("split: the corpus's own split of these takes leaves a split empty: they are split a sixth each to "
                "val and test (sorted by name)")
    elif declared and all(len(v) == 1 for v in declared.values()):
        note = (f"split: the corpus's own split names {len(declared)} of the {len(subjects)} speakers or takes: "
                "all are split a sixth each to val and test (sorted by name)")
    elif declared:
        note = ("split: the corpus splits by sentence (a speaker's takes in several splits), a BlendVOCA folder by "
                "speaker: the speakers are split a sixth each to val and test (sorted by name)")
    else:
        note = ("split: the corpus has no split of its own: its speakers are split in VOCASET's proportions, "
                "a sixth each to val and test (sorted by name)")
    return subject_splits(subjects), note


def sentence_names(takes: list[Take]) -> dict:
    """``{(subject, take name): "sentenceNN"}``: each speaker's takes numbered from 1 in
    name order (two digits, more when a speaker has over 99)."""
    by_subject: dict[str, list[str]] = {}
    for take in takes:
        by_subject.setdefault(take.subject, []).append(take.name)
    out = {}
    for subject, names in by_subject.items():
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise DataError(f"{subject}: takes named alike: {repeated[:5]}")
        width = max(2, len(str(len(names))))
        for k, name in enumerate(sorted(names), start=1):
            out[(subject, name)] = f"sentence{k:0{width}d}"
    return out


def _previous_files(out: Path, dataset: str) -> dict[str, str]:
    """``{relative path: sha256}`` of the data files a previous build of ``dataset`` into ``out``
    listed (to remove those no longer built: :func:`blendvoca.builder.outdir.remove_own_outputs`
    removes only those under ``out`` whose sha256 is still the listed one)."""
    try:
        manifest = fmt.read_manifest(out)
    except (DataError, OSError):
        return {}
    files = manifest.get("files")
    if (manifest.get("dataset") or {}).get("name") != dataset or not isinstance(files, dict):
        return {}
    return {rel: sha for rel, sha in files.items() if isinstance(rel, str) and isinstance(sha, str)}


def speaker_names(takes: list[Take]) -> dict[str, str]:
    """``{folder: the corpus's speaker name}`` of the subjects whose folder name is not the name.

    Raises
    ------
    DataError
        Two different speaker names given one folder (an adapter's names that are not injective).
    """
    names: dict[str, str] = {}
    for take in takes:
        speaker = take.speaker if take.speaker is not None else take.subject
        if names.setdefault(take.subject, speaker) != speaker:
            raise DataError(f"speakers {names[take.subject]!r} and {speaker!r} would share the folder "
                            f"{take.subject!r}; expected one folder per speaker")
    return {subject: name for subject, name in sorted(names.items()) if subject != name}


#: The data-format version of coefficient builds (part of their recipe id): change it when
#: what the adapters write from the same corpus changes.
#: coeffs2: takes longer than 10 s are cut into utterances (blendvoca.datasets.utterances).
COEFFICIENT_FORMAT = "coeffs2"


def coefficient_recipe(root: Path, dataset: str, cuts: dict | None = None) -> dict:
    """The recipe of building ``dataset`` from the corpus at ``root``: every corpus file, the
    adapter, the frame rate, the user's cut list if any and the reference rig every speaker gets
    (:func:`blendvoca.format.make_recipe`)."""
    parameters = {"dataset": dataset, "fps": fmt.FPS}
    if cuts is not None:
        parameters["cuts"] = {take: list(times) for take, times in sorted(cuts.items())}
    return fmt.make_recipe(fmt.corpus_files(root), parameters, root=root,
                           assets={"arkit-reference-rig": fmt.file_digest(resolve("arkit-reference-rig"))},
                           format_version=COEFFICIENT_FORMAT)


def _report(out: Path, dataset: dict, summary: BuildSummary, splits: dict, notes: list[str],
            sections: list[str] = ()) -> str:
    """``report/README.md`` of a coefficient build; returns its relative path."""
    lines = [f"# {dataset['title']} as a BlendVOCA folder", "",
             f"Built by `python -m blendvoca.build --dataset {dataset['name']}` from `{dataset['root']}`: "
             f"{summary.built['sentences']} sentences of {summary.built['speakers']} speakers, weights moved to "
             f"ARKit's names ({dataset['convention']} convention) and resampled to {fmt.FPS} fps. No source "
             "meshes: vertex metrics are scored through the ARKit reference rig (rig space) only.", "",
             "| split | speakers |", "|---|---|"]
    lines += [f"| {name} | {', '.join(subjects)} |" for name, subjects in splits.items()]
    if notes or summary.warnings:
        lines += ["", "## Notes", ""] + [f"- {n}" for n in notes]
        lines += [f"- {w['subject']} {w['sentence'] or ''}: {w['message']}" for w in summary.warnings]
    if summary.failures:
        lines += ["", "## Failed", ""] + [f"- {f['subject']} {f['sentence'] or ''}: {f['reason']}"
                                         for f in summary.failures]
    for section in sections:
        lines += ["", section.rstrip("\n")]
    rel = f"{fmt.REPORT_DIR}/README.md"
    (out / fmt.REPORT_DIR).mkdir(exist_ok=True)
    with atomic_write(out / rel, "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")
    return rel


def build_coefficient_dataset(out, root, takes: Iterable[Take], *, dataset: str, title: str, convention: str,
                              report: bool = True, cuts=None, long_takes: bool = False,
                              report_sections: Callable | None = None) -> BuildSummary:
    """Write the BlendVOCA folder of a coefficient corpus.

    Parameters
    ----------
    out : path
        The folder to write (new, empty, or a previous build).
    root : path
        The corpus (recorded in the manifest; ``out`` may not be inside it).
    takes : iterable of Take
        What the adapter found; none is read before the output folder is accepted.
    dataset, title : str
        The registry name (``beat``) and the name tables show (``BEAT``).
    convention : str
        The corpus's naming convention (:mod:`blendvoca.names`), for the record.
    report : bool
        Write ``report/README.md``.
    cuts : path, optional
        The user's cut list (:func:`blendvoca.datasets.utterances.read_cut_list`): where to cut
        the takes it names, instead of at the pauses found.
    long_takes : bool
        The corpus is of long takes: one shorter than an utterance (2 s) fails.
    report_sections : callable (out, dataset record, splits) -> (sections, files), optional
        More sections of the report (markdown) and the files they show (written under
        ``report/``, relative paths), from the corpus's adapter; the record is the manifest's
        ``dataset`` (``root``, ``sources``, ``utterances``, ...).

    Returns
    -------
    BuildSummary
        ``built`` counts speakers and sentences; a take that cannot be read is a
        failure (``stage`` ``"input"``), the others are built.

    Raises
    ------
    BlendVOCAError
        Before any work: an unusable ``out`` (``OutputDirError``), takes named alike, a
        cut list that cannot be read or names a take the corpus lacks (``CutListError``).
    """
    started = time.perf_counter()
    out, root = Path(out).expanduser().resolve(), Path(root).expanduser().resolve()
    takes = sorted(takes, key=lambda t: (t.subject, t.name))
    user_cuts = None
    if cuts is not None:
        user_cuts = read_cut_list(cuts)
        check_cut_list(user_cuts, [t.name for t in takes], path=cuts)
    check_output_dir(out, root)
    splits, split_note = corpus_splits(takes)
    sentence_names(takes)  # takes named alike are refused before any work
    speakers = speaker_names(takes)
    previous = _previous_files(out, dataset)
    recipe = coefficient_recipe(root, dataset, user_cuts)  # the identity, known before any output is written
    claim_output_dir(out)
    summary = BuildSummary(out=out)
    notes = [split_note]
    with build_lock(out):
        fmt.remove_manifest(out)
        files, tracks, sources, built_subjects, utterances, counts = [], [], {}, set(), {}, {}
        for take in bar(takes, desc=f"{dataset} takes", leave=False):
            sentence = None
            where = f"{root / take.source}"
            try:
                coeffs, names, fps = take.weights()
                track, columns, missing = take_track(coeffs, names, fps, where=where)
                samples, rate = take.audio()
                samples = np.asarray(samples, dtype=np.float32)
                seconds_audio, seconds_motion = len(samples) / float(rate), len(track) / fmt.FPS
                if seconds_audio <= 0:
                    raise DataError(f"{where}: the take's audio is empty")
                if min(seconds_audio, seconds_motion) < MIN_TAKE_S:
                    raise DataError(f"{where}: audio of {seconds_audio:.3g} s and {seconds_motion:.2f} s of motion: "
                                    f"too short; expected a take of at least {MIN_TAKE_S:g} s of both")
                # the frames the audio covers, to within half a sample (a resampled WAV is rounded to a sample)
                frames = min(len(track), int(np.floor(seconds_audio * fmt.FPS + 0.5 * fmt.FPS / rate + 1e-9)))
                mismatch = check_durations(take, seconds_audio, seconds_motion, where=where)
                if mismatch is None and frames < len(track):  # within the tolerance, yet frames go: said, never silent
                    mismatch = (f"take {take.name}: {len(track) - frames} motion frame(s) after the audio's end "
                                f"({seconds_audio:.3f} s) were cut ({len(track)} -> {frames} frames)")
                track, samples = track[:frames], samples[: int(round(frames / fmt.FPS * rate))]
                if frames < 1:
                    raise DataError(f"{where}: shorter than one frame at {fmt.FPS} fps")
                pose = take_pose(take, frames, where=where)
                spans = take_spans(track, samples, int(rate), fmt.FPS, where=where, long_take=long_takes,
                                   cuts_s=None if user_cuts is None else user_cuts.get(take.name))
                if mismatch:
                    summary.warnings.append({"subject": take.subject, "sentence": sentence, "message": mismatch})
            except (BlendVOCAError, OSError, ValueError, KeyError, TypeError) as error:
                summary.failures.append({"subject": take.subject, "sentence": sentence, "stage": "input",
                                         "reason": f"{take.source}: {error}"})
                continue
            for message in missing:
                summary.warnings.append({"subject": take.subject, "sentence": None, "message": message})
            for span in spans:
                counts[take.subject] = counts.get(take.subject, 0) + 1
                sentence = f"sentence{counts[take.subject]:02d}"
                piece = track[span.start:span.end]
                sound = samples[int(round(span.start / fmt.FPS * rate)): int(round(span.end / fmt.FPS * rate))]
                try:
                    files.append(fmt.write_coeffs(out, take.subject, sentence, piece, columns))
                    files.append(fmt.write_audio(out, take.subject, sentence, sound, int(rate)))
                    if pose is not None:
                        files.append(fmt.write_pose(out, take.subject, sentence, pose[span.start:span.end]))
                except OSError as error:
                    raise unwritable(error, out) from None
                tracks.append(remap(piece, columns, BLENDVOCA_NAMES, missing="refuse"))
                sources[f"{take.subject}/{sentence}"] = take.source
                utterances[f"{take.subject}/{sentence}"] = fmt.utterance_record(
                    take.name, span.start, span.end, fmt.FPS, cut=span.cut)
                summary.built["sentences"] += 1
            built_subjects.add(take.subject)
        if not tracks:
            raise DataError(f"{root}: no take of the {title} corpus could be read: "
                            + "; ".join(f["reason"] for f in summary.failures[:3]))
        if built_subjects != {t.subject for t in takes}:  # split what was built (a failed take leaves no hole)
            built_takes = [t for t in takes if t.subject in built_subjects]
            splits, split_note = corpus_splits(built_takes)
            notes[0] = f"{split_note} (over the {len(built_subjects)} speakers or takes built; see the failures)"
        all_test = len(built_subjects) < 3  # corpus_splits put every one in test
        if not splits["test"] or not (all_test or all(splits.values())):
            raise DataError(f"{root}: after the takes that failed, a split has no speaker left ({splits}); "
                            "see the failures: " + "; ".join(f["reason"] for f in summary.failures[:3]))
        reference = load_arkit_reference("all")
        try:
            for subject in sorted(built_subjects):
                files.append(fmt.write_rig(out, subject, reference))
            files.append(fmt.write_coeffs_std(out, coeffs_std(tracks), BLENDVOCA_NAMES))
            files.append(fmt.write_splits(out, splits))
        except OSError as error:
            raise unwritable(error, out) from None
        summary.built["speakers"] = len(built_subjects)
        record = {"name": dataset, "title": title, "kind": KIND, "meshes": False, "convention": convention,
                  "root": str(root), "fps": fmt.FPS, "sources": dict(sorted(sources.items())),
                  "utterances": dict(sorted(utterances.items())),
                  "cuts": str(Path(cuts).expanduser().resolve()) if cuts is not None else "pauses"}
        if speakers:
            record["speakers"] = {s: n for s, n in speakers.items() if s in built_subjects}
        if report:
            sections, written = report_sections(out, record, splits) if report_sections else ([], [])
            if report_sections is None and any(u["cut"] != "end" for u in utterances.values()):
                sections.append(utterances_markdown(utterances, splits))
            files += written
            files.append(_report(out, record, summary, splits, notes, sections))
        remove_own_outputs(out, {"files": {rel: sha for rel, sha in previous.items() if rel not in set(files)}})
        write_dataset_manifest(out, files=files, dataset=record, failures=summary.failures,
                               params={"dataset": dataset, "fps": fmt.FPS, "report": bool(report)}, recipe=recipe)
    summary.warnings[:0] = [{"subject": "", "sentence": None, "message": n} for n in notes]
    summary.seconds["total"] = time.perf_counter() - started
    return summary


def coefficient_adapter(read_takes: Callable, *, dataset: str, title: str, convention: str,
                        default_root: Callable | None = None, long_takes: bool = False,
                        report_sections: Callable | None = None) -> DatasetAdapter:
    """The adapter of a coefficient corpus: ``read_takes(root)`` finds its takes, then
    :func:`build_coefficient_dataset` writes them (``workers``, ``shapes`` and ``delta``
    do not apply: nothing is fitted, every shape of the corpus is kept). It declares the
    option ``cuts`` (``--cuts FILE``, a cut list). ``default_root()``, when given, is the
    corpus of a build without ``--root`` (``root=None``); ``long_takes`` and
    ``report_sections`` are passed to :func:`build_coefficient_dataset`."""

    def build(root, out, *, workers: int | None = None, shapes: str = "speech", delta: float = 0.1,
              report: bool = True, cuts=None) -> BuildSummary:
        if root is None and default_root is not None:
            root = default_root()
        return build_coefficient_dataset(out, root, read_takes(root), dataset=dataset, title=title,
                                         convention=convention, report=report, cuts=cuts, long_takes=long_takes,
                                         report_sections=report_sections)

    return DatasetAdapter(build, options=("cuts",), default_root=default_root)
